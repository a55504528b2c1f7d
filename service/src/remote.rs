//! `meshlod serve` and `meshlod client`: the server's command line, and a client that speaks the
//! same flags as the local commands.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use meshlod_engine::io::{read_mesh, write_mesh};
use meshlod_service::convert::{MeshLimits, mesh_from_proto, mesh_to_proto};
use meshlod_service::proto;
use meshlod_service::proto::mesh_lod_client::MeshLodClient;
use meshlod_service::server::{ServerConfig, serve_with_listener, shutdown_signal};
use serde_json::json;
use tonic::codec::CompressionEncoding;
use tonic::transport::{Channel, Endpoint};

use crate::commands::{
    Auto, BoundaryArg, MetricArg, ModeArg, NormalsArg, PlacementArg, RefineArgs, SimplifyArgs, WArg,
};

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum LogFormat {
    Text,
    Json,
}

/// `meshlod serve` flags; every one has an environment variable for container deployments.
#[derive(Debug, Args)]
pub(crate) struct ServeArgs {
    /// gRPC listen address.
    #[arg(long, env = "MESHLOD_LISTEN", default_value = "127.0.0.1:50051")]
    listen: SocketAddr,
    /// Prometheus metrics listen address (`/metrics`); empty to disable.
    #[arg(long, env = "MESHLOD_METRICS_LISTEN", default_value = "127.0.0.1:9090")]
    metrics_listen: String,
    /// Heavy requests running at once (default: the number of cores).
    #[arg(long, env = "MESHLOD_MAX_CONCURRENT")]
    max_concurrent: Option<usize>,
    /// Heavy requests waiting at once before RESOURCE_EXHAUSTED (default: twice the cores).
    #[arg(long, env = "MESHLOD_MAX_QUEUE")]
    max_queue: Option<usize>,
    /// Largest gRPC message, MiB.
    #[arg(long, env = "MESHLOD_MAX_MESSAGE_MIB", default_value_t = 256)]
    max_message_mib: usize,
    /// Largest mesh accepted, in faces.
    #[arg(long, env = "MESHLOD_MAX_FACES", default_value_t = MeshLimits::default().max_faces)]
    max_faces: usize,
    /// TLS certificate (PEM); with --tls-key enables TLS.
    #[arg(long, env = "MESHLOD_TLS_CERT", requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// TLS private key (PEM).
    #[arg(long, env = "MESHLOD_TLS_KEY", requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// Require `authorization: Bearer <token>` on every MeshLod call.
    #[arg(long, env = "MESHLOD_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Log format.
    #[arg(long, env = "MESHLOD_LOG_FORMAT", value_enum, default_value_t = LogFormat::Text)]
    log_format: LogFormat,
    /// Predictor model folder (predictor.onnx + metadata.json); default: the model built in.
    #[arg(long, env = "MESHLOD_MODEL_DIR")]
    model_dir: Option<PathBuf>,
}

fn init_logging(format: LogFormat) {
    let filter = tracing_subscriber::EnvFilter::try_from_env("MESHLOD_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr);
    let _ = match format {
        LogFormat::Text => builder.try_init(),
        LogFormat::Json => builder.json().try_init(),
    };
}

/// Runs the server until SIGTERM or Ctrl-C.
pub(crate) fn serve(args: ServeArgs) -> Result<()> {
    init_logging(args.log_format);
    let defaults = ServerConfig::default();
    let metrics_listen = if args.metrics_listen.trim().is_empty() {
        None
    } else {
        Some(args.metrics_listen.parse().with_context(|| format!("--metrics-listen {}", args.metrics_listen))?)
    };
    let predictor = meshlod_service::predict::load(args.model_dir.as_deref()).context("loading the predictor model")?;
    tracing::info!(model = %predictor.metadata().model_version, "predictor loaded");
    let config = ServerConfig {
        predictor: Some(std::sync::Arc::new(predictor)),
        listen: args.listen,
        metrics_listen,
        max_concurrent: args.max_concurrent.unwrap_or(defaults.max_concurrent),
        max_queue: args.max_queue.unwrap_or(defaults.max_queue),
        max_message_bytes: args.max_message_mib << 20,
        limits: MeshLimits { max_faces: args.max_faces, max_vertices: args.max_faces },
        tls: args.tls_cert.zip(args.tls_key),
        token: args.token,
        ..defaults
    };
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(async move {
        let listener =
            tokio::net::TcpListener::bind(config.listen).await.with_context(|| format!("binding {}", config.listen))?;
        serve_with_listener(listener, config, shutdown_signal()).await.map_err(|e| anyhow::anyhow!(e))
    })
}

/// `meshlod client` flags.
#[derive(Debug, Args)]
pub(crate) struct ClientArgs {
    /// Server address.
    #[arg(long, env = "MESHLOD_SERVER", default_value = "http://127.0.0.1:50051")]
    server: String,
    /// Bearer token, if the server requires one.
    #[arg(long, env = "MESHLOD_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Deadline of the call, seconds.
    #[arg(long, default_value_t = 600.0)]
    timeout: f64,
    #[command(subcommand)]
    operation: ClientOperation,
}

#[derive(Debug, Subcommand)]
pub(crate) enum ClientOperation {
    /// Simplify on the server (flags as `meshlod simplify`).
    Simplify(SimplifyArgs),
    /// Refine on the server (flags as `meshlod refine`).
    Refine(RefineArgs),
    /// Ask the server's predictor for w and ETC.
    Predict {
        /// Input mesh.
        input: PathBuf,
        /// Fraction of faces to remove.
        #[arg(long)]
        ratio: Option<f64>,
        /// Faces to keep.
        #[arg(long)]
        faces: Option<u32>,
    },
}

/// A connected client with the service's limits and compression.
pub(crate) async fn connect(server: &str, timeout: f64) -> Result<MeshLodClient<Channel>> {
    let endpoint = Endpoint::from_shared(server.to_string())
        .with_context(|| format!("server address {server}"))?
        .timeout(Duration::from_secs_f64(timeout))
        .connect_timeout(Duration::from_secs(10));
    let channel = endpoint.connect().await.with_context(|| format!("connecting to {server}"))?;
    Ok(MeshLodClient::new(channel)
        .max_decoding_message_size(usize::MAX)
        .max_encoding_message_size(usize::MAX)
        .send_compressed(CompressionEncoding::Gzip)
        .accept_compressed(CompressionEncoding::Gzip))
}

fn with_token<T>(message: T, token: &Option<String>) -> Result<tonic::Request<T>> {
    let mut request = tonic::Request::new(message);
    if let Some(t) = token {
        request.metadata_mut().insert("authorization", format!("Bearer {t}").parse().context("token")?);
    }
    Ok(request)
}

fn input_of(path: &std::path::Path) -> Result<proto::MeshInput> {
    let mesh = read_mesh(path)?;
    Ok(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(mesh_to_proto(&mesh))) })
}

/// The contract's options for the CLI's simplify flags.
pub(crate) fn simplify_request(args: &SimplifyArgs) -> Result<proto::SimplifyRequest> {
    Ok(proto::SimplifyRequest {
        input: Some(input_of(&args.input)?),
        options: Some(proto::SimplifyOptions {
            target_faces: args.faces.map(|n| n as u32),
            target_ratio: args.ratio,
            max_error: args.max_error,
            metric: match args.metric {
                MetricArg::Qfvp => proto::Metric::Qfvp,
                MetricArg::Qem => proto::Metric::Qem,
                MetricArg::Melax => proto::Metric::Melax,
            } as i32,
            w: match args.w {
                WArg::Value(w) => Some(w),
                WArg::Auto | WArg::Search => None,
            },
            w_auto: args.w == WArg::Auto,
            w_search: args.w == WArg::Search,
            guard: (args.guard != 0.0).then_some(args.guard),
            placement: match args.placement {
                PlacementArg::Optimal => proto::Placement::Optimal,
                PlacementArg::Paper => proto::Placement::Paper,
                PlacementArg::Endpoint => proto::Placement::Endpoint,
            } as i32,
            normals: match args.normals {
                NormalsArg::Linear => proto::NormalUpdate::Linear,
                NormalsArg::Recompute => proto::NormalUpdate::Recompute,
            } as i32,
            boundary: match args.boundary {
                BoundaryArg::Preserve => proto::BoundaryMode::Preserve,
                BoundaryArg::Lock => proto::BoundaryMode::Lock,
            } as i32,
            max_normal_change_degrees: Some(args.max_normal_change),
            return_progressive: false,
            compute_hausdorff: args.hausdorff,
        }),
    })
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

/// Runs one simplification on the server and writes its output; returns the JSON report.
pub(crate) async fn remote_simplify(
    client: &mut MeshLodClient<Channel>,
    args: &SimplifyArgs,
    token: &Option<String>,
) -> Result<serde_json::Value> {
    let request = simplify_request(args)?;
    let response = match &request.input {
        // Meshes over 32 MiB go up in 1 MiB chunks (SimplifyUpload) instead of one message.
        Some(proto::MeshInput { source: Some(proto::mesh_input::Source::Mesh(m)) })
            if 4 * (m.positions.len() + m.indices.len()) > UPLOAD_ABOVE_BYTES =>
        {
            let chunks = chunked(m, request.options);
            client.simplify_upload(with_token(tokio_stream::iter(chunks), token)?).await?.into_inner()
        }
        _ => client.simplify(with_token(request, token)?).await?.into_inner(),
    };
    let mesh =
        mesh_from_proto(response.mesh.as_ref().context("response without mesh")?, "mesh", &MeshLimits::default())?;
    write_mesh(&args.output, &mesh)?;
    let stats = response.stats.unwrap_or_default();
    let mut report = json!({
        "faces_in": stats.faces_in, "faces_out": stats.faces_out, "metric": stats.metric, "w": stats.w,
        "guard": stats.guard,
        "seconds": stats.seconds, "stop_reason": stats.stop_reason, "collapses": stats.collapses,
    });
    if let Some(h) = response.hausdorff {
        for (key, value) in crate::commands::hausdorff_json(&h) {
            report[key] = value;
        }
    }
    Ok(report)
}

/// Runs one refinement on the server and writes its output; returns the JSON report.
pub(crate) async fn remote_refine(
    client: &mut MeshLodClient<Channel>,
    args: &RefineArgs,
    token: &Option<String>,
) -> Result<serde_json::Value> {
    let mode = match args.mode {
        None => proto::RefineMode::Unspecified,
        Some(ModeArg::Simplify) => proto::RefineMode::Simplify,
        Some(ModeArg::Subdivide) => proto::RefineMode::Subdivide,
        Some(ModeArg::Both) => proto::RefineMode::Both,
    };
    let request = proto::RefineRequest {
        input: Some(input_of(&args.input)?),
        etc: match args.etc {
            Some(Auto::Value(e)) => Some(e),
            _ => None,
        },
        target_faces: args.faces.map(|n| n as u32),
        etc_auto: args.etc == Some(Auto::Auto),
        mode: mode as i32,
        rounds: Some(args.rounds),
    };
    let response = client.refine(with_token(request, token)?).await?.into_inner();
    let mesh =
        mesh_from_proto(response.mesh.as_ref().context("response without mesh")?, "mesh", &MeshLimits::default())?;
    write_mesh(&args.output, &mesh)?;
    let s = response.stats.unwrap_or_default();
    Ok(json!({"faces_in": s.faces_in, "faces_out": s.faces_out, "etc": s.etc, "mode": s.mode, "seconds": s.seconds}))
}

/// Runs one client command.
pub(crate) fn client(args: ClientArgs) -> Result<()> {
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(async move {
        let mut client = connect(&args.server, args.timeout).await?;
        let report = match &args.operation {
            ClientOperation::Simplify(a) => remote_simplify(&mut client, a, &args.token).await?,
            ClientOperation::Refine(a) => remote_refine(&mut client, a, &args.token).await?,
            ClientOperation::Predict { input, ratio, faces } => {
                if ratio.is_none() && faces.is_none() {
                    bail!("give --ratio or --faces");
                }
                let request = proto::PredictRequest {
                    subject: Some(proto::predict_request::Subject::Input(input_of(input)?)),
                    target_faces: *faces,
                    target_ratio: *ratio,
                };
                let r = client.predict(with_token(request, &args.token)?).await?.into_inner();
                json!({"w": r.w, "probabilities": r.probabilities, "classes": r.classes, "etc": r.etc, "model_version": r.model_version})
            }
        };
        println!("{}", serde_json::to_string_pretty(&report)?);
        Ok(())
    })
}
