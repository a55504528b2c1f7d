//! The compact `.pm` form (version 3): what comes back, and its size per split against the
//! format's targets (docs/pm-format.md), on procedural and shared meshes.

use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{Placement, SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};

mod common;
use common::assert_compact_round_trip;

fn progressive(mesh: &Mesh, ratio: f64, placement: Placement) -> meshlod_engine::pm::ProgressiveMesh {
    let options =
        SimplifyOptions { target_ratio: Some(ratio), record_progressive: true, placement, ..Default::default() };
    simplify(mesh, &options).unwrap().progressive.unwrap()
}

#[test]
fn positions_only_levels_come_back_on_the_grid_within_16_bytes_a_split() {
    let mut meshes: Vec<(String, Mesh)> = vec![("icosphere".into(), procedural::icosphere(5))];
    if meshlod_engine::datasets::require_shared_meshes("pm_compact").is_some() {
        for name in ["stanford-bunny", "cow", "fandisk"] {
            let path = meshlod_engine::datasets::shared_mesh(name).expect("a shared mesh");
            meshes.push((name.into(), read_mesh(path).unwrap()));
        }
    }
    for (name, mesh) in &meshes {
        for placement in [Placement::Optimal, Placement::Endpoint] {
            let pm = progressive(mesh, 0.99, placement);
            let per_split = assert_compact_round_trip(name, &pm);
            let lossless = meshlod_engine::pm_format::encode_lossless(&pm).len() as f64 / pm.levels() as f64;
            println!("{name} {placement:?}: {per_split:.1} B per split (lossless {lossless:.1})");
            assert!(per_split <= 16.0, "{name} {placement:?}: {per_split:.1} B per split");
        }
    }
}

/// A latitude–longitude sphere whose poles take one texture coordinate per face, as UV spheres
/// come from most tools (and capsule.obj of ../shared/textured): `segments` values at one vertex.
fn uv_sphere(rings: u32, segments: u32) -> Mesh {
    use std::f64::consts::PI;
    let mut positions = vec![[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    let ring = |r: u32, s: u32| 2 + (r - 1) * segments + s % segments;
    for r in 1..rings {
        let theta = PI * r as f64 / rings as f64;
        for s in 0..segments {
            let phi = 2.0 * PI * s as f64 / segments as f64;
            let p = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            positions.push(p.map(|c| c as f32));
        }
    }
    let (mut triangles, mut uvs) = (Vec::new(), Vec::new());
    let uv = |r: u32, s: u32| [s as f32 / segments as f32, 1.0 - r as f32 / rings as f32];
    for s in 0..segments {
        // The poles: each face's pole corner at its own u.
        triangles.push([0, ring(1, s), ring(1, s + 1)]);
        uvs.extend([[(s as f32 + 0.5) / segments as f32, 1.0], uv(1, s), uv(1, s + 1)]);
        triangles.push([1, ring(rings - 1, s + 1), ring(rings - 1, s)]);
        uvs.extend([[(s as f32 + 0.5) / segments as f32, 0.0], uv(rings - 1, s + 1), uv(rings - 1, s)]);
        for r in 1..rings - 1 {
            let [a, b, c, d] = [ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1)];
            let [ua, ub, uc, ud] = [uv(r, s), uv(r + 1, s), uv(r + 1, s + 1), uv(r, s + 1)];
            triangles.extend([[a, b, c], [a, c, d]]);
            uvs.extend([ua, ub, uc, ua, uc, ud]);
        }
    }
    let mut mesh = Mesh::new(positions, triangles).unwrap();
    mesh.corners.set_uvs(Some(uvs));
    mesh
}

#[test]
fn a_vertex_with_more_values_than_one_field_holds_comes_back() {
    // 96 values at each pole: a corner's place among them is a unary count past 64 bits.
    let mesh = uv_sphere(24, 96);
    mesh.check().unwrap();
    for ratio in [0.5, 0.99] {
        let pm = progressive(&mesh, ratio, Placement::Endpoint);
        assert!(pm.has_attributes());
        assert_compact_round_trip(&format!("uv sphere at {ratio}"), &pm);
    }
}
