//! A client of a meshlod server: one connection, reused by every job of a batch, and the
//! [`Executor`] that sends jobs to it. Inputs are read and outputs written here, so a remote job
//! takes the same files and gives the same report as a local one.

use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use tonic::codec::CompressionEncoding;
use tonic::transport::{Channel, Endpoint};

use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes, write_mesh_to};

use crate::convert::{MeshLimits, mesh_from_proto, mesh_to_proto, progressive_from_proto};
use crate::executor::{
    Executor, PredictJob, RefineJob, SimplifyJob, check_simplify_outputs, finish_refine, finish_simplify, load,
};
use crate::proto;
use crate::proto::mesh_lod_client::MeshLodClient;
use crate::report::{self, PredictReport, RefineReport, SimplifyReport};

/// The server address as tonic wants it: `host:port` gains `http://`.
pub fn endpoint_uri(server: &str) -> String {
    if server.contains("://") { server.to_string() } else { format!("http://{server}") }
}

/// A channel to `server` (`http://host:port`, `https://…` or plain `host:port`); `timeout` is each
/// call's deadline.
pub async fn channel(server: &str, timeout: Duration) -> Result<Channel> {
    let uri = endpoint_uri(server);
    let endpoint = Endpoint::from_shared(uri.clone())
        .with_context(|| format!("server address {server}"))?
        .timeout(timeout)
        .connect_timeout(Duration::from_secs(10));
    endpoint.connect().await.with_context(|| format!("connecting to {uri}"))
}

/// A MeshLod client on `channel` with the service's limits and compression.
pub fn mesh_lod(channel: Channel) -> MeshLodClient<Channel> {
    MeshLodClient::new(channel)
        .max_decoding_message_size(usize::MAX)
        .max_encoding_message_size(usize::MAX)
        .send_compressed(CompressionEncoding::Gzip)
        .accept_compressed(CompressionEncoding::Gzip)
}

/// Asks the server's standard health service (grpc.health.v1) whether `service` ("" for the
/// whole server) is serving.
pub async fn health(server: &str, service: &str, timeout: Duration) -> Result<()> {
    use tonic_health::pb::health_check_response::ServingStatus;
    use tonic_health::pb::health_client::HealthClient;
    let mut client = HealthClient::new(channel(server, timeout).await?);
    let response = client
        .check(tonic_health::pb::HealthCheckRequest { service: service.to_string() })
        .await
        .with_context(|| format!("health check of {server}"))?
        .into_inner();
    match ServingStatus::try_from(response.status) {
        Ok(ServingStatus::Serving) => Ok(()),
        other => anyhow::bail!("{server}: not serving ({other:?})"),
    }
}

/// Meshes whose positions and indices exceed this many bytes are uploaded in chunks.
const UPLOAD_ABOVE_BYTES: usize = 32 << 20;
/// Values (floats or indices) per upload chunk: 1 MiB of each.
const CHUNK_VALUES: usize = 1 << 18;

/// Splits a mesh into upload chunks; the options travel with the first.
fn chunked(mesh: &proto::Mesh, options: Option<proto::SimplifyOptions>) -> Vec<proto::MeshChunk> {
    let count = mesh.positions.len().max(mesh.indices.len()).div_ceil(CHUNK_VALUES).max(1);
    (0..count)
        .map(|i| {
            let range = |len: usize| (i * CHUNK_VALUES).min(len)..((i + 1) * CHUNK_VALUES).min(len);
            proto::MeshChunk {
                options: if i == 0 { options } else { None },
                positions: mesh.positions[range(mesh.positions.len())].to_vec(),
                indices: mesh.indices[range(mesh.indices.len())].to_vec(),
            }
        })
        .collect()
}

/// Runs jobs on a server over one connection. Its methods block on its own runtime, so it can be
/// used from plain threads (a batch's workers), not from inside another async runtime.
pub struct Remote {
    runtime: tokio::runtime::Runtime,
    client: MeshLodClient<Channel>,
    token: Option<Arc<str>>,
}

impl Remote {
    /// Connects to `server`; `timeout` is each call's deadline.
    pub fn connect(server: &str, token: Option<String>, timeout: Duration) -> Result<Remote> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .context("starting the async runtime")?;
        let client = mesh_lod(runtime.block_on(channel(server, timeout))?);
        Ok(Remote { runtime, client, token: token.map(Arc::from) })
    }

    fn request<T>(&self, message: T) -> Result<tonic::Request<T>> {
        let mut request = tonic::Request::new(message);
        if let Some(t) = &self.token {
            request.metadata_mut().insert("authorization", format!("Bearer {t}").parse().context("token")?);
        }
        Ok(request)
    }
}

/// How a mesh goes up: as a `Mesh` message, or, when it has materials (which that message cannot
/// carry), as a GLB file with its materials, textures and images; then the result is asked for as
/// GLB too (the second value), so that it comes back with them.
fn input_of(mesh: &meshlod_engine::Mesh) -> Result<(proto::MeshInput, Option<proto::MeshFormat>)> {
    if mesh.corners.materials().is_none() || mesh.corners.library.is_none() {
        return Ok((proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh_to_proto(mesh))) }, None));
    }
    let mut data = Vec::new();
    write_mesh_to(&mut data, mesh, MeshFormat::Gltf).context("encoding the input as GLB")?;
    let file = proto::EncodedMesh { data, format: proto::MeshFormat::Gltf as i32 };
    Ok((proto::MeshInput { source: Some(proto::mesh_input::Source::File(file)) }, Some(proto::MeshFormat::Gltf)))
}

/// The result of a response: its `encoded` file when there is one, else its `mesh`.
fn output_of(mesh: Option<&proto::Mesh>, encoded: Option<&proto::EncodedMesh>) -> Result<meshlod_engine::Mesh> {
    if let Some(file) = encoded {
        let name = std::path::Path::new("response.glb");
        return Ok(read_mesh_bytes(&file.data, Some(MeshFormat::Gltf), name, &ReadLimits::default())?);
    }
    Ok(mesh_from_proto(mesh.context("response without mesh")?, "mesh", &MeshLimits::default())?)
}

/// Inserts at `at` the input file's own warnings (what it had that a result does not carry, what
/// was mended on reading) that the server's `warnings` do not already hold.
fn add_input_warnings(warnings: &mut Vec<String>, input: &meshlod_engine::Mesh, at: usize) {
    let missing: Vec<String> = input.corners.input_warnings().filter(|w| !warnings.contains(w)).collect();
    warnings.splice(at..at, missing);
}

/// A status from the server as the job error it stands for, said to come from the server.
fn status_error(status: tonic::Status) -> anyhow::Error {
    anyhow::Error::new(crate::convert::error_from_status(&status)).context("server")
}

impl Executor for Remote {
    fn simplify(&self, job: &SimplifyJob) -> Result<SimplifyReport> {
        check_simplify_outputs(job)?;
        let mesh = load(&job.input)?;
        let request = job.request();
        let options = proto::SimplifyOptions::from(&request);
        let mut client = self.client.clone();
        let response = self.runtime.block_on(async {
            // Meshes over 32 MiB go up in 1 MiB chunks (SimplifyUpload) instead of one message:
            // positions and indices only, as that call takes them.
            if 12 * mesh.vertex_count() + 12 * mesh.face_count() > UPLOAD_ABOVE_BYTES {
                let chunks = chunked(&mesh_to_proto(&mesh), Some(options));
                client.simplify_upload(self.request(tokio_stream::iter(chunks))?).await.map_err(status_error)
            } else {
                let (input, output_format) = input_of(&mesh)?;
                let request = proto::SimplifyRequest {
                    input: Some(input),
                    options: Some(options),
                    output_format: output_format.map_or(0, |f| f as i32),
                    // The result is written here (`job.write`), from the exact values.
                    quantize_output: false,
                };
                client.simplify(self.request(request)?).await.map_err(status_error)
            }
        })?;
        let response = response.into_inner();
        let out = output_of(response.mesh.as_ref(), response.encoded.as_ref())?;
        let pm_file = response.progressive.as_ref().map(|pm| pm.file.as_slice()).filter(|f| !f.is_empty());
        let progressive = match &response.progressive {
            // With attributes the server sends the `.pm` file too: written as it came, the same
            // bytes as a local run.
            Some(pm) if !pm.file.is_empty() => {
                Some(meshlod_engine::pm_format::decode(&pm.file, std::path::Path::new("response.pm"))?.0)
            }
            Some(pm) => {
                Some(progressive_from_proto(pm.base.as_ref().context("progressive mesh without base")?, &pm.splits)?)
            }
            None => None,
        };
        let mut stats = response.stats.unwrap_or_default();
        // What the input file had that the mesh sent up could not say (the server reads the mesh,
        // not the file), where a local run says it: after the options' warnings.
        let after = crate::jobs::simplify_warnings(&request).len().min(stats.warnings.len());
        add_input_warnings(&mut stats.warnings, &mesh, after);
        let measured = (response.hausdorff.as_ref(), response.compare.as_ref());
        finish_simplify(job, &out, progressive.as_ref(), pm_file, &stats, measured)
    }

    fn refine(&self, job: &RefineJob) -> Result<RefineReport> {
        job.write.check(meshlod_engine::io::output_format(&job.output)?)?;
        let mesh = load(&job.input)?;
        let (input, output_format) = input_of(&mesh)?;
        let request = proto::RefineRequest {
            input: Some(input),
            output_format: output_format.map_or(0, |f| f as i32),
            ..proto::RefineRequest::from(&job.request)
        };
        let mut client = self.client.clone();
        let response = self
            .runtime
            .block_on(async { client.refine(self.request(request)?).await.map_err(status_error) })?
            .into_inner();
        let out = output_of(response.mesh.as_ref(), response.encoded.as_ref())?;
        let mut stats = response.stats.unwrap_or_default();
        let end = stats.warnings.len();
        add_input_warnings(&mut stats.warnings, &mesh, end);
        finish_refine(job, &out, &stats)
    }

    fn predict(&self, job: &PredictJob) -> Result<PredictReport> {
        let mesh = load(&job.input)?;
        let request = proto::PredictRequest {
            subject: Some(proto::predict_request::Subject::Input(input_of(&mesh)?.0)),
            target_faces: job.target_faces,
            target_ratio: job.target_ratio,
        };
        let mut client = self.client.clone();
        let response = self
            .runtime
            .block_on(async { client.predict(self.request(request)?).await.map_err(status_error) })?
            .into_inner();
        Ok(report::predict(&response))
    }
}
