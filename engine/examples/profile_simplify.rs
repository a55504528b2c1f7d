//! Runs simplifications for profiling and for checking that a speed change kept the output.
//!
//! `cargo run --release -p meshlod-engine --example profile_simplify -- FILE [KEEP] [REPEAT] [--peer] [--guard] [--no-distance-term] [--no-progressive] [--digest]`
//!
//! - default: the engine's defaults (QFVP w = 0 with the fan-distance term) with progressive-mesh
//!   records (the simplify bench's case) to KEEP of the faces (default 0.1), REPEAT times
//!   (default 5); prints each time and the best. Run it under
//!   `valgrind --tool=callgrind` with REPEAT 1 for instruction counts.
//! - `--peer`: meshoptimizer's `simplify` on the same mesh and target instead.
//! - `--guard`: w = 0 (the default) with the distance guard at weight 1.
//! - `--no-distance-term`: the fan-distance term off (the cost as the paper has it).
//! - `--no-progressive`: without progressive-mesh records (`simplify`'s own default).
//! - `--digest`: one hash per (w, placement) of the output mesh and the vertex splits, and one for
//!   Melax: a change meant to be output-preserving must print the same lines before and after.

#[path = "../benches/support/peer.rs"]
mod peer;

use std::hash::{Hash, Hasher};
use std::time::Instant;

use meshlod_engine::Mesh;
use meshlod_engine::simplify::{Metric, Placement, SimplifyOptions, prepare, simplify};

fn options(mesh: &Mesh, keep: f64, metric: Metric, placement: Placement) -> SimplifyOptions {
    let defaults = SimplifyOptions::default();
    SimplifyOptions {
        distance_term: if std::env::args().any(|a| a == "--no-distance-term") { 0.0 } else { defaults.distance_term },
        target_faces: Some((mesh.face_count() as f64 * keep).round() as usize),
        target_ratio: None,
        metric,
        placement,
        record_progressive: !std::env::args().any(|a| a == "--no-progressive"),
        ..defaults
    }
}

fn digest(mesh: &Mesh, keep: f64) {
    for w in [0.0, 1.0, 2.0] {
        for placement in [Placement::Optimal, Placement::Paper] {
            let out = simplify(mesh, &options(mesh, keep, Metric::Qfvp { w }, placement)).expect("simplifies");
            let mut h = std::collections::hash_map::DefaultHasher::new();
            out.mesh.positions.iter().for_each(|p| p.map(f32::to_bits).hash(&mut h));
            out.mesh.triangles.hash(&mut h);
            for s in out.progressive.as_ref().expect("recorded").splits() {
                (s.vs, s.vl, s.vr, s.new_position.map(f32::to_bits), s.error.to_bits()).hash(&mut h);
            }
            println!(
                "w={w} {placement:?}: {} faces, {} rejected, digest {:016x}",
                out.mesh.face_count(),
                out.stats.rejected,
                h.finish()
            );
        }
    }
    let out = simplify(mesh, &options(mesh, keep, Metric::Melax, Placement::Optimal)).expect("simplifies");
    let mut h = std::collections::hash_map::DefaultHasher::new();
    out.mesh.triangles.hash(&mut h);
    println!("melax: {} faces, digest {:016x}", out.mesh.face_count(), h.finish());
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| args.iter().any(|a| a == name);
    let positional: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let Some(path) = positional.first() else {
        eprintln!(
            "usage: profile_simplify FILE [KEEP] [REPEAT] [--peer] [--guard] [--no-distance-term] [--no-progressive] [--digest]"
        );
        std::process::exit(2);
    };
    let mesh = prepare(&meshlod_engine::io::read_mesh(path.as_str()).expect("reads")).0;
    let keep: f64 = positional.get(1).and_then(|k| k.parse().ok()).unwrap_or(0.1);
    let repeat: usize = positional.get(2).and_then(|k| k.parse().ok()).unwrap_or(5);
    if flag("--digest") {
        digest(&mesh, keep);
        return;
    }
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        let started = Instant::now();
        let faces = if flag("--peer") {
            peer::meshopt_simplify(&mesh, (mesh.face_count() as f64 * keep).round() as usize).face_count()
        } else if flag("--guard") {
            let options =
                SimplifyOptions { guard: 1.0, ..options(&mesh, keep, Metric::Qfvp { w: 0.0 }, Placement::Optimal) };
            simplify(&mesh, &options).expect("simplifies").mesh.face_count()
        } else {
            simplify(&mesh, &options(&mesh, keep, Metric::Qfvp { w: 0.0 }, Placement::Optimal))
                .expect("simplifies")
                .mesh
                .face_count()
        };
        let seconds = started.elapsed().as_secs_f64();
        best = best.min(seconds);
        println!("{faces} faces in {:.1} ms", seconds * 1e3);
    }
    println!("best {:.1} ms", best * 1e3);
}
