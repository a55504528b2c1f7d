//! What the server is configured with, and its embedded defaults.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;

use crate::convert::MeshLimits;

/// Everything the server is configured with; `Default` is the embedded default that needs no
/// configuration: loopback, one slot per core.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// gRPC listen address.
    pub listen: SocketAddr,
    /// Prometheus metrics listen address (`None`: no metrics endpoint).
    pub metrics_listen: Option<SocketAddr>,
    /// Heavy requests running at once.
    pub max_concurrent: usize,
    /// Heavy requests waiting at once.
    pub max_queue: usize,
    /// Largest gRPC message accepted or sent, bytes.
    pub max_message_bytes: usize,
    /// Target size of each SimplifyStream message, bytes.
    pub stream_message_bytes: usize,
    /// Mesh size limits.
    pub limits: MeshLimits,
    /// PEM certificate and key for TLS (both or neither).
    pub tls: Option<(PathBuf, PathBuf)>,
    /// Required bearer token (`authorization: Bearer <token>`), if any.
    pub token: Option<String>,
    /// The parameter predictor (`None`: Predict, w_auto and etc_auto answer FAILED_PRECONDITION).
    pub predictor: Option<Arc<meshlod_predictor::Predictor>>,
}

impl Default for ServerConfig {
    fn default() -> Self {
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        ServerConfig {
            listen: "127.0.0.1:50051".parse().expect("valid address"),
            metrics_listen: None,
            max_concurrent: cores,
            max_queue: 2 * cores,
            // A 2-million-triangle mesh is ~36 MB as positions + indices; leave room for PM records.
            max_message_bytes: 256 << 20,
            stream_message_bytes: 1 << 20,
            limits: MeshLimits::default(),
            tls: None,
            token: None,
            predictor: None,
        }
    }
}
