//! The command line: every subcommand's flags, and how they become jobs. No work is done here.
//!
//! The simplify, refine and predict flags are one set of structs, used by the local commands,
//! by `meshlod client` and by batch manifests; they map onto the contract's options in one place
//! ([`SimplifyArgs::job`]), and the contract's options onto the engine's in one other
//! (`meshlod_service::convert`), where the engine's defaults fill what is not given.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Parser, Subcommand, ValueEnum};
use meshlod_engine::compare::CompareOptions;
use meshlod_engine::hausdorff::HausdorffOptions;
use meshlod_engine::io::WriteOptions;
use meshlod_service::convert::MeshLimits;
use meshlod_service::executor::{PredictJob, RefineJob, SimplifyJob};
use meshlod_service::proto;
use meshlod_service::request::{EtcChoice, RefineRequest, SimplifyRequest, WChoice};

use crate::samples::SamplesArgs;

/// meshlod: progressive meshes and levels of detail for heavy triangle meshes, from the command
/// line, as a gRPC server, or as its client.
#[derive(Debug, Parser)]
#[command(name = "meshlod", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// How `compare` renders (also `simplify --compare`).
#[derive(Debug, Clone, Args)]
pub struct CompareArgs {
    /// Number of views, spread over the sphere around A.
    #[arg(long, default_value_t = CompareOptions::DEFAULT_VIEWS)]
    pub views: usize,
    /// Width and height of each view, in pixels.
    #[arg(long, default_value_t = CompareOptions::DEFAULT_SIZE)]
    pub size: usize,
    /// Write the pictures as a PNG: a row per view, A | B | their difference as a heat map.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Leave out the Hausdorff distance (pixels only).
    #[arg(long)]
    pub no_hausdorff: bool,
}

impl CompareArgs {
    /// The engine's options.
    pub fn options(&self) -> CompareOptions {
        CompareOptions { views: self.views, size: self.size, hausdorff: !self.no_hausdorff }
    }
}

/// Every subcommand.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print a validation report: counts, bounding box, degenerate/duplicate faces, manifoldness;
    /// and, as warnings, what a result written from the file would not carry.
    Info {
        /// Mesh file (.obj, .ply, .stl, .off, .gltf or .glb).
        file: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Convert a mesh between formats (in: OBJ, PLY, STL, OFF, glTF, GLB; out: OBJ, PLY, glTF, GLB;
    /// formats from the extensions).
    Convert {
        /// Input mesh.
        input: PathBuf,
        /// Output mesh (.obj, binary .ply, .gltf or .glb); the form without `-o` is accepted too.
        #[arg(short, long = "output", value_name = "OUTPUT", required_unless_present = "output_positional")]
        output: Option<PathBuf>,
        /// The output as a second positional argument (`convert IN OUT`), as older scripts call it.
        #[arg(value_name = "OUTPUT", conflicts_with = "output", hide = true)]
        output_positional: Option<PathBuf>,
        /// Weld coincident vertices, drop degenerate/duplicate faces and unreferenced vertices.
        #[arg(long)]
        clean: bool,
        /// Write positions only: leave out normals, texture coordinates and colours (a geometry-only
        /// copy; simplifying it then ignores the input's seams).
        #[arg(long)]
        drop_attributes: bool,
        #[command(flatten)]
        write: WriteArgs,
    },
    /// Symmetric Hausdorff distance between two meshes, with certified lower and upper bounds
    /// (units relative to A).
    Hausdorff {
        /// Reference mesh A (its bounding box defines the units).
        a: PathBuf,
        /// Mesh B.
        b: PathBuf,
        /// Relative gap allowed between the bounds: stop when upper ≤ lower · (1 + tolerance).
        #[arg(long, default_value_t = HausdorffOptions::DEFAULT_TOLERANCE)]
        tolerance: f64,
        /// Face samples per direction for the area-weighted mean and RMS (default: half the
        /// larger vertex count, at least 10000).
        #[arg(long)]
        samples: Option<usize>,
        /// Seed of the face sampler.
        #[arg(long, default_value_t = HausdorffOptions::default().seed)]
        seed: u64,
        /// Only the one-sided distance from A's surface to B's, its bounds met within the tolerance
        /// (the symmetric search proves the smaller direction only below the larger one).
        #[arg(long)]
        directed: bool,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Compare two meshes as a viewer sees them: both rendered from the same views around A with
    /// their textures, vertex colours and normals, and the pictures compared pixel by pixel
    /// (mean difference, PSNR, silhouette), beside the certified Hausdorff distance.
    Compare {
        /// Reference mesh A (the views are around it; its bounding box defines the units).
        a: PathBuf,
        /// Mesh B (a LOD of A, say).
        b: PathBuf,
        #[command(flatten)]
        compare: CompareArgs,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Write a procedurally generated mesh (for trying meshlod without data).
    Generate {
        /// Which shape.
        #[arg(value_enum)]
        shape: Shape,
        /// Output mesh (.obj, .ply, .gltf or .glb).
        #[arg(short, long)]
        output: PathBuf,
        /// Resolution: subdivision level for the sphere (at most 9; default 6: 81 920 faces), grid
        /// steps for the others (default 64: 8 192 to 49 152 faces).
        #[arg(long)]
        resolution: Option<u32>,
    },
    /// Simplify by edge collapse (QFVP, QEM or Melax), optionally writing a progressive mesh.
    Simplify(SimplifyArgs),
    /// Energy-operator LOD: collapse low-energy faces and/or subdivide high-energy ones.
    Refine(RefineArgs),
    /// Extract one level of detail from a progressive mesh (.pm).
    Lod {
        /// Progressive mesh written by `meshlod simplify --pm`.
        input: PathBuf,
        /// Output mesh (.obj, .ply, .gltf or .glb).
        #[arg(short, long)]
        output: PathBuf,
        /// The finest level with at most this many faces.
        #[arg(long, conflicts_with_all = ["vertices", "max_error"])]
        faces: Option<usize>,
        /// The level with this many vertices.
        #[arg(long, conflicts_with = "max_error")]
        vertices: Option<usize>,
        /// The coarsest level whose recorded collapse error is at most this (paper units).
        #[arg(long)]
        max_error: Option<f32>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        write: WriteArgs,
    },
    /// Predict w and ETC for a mesh and a target with the shipped (or $MESHLOD_MODEL_DIR) model.
    Predict(PredictArgs),
    /// Run the gRPC server (meshlod.v1.MeshLod, health, reflection, metrics).
    Serve(ServeArgs),
    /// Call a meshlod server: the same operations, flags and reports as the local commands.
    Client(ClientArgs),
    /// Ask a server's health service (grpc.health.v1) whether it is serving; exit 0 if so.
    Health(HealthArgs),
    /// Run many jobs from a manifest, locally or against a server (see `meshlod batch --help`).
    Batch(BatchArgs),
    /// Generate training samples for the predictor (features, errors of every w, exact ETCs).
    Samples(SamplesArgs),
    /// Run the main job on a built-in mesh: generate, validate, simplify, measure. Needs no files.
    Demo {
        /// Directory to write the demo meshes into (default: a temporary directory).
        #[arg(long)]
        out_dir: Option<PathBuf>,
    },
}

/// A procedural shape.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Shape {
    Sphere,
    Torus,
    Box,
    Terrain,
    Blob,
}

/// Collapse cost.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MetricArg {
    Qfvp,
    Qem,
    Melax,
}

/// Placement of the merged vertex.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum PlacementArg {
    /// optimal, or endpoint for a mesh with texture coordinates (their values stay where they were)
    Auto,
    Paper,
    Optimal,
    Endpoint,
}

/// Normal of the merged vertex.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum NormalsArg {
    Linear,
    Recompute,
}

/// Open boundaries.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum BoundaryArg {
    Preserve,
    Lock,
}

/// Refine mode.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ModeArg {
    Simplify,
    Subdivide,
    Both,
}

/// `--w`: a number, `auto` (the predictor's choice) or `search` (the best of every class, measured).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WArg {
    Value(f64),
    Auto,
    Search,
}

impl std::str::FromStr for WArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("search") {
            return Ok(WArg::Search);
        }
        match s.parse::<Auto>() {
            Ok(Auto::Auto) => Ok(WArg::Auto),
            Ok(Auto::Value(w)) => Ok(WArg::Value(w)),
            Err(_) => Err(format!("'{s}' is neither a number, 'auto' nor 'search'")),
        }
    }
}

/// A number, or `auto` for the predictor's choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Auto {
    Auto,
    Value(f64),
}

impl std::str::FromStr for Auto {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Auto::Auto);
        }
        s.parse::<f64>().map(Auto::Value).map_err(|_| format!("'{s}' is neither a number nor 'auto'"))
    }
}

/// How a command writes its output mesh.
#[derive(Debug, Clone, Copy, Default, Args)]
pub struct WriteArgs {
    /// glTF output: store the vertex data as integers (KHR_mesh_quantization): about half the
    /// bytes per vertex (positions on a 16-bit grid over the largest side).
    #[arg(long)]
    pub quantize: bool,
}

impl WriteArgs {
    /// The engine's write options these flags ask for.
    pub fn options(&self) -> WriteOptions {
        WriteOptions { quantize: self.quantize }
    }
}

/// `meshlod simplify` flags (also `client simplify` and batch `simplify` jobs).
#[derive(Debug, Clone, Args)]
pub struct SimplifyArgs {
    /// Input mesh (.obj, .ply, .stl, .off, .gltf or .glb).
    pub input: PathBuf,
    /// Output mesh (.obj, .ply, .gltf or .glb).
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub write: WriteArgs,
    /// Keep at most this many faces.
    #[arg(long)]
    pub faces: Option<u32>,
    /// Fraction of the faces to keep: 0.1 keeps 10% (as gltfpack's -si counts). The same target
    /// as `--ratio 0.9`.
    #[arg(long, value_name = "FRACTION", conflicts_with = "ratio", value_parser = parse_keep)]
    pub keep: Option<f64>,
    /// Fraction of the faces to remove, as in the paper: 0.9 keeps 10% (default 0.5 when neither
    /// --faces nor --keep is given; with --faces too, whichever is met first).
    #[arg(long)]
    pub ratio: Option<f64>,
    /// Stop before a collapse whose error estimate exceeds this (paper units).
    #[arg(long)]
    pub max_error: Option<f64>,
    /// Collapse cost.
    #[arg(long, value_enum, default_value_t = MetricArg::Qfvp)]
    pub metric: MetricArg,
    /// QFVP exponent w in [0, 2] (0 is plain QEM; the lowest error on most shared meshes, see
    /// docs/simplify-report.md); `auto` for the predictor's choice; `search` to simplify with each
    /// of 0, 0.5, 1, 1.5, 2 and keep the result with the lowest Hausdorff distance (five runs).
    #[arg(long, default_value = "0")]
    pub w: WArg,
    /// Placement of the merged vertex.
    #[arg(long, value_enum, default_value_t = PlacementArg::Auto)]
    pub placement: PlacementArg,
    /// Normal of the merged vertex: the paper's linear estimate or a recompute over its fan.
    #[arg(long, value_enum, default_value_t = NormalsArg::Linear)]
    pub normals: NormalsArg,
    /// Open boundaries: preserve (slide along the border; a hole shrunk to a triangle may close)
    /// or lock (never move; every hole stays open).
    #[arg(long, value_enum, default_value_t = BoundaryArg::Preserve)]
    pub boundary: BoundaryArg,
    /// The same as `--boundary lock`.
    #[arg(long)]
    pub lock_border: bool,
    /// Keep every vertex of a texture, normal, colour or material seam in place.
    #[arg(long)]
    pub lock_seams: bool,
    /// Weights of the attribute quadrics in the cost, e.g. `uv=0.3` (each ≥ 0; unset ones 0; all
    /// 0 turns them off). Default: `normal=0.0001` for a mesh with texture coordinates (normals
    /// charged a little, which the pixels favour: docs/textured-report.md), none for the others.
    #[arg(long, value_name = "uv=W,normal=W,color=W", value_parser = parse_attribute_weights)]
    pub attribute_weights: Option<proto::AttributeWeights>,
    /// Take out whole parts (faces joined through shared vertices: chain links, bolts) once the
    /// error reaches their size, so that their faces go to the larger shapes; the part with the
    /// most faces stays. Not with --pm (docs/attributes-report.md).
    #[arg(long, conflicts_with = "pm")]
    pub prune: bool,
    /// One sequence of collapses over the whole mesh, never in halves (`--help` says when).
    #[arg(long, help = whole_help())]
    pub whole: bool,
    /// Largest change of a face normal one collapse may cause, in degrees (default 90).
    #[arg(long)]
    pub max_normal_change: Option<f64>,
    /// Distance guard: each collapse also pays for the distance it opens between the result and
    /// the input, measured both ways. Lower Hausdorff distance on most meshes (a thin tip is no
    /// longer shortened for free) at several times the cost (docs/simplify-report.md, Table 1b).
    /// `--guard` alone is weight 1; 0 is off.
    #[arg(long, value_name = "WEIGHT", num_args = 0..=1, default_missing_value = "1")]
    pub guard: Option<f64>,
    /// Weight of the fan-distance term (`--help` says what it does).
    #[arg(long, value_name = "WEIGHT", help = distance_term_help())]
    pub distance_term: Option<f64>,
    /// Also write the progressive mesh (base + vertex splits) to this .pm file: the compact form,
    /// positions and values on 16-bit grids (docs/pm-format.md).
    #[arg(long)]
    pub pm: Option<PathBuf>,
    /// Write the .pm with every float as it is (format version 1, or 2 with attributes): levels
    /// bit for bit, about three times the size of the compact form.
    #[arg(long, requires = "pm")]
    pub pm_lossless: bool,
    /// Measure the Hausdorff distance between input and output (certified bounds).
    #[arg(long)]
    pub hausdorff: bool,
    /// Compare input and output in pixels, as `meshlod compare` does with its default views
    /// (mean difference, PSNR, silhouette in the report).
    #[arg(long)]
    pub compare: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

impl SimplifyArgs {
    /// The job these flags ask for, in the engine's terms.
    pub fn job(&self) -> SimplifyJob {
        use meshlod_engine::simplify::{
            AttributeWeights, BoundaryMode, Metric, NormalUpdate, Placement, SimplifyOptions,
        };
        let defaults = SimplifyOptions::default();
        let w = match self.w {
            WArg::Value(w) => WChoice::Given(w),
            WArg::Auto => WChoice::Auto,
            WArg::Search => WChoice::Search,
        };
        let options = SimplifyOptions {
            max_error: self.max_error,
            metric: match self.metric {
                // (w is 0 here while the predictor or the search chooses it.)
                MetricArg::Qfvp => Metric::Qfvp { w: if let WChoice::Given(w) = w { w } else { 0.0 } },
                MetricArg::Qem => Metric::Qem,
                MetricArg::Melax => Metric::Melax,
            },
            placement: match self.placement {
                PlacementArg::Auto => Placement::Auto,
                PlacementArg::Optimal => Placement::Optimal,
                PlacementArg::Paper => Placement::Paper,
                PlacementArg::Endpoint => Placement::Endpoint,
            },
            normals: match self.normals {
                NormalsArg::Linear => NormalUpdate::Linear,
                NormalsArg::Recompute => NormalUpdate::Recompute,
            },
            boundary: match (self.boundary, self.lock_border) {
                (BoundaryArg::Preserve, false) => BoundaryMode::Preserve,
                _ => BoundaryMode::Lock,
            },
            lock_seams: self.lock_seams,
            max_normal_change_degrees: self.max_normal_change.unwrap_or(defaults.max_normal_change_degrees),
            record_progressive: self.pm.is_some(),
            guard: self.guard.unwrap_or(defaults.guard),
            distance_term: self.distance_term.unwrap_or(defaults.distance_term),
            attribute_weights: self.attribute_weights.map(|w| AttributeWeights {
                uv: w.uv,
                normal: w.normal,
                color: w.color,
            }),
            prune: self.prune,
            halves: !self.whole,
            ..defaults
        }
        .with_targets(self.faces.map(|n| n as usize), removed_fraction(self.ratio, self.keep));
        let options = SimplifyRequest {
            options,
            w,
            compute_hausdorff: self.hausdorff,
            progressive_lossless: self.pm_lossless,
            compare: self.compare,
        };
        SimplifyJob {
            input: self.input.clone(),
            output: self.output.clone(),
            write: self.write.options(),
            options,
            pm: self.pm.clone(),
        }
    }
}

/// `meshlod refine` flags (also `client refine` and batch `refine` jobs).
#[derive(Debug, Clone, Args)]
pub struct RefineArgs {
    /// Input mesh (.obj, .ply, .stl, .off, .gltf or .glb).
    pub input: PathBuf,
    /// Output mesh (.obj, .ply, .gltf or .glb).
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub write: WriteArgs,
    /// Energy threshold coefficient: threshold = ETC × mean face energy; `auto` (with --faces) takes
    /// the predictor's estimate instead of the exact search.
    #[arg(long, required_unless_present = "faces")]
    pub etc: Option<Auto>,
    /// Target face count; the ETC reaching it is searched and reported.
    #[arg(long)]
    pub faces: Option<u32>,
    /// What to do (default: subdivide, or with --faces whichever direction reaches the target).
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
    /// Subdivision rounds.
    #[arg(long, default_value_t = 1)]
    pub rounds: u32,
    /// Measure the output against this reference mesh (certified Hausdorff, mean).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

impl RefineArgs {
    /// The job these flags ask for.
    pub fn job(&self) -> RefineJob {
        use meshlod_engine::refine::RefineMode;
        let request = RefineRequest {
            etc: match self.etc {
                Some(Auto::Value(e)) => EtcChoice::Given(e),
                Some(Auto::Auto) => EtcChoice::Auto,
                None => EtcChoice::Search,
            },
            target_faces: self.faces.map(|n| n as usize),
            mode: self.mode.map(|m| match m {
                ModeArg::Simplify => RefineMode::Simplify,
                ModeArg::Subdivide => RefineMode::Subdivide,
                ModeArg::Both => RefineMode::Both,
            }),
            rounds: self.rounds,
        };
        RefineJob {
            input: self.input.clone(),
            output: self.output.clone(),
            write: self.write.options(),
            request,
            reference: self.reference.clone(),
        }
    }
}

/// `meshlod predict` flags (also `client predict`).
#[derive(Debug, Clone, Args)]
pub struct PredictArgs {
    /// Input mesh.
    pub input: PathBuf,
    /// Fraction of faces to remove, as in the paper (0.9 keeps 10%).
    #[arg(long, required_unless_present_any = ["faces", "keep"])]
    pub ratio: Option<f64>,
    /// Fraction of faces to keep (0.1: the same target as `--ratio 0.9`).
    #[arg(long, value_name = "FRACTION", conflicts_with = "ratio", value_parser = parse_keep)]
    pub keep: Option<f64>,
    /// Target face count (with --ratio too: whichever is met first).
    #[arg(long)]
    pub faces: Option<u32>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

impl PredictArgs {
    /// The job these flags ask for.
    pub fn job(&self) -> PredictJob {
        PredictJob {
            input: self.input.clone(),
            target_faces: self.faces,
            target_ratio: removed_fraction(self.ratio, self.keep),
        }
    }
}

/// Log format of the server.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum LogFormat {
    Text,
    Json,
}

/// `meshlod serve` flags; every one has an environment variable for container deployments.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// gRPC listen address.
    #[arg(long, env = "MESHLOD_LISTEN", default_value = "127.0.0.1:50051")]
    pub listen: SocketAddr,
    /// Prometheus metrics listen address (`/metrics`); empty to disable.
    #[arg(long, env = "MESHLOD_METRICS_LISTEN", default_value = "127.0.0.1:9090")]
    pub metrics_listen: String,
    /// Heavy requests running at once (default: the number of cores). Memory grows with it: see
    /// deploy/README.md for sizing it with --max-faces against a memory limit.
    #[arg(long, env = "MESHLOD_MAX_CONCURRENT")]
    pub max_concurrent: Option<usize>,
    /// Heavy requests waiting at once before RESOURCE_EXHAUSTED (default: twice the cores).
    #[arg(long, env = "MESHLOD_MAX_QUEUE")]
    pub max_queue: Option<usize>,
    /// Largest gRPC message, MiB.
    #[arg(long, env = "MESHLOD_MAX_MESSAGE_MIB", default_value_t = 256)]
    pub max_message_mib: usize,
    /// Largest mesh accepted, in faces (and in vertices).
    #[arg(long, env = "MESHLOD_MAX_FACES", default_value_t = MeshLimits::default().max_faces)]
    pub max_faces: usize,
    /// TLS certificate (PEM); with --tls-key enables TLS.
    #[arg(long, env = "MESHLOD_TLS_CERT", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// TLS private key (PEM).
    #[arg(long, env = "MESHLOD_TLS_KEY", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Require `authorization: Bearer <token>` on every MeshLod call.
    #[arg(long, env = "MESHLOD_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Log format.
    #[arg(long, env = "MESHLOD_LOG_FORMAT", value_enum, default_value_t = LogFormat::Text)]
    pub log_format: LogFormat,
    /// Predictor model folder (predictor.onnx + metadata.json); default: the model built in.
    #[arg(long, env = "MESHLOD_MODEL_DIR")]
    pub model_dir: Option<PathBuf>,
}

/// Where a server is and how to reach it.
#[derive(Debug, Clone, Args)]
pub struct ServerArgs {
    /// Server address: `host:port`, `http://host:port` or `https://host:port`.
    #[arg(long, env = "MESHLOD_SERVER", default_value = "127.0.0.1:50051")]
    pub server: String,
    /// Bearer token, if the server requires one.
    #[arg(long, env = "MESHLOD_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Deadline of each call, seconds.
    #[arg(long, default_value_t = 600.0)]
    pub timeout: f64,
}

impl ServerArgs {
    /// The deadline of each call.
    pub fn deadline(&self) -> anyhow::Result<Duration> {
        Duration::try_from_secs_f64(self.timeout)
            .map_err(|_| anyhow::anyhow!("--timeout {} is not a duration", self.timeout))
    }
}

/// `meshlod client` flags.
#[derive(Debug, Args)]
pub struct ClientArgs {
    #[command(flatten)]
    pub server: ServerArgs,
    #[command(subcommand)]
    pub operation: ClientOperation,
}

/// What the client asks the server for.
#[derive(Debug, Subcommand)]
pub enum ClientOperation {
    /// Simplify on the server (flags and report as `meshlod simplify`).
    Simplify(SimplifyArgs),
    /// Refine on the server (flags and report as `meshlod refine`).
    Refine(RefineArgs),
    /// Ask the server's predictor for w and ETC (flags and report as `meshlod predict`).
    Predict(PredictArgs),
}

/// `meshlod health` flags.
#[derive(Debug, Args)]
pub struct HealthArgs {
    /// Server address: `host:port` or a URL.
    #[arg(long, env = "MESHLOD_SERVER", default_value = "127.0.0.1:50051")]
    pub server: String,
    /// Service to ask about (default: the whole server; `meshlod.v1.MeshLod` for the service).
    #[arg(long, default_value = "")]
    pub service: String,
    /// Give up after this many seconds.
    #[arg(long, default_value_t = 5.0)]
    pub timeout: f64,
}

/// The manifest format, shown by `meshlod batch --help` and in the README.
pub const MANIFEST_HELP: &str = "\
The manifest is JSON lines: one job object per line; blank lines and lines starting with # are skipped.

  {\"op\": \"simplify\", \"input\": \"in/bunny.obj\", \"output\": \"out/bunny-10.ply\", \"args\": [\"--ratio\", \"0.9\", \"--pm\", \"out/bunny.pm\"]}
  {\"op\": \"refine\", \"input\": \"in/cow.obj\", \"output\": \"out/cow-fine.obj\", \"args\": [\"--etc\", \"1.0\"]}

Keys: op (simplify or refine), input, output, and optionally args: the command's flags, as on the
command line (--json is implied). Any other key is an error. Relative paths, in input, output and in
the path flags of args (--pm, --reference), are relative to the manifest's folder.

A job whose outputs exist and are newer than its input and the manifest, with the files they refer
to (an OBJ's MTL file and textures), is skipped (--force redoes it), so an interrupted batch resumes; a failed job removes what it wrote, so it is never skipped.
The batch exits non-zero if any job failed.";

/// `meshlod batch` flags.
#[derive(Debug, Args)]
#[command(after_long_help = MANIFEST_HELP)]
pub struct BatchArgs {
    /// Manifest: one JSON job per line (see below).
    pub manifest: PathBuf,
    /// Run against this server instead of locally (one connection for the whole batch).
    #[arg(long, env = "MESHLOD_SERVER")]
    pub server: Option<String>,
    /// Bearer token for the server.
    #[arg(long, env = "MESHLOD_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Deadline of each remote job, seconds.
    #[arg(long, default_value_t = 600.0)]
    pub timeout: f64,
    /// Jobs at once (default: the number of cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Write the per-job results (JSON lines) here instead of stdout.
    #[arg(long)]
    pub results: Option<PathBuf>,
    /// Redo jobs whose output is already up to date.
    #[arg(long)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Run only the jobs whose index (0-based, in manifest order) modulo `--shard-count` is this
    /// (default: $JOB_COMPLETION_INDEX, set by a Kubernetes Indexed Job).
    #[arg(long, env = "JOB_COMPLETION_INDEX", requires = "shard_count")]
    pub shard_index: Option<usize>,
    /// Number of shards the manifest is split into (one per pod of an Indexed Job).
    #[arg(long, env = "MESHLOD_SHARD_COUNT")]
    pub shard_count: Option<usize>,
}

/// One batch job, parsed with the same flags as the command line.
#[derive(Debug, Clone)]
pub enum Job {
    Simplify(SimplifyArgs),
    Refine(RefineArgs),
}

/// Parses `meshlod OP INPUT -o OUTPUT ARGS…` into a job.
pub fn parse_job(op: &str, input: &str, output: &str, args: &[String]) -> anyhow::Result<Job> {
    let argv = ["meshlod", op, input, "-o", output].into_iter().map(String::from).chain(args.iter().cloned());
    match Cli::try_parse_from(argv).map_err(|e| anyhow::anyhow!("{}", e.render().to_string().trim()))?.command {
        Command::Simplify(a) => Ok(Job::Simplify(a)),
        Command::Refine(a) => Ok(Job::Refine(a)),
        _ => anyhow::bail!("op must be simplify or refine, not {op}"),
    }
}

/// `uv=W,normal=W,color=W` (any subset, any order) as the contract's weights; the range is
/// checked where every front end's options are.
fn parse_attribute_weights(text: &str) -> Result<proto::AttributeWeights, String> {
    let mut weights = proto::AttributeWeights::default();
    for part in text.split(',').filter(|p| !p.trim().is_empty()) {
        let (name, value) = part.split_once('=').ok_or_else(|| format!("'{part}' is not NAME=WEIGHT"))?;
        let value: f64 = value.trim().parse().map_err(|_| format!("'{value}' is not a number"))?;
        match name.trim() {
            "uv" => weights.uv = value,
            "normal" => weights.normal = value,
            "color" | "colour" => weights.color = value,
            other => return Err(format!("unknown attribute '{other}' (uv, normal, color)")),
        }
    }
    Ok(weights)
}

/// `--keep`: a fraction of the faces to keep, in (0, 1].
fn parse_keep(text: &str) -> Result<f64, String> {
    let keep: f64 = text.parse().map_err(|_| format!("{text:?} is not a number"))?;
    if keep > 0.0 && keep <= 1.0 {
        Ok(keep)
    } else {
        Err(format!("{keep} is outside (0, 1]: the fraction of the faces to keep"))
    }
}

/// The contract's `target_ratio` (the fraction removed) from `--ratio` or `--keep` (the fraction
/// kept), whichever was given: clap lets only one through.
fn removed_fraction(ratio: Option<f64>, keep: Option<f64>) -> Option<f64> {
    ratio.or(keep.map(|k| 1.0 - k))
}

/// `--whole`'s help, its figures from the engine's constants.
fn whole_help() -> String {
    format!(
        "One sequence of collapses over the whole mesh, never in halves: by default a mesh of {} faces or more, \
         simplified to 1/{} of them or fewer, is first simplified in two halves side by side (faster on two \
         threads; docs/benchmarks.md), which a progressive mesh's levels then follow only approximately",
        meshlod_engine::simplify::HALVES_FROM_FACES,
        meshlod_engine::simplify::HALVES_TO_SHARE,
    )
}

/// `--distance-term`'s help, its figures from the engine's constants.
fn distance_term_help() -> String {
    format!(
        "Weight of the fan-distance term (default {}; 0 leaves the paper's QFVP/QEM cost as it is): with it each \
         collapse ranks by its quadric error per unit of area and, once {}% of the input's faces are gone, also \
         pays for how far it moves the faces it changes, measured on those faces alone. Ignored with Melax, with \
         --guard and on meshes with texture coordinates (docs/meshlab-comparison.md, docs/attributes-report.md)",
        meshlod_engine::simplify::DEFAULT_DISTANCE_TERM,
        (meshlod_engine::simplify::FAN_TERM_FROM * 100.0).round(),
    )
}
