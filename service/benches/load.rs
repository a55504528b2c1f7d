//! Load benchmark of the gRPC service, in one process over loopback: request throughput and
//! p50/p99 latency at concurrency 1, 8 and 32 for a small request, and Simplify of
//! stanford-bunny to 10% over gRPC beside the same call in process (the gRPC overhead).
//!
//! Run: `cargo bench -p meshlod --bench load`.

use std::time::{Duration, Instant};

use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};
use meshlod_service::convert::mesh_to_proto;
use meshlod_service::proto;
use meshlod_service::proto::mesh_lod_client::MeshLodClient;
use meshlod_service::server::{ServerConfig, serve_with_listener};
use tonic::transport::Channel;

fn request(mesh: &Mesh, ratio: f64) -> proto::SimplifyRequest {
    proto::SimplifyRequest {
        input: Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh_to_proto(mesh))) }),
        options: Some(proto::SimplifyOptions { target_ratio: Some(ratio), ..Default::default() }),
        ..Default::default()
    }
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

/// One kind of request for the load loop.
#[derive(Clone)]
enum Call {
    Simplify(proto::SimplifyRequest),
    Predict(proto::PredictRequest),
}

async fn load(client: &MeshLodClient<Channel>, call: &Call, label: &str, concurrency: usize, total: usize) {
    let started = Instant::now();
    let mut tasks = Vec::new();
    for worker in 0..concurrency {
        let mut client = client.clone();
        let call = call.clone();
        let n = total / concurrency + usize::from(worker < total % concurrency);
        tasks.push(tokio::spawn(async move {
            let mut latencies = Vec::with_capacity(n);
            for _ in 0..n {
                let t = Instant::now();
                match &call {
                    Call::Simplify(r) => drop(client.simplify(r.clone()).await.expect("simplify")),
                    Call::Predict(r) => drop(client.predict(r.clone()).await.expect("predict")),
                }
                latencies.push(t.elapsed());
            }
            latencies
        }));
    }
    let mut all = Vec::new();
    for t in tasks {
        all.extend(t.await.expect("worker"));
    }
    let elapsed = started.elapsed();
    all.sort();
    println!(
        "{label}, concurrency {concurrency}: {} requests, {:.0} req/s, p50 {:.2} ms, p99 {:.2} ms",
        all.len(),
        all.len() as f64 / elapsed.as_secs_f64(),
        percentile(&all, 0.5).as_secs_f64() * 1e3,
        percentile(&all, 0.99).as_secs_f64() * 1e3
    );
}

fn main() {
    let runtime = tokio::runtime::Runtime::new().expect("runtime");
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let addr = listener.local_addr().expect("address");
        let predictor = std::sync::Arc::new(meshlod_service::predict::load(None).expect("model"));
        let config = ServerConfig { max_queue: 64, predictor: Some(predictor), ..Default::default() };
        tokio::spawn(serve_with_listener(listener, config, std::future::pending()));
        tokio::time::sleep(Duration::from_millis(200)).await;
        let channel = Channel::from_shared(format!("http://{addr}")).expect("uri").connect().await.expect("connect");
        let client = MeshLodClient::new(channel).max_decoding_message_size(usize::MAX).max_encoding_message_size(usize::MAX);
        let shape = meshlod_engine::features::shape_features(&procedural::icosphere(3));
        let predict = Call::Predict(proto::PredictRequest {
            subject: Some(proto::predict_request::Subject::Features(proto::ShapeFeatures { values: shape.to_vec() })),
            target_faces: Some(1000),
            target_ratio: Some(0.9),
        });
        for concurrency in [1, 8, 32] {
            load(&client, &predict, "Predict (features)", concurrency, 4000).await;
        }
        let small = Call::Simplify(request(&procedural::icosphere(3), 0.5));
        for concurrency in [1, 8, 32] {
            load(&client, &small, "small Simplify (icosphere 1280 → 640 faces)", concurrency, 400).await;
        }
        let Some(dir) = meshlod_engine::datasets::shared_meshes_dir() else {
            eprintln!("!!! shared meshes not found (set MESHLOD_MESHES): bunny case skipped !!!");
            return;
        };
        let bunny = read_mesh(dir.join("stanford-bunny.obj")).expect("bunny");
        let options = SimplifyOptions { target_ratio: Some(0.9), ..Default::default() };
        let mut in_process = Duration::MAX;
        let mut over_grpc = Duration::MAX;
        let big = request(&bunny, 0.9);
        for _ in 0..5 {
            let t = Instant::now();
            let local = simplify(&bunny, &options).expect("simplify");
            std::hint::black_box(&local);
            in_process = in_process.min(t.elapsed());
            let mut c = client.clone();
            let t = Instant::now();
            c.simplify(big.clone()).await.expect("simplify over gRPC");
            over_grpc = over_grpc.min(t.elapsed());
        }
        println!(
            "stanford-bunny Simplify to 10%: in process {:.1} ms, over gRPC {:.1} ms (request encode, transfer, decode, convert included), overhead {:+.1}%",
            in_process.as_secs_f64() * 1e3,
            over_grpc.as_secs_f64() * 1e3,
            (over_grpc.as_secs_f64() / in_process.as_secs_f64() - 1.0) * 100.0
        );
    });
}
