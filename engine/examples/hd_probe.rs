use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
fn main() {
    let dir = meshlod_engine::datasets::shared_meshes_dir().unwrap();
    let reps: usize = std::env::var("REPS").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    for name in std::env::args().skip(1) {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap();
        let s = simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), ..Default::default() }).unwrap().mesh;
        for _ in 0..reps {
            let t = std::time::Instant::now();
            let r = hausdorff(&mesh, &s, &HausdorffOptions::default()).unwrap();
            println!(
                "{name}: {:.1} ms  [{:.6},{:.6}] a_to_b ev {} splits {}  b_to_a ev {} splits {}",
                t.elapsed().as_secs_f64() * 1e3,
                r.hausdorff_lower,
                r.hausdorff,
                r.a_to_b.evaluations,
                r.a_to_b.splits,
                r.b_to_a.evaluations,
                r.b_to_a.splits
            );
        }
    }
}
