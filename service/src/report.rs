//! The JSON reports of every front end, built from the contract's messages: a local run and the
//! same run on a server give the same keys, because both pass through these functions.
//!
//! Distances carry their unit in the key: `_paper` (the mesh centred and scaled so its largest
//! bounding-box side spans [−1, 1]), `_absolute` (the input's own units) or `_diag_pct` (% of the
//! bounding-box diagonal).

use meshlod_engine::hausdorff::{DirectedDistance, HausdorffReport};
use meshlod_engine::pm::ProgressiveMesh;
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

/// The Hausdorff keys of a simplify or refine report.
pub fn hausdorff(d: &proto::HausdorffReport) -> Report {
    object(json!({
        "hausdorff_paper": d.hausdorff,
        "hausdorff_lower_paper": d.hausdorff_lower,
        "hausdorff_diag_pct": d.hausdorff_diag_pct,
        "hausdorff_tolerance": d.tolerance,
        "hausdorff_converged": d.converged,
        "mean_paper": d.mean,
        "rms_paper": d.rms,
        "samples": d.samples,
    }))
}

/// A simplification's report.
pub fn simplify(s: &proto::SimplifyStats, measured: Option<&proto::HausdorffReport>) -> Report {
    let w_source = match proto::WSource::try_from(s.w_source) {
        Ok(proto::WSource::Predicted) => "predicted",
        Ok(proto::WSource::Searched) => "searched",
        _ => "given",
    };
    let candidates: Vec<Value> =
        s.w_candidates.iter().map(|c| json!({ "w": c.w, "hausdorff_paper": c.hausdorff })).collect();
    let mut report = object(json!({
        "faces_in": s.faces_in,
        "faces_out": s.faces_out,
        "target_faces": s.target_faces,
        "kept_fraction": s.faces_out as f64 / s.faces_in.max(1) as f64,
        "removed_fraction": 1.0 - s.faces_out as f64 / s.faces_in.max(1) as f64,
        "vertices_in": s.vertices_in,
        "vertices_out": s.vertices_out,
        "collapses": s.collapses,
        "stop_reason": s.stop_reason,
        "rejected": s.rejected,
        "refused": refused(s.refused.as_ref()),
        "dropped_duplicate_faces": s.dropped_duplicate_faces,
        "back_faces": s.back_faces,
        "halves": s.halves,
        "frozen_vertices": s.frozen_vertices,
        "holes_closed": s.holes_closed,
        "parts_removed": s.parts_removed,
        "metric": s.metric,
        "w": if s.metric == "melax" { Value::Null } else { json!(s.w) },
        "w_source": w_source,
        "w_candidates": if candidates.is_empty() { Value::Null } else { Value::Array(candidates) },
        "model_version": if s.model_version.is_empty() { Value::Null } else { json!(s.model_version) },
        "placement": s.placement,
        "normals": s.normals,
        "boundary": s.boundary,
        "guard": s.guard,
        "distance_term": s.distance_term,
        "max_collapse_error_paper": s.max_collapse_error,
        "seconds": s.seconds,
        "warnings": s.warnings,
    }));
    if let Some(d) = measured {
        report.extend(hausdorff(d));
    }
    report
}

/// The refused candidates by rule (they sum to `rejected`), every rule named.
fn refused(r: Option<&proto::Refusals>) -> Value {
    let r = r.copied().unwrap_or_default();
    json!({
        "link": r.link,
        "too_few_faces": r.too_few_faces,
        "normal_change": r.normal_change,
        "needle": r.needle,
        "fold": r.fold,
        "seam": r.seam,
        "uv_flip": r.uv_flip,
    })
}

/// The progressive-mesh keys of a simplify report whose `.pm` file has `bytes` bytes: the
/// materials section (its images inside) apart, and the bytes per split without it or the base.
pub fn progressive(pm: &ProgressiveMesh, bytes: usize) -> Report {
    let base_bytes = 12 * (pm.base().vertex_count() + pm.base().face_count());
    let materials = meshlod_engine::pm_format::materials_section_len(pm);
    object(json!({
        "pm_bytes": bytes,
        "pm_materials_bytes": materials,
        "pm_splits": pm.levels(),
        "bytes_per_split": (bytes.saturating_sub(base_bytes + 32 + materials)) as f64 / pm.levels().max(1) as f64,
    }))
}

/// A refinement's report.
pub fn refine(s: &proto::RefineStats) -> Report {
    object(json!({
        "faces_in": s.faces_in,
        "faces_out": s.faces_out,
        "mode": s.mode,
        "etc": s.etc,
        "etc_source": s.etc_source,
        "model_version": if s.model_version.is_empty() { Value::Null } else { json!(s.model_version) },
        "threshold": s.threshold,
        "rounds": s.rounds,
        "split_edges": s.split_edges,
        "collapses": s.collapses,
        "seconds": s.seconds,
        "warnings": s.warnings,
    }))
}

/// The keys of a refine report measured against a reference mesh.
pub fn reference(d: &HausdorffReport) -> Report {
    object(json!({
        "reference_hausdorff_paper": d.hausdorff,
        "reference_hausdorff_lower_paper": d.hausdorff_lower,
        "reference_hausdorff_diag_pct": d.hausdorff_diag_pct,
        "reference_mean_paper": d.mean,
        "reference_mean_diag_pct": d.mean_diag_pct,
    }))
}

/// A prediction's report.
pub fn predict(r: &proto::PredictResponse) -> Report {
    object(json!({
        "faces_in": r.faces_in,
        "target_faces": r.target_faces,
        "w": r.w,
        "probabilities": r.probabilities,
        "classes": r.classes,
        "etc": r.etc,
        "etc_mode": r.etc_mode,
        "model_version": r.model_version,
    }))
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
