//! Prints the `.pm` size table of `docs/pm-format.md`: bytes per vertex split of the compact
//! form (version 3) and the lossless one (version 1 or 2), for the shared meshes and textured
//! assets simplified by 99 %, with the default (auto) placement and with endpoint placement.
//! The materials section (images inside) is left out of the per-split figure.
//!
//! Run: `MESHLOD_MESHES=../shared/meshes MESHLOD_TEXTURED=../shared/textured \
//!       cargo run --release -p meshlod-engine --example pm_sizes`

use meshlod_engine::Mesh;
use meshlod_engine::io::read_mesh;
use meshlod_engine::pm::ProgressiveMesh;
use meshlod_engine::pm_format::{encode, encode_lossless, materials_section_len};
use meshlod_engine::simplify::{Placement, SimplifyOptions, simplify};

/// Bytes per split of `encode`, without the materials section.
fn per_split(pm: &ProgressiveMesh, encode: fn(&ProgressiveMesh) -> Vec<u8>) -> f64 {
    (encode(pm).len() - materials_section_len(pm)) as f64 / pm.levels().max(1) as f64
}

fn main() {
    let mut meshes: Vec<(String, Mesh)> = Vec::new();
    let shared = meshlod_engine::datasets::shared_meshes_dir().expect("shared meshes (set MESHLOD_MESHES)");
    for name in ["stanford-bunny", "cow", "fandisk", "nefertiti", "spot"] {
        meshes.push((name.into(), read_mesh(shared.join(format!("{name}.obj"))).expect("reads")));
    }
    let textured = meshlod_engine::datasets::shared_textured_dir().expect("textured assets (set MESHLOD_TEXTURED)");
    for file in [
        "draco__Duck/Duck.gltf",
        "draco__CesiumMan/CesiumMan.gltf",
        "draco__Fox/Fox.gltf",
        "draco__Lantern/Lantern.gltf",
        "trimesh__capsule/capsule.obj",
        "trimesh__fuze/fuze.obj",
        "meshoptimizer__pirate/pirate.obj",
    ] {
        meshes
            .push((file.split('/').next_back().unwrap_or(file).into(), read_mesh(textured.join(file)).expect("reads")));
    }
    println!(
        "| mesh | attributes | splits | compact, auto placement | lossless, auto | compact, endpoint | lossless, endpoint |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|");
    for (name, mesh) in &meshes {
        let run = |placement| {
            let options =
                SimplifyOptions { target_ratio: Some(0.99), record_progressive: true, placement, ..Default::default() };
            simplify(mesh, &options).expect("simplifies").progressive.expect("asked for")
        };
        let (auto, endpoint) = (run(Placement::Auto), run(Placement::Endpoint));
        let names = mesh.corners.names().into_iter().filter(|n| *n != "material").collect::<Vec<_>>();
        println!(
            "| {name} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} |",
            if names.is_empty() { "positions".to_string() } else { names.join(" + ") },
            auto.levels(),
            per_split(&auto, encode),
            per_split(&auto, encode_lossless),
            per_split(&endpoint, encode),
            per_split(&endpoint, encode_lossless),
        );
    }
}
