//! What each subcommand does: the simplify, refine and predict commands hand their job to an
//! executor (here, or a server for `meshlod client`) and print its report; the others are small
//! local tools. Text output is for people (counts first, 6 significant digits); `--json` prints
//! the report as it is.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use meshlod_engine::compare::{CompareReport, compare};
use meshlod_engine::hausdorff::{HausdorffOptions, HausdorffReport, directed_hausdorff, hausdorff};
use meshlod_engine::io::{WriteOptions, output_format, write_mesh, write_mesh_with};
use meshlod_engine::pm_format::{encode, read_pm};
use meshlod_engine::procedural;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::validate::{clean, validate};
use meshlod_service::client::Remote;
use meshlod_service::convert::MeshLimits;
use meshlod_service::executor::{Executor, Local, load};
use meshlod_service::report;
use meshlod_service::server::{ServerConfig, serve_with_listener, shutdown_signal};
use serde_json::Value;

use crate::cli::{
    Cli, ClientOperation, Command, CompareArgs, HealthArgs, LogFormat, PredictArgs, RefineArgs, ServeArgs, Shape,
    SimplifyArgs,
};

/// `println!` that hands a failed write back as an error instead of panicking: a reader that
/// closes the pipe early (`meshlod info x.obj --json | head`) ends the command quietly
/// (`main` exits with 141, as a process stopped by SIGPIPE does).
macro_rules! out {
    ($($arg:tt)*) => {
        writeln!(std::io::stdout().lock(), $($arg)*)?
    };
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { file, json } => info(&file, json),
        Command::Convert { input, output, output_positional, clean, drop_attributes, write } => {
            let output = output.or(output_positional).context("convert: give the output with -o OUT")?;
            convert(&input, &output, clean, drop_attributes, &write.options())
        }
        Command::Hausdorff { a, b, tolerance, samples, seed, directed, json } => {
            let options = HausdorffOptions { samples, seed, tolerance, cancel: None };
            measure(&a, &b, &options, directed, json)
        }
        Command::Compare { a, b, compare, json } => compare_files(&a, &b, &compare, json),
        Command::Generate { shape, output, resolution } => generate(shape, &output, resolution),
        Command::Simplify(args) => run_simplify(&local(), &args),
        Command::Refine(args) => run_refine(&local(), &args),
        Command::Predict(args) => run_predict(&local(), &args),
        Command::Lod { input, output, faces, vertices, max_error, json, write } => {
            lod(&input, &output, faces, vertices, max_error, json, &write.options())
        }
        Command::Serve(args) => serve(args),
        Command::Client(args) => {
            let remote = Remote::connect(&args.server.server, args.server.token.clone(), args.server.deadline()?)?;
            match &args.operation {
                ClientOperation::Simplify(a) => run_simplify(&remote, a),
                ClientOperation::Refine(a) => run_refine(&remote, a),
                ClientOperation::Predict(a) => run_predict(&remote, a),
            }
        }
        Command::Health(args) => health(&args),
        Command::Batch(args) => crate::batch::run(args),
        Command::Samples(args) => crate::samples::run(args),
        Command::Demo { out_dir } => demo(out_dir),
    }
}

/// The local executor, its predictor from `$MESHLOD_MODEL_DIR` or built in.
fn local() -> Local {
    Local::new(std::env::var_os("MESHLOD_MODEL_DIR").map(PathBuf::from))
}

/// A spinner on the terminal while `work` runs (nothing when stderr is not a terminal).
fn with_progress<T>(what: String, work: impl FnOnce() -> T) -> T {
    if !std::io::stderr().is_terminal() {
        return work();
    }
    let spinner = indicatif::ProgressBar::new_spinner().with_message(what);
    spinner.enable_steady_tick(Duration::from_millis(120));
    let out = work();
    spinner.finish_and_clear();
    out
}

/// `x` with 6 significant digits, without trailing zeros.
pub(crate) fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = 5 - x.abs().log10().floor() as i32;
    if !(0..=15).contains(&decimals) {
        return format!("{x:.5e}");
    }
    let text = format!("{x:.*}", decimals as usize);
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text }
}

fn print_json(report: &impl serde::Serialize) -> Result<()> {
    out!("{}", serde_json::to_string_pretty(report)?);
    Ok(())
}

fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("meshlod: warning: {w}");
    }
}

fn print_hausdorff_line(measured: Option<&report::HausdorffKeys>) -> Result<()> {
    if let Some(d) = measured {
        out!(
            "  Hausdorff ≤ {} paper units (≥ {}, certified; {} % of the diagonal); mean {}, rms {}",
            sig(d.hausdorff_paper),
            sig(d.hausdorff_lower_paper),
            sig(d.hausdorff_diag_pct),
            sig(d.mean_paper),
            sig(d.rms_paper),
        );
    }
    Ok(())
}

/// `simplify` and `client simplify`.
fn run_simplify(executor: &dyn Executor, args: &SimplifyArgs) -> Result<()> {
    let job = args.job();
    let report = with_progress(format!("simplifying {}", args.input.display()), || executor.simplify(&job))?;
    warn_all(&report.warnings);
    if args.json {
        return print_json(&report);
    }
    // A count the text names only when it is not zero: ", 1 {one}" or ", N {many}".
    let counted = |n: u32, one: &str, many: &str| match n {
        0 => String::new(),
        1 => format!(", 1 {one}"),
        n => format!(", {n} {many}"),
    };
    // The rules behind the refusals, most first: what held the edges of a run that stopped
    // above its target.
    let mut rules: Vec<(u64, &str)> =
        report.refused.by_rule().into_iter().filter(|&(_, n)| n > 0).map(|(r, n)| (n, r)).collect();
    rules.sort_by(|x, y| y.0.cmp(&x.0).then(x.1.cmp(y.1)));
    let rules = if rules.is_empty() {
        String::new()
    } else {
        let named: Vec<String> = rules.iter().map(|(n, rule)| format!("{n} {}", rule.replace('_', " "))).collect();
        format!(" ({})", named.join(", "))
    };
    let holes = counted(report.holes_closed, "triangular hole closed", "triangular holes closed");
    let parts = counted(report.parts_removed, "part taken out", "parts taken out");
    let copies = counted(report.dropped_duplicate_faces, "duplicate face dropped", "duplicate faces dropped");
    let backs = counted(report.back_faces, "back face kept with its front", "back faces kept with their fronts");
    let halves = if report.halves { ", in two halves first" } else { "" };
    out!(
        "{} → {} faces, {} → {} vertices ({}): {} collapses, {} refused{rules}, {} frozen vertices{holes}{parts}{copies}{backs}{halves}",
        report.faces_in,
        report.faces_out,
        report.vertices_in,
        report.vertices_out,
        report.stop_reason.replace('_', " "),
        report.collapses,
        report.rejected,
        report.frozen_vertices,
    );
    let w = report.w.map_or(String::new(), |w| format!(" w = {}", sig(w)));
    out!(
        "  {}{w} ({}), {} placement, guard {}; {} s → {}",
        report.metric,
        report.w_source,
        report.placement,
        sig(report.guard),
        sig(report.seconds),
        args.output.display()
    );
    print_hausdorff_line(report.hausdorff.as_ref())?;
    if let Some(c) = &report.compare {
        let (views, size) = (c.pixels_views as usize, c.pixels_size as usize);
        out!("  {}", pixels_line(c.pixels_mae, c.pixels_psnr_db, c.pixels_silhouette, views, size));
    }
    if let (Some(pm), Some(keys)) = (&args.pm, &report.progressive) {
        let materials = if keys.pm_materials_bytes > 0 {
            format!(", {} of them materials and images", keys.pm_materials_bytes)
        } else {
            String::new()
        };
        out!(
            "  progressive mesh: {} splits, {} bytes{materials} ({} bytes per split) → {}",
            keys.pm_splits,
            keys.pm_bytes,
            sig(keys.bytes_per_split),
            pm.display()
        );
    }
    Ok(())
}

/// `refine` and `client refine`.
fn run_refine(executor: &dyn Executor, args: &RefineArgs) -> Result<()> {
    let job = args.job();
    let report = with_progress(format!("refining {}", args.input.display()), || executor.refine(&job))?;
    warn_all(&report.warnings);
    if args.json {
        return print_json(&report);
    }
    out!(
        "{} → {} faces ({}): ETC {} ({}), {} edges split, {} collapses; {} s → {}",
        report.faces_in,
        report.faces_out,
        report.mode,
        sig(report.etc),
        report.etc_source,
        report.split_edges,
        report.collapses,
        sig(report.seconds),
        args.output.display()
    );
    if let Some(d) = &report.reference {
        out!(
            "  against {}: Hausdorff ≤ {} paper units (≥ {}, certified), mean {}",
            args.reference.as_deref().unwrap_or(Path::new("the reference")).display(),
            sig(d.reference_hausdorff_paper),
            sig(d.reference_hausdorff_lower_paper),
            sig(d.reference_mean_paper),
        );
    }
    Ok(())
}

/// `predict` and `client predict`.
fn run_predict(executor: &dyn Executor, args: &PredictArgs) -> Result<()> {
    let report = executor.predict(&args.job())?;
    if args.json {
        return print_json(&report);
    }
    let spread: Vec<String> = report
        .classes
        .iter()
        .zip(&report.probabilities)
        .map(|(c, p)| format!("{}: {}", sig(*c), sig(f64::from(*p))))
        .collect();
    out!(
        "{} → {} faces: w = {} (probabilities {}), ETC ≈ {} to {}; model {}",
        report.faces_in,
        report.target_faces,
        sig(report.w),
        spread.join(", "),
        sig(report.etc),
        report.etc_mode,
        report.model_version,
    );
    Ok(())
}

fn info(file: &Path, json: bool) -> Result<()> {
    let mesh = load(file)?;
    let mut value = serde_json::to_value(validate(&mesh))?;
    // What the commands that write a result would say of this input (left out, carried as it
    // was, mended): in the JSON, and as every command says it on stderr.
    let warnings: Vec<String> = mesh.corners.input_warnings().collect();
    if json {
        value["warnings"] = serde_json::json!(warnings);
        out!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    warnings.iter().for_each(|w| eprintln!("meshlod: warning: {w}"));
    out!("{}", file.display());
    // The report's own field order: counts first.
    for (key, v) in value.as_object().expect("report is an object") {
        let shown = match v {
            Value::String(s) => s.clone(),
            Value::Number(n) if n.is_f64() => sig(n.as_f64().unwrap_or(f64::NAN)),
            Value::Array(items) => {
                let item = |i: &Value| i.as_f64().map(sig).or_else(|| i.as_str().map(String::from));
                items.iter().map(|i| item(i).unwrap_or_else(|| i.to_string())).collect::<Vec<_>>().join(" ")
            }
            other => other.to_string(),
        };
        out!("  {:<30} {shown}", key.replace('_', " "));
    }
    Ok(())
}

fn convert(input: &Path, output: &Path, do_clean: bool, drop_attributes: bool, write: &WriteOptions) -> Result<()> {
    write.check(output_format(output)?)?;
    let mut mesh = load(input)?;
    if drop_attributes {
        mesh.corners = Default::default();
    }
    let unwritten = meshlod_engine::io::unwritten_warning(output_format(output)?, &mesh);
    for warning in mesh.corners.input_warnings().chain(unwritten) {
        eprintln!("meshlod: warning: {warning}");
    }
    if do_clean {
        let (cleaned, report) = clean(&mesh);
        eprintln!("clean: {}", serde_json::to_string(&report)?);
        mesh = cleaned;
    }
    write_mesh_with(output, &mesh, write)?;
    Ok(())
}

fn measure(a: &Path, b: &Path, options: &HausdorffOptions, directed: bool, json: bool) -> Result<()> {
    let (mesh_a, mesh_b) = (load(a)?, load(b)?);
    if directed {
        let d = with_progress("measuring".into(), || directed_hausdorff(&mesh_a, &mesh_b, options))?;
        if json {
            return print_json(&report::hausdorff_directed(&d, options.tolerance));
        }
        out!(
            "a → b: at most {} paper units (certified), at least {}; mean {}, rms {}",
            sig(d.max_upper),
            sig(d.max_lower),
            sig(d.mean),
            sig(d.rms)
        );
        return Ok(());
    }
    let r = with_progress("measuring".into(), || hausdorff(&mesh_a, &mesh_b, options))?;
    if json {
        return print_json(&report::hausdorff_full(&r));
    }
    print_hausdorff(&r)
}

/// `meshlod compare`: renders of A and B compared, the figures printed, the pictures written
/// when asked.
fn compare_files(a: &Path, b: &Path, args: &CompareArgs, json: bool) -> Result<()> {
    let (mesh_a, mesh_b) = (load(a)?, load(b)?);
    let comparison = with_progress("rendering".into(), || compare(&mesh_a, &mesh_b, &args.options()))?;
    if let Some(png) = &args.png {
        comparison.write_png(png)?;
    }
    let r = &comparison.report;
    warn_all(&r.notes);
    if json {
        return print_json(r);
    }
    print_compare(r)
}

/// A comparison's pixel figures as one line of text.
fn pixels_line(mae: f64, psnr: Option<f64>, silhouette: f64, views: usize, size: usize) -> String {
    format!(
        "pixels: mean difference {} levels of 255, PSNR {}, silhouette {} % ({views} views of {size} px)",
        sig(mae),
        psnr.map_or("∞ (the same pictures)".to_string(), |p| format!("{} dB", sig(p))),
        sig(100.0 * silhouette),
    )
}

/// The figures of a comparison in text.
pub(crate) fn print_compare(r: &CompareReport) -> Result<()> {
    let line = pixels_line(r.mae, r.psnr, r.silhouette, r.views, r.size);
    out!("{line}; {} faces against {}", r.faces_b, r.faces_a);
    if let (Some(upper), Some(lower), Some(pct)) = (r.hausdorff, r.hausdorff_lower, r.hausdorff_diag_pct) {
        out!("Hausdorff ≤ {} paper units (≥ {}, certified; {} % of the diagonal)", sig(upper), sig(lower), sig(pct));
    }
    Ok(())
}

/// `meshlod hausdorff` in text: the certified figure first, then how it was obtained.
fn print_hausdorff(r: &HausdorffReport) -> Result<()> {
    out!(
        "Hausdorff ≤ {} paper units ({} % of the diagonal, {} absolute): certified upper bound; lower bound {} ({})",
        sig(r.hausdorff),
        sig(r.hausdorff_diag_pct),
        sig(r.hausdorff_absolute),
        sig(r.hausdorff_lower),
        if r.converged {
            format!("within the tolerance {}", r.tolerance)
        } else {
            format!("the work budget ran out before the tolerance {} was met", r.tolerance)
        }
    );
    out!(
        "  a → b: [{}, {}]   b → a: [{}, {}]",
        sig(r.a_to_b.max_lower),
        sig(r.a_to_b.max_upper),
        sig(r.b_to_a.max_lower),
        sig(r.b_to_a.max_upper)
    );
    out!(
        "  mean {}, rms {} (area-weighted, {} face samples); {} s",
        sig(r.mean),
        sig(r.rms),
        r.samples,
        sig(r.seconds)
    );
    Ok(())
}

fn lod(
    input: &Path,
    output: &Path,
    faces: Option<usize>,
    vertices: Option<usize>,
    max_error: Option<f32>,
    json: bool,
    write: &WriteOptions,
) -> Result<()> {
    write.check(output_format(output)?)?;
    if max_error.is_some_and(|e| !(e.is_finite() && e >= 0.0)) {
        bail!("--max-error {} must be a finite number ≥ 0", max_error.unwrap_or_default());
    }
    let pm = read_pm(input)?;
    let base = pm.base();
    if let Some(n) = faces
        && n < base.face_count()
    {
        eprintln!(
            "meshlod: warning: --faces {n} is below the coarsest level (the base mesh, {} faces): writing the base",
            base.face_count()
        );
    }
    if let Some(n) = vertices
        && n < base.vertex_count()
    {
        eprintln!(
            "meshlod: warning: --vertices {n} is below the coarsest level (the base mesh, {} vertices): writing the base",
            base.vertex_count()
        );
    }
    let level = match (faces, vertices, max_error) {
        (Some(n), _, _) => pm.level_for_faces(n),
        (_, Some(n), _) => n.saturating_sub(pm.base().vertex_count()).min(pm.levels()),
        // Errors do not increase along the splits: refine while the next split's error is above
        // the tolerance.
        (_, _, Some(e)) => pm.splits().iter().take_while(|s| s.error > e).count(),
        _ => bail!("give one of --faces, --vertices or --max-error"),
    };
    let mesh = pm.at_level(level);
    write_mesh_with(output, &mesh, write)?;
    if json {
        let report = serde_json::json!({
            "level": level, "levels": pm.levels(), "faces": mesh.face_count(), "vertices": mesh.vertex_count()
        });
        out!("{report}");
    } else {
        out!("level {level} of {}: {} faces, {} vertices", pm.levels(), mesh.face_count(), mesh.vertex_count());
    }
    Ok(())
}

/// Largest sphere level `generate` accepts (20 · 4⁹ = 5.2 M faces).
const MAX_SPHERE_LEVEL: u32 = 9;

fn generate(shape: Shape, output: &Path, resolution: Option<u32>) -> Result<()> {
    output_format(output)?;
    let mesh = match (shape, resolution) {
        (_, Some(0)) => bail!("--resolution must be at least 1"),
        (Shape::Sphere, Some(r)) if r > MAX_SPHERE_LEVEL => {
            bail!("--resolution {r}: the sphere's subdivision level is at most {MAX_SPHERE_LEVEL}")
        }
        (Shape::Sphere, r) => procedural::icosphere(r.unwrap_or(6)),
        (Shape::Torus, r) => procedural::torus(r.unwrap_or(64) * 2, r.unwrap_or(64), 0.35),
        (Shape::Box, r) => procedural::sharp_box(r.unwrap_or(64)),
        (Shape::Terrain, r) => procedural::terrain(r.unwrap_or(64), 1),
        (Shape::Blob, r) => procedural::bumpy_blob(r.unwrap_or(64), r.unwrap_or(64) * 2, 1),
    };
    write_mesh(output, &mesh)?;
    eprintln!("{} vertices, {} faces → {}", mesh.vertex_count(), mesh.face_count(), output.display());
    Ok(())
}

fn init_logging(format: LogFormat) {
    let filter = tracing_subscriber::EnvFilter::try_from_env("MESHLOD_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // Colours only for a person watching: not in files, pipes or container logs.
        .with_ansi(std::io::stderr().is_terminal());
    let _ = match format {
        LogFormat::Text => builder.try_init(),
        LogFormat::Json => builder.json().try_init(),
    };
}

/// Runs the server until SIGTERM or Ctrl-C.
fn serve(args: ServeArgs) -> Result<()> {
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
        limits: MeshLimits::for_faces(args.max_faces),
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

fn health(args: &HealthArgs) -> Result<()> {
    let timeout = Duration::try_from_secs_f64(args.timeout).context("--timeout")?;
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    runtime.block_on(async {
        tokio::time::timeout(timeout, meshlod_service::client::health(&args.server, &args.service, timeout))
            .await
            .map_err(|_| anyhow::anyhow!("{}: no answer within {} s", args.server, args.timeout))?
    })?;
    out!("serving");
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
    out!(
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
    out!(
        "simplified 90% with {} (w = {}): {} → {} faces in {} s; progressive mesh {} splits, {} bytes → {}",
        options.metric.name(),
        options.metric.w().unwrap_or(0.0),
        result.stats.faces_in,
        result.stats.faces_out,
        sig(result.stats.seconds),
        pm.levels(),
        bytes.len(),
        pm_path.display()
    );
    out!("level of detail    faces   Hausdorff (paper units)   % of diagonal");
    for faces in [result.stats.faces_out, 10_000, 25_000, original.face_count()] {
        let lod = pm.at_faces(faces);
        let d: HausdorffReport = hausdorff(&original, &lod, &HausdorffOptions::default())?;
        out!(
            "  ≤ {faces:>7}    {:>7}   {:>20}    {:>10}",
            lod.face_count(),
            sig(d.hausdorff),
            sig(d.hausdorff_diag_pct)
        );
    }
    Ok(())
}
