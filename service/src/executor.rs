//! Jobs on files, and the one trait that runs them here ([`Local`]) or on a server
//! ([`crate::client::Remote`]). A job reads its input, runs, writes its outputs and returns its
//! report; both executors finish a job with the same code, so their reports have the same keys.
//! The CLI's single commands, `meshlod client` and `meshlod batch` all go through here.

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use anyhow::{Context, Result};
use meshlod_engine::Mesh;
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::{WriteOptions, output_format, read_mesh, write_mesh_with};
use meshlod_engine::pm::ProgressiveMesh;
use meshlod_engine::pm_format::{encode, encode_lossless};
use meshlod_predictor::Predictor;

use crate::error::JobError;
use crate::proto;
use crate::report::{self, PredictReport, RefineReport, SimplifyReport};
use crate::request::{EtcChoice, RefineRequest, SimplifyRequest, WChoice};

/// One simplification of a file.
#[derive(Debug, Clone)]
pub struct SimplifyJob {
    /// Input mesh.
    pub input: PathBuf,
    /// Output mesh (its extension picks the format).
    pub output: PathBuf,
    /// How the output is written.
    pub write: WriteOptions,
    /// What to do, in the engine's terms (whether the progressive mesh is recorded is set from
    /// `pm`).
    pub options: SimplifyRequest,
    /// Where to write the progressive mesh, if anywhere.
    pub pm: Option<PathBuf>,
}

impl SimplifyJob {
    /// The request as the job runs it: the progressive mesh recorded when a `.pm` is asked for.
    pub fn request(&self) -> SimplifyRequest {
        let mut request = self.options.clone();
        request.options.record_progressive = self.pm.is_some();
        request
    }
}

/// One refinement of a file.
#[derive(Debug, Clone)]
pub struct RefineJob {
    /// Input mesh.
    pub input: PathBuf,
    /// Output mesh.
    pub output: PathBuf,
    /// How the output is written.
    pub write: WriteOptions,
    /// What to do, in the engine's terms.
    pub request: RefineRequest,
    /// Measure the output against this mesh.
    pub reference: Option<PathBuf>,
}

/// One prediction for a file.
#[derive(Debug, Clone)]
pub struct PredictJob {
    /// Input mesh.
    pub input: PathBuf,
    /// Faces to keep.
    pub target_faces: Option<u32>,
    /// Fraction of faces to remove.
    pub target_ratio: Option<f64>,
}

/// Runs jobs: here, or on a server. Shared by the threads of a batch.
pub trait Executor: Sync {
    /// Runs a simplification and writes its outputs.
    fn simplify(&self, job: &SimplifyJob) -> Result<SimplifyReport>;
    /// Runs a refinement and writes its output.
    fn refine(&self, job: &RefineJob) -> Result<RefineReport>;
    /// Asks the predictor.
    fn predict(&self, job: &PredictJob) -> Result<PredictReport>;
}

/// Reads a job's input mesh.
pub fn load(path: &Path) -> Result<Mesh> {
    Ok(read_mesh(path)?)
}

/// Checks what a simplify job will write before any work: a mesh format and folders that exist.
pub fn check_simplify_outputs(job: &SimplifyJob) -> Result<()> {
    job.write.check(output_format(&job.output)?)?;
    if let Some(pm) = &job.pm
        && let Some(parent) = pm.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        anyhow::bail!("{}: its folder does not exist", pm.display());
    }
    Ok(())
}

/// The end of every simplify job, wherever it ran: writes the mesh and the progressive mesh (the
/// `.pm` bytes a server sent, `pm_file`, as they are; else encoded here), and builds the report.
pub fn finish_simplify(
    job: &SimplifyJob,
    mesh: &Mesh,
    progressive: Option<&ProgressiveMesh>,
    pm_file: Option<&[u8]>,
    stats: &proto::SimplifyStats,
    (measured, compared): (Option<&proto::HausdorffReport>, Option<&proto::CompareReport>),
) -> Result<SimplifyReport> {
    write_mesh_with(&job.output, mesh, &job.write)?;
    let mut report = report::simplify(stats, measured, compared);
    add_unwritten_warning(&mut report.warnings, &job.output, mesh);
    if let Some(path) = &job.pm {
        let pm = progressive.context("the run returned no progressive mesh")?;
        let bytes = match pm_file {
            Some(file) => file.to_vec(),
            None if job.options.progressive_lossless => encode_lossless(pm),
            None => encode(pm),
        };
        std::fs::write(path, &bytes).with_context(|| format!("writing {}", path.display()))?;
        report.progressive = Some(report::progressive(pm, bytes.len()));
    }
    Ok(report)
}

/// Adds to a report's warnings what the output file's format could not hold of `mesh`.
fn add_unwritten_warning(warnings: &mut Vec<String>, output: &std::path::Path, mesh: &Mesh) {
    let warning = output_format(output).ok().and_then(|format| meshlod_engine::io::unwritten_warning(format, mesh));
    warnings.extend(warning);
}

/// The end of every refine job: writes the mesh, measures it against the reference if asked.
pub fn finish_refine(job: &RefineJob, mesh: &Mesh, stats: &proto::RefineStats) -> Result<RefineReport> {
    write_mesh_with(&job.output, mesh, &job.write)?;
    let mut report = report::refine(stats);
    add_unwritten_warning(&mut report.warnings, &job.output, mesh);
    if let Some(reference) = &job.reference {
        let reference_mesh = load(reference)?;
        let d = hausdorff(&reference_mesh, mesh, &HausdorffOptions::default())?;
        report.reference = Some(report::reference(&d));
    }
    Ok(report)
}

/// Runs jobs in this process; the predictor is loaded on first use.
#[derive(Debug, Default)]
pub struct Local {
    model_dir: Option<PathBuf>,
    predictor: OnceLock<std::result::Result<Arc<Predictor>, String>>,
}

impl Local {
    /// An executor whose predictor comes from `model_dir` (`predictor.onnx` and `metadata.json`),
    /// or is the one built in.
    pub fn new(model_dir: Option<PathBuf>) -> Local {
        Local { model_dir, predictor: OnceLock::new() }
    }

    /// The predictor, loaded once.
    pub fn predictor(&self) -> Result<Arc<Predictor>> {
        self.predictor
            .get_or_init(|| {
                crate::predict::load(self.model_dir.as_deref())
                    .map(Arc::new)
                    .map_err(|e| format!("loading the predictor model: {e}"))
            })
            .clone()
            .map_err(anyhow::Error::msg)
    }

    fn predictor_if(&self, needed: bool) -> Result<Option<Arc<Predictor>>> {
        if needed { self.predictor().map(Some) } else { Ok(None) }
    }
}

/// A job's error as an error for people: where the field is the input mesh, it names the file
/// instead (`bunny.obj.mesh.indices[7]: …` reads as the file's fault); otherwise the typed error
/// itself, so that the command line can name the flag that set the field.
fn job_error(e: JobError, input: &Path) -> anyhow::Error {
    match e.field.strip_prefix("input") {
        Some(rest) if rest.is_empty() || rest.starts_with('.') => {
            anyhow::anyhow!("{}{rest}: {}", input.display(), e.reason)
        }
        _ => anyhow::Error::new(e),
    }
}

impl Executor for Local {
    fn simplify(&self, job: &SimplifyJob) -> Result<SimplifyReport> {
        check_simplify_outputs(job)?;
        let mesh = load(&job.input)?;
        let request = job.request();
        let predictor = self.predictor_if(request.w == WChoice::Auto)?;
        let run =
            crate::jobs::simplify(&mesh, &request, predictor.as_deref(), None).map_err(|e| job_error(e, &job.input))?;
        let progressive = run.result.progressive.as_ref();
        let measured = (run.hausdorff.as_ref(), run.compare.as_ref());
        finish_simplify(job, &run.result.mesh, progressive, None, &run.stats, measured)
    }

    fn refine(&self, job: &RefineJob) -> Result<RefineReport> {
        job.write.check(output_format(&job.output)?)?;
        let mesh = load(&job.input)?;
        let predictor = self.predictor_if(job.request.etc == EtcChoice::Auto)?;
        let (result, stats) = crate::jobs::refine(&mesh, &job.request, predictor.as_deref(), None, usize::MAX)
            .map_err(|e| job_error(e, &job.input))?;
        finish_refine(job, &result.mesh, &stats)
    }

    fn predict(&self, job: &PredictJob) -> Result<PredictReport> {
        let mesh = load(&job.input)?;
        let predictor = self.predictor()?;
        let response = crate::jobs::predict_mesh(&predictor, &mesh, job.target_faces, job.target_ratio)
            .map_err(|e| job_error(e, &job.input))?;
        Ok(report::predict(&response))
    }
}
