//! The tonic gRPC server: admission control, CPU work off the async runtime, cancellation,
//! health, reflection, compression, metrics, optional TLS and bearer token, graceful shutdown.
//!
//! - `service` — the MeshLod RPCs: check the request, run the operation (`crate::jobs`) in an
//!   admitted slot, convert back;
//! - `admission` — at most `max_concurrent` heavy requests run (each on a blocking thread), at
//!   most `max_queue` wait; beyond that a request is refused with RESOURCE_EXHAUSTED at once. Every
//!   heavy request carries a cancel flag that the engine reads inside its loops; the flag is raised
//!   when the request's future is dropped (client cancel, deadline), so the work stops within
//!   milliseconds and its CPU slot frees;
//! - `auth` — the bearer token check;
//! - `codes` — the contract's codes for the codec's errors (undecodable → INVALID_ARGUMENT,
//!   oversize → RESOURCE_EXHAUSTED).

mod admission;
mod auth;
mod codes;
mod config;
mod service;

use std::future::Future;
use std::sync::Arc;

use tokio::net::TcpListener;
use tonic::codec::CompressionEncoding;

pub use auth::TokenCheck;
pub use config::ServerConfig;
pub use service::MeshLodService;

use crate::metrics::Metrics;
use crate::proto;
use crate::proto::mesh_lod_server::MeshLodServer;

/// Runs the server on `listener` until `shutdown` completes, then drains in-flight requests.
pub async fn serve_with_listener(
    listener: TcpListener,
    config: ServerConfig,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let metrics = Arc::new(Metrics::default());
    if let Some(addr) = config.metrics_listen {
        let metrics_listener = crate::metrics::bind(addr).await?;
        tracing::info!(address = %metrics_listener.local_addr()?, "metrics on /metrics");
        tokio::spawn(crate::metrics::serve_metrics(metrics_listener, metrics.clone()));
    }
    let (health_reporter, health_service) = tonic_health::server::health_reporter();
    health_reporter.set_serving::<MeshLodServer<MeshLodService>>().await;
    let reflection = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(proto::FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1()?;
    let service = MeshLodService::new(config.clone(), metrics);
    let server = MeshLodServer::new(service)
        .accept_compressed(CompressionEncoding::Gzip)
        .accept_compressed(CompressionEncoding::Zstd)
        .send_compressed(CompressionEncoding::Gzip)
        .send_compressed(CompressionEncoding::Zstd)
        .max_decoding_message_size(config.max_message_bytes)
        .max_encoding_message_size(config.max_message_bytes);
    // Outermost, so that it sees the transport's headers (the interceptor drops grpc-timeout).
    let server = codes::ContractCodes(tonic::service::interceptor::InterceptedService::new(
        server,
        TokenCheck::new(config.token.as_deref()),
    ));
    let mut builder = tonic::transport::Server::builder()
        .trace_fn(|request| tracing::info_span!("grpc", path = %request.uri().path()));
    if let Some((cert, key)) = &config.tls {
        let identity = tonic::transport::Identity::from_pem(std::fs::read(cert)?, std::fs::read(key)?);
        builder = builder.tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))?;
    }
    // No Nagle: small gRPC frames would otherwise wait for delayed ACKs on every request.
    let incoming = tonic::transport::server::TcpIncoming::from(listener)
        .with_nodelay(Some(true))
        .with_keepalive(Some(std::time::Duration::from_secs(60)));
    tracing::info!(address = %incoming.local_addr()?, tls = config.tls.is_some(), auth = config.token.is_some(), "serving meshlod.v1.MeshLod");
    builder
        .add_service(health_service)
        .add_service(reflection)
        .add_service(server)
        .serve_with_incoming_shutdown(incoming, async move {
            shutdown.await;
            tracing::info!("shutting down: draining in-flight requests");
        })
        .await?;
    Ok(())
}

/// Completes on SIGTERM or Ctrl-C.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! { _ = ctrl_c => {}, _ = term => {} }
}
