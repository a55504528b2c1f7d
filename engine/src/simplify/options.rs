//! What a run is asked for and what it reports: the option types with their defaults, their one
//! check ([`SimplifyOptions::validate`], errors named after the fields), the one face target
//! ([`SimplifyOptions::face_target`]), stop reasons and figures.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use crate::error::MeshError;
use crate::mesh::Mesh;
use crate::pm::ProgressiveMesh;

/// The collapse cost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "metric", rename_all = "lowercase")]
pub enum Metric {
    /// `vᵀQv · (1 − cos θ)^w`, w ∈ [0, 2].
    Qfvp {
        /// Exponent of the normal-angle term.
        w: f64,
    },
    /// Plain quadric error `vᵀQv` (QFVP with w = 0).
    Qem,
    /// Melax: edge length × curvature; the removed vertex moves onto the survivor.
    Melax,
}

impl Metric {
    /// Short name as the CLI spells it.
    pub fn name(&self) -> &'static str {
        match self {
            Metric::Qfvp { .. } => "qfvp",
            Metric::Qem => "qem",
            Metric::Melax => "melax",
        }
    }

    /// The QFVP exponent (0 for QEM, none for Melax).
    pub fn w(&self) -> Option<f64> {
        match self {
            Metric::Qfvp { w } => Some(*w),
            Metric::Qem => Some(0.0),
            Metric::Melax => None,
        }
    }
}

/// Where the merged vertex goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Placement {
    /// The paper's rule: the best of the two endpoints and their midpoint.
    Paper,
    /// The quadric minimiser when well conditioned and near the edge, else the paper's rule.
    Optimal,
    /// The better endpoint (half-edge collapse): vertices never move, so each vertex split
    /// carries one position and the `.pm` file is smallest.
    Endpoint,
    /// `Optimal` for a mesh without texture coordinates, `Endpoint` for one with them: a vertex
    /// keeps the values it had at the position it had, so the texture does not slide (the
    /// trade in texture-space and position error is measured in docs/attributes-report.md).
    Auto,
}

impl Placement {
    /// The placement `Auto` stands for on `mesh`; others are themselves.
    pub fn resolve(self, mesh: &crate::mesh::Mesh) -> Placement {
        match self {
            Placement::Auto if mesh.corners.uvs().is_some() => Placement::Endpoint,
            Placement::Auto => Placement::Optimal,
            other => other,
        }
    }
}

/// How the merged vertex's normal is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum NormalUpdate {
    /// The paper's linear estimate `(cs·ns + ct·nt) / (cs + ct)`, cs, ct the endpoint face counts.
    Linear,
    /// Mean of the face normals of the merged vertex's new fan.
    Recompute,
}

/// How open boundaries are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BoundaryMode {
    /// Boundary vertices may collapse along their boundary; planes perpendicular to the boundary
    /// faces are added to their quadrics so the border keeps its shape. A loop shrunk to three
    /// edges (a triangular hole) may close (rule 3 of the module doc).
    Preserve,
    /// Boundary vertices never move and are never removed: every hole stays open.
    Lock,
}

/// Weights of [`SimplifyOptions::attribute_weights`], each ≥ 0, in squared attribute units per
/// squared bounding-box diagonal (1 for texture coordinates charges a full-texture jump like a
/// displacement by the diagonal).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AttributeWeights {
    /// Texture coordinates.
    pub uv: f64,
    /// Normals (unit vectors).
    pub normal: f64,
    /// Colours (RGBA in [0, 1]).
    pub color: f64,
}

impl AttributeWeights {
    /// The weights a mesh with texture coordinates gets when none are given: normals charged a
    /// little (a mesh without normals pays nothing). Across the shared textured assets at 50, 25
    /// and 10% this lowered the mean pixel difference from the input (`meshlod compare`, geometric
    /// mean 7.95 → 5.62 levels) for a certified Hausdorff distance 15% higher (0.0183 → 0.0210);
    /// weights 10 to 1000 times larger raised the distance more and the pixels gained less, 10
    /// times smaller gained less, texture coordinate weights added nothing. A mesh without
    /// texture coordinates (a scan, a CAD part: judged by its surface) gets none.
    pub const TEXTURED: AttributeWeights = AttributeWeights { uv: 0.0, normal: 1e-4, color: 0.0 };

    /// Whether the term is off.
    pub fn is_off(&self) -> bool {
        self.uv == 0.0 && self.normal == 0.0 && self.color == 0.0
    }
}

/// Options of [`simplify`](super::simplify()). Targets combine: simplification stops at whichever is met first.
#[derive(Debug, Clone)]
pub struct SimplifyOptions {
    /// Stop when at most this many faces remain.
    pub target_faces: Option<usize>,
    /// Stop when this fraction of the faces has been removed (0.9 keeps 10%), as in the paper.
    pub target_ratio: Option<f64>,
    /// Stop before a collapse whose error estimate exceeds this, in paper units.
    pub max_error: Option<f64>,
    /// Collapse cost.
    pub metric: Metric,
    /// Placement of the merged vertex (Melax always uses the surviving endpoint).
    pub placement: Placement,
    /// Normal of the merged vertex.
    pub normals: NormalUpdate,
    /// Boundary handling.
    pub boundary: BoundaryMode,
    /// Largest change of a face normal a collapse may cause, in degrees (0, 180].
    pub max_normal_change_degrees: f64,
    /// Build the progressive mesh (base mesh + vertex splits).
    pub record_progressive: bool,
    /// Weight of the distance guard, ≥ 0 (0, the default, turns it off; 1 is the documented
    /// setting). With it, each QEM/QFVP collapse is ranked by its quadric error over A, the surface
    /// area behind the merged quadric, plus `guard · d²`, before the normal factor: d a measured
    /// distance between the collapse's new fan and the input surface, both ways (the module doc's
    /// "distance guard"). It covers quadric error's blind spot, a thin tip shortened along its own
    /// faces, at a price in time and memory given in docs/benchmarks.md; not with Melax.
    pub guard: f64,
    /// Weight of the fan-distance term, ≥ 0 (default [`DEFAULT_DISTANCE_TERM`]; 0 leaves the
    /// paper's cost as it is). Each QEM/QFVP collapse is ranked by its quadric error over A, the
    /// surface area behind the merged quadric, plus `distance_term · d²`, before the normal
    /// factor, like the guard's term but with d measured on the fans the collapse changes only:
    /// from each new face's centroid to the plane of the face it was, and from each endpoint to
    /// the new faces that were its own (the module doc's "fan-distance term"), once the share
    /// [`super::FAN_TERM_FROM`] of the input's faces is gone (the collapses before are ranked by their quadric error over A
    /// alone). Its price in time is in docs/benchmarks.md; ignored with Melax, while the guard is
    /// on (the guard measures against the input instead) and on meshes with texture coordinates
    /// (measured worse there, docs/attributes-report.md).
    /// [`SimplifyStats::distance_term`] gives the weight that was used.
    pub distance_term: f64,
    /// Keep every vertex on a seam (where a vertex's corners differ in texture coordinates,
    /// normals, colours or material) in place: seams keep every vertex they had.
    pub lock_seams: bool,
    /// Weights of the attribute quadrics in the cost (texture coordinates, normals, colours): per
    /// wedge, how far the values a collapse leaves at the merged vertex are from what the faces
    /// it has taken in gave there (`attribute_quadric`). `None`, the default: [`AttributeWeights::
    /// TEXTURED`] for a mesh with texture coordinates, off for the others
    /// ([`SimplifyOptions::attribute_weights_for`]); all 0 turns them off. Measured in
    /// docs/attributes-report.md and docs/textured-report.md.
    pub attribute_weights: Option<AttributeWeights>,
    /// Take out whole parts (faces joined through shared vertices: chain links, bolts, a tree's
    /// far leaves) once the run's largest collapse error reaches their size, so that the faces
    /// they would keep go to the larger shapes, as meshoptimizer's `SimplifyPrune` does. A part's
    /// size, paper units, is the larger of half its bounding box's diagonal and its farthest
    /// vertex's distance to the other parts (`prune` module). The part with the most faces always
    /// stays; a part goes only while the face target allows it. Off by default, where every part
    /// keeps at least its smallest manifold form; not with `record_progressive` (a vertex split
    /// cannot bring back a part its base mesh lacks). Measured in docs/attributes-report.md.
    pub prune: bool,
    /// Simplify a large mesh in two halves side by side first (on by default): a mesh of
    /// [`HALVES_FROM_FACES`](super::HALVES_FROM_FACES) faces or more, simplified to an eighth of them
    /// or fewer with the quadric costs alone (no guard, Melax, pruning, error limit or per-corner
    /// attributes), is cut in two at the median of its faces; each half is simplified apart (on
    /// its own thread where the pool has two) with the band along the cut left alone, to twice the
    /// target, then the rest as a whole (`halves` module: what it keeps of a single run's order).
    /// Off, one sequence runs over the whole mesh, whose progressive mesh then has every level
    /// equal to the mesh a straight run to its face count gives. Measured in docs/benchmarks.md.
    pub halves: bool,
    /// Set to `true` by another thread to stop the work; the call then returns
    /// [`MeshError::Cancelled`].
    pub cancel: Option<Arc<AtomicBool>>,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        SimplifyOptions {
            target_faces: None,
            target_ratio: Some(DEFAULT_TARGET_RATIO),
            max_error: None,
            // w = 0 gave the lowest Hausdorff on 16 of 22 (mesh, reduction) cases of the shared
            // meshes (docs/simplify-report.md); a per-mesh w comes from the predictor.
            metric: Metric::Qfvp { w: 0.0 },
            placement: Placement::Auto,
            normals: NormalUpdate::Linear,
            boundary: BoundaryMode::Preserve,
            max_normal_change_degrees: DEFAULT_MAX_NORMAL_CHANGE_DEGREES,
            record_progressive: false,
            guard: 0.0,
            distance_term: DEFAULT_DISTANCE_TERM,
            lock_seams: false,
            attribute_weights: None,
            prune: false,
            halves: true,
            cancel: None,
        }
    }
}

/// Why the collapse loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The face target (count or ratio) was reached.
    TargetReached,
    /// The next collapse would have exceeded `max_error`.
    MaxErrorReached,
    /// No legal collapse remained (every candidate would break manifoldness, flip a face, touch a
    /// locked vertex or a boundary rule) before the target.
    NoLegalCollapse,
}

impl StopReason {
    /// The reason as reports and the gRPC contract spell it.
    pub fn as_str(&self) -> &'static str {
        match self {
            StopReason::TargetReached => "target_reached",
            StopReason::MaxErrorReached => "max_error_reached",
            StopReason::NoLegalCollapse => "no_legal_collapse",
        }
    }
}

/// Figures of one run.
#[derive(Debug, Clone, Serialize)]
pub struct SimplifyStats {
    /// Faces of the input (after dropping faces that repeat a vertex).
    pub faces_in: usize,
    /// Faces of the output.
    pub faces_out: usize,
    /// Referenced vertices of the input.
    pub vertices_in: usize,
    /// Vertices of the output.
    pub vertices_out: usize,
    /// The face target that applied.
    pub target_faces: usize,
    /// The placement used (`Auto` resolved).
    pub placement: Placement,
    /// Collapses performed.
    pub collapses: usize,
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// Largest collapse error estimate, paper units.
    pub max_collapse_error: f64,
    /// Candidates refused by the legality checks (the sum of `refused`).
    pub rejected: usize,
    /// The same refusals, by rule.
    pub refused: Refusals,
    /// Vertices that never move or disappear (each may take in neighbours, rule 1): non-manifold
    /// or inconsistently oriented neighbourhoods (frozen), where three or more sets of attribute
    /// values meet, locked seams' vertices and boundary vertices under [`BoundaryMode::Lock`].
    pub frozen_vertices: usize,
    /// Triangular holes (boundary loops of three edges) closed by collapsing one of their edges
    /// (rule 3): each takes one boundary loop away.
    pub holes_closed: usize,
    /// Parts taken out whole ([`SimplifyOptions::prune`]).
    pub parts_removed: usize,
    /// Faces dropped before simplifying because they repeat a vertex index.
    pub dropped_degenerate_faces: usize,
    /// Faces dropped before simplifying because they copy another face: the same three vertices,
    /// the same way round, the same values.
    pub dropped_duplicate_faces: usize,
    /// Faces that back another (the same three vertices the other way round, the same values but
    /// for normals, which may point the other way: a double-sided sheet modelled with two faces):
    /// simplified with the face they back, as one sheet, and written again, reversed, beside each
    /// output face whose input face had one. The progressive mesh holds the one sheet.
    pub back_faces: usize,
    /// Whether the run went in two halves first ([`SimplifyOptions::halves`]).
    pub halves: bool,
    /// The fan-distance term's weight that applied: 0 where it was off or did not apply (Melax,
    /// the distance guard on, texture coordinates carried). It is measured once the share
    /// [`super::FAN_TERM_FROM`] of the input's faces is gone, so a run that stops before that never
    /// pays it.
    pub distance_term: f64,
    /// Whether the input was flat-shaded (every corner's normal its face's own): the run went
    /// without its normals, the result has its faces' normals, and the progressive mesh none (glTF
    /// draws a mesh without normals flat).
    pub flat_normals: bool,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// Result of [`simplify`](super::simplify()).
#[derive(Debug, Clone)]
pub struct Simplified {
    /// The simplified mesh: surviving vertices in input order, surviving faces in input order.
    pub mesh: Mesh,
    /// The progressive mesh, when asked for.
    pub progressive: Option<ProgressiveMesh>,
    /// Figures of the run.
    pub stats: SimplifyStats,
}

/// The target ratio when neither target is given: half the faces removed.
pub const DEFAULT_TARGET_RATIO: f64 = 0.5;

/// The largest face-normal change a collapse may cause by default, degrees.
pub const DEFAULT_MAX_NORMAL_CHANGE_DEGREES: f64 = 90.0;

/// Default weight of the fan-distance term ([`SimplifyOptions::distance_term`]): the weight at
/// which it gave the lowest errors beside meshoptimizer and MeshLab (docs/meshlab-comparison.md).
pub const DEFAULT_DISTANCE_TERM: f64 = 1.0;

impl SimplifyOptions {
    /// The attribute weights that apply to `mesh`: those given, else [`AttributeWeights::TEXTURED`]
    /// for a mesh with texture coordinates and none for the others.
    pub fn attribute_weights_for(&self, mesh: &Mesh) -> AttributeWeights {
        self.attribute_weights.unwrap_or(if mesh.corners.uvs().is_some() {
            AttributeWeights::TEXTURED
        } else {
            AttributeWeights::default()
        })
    }
}

impl SimplifyOptions {
    /// Checks every option on its own and against the others; errors name the field.
    pub fn validate(&self) -> Result<(), MeshError> {
        if let Some(r) = self.target_ratio
            && !(0.0..1.0).contains(&r)
        {
            return Err(MeshError::InvalidParameter {
                name: "target_ratio",
                reason: format!("{r} is outside [0, 1): it is the fraction of faces removed"),
            });
        }
        if let Metric::Qfvp { w } = self.metric
            && !(0.0..=2.0).contains(&w)
        {
            return Err(MeshError::InvalidParameter { name: "w", reason: format!("{w} is outside [0, 2]") });
        }
        if let Some(e) = self.max_error
            && (e.is_nan() || e < 0.0)
        {
            return Err(MeshError::InvalidParameter { name: "max_error", reason: format!("{e} must be ≥ 0") });
        }
        let guard = self.guard;
        if !(guard.is_finite() && guard >= 0.0) {
            return Err(MeshError::InvalidParameter {
                name: "guard",
                reason: format!("{guard} must be a finite number ≥ 0"),
            });
        }
        if guard > 0.0 && self.metric == Metric::Melax {
            return Err(MeshError::InvalidParameter {
                name: "guard",
                reason: "the distance guard adds to the quadric costs (QFVP, QEM), not to Melax's".into(),
            });
        }
        let term = self.distance_term;
        if !(term.is_finite() && term >= 0.0) {
            return Err(MeshError::InvalidParameter {
                name: "distance_term",
                reason: format!("{term} must be a finite number ≥ 0"),
            });
        }
        if self.prune && self.record_progressive {
            return Err(MeshError::InvalidParameter {
                name: "prune",
                reason: "a progressive mesh cannot bring back a part its base mesh lacks: ask for one or the other"
                    .into(),
            });
        }
        let a = self.attribute_weights.unwrap_or_default();
        for (name, w) in [
            ("attribute_weights.uv", a.uv),
            ("attribute_weights.normal", a.normal),
            ("attribute_weights.color", a.color),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                return Err(MeshError::InvalidParameter { name, reason: format!("{w} must be a finite number ≥ 0") });
            }
        }
        let angle = self.max_normal_change_degrees;
        if !(angle > 0.0 && angle <= 180.0) {
            return Err(MeshError::InvalidParameter {
                name: "max_normal_change_degrees",
                reason: format!("{angle} is outside (0, 180]"),
            });
        }
        Ok(())
    }

    /// The face count a run on `faces` faces stops at: the larger of the two targets where both
    /// are given (whichever is met first), 0 where neither is. The one definition: the predictor's
    /// features, the server and the CLI all ask here.
    pub fn face_target(&self, faces: usize) -> usize {
        let by_ratio = self.target_ratio.map(|r| ((faces as f64) * (1.0 - r)).round() as usize);
        match (self.target_faces, by_ratio) {
            (Some(n), Some(m)) => n.max(m),
            (Some(n), None) => n,
            (None, Some(m)) => m,
            (None, None) => 0,
        }
    }

    /// The options with the targets a request gives: neither gives the default share
    /// (the one `SimplifyOptions::default()` has); with both, whichever is met first.
    pub fn with_targets(self, target_faces: Option<usize>, target_ratio: Option<f64>) -> SimplifyOptions {
        let target_ratio =
            if target_faces.is_none() && target_ratio.is_none() { Some(DEFAULT_TARGET_RATIO) } else { target_ratio };
        SimplifyOptions { target_faces, target_ratio, ..self }
    }

    /// [`SimplifyOptions::face_target`] for `mesh` as [`super::simplify`] will count its faces (those
    /// that repeat a vertex are dropped first): what a caller that predicts or reports the target
    /// before the run should ask.
    pub fn face_target_for(&self, mesh: &Mesh) -> usize {
        let usable = mesh.triangles.iter().filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]).count();
        self.face_target(usable)
    }
}

/// Candidates refused at the top of the queue, by legality rule (module doc, rules 3–6).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Refusals {
    /// Rule 3: the link condition (the endpoints share a neighbour off the edge, or the edge does
    /// not have one or two faces).
    pub link: usize,
    /// Rule 3: the merged vertex would keep too few faces.
    pub too_few_faces: usize,
    /// Rule 4: a face normal would turn by more than the limit.
    pub normal_change: usize,
    /// Rule 5: a face would become a needle or have no area.
    pub needle: usize,
    /// Rule 6: a moved face would fold onto a neighbour.
    pub fold: usize,
    /// Rule 7 (meshes with per-corner attributes): the collapse would carry values across a seam.
    pub seam: usize,
    /// Rule 7: a face's texture-space triangle would flip or lose its area.
    pub uv_flip: usize,
}

impl Refusals {
    /// Adds `other`'s counts, rule by rule.
    pub(crate) fn add(&mut self, other: &Refusals) {
        self.link += other.link;
        self.too_few_faces += other.too_few_faces;
        self.normal_change += other.normal_change;
        self.needle += other.needle;
        self.fold += other.fold;
        self.seam += other.seam;
        self.uv_flip += other.uv_flip;
    }

    /// Counts one refusal under its rule.
    pub(crate) fn count(&mut self, refusal: Refusal) {
        *match refusal {
            Refusal::Link => &mut self.link,
            Refusal::TooFewFaces => &mut self.too_few_faces,
            Refusal::NormalChange => &mut self.normal_change,
            Refusal::Needle => &mut self.needle,
            Refusal::Fold => &mut self.fold,
            Refusal::Seam => &mut self.seam,
            Refusal::UvFlip => &mut self.uv_flip,
        } += 1;
    }

    /// All refusals.
    pub fn total(&self) -> usize {
        self.link + self.too_few_faces + self.normal_change + self.needle + self.fold + self.seam + self.uv_flip
    }
}

/// Why a candidate collapse was refused (module doc, rules 3–6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Refusal {
    /// Rule 3: link condition.
    Link,
    /// Rule 3: too few faces left at the merged vertex.
    TooFewFaces,
    /// Rule 4: a normal turns too far.
    NormalChange,
    /// Rule 5: a needle or zero-area face.
    Needle,
    /// Rule 6: a fold.
    Fold,
    /// Rule 7: attribute values would cross a seam.
    Seam,
    /// Rule 7: a texture-space triangle would flip or lose its area.
    UvFlip,
}

/// What a run made, as [`super::simplify`] reports it.
pub(super) struct Outcome {
    pub(super) mesh: Mesh,
    pub(super) progressive: Option<ProgressiveMesh>,
    pub(super) collapses: usize,
    pub(super) holes_closed: usize,
    pub(super) stop_reason: StopReason,
    pub(super) max_collapse_error: f64,
    pub(super) refused: Refusals,
    pub(super) frozen_vertices: usize,
    pub(super) parts_removed: usize,
    pub(super) dropped_duplicate_faces: usize,
    pub(super) back_faces: usize,
    pub(super) halves: bool,
    pub(super) distance_term: f64,
}

/// What a run resolves once from its options.
pub(crate) struct Config<'o> {
    /// The options as given (placement resolved).
    pub(crate) options: &'o SimplifyOptions,
    /// The cosine of the largest normal change one collapse may cause.
    pub(crate) cos_max_normal_change: f64,
}

impl<'o> Config<'o> {
    /// The run's configuration from its options.
    pub(crate) fn new(options: &'o SimplifyOptions) -> Config<'o> {
        Config { options, cos_max_normal_change: options.max_normal_change_degrees.to_radians().cos() }
    }
}
