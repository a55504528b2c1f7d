//! The MeshLod RPCs: each reads its request's mesh (with the size limits), runs the operation
//! from `crate::jobs` in an admitted slot, and converts the result back. Nothing here checks an
//! option: the jobs do, once for every front end.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use meshlod_engine::hausdorff::{check_surface, hausdorff};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status};

use super::admission::Admission;
use super::codes;
use super::config::ServerConfig;
use crate::convert::{self, engine_error, mesh_from_input, mesh_to_proto, progressive_to_proto, split_to_proto};
use crate::jobs;
use crate::metrics::Metrics;
use crate::proto;
use crate::proto::mesh_lod_server::MeshLod;
use crate::stream_values::stream_values;

/// The MeshLod service.
#[derive(Clone)]
pub struct MeshLodService {
    config: Arc<ServerConfig>,
    admission: Arc<Admission>,
    metrics: Arc<Metrics>,
}

/// The outcome of one call, recorded once: when the call ends, or — when its future is dropped
/// first (the client cancelled, or its deadline passed) — as CANCELLED or DEADLINE_EXCEEDED.
struct Outcome<'a> {
    metrics: &'a Metrics,
    method: &'static str,
    started: Instant,
    deadline: Option<codes::CallDeadline>,
    recorded: bool,
}

impl<'a> Outcome<'a> {
    fn start(metrics: &'a Metrics, method: &'static str, deadline: Option<codes::CallDeadline>) -> Outcome<'a> {
        Outcome { metrics, method, started: Instant::now(), deadline, recorded: false }
    }

    fn record(&mut self, code: tonic::Code, message: &str) {
        self.recorded = true;
        let elapsed = self.started.elapsed();
        self.metrics.record(self.method, code, elapsed);
        if code == tonic::Code::Ok {
            tracing::info!(method = self.method, ms = elapsed.as_millis() as u64, "ok");
        } else {
            tracing::warn!(method = self.method, code = ?code, message, "refused or failed");
        }
    }

    fn finish<T>(mut self, result: &Result<T, Status>) {
        match result {
            Ok(_) => self.record(tonic::Code::Ok, ""),
            Err(s) => self.record(s.code(), s.message()),
        }
    }
}

impl Drop for Outcome<'_> {
    fn drop(&mut self) {
        if !self.recorded {
            let expired = self.deadline.is_some_and(|d| d.expired());
            let code = if expired { tonic::Code::DeadlineExceeded } else { tonic::Code::Cancelled };
            self.record(code, "the call ended before its work");
        }
    }
}

/// The call's deadline, as the transport layer read it ([`codes::CallDeadline`]).
fn deadline<T>(request: &Request<T>) -> Option<codes::CallDeadline> {
    request.extensions().get::<codes::CallDeadline>().copied()
}

impl MeshLodService {
    /// A service with its own admission control and metrics.
    pub fn new(config: ServerConfig, metrics: Arc<Metrics>) -> Self {
        let admission = Admission::new(config.max_concurrent, config.max_queue, metrics.clone());
        MeshLodService { config: Arc::new(config), admission: Arc::new(admission), metrics }
    }

    /// Runs `work` once admitted, and records its outcome (also when the call goes away first).
    async fn run<T: Send + 'static>(
        &self,
        method: &'static str,
        deadline: Option<codes::CallDeadline>,
        work: impl FnOnce(Arc<AtomicBool>) -> Result<T, Status> + Send + 'static,
    ) -> Result<T, Status> {
        let outcome = Outcome::start(&self.metrics, method, deadline);
        let result = self.admission.run(work).await;
        outcome.finish(&result);
        result
    }
    /// Reads the request's mesh and simplifies it; `progressive` forces the progressive mesh on.
    fn simplification(
        &self,
        request: proto::SimplifyRequest,
        progressive: bool,
    ) -> impl FnOnce(Arc<AtomicBool>) -> Result<jobs::Simplification, Status> + Send + 'static {
        let limits = self.config.limits;
        let predictor = self.config.predictor.clone();
        move |cancel| {
            let format = convert::output_format(request.output_format, "output_format")?;
            let write = convert::write_options(request.quantize_output, format)?;
            let mesh = mesh_from_input(request.input.as_ref(), "input", &limits, Some(cancel.clone()))?;
            let mut options = request.options.unwrap_or_default();
            options.return_progressive |= progressive;
            let request = jobs::SimplifyRequest::try_from(&options)?;
            let mut run = jobs::simplify(&mesh, &request, predictor.as_deref(), Some(cancel))?;
            run.encoded = convert::encode_mesh(&run.result.mesh, format, &write)?;
            Ok(run)
        }
    }

    /// One simplification answered in one message (Simplify and SimplifyUpload).
    async fn simplify_unary(
        &self,
        method: &'static str,
        deadline: Option<codes::CallDeadline>,
        request: proto::SimplifyRequest,
    ) -> Result<Response<proto::SimplifyResponse>, Status> {
        let run = self.run(method, deadline, self.simplification(request, false)).await?;
        Ok(Response::new(simplify_response(run)))
    }
}

fn simplify_response(run: jobs::Simplification) -> proto::SimplifyResponse {
    proto::SimplifyResponse {
        mesh: run.encoded.is_none().then(|| mesh_to_proto(&run.result.mesh)),
        progressive: run.result.progressive.as_ref().map(|pm| progressive_to_proto(pm, run.progressive_lossless)),
        stats: Some(run.stats),
        hausdorff: run.hausdorff,
        compare: run.compare,
        encoded: run.encoded,
    }
}

#[tonic::async_trait]
impl MeshLod for MeshLodService {
    async fn simplify(
        &self,
        request: Request<proto::SimplifyRequest>,
    ) -> Result<Response<proto::SimplifyResponse>, Status> {
        let deadline = deadline(&request);
        self.simplify_unary("Simplify", deadline, request.into_inner()).await
    }

    type SimplifyStreamStream = ReceiverStream<Result<proto::SimplifyStreamMessage, Status>>;

    async fn simplify_stream(
        &self,
        request: Request<proto::SimplifyRequest>,
    ) -> Result<Response<Self::SimplifyStreamStream>, Status> {
        let deadline = deadline(&request);
        let run = self.run("SimplifyStream", deadline, self.simplification(request.into_inner(), true)).await?;
        let pm = run.result.progressive.expect("progressive forced on");
        let stats = run.stats;
        // Batches of whole splits, each message under the configured size (a split is ~20–40 bytes
        // encoded, more with the values it brings).
        let limit = self.config.stream_message_bytes.saturating_sub(64).max(1);
        let (tx, rx) = mpsc::channel(4);
        tokio::spawn(async move {
            use proto::simplify_stream_message::Item;
            let send = |item| proto::SimplifyStreamMessage { item: Some(item) };
            if tx.send(Ok(send(Item::Base(convert::pm_base_to_proto(&pm))))).await.is_err() {
                return;
            }
            // With attributes: the base's corner values next, then each split's with the split.
            let (base_values, mut split_values) = match stream_values(&pm) {
                Some((base, splits)) => (Some(base), splits.into_iter().map(Some).collect()),
                None => (None, vec![None; pm.levels()]),
            };
            if let Some(base) = base_values
                && tx.send(Ok(send(Item::BaseCorners(base)))).await.is_err()
            {
                return;
            }
            let mut batch = proto::VertexSplitBatch::default();
            let mut size = 0;
            for (j, (s, values)) in pm.splits().iter().zip(&mut split_values).enumerate() {
                let split = proto::VertexSplit { corners: values.take(), ..split_to_proto(s) };
                let bytes = prost::Message::encoded_len(&split) + 4;
                if !batch.splits.is_empty() && size + bytes > limit {
                    let full =
                        std::mem::replace(&mut batch, proto::VertexSplitBatch { first: j as u32, splits: Vec::new() });
                    if tx.send(Ok(send(Item::Splits(full)))).await.is_err() {
                        return; // the client went away
                    }
                    size = 0;
                }
                size += bytes;
                batch.splits.push(split);
            }
            if !batch.splits.is_empty() && tx.send(Ok(send(Item::Splits(batch)))).await.is_err() {
                return;
            }
            let _ = tx.send(Ok(send(Item::Stats(stats)))).await;
        });
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn simplify_upload(
        &self,
        request: Request<tonic::Streaming<proto::MeshChunk>>,
    ) -> Result<Response<proto::SimplifyResponse>, Status> {
        let mut outcome = Outcome::start(&self.metrics, "SimplifyUpload", deadline(&request));
        // A slot first: an upload is buffered only once it may run, so uploads waiting for a slot
        // hold no memory, and at most `max_concurrent` are buffered at once.
        let admitted = match self.admission.admit().await {
            Ok(a) => a,
            Err(s) => {
                outcome.record(s.code(), s.message());
                return Err(s);
            }
        };
        let mut stream = request.into_inner();
        let limits = self.config.limits;
        let mut options = None;
        let mut mesh = proto::Mesh::default();
        let received: Result<(), Status> = async {
            while let Some(chunk) = stream.message().await.map_err(codes::contract_status)? {
                if options.is_none() {
                    options = Some(chunk.options.unwrap_or_default());
                }
                if (mesh.positions.len() + chunk.positions.len()) / 3 > limits.max_vertices
                    || (mesh.indices.len() + chunk.indices.len()) / 3 > limits.max_faces
                {
                    return Err(Status::invalid_argument(format!(
                        "input: mesh too large: the upload passed {} vertices or {} faces",
                        limits.max_vertices, limits.max_faces
                    )));
                }
                mesh.positions.extend_from_slice(&chunk.positions);
                mesh.indices.extend_from_slice(&chunk.indices);
            }
            Ok(())
        }
        .await;
        if let Err(s) = received {
            outcome.record(s.code(), s.message());
            return Err(s);
        }
        let request = proto::SimplifyRequest {
            input: Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh)) }),
            options,
            ..Default::default()
        };
        let result = admitted.run(self.simplification(request, false)).await;
        outcome.finish(&result);
        Ok(Response::new(simplify_response(result?)))
    }

    async fn refine(&self, request: Request<proto::RefineRequest>) -> Result<Response<proto::RefineResponse>, Status> {
        let deadline = deadline(&request);
        let request = request.into_inner();
        let predictor = self.config.predictor.clone();
        let limits = self.config.limits;
        let response = self
            .run("Refine", deadline, move |cancel| {
                let format = convert::output_format(request.output_format, "output_format")?;
                let write = convert::write_options(request.quantize_output, format)?;
                let job = jobs::RefineRequest::try_from(&request)?;
                let mesh = mesh_from_input(request.input.as_ref(), "input", &limits, Some(cancel.clone()))?;
                let (result, stats) = jobs::refine(&mesh, &job, predictor.as_deref(), Some(cancel), limits.max_faces)?;
                let encoded = convert::encode_mesh(&result.mesh, format, &write)?;
                Ok(proto::RefineResponse {
                    mesh: encoded.is_none().then(|| mesh_to_proto(&result.mesh)),
                    stats: Some(stats),
                    encoded,
                })
            })
            .await?;
        Ok(Response::new(response))
    }

    async fn hausdorff(
        &self,
        request: Request<proto::HausdorffRequest>,
    ) -> Result<Response<proto::HausdorffReport>, Status> {
        let deadline = deadline(&request);
        let request = request.into_inner();
        let limits = self.config.limits;
        let report = self
            .run("Hausdorff", deadline, move |cancel| {
                let mut options = convert::hausdorff_options(request.tolerance, request.samples)?;
                let a = mesh_from_input(request.a.as_ref(), "a", &limits, Some(cancel.clone()))?;
                let b = mesh_from_input(request.b.as_ref(), "b", &limits, Some(cancel.clone()))?;
                options.cancel = Some(cancel);
                // Each mesh checked on its own, so that the error names its field.
                for (mesh, field) in [(&a, "a"), (&b, "b")] {
                    check_surface(mesh).map_err(|e| Status::invalid_argument(format!("{field}: {e}")))?;
                }
                let d = hausdorff(&a, &b, &options).map_err(|e| Status::from(engine_error(e, "")))?;
                Ok(convert::hausdorff_to_proto(&d))
            })
            .await?;
        Ok(Response::new(report))
    }

    async fn predict(
        &self,
        request: Request<proto::PredictRequest>,
    ) -> Result<Response<proto::PredictResponse>, Status> {
        let deadline = deadline(&request);
        let request = request.into_inner();
        let limits = self.config.limits;
        let Some(predictor) = self.config.predictor.clone() else {
            self.metrics.record("Predict", tonic::Code::FailedPrecondition, std::time::Duration::ZERO);
            return Err(Status::failed_precondition("this server runs without a predictor model"));
        };
        let response = self
            .run("Predict", deadline, move |cancel| {
                let subject = request.subject.as_ref().ok_or_else(|| Status::invalid_argument("subject: missing"))?;
                match subject {
                    proto::predict_request::Subject::Input(input) => {
                        let mesh = mesh_from_input(Some(input), "input", &limits, Some(cancel.clone()))?;
                        jobs::predict_mesh(&predictor, &mesh, request.target_faces, request.target_ratio)
                            .map_err(Status::from)
                    }
                    proto::predict_request::Subject::Features(f) => {
                        let shape = jobs::features_from_proto(f)?;
                        // Without a mesh, the face count comes from the target: faces and ratio.
                        let (Some(t), Some(r)) = (request.target_faces, request.target_ratio) else {
                            return Err(Status::invalid_argument(
                                "target_ratio: with features, give target_faces and target_ratio",
                            ));
                        };
                        if !(0.0..1.0).contains(&r) {
                            return Err(Status::invalid_argument(format!("target_ratio: {r} is outside [0, 1)")));
                        }
                        let faces_in = (t as f64 / (1.0 - r)).round() as usize;
                        jobs::predict(&predictor, &shape, faces_in, Some(t), None).map_err(Status::from)
                    }
                }
            })
            .await?;
        Ok(Response::new(response))
    }
}
