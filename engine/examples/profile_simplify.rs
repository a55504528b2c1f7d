//! Runs one simplification for profiling: `cargo run --release --example profile_simplify -- FILE KEEP`.
use meshlod_engine::simplify::{SimplifyOptions, simplify};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mesh = meshlod_engine::io::read_mesh(&args[1]).expect("reads");
    let keep: f64 = args.get(2).and_then(|k| k.parse().ok()).unwrap_or(0.1);
    let repeat: usize = args.get(3).and_then(|k| k.parse().ok()).unwrap_or(5);
    for _ in 0..repeat {
        let out = simplify(
            &mesh,
            &SimplifyOptions { target_ratio: Some(1.0 - keep), record_progressive: true, ..Default::default() },
        )
        .expect("simplifies");
        println!("{} faces in {:.3} s", out.mesh.face_count(), out.stats.seconds);
    }
}
