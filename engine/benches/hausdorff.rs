//! Hausdorff benchmark: stanford-bunny (69k faces) against a 10% simplified copy with default
//! sampling, all cores (2 here). Prints: input, samples, result, time.
//!
//! Run: `cargo bench -p meshlod-engine --bench hausdorff`.

// The peak-tracking allocator needs `unsafe` (GlobalAlloc); benches only.
#[allow(unsafe_code, dead_code)]
#[path = "support/mod.rs"]
mod common;

use common::{PeakAlloc, best_of};
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};

#[global_allocator]
static ALLOC: PeakAlloc = PeakAlloc;

fn main() {
    let Some(dir) = meshlod_engine::datasets::shared_meshes_dir() else {
        eprintln!("!!! shared meshes not found (set MESHLOD_MESHES) !!!");
        std::process::exit(1);
    };
    for (name, keep) in [("stanford-bunny", 0.1), ("nefertiti", 0.1), ("cow", 0.1)] {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).expect("reads");
        let simplified = simplify(&mesh, &SimplifyOptions { target_ratio: Some(1.0 - keep), ..Default::default() })
            .expect("simplifies");
        let (report, seconds) =
            best_of(5, || hausdorff(&mesh, &simplified.mesh, &HausdorffOptions::default()).expect("measures"));
        println!(
            "{name}: {} vs {} triangles, {} samples, hausdorff {:.6} paper units, mean {:.6}, time {:.1} ms on {} threads",
            mesh.face_count(),
            simplified.mesh.face_count(),
            report.samples,
            report.hausdorff,
            report.mean,
            seconds * 1e3,
            rayon::current_num_threads()
        );
    }
}
