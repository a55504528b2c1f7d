//! Soak and fault test over loopback: many clients send a mix of valid, invalid, cancelled and
//! expiring requests for a bounded time (`MESHLOD_SOAK_SECONDS`, default 20) to a server with small
//! limits. Asserted: no INTERNAL or UNKNOWN status; health answered within a second throughout;
//! every valid result equal to the same simplification run in process (what the CLI runs); the
//! gauges back to 0 at the end; peak memory of the process under a stated bound. The figures are
//! printed for docs/reliability.md.

mod common;

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use common::{gauge, scrape};
use meshlod_engine::procedural;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_service::convert::{MeshLimits, mesh_to_proto};
use meshlod_service::proto;
use meshlod_service::proto::mesh_lod_client::MeshLodClient;
use meshlod_service::server::{ServerConfig, serve_with_listener};
use tokio::sync::Mutex;
use tonic::Code;

/// Peak resident memory of this process (server and clients), MB.
fn peak_rss_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

fn request(mesh: &meshlod_engine::Mesh, ratio: f64) -> proto::SimplifyRequest {
    proto::SimplifyRequest {
        input: Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh_to_proto(mesh))) }),
        options: Some(proto::SimplifyOptions { target_ratio: Some(ratio), ..Default::default() }),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mixed_load_keeps_the_contract() {
    let seconds: u64 = std::env::var("MESHLOD_SOAK_SECONDS").ok().and_then(|v| v.parse().ok()).unwrap_or(20);
    let metrics_addr = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let config = ServerConfig {
        max_concurrent: 2,
        max_queue: 4,
        limits: MeshLimits::for_faces(200_000),
        max_message_bytes: 8 << 20,
        metrics_listen: Some(metrics_addr),
        ..Default::default()
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(async move {
        serve_with_listener(listener, config, async {
            let _ = stop_rx.await;
        })
        .await
        .unwrap();
    });
    let channel = loop {
        if let Ok(c) = tonic::transport::Channel::from_shared(format!("http://{addr}")).unwrap().connect().await {
            break c;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    // The valid request and what the engine gives for it in process.
    let small = procedural::bumpy_blob(30, 60, 2);
    let expected = simplify(&small, &SimplifyOptions { target_ratio: Some(0.8), ..Default::default() }).unwrap().mesh;
    let expected = Arc::new(mesh_to_proto(&expected));
    let heavy = request(&procedural::bumpy_blob(200, 400, 3), 0.99);
    let codes: Arc<Mutex<BTreeMap<String, u64>>> = Arc::default();
    let end = Instant::now() + Duration::from_secs(seconds);
    let failed = Arc::new(AtomicBool::new(false));
    let mut clients = Vec::new();
    for id in 0..32u64 {
        let client = MeshLodClient::new(channel.clone()).max_decoding_message_size(usize::MAX);
        let (small, heavy, expected, codes) = (request(&small, 0.8), heavy.clone(), expected.clone(), codes.clone());
        clients.push(tokio::spawn(async move {
            let mut client = client;
            let mut k = id;
            while Instant::now() < end {
                k = k.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let kind = (k >> 33) % 6;
                let outcome = match kind {
                    // Valid: compared with the in-process result.
                    0 | 1 => match client.simplify(small.clone()).await {
                        Ok(r) => {
                            let mesh = r.into_inner().mesh.unwrap();
                            assert_eq!(&mesh, expected.as_ref(), "a valid result differs from the engine's");
                            "Ok".to_string()
                        }
                        Err(s) => format!("{:?}", s.code()),
                    },
                    // Invalid: an index out of range.
                    2 => {
                        let mut bad = small.clone();
                        if let Some(proto::mesh_input::Source::Mesh(m)) =
                            bad.input.as_mut().and_then(|i| i.source.as_mut())
                        {
                            m.indices[5] = 1 << 30;
                        }
                        // Checked once admitted: a busy server says so first.
                        let s = client.simplify(bad).await.unwrap_err();
                        assert!(matches!(s.code(), Code::InvalidArgument | Code::ResourceExhausted), "{s:?}");
                        format!("{:?}", s.code())
                    }
                    // A deadline shorter than the work.
                    3 => {
                        let mut r = tonic::Request::new(heavy.clone());
                        r.set_timeout(Duration::from_millis(1 + (k >> 40) % 200));
                        match client.simplify(r).await {
                            Ok(_) => "Ok".to_string(),
                            Err(s) => format!("{:?}", s.code()),
                        }
                    }
                    // Cancelled by the client after a moment.
                    4 => {
                        let call = client.simplify(heavy.clone());
                        match tokio::time::timeout(Duration::from_millis(5 + (k >> 40) % 100), call).await {
                            Ok(Ok(_)) => "Ok".to_string(),
                            Ok(Err(s)) => format!("{:?}", s.code()),
                            Err(_) => "ClientCancelled".to_string(),
                        }
                    }
                    // Garbage options: out-of-range enum.
                    _ => {
                        let mut bad = small.clone();
                        bad.options.as_mut().unwrap().metric = 77;
                        let s = client.simplify(bad).await.unwrap_err();
                        assert!(matches!(s.code(), Code::InvalidArgument | Code::ResourceExhausted), "{s:?}");
                        format!("{:?}", s.code())
                    }
                };
                *codes.lock().await.entry(outcome).or_default() += 1;
            }
        }));
    }
    // Health answers within a second throughout.
    let mut health = tonic_health::pb::health_client::HealthClient::new(channel.clone());
    let mut slowest = Duration::ZERO;
    while Instant::now() < end {
        let asked = Instant::now();
        let answer = tokio::time::timeout(
            Duration::from_secs(1),
            health.check(tonic_health::pb::HealthCheckRequest { service: String::new() }),
        )
        .await;
        assert!(matches!(answer, Ok(Ok(_))), "health did not answer within 1 s: {answer:?}");
        slowest = slowest.max(asked.elapsed());
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    for c in clients {
        if c.await.is_err() {
            failed.store(true, Ordering::SeqCst);
        }
    }
    assert!(!failed.load(Ordering::SeqCst), "a client's assertion failed");
    let codes = codes.lock().await.clone();
    let total: u64 = codes.values().sum();
    eprintln!("soak: {seconds} s, 32 clients, {total} requests: {codes:?}; health slowest {slowest:?}");
    for bad in ["Internal", "Unknown"] {
        assert!(!codes.contains_key(bad), "{bad} answered: {codes:?}");
    }
    assert!(codes.get("Ok").copied().unwrap_or(0) > 0 && codes.get("InvalidArgument").copied().unwrap_or(0) > 0);
    // Everything drains: no request in flight or waiting.
    let drained = Instant::now();
    loop {
        let text = scrape(metrics_addr);
        if gauge(&text, "meshlod_in_flight") == 0 && gauge(&text, "meshlod_queue_depth") == 0 {
            eprintln!(
                "soak: server metrics at the end:\n{}",
                text.lines()
                    .filter(|l| l.starts_with("meshlod_requests_total") || l.starts_with("meshlod_rejected"))
                    .collect::<Vec<_>>()
                    .join("\n")
            );
            break;
        }
        assert!(drained.elapsed() < Duration::from_secs(10), "gauges did not return to 0:\n{text}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let peak = peak_rss_mb();
    eprintln!("soak: peak RSS of the process (server and clients) {peak:.0} MB");
    assert!(peak < 1500.0, "peak RSS {peak:.0} MB");
    let _ = stop_tx.send(());
    tokio::time::timeout(Duration::from_secs(30), server).await.unwrap().unwrap();
}
