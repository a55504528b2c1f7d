//! Subcommands of the `meshlod` binary.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use meshlod_engine::features::W_CLASSES;
use meshlod_engine::hausdorff::{HausdorffOptions, HausdorffReport, directed_hausdorff, hausdorff};
use meshlod_engine::io::{read_mesh, write_mesh};
use meshlod_engine::pm_format::{encode, read_pm};
use meshlod_engine::refine::{RefineMode, RefineOptions, refine};
use meshlod_engine::simplify::{
    BoundaryMode, Metric, NormalUpdate, Placement, SimplifyOptions, simplify, simplify_search_w,
};
use meshlod_engine::validate::{clean, validate};
use meshlod_engine::{Mesh, procedural};
use serde_json::json;

/// meshlod: progressive meshes and levels of detail for heavy triangle meshes.
#[derive(Debug, Parser)]
#[command(name = "meshlod", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print a validation report: counts, bounding box, degenerate/duplicate faces, manifoldness.
    Info {
        /// Mesh file (.obj or .ply).
        file: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Convert between OBJ and PLY (format from the output extension).
    Convert {
        /// Input mesh.
        input: PathBuf,
        /// Output mesh (.obj or binary .ply).
        output: PathBuf,
        /// Weld coincident vertices, drop degenerate/duplicate faces and unreferenced vertices.
        #[arg(long)]
        clean: bool,
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
    /// Write a procedurally generated mesh (for trying meshlod without data).
    Generate {
        /// Which shape.
        #[arg(value_enum)]
        shape: Shape,
        /// Output mesh (.obj or .ply).
        #[arg(short, long)]
        output: PathBuf,
        /// Resolution: subdivision level for the sphere, grid steps for the others.
        #[arg(long, default_value_t = 64)]
        resolution: u32,
    },
    /// Simplify by edge collapse (QFVP, QEM or Melax), optionally writing a progressive mesh.
    Simplify(SimplifyArgs),
    /// Energy-operator LOD: collapse low-energy faces and/or subdivide high-energy ones.
    Refine(RefineArgs),
    /// Extract one level of detail from a progressive mesh (.pm).
    Lod {
        /// Progressive mesh written by `meshlod simplify --pm`.
        input: PathBuf,
        /// Output mesh (.obj or .ply).
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
    },
    /// Run the gRPC server (meshlod.v1.MeshLod, health, reflection, metrics).
    Serve(crate::remote::ServeArgs),
    /// Call a meshlod server: the same operations and flags as the local commands.
    Client(crate::remote::ClientArgs),
    /// Run many jobs from a manifest (JSON lines), locally or against a server.
    Batch(crate::batch::BatchArgs),
    /// Predict w and ETC for a mesh and a target with the shipped (or $MESHLOD_MODEL_DIR) model.
    Predict {
        /// Input mesh.
        input: PathBuf,
        /// Fraction of faces to remove.
        #[arg(long, conflicts_with = "faces", required_unless_present = "faces")]
        ratio: Option<f64>,
        /// Target face count.
        #[arg(long)]
        faces: Option<usize>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Generate training samples for the predictor (features, errors of every w, exact ETCs).
    Samples(crate::samples::SamplesArgs),
    /// Run the main job on a built-in mesh: generate, validate, measure. Needs no files.
    Demo {
        /// Directory to write the demo meshes into (default: a temporary directory).
        #[arg(long)]
        out_dir: Option<PathBuf>,
    },
}

#[derive(Debug, Clone, clap::Args)]
pub(crate) struct SimplifyArgs {
    /// Input mesh (.obj or .ply).
    pub(crate) input: PathBuf,
    /// Output mesh (.obj or .ply).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Keep at most this many faces.
    #[arg(long, conflicts_with = "ratio")]
    pub(crate) faces: Option<usize>,
    /// Fraction of the faces to remove, as in the paper: 0.9 keeps 10% (default 0.5).
    #[arg(long)]
    pub(crate) ratio: Option<f64>,
    /// Stop before a collapse whose error estimate exceeds this (paper units).
    #[arg(long)]
    pub(crate) max_error: Option<f64>,
    /// Collapse cost.
    #[arg(long, value_enum, default_value_t = MetricArg::Qfvp)]
    pub(crate) metric: MetricArg,
    /// QFVP exponent w in [0, 2] (0 is plain QEM; the lowest error on most shared meshes, see
    /// docs/simplify-report.md); `auto` for the predictor's choice; `search` to simplify with each
    /// of 0, 0.5, 1, 1.5, 2 and keep the result with the lowest Hausdorff distance (five runs).
    #[arg(long, default_value = "0")]
    pub(crate) w: WArg,
    /// Placement of the merged vertex.
    #[arg(long, value_enum, default_value_t = PlacementArg::Optimal)]
    pub(crate) placement: PlacementArg,
    /// Normal of the merged vertex: the paper's linear estimate or a recompute over its fan.
    #[arg(long, value_enum, default_value_t = NormalsArg::Linear)]
    pub(crate) normals: NormalsArg,
    /// Open boundaries: preserve (slide along the border) or lock (never move).
    #[arg(long, value_enum, default_value_t = BoundaryArg::Preserve)]
    pub(crate) boundary: BoundaryArg,
    /// Largest change of a face normal one collapse may cause, in degrees.
    #[arg(long, default_value_t = 90.0)]
    pub(crate) max_normal_change: f64,
    /// Distance guard: each collapse also pays for the distance it opens between the result and
    /// the input, measured both ways. Lower Hausdorff distance on most meshes (a thin tip is no
    /// longer shortened for free) at several times the cost (docs/simplify-report.md, Table 1b).
    /// `--guard` alone is weight 1; 0 is off.
    #[arg(long, value_name = "WEIGHT", num_args = 0..=1, default_missing_value = "1", default_value_t = 0.0)]
    pub(crate) guard: f64,
    /// Also write the progressive mesh (base + vertex splits) to this .pm file.
    #[arg(long)]
    pub(crate) pm: Option<PathBuf>,
    /// Measure the Hausdorff distance between input and output.
    #[arg(long)]
    pub(crate) hausdorff: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Debug, Clone, clap::Args)]
pub(crate) struct RefineArgs {
    /// Input mesh (.obj or .ply).
    pub(crate) input: PathBuf,
    /// Output mesh (.obj or .ply).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Energy threshold coefficient: threshold = ETC × mean face energy; `auto` (with --faces) takes
    /// the predictor's estimate instead of the exact search.
    #[arg(long, required_unless_present = "faces")]
    pub(crate) etc: Option<Auto>,
    /// Target face count; the ETC reaching it is searched and reported.
    #[arg(long)]
    pub(crate) faces: Option<usize>,
    /// What to do (default: subdivide, or with --faces whichever direction reaches the target).
    #[arg(long, value_enum)]
    pub(crate) mode: Option<ModeArg>,
    /// Subdivision rounds.
    #[arg(long, default_value_t = 1)]
    pub(crate) rounds: u32,
    /// Measure the Metro error of the output against this reference mesh.
    #[arg(long)]
    pub(crate) reference: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum ModeArg {
    Simplify,
    Subdivide,
    Both,
}

pub(crate) fn run_refine(args: RefineArgs) -> Result<()> {
    let report = refine_report(&args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{}: {} → {} faces with ETC {:.4} in {:.3} s",
            report["mode"],
            report["faces_in"],
            report["faces_out"],
            report["etc"].as_f64().unwrap_or(0.0),
            report["seconds"].as_f64().unwrap_or(0.0)
        );
        if let Some(m) = report.get("reference_mean") {
            println!("against the reference: mean {m}, max {} (paper units)", report["reference_max"]);
        }
    }
    Ok(())
}

/// Runs a local refinement and returns its JSON report.
pub(crate) fn refine_report(args: &RefineArgs) -> Result<serde_json::Value> {
    let mesh = load(&args.input)?;
    let mode = match (args.mode, args.faces) {
        (Some(ModeArg::Simplify), _) => RefineMode::Simplify,
        (Some(ModeArg::Subdivide), _) => RefineMode::Subdivide,
        (Some(ModeArg::Both), _) => RefineMode::Both,
        (None, Some(n)) if n < mesh.face_count() => RefineMode::Simplify,
        (None, _) => RefineMode::Subdivide,
    };
    let (etc, target_faces, model_version) = match (args.etc, args.faces) {
        (Some(Auto::Value(_)), Some(_)) => bail!("give --etc or --faces, not both (or --etc auto with --faces)"),
        (Some(Auto::Value(e)), None) => (Some(e), None, None),
        (Some(Auto::Auto), Some(n)) => {
            let advice = meshlod_service::predict::advise(&predictor()?, &mesh, n)?;
            (Some(advice.etc), None, Some(advice.model_version))
        }
        (Some(Auto::Auto), None) => bail!("--etc auto needs --faces (the target the ETC is predicted for)"),
        (None, faces) => (None, faces, None),
    };
    let options = RefineOptions { etc, target_faces, mode, rounds: args.rounds, cancel: None };
    let result = refine(&mesh, &options)?;
    write_mesh(&args.output, &result.mesh)?;
    let stats = &result.stats;
    let mut report = json!({
        "faces_in": stats.faces_in,
        "faces_out": stats.faces_out,
        "etc": stats.etc,
        "threshold": stats.threshold,
        "mode": stats.mode,
        "rounds": stats.rounds,
        "split_edges": stats.split_edges,
        "etc_source": if model_version.is_some() { "predicted" } else if args.etc.is_some() { "given" } else { "searched" },
        "model_version": model_version,
        "collapses": stats.collapses,
        "seconds": stats.seconds,
    });
    if let Some(reference) = &args.reference {
        let reference_mesh = load(reference)?;
        let d = hausdorff(&reference_mesh, &result.mesh, &HausdorffOptions::default())?;
        report["reference_mean"] = json!(d.mean);
        report["reference_max"] = json!(d.hausdorff);
        report["reference_max_lower"] = json!(d.hausdorff_lower);
        report["reference_mean_diag_pct"] = json!(d.mean_diag_pct);
        report["reference_max_diag_pct"] = json!(d.hausdorff_diag_pct);
    }
    Ok(report)
}

/// `--w`: a number, `auto` (the predictor's choice) or `search` (the best of every class, measured).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum WArg {
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
pub(crate) enum Auto {
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

/// The predictor: the model in `$MESHLOD_MODEL_DIR` if set, else the one built in.
pub(crate) fn predictor() -> Result<meshlod_predictor::Predictor> {
    let dir = std::env::var_os("MESHLOD_MODEL_DIR").map(PathBuf::from);
    meshlod_service::predict::load(dir.as_deref()).context("loading the predictor model")
}

fn run_predict(input: &Path, ratio: Option<f64>, faces: Option<usize>, json: bool) -> Result<()> {
    if let Some(r) = ratio
        && !(0.0..1.0).contains(&r)
    {
        bail!("--ratio {r} is outside [0, 1): it is the fraction of faces removed");
    }
    let mesh = meshlod_engine::simplify::prepare(&load(input)?).0;
    let target =
        meshlod_service::predict::target_faces(mesh.face_count(), faces, ratio).context("give --ratio or --faces")?;
    let started = Instant::now();
    let advice = meshlod_service::predict::advise(&predictor()?, &mesh, target)?;
    let report = json!({
        "faces_in": mesh.face_count(),
        "target_faces": target,
        "w": advice.w.w,
        "probabilities": advice.w.probabilities,
        "classes": advice.w.classes,
        "etc": advice.etc,
        "etc_mode": if target > mesh.face_count() { "subdivide" } else { "simplify" },
        "model_version": advice.model_version,
        "seconds": started.elapsed().as_secs_f64(),
    });
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "w = {} (probabilities {:?} for {:?}), ETC ≈ {:.4} for {} faces ({}), model {}",
            advice.w.w,
            advice.w.probabilities,
            advice.w.classes,
            advice.etc,
            target,
            report["etc_mode"],
            advice.model_version
        );
    }
    Ok(())
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum MetricArg {
    Qfvp,
    Qem,
    Melax,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum PlacementArg {
    Paper,
    Optimal,
    Endpoint,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum NormalsArg {
    Linear,
    Recompute,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum BoundaryArg {
    Preserve,
    Lock,
}

impl SimplifyArgs {
    pub(crate) fn options(&self, w: f64) -> SimplifyOptions {
        SimplifyOptions {
            target_faces: self.faces,
            target_ratio: if self.faces.is_some() { self.ratio } else { Some(self.ratio.unwrap_or(0.5)) },
            max_error: self.max_error,
            metric: match self.metric {
                MetricArg::Qfvp => Metric::Qfvp { w },
                MetricArg::Qem => Metric::Qem,
                MetricArg::Melax => Metric::Melax,
            },
            placement: match self.placement {
                PlacementArg::Paper => Placement::Paper,
                PlacementArg::Optimal => Placement::Optimal,
                PlacementArg::Endpoint => Placement::Endpoint,
            },
            normals: match self.normals {
                NormalsArg::Linear => NormalUpdate::Linear,
                NormalsArg::Recompute => NormalUpdate::Recompute,
            },
            boundary: match self.boundary {
                BoundaryArg::Preserve => BoundaryMode::Preserve,
                BoundaryArg::Lock => BoundaryMode::Lock,
            },
            max_normal_change_degrees: self.max_normal_change,
            record_progressive: self.pm.is_some(),
            guard: self.guard,
            cancel: None,
        }
    }
}

pub(crate) fn run_simplify(args: SimplifyArgs) -> Result<()> {
    let report = simplify_report(&args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} → {} faces ({} collapses, {}) with {} in {:.3} s",
            report["faces_in"],
            report["faces_out"],
            report["collapses"],
            report["stop_reason"],
            report["metric"],
            report["seconds"].as_f64().unwrap_or(0.0)
        );
        if let Some(h) = report.get("hausdorff") {
            println!(
                "hausdorff ≤ {} paper units (≥ {}, certified), mean {}",
                h, report["hausdorff_lower"], report["mean"]
            );
        }
        if let Some(b) = report.get("pm_bytes") {
            println!("progressive mesh: {b} bytes, {} bytes per split", report["bytes_per_split"]);
        }
    }
    Ok(())
}

/// Runs a local simplification and returns its JSON report.
pub(crate) fn simplify_report(args: &SimplifyArgs) -> Result<serde_json::Value> {
    let mesh = load(&args.input)?;
    let (w, model_version) = match args.w {
        WArg::Value(w) => (w, None),
        WArg::Search => (0.0, None), // replaced by each candidate in turn
        WArg::Auto => {
            let target = meshlod_service::predict::target_faces(mesh.face_count(), args.faces, args.ratio)
                .unwrap_or(mesh.face_count() / 2);
            let advice = meshlod_service::predict::advise(&predictor()?, &mesh, target)?;
            (advice.w.w, Some(advice.model_version))
        }
    };
    let mut options = args.options(w);
    // A search has measured its result already; `measured` keeps that for --hausdorff.
    let (result, candidates, measured) = if args.w == WArg::Search {
        let search = simplify_search_w(&mesh, &options, &W_CLASSES)?;
        options.metric = Metric::Qfvp { w: search.w };
        let candidates: Vec<serde_json::Value> =
            search.errors.iter().map(|&(w, hausdorff)| json!({ "w": w, "hausdorff": hausdorff })).collect();
        (search.best, Some(candidates), Some(search.hausdorff))
    } else {
        (simplify(&mesh, &options)?, None, None)
    };
    write_mesh(&args.output, &result.mesh)?;
    let stats = &result.stats;
    let mut report = json!({
        "faces_in": stats.faces_in,
        "faces_out": stats.faces_out,
        "vertices_in": stats.vertices_in,
        "vertices_out": stats.vertices_out,
        "metric": options.metric.name(),
        "w": options.metric.w(),
        "w_source": if model_version.is_some() {
            "predicted"
        } else if candidates.is_some() {
            "searched"
        } else {
            "given"
        },
        "w_candidates": candidates,
        "model_version": model_version,
        "placement": options.placement,
        "normals": options.normals,
        "boundary": options.boundary,
        "guard": options.guard,
        "collapses": stats.collapses,
        "stop_reason": stats.stop_reason,
        "max_collapse_error": stats.max_collapse_error,
        "frozen_vertices": stats.frozen_vertices,
        "seconds": stats.seconds,
    });
    if let (Some(path), Some(pm)) = (&args.pm, &result.progressive) {
        let bytes = encode(pm);
        std::fs::write(path, &bytes).with_context(|| format!("writing {}", path.display()))?;
        let base_bytes = 12 * (pm.base().vertex_count() + pm.base().face_count());
        report["pm_bytes"] = json!(bytes.len());
        report["pm_splits"] = json!(pm.levels());
        report["bytes_per_split"] =
            json!((bytes.len().saturating_sub(base_bytes + 32)) as f64 / pm.levels().max(1) as f64);
    }
    if args.hausdorff {
        let d = match measured {
            Some(d) => d,
            None => hausdorff(&mesh, &result.mesh, &HausdorffOptions::default())?,
        };
        for (key, value) in hausdorff_json(&meshlod_service::convert::hausdorff_to_proto(&d)) {
            report[key] = value;
        }
    }
    Ok(report)
}

/// The Hausdorff figures every JSON report carries, local or from the server, under the same keys
/// (paper units unless named).
pub(crate) fn hausdorff_json(d: &meshlod_service::proto::HausdorffReport) -> Vec<(&'static str, serde_json::Value)> {
    vec![
        ("hausdorff", json!(d.hausdorff)),
        ("hausdorff_lower", json!(d.hausdorff_lower)),
        ("hausdorff_tolerance", json!(d.tolerance)),
        ("hausdorff_converged", json!(d.converged)),
        ("hausdorff_diag_pct", json!(d.hausdorff_diag_pct)),
        ("mean", json!(d.mean)),
        ("rms", json!(d.rms)),
        ("samples", json!(d.samples)),
    ]
}

/// `meshlod hausdorff` in text: the certified figure first, then how it was obtained.
fn print_hausdorff(r: &HausdorffReport) {
    println!(
        "hausdorff {:.6} paper units ({:.4}% of the diagonal, {:.6e} absolute): certified upper bound; \
         lower bound {:.6} ({})",
        r.hausdorff,
        r.hausdorff_diag_pct,
        r.hausdorff_absolute,
        r.hausdorff_lower,
        if r.converged {
            format!("within the tolerance {}", r.tolerance)
        } else {
            format!("the work budget ran out before the tolerance {} was met", r.tolerance)
        }
    );
    println!(
        "  a → b: [{:.6}, {:.6}]   b → a: [{:.6}, {:.6}]",
        r.a_to_b.max_lower, r.a_to_b.max_upper, r.b_to_a.max_lower, r.b_to_a.max_upper
    );
    println!("  mean {:.6}, rms {:.6} (area-weighted, {} face samples); {:.3} s", r.mean, r.rms, r.samples, r.seconds);
}

fn run_lod(
    input: &Path,
    output: &Path,
    faces: Option<usize>,
    vertices: Option<usize>,
    max_error: Option<f32>,
    json: bool,
) -> Result<()> {
    let pm = read_pm(input)?;
    let level = match (faces, vertices, max_error) {
        (Some(n), _, _) => pm.level_for_faces(n),
        (_, Some(n), _) => n.saturating_sub(pm.base().vertex_count()).min(pm.levels()),
        // Errors do not increase along the splits: refine while the next split's error is above
        // the tolerance.
        (_, _, Some(e)) => pm.splits().iter().take_while(|s| s.error > e).count(),
        _ => bail!("give one of --faces, --vertices or --max-error"),
    };
    let mesh = pm.at_level(level);
    write_mesh(output, &mesh)?;
    if json {
        println!(
            "{}",
            json!({"level": level, "levels": pm.levels(), "faces": mesh.face_count(), "vertices": mesh.vertex_count()})
        );
    } else {
        println!("level {level} of {}: {} faces, {} vertices", pm.levels(), mesh.face_count(), mesh.vertex_count());
    }
    Ok(())
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Shape {
    Sphere,
    Torus,
    Box,
    Terrain,
    Blob,
}

fn generate(shape: Shape, resolution: u32) -> Mesh {
    match shape {
        Shape::Sphere => procedural::icosphere(resolution.min(9)),
        Shape::Torus => procedural::torus(resolution * 2, resolution, 0.35),
        Shape::Box => procedural::sharp_box(resolution),
        Shape::Terrain => procedural::terrain(resolution, 1),
        Shape::Blob => procedural::bumpy_blob(resolution, resolution * 2, 1),
    }
}

fn load(path: &Path) -> Result<Mesh> {
    Ok(read_mesh(path)?)
}

/// One batch job, parsed with the same flags as the command line.
#[derive(Debug, Clone)]
pub(crate) enum Job {
    Simplify(SimplifyArgs),
    Refine(RefineArgs),
}

/// Parses `meshlod OP INPUT -o OUTPUT ARGS…` into a job.
pub(crate) fn parse_job(op: &str, input: &str, output: &str, args: &[String]) -> Result<Job> {
    let argv = ["meshlod", op, input, "-o", output].into_iter().map(String::from).chain(args.iter().cloned());
    match Cli::try_parse_from(argv).map_err(|e| anyhow::anyhow!("{}", e.render().to_string().trim()))?.command {
        Command::Simplify(a) => Ok(Job::Simplify(a)),
        Command::Refine(a) => Ok(Job::Refine(a)),
        _ => bail!("op must be simplify or refine, not {op}"),
    }
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { file, json } => {
            let mesh = load(&file)?;
            let report = validate(&mesh);
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                println!("{}", file.display());
                let value = serde_json::to_value(&report)?;
                for (key, v) in value.as_object().expect("report is an object") {
                    println!("  {key:<30} {v}");
                }
            }
        }
        Command::Convert { input, output, clean: do_clean } => {
            let mut mesh = load(&input)?;
            if do_clean {
                let (cleaned, report) = clean(&mesh);
                eprintln!("clean: {}", serde_json::to_string(&report)?);
                mesh = cleaned;
            }
            write_mesh(&output, &mesh)?;
        }
        Command::Hausdorff { a, b, tolerance, samples, seed, directed, json } => {
            let (mesh_a, mesh_b) = (load(&a)?, load(&b)?);
            let options = HausdorffOptions { samples, seed, tolerance, cancel: None };
            if directed {
                let d = directed_hausdorff(&mesh_a, &mesh_b, &options)?;
                if json {
                    let mut value = serde_json::to_value(d)?;
                    value["direction"] = json!("a_to_b");
                    value["tolerance"] = json!(tolerance);
                    println!("{}", serde_json::to_string_pretty(&value)?);
                } else {
                    println!(
                        "a → b: at most {:.6} paper units (certified), at least {:.6}; mean {:.6}, rms {:.6}",
                        d.max_upper, d.max_lower, d.mean, d.rms
                    );
                }
                return Ok(());
            }
            let report = hausdorff(&mesh_a, &mesh_b, &options)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print_hausdorff(&report);
            }
        }
        Command::Generate { shape, output, resolution } => {
            if resolution == 0 {
                bail!("--resolution must be at least 1");
            }
            write_mesh(&output, &generate(shape, resolution))?;
        }
        Command::Simplify(args) => run_simplify(args)?,
        Command::Refine(args) => run_refine(args)?,
        Command::Lod { input, output, faces, vertices, max_error, json } => {
            run_lod(&input, &output, faces, vertices, max_error, json)?
        }
        Command::Serve(args) => crate::remote::serve(args)?,
        Command::Client(args) => crate::remote::client(args)?,
        Command::Batch(args) => crate::batch::run(args)?,
        Command::Samples(args) => crate::samples::run(args)?,
        Command::Predict { input, ratio, faces, json } => run_predict(&input, ratio, faces, json)?,
        Command::Demo { out_dir } => demo(out_dir)?,
    }
    Ok(())
}

fn demo(out_dir: Option<PathBuf>) -> Result<()> {
    let dir = match out_dir {
        Some(d) => d,
        None => std::env::temp_dir().join(format!("meshlod-demo-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let original = procedural::bumpy_blob(120, 240, 7);
    let original_path = dir.join("blob.ply");
    write_mesh(&original_path, &original)?;
    let report = validate(&original);
    println!(
        "demo mesh: {} vertices, {} faces, manifold and oriented: {} → {}",
        report.vertices,
        report.faces,
        report.is_manifold_oriented,
        original_path.display()
    );
    let options = SimplifyOptions { target_ratio: Some(0.9), record_progressive: true, ..Default::default() };
    let result = simplify(&original, &options)?;
    let pm = result.progressive.as_ref().expect("asked for");
    let pm_path = dir.join("blob.pm");
    let bytes = encode(pm);
    std::fs::write(&pm_path, &bytes).with_context(|| format!("writing {}", pm_path.display()))?;
    let base_path = dir.join("blob-base.ply");
    write_mesh(&base_path, &result.mesh)?;
    println!(
        "simplified 90% with {} (w = {}): {} → {} faces in {:.3} s; progressive mesh {} splits, {} bytes → {}",
        options.metric.name(),
        options.metric.w().unwrap_or(0.0),
        result.stats.faces_in,
        result.stats.faces_out,
        result.stats.seconds,
        pm.levels(),
        bytes.len(),
        pm_path.display()
    );
    println!("level of detail    faces   Hausdorff (paper units)   % of diagonal");
    for faces in [result.stats.faces_out, 10_000, 25_000, original.face_count()] {
        let lod = pm.at_faces(faces);
        let d = hausdorff(&original, &lod, &HausdorffOptions::default())?;
        println!("  ≤ {faces:>7}    {:>7}   {:>20.6}    {:>10.4}", lod.face_count(), d.hausdorff, d.hausdorff_diag_pct);
    }
    Ok(())
}
