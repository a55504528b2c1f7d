//! `meshlod batch MANIFEST`: many jobs, here or on one server over one connection, with bounded
//! parallelism, a progress bar, one JSON result line per job, resumability, and sharding across
//! the pods of a Kubernetes Indexed Job. The manifest format is [`crate::cli::MANIFEST_HELP`].

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use meshlod_service::client::Remote;
use meshlod_service::executor::{Executor, Local};
use serde::Deserialize;
use serde_json::json;

use crate::cli::{BatchArgs, Job, parse_job};

/// One line of the manifest; any other key is refused.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestLine {
    op: String,
    input: PathBuf,
    output: PathBuf,
    #[serde(default)]
    args: Vec<String>,
}

/// A job of the manifest with its line number.
#[derive(Debug)]
struct Entry {
    line: usize,
    job: Job,
}

impl Entry {
    fn input(&self) -> &Path {
        match &self.job {
            Job::Simplify(a) => &a.input,
            Job::Refine(a) => &a.input,
        }
    }

    /// Every file the job writes.
    fn outputs(&self) -> Vec<&Path> {
        match &self.job {
            Job::Simplify(a) => std::iter::once(a.output.as_path()).chain(a.pm.as_deref()).collect(),
            Job::Refine(a) => vec![a.output.as_path()],
        }
    }
}

/// Reads and checks every line of the manifest: all jobs parse, or the batch does not start.
fn read_manifest(manifest: &Path) -> Result<Vec<Entry>> {
    let text = std::fs::read_to_string(manifest).with_context(|| format!("reading {}", manifest.display()))?;
    let base = manifest.parent().unwrap_or(Path::new(".")).to_path_buf();
    let resolve = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { base.join(p) };
    let mut jobs = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() || line.trim_start().starts_with('#') {
            continue;
        }
        let at = || format!("{} line {}", manifest.display(), i + 1);
        let entry: ManifestLine = serde_json::from_str(line).with_context(at)?;
        let (input, output) = (resolve(&entry.input), resolve(&entry.output));
        let mut job =
            parse_job(&entry.op, &input.to_string_lossy(), &output.to_string_lossy(), &entry.args).with_context(at)?;
        // Path flags are relative to the manifest too, like input and output.
        match &mut job {
            Job::Simplify(a) => {
                a.json = true;
                a.pm = a.pm.as_deref().map(resolve);
            }
            Job::Refine(a) => {
                a.json = true;
                a.reference = a.reference.as_deref().map(resolve);
            }
        }
        jobs.push(Entry { line: i + 1, job });
    }
    if jobs.is_empty() {
        bail!("{}: no jobs", manifest.display());
    }
    Ok(jobs)
}

/// Whether every output of a job exists and is newer than its input and the manifest, and the
/// files it refers to (an OBJ's MTL file and textures) are there.
fn up_to_date(entry: &Entry, manifest: &Path) -> bool {
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    let (Some(input), Some(manifest)) = (modified(entry.input()), modified(manifest)) else { return false };
    entry.outputs().into_iter().all(|o| {
        modified(o).is_some_and(|o| o >= input && o >= manifest)
            && meshlod_engine::io::referenced_files(o).iter().all(|f| f.is_file())
    })
}

fn run_job(entry: &Entry, executor: &dyn Executor) -> Result<serde_json::Value> {
    for output in entry.outputs() {
        if let Some(parent) = output.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
        }
    }
    let report = match &entry.job {
        Job::Simplify(a) => executor.simplify(&a.job()).and_then(|r| Ok(serde_json::to_value(r)?)),
        Job::Refine(a) => executor.refine(&a.job()).and_then(|r| Ok(serde_json::to_value(r)?)),
    };
    if report.is_err() {
        // Whatever the job wrote before it failed would make a rerun skip it.
        for output in entry.outputs() {
            let _ = std::fs::remove_file(output);
        }
    }
    report
}

/// Runs a batch.
pub fn run(args: BatchArgs) -> Result<()> {
    let mut jobs = read_manifest(&args.manifest)?;
    if let (Some(index), Some(count)) = (args.shard_index, args.shard_count) {
        if count == 0 || index >= count {
            bail!("shard {index} of {count}: the index must be below the count");
        }
        let mut k = 0;
        jobs.retain(|_| {
            k += 1;
            (k - 1) % count == index
        });
    } else if args.shard_count.is_some_and(|c| c > 1) {
        bail!("--shard-count needs --shard-index (or $JOB_COMPLETION_INDEX)");
    }
    let workers = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get())).max(1);
    let executor: Box<dyn Executor> = match &args.server {
        Some(server) => {
            let timeout = Duration::try_from_secs_f64(args.timeout).context("--timeout")?;
            Box::new(Remote::connect(server, args.token.clone(), timeout)?)
        }
        None => Box::new(Local::new(std::env::var_os("MESHLOD_MODEL_DIR").map(PathBuf::from))),
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
                while let Some(entry) = jobs.get(next.fetch_add(1, Ordering::SeqCst)) {
                    let started = Instant::now();
                    let (line, input, outputs) = (entry.line, entry.input(), entry.outputs());
                    let output = outputs[0];
                    let record = if !args.force && up_to_date(entry, &args.manifest) {
                        json!({"line": line, "input": input, "output": output, "status": "skipped"})
                    } else {
                        match run_job(entry, executor.as_ref()) {
                            Ok(report) => json!({"line": line, "input": input, "output": output, "status": "ok",
                                "seconds": started.elapsed().as_secs_f64(), "report": report}),
                            Err(e) => {
                                failed.fetch_add(1, Ordering::SeqCst);
                                json!({"line": line, "input": input, "output": output, "status": "error",
                                    "message": format!("{e:#}")})
                            }
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
