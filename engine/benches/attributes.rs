//! Attribute-carrying simplification beside meshoptimizer's attribute-aware simplifier
//! (`meshopt::simplify_with_attributes_and_locks`), on every shared textured asset and spot, to 10%
//! of the faces. meshlod runs first (default options: w = 0, attributes carried, seams kept);
//! meshoptimizer then gets meshlod's face count as its target, with the same vertices split where
//! their attributes differ (as a GPU buffer holds them) and weights 1 for texture coordinates,
//! 0.5 for normals. Where meshoptimizer stops above that count (no collapse left that its rules
//! allow), meshlod runs again with meshoptimizer's count as its target, so that the two are
//! compared at equal face counts; both are timed asked for that count. Error: the certified symmetric Hausdorff distance of the positions to the input
//! (paper units) for both; then the appearance error ([`meshlod_engine::appearance`]): texture-space
//! distance to the input's values at the nearest input point on the same chart (and, beside it,
//! of any chart), in texels of a 1024² texture, and normal deviation in degrees, over 20 000 points spread over each result by
//! area; and the faces whose texture-space triangle turns over against the input's. Times: one thread, interleaved, best of 15. Then the same count with the attribute
//! quadrics and with `--prune`; last, meshlod's result written as GLB with floats and quantized
//! (`--quantize`): bytes, and how far quantizing moved the surface.
//!
//! Run: `cargo bench -p meshlod-engine --bench attributes`.

#[allow(unsafe_code, dead_code)]
#[path = "support/mod.rs"]
mod common;

use std::path::PathBuf;

use common::best_of_interleaved;
use meshlod_engine::Mesh;
use meshlod_engine::appearance::{Spread, appearance_error};
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::{MeshFormat, ReadLimits, WriteOptions, read_mesh, read_mesh_bytes, write_gltf_with};
use meshlod_engine::simplify::{AttributeWeights, Simplified, SimplifyOptions, simplify};

/// Timed calls per side, interleaved, best taken (as the simplify bench: with 5 a ratio moved by
/// more between runs than the changes it measures).
const RUNS: usize = 15;

/// The attribute quadrics' weights measured beside the default.
const WEIGHTED: AttributeWeights = AttributeWeights { uv: 0.3, normal: 0.0, color: 0.0 };

/// meshoptimizer's input: `mesh`'s vertices split where their attributes differ, with the
/// attribute stream and weights (built once, outside the timed call, as a GPU pipeline has them).
struct PeerInput {
    positions: Vec<[f32; 3]>,
    bytes: Vec<u8>,
    indices: Vec<u32>,
    attributes: Vec<f32>,
    weights: Vec<f32>,
    lock: Vec<bool>,
}

fn peer_input(mesh: &Mesh) -> PeerInput {
    let wedges = mesh.corners.wedges(&mesh.triangles, mesh.vertex_count());
    let count = wedges.source.len();
    let positions: Vec<[f32; 3]> = (0..count).map(|i| mesh.positions[wedges.vertex(&mesh.triangles, i)]).collect();
    let bytes = positions.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let (mut attributes, mut weights) = (Vec::new(), Vec::new());
    let c = &mesh.corners;
    if c.uvs().is_some() {
        weights.extend([1.0, 1.0]);
    }
    if c.normals().is_some() {
        weights.extend([0.5; 3]);
    }
    for &k in &wedges.source {
        attributes.extend(c.uvs().into_iter().flat_map(|u| u[k]));
        attributes.extend(c.normals().into_iter().flat_map(|n| n[k]));
    }
    if weights.is_empty() {
        attributes = vec![0.0; count];
        weights = vec![0.0];
    }
    PeerInput { positions, bytes, indices: wedges.corner_vertex, attributes, weights, lock: vec![false; count] }
}

/// meshoptimizer's attribute-aware simplifier to `target` faces: the result's indices.
fn peer(input: &PeerInput, target: usize) -> Vec<u32> {
    let adapter = meshopt::VertexDataAdapter::new(&input.bytes, 12, 0).expect("valid vertex data");
    // (meshopt's output keeps a subset of the split vertices: their values are the input's.)
    meshopt::simplify_with_attributes_and_locks(
        &input.indices,
        &adapter,
        &input.attributes,
        &input.weights,
        input.weights.len() * 4,
        &input.lock,
        target * 3,
        f32::MAX,
        meshopt::SimplifyOptions::None,
        None,
    )
}

fn main() {
    let Some(textured) = meshlod_engine::datasets::shared_textured_dir() else {
        eprintln!("!!! shared textured assets not found (set MESHLOD_TEXTURED) !!!");
        std::process::exit(1);
    };
    let manifest = std::fs::read_to_string(textured.join("MANIFEST.tsv")).expect("manifest");
    let mut assets: Vec<PathBuf> =
        manifest.lines().skip(1).filter_map(|l| l.split('\t').next()).map(|f| textured.join(f)).collect();
    assets.extend(meshlod_engine::datasets::shared_mesh("spot"));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    println!(
        "| asset | attributes | faces in | meshlod at 10% (target) | meshopt at that count | compared at | meshlod error | meshopt error | error ratio | meshlod time | meshopt time | time ratio |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let mut appearance_rows = Vec::new();
    let mut term_rows = Vec::new();
    let mut size_rows = Vec::new();
    let mut prune_rows = Vec::new();
    for path in assets {
        let mesh = read_mesh(&path).expect("reads");
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("?");
        let first = SimplifyOptions { target_ratio: Some(0.9), ..Default::default() };
        let input = peer_input(&mesh);
        let reached = simplify(&mesh, &first).expect("simplifies").mesh.face_count();
        let peer_reached = peer(&input, reached).len() / 3;
        // Equal face counts: meshlod again at meshoptimizer's count where that is higher. Both
        // are timed asked for that count (where meshlod stopped above its own target, asking it
        // for that target again would time the passes that find nothing more, which meshoptimizer,
        // asked for the count it reached, is not timed on).
        let target = reached.max(peer_reached);
        let options = SimplifyOptions { target_ratio: None, target_faces: Some(target), ..first.clone() };
        let ((ours, t_ours), (indices, t_theirs)) = pool.install(|| {
            best_of_interleaved(RUNS, || simplify(&mesh, &options).expect("simplifies"), || peer(&input, target))
        });
        let triangles = indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mut theirs = Mesh::new(input.positions.clone(), triangles).expect("meshopt's output is a mesh");
        // Its corners' values: the split vertices' attribute stream (uv first, then normal).
        let stride = input.weights.len();
        let has_uv = mesh.corners.uvs().is_some();
        let uv_at = |i: u32| [input.attributes[i as usize * stride], input.attributes[i as usize * stride + 1]];
        let normal_offset = if has_uv { 2 } else { 0 };
        let normal_at = |i: u32| {
            let k = i as usize * stride + normal_offset;
            [input.attributes[k], input.attributes[k + 1], input.attributes[k + 2]]
        };
        if has_uv {
            theirs.corners.set_uvs(Some(indices.iter().map(|&i| uv_at(i)).collect()));
        }
        if mesh.corners.normals().is_some() {
            theirs.corners.set_normals(Some(indices.iter().map(|&i| normal_at(i)).collect()));
        }
        let look = |m: &Mesh| appearance_error(&mesh, m, 20_000, 1024.0, 1).expect("measures");
        let (a_ours, a_theirs) = (look(&ours.mesh), look(&theirs));
        let cell = |x: Option<Spread>, pick: fn(&Spread) -> f64| {
            x.as_ref().map_or("–".to_string(), |s| format!("{:.2}", pick(s)))
        };
        let count = |x: Option<usize>| x.map_or("–".to_string(), |n| n.to_string());
        appearance_rows.push(format!(
            "| {} | {} / {} | {} / {} | {} / {} | {} / {} | {} / {} | {} / {} | {} / {} |",
            name,
            cell(a_ours.uv_texels, |s| s.mean),
            cell(a_theirs.uv_texels, |s| s.mean),
            cell(a_ours.uv_texels, |s| s.p95),
            cell(a_theirs.uv_texels, |s| s.p95),
            cell(a_ours.uv_texels_any_chart, |s| s.mean),
            cell(a_theirs.uv_texels_any_chart, |s| s.mean),
            cell(a_ours.uv_texels_any_chart, |s| s.p95),
            cell(a_theirs.uv_texels_any_chart, |s| s.p95),
            cell(a_ours.normal_degrees, |s| s.mean),
            cell(a_theirs.normal_degrees, |s| s.mean),
            cell(a_ours.normal_degrees, |s| s.p95),
            cell(a_theirs.normal_degrees, |s| s.p95),
            count(a_ours.uv_turned_over),
            count(a_theirs.uv_turned_over),
        ));
        let error = |m: &Mesh| hausdorff(&mesh, m, &HausdorffOptions::default()).expect("measures").hausdorff;
        let (e_ours, e_theirs) = (error(&ours.mesh), error(&theirs));
        // Other options at the same count, beside the same meshoptimizer result: the result, its
        // time over meshoptimizer's (timed interleaved with it again) and its appearance error.
        let variant = |o: &SimplifyOptions| {
            let ((out, t), (_, t_peer)) = pool.install(|| {
                best_of_interleaved(RUNS, || simplify(&mesh, o).expect("simplifies"), || peer(&input, target))
            });
            let a = look(&out.mesh);
            (out, t / t_peer, a)
        };
        // Each variant's row starts with the asset, its faces, and its position error and time
        // over meshoptimizer's.
        let lead = |out: &Simplified, time: f64| {
            format!("| {name} | {} | {:.2} | {:.2} |", out.mesh.face_count(), error(&out.mesh) / e_theirs, time)
        };
        // The attribute quadrics on (`--attribute-weights uv=0.3`).
        let (term, term_time, a_term) =
            variant(&SimplifyOptions { attribute_weights: Some(WEIGHTED), ..options.clone() });
        term_rows.push(format!(
            "{} {} / {} | {} / {} |",
            lead(&term, term_time),
            cell(a_term.uv_texels, |s| s.mean),
            cell(a_ours.uv_texels, |s| s.mean),
            cell(a_term.normal_degrees, |s| s.mean),
            cell(a_ours.normal_degrees, |s| s.mean),
        ));
        // `--prune`: parts taken out whole once the error reaches their size.
        let (pruned, prune_time, a_pruned) = variant(&SimplifyOptions { prune: true, ..options.clone() });
        prune_rows.push(format!(
            "{} {} | {} / {} | {} / {} |",
            lead(&pruned, prune_time),
            pruned.stats.parts_removed,
            cell(a_pruned.uv_texels, |s| s.mean),
            cell(a_theirs.uv_texels, |s| s.mean),
            cell(a_pruned.uv_texels, |s| s.p95),
            cell(a_theirs.uv_texels, |s| s.p95),
        ));
        size_rows.push(quantized_row(&path, &ours.mesh));
        println!(
            "| {} | {} | {} | {} ({}) | {} | {} / {} | {:.5} | {:.5} | {:.2} | {:.1} ms | {:.1} ms | {:.2} |",
            name,
            mesh.corners.names().join(", "),
            mesh.face_count(),
            reached,
            first.face_target_for(&mesh),
            peer_reached,
            ours.mesh.face_count(),
            theirs.face_count(),
            e_ours,
            e_theirs,
            e_ours / e_theirs,
            t_ours * 1e3,
            t_theirs * 1e3,
            t_ours / t_theirs,
        );
    }
    println!(
        "\n| asset | uv mean, texels, same chart (meshlod / meshopt) | uv p95, same chart | uv mean, any chart | uv p95, any chart | normal mean, degrees | normal p95, degrees | texture triangles turned over |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|"
    );
    for row in appearance_rows {
        println!("{row}");
    }
    println!(
        "\n| asset (attribute quadrics, uv = 0.3) | faces | position error ÷ meshopt's | time ÷ meshopt's | uv mean, texels (quadrics / default) | normal mean, degrees (quadrics / default) |\n\
         |---|---:|---:|---:|---:|---:|"
    );
    for row in term_rows {
        println!("{row}");
    }
    println!(
        "\n| asset (`--prune`) | faces | position error ÷ meshopt's | time ÷ meshopt's | parts taken out | uv mean, texels (prune / meshopt) | uv p95 |\n\
         |---|---:|---:|---:|---:|---:|---:|"
    );
    for row in prune_rows {
        println!("{row}");
    }
    println!(
        "\n| asset (meshlod at 10%, GLB) | vertex bytes, floats → quantized | file bytes, floats → quantized | position moved (certified Hausdorff, paper units) |\n\
         |---|---:|---:|---:|"
    );
    for row in size_rows {
        println!("{row}");
    }
}

/// The GLB of `lod` with floats and quantized (`--quantize`): its vertex bytes, its file bytes,
/// and how far quantizing moved the surface.
fn quantized_row(path: &std::path::Path, lod: &Mesh) -> String {
    let folder = std::env::temp_dir();
    let write = |quantize: bool| {
        let mut bytes = Vec::new();
        let options = WriteOptions { quantize };
        write_gltf_with(&mut bytes, lod, true, Some(&folder), &options).expect("writes");
        let length = u32::from_le_bytes(bytes[12..16].try_into().expect("a GLB")) as usize;
        let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + length]).expect("its JSON");
        let views = json["bufferViews"].as_array().expect("views").iter();
        let vertex: u64 = views.filter(|v| v["target"] == 34962).filter_map(|v| v["byteLength"].as_u64()).sum();
        let mesh = read_mesh_bytes(&bytes, Some(MeshFormat::Gltf), path, &ReadLimits::default()).expect("reads back");
        (vertex, bytes.len(), mesh)
    };
    let ((v_float, f_float, float), (v_quantized, f_quantized, quantized)) = (write(false), write(true));
    let moved = hausdorff(&float, &quantized, &HausdorffOptions::default()).expect("measures").hausdorff;
    format!(
        "| {} | {v_float} → {v_quantized} ({:.2}) | {f_float} → {f_quantized} ({:.2}) | {moved:.1e} |",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("?"),
        v_quantized as f64 / v_float as f64,
        f_quantized as f64 / f_float as f64,
    )
}
