//! meshlod service: the operations behind every front end, the gRPC server and its client, and
//! the conversions between the public contract (`proto/meshlod/v1/meshlod.proto`) and the engine.
//!
//! Modules in the order a request meets them:
//! - `proto` — the contract's generated types;
//! - [`convert`] — contract ↔ engine (meshes, options via `TryFrom`, reports), with field paths;
//! - [`jobs`] — simplify / refine / predict on a mesh in memory, from the contract's options;
//! - [`executor`] — jobs on files, run here ([`executor::Local`]) or on a server
//!   ([`client::Remote`]), ending in one [`report`] shape;
//! - [`server`] — the tonic service, admission control and auth; [`metrics`] its Prometheus text;
//! - [`predict`] — the predictor's inputs from the engine's features.
//!
//! The `meshlod` binary (src/main.rs and its modules) holds the command line and printing only.

pub mod client;
pub mod convert;
pub mod error;
pub mod executor;
pub mod jobs;
pub mod metrics;
pub mod predict;
pub mod report;
pub mod request;
pub mod server;
pub mod stream_values;

/// Code generated from `proto/meshlod/v1/meshlod.proto`.
#[allow(missing_docs, clippy::all, clippy::pedantic)]
pub mod proto {
    tonic::include_proto!("meshlod.v1");

    /// Encoded file descriptor set, for server reflection.
    pub const FILE_DESCRIPTOR_SET: &[u8] = tonic::include_file_descriptor_set!("meshlod_descriptor");
}
