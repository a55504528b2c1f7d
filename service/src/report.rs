//! The JSON reports of every front end, built from the contract's messages: a local run and the
//! same run on a server give the same keys, because both pass through these functions.
//!
//! Distances carry their unit in the key: `_paper` (the mesh centred and scaled so its largest
//! bounding-box side spans [−1, 1]), `_absolute` (the input's own units) or `_diag_pct` (% of the
//! bounding-box diagonal).

use meshlod_engine::hausdorff::{DirectedDistance, HausdorffReport};
use meshlod_engine::pm::ProgressiveMesh;
use serde::Serialize;
use serde_json::{Map, Value, json};

use crate::proto;

/// A report: keys in the order they are written.
pub type Report = Map<String, Value>;

fn object(value: Value) -> Report {
    match value {
        Value::Object(map) => map,
        _ => unreachable!("reports are built from object literals"),
    }
}

/// The certified distance of a result from its input, as simplify reports it (paper units).
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HausdorffKeys {
    pub hausdorff_paper: f64,
    pub hausdorff_lower_paper: f64,
    pub hausdorff_diag_pct: f64,
    pub hausdorff_tolerance: f64,
    pub hausdorff_converged: bool,
    pub mean_paper: f64,
    pub rms_paper: f64,
    pub samples: u64,
}

impl HausdorffKeys {
    /// The keys of a measured distance.
    pub fn of(d: &proto::HausdorffReport) -> HausdorffKeys {
        HausdorffKeys {
            hausdorff_paper: d.hausdorff,
            hausdorff_lower_paper: d.hausdorff_lower,
            hausdorff_diag_pct: d.hausdorff_diag_pct,
            hausdorff_tolerance: d.tolerance,
            hausdorff_converged: d.converged,
            mean_paper: d.mean,
            rms_paper: d.rms,
            samples: d.samples,
        }
    }
}

/// Input and result compared in pixels, as simplify reports it (`--compare`).
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompareKeys {
    pub pixels_mae: f64,
    pub pixels_psnr_db: Option<f64>,
    pub pixels_silhouette: f64,
    pub pixels_views: u32,
    pub pixels_size: u32,
}

impl CompareKeys {
    /// The keys of a comparison.
    pub fn of(c: &proto::CompareReport) -> CompareKeys {
        CompareKeys {
            pixels_mae: c.mae,
            pixels_psnr_db: c.psnr,
            pixels_silhouette: c.silhouette,
            pixels_views: c.views,
            pixels_size: c.size,
        }
    }
}

/// The refused candidates by rule (they sum to `rejected`), every rule named.
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Refused {
    pub link: u64,
    pub too_few_faces: u64,
    pub normal_change: u64,
    pub needle: u64,
    pub fold: u64,
    pub seam: u64,
    pub uv_flip: u64,
}

impl Refused {
    /// Each rule's name (as the report's key) with its count.
    pub fn by_rule(&self) -> [(&'static str, u64); 7] {
        [
            ("link", self.link),
            ("too_few_faces", self.too_few_faces),
            ("normal_change", self.normal_change),
            ("needle", self.needle),
            ("fold", self.fold),
            ("seam", self.seam),
            ("uv_flip", self.uv_flip),
        ]
    }
}

/// One w a search tried, with the distance it gave.
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WCandidate {
    pub w: f64,
    pub hausdorff_paper: f64,
}

/// The progressive mesh's `.pm` file, as simplify reports it.
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProgressiveKeys {
    /// The file's bytes.
    pub pm_bytes: usize,
    /// Of them, the materials section (its images inside).
    pub pm_materials_bytes: usize,
    pub pm_splits: usize,
    /// Bytes per split, the base and the materials section left out.
    pub bytes_per_split: f64,
}

/// A simplification's report: what `--json` prints (field names as keys) and the text says.
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimplifyReport {
    pub faces_in: u32,
    pub faces_out: u32,
    pub target_faces: u32,
    pub kept_fraction: f64,
    pub removed_fraction: f64,
    pub vertices_in: u32,
    pub vertices_out: u32,
    pub collapses: u32,
    pub stop_reason: String,
    pub rejected: u64,
    pub refused: Refused,
    pub dropped_duplicate_faces: u32,
    pub back_faces: u32,
    pub halves: bool,
    pub flat_normals: bool,
    pub frozen_vertices: u32,
    pub holes_closed: u32,
    pub parts_removed: u32,
    pub metric: String,
    /// `None` for Melax, which has no w.
    pub w: Option<f64>,
    pub w_source: &'static str,
    pub w_candidates: Option<Vec<WCandidate>>,
    pub model_version: Option<String>,
    pub placement: String,
    pub normals: String,
    pub boundary: String,
    pub guard: f64,
    pub distance_term: f64,
    pub max_collapse_error_paper: f64,
    pub seconds: f64,
    pub warnings: Vec<String>,
    #[serde(flatten)]
    pub hausdorff: Option<HausdorffKeys>,
    #[serde(flatten)]
    pub compare: Option<CompareKeys>,
    #[serde(flatten)]
    pub progressive: Option<ProgressiveKeys>,
}

/// A simplification's report from the contract's figures: the run's, and the distance and the
/// comparison in pixels when they were measured.
pub fn simplify(
    s: &proto::SimplifyStats,
    measured: Option<&proto::HausdorffReport>,
    compared: Option<&proto::CompareReport>,
) -> SimplifyReport {
    let w_source = match proto::WSource::try_from(s.w_source) {
        Ok(proto::WSource::Predicted) => "predicted",
        Ok(proto::WSource::Searched) => "searched",
        _ => "given",
    };
    let candidates: Vec<WCandidate> =
        s.w_candidates.iter().map(|c| WCandidate { w: c.w, hausdorff_paper: c.hausdorff }).collect();
    let r = s.refused.unwrap_or_default();
    let kept = s.faces_out as f64 / s.faces_in.max(1) as f64;
    SimplifyReport {
        faces_in: s.faces_in,
        faces_out: s.faces_out,
        target_faces: s.target_faces,
        kept_fraction: kept,
        removed_fraction: 1.0 - kept,
        vertices_in: s.vertices_in,
        vertices_out: s.vertices_out,
        collapses: s.collapses,
        stop_reason: s.stop_reason.clone(),
        rejected: s.rejected,
        refused: Refused {
            link: r.link,
            too_few_faces: r.too_few_faces,
            normal_change: r.normal_change,
            needle: r.needle,
            fold: r.fold,
            seam: r.seam,
            uv_flip: r.uv_flip,
        },
        dropped_duplicate_faces: s.dropped_duplicate_faces,
        back_faces: s.back_faces,
        halves: s.halves,
        flat_normals: s.flat_normals,
        frozen_vertices: s.frozen_vertices,
        holes_closed: s.holes_closed,
        parts_removed: s.parts_removed,
        metric: s.metric.clone(),
        w: (s.metric != "melax").then_some(s.w),
        w_source,
        w_candidates: (!candidates.is_empty()).then_some(candidates),
        model_version: (!s.model_version.is_empty()).then(|| s.model_version.clone()),
        placement: s.placement.clone(),
        normals: s.normals.clone(),
        boundary: s.boundary.clone(),
        guard: s.guard,
        distance_term: s.distance_term,
        max_collapse_error_paper: s.max_collapse_error,
        seconds: s.seconds,
        warnings: s.warnings.clone(),
        hausdorff: measured.map(HausdorffKeys::of),
        compare: compared.map(CompareKeys::of),
        progressive: None,
    }
}

/// The progressive-mesh keys of a simplify report whose `.pm` file has `bytes` bytes: the
/// materials section (its images inside) apart, and the bytes per split without it or the base.
pub fn progressive(pm: &ProgressiveMesh, bytes: usize) -> ProgressiveKeys {
    let base_bytes = 12 * (pm.base().vertex_count() + pm.base().face_count());
    let materials = meshlod_engine::pm_format::materials_section_len(pm);
    ProgressiveKeys {
        pm_bytes: bytes,
        pm_materials_bytes: materials,
        pm_splits: pm.levels(),
        bytes_per_split: (bytes.saturating_sub(base_bytes + 32 + materials)) as f64 / pm.levels().max(1) as f64,
    }
}

/// A refinement measured against a reference mesh (paper units).
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReferenceKeys {
    pub reference_hausdorff_paper: f64,
    pub reference_hausdorff_lower_paper: f64,
    pub reference_hausdorff_diag_pct: f64,
    pub reference_mean_paper: f64,
    pub reference_mean_diag_pct: f64,
}

/// The keys of a refine report measured against a reference mesh.
pub fn reference(d: &HausdorffReport) -> ReferenceKeys {
    ReferenceKeys {
        reference_hausdorff_paper: d.hausdorff,
        reference_hausdorff_lower_paper: d.hausdorff_lower,
        reference_hausdorff_diag_pct: d.hausdorff_diag_pct,
        reference_mean_paper: d.mean,
        reference_mean_diag_pct: d.mean_diag_pct,
    }
}

/// A refinement's report.
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefineReport {
    pub faces_in: u32,
    pub faces_out: u32,
    pub mode: String,
    pub etc: f64,
    pub etc_source: String,
    pub model_version: Option<String>,
    pub threshold: f64,
    pub rounds: u32,
    pub split_edges: u32,
    pub collapses: u32,
    pub seconds: f64,
    pub warnings: Vec<String>,
    #[serde(flatten)]
    pub reference: Option<ReferenceKeys>,
}

/// A refinement's report from the contract's figures.
pub fn refine(s: &proto::RefineStats) -> RefineReport {
    RefineReport {
        faces_in: s.faces_in,
        faces_out: s.faces_out,
        mode: s.mode.clone(),
        etc: s.etc,
        etc_source: s.etc_source.clone(),
        model_version: (!s.model_version.is_empty()).then(|| s.model_version.clone()),
        threshold: s.threshold,
        rounds: s.rounds,
        split_edges: s.split_edges,
        collapses: s.collapses,
        seconds: s.seconds,
        warnings: s.warnings.clone(),
        reference: None,
    }
}

/// A prediction's report.
// The fields are the JSON report keys, unit in the name (module doc).
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictReport {
    pub faces_in: u64,
    pub target_faces: u64,
    pub w: f64,
    pub probabilities: Vec<f32>,
    pub classes: Vec<f64>,
    pub etc: f64,
    pub etc_mode: String,
    pub model_version: String,
}

/// A prediction's report from the contract's answer.
pub fn predict(r: &proto::PredictResponse) -> PredictReport {
    PredictReport {
        faces_in: r.faces_in,
        target_faces: r.target_faces,
        w: r.w,
        probabilities: r.probabilities.clone(),
        classes: r.classes.clone(),
        etc: r.etc,
        etc_mode: r.etc_mode.clone(),
        model_version: r.model_version.clone(),
    }
}

fn directed(d: &DirectedDistance) -> Value {
    json!({
        "max_lower_paper": d.max_lower,
        "max_upper_paper": d.max_upper,
        "mean_paper": d.mean,
        "rms_paper": d.rms,
        "evaluations": d.evaluations,
        "splits": d.splits,
        "converged": d.converged,
    })
}

/// The `hausdorff` command's report: symmetric figures first, then each direction.
pub fn hausdorff_full(r: &HausdorffReport) -> Report {
    object(json!({
        "hausdorff_paper": r.hausdorff,
        "hausdorff_lower_paper": r.hausdorff_lower,
        "hausdorff_absolute": r.hausdorff_absolute,
        "hausdorff_lower_absolute": r.hausdorff_lower_absolute,
        "hausdorff_diag_pct": r.hausdorff_diag_pct,
        "tolerance": r.tolerance,
        "converged": r.converged,
        "mean_paper": r.mean,
        "mean_diag_pct": r.mean_diag_pct,
        "rms_paper": r.rms,
        "samples": r.samples,
        "seconds": r.seconds,
        "a_to_b": directed(&r.a_to_b),
        "b_to_a": directed(&r.b_to_a),
    }))
}

/// The `hausdorff --directed` report: one direction, A → B.
pub fn hausdorff_directed(d: &DirectedDistance, tolerance: f64) -> Report {
    let mut report = object(json!({ "direction": "a_to_b", "tolerance": tolerance }));
    if let Value::Object(fields) = directed(d) {
        report.extend(fields);
    }
    report
}
