//! meshlod service: the gRPC server, its clients, and the conversions between the public contract
//! (`proto/meshlod/v1/meshlod.proto`) and the engine. Thin by design: validate, convert, call the
//! engine off the async runtime, convert back.

pub mod convert;
pub mod metrics;
pub mod predict;
pub mod server;

/// Code generated from `proto/meshlod/v1/meshlod.proto`.
#[allow(missing_docs, clippy::all, clippy::pedantic)]
pub mod proto {
    tonic::include_proto!("meshlod.v1");

    /// Encoded file descriptor set, for server reflection.
    pub const FILE_DESCRIPTOR_SET: &[u8] = tonic::include_file_descriptor_set!("meshlod_descriptor");
}
