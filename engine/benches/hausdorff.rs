//! Hausdorff benchmark: each mesh against its 10% simplification (w = 0, default options as one
//! sequence over the whole mesh, `halves` off, so that the pairs stay the same), all
//! cores. In one run, per mesh:
//! - certified: [`hausdorff`] at the default tolerance (1e-3): lower and upper bound, time;
//! - sampled default: the Metro-style sampler as `meshlod hausdorff` ran it before the bounds
//!   (every vertex, n edge and n face samples per direction, n = the larger vertex count, at
//!   least 10 000): its maximum, a lower bound only, and its time;
//! - sampled 1 M: the same sampler with 1 M edge and 1 M face samples per direction.
//!
//! The ratio certified / sampled default is the speed target (< 1). pymeshlab's Metro at 1 M
//! samples is timed beside `meshlod hausdorff` by `tools/hausdorff_bench.py`.
//!
//! Run: `cargo bench -p meshlod-engine --bench hausdorff`.

// The peak-tracking allocator needs `unsafe` (GlobalAlloc); benches only.
#[allow(unsafe_code, dead_code)]
#[path = "support/mod.rs"]
mod common;

use common::{PeakAlloc, best_of, best_of_interleaved};
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff, sampled_max};
use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::{DistanceUnits, Mesh};

#[global_allocator]
static ALLOC: PeakAlloc = PeakAlloc;

fn main() {
    let Some(dir) = meshlod_engine::datasets::shared_meshes_dir() else {
        eprintln!("!!! shared meshes not found (set MESHLOD_MESHES) !!!");
        std::process::exit(1);
    };
    println!(
        "{} threads; distances in paper units; times best of 5\n\n\
         | mesh | faces | certified [L, U] | time | sampled default max | time | ratio | sampled 1 M max | time |\n\
         |---|---:|---|---:|---:|---:|---:|---:|---:|",
        rayon::current_num_threads()
    );
    for name in ["stanford-bunny", "nefertiti", "cow", "fandisk", "ogre"] {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).expect("reads");
        let simplified =
            simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), halves: false, ..Default::default() })
                .expect("simplifies")
                .mesh;
        let units = DistanceUnits::new(&mesh.surface_bounds().expect("faces"));
        let default_n = mesh.vertex_count().max(simplified.vertex_count()).max(HausdorffOptions::MIN_DEFAULT_SAMPLES);
        let sampled = |n: usize| move |a: &Mesh, b: &Mesh| sampled_max(a, b, n, 0x5eed).expect("measures");
        // Interleaved, so that passing load on a shared host hits both alike.
        let ((certified, t_certified), (max_default, t_default)) = best_of_interleaved(
            5,
            || hausdorff(&mesh, &simplified, &HausdorffOptions::default()).expect("measures"),
            || sampled(default_n)(&mesh, &simplified),
        );
        let (max_dense, t_dense) = best_of(3, || sampled(1_000_000)(&mesh, &simplified));
        println!(
            "| {name} | {} → {} | [{:.6}, {:.6}] | {:.1} ms | {:.6} | {:.1} ms | {:.2} | {:.6} | {:.1} ms |",
            mesh.face_count(),
            simplified.face_count(),
            certified.hausdorff_lower,
            certified.hausdorff,
            t_certified * 1e3,
            units.to_paper(max_default),
            t_default * 1e3,
            t_certified / t_default,
            units.to_paper(max_dense),
            t_dense * 1e3,
        );
        assert!(certified.converged, "{name}: the bounds did not meet");
    }
}
