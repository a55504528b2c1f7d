//! Predictor benchmark: model load time and single-call inference latency, in process.
//!
//! Run: `cargo bench -p meshlod-predictor --bench inference`.

use std::time::Instant;

use meshlod_predictor::Predictor;

fn main() {
    let started = Instant::now();
    let predictor = Predictor::embedded().expect("embedded model loads");
    let load = started.elapsed();
    let n_w = predictor.metadata().w_input_names.len();
    let n_etc = predictor.metadata().etc_input_names.len();
    let w_input: Vec<f32> = (0..n_w).map(|i| 0.1 * i as f32).collect();
    let etc_input: Vec<f32> = (0..n_etc).map(|i| 0.05 * i as f32).collect();
    for _ in 0..1000 {
        std::hint::black_box(predictor.predict(&w_input, &etc_input).expect("runs"));
    }
    let calls = 20_000;
    let mut latencies = Vec::with_capacity(calls);
    for _ in 0..calls {
        let t = Instant::now();
        std::hint::black_box(predictor.predict(&w_input, &etc_input).expect("runs"));
        latencies.push(t.elapsed());
    }
    latencies.sort();
    let mean = latencies.iter().map(|d| d.as_secs_f64()).sum::<f64>() / calls as f64;
    println!(
        "predictor {}: load {:.1} ms; inference mean {:.1} µs, p50 {:.1} µs, p99 {:.1} µs over {calls} calls (w and ETC together)",
        predictor.metadata().model_version,
        load.as_secs_f64() * 1e3,
        mean * 1e6,
        latencies[calls / 2].as_secs_f64() * 1e6,
        latencies[calls * 99 / 100].as_secs_f64() * 1e6
    );
}
