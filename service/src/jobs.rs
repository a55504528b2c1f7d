//! The operations behind every front end, from the contract's options to the engine and back:
//! one simplification, refinement or prediction of a mesh already in memory. The server runs them
//! inside its admission control; the CLI runs them directly; the client sends the same options to
//! a server that runs them. So a flag means the same thing everywhere, and every report is built
//! from the same contract messages ([`crate::report`]).
//!
//! Errors are gRPC statuses whose message starts with the request field it concerns
//! (`options.target_ratio: …`); the CLI prints the message.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use meshlod_engine::compare::{CompareOptions, compare};
use meshlod_engine::features::{SHAPE_FEATURE_NAMES, SHAPE_FEATURES, Shape, W_CLASSES, shape_features};
use meshlod_engine::hausdorff::{HausdorffOptions, HausdorffReport, hausdorff};
use meshlod_engine::refine::{RefineMode, RefineOptions, Refined, refine as engine_refine};
use meshlod_engine::simplify::{Metric, NormalUpdate, Simplified, SimplifyOptions, simplify as engine_simplify};
use meshlod_engine::simplify::{prepare, simplify_search_w};
use meshlod_engine::{Mesh, MeshError};
use meshlod_predictor::Predictor;

use crate::convert::{self, engine_error};
use crate::error::JobError;
use crate::proto;
pub use crate::request::{EtcChoice, RefineRequest, SimplifyRequest, WChoice};

/// What [`simplify`] produced.
#[derive(Debug)]
pub struct Simplification {
    /// The engine's result (mesh, progressive mesh when asked for, figures).
    pub result: Simplified,
    /// The figures as the contract reports them.
    pub stats: proto::SimplifyStats,
    /// The measured distance, when asked for.
    pub hausdorff: Option<proto::HausdorffReport>,
    /// Input and result compared in pixels, when asked for.
    pub compare: Option<proto::CompareReport>,
    /// The result as a file, when the request asked for one (`output_format`).
    pub encoded: Option<proto::EncodedMesh>,
    /// Whether the progressive mesh's `.pm` file goes out in the lossless form.
    pub progressive_lossless: bool,
}

/// Options that are accepted but change nothing, said back to the caller.
pub fn simplify_warnings(r: &SimplifyRequest) -> Vec<String> {
    let metric = r.options.metric;
    let given = match r.w {
        WChoice::Given(w) => w,
        WChoice::Auto | WChoice::Search => 0.0,
    };
    let quadric_w0 =
        matches!(metric, Metric::Qem) || (matches!(metric, Metric::Qfvp { .. }) && r.w == WChoice::Given(0.0));
    let mut out = Vec::new();
    if matches!(metric, Metric::Qem | Metric::Melax) && (given != 0.0 || r.w == WChoice::Auto) {
        out.push(format!("w has no effect with the {} metric", metric.name().to_uppercase()));
    }
    if quadric_w0 && r.options.normals == NormalUpdate::Recompute {
        out.push("normals recompute has no effect at w = 0: the vertex normals only enter QFVP's normal term".into());
    }
    out
}

/// The warning for the input's attributes that `operation`'s result (which has `kept`) lost.
pub fn lost_attributes(mesh: &Mesh, kept: &[&str], operation: &str) -> Option<String> {
    let lost: Vec<&str> = mesh.corners.names().into_iter().filter(|n| !kept.contains(n)).collect();
    (!lost.is_empty()).then(|| {
        format!("the input's attributes ({}) are not kept: {operation} does not carry them yet", lost.join(", "))
    })
}

/// What `r` asks to measure of `result` against its input `mesh`: the certified distance (the one
/// a search `measured` already, else measured here) and the comparison in pixels.
fn measure(
    mesh: &Mesh,
    result: &Mesh,
    r: &SimplifyRequest,
    measured: Option<HausdorffReport>,
    cancel: Option<Arc<AtomicBool>>,
) -> Result<(Option<proto::HausdorffReport>, Option<proto::CompareReport>), JobError> {
    let distance = match (r.compute_hausdorff, measured) {
        (false, _) => None,
        (true, Some(d)) => Some(d),
        (true, None) => {
            let h = HausdorffOptions { cancel, ..Default::default() };
            Some(hausdorff(mesh, result, &h).map_err(|e| engine_error(e, "options"))?)
        }
    };
    let pixels = if r.compare {
        let options = CompareOptions { hausdorff: false, ..Default::default() };
        Some(compare(mesh, result, &options).map_err(|e| engine_error(e, "options.compare"))?.report)
    } else {
        None
    };
    Ok((distance.as_ref().map(convert::hausdorff_to_proto), pixels.as_ref().map(convert::compare_to_proto)))
}

/// Simplifies `mesh` as `r` asks; `WChoice::Auto` asks `predictor`.
pub fn simplify(
    mesh: &Mesh,
    r: &SimplifyRequest,
    predictor: Option<&Predictor>,
    cancel: Option<Arc<AtomicBool>>,
) -> Result<Simplification, JobError> {
    // Every option checked before any work, the predictor's included.
    let mut options = r.options.clone();
    options.validate().map_err(|e| engine_error(e, "options"))?;
    options.cancel = cancel;
    let (w_source, model_version) = if r.w == WChoice::Search {
        (proto::WSource::Searched, String::new())
    } else if r.w == WChoice::Auto {
        let predictor = predictor
            .ok_or_else(|| JobError::precondition("options.w_auto", "this server runs without a predictor model"))?;
        // The target the run will stop at, as the engine counts it.
        let target = options.face_target_for(mesh);
        let advice = crate::predict::advise(predictor, mesh, target).map_err(|e| JobError::internal(e.to_string()))?;
        if let Metric::Qfvp { w } = &mut options.metric {
            *w = advice.w.w;
        }
        (proto::WSource::Predicted, advice.model_version)
    } else {
        (proto::WSource::Given, String::new())
    };
    // A search has measured its result already; `measured` keeps that for compute_hausdorff.
    let (result, w_candidates, measured) = if r.w == WChoice::Search {
        let search = simplify_search_w(mesh, &options, &W_CLASSES).map_err(|e| engine_error(e, "options"))?;
        options.metric = Metric::Qfvp { w: search.w };
        let candidates = search.errors.iter().map(|&(w, hausdorff)| proto::WCandidate { w, hausdorff }).collect();
        (search.best, candidates, Some(search.hausdorff))
    } else {
        (engine_simplify(mesh, &options).map_err(|e| engine_error(e, "options"))?, Vec::new(), None)
    };
    let (hausdorff, compare) = measure(mesh, &result.mesh, r, measured, options.cancel.clone())?;
    let s = &result.stats;
    let stats = proto::SimplifyStats {
        faces_in: s.faces_in as u32,
        faces_out: s.faces_out as u32,
        vertices_in: s.vertices_in as u32,
        vertices_out: s.vertices_out as u32,
        collapses: s.collapses as u32,
        stop_reason: s.stop_reason.as_str().to_string(),
        metric: options.metric.name().to_string(),
        w: options.metric.w().unwrap_or(0.0),
        w_source: w_source as i32,
        model_version,
        max_collapse_error: s.max_collapse_error,
        seconds: s.seconds,
        w_candidates,
        guard: options.guard,
        distance_term: s.distance_term,
        warnings: simplify_warnings(r)
            .into_iter()
            .chain(mesh.corners.input_warnings())
            .chain((options.record_progressive && s.flat_normals).then(|| {
                "the input is flat-shaded: the result has its faces' normals, the progressive mesh none \
                 (a glTF viewer draws a mesh without normals flat)"
                    .to_string()
            }))
            .chain((options.record_progressive && s.back_faces > 0).then(|| {
                format!(
                    "{} back faces (a double-sided sheet modelled with two faces): the result has both sides, \
                     the progressive mesh and its levels the one sheet",
                    s.back_faces
                )
            }))
            .collect(),
        frozen_vertices: s.frozen_vertices as u32,
        holes_closed: s.holes_closed as u32,
        parts_removed: s.parts_removed as u32,
        target_faces: s.target_faces as u32,
        rejected: s.rejected as u64,
        refused: Some(convert::refusals_to_proto(&s.refused)),
        dropped_duplicate_faces: s.dropped_duplicate_faces as u32,
        back_faces: s.back_faces as u32,
        halves: s.halves,
        flat_normals: s.flat_normals,
        placement: format!("{:?}", result.stats.placement).to_lowercase(),
        normals: match options.normals {
            NormalUpdate::Linear => "linear".into(),
            NormalUpdate::Recompute => "recompute".into(),
        },
        boundary: format!("{:?}", options.boundary).to_lowercase(),
    };
    Ok(Simplification {
        result,
        stats,
        hausdorff,
        compare,
        encoded: None,
        progressive_lossless: r.progressive_lossless,
    })
}

/// The refiner's options for a request: the mode inferred where unset, the ETC predicted where
/// `EtcChoice::Auto` asks for it. Also returns where
/// the ETC comes from and the model's version when it was predicted.
fn refine_options(
    mesh: &Mesh,
    r: &RefineRequest,
    predictor: Option<&Predictor>,
) -> Result<(RefineOptions, &'static str, String), JobError> {
    let (mut etc, mut target_faces, mut model_version) = (None, r.target_faces, String::new());
    let source = match r.etc {
        EtcChoice::Given(e) => {
            etc = Some(e);
            "given"
        }
        EtcChoice::Auto => {
            let predictor = predictor
                .ok_or_else(|| JobError::precondition("etc_auto", "this server runs without a predictor model"))?;
            let target =
                target_faces.ok_or_else(|| JobError::invalid("target_faces", "etc_auto needs a target face count"))?;
            let advice =
                crate::predict::advise(predictor, mesh, target).map_err(|e| JobError::internal(e.to_string()))?;
            (etc, target_faces, model_version) = (Some(advice.etc), None, advice.model_version);
            "predicted"
        }
        EtcChoice::Search => "searched",
    };
    // Unset: the direction that reaches the target, or subdivision.
    let mode = r.mode.unwrap_or(match r.target_faces {
        Some(n) if n < mesh.face_count() => RefineMode::Simplify,
        _ => RefineMode::Subdivide,
    });
    let options = RefineOptions { etc, target_faces, mode, rounds: r.rounds, cancel: None, max_faces: None };
    Ok((options, source, model_version))
}

/// Refines `mesh` as `r` says; the result may have at most `max_faces` faces.
pub fn refine(
    mesh: &Mesh,
    r: &RefineRequest,
    predictor: Option<&Predictor>,
    cancel: Option<Arc<AtomicBool>>,
    max_faces: usize,
) -> Result<(Refined, proto::RefineStats), JobError> {
    let (mut options, etc_source, model_version) = refine_options(mesh, r, predictor)?;
    options.cancel = cancel;
    options.max_faces = Some(max_faces);
    // The output's size is known before each subdivision round is built: refused before the work.
    let result = engine_refine(mesh, &options).map_err(|e| match e {
        MeshError::TooLarge { what, count, limit, .. } if what.starts_with("faces (refine") => JobError::invalid(
            "rounds",
            format!("the result would have {count} faces or more, over the limit of {limit}"),
        ),
        other => engine_error(other, ""),
    })?;
    let s = &result.stats;
    let stats = proto::RefineStats {
        faces_in: s.faces_in as u32,
        faces_out: s.faces_out as u32,
        etc: s.etc,
        mode: format!("{:?}", s.mode).to_lowercase(),
        split_edges: s.split_edges as u32,
        collapses: s.collapses as u32,
        seconds: s.seconds,
        threshold: s.threshold,
        rounds: s.rounds,
        etc_source: etc_source.into(),
        model_version,
        warnings: lost_attributes(mesh, &result.mesh.corners.names(), "refinement")
            .into_iter()
            .chain(mesh.corners.input_warnings())
            .collect(),
    };
    Ok((result, stats))
}

/// The predictor's advice for shape features of a mesh of `faces_in` faces and a target given as
/// the contract gives it (faces kept and/or ratio removed: whichever is met first, as
/// [`SimplifyOptions::face_target`] has it).
pub fn predict(
    predictor: &Predictor,
    shape: &Shape,
    faces_in: usize,
    target_faces: Option<u32>,
    target_ratio: Option<f64>,
) -> Result<proto::PredictResponse, JobError> {
    if target_faces.is_none() && target_ratio.is_none() {
        return Err(JobError::invalid("target_faces", "give target_faces or target_ratio"));
    }
    let targets =
        SimplifyOptions { target_faces: target_faces.map(|n| n as usize), target_ratio, ..Default::default() };
    targets.validate().map_err(|e| engine_error(e, ""))?;
    let target = targets.face_target(faces_in).max(1);
    let advice = crate::predict::advise_features(predictor, shape, faces_in, target)
        .map_err(|e| JobError::invalid("features.values", e.to_string()))?;
    Ok(proto::PredictResponse {
        w: advice.w.w,
        probabilities: advice.w.probabilities,
        classes: advice.w.classes,
        etc: advice.etc,
        model_version: advice.model_version,
        faces_in: faces_in as u64,
        target_faces: target as u64,
        etc_mode: if target > faces_in { "subdivide" } else { "simplify" }.into(),
    })
}

/// [`predict`] for a mesh: its shape features computed here.
pub fn predict_mesh(
    predictor: &Predictor,
    mesh: &Mesh,
    target_faces: Option<u32>,
    target_ratio: Option<f64>,
) -> Result<proto::PredictResponse, JobError> {
    // Faces that repeat a vertex are dropped first, as the simplifier does.
    let (mesh, _, _) = prepare(mesh);
    predict(predictor, &shape_features(&mesh), mesh.face_count(), target_faces, target_ratio)
}

/// The shape features a Predict request carries instead of a mesh, checked.
pub fn features_from_proto(f: &proto::ShapeFeatures) -> Result<Shape, JobError> {
    let shape: Shape = f.values.as_slice().try_into().map_err(|_| {
        JobError::invalid(
            "features.values",
            format!(
                "expected the {SHAPE_FEATURES} shape features {SHAPE_FEATURE_NAMES:?}, got {} values",
                f.values.len()
            ),
        )
    })?;
    if let Some(i) = shape.iter().position(|v| !v.is_finite()) {
        return Err(JobError::invalid(format!("features.values[{i}]"), format!("{} is not finite", shape[i])));
    }
    Ok(shape)
}
