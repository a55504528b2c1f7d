//! Simplification benchmark: meshlod (its defaults, w = 0 with the fan-distance term, unless a line
//! says otherwise; progressive-mesh records on but in the lines "without progressive-mesh
//! records", which is how `simplify` runs unless the progressive mesh is asked for) beside
//! meshoptimizer at the same target face count, in one process, single-threaded but for the lines
//! "on two threads" (meshlod called from a pool of two, where its setup's passes and a large mesh's
//! two halves run side by side; meshoptimizer on one). The lines "as one sequence" run meshlod
//! with `halves` off (`--whole`): one sequence of collapses over the whole mesh.
//! Prints one standard line per case:
//! `input → output triangles, error, time, peer time, ratio`, plus throughput and peak memory.
//!
//! Run: `cargo bench -p meshlod-engine --bench simplify` (needs the shared meshes; the 2-million
//! triangle case is ogre subdivided twice, or a procedural torus without them). `MESHLOD_BENCH_QUICK=1` runs one repetition.
//! The "paper's cost" lines price the fan-distance term (they leave it out) and the "with the
//! distance guard" lines that option (`SimplifyOptions::guard`); the 2× target is for the default.

// The peak-tracking allocator needs `unsafe` (GlobalAlloc); benches only.
#[allow(unsafe_code, dead_code)]
#[path = "support/mod.rs"]
mod common;
#[path = "support/peer.rs"]
mod peer;

use common::{PeakAlloc, best_of_interleaved, peak_during};
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::read_mesh;
use meshlod_engine::refine::subdivide_uniform;
use meshlod_engine::simplify::{Metric, SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};
use peer::meshopt_simplify;

#[global_allocator]
static ALLOC: PeakAlloc = PeakAlloc;

/// What a line changes from the defaults.
#[derive(Clone, Copy)]
enum Variant {
    Default,
    /// The paper's QFVP at this w, without the fan-distance term.
    Paper(f64),
    /// The distance guard at weight 1 (w = 0).
    Guard,
    /// The defaults, called from a pool of two threads (the setup's passes run side by side).
    TwoThreads,
    /// The defaults without progressive-mesh records: `simplify` as a caller runs it unless it
    /// asks for the progressive mesh (`--pm`, gRPC `return_progressive`).
    NoRecords,
    /// The defaults with `halves` off: one sequence over the whole mesh.
    Whole,
}

fn case(name: &str, mesh: &Mesh, keep: f64, runs: usize, measure_error: bool, variant: Variant) {
    let faces_in = mesh.face_count();
    let target = ((faces_in as f64) * keep).round() as usize;
    let defaults = SimplifyOptions {
        target_faces: Some(target),
        target_ratio: None,
        record_progressive: true,
        ..Default::default()
    };
    let options = match variant {
        Variant::Default | Variant::TwoThreads => defaults,
        Variant::Paper(w) => SimplifyOptions { metric: Metric::Qfvp { w }, distance_term: 0.0, ..defaults },
        Variant::Guard => SimplifyOptions { guard: 1.0, ..defaults },
        Variant::NoRecords => SimplifyOptions { record_progressive: false, ..defaults },
        Variant::Whole => SimplifyOptions { halves: false, ..defaults },
    };
    // The other lines run on the calling thread, the global pool having one thread.
    let two = matches!(variant, Variant::TwoThreads)
        .then(|| rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a thread pool"));
    let ours = || match &two {
        Some(pool) => pool.install(|| simplify(mesh, &options).expect("simplifies")),
        None => simplify(mesh, &options).expect("simplifies"),
    };
    let ((ours, ours_time), (peer, peer_time)) = best_of_interleaved(runs, ours, || meshopt_simplify(mesh, target));
    let (_, ours_peak) = peak_during(|| simplify(mesh, &options).expect("simplifies"));
    let (_, peer_peak) = peak_during(|| meshopt_simplify(mesh, target));
    let errors = if measure_error {
        let h = |m: &Mesh| hausdorff(mesh, m, &HausdorffOptions::default()).map(|r| r.hausdorff).unwrap_or(f64::NAN);
        format!("error {:.5} (peer {:.5}) paper units", h(&ours.mesh), h(&peer))
    } else {
        "error not measured".to_string()
    };
    println!(
        "{name}: {faces_in} → {} triangles (peer {}), {errors}, time {:.1} ms, peer {:.1} ms, ratio {:.2}; \
         {:.2} M input tri/s; peak {:.0} B/input tri (peer {:.0}); {} splits",
        ours.mesh.face_count(),
        peer.face_count(),
        ours_time * 1e3,
        peer_time * 1e3,
        ours_time / peer_time,
        faces_in as f64 / ours_time / 1e6,
        ours_peak as f64 / faces_in as f64,
        peer_peak as f64 / faces_in as f64,
        ours.progressive.as_ref().map_or(0, |p| p.levels()),
    );
}

fn main() {
    // Single-threaded but for the lines on two threads, the pool a caller of the command line or
    // the service gets on the 2-core machines (Hausdorff uses rayon; keep it off the timed part).
    rayon::ThreadPoolBuilder::new().num_threads(1).build_global().ok();
    let quick = std::env::var_os("MESHLOD_BENCH_QUICK").is_some();
    // Best of 15, interleaved: with 5, a line's ratio moved by up to ±15% between runs on the
    // shared development machine; with 15, by a few percent (docs/benchmarks.md).
    let runs = if quick { 1 } else { 15 };
    match meshlod_engine::datasets::shared_meshes_dir() {
        Some(dir) => {
            for name in ["stanford-bunny", "nefertiti", "ogre"] {
                let mesh = read_mesh(dir.join(format!("{name}.obj"))).expect("shared mesh reads");
                let (mesh, _, _) = meshlod_engine::simplify::prepare(&mesh);
                // What a caller gets without choosing anything.
                for keep in [0.1, 0.01] {
                    case(&format!("{name} keep {:.0}%", keep * 100.0), &mesh, keep, runs, true, Variant::Default);
                }
                // Without the records (what a caller gets who does not ask for the progressive mesh).
                for keep in [0.1, 0.01] {
                    let label = format!("{name} keep {:.0}% without progressive-mesh records", keep * 100.0);
                    case(&label, &mesh, keep, runs, false, Variant::NoRecords);
                }
                // Where the caller's pool has two threads (meshoptimizer still on one).
                for keep in [0.1, 0.01] {
                    let label = format!("{name} keep {:.0}% on two threads", keep * 100.0);
                    case(&label, &mesh, keep, runs, false, Variant::TwoThreads);
                }
                // One sequence over the whole mesh: what the halves change in time and error.
                for keep in [0.1, 0.01] {
                    let label = format!("{name} keep {:.0}% as one sequence", keep * 100.0);
                    case(&label, &mesh, keep, runs, true, Variant::Whole);
                }
                // The paper's cost, at the default w and at the paper's w = 1: the fan-distance
                // term's price and gain.
                for w in [0.0, 1.0] {
                    let label = format!("{name} keep 10%, the paper's cost at w = {w}");
                    case(&label, &mesh, 0.1, runs, true, Variant::Paper(w));
                }
                // The distance guard's price (an option, off by default), against the same peer.
                let label = format!("{name} keep 10% with the distance guard (weight 1)");
                case(&label, &mesh, 0.1, runs.min(2), true, Variant::Guard);
            }
        }
        None => eprintln!("!!! shared meshes not found (set MESHLOD_MESHES): only the procedural case runs !!!"),
    }
    // Scale: ogre (124k) with two rounds of uniform butterfly is 1.98 M triangles; without the
    // shared meshes, a procedural torus of the same size.
    let (label, big) = match meshlod_engine::datasets::shared_mesh("ogre") {
        Some(path) => {
            let ogre = meshlod_engine::simplify::prepare(&read_mesh(path).expect("ogre reads")).0;
            ("ogre subdivided twice", subdivide_uniform(&subdivide_uniform(&ogre)))
        }
        None => ("procedural torus", procedural::torus(1414, 707, 0.3)),
    };
    for (variant, records) in [
        (Variant::Default, ""),
        (Variant::NoRecords, " without progressive-mesh records"),
        (Variant::TwoThreads, " on two threads"),
        (Variant::Whole, " as one sequence"),
    ] {
        let name = format!("{label} ({} M) keep 1%{records}", big.face_count() as f64 / 1e6);
        case(&name, &big, 0.01, if quick { 1 } else { 2 }, false, variant);
    }
}
