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
