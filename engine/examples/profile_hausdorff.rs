//! Runs certified Hausdorff measurements for profiling: a shared mesh against its 10%
//! simplification (w = 0), as the hausdorff bench does.
//!
//! `cargo run --release -p meshlod-engine --example profile_hausdorff -- [MESH] [REPEAT] [--sampled]`
//!
//! MESH is a name in the shared meshes (default stanford-bunny), REPEAT the number of runs (default
//! 10); prints the best time, and with REPEAT 1 the report. `--sampled` runs the Metro-style
//! sampled peer (n = the larger vertex count) instead. Instruction counts of one call, which move
//! far less than times on a shared host:
//! `valgrind --tool=callgrind` with RAYON_NUM_THREADS=1 at REPEAT 3 minus REPEAT 1, halved.

use std::time::Instant;

use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff, sampled_max};
use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sampled = args.iter().any(|a| a == "--sampled");
    let mut positional = args.iter().filter(|a| !a.starts_with("--"));
    let name = positional.next().map_or("stanford-bunny", String::as_str);
    let repeat: usize = positional.next().map_or(10, |r| r.parse().expect("REPEAT is a count"));
    let Some(dir) = meshlod_engine::datasets::shared_meshes_dir() else {
        eprintln!("shared meshes not found (set MESHLOD_MESHES)");
        std::process::exit(1);
    };
    let mesh = read_mesh(dir.join(format!("{name}.obj"))).expect("reads");
    let simplified =
        simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), ..Default::default() }).expect("simplifies").mesh;
    let n = mesh.vertex_count().max(simplified.vertex_count()).max(HausdorffOptions::MIN_DEFAULT_SAMPLES);
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        let started = Instant::now();
        if sampled {
            let max = sampled_max(&mesh, &simplified, n, 0x5eed).expect("measures");
            if repeat == 1 {
                println!("sampled max {max} (absolute)");
            }
        } else {
            let report = hausdorff(&mesh, &simplified, &HausdorffOptions::default()).expect("measures");
            if repeat == 1 {
                println!("{report:#?}");
            }
        }
        best = best.min(started.elapsed().as_secs_f64());
    }
    println!("best of {repeat}: {:.1} ms", best * 1e3);
}
