//! Prometheus metrics of the server, served as text on a separate HTTP port.
//!
//! Kept dependency-free: a few atomics and a mutex-guarded map of labelled counters, rendered in
//! the Prometheus text exposition format by a minimal HTTP/1.1 responder.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::net::SocketAddr;
use std::sync::Mutex;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpListener;

/// Upper bounds (seconds) of the latency histogram buckets.
const BUCKETS: [f64; 12] = [0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0];

#[derive(Default)]
struct Histogram {
    counts: [u64; BUCKETS.len()],
    count: u64,
    sum: f64,
}

/// Counters, gauges and histograms of the service.
#[derive(Default)]
pub struct Metrics {
    requests: Mutex<BTreeMap<(String, String), u64>>,
    latency: Mutex<BTreeMap<String, Histogram>>,
    in_flight: AtomicI64,
    queued: AtomicI64,
    rejected: AtomicU64,
}

impl Metrics {
    /// Records one finished request.
    pub fn record(&self, method: &str, code: tonic::Code, elapsed: Duration) {
        let code = format!("{code:?}");
        *self.requests.lock().expect("metrics lock").entry((method.to_string(), code)).or_default() += 1;
        let seconds = elapsed.as_secs_f64();
        let mut latency = self.latency.lock().expect("metrics lock");
        let h = latency.entry(method.to_string()).or_default();
        for (i, &bound) in BUCKETS.iter().enumerate() {
            if seconds <= bound {
                h.counts[i] += 1;
            }
        }
        h.count += 1;
        h.sum += seconds;
    }

    /// Adds `delta` to the in-flight gauge.
    pub fn add_in_flight(&self, delta: i64) {
        self.in_flight.fetch_add(delta, Ordering::Relaxed);
    }

    /// Adds `delta` to the queue-depth gauge.
    pub fn add_queued(&self, delta: i64) {
        self.queued.fetch_add(delta, Ordering::Relaxed);
    }

    /// Counts a request turned away at admission.
    pub fn add_rejected(&self) {
        self.rejected.fetch_add(1, Ordering::Relaxed);
    }

    /// The metrics in Prometheus text format.
    pub fn render(&self) -> String {
        let mut out = String::new();
        out.push_str("# HELP meshlod_requests_total Finished gRPC requests by method and status code.\n");
        out.push_str("# TYPE meshlod_requests_total counter\n");
        for ((method, code), n) in self.requests.lock().expect("metrics lock").iter() {
            let _ = writeln!(out, "meshlod_requests_total{{method=\"{method}\",code=\"{code}\"}} {n}");
        }
        out.push_str("# HELP meshlod_request_duration_seconds Request latency by method.\n");
        out.push_str("# TYPE meshlod_request_duration_seconds histogram\n");
        for (method, h) in self.latency.lock().expect("metrics lock").iter() {
            for (i, bound) in BUCKETS.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "meshlod_request_duration_seconds_bucket{{method=\"{method}\",le=\"{bound}\"}} {}",
                    h.counts[i]
                );
            }
            let _ =
                writeln!(out, "meshlod_request_duration_seconds_bucket{{method=\"{method}\",le=\"+Inf\"}} {}", h.count);
            let _ = writeln!(out, "meshlod_request_duration_seconds_sum{{method=\"{method}\"}} {}", h.sum);
            let _ = writeln!(out, "meshlod_request_duration_seconds_count{{method=\"{method}\"}} {}", h.count);
        }
        let _ =
            writeln!(out, "# HELP meshlod_in_flight Requests running on the CPU pool.\n# TYPE meshlod_in_flight gauge");
        let _ = writeln!(out, "meshlod_in_flight {}", self.in_flight.load(Ordering::Relaxed));
        let _ = writeln!(
            out,
            "# HELP meshlod_queue_depth Requests waiting for a CPU slot.\n# TYPE meshlod_queue_depth gauge"
        );
        let _ = writeln!(out, "meshlod_queue_depth {}", self.queued.load(Ordering::Relaxed));
        let _ = writeln!(
            out,
            "# HELP meshlod_rejected_total Requests refused with RESOURCE_EXHAUSTED.\n# TYPE meshlod_rejected_total counter"
        );
        let _ = writeln!(out, "meshlod_rejected_total {}", self.rejected.load(Ordering::Relaxed));
        out
    }
}

/// Serves `GET /metrics` (and `/` for a liveness check) until the task is dropped.
pub async fn serve_metrics(listener: TcpListener, metrics: std::sync::Arc<Metrics>) {
    loop {
        let Ok((mut socket, _)) = listener.accept().await else { continue };
        let metrics = metrics.clone();
        tokio::spawn(async move {
            let mut buf = [0u8; 1024];
            let n = match tokio::time::timeout(Duration::from_secs(5), socket.read(&mut buf)).await {
                Ok(Ok(n)) => n,
                _ => return,
            };
            let request = String::from_utf8_lossy(&buf[..n]);
            let (status, body) = if request.starts_with("GET /metrics") {
                ("200 OK", metrics.render())
            } else if request.starts_with("GET / ") {
                ("200 OK", "meshlod metrics: see /metrics\n".to_string())
            } else {
                ("404 Not Found", "not found\n".to_string())
            };
            let response = format!(
                "HTTP/1.1 {status}\r\ncontent-type: text/plain; version=0.0.4\r\ncontent-length: {}\r\nconnection: close\r\n\r\n{body}",
                body.len()
            );
            let _ = socket.write_all(response.as_bytes()).await;
        });
    }
}

/// Binds the metrics listener.
pub async fn bind(addr: SocketAddr) -> std::io::Result<TcpListener> {
    TcpListener::bind(addr).await
}
