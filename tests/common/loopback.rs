//! A gRPC server on a loopback port for the end-to-end tests, in this process.

use std::net::SocketAddr;
use std::time::Duration;

use meshlod_engine::Mesh;
use meshlod_service::convert::mesh_to_proto;
use meshlod_service::proto;
use meshlod_service::proto::mesh_lod_client::MeshLodClient;
use meshlod_service::server::{ServerConfig, serve_with_listener};
use tokio::sync::oneshot;
use tonic::transport::Channel;

pub struct TestServer {
    pub addr: SocketAddr,
    pub metrics: Option<SocketAddr>,
    stop: Option<oneshot::Sender<()>>,
    handle: tokio::task::JoinHandle<()>,
}

impl TestServer {
    pub async fn start(config: ServerConfig) -> TestServer {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let (tx, rx) = oneshot::channel::<()>();
        let metrics = config.metrics_listen;
        let handle = tokio::spawn(async move {
            serve_with_listener(listener, config, async {
                let _ = rx.await;
            })
            .await
            .unwrap();
        });
        TestServer { addr, metrics, stop: Some(tx), handle }
    }

    pub async fn client(&self) -> MeshLodClient<Channel> {
        let channel = channel(self.addr).await;
        MeshLodClient::new(channel).max_decoding_message_size(usize::MAX).max_encoding_message_size(usize::MAX)
    }

    pub async fn stop(mut self) {
        let _ = self.stop.take().unwrap().send(());
        tokio::time::timeout(Duration::from_secs(30), self.handle).await.expect("graceful shutdown").unwrap();
    }
}

pub async fn channel(addr: SocketAddr) -> Channel {
    for _ in 0..50 {
        if let Ok(c) = Channel::from_shared(format!("http://{addr}")).unwrap().connect().await {
            return c;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    panic!("server at {addr} did not come up");
}

/// `mesh` as a request's input.
pub fn input(mesh: &Mesh) -> Option<proto::MeshInput> {
    Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh_to_proto(mesh))) })
}

/// A Simplify request for `mesh` with `ratio`, the other options the contract's defaults.
pub fn simplify_request(mesh: &Mesh, ratio: f64) -> proto::SimplifyRequest {
    proto::SimplifyRequest {
        input: input(mesh),
        options: Some(proto::SimplifyOptions { target_ratio: Some(ratio), ..Default::default() }),
        ..Default::default()
    }
}
