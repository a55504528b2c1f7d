//! End-to-end tests of the gRPC service's admission control over real loopback TCP: a busy server
//! refuses at once (RESOURCE_EXHAUSTED, uploads after their first chunk), an expired or cancelled
//! call frees its slot, and every outcome is counted under its code.

mod common;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use common::loopback::{TestServer, simplify_request};
use common::{gauge, in_flight, scrape};
use meshlod_engine::procedural;
use meshlod_service::proto;
use meshlod_service::server::ServerConfig;
use tonic::Code;

/// A request that takes several times the test's deadline however fast the machine: a 2M-face
/// bumpy blob to 1% with the distance guard, as one sequence (on two threads the default's halves
/// finished it in 1.25 s, under the deadline).
fn long_request() -> proto::SimplifyRequest {
    let mut request = simplify_request(&procedural::bumpy_blob(700, 1400, 1), 0.99);
    let options = request.options.as_mut().expect("options");
    (options.guard, options.whole) = (Some(1.0), true);
    request
}

fn requests(metrics: SocketAddr, method: &str, code: &str) -> u64 {
    let key = format!("meshlod_requests_total{{method=\"{method}\",code=\"{code}\"}} ");
    scrape(metrics).lines().find_map(|l| l.strip_prefix(&key)).map_or(0, |n| n.trim().parse().unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn busy_server_refuses_and_cancelled_work_stops() {
    let metrics_port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap();
    let config =
        ServerConfig { max_concurrent: 1, max_queue: 0, metrics_listen: Some(metrics_port), ..Default::default() };
    let server = TestServer::start(config).await;
    let metrics = server.metrics.unwrap();
    let long = long_request();
    let mut first = server.client().await;
    let started = Instant::now();
    let running = tokio::spawn(async move {
        let mut request = tonic::Request::new(long);
        request.set_timeout(Duration::from_millis(1500));
        first.simplify(request).await
    });
    // Wait until the long request occupies the only slot.
    while in_flight(metrics) == 0 {
        assert!(started.elapsed() < Duration::from_secs(20), "long request never started");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let mut second = server.client().await;
    let refused = second.simplify(simplify_request(&procedural::icosphere(2), 0.5)).await.unwrap_err();
    assert_eq!(refused.code(), Code::ResourceExhausted, "{refused:?}");
    // An upload is admitted before it is buffered: with no slot and no queue place it is refused
    // after its first chunk, while its stream is still open (it used to be read to its end first).
    let (tx, rx) = tokio::sync::mpsc::channel::<proto::MeshChunk>(1);
    tx.send(proto::MeshChunk { options: None, positions: vec![0.0; 3 * 1024], indices: vec![0; 3 * 1024] })
        .await
        .unwrap();
    let mut third = server.client().await;
    let upload = tokio::time::timeout(
        Duration::from_secs(5),
        third.simplify_upload(tokio_stream::wrappers::ReceiverStream::new(rx)),
    )
    .await
    .expect("refused without waiting for the stream to end")
    .unwrap_err();
    assert_eq!(upload.code(), Code::ResourceExhausted, "{upload:?}");
    assert_eq!(gauge(&scrape(metrics), "meshlod_queue_depth"), 0);
    drop(tx);
    // The deadline passes: the call fails and the server's worker stops instead of finishing.
    let result = running.await.unwrap();
    let code = result.unwrap_err().code();
    assert!(matches!(code, Code::Cancelled | Code::DeadlineExceeded), "{code:?}");
    let deadline_at = Instant::now();
    while in_flight(metrics) != 0 {
        assert!(deadline_at.elapsed() < Duration::from_secs(3), "cancelled work kept running");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // The slot is free again.
    assert!(second.simplify(simplify_request(&procedural::icosphere(2), 0.5)).await.is_ok());
    // Every outcome is counted under its code: the expired call too (it used to be left out).
    assert_eq!(requests(metrics, "Simplify", "DeadlineExceeded"), 1, "{}", scrape(metrics));
    assert_eq!(requests(metrics, "Simplify", "ResourceExhausted"), 1);
    assert_eq!(requests(metrics, "SimplifyUpload", "ResourceExhausted"), 1);
    assert_eq!(requests(metrics, "Simplify", "Ok"), 1);
    // A call the client cancels is counted as cancelled, and its slot freed.
    let mut fourth = server.client().await;
    let long = long_request();
    let cancelled = tokio::spawn(async move { fourth.simplify(long).await });
    let started = Instant::now();
    while in_flight(metrics) == 0 {
        assert!(started.elapsed() < Duration::from_secs(20), "long request never started");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    cancelled.abort();
    let aborted_at = Instant::now();
    while in_flight(metrics) != 0 || requests(metrics, "Simplify", "Cancelled") == 0 {
        assert!(aborted_at.elapsed() < Duration::from_secs(5), "{}", scrape(metrics));
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    server.stop().await;
}
