//! `meshlod batch MANIFEST`: many jobs, locally or against a server, with bounded parallelism, a
//! progress bar, one JSON result line per job, and resumability.
//!
//! The manifest is JSON lines; each line is one job with the same flags as the command line:
//!
//! ```text
//! {"op": "simplify", "input": "in/bunny.obj", "output": "out/bunny-10.ply", "args": ["--ratio", "0.9"]}
//! {"op": "refine",   "input": "in/cow.obj",   "output": "out/cow-fine.obj", "args": ["--etc", "1.0"]}
//! ```
//!
//! A job whose output exists and is newer than its input and than the manifest is skipped
//! (`--force` redoes it), so an interrupted batch resumes where it stopped. Relative paths are
//! relative to the manifest's folder.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Deserialize;
use serde_json::json;

use crate::commands::{Job, parse_job, refine_report, simplify_report};

/// `meshlod batch` flags.
#[derive(Debug, Args)]
pub(crate) struct BatchArgs {
    /// Manifest: one JSON job per line.
    manifest: PathBuf,
    /// Run against this server instead of locally.
    #[arg(long, env = "MESHLOD_SERVER")]
    server: Option<String>,
    /// Bearer token for the server.
    #[arg(long, env = "MESHLOD_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Jobs at once (default: the number of cores).
    #[arg(long)]
    jobs: Option<usize>,
    /// Write the per-job results (JSON lines) here instead of stdout.
    #[arg(long)]
    results: Option<PathBuf>,
    /// Redo jobs whose output is already up to date.
    #[arg(long)]
    force: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, Deserialize)]
struct ManifestLine {
    op: String,
    input: PathBuf,
    output: PathBuf,
    #[serde(default)]
    args: Vec<String>,
}

fn up_to_date(input: &Path, output: &Path, manifest: &Path) -> bool {
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    match (modified(input), modified(output), modified(manifest)) {
        (Some(i), Some(o), Some(m)) => o >= i && o >= m,
        _ => false,
    }
}

/// Runs a batch.
pub(crate) fn run(args: BatchArgs) -> Result<()> {
    let text =
        std::fs::read_to_string(&args.manifest).with_context(|| format!("reading {}", args.manifest.display()))?;
    let base = args.manifest.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut jobs = Vec::new();
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
    {
        let entry: ManifestLine = serde_json::from_str(line)
            .with_context(|| format!("{} line {}: not a job object", args.manifest.display(), i + 1))?;
        let input = base.join(&entry.input);
        let output = base.join(&entry.output);
        let job = parse_job(&entry.op, &input.to_string_lossy(), &output.to_string_lossy(), &entry.args)
            .with_context(|| format!("{} line {}", args.manifest.display(), i + 1))?;
        jobs.push((i + 1, input, output, job));
    }
    if jobs.is_empty() {
        bail!("{}: no jobs", args.manifest.display());
    }
    let workers = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get())).max(1);
    let runtime = match &args.server {
        Some(_) => Some(tokio::runtime::Runtime::new().context("starting the async runtime")?),
        None => None,
    };
    let progress = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(jobs.len() as u64).with_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} jobs, {elapsed} {msg}")
                .expect("valid template"),
        )
    };
    let sink: Mutex<Box<dyn Write + Send>> = Mutex::new(match &args.results {
        Some(path) => Box::new(std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?),
        None => Box::new(std::io::stdout()),
    });
    let next = AtomicUsize::new(0);
    let failed = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..workers.min(jobs.len()) {
            scope.spawn(|| {
                while let Some((line, input, output, job)) = jobs.get(next.fetch_add(1, Ordering::SeqCst)) {
                    let started = Instant::now();
                    let result = if !args.force && up_to_date(input, output, &args.manifest) {
                        Ok(None)
                    } else {
                        run_job(job, runtime.as_ref(), &args).map(Some)
                    };
                    let record = match result {
                        Ok(None) => json!({"line": line, "input": input, "output": output, "status": "skipped"}),
                        Ok(Some(report)) => json!({"line": line, "input": input, "output": output, "status": "ok",
                            "seconds": started.elapsed().as_secs_f64(), "report": report}),
                        Err(e) => {
                            failed.fetch_add(1, Ordering::SeqCst);
                            json!({"line": line, "input": input, "output": output, "status": "error", "message": format!("{e:#}")})
                        }
                    };
                    if let Ok(mut out) = sink.lock() {
                        let _ = writeln!(out, "{record}");
                    }
                    progress.inc(1);
                }
            });
        }
    });
    progress.finish_with_message("done");
    let failed = failed.load(Ordering::SeqCst);
    if failed > 0 {
        bail!("{failed} of {} jobs failed (see the results)", jobs.len());
    }
    Ok(())
}

fn run_job(job: &Job, runtime: Option<&tokio::runtime::Runtime>, args: &BatchArgs) -> Result<serde_json::Value> {
    if let Some(parent) = match job {
        Job::Simplify(a) => a.output.parent(),
        Job::Refine(a) => a.output.parent(),
    } {
        std::fs::create_dir_all(parent).ok();
    }
    match (runtime, &args.server) {
        (Some(runtime), Some(server)) => runtime.block_on(async {
            let mut client = crate::remote::connect(server, 600.0).await?;
            match job {
                Job::Simplify(a) => crate::remote::remote_simplify(&mut client, a, &args.token).await,
                Job::Refine(a) => crate::remote::remote_refine(&mut client, a, &args.token).await,
            }
        }),
        _ => match job {
            Job::Simplify(a) => simplify_report(a),
            Job::Refine(a) => refine_report(a),
        },
    }
}
