//! Helpers shared by the end-to-end tests of the `meshlod` binary.
#![allow(dead_code)]

use std::collections::BTreeSet;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

pub mod loopback;

pub fn meshlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshlod")).args(args).output().expect("meshlod runs")
}

pub fn ok(args: &[&str]) -> Output {
    let out = meshlod(args);
    assert!(out.status.success(), "{args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    out
}

pub fn ok_json(args: &[&str]) -> Value {
    let out = ok(args);
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{args:?}: bad JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)))
}

pub fn fails_with(args: &[&str], needle: &str) -> String {
    let out = meshlod(args);
    assert!(!out.status.success(), "{args:?} should fail");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(stderr.contains(needle), "{args:?}: stderr '{stderr}' lacks '{needle}'");
    stderr
}

pub fn tempdir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meshlod-e2e-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

pub fn keys(v: &Value) -> BTreeSet<String> {
    v.as_object().expect("a JSON object").keys().cloned().collect()
}

/// `meshlod serve` on a free loopback port, stopped when dropped.
pub struct Server {
    child: Child,
    pub address: String,
}

impl Server {
    pub fn start() -> Server {
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let address = format!("127.0.0.1:{port}");
        let child = Command::new(env!("CARGO_BIN_EXE_meshlod"))
            .args(["serve", "--listen", &address, "--metrics-listen", ""])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("server starts");
        let server = Server { child, address };
        // `meshlod health` with a bare host:port, as the deploy files use it.
        let started = Instant::now();
        while !meshlod(&["health", "--server", &server.address, "--timeout", "2"]).status.success() {
            assert!(started.elapsed() < Duration::from_secs(60), "the server did not become healthy");
            std::thread::sleep(Duration::from_millis(100));
        }
        server
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The Prometheus text of a server's metrics endpoint.
pub fn scrape(metrics: std::net::SocketAddr) -> String {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(metrics).unwrap();
    s.write_all(b"GET /metrics HTTP/1.1\r\nhost: x\r\n\r\n").unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    text
}

/// A gauge's value in scraped metrics text.
pub fn gauge(text: &str, name: &str) -> i64 {
    text.lines().find_map(|l| l.strip_prefix(&format!("{name} "))).unwrap().trim().parse().unwrap()
}

/// The requests a server is working on, from its metrics endpoint.
pub fn in_flight(metrics: std::net::SocketAddr) -> i64 {
    gauge(&scrape(metrics), "meshlod_in_flight")
}
