//! The tonic gRPC server: admission control, CPU work off the async runtime, cancellation,
//! health, reflection, compression, metrics, optional TLS and bearer token, graceful shutdown.
//!
//! Admission: at most `max_concurrent` heavy requests run (each on a blocking thread), at most
//! `max_queue` wait; beyond that a request is refused with RESOURCE_EXHAUSTED at once. Every heavy
//! request carries a cancel flag that the engine reads inside its loops; the flag is raised when
//! the request's future is dropped (client cancel, deadline), so the work stops within
//! milliseconds and its CPU slot frees.

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use meshlod_engine::features::W_CLASSES;
use meshlod_engine::hausdorff::{HausdorffOptions, check_surface, hausdorff};
use meshlod_engine::refine::{RefineMode, RefineOptions, refine};
use meshlod_engine::simplify::{Metric, simplify, simplify_search_w};
use tokio::net::TcpListener;
use tokio::sync::{Semaphore, mpsc};
use tokio_stream::wrappers::ReceiverStream;
use tonic::codec::CompressionEncoding;
use tonic::{Request, Response, Status};

use crate::convert::{
    self, MeshLimits, engine_status, mesh_from_input, mesh_to_proto, progressive_to_proto, split_to_proto,
};
use crate::metrics::Metrics;
use crate::proto;
use crate::proto::mesh_lod_server::{MeshLod, MeshLodServer};

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

/// Bounded admission: `max_concurrent` slots and a waiting line of `max_queue`.
struct Admission {
    slots: Arc<Semaphore>,
    waiting: AtomicUsize,
    max_queue: usize,
}

/// Raises the cancel flag when dropped unless disarmed: the request's future was dropped.
struct CancelOnDrop(Arc<AtomicBool>, bool);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        if !self.1 {
            self.0.store(true, Ordering::Relaxed);
        }
    }
}

/// The MeshLod service.
#[derive(Clone)]
pub struct MeshLodService {
    config: Arc<ServerConfig>,
    admission: Arc<Admission>,
    metrics: Arc<Metrics>,
}

impl MeshLodService {
    /// A service with its own admission control and metrics.
    pub fn new(config: ServerConfig, metrics: Arc<Metrics>) -> Self {
        let admission = Admission {
            slots: Arc::new(Semaphore::new(config.max_concurrent.max(1))),
            waiting: AtomicUsize::new(0),
            max_queue: config.max_queue,
        };
        MeshLodService { config: Arc::new(config), admission: Arc::new(admission), metrics }
    }

    /// Runs `work` on a blocking thread once admitted, with a cancel flag tied to this future.
    async fn run<T: Send + 'static>(
        &self,
        method: &'static str,
        work: impl FnOnce(Arc<AtomicBool>) -> Result<T, Status> + Send + 'static,
    ) -> Result<T, Status> {
        let started = Instant::now();
        let result = self.admit_and_run(work).await;
        let code = result.as_ref().map_or_else(|s| s.code(), |_| tonic::Code::Ok);
        self.metrics.record(method, code, started.elapsed());
        match &result {
            Ok(_) => tracing::info!(method, ms = started.elapsed().as_millis() as u64, "ok"),
            Err(s) => tracing::warn!(method, code = ?s.code(), message = s.message(), "refused or failed"),
        }
        result
    }

    /// One simplification answered in one message (Simplify and SimplifyUpload).
    async fn simplify_unary(
        &self,
        method: &'static str,
        request: proto::SimplifyRequest,
    ) -> Result<Response<proto::SimplifyResponse>, Status> {
        let limits = self.config.limits;
        let predictor = self.config.predictor.clone();
        let response = self
            .run(method, move |cancel| {
                let (result, stats, hausdorff, _) =
                    run_simplify(&request, &limits, predictor.as_deref(), cancel, false)?;
                Ok(proto::SimplifyResponse {
                    mesh: Some(mesh_to_proto(&result.mesh)),
                    progressive: result.progressive.as_ref().map(progressive_to_proto),
                    stats: Some(stats),
                    hausdorff,
                })
            })
            .await?;
        Ok(Response::new(response))
    }

    async fn admit_and_run<T: Send + 'static>(
        &self,
        work: impl FnOnce(Arc<AtomicBool>) -> Result<T, Status> + Send + 'static,
    ) -> Result<T, Status> {
        let permit = match self.admission.slots.clone().try_acquire_owned() {
            Ok(p) => p,
            Err(_) => {
                let waiting = self.admission.waiting.fetch_add(1, Ordering::SeqCst);
                if waiting >= self.admission.max_queue {
                    self.admission.waiting.fetch_sub(1, Ordering::SeqCst);
                    self.metrics.add_rejected();
                    return Err(Status::resource_exhausted(format!(
                        "server busy: {} requests running and {} queued; retry later",
                        self.config.max_concurrent, self.admission.max_queue
                    )));
                }
                self.metrics.add_queued(1);
                // The waiting count is released however this future ends (dropped while queued too).
                struct Leave<'a>(&'a Admission, &'a Metrics);
                impl Drop for Leave<'_> {
                    fn drop(&mut self) {
                        self.0.waiting.fetch_sub(1, Ordering::SeqCst);
                        self.1.add_queued(-1);
                    }
                }
                let _leave = Leave(&self.admission, &self.metrics);
                self.admission.slots.clone().acquire_owned().await.map_err(|_| Status::unavailable("shutting down"))?
            }
        };
        let cancel = Arc::new(AtomicBool::new(false));
        let mut guard = CancelOnDrop(cancel.clone(), false);
        let metrics = self.metrics.clone();
        metrics.add_in_flight(1);
        let handle = tokio::task::spawn_blocking(move || {
            let _permit = permit; // the slot is held until the work really ends
            let out = work(cancel);
            metrics.add_in_flight(-1);
            out
        });
        let result = handle.await.map_err(|e| {
            tracing::error!(error = %e, "worker panicked");
            Status::internal("internal error while processing the request")
        })?;
        guard.1 = true;
        result
    }
}

fn require<'a, T>(value: &'a Option<T>, field: &str) -> Result<&'a T, Status> {
    value.as_ref().ok_or_else(|| Status::invalid_argument(format!("{field}: missing")))
}

/// Validates and runs one simplification; shared by the unary and streaming RPCs.
fn run_simplify(
    request: &proto::SimplifyRequest,
    limits: &MeshLimits,
    predictor: Option<&meshlod_predictor::Predictor>,
    cancel: Arc<AtomicBool>,
    force_progressive: bool,
) -> Result<
    (meshlod_engine::simplify::Simplified, proto::SimplifyStats, Option<proto::HausdorffReport>, meshlod_engine::Mesh),
    Status,
> {
    let default_options = proto::SimplifyOptions::default();
    let o = request.options.as_ref().unwrap_or(&default_options);
    let mesh = mesh_from_input(request.input.as_ref(), "input", limits)?;
    if o.w_auto && o.w_search {
        return Err(Status::invalid_argument("options.w_search: not together with options.w_auto"));
    }
    let (w, w_source, model_version) = if o.w_search {
        (0.0, proto::WSource::Searched, String::new())
    } else if o.w_auto {
        let predictor = predictor
            .ok_or_else(|| Status::failed_precondition("options.w_auto: this server runs without a predictor model"))?;
        let target =
            crate::predict::target_faces(mesh.face_count(), o.target_faces.map(|n| n as usize), o.target_ratio)
                .unwrap_or(mesh.face_count() / 2);
        let advice = crate::predict::advise(predictor, &mesh, target).map_err(|e| Status::internal(e.to_string()))?;
        (advice.w.w, proto::WSource::Predicted, advice.model_version)
    } else {
        (o.w.unwrap_or(0.0), proto::WSource::Given, String::new())
    };
    let mut options = convert::simplify_options(o, w)?;
    options.record_progressive |= force_progressive;
    options.cancel = Some(cancel);
    // A search has measured its result already; `measured` keeps that for compute_hausdorff.
    let (result, w_candidates, measured) = if o.w_search {
        let search = simplify_search_w(&mesh, &options, &W_CLASSES).map_err(|e| engine_status(e, "options"))?;
        options.metric = Metric::Qfvp { w: search.w };
        let candidates = search.errors.iter().map(|&(w, hausdorff)| proto::WCandidate { w, hausdorff }).collect();
        (search.best, candidates, Some(search.hausdorff))
    } else {
        (simplify(&mesh, &options).map_err(|e| engine_status(e, "options"))?, Vec::new(), None)
    };
    let hausdorff = if o.compute_hausdorff {
        let d = match measured {
            Some(d) => d,
            None => {
                let options = HausdorffOptions { cancel: options.cancel.clone(), ..Default::default() };
                hausdorff(&mesh, &result.mesh, &options).map_err(|e| engine_status(e, "options"))?
            }
        };
        Some(convert::hausdorff_to_proto(&d))
    } else {
        None
    };
    let s = &result.stats;
    let stats = proto::SimplifyStats {
        faces_in: s.faces_in as u32,
        faces_out: s.faces_out as u32,
        vertices_in: s.vertices_in as u32,
        vertices_out: s.vertices_out as u32,
        collapses: s.collapses as u32,
        stop_reason: s.stop_reason.as_str().to_string(),
        metric: options.metric.name().to_string(),
        w: options.metric.w().unwrap_or(0.0),
        w_source: w_source as i32,
        model_version,
        max_collapse_error: s.max_collapse_error,
        seconds: s.seconds,
        w_candidates,
        guard: options.guard,
    };
    Ok((result, stats, hausdorff, mesh))
}

#[tonic::async_trait]
impl MeshLod for MeshLodService {
    async fn simplify(
        &self,
        request: Request<proto::SimplifyRequest>,
    ) -> Result<Response<proto::SimplifyResponse>, Status> {
        self.simplify_unary("Simplify", request.into_inner()).await
    }

    type SimplifyStreamStream = ReceiverStream<Result<proto::SimplifyStreamMessage, Status>>;

    async fn simplify_stream(
        &self,
        request: Request<proto::SimplifyRequest>,
    ) -> Result<Response<Self::SimplifyStreamStream>, Status> {
        let request = request.into_inner();
        let limits = self.config.limits;
        let predictor = self.config.predictor.clone();
        let (result, stats, _, _) = self
            .run("SimplifyStream", move |cancel| run_simplify(&request, &limits, predictor.as_deref(), cancel, true))
            .await?;
        let pm = result.progressive.expect("progressive forced on");
        // Splits are ~20–40 bytes encoded; batch so each message stays under the configured size.
        let per_batch = (self.config.stream_message_bytes / 48).max(1);
        let (tx, rx) = mpsc::channel(4);
        tokio::spawn(async move {
            use proto::simplify_stream_message::Item;
            let send = |item| proto::SimplifyStreamMessage { item: Some(item) };
            if tx.send(Ok(send(Item::Base(mesh_to_proto(pm.base()))))).await.is_err() {
                return;
            }
            for (i, chunk) in pm.splits().chunks(per_batch).enumerate() {
                let batch = proto::VertexSplitBatch {
                    first: (i * per_batch) as u32,
                    splits: chunk.iter().map(split_to_proto).collect(),
                };
                if tx.send(Ok(send(Item::Splits(batch)))).await.is_err() {
                    return; // the client went away
                }
            }
            let _ = tx.send(Ok(send(Item::Stats(stats)))).await;
        });
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn simplify_upload(
        &self,
        request: Request<tonic::Streaming<proto::MeshChunk>>,
    ) -> Result<Response<proto::SimplifyResponse>, Status> {
        let mut stream = request.into_inner();
        let limits = self.config.limits;
        let mut options = None;
        let mut mesh = proto::Mesh::default();
        while let Some(chunk) = stream.message().await? {
            if options.is_none() {
                options = Some(chunk.options.unwrap_or_default());
            }
            mesh.positions.extend_from_slice(&chunk.positions);
            mesh.indices.extend_from_slice(&chunk.indices);
            if mesh.positions.len() / 3 > limits.max_vertices || mesh.indices.len() / 3 > limits.max_faces {
                return Err(Status::invalid_argument(format!(
                    "input: mesh too large: the upload passed {} vertices or {} faces",
                    limits.max_vertices, limits.max_faces
                )));
            }
        }
        let request = proto::SimplifyRequest {
            input: Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh)) }),
            options,
        };
        self.simplify_unary("SimplifyUpload", request).await
    }

    async fn refine(&self, request: Request<proto::RefineRequest>) -> Result<Response<proto::RefineResponse>, Status> {
        let request = request.into_inner();
        let predictor = self.config.predictor.clone();
        let limits = self.config.limits;
        let response = self
            .run("Refine", move |cancel| {
                let mesh = mesh_from_input(request.input.as_ref(), "input", &limits)?;
                let mut request = request;
                if request.etc_auto {
                    let predictor = predictor.as_deref().ok_or_else(|| {
                        Status::failed_precondition("etc_auto: this server runs without a predictor model")
                    })?;
                    let target = request
                        .target_faces
                        .ok_or_else(|| Status::invalid_argument("target_faces: etc_auto needs a target face count"))?;
                    let advice = crate::predict::advise(predictor, &mesh, target as usize)
                        .map_err(|e| Status::internal(e.to_string()))?;
                    request.etc = Some(advice.etc);
                    request.target_faces = None;
                }
                let mode = match proto::RefineMode::try_from(request.mode) {
                    Ok(proto::RefineMode::Simplify) => RefineMode::Simplify,
                    Ok(proto::RefineMode::Subdivide) => RefineMode::Subdivide,
                    Ok(proto::RefineMode::Both) => RefineMode::Both,
                    Ok(proto::RefineMode::Unspecified) => match request.target_faces {
                        Some(n) if (n as usize) < mesh.face_count() => RefineMode::Simplify,
                        _ => RefineMode::Subdivide,
                    },
                    Err(_) => return Err(Status::invalid_argument(format!("mode: unknown value {}", request.mode))),
                };
                if request.etc.is_none() && request.target_faces.is_none() {
                    return Err(Status::invalid_argument("etc: give etc or target_faces"));
                }
                let options = RefineOptions {
                    etc: request.etc,
                    target_faces: request.target_faces.map(|n| n as usize),
                    mode,
                    rounds: request.rounds.unwrap_or(1),
                    cancel: Some(cancel),
                };
                let result = refine(&mesh, &options).map_err(|e| engine_status(e, "request"))?;
                if result.mesh.face_count() > limits.max_faces {
                    return Err(Status::invalid_argument(format!(
                        "rounds: the result would have {} faces, over the limit of {}",
                        result.mesh.face_count(),
                        limits.max_faces
                    )));
                }
                let s = &result.stats;
                Ok(proto::RefineResponse {
                    mesh: Some(mesh_to_proto(&result.mesh)),
                    stats: Some(proto::RefineStats {
                        faces_in: s.faces_in as u32,
                        faces_out: s.faces_out as u32,
                        etc: s.etc,
                        mode: format!("{:?}", s.mode).to_lowercase(),
                        split_edges: s.split_edges as u32,
                        collapses: s.collapses as u32,
                        seconds: s.seconds,
                    }),
                })
            })
            .await?;
        Ok(Response::new(response))
    }

    async fn hausdorff(
        &self,
        request: Request<proto::HausdorffRequest>,
    ) -> Result<Response<proto::HausdorffReport>, Status> {
        let request = request.into_inner();
        let limits = self.config.limits;
        let report = self
            .run("Hausdorff", move |cancel| {
                let mut options = convert::hausdorff_options(request.tolerance, request.samples)?;
                let a = mesh_from_input(request.a.as_ref(), "a", &limits)?;
                let b = mesh_from_input(request.b.as_ref(), "b", &limits)?;
                options.cancel = Some(cancel);
                // Each mesh checked on its own, so that the error names its field.
                for (mesh, field) in [(&a, "a"), (&b, "b")] {
                    check_surface(mesh).map_err(|e| Status::invalid_argument(format!("{field}: {e}")))?;
                }
                let d = hausdorff(&a, &b, &options).map_err(|e| engine_status(e, "request"))?;
                Ok(convert::hausdorff_to_proto(&d))
            })
            .await?;
        Ok(Response::new(report))
    }

    async fn predict(
        &self,
        request: Request<proto::PredictRequest>,
    ) -> Result<Response<proto::PredictResponse>, Status> {
        let request = request.into_inner();
        let limits = self.config.limits;
        let Some(predictor) = self.config.predictor.clone() else {
            self.metrics.record("Predict", tonic::Code::FailedPrecondition, std::time::Duration::ZERO);
            return Err(Status::failed_precondition("this server runs without a predictor model"));
        };
        let response = self
            .run("Predict", move |_cancel| {
                let subject = require(&request.subject, "subject")?;
                if let Some(r) = request.target_ratio
                    && !(0.0..1.0).contains(&r)
                {
                    return Err(Status::invalid_argument(format!("target_ratio: {r} is outside [0, 1)")));
                }
                let (shape, faces_in) = match subject {
                    proto::predict_request::Subject::Input(input) => {
                        let mesh = mesh_from_input(Some(input), "input", &limits)?;
                        (meshlod_engine::features::shape_features(&mesh), mesh.face_count())
                    }
                    proto::predict_request::Subject::Features(f) => {
                        let shape: [f32; 8] = f.values.as_slice().try_into().map_err(|_| {
                            Status::invalid_argument(format!(
                                "features.values: expected the 8 shape features {:?}, got {} values",
                                meshlod_engine::features::SHAPE_FEATURE_NAMES,
                                f.values.len()
                            ))
                        })?;
                        // Without a mesh, the face count comes from the target: faces and ratio.
                        let faces_in = request
                            .target_faces
                            .zip(request.target_ratio)
                            .map(|(t, r)| (t as f64 / (1.0 - r)).round() as usize)
                            .ok_or_else(|| {
                                Status::invalid_argument(
                                    "target_ratio: with features, give target_faces and target_ratio",
                                )
                            })?;
                        (shape, faces_in)
                    }
                };
                let target = crate::predict::target_faces(
                    faces_in,
                    request.target_faces.map(|n| n as usize),
                    request.target_ratio,
                )
                .ok_or_else(|| Status::invalid_argument("target_faces: give target_faces or target_ratio"))?;
                let advice = crate::predict::advise_features(&predictor, &shape, faces_in, target)
                    .map_err(|e| Status::invalid_argument(e.to_string()))?;
                Ok(proto::PredictResponse {
                    w: advice.w.w,
                    probabilities: advice.w.probabilities,
                    classes: advice.w.classes,
                    etc: advice.etc,
                    model_version: advice.model_version,
                })
            })
            .await?;
        Ok(Response::new(response))
    }
}

/// Checks the bearer token of every request when one is configured.
#[derive(Clone)]
pub struct TokenCheck(Option<Arc<str>>);

impl tonic::service::Interceptor for TokenCheck {
    fn call(&mut self, request: Request<()>) -> Result<Request<()>, Status> {
        let Some(expected) = &self.0 else { return Ok(request) };
        let given = request.metadata().get("authorization").and_then(|v| v.to_str().ok());
        match given.and_then(|v| v.strip_prefix("Bearer ")) {
            Some(token) if token.as_bytes() == expected.as_bytes() => Ok(request),
            Some(_) => Err(Status::unauthenticated("invalid bearer token")),
            None => Err(Status::unauthenticated("missing authorization: Bearer <token>")),
        }
    }
}

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
    let server = tonic::service::interceptor::InterceptedService::new(
        server,
        TokenCheck(config.token.as_deref().map(Arc::from)),
    );
    let mut builder = tonic::transport::Server::builder()
        .trace_fn(|request| tracing::info_span!("grpc", path = %request.uri().path()));
    if let Some((cert, key)) = &config.tls {
        let identity = tonic::transport::Identity::from_pem(std::fs::read(cert)?, std::fs::read(key)?);
        builder = builder.tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))?;
    }
    // No Nagle: small gRPC frames would otherwise wait for delayed ACKs (~40 ms per request).
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
