//! Edge-collapse simplification with the QFVP, QEM and Melax costs, recorded as a progressive mesh.
//!
//! Sources:
//! - QFVP: the cost `vᵀQv · (1 − cos θ)^w` of the "quadric + feature-vertex-preserving" progressive
//!   mesh paper (`../shared/papers/qfvp-progressive-mesh.txt`), θ the angle between the normals of
//!   the two endpoints, w ∈ [0, 2]; w = 0 is plain QEM.
//! - QEM: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics", 1997.
//! - Melax: S. Melax, "A simple, fast and effective polygon reduction algorithm", Game Developer,
//!   1998 — cost = edge length × curvature term.
//! - Progressive meshes: H. Hoppe, "Progressive meshes", SIGGRAPH 1996.
//!
//! Data flows in this order: preparation (drop unusable faces, classify vertices) → quadrics and
//! normals → one priority queue of candidate collapses (stale entries skipped by per-vertex version
//! stamps, as in the paper) → validity checks at pop time → collapse and log → output mesh and,
//! if asked, the progressive mesh built from the log (`crate::pm`).
//!
//! ## Ordering and ties
//! For QFVP with w > 0 the cost is exactly zero where both endpoint normals agree (flat regions):
//! those collapses all cost nothing. The queue puts every zero-cost candidate first, ordered among
//! themselves by quadric error, so flat regions are simplified in the order plain QEM would use;
//! positive costs follow in cost order (`crate::queue::order_key`, costs kept as `f32`). Where the
//! quadric error itself vanishes (an exactly planar neighbourhood: zero, or too small for an `f32`)
//! the shorter edge goes first, which keeps the triangles of planar regions well shaped: on fandisk
//! it refuses 0.07× as many candidates as leaving them tied did, and runs in 0.4× the time.
//! Remaining ties go to the lower first vertex id, then to the queue's layout, which the sequence
//! of pushes, pops, refills and sweeps fixes (not push order: a heap is not stable): a run is
//! deterministic, which the progressive mesh's `at_faces` relies on, but a change to the queue
//! moves ties among equal keys.
//!
//! ## The distance guard (optional, [`SimplifyOptions::guard`])
//! Quadric error has a blind spot: shortening a thin tip (a cow's horn, a finger) moves its apex
//! along planes nearly parallel to the move, so the collapse looks cheap while the Hausdorff
//! distance jumps. The guard charges each candidate `guard · A · d²` on top of its quadric error
//! (then the QFVP normal factor as usual), with A the surface area behind the merged quadric and d
//! a measured distance, both ways: from the input vertices merged into the endpoints (up to
//! [`WITNESSES`] each, the farthest) to the fan the collapse would create, and from the new
//! position and the new faces' centroids to the input surface ([`DistanceGuard`]). The term only
//! adds, so entries are queued without it and measured when they reach the top: one that is no
//! longer the cheapest goes back with its measured key (a lazy queue: the greedy order of the
//! guarded costs, measuring ~3 candidates per collapse instead of ~12). About 12× the time of
//! a run without it; on the shared meshes at weight 1 and w = 0, a lower Hausdorff distance than
//! without it in 24 of 33 (mesh, reduction) cases (docs/simplify-report.md, Table 1b).
//!
//! ## Legality of a collapse (a, b) → a at position p, checked in this order
//! ```text
//!        vl                  vl
//!       /  \                 |
//!      /    \                |
//!     a------b     ==>       a (at p)
//!      \    /                |
//!       \  /                 |
//!        vr                  vr
//! ```
//! 1. neither endpoint is frozen (non-manifold or inconsistently oriented neighbourhood);
//! 2. boundaries: an interior edge with both ends on the boundary is refused (it would pinch the
//!    surface); a boundary vertex is never removed in favour of an interior one and does not move
//!    off its boundary; with [`BoundaryMode::Lock`] boundary vertices never move or disappear;
//! 3. link condition: the common neighbours of a and b are exactly vl and vr (Dey et al.), and the
//!    merged vertex keeps at least one face (three for an interior vertex), so the surface stays a
//!    2-manifold and no component collapses to nothing;
//! 4. every face that survives around a or b keeps a normal within
//!    [`SimplifyOptions::max_normal_change_degrees`] of its old one (no flips);
//! 5. no surviving face becomes a needle or zero-area triangle ([`MIN_TRIANGLE_QUALITY`]);
//! 6. no fold: no moved face turns back onto the unmoved face across its far edge, and no two moved
//!    faces that share an edge turn back onto each other (normals' dot product below [`FOLD_DOT`]).
//!    The face across is looked at only when the normal cones of the far edge's two ends
//!    (`NormalCone`: how far the faces around a vertex stray from its normal) leave a fold
//!    possible (one moved face in 600 to 10 000 on bunny, nefertiti and fandisk); debug builds check
//!    every skipped one anyway.

use std::borrow::Cow;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering as AtomicOrdering};
use std::time::Instant;

use glam::DVec3;
use serde::Serialize;
use smallvec::SmallVec;

use crate::error::MeshError;
use crate::fan::{Corner, FAN_INLINE, FanSlot};
use crate::hausdorff::{HausdorffOptions, HausdorffReport, hausdorff};
use crate::mesh::{DistanceUnits, Mesh};
use crate::pm::{CollapseRecord, ProgressiveMesh};
use crate::prefetch::prefetch;
use crate::quadric::{Quadric, QuadricPair};
use crate::queue::{QueueEntry, TieredQueue, order_key};

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
    /// faces are added to their quadrics so the border keeps its shape.
    Preserve,
    /// Boundary vertices never move and are never removed.
    Lock,
}

/// Options of [`simplify`]. Targets combine: simplification stops at whichever is met first.
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
    /// setting). With it, each QEM/QFVP collapse cost also pays `guard · A · d²` before the normal
    /// factor: A the surface area behind the merged quadric, d a measured distance between the
    /// collapse's new fan and the input surface, both ways (see [`DistanceGuard`]). It covers
    /// quadric error's blind spot, a thin tip shortened along its own faces, at about 12× the
    /// time and ~75 more bytes of peak memory per input triangle; not with Melax.
    pub guard: f64,
    /// Set to `true` by another thread to stop the work; the call then returns
    /// [`MeshError::Cancelled`].
    pub cancel: Option<Arc<AtomicBool>>,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        SimplifyOptions {
            target_faces: None,
            target_ratio: Some(0.5),
            max_error: None,
            // w = 0 gave the lowest Hausdorff on 16 of 22 (mesh, reduction) cases of the shared
            // meshes (docs/simplify-report.md); a per-mesh w comes from the predictor.
            metric: Metric::Qfvp { w: 0.0 },
            placement: Placement::Optimal,
            normals: NormalUpdate::Linear,
            boundary: BoundaryMode::Preserve,
            max_normal_change_degrees: 90.0,
            record_progressive: false,
            guard: 0.0,
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
    /// Collapses performed.
    pub collapses: usize,
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// Largest collapse error estimate, paper units.
    pub max_collapse_error: f64,
    /// Candidates refused by the legality checks.
    pub rejected: usize,
    /// Vertices no collapse may touch: non-manifold or inconsistently oriented neighbourhoods, and
    /// boundary vertices under [`BoundaryMode::Lock`].
    pub frozen_vertices: usize,
    /// Faces dropped before simplifying because they repeat a vertex index.
    pub dropped_degenerate_faces: usize,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// Result of [`simplify`].
#[derive(Debug, Clone)]
pub struct Simplified {
    /// The simplified mesh: surviving vertices in input order, surviving faces in input order.
    pub mesh: Mesh,
    /// The progressive mesh, when asked for.
    pub progressive: Option<ProgressiveMesh>,
    /// Figures of the run.
    pub stats: SimplifyStats,
}

/// Smallest `4√3·area / Σ edge²` (1 for an equilateral triangle) a collapse may create.
pub const MIN_TRIANGLE_QUALITY: f64 = 1e-3;

/// Two faces sharing an edge at the merged vertex may not end up with normals whose dot product is
/// below this (a fold of more than ~154°).
pub const FOLD_DOT: f64 = -0.9;

/// Fans up to this many faces are checked for folds pair by pair; larger ones by sorting.
const SMALL_FAN: usize = 16;

/// Times the queue is rebuilt from all remaining edges when it runs dry before the target: a
/// candidate refused earlier may have become legal after its neighbourhood changed.
pub const MAX_PASSES: usize = 4;

/// Weight of the boundary-constraint planes relative to the face planes.
const BOUNDARY_WEIGHT: f64 = 10.0;

/// How often (in queue pops) the cancel flag is read.
const CANCEL_CHECK_INTERVAL: usize = 256;

pub(crate) const NONE: u32 = u32::MAX;

/// Marks a queue entry's `b` when its key includes the distance guard's term.
const GUARDED: u32 = 1 << 31;

/// Vertex classification fixed at the start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum VertexKind {
    #[default]
    Interior,
    Boundary,
    /// Non-manifold or inconsistently oriented: no collapse touches it.
    Frozen,
}

/// Mutable state of one run: the algorithm owns it; nothing is left attached to the input mesh.
pub(crate) struct State<'o> {
    pub(crate) options: &'o SimplifyOptions,
    /// Quadric, normal, position and class of each vertex (see [`VertexData`]).
    pub(crate) vertices: Vec<VertexData>,
    /// Each face's corners, kept current by every collapse while `track_triangles` is set; the
    /// simplifier's own loop does without (the fans carry what the loop reads: the state is made
    /// without the array) and builds it once at the end from the log
    /// ([`State::rebuild_triangles`]).
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) track_triangles: bool,
    pub(crate) face_alive: Vec<bool>,
    /// The live faces around each vertex, with their other two corners.
    pub(crate) fans: Vec<FanSlot>,
    pub(crate) vertex_alive: Vec<bool>,
    pub(crate) version: Vec<u32>,
    /// Scratch marks for the link condition.
    pub(crate) mark: Vec<u32>,
    pub(crate) mark_stamp: u32,
    /// Scratch for the fold check: the two other corners and the new unit normal of each face.
    pub(crate) fan_scratch: Vec<([u32; 2], DVec3)>,
    /// Scratch for the fold check: for a ring vertex x, the index in `fan_scratch` of the face
    /// whose far edge starts at x (valid only where that face's far edge does start at x).
    pub(crate) spoke: Vec<u32>,
    /// The collapse (survivor, removed, position bits) that `is_legal` last accepted, whose new
    /// face normals `fan_scratch` still holds.
    pub(crate) checked: Option<(u32, u32, [u32; 3])>,
    pub(crate) cos_max_normal_change: f64,
    /// What the distance guard measures with, when it is on.
    pub(crate) guard: Option<DistanceGuard>,
}

/// What ranking an edge reads of each endpoint, in one 128-byte block (two adjacent cache lines)
/// rather than a line or two in each of four arrays. The cost is evaluated about twelve times per
/// collapse, mostly with a neighbour whose data is not in cache. On stanford-bunny (whose vertex
/// order is far from its surface order) this took cost evaluation's simulated L2 misses from 904 k to
/// 392 k and the run's time down by 10–20%; on meshes stored in surface order it gains less
/// (docs/benchmarks.md).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct VertexData {
    pub(crate) quadric: Quadric,
    /// Unit vertex normal: Gouraud at the start, then the linear estimate (or the recomputed mean).
    pub(crate) normal: DVec3,
    pub(crate) position: [f32; 3],
    pub(crate) kind: VertexKind,
    /// A lower bound on the cosine between `normal` and the unit normal of every live face around
    /// the vertex ([`NormalCone`]), in the block's last spare bytes.
    pub(crate) cone: NormalCone,
}

const _: () = assert!(std::mem::size_of::<VertexData>() == 128);

impl VertexData {
    /// Asks the cache for both lines of the block (the quadric starts the first; normal, position,
    /// class and cone fill the second).
    #[inline]
    pub(crate) fn prefetch(&self) {
        prefetch(&self.quadric);
        prefetch(&self.position);
    }
}

/// Whether two faces of a new fan (far edge, unit normal) that share a vertex other than the
/// merged one turn back onto each other: every pair looked at, the reference for the one-pass
/// check in [`State::is_legal`].
fn folds_pairwise(fan: &[([u32; 2], DVec3)]) -> bool {
    (0..fan.len()).any(|i| {
        (i + 1..fan.len()).any(|j| {
            let ([a, b], ni) = fan[i];
            let ([c, d], nj) = fan[j];
            (a == c || a == d || b == c || b == d) && ni.dot(nj) < FOLD_DOT
        })
    })
}

/// Faces whose quality (`4√3·area / Σ edge²`) is below this at the start make their corners'
/// [`NormalCone`]s unusable: the normal of such a face depends on which corner its cross product
/// starts from by more than the cone test's margin. Every face a collapse creates is far above it
/// ([`MIN_TRIANGLE_QUALITY`]).
const CONE_MIN_QUALITY: f64 = 1e-4;

/// Margin (in cosine) that the cone test keeps from the fold threshold: far more than the rounding
/// of the unit normals it compares, so a skipped check is one that could not have failed.
const CONE_MARGIN: f64 = 1e-6;

/// `sin` of the fold angle, `√(1 − FOLD_DOT²)`.
const FOLD_SIN: f64 = 0.435_889_894_354_067_4;

/// The cosine of the widest angle between a vertex's normal and the normals of the faces around it,
/// rounded down to a multiple of 1/32767 (so it never claims a narrower cone than there is).
///
/// It lets the fold check skip the face across a moved face's far edge (x, y) when no face at x can
/// be folded onto: if the moved face's new normal is within θ of x's normal and every face at x is
/// within γ of it, the two normals are at most θ + γ apart, and below the fold angle the check
/// passes. Reading the face across costs a search of x's fan and the position of a vertex of the
/// 2-ring, the largest source of cache misses of the whole loop; the cone sits in the block of x,
/// which the check has just read for x's position. Kept exact by widening the cones of every
/// vertex of each face a collapse moves ([`State::collapse`]), and recomputed for the survivor,
/// whose normal changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NormalCone(i16);

impl NormalCone {
    /// No face yet: every normal is within 0° (the first face widens it).
    const EMPTY: NormalCone = NormalCone(i16::MAX);
    /// Never usable: below −FOLD_DOT's reach, so the test never passes.
    const NEVER: NormalCone = NormalCone(i16::MIN);

    fn at_least(cos: f64) -> NormalCone {
        // One step below the truncated value, so never above `cos` (a float-to-int cast
        // truncates toward zero and saturates; `floor` would be a library call). `max` maps NaN
        // to the lowest value, which no test passes.
        NormalCone((cos * 32767.0 - 1.0).max(NormalCone::NEVER.0 as f64) as i16)
    }

    fn cos(self) -> f64 {
        self.0 as f64 / 32767.0
    }

    /// Widens the cone around `axis` to take in the unit normal `n`.
    fn widen(&mut self, axis: DVec3, n: DVec3) {
        *self = NormalCone(self.0.min(NormalCone::at_least(axis.dot(n)).0));
    }

    /// Whether no face of this cone (around the unit `axis`) can be folded onto a face with unit
    /// normal `n`: the angle between `n` and the axis plus the cone's half-angle stays below the
    /// fold angle, with a margin.
    #[inline]
    fn excludes_fold(self, axis: DVec3, n: DVec3) -> bool {
        let d = axis.dot(n);
        let cos = self.cos();
        // With √(1 − d²) ≤ 1 first (no square root): enough for the usual nearly flat fan.
        d >= FOLD_DOT + CONE_MARGIN
            && (cos >= FOLD_DOT * d + FOLD_SIN + CONE_MARGIN
                || cos >= FOLD_DOT * d + FOLD_SIN * (1.0 - d * d).max(0.0).sqrt() + CONE_MARGIN)
    }
}

impl Default for NormalCone {
    fn default() -> Self {
        NormalCone::EMPTY
    }
}

/// A collapse ready to apply: `removed` merges into `survivor`, which moves to `position`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub(crate) cost: f64,
    pub(crate) survivor: u32,
    pub(crate) removed: u32,
    pub(crate) position: [f32; 3],
}

/// Which endpoint of an edge survives its collapse.
#[derive(Debug, Clone, Copy)]
enum Keep {
    A,
    B,
    /// Either may: the one with more faces ([`State::evaluate`]).
    Larger,
}

/// A collapse as [`State::choose`] ranks it, before the survivor is fixed.
#[derive(Debug, Clone, Copy)]
struct Choice {
    cost: f64,
    error: f64,
    keep: Keep,
    position: DVec3,
}

#[inline]
fn to_f64(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[inline]
fn to_f32(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Input vertices each vertex answers for under the distance guard.
pub(crate) const WITNESSES: usize = 8;

/// What the distance guard ([`SimplifyOptions::guard`]) measures with.
///
/// Input → result: each vertex keeps up to [`WITNESSES`] input vertices merged into it, the ones
/// farthest from its fan after its last collapse (at the start, itself); a candidate collapse is
/// charged the largest distance from the witnesses of both endpoints to the fan it would create.
///
/// Result → input: the distance from the new position and from the centroids of the new faces to
/// the input surface. A walk over the input's faces finds it first: from a face known to be near
/// (each vertex keeps one), each step goes to the edge neighbour closest to the probe while that
/// is closer. The walk can stop at a local minimum, so its distance is never below the true one:
/// where it is within the largest distance found so far it cannot change the charge and stands;
/// otherwise a closest-point tree over the input, seeded with the walk's face, gives the exact
/// distance. The charge is therefore exact, and most probes never reach the tree.
///
/// Bounded work per candidate whatever the reduction. Memory: the tree (56 bytes per input
/// triangle) and the face adjacency (12), and 48 bytes per input vertex.
pub(crate) struct DistanceGuard {
    origin: Vec<[f32; 3]>,
    witnesses: Vec<[u32; WITNESSES]>,
    bvh: crate::bvh::TriangleBvh,
    /// The tree slots of the faces across the three edges of the face in each slot; NONE at a
    /// boundary or a non-manifold edge.
    across: Vec<[u32; 3]>,
    /// Per vertex, the tree slot of an input face near it (where walks start).
    hint: Vec<u32>,
}

/// Most steps a nearest-face walk takes (each is strictly closer; this only bounds the time).
const WALK_STEPS: usize = 64;

impl DistanceGuard {
    fn new(mesh: &Mesh, fans: &[FanSlot]) -> Option<DistanceGuard> {
        let bvh = crate::bvh::TriangleBvh::new(mesh)?;
        let slots = bvh.slots_by_face(mesh.face_count());
        let hint = fans.iter().map(|f| f.first().map_or(NONE, |c| slots[c.face as usize])).collect();
        let witnesses = (0..mesh.vertex_count() as u32)
            .map(|v| {
                let mut w = [NONE; WITNESSES];
                w[0] = v;
                w
            })
            .collect();
        // The face across edge (u → v) of a face is the one at u whose corner comes back from v
        // (prev = v); found in u's fan, which holds the input's faces at this point. Left NONE
        // where the edge has no such face or more than one (boundary, non-manifold).
        let mut across = vec![[NONE; 3]; bvh.len()];
        for (f, t) in mesh.triangles.iter().enumerate() {
            let Some(&slot) = slots.get(f).filter(|&&s| s != NONE) else { continue };
            for i in 0..3 {
                let (u, v) = (t[i], t[(i + 1) % 3]);
                let mut back = fans[u as usize].iter().filter(|c| c.prev == v);
                if let (Some(c), None) = (back.next(), back.next()) {
                    across[slot as usize][i] = slots[c.face as usize];
                }
            }
        }
        Some(DistanceGuard { origin: mesh.positions.clone(), witnesses, bvh, across, hint })
    }

    /// The squared distance from `q` to the input surface where it matters: `walked` (a walk's
    /// result, never below the true distance) when that is within `worst` already, else the
    /// tree's exact answer.
    fn exact(&self, q: DVec3, walked: f64, slot: u32, worst: f64) -> f64 {
        if walked <= worst {
            return walked;
        }
        self.bvh.closest_point(q, Some(slot)).distance_squared
    }

    /// The walk's nearest input face to `q` from the nearest of `starts` (NONE entries skipped):
    /// (squared distance, slot); (∞, NONE) without a start. Stops as soon as a face is within
    /// `enough` (squared): the caller only needs to know that.
    fn nearest_face(&self, q: DVec3, starts: &[u32], enough: f64) -> (f64, u32) {
        let mut best = (f64::INFINITY, NONE);
        for &f in starts.iter().filter(|&&f| f != NONE) {
            let d = self.bvh.slot_distance_squared(q, f);
            if d < best.0 {
                best = (d, f);
                if d <= enough {
                    return best;
                }
            }
        }
        if best.1 == NONE {
            return best;
        }
        for _ in 0..WALK_STEPS {
            if best.0 <= enough {
                break;
            }
            let mut step = best;
            for &g in self.across[best.1 as usize].iter().filter(|&&g| g != NONE) {
                let d = self.bvh.slot_distance_squared(q, g);
                if d < step.0 {
                    step = (d, g);
                }
            }
            if step.1 == best.1 {
                break;
            }
            best = step;
        }
        best
    }
}

/// Squared distance from `q` to the nearest of the triangles (`p`, x, y) over `far_edges`
/// (infinite when there are none).
fn fan_distance2(q: DVec3, p: DVec3, far_edges: &[(DVec3, DVec3)]) -> f64 {
    far_edges
        .iter()
        .map(|&(x, y)| (crate::bvh::closest_point_on_triangle(q, p, x, y) - q).length_squared())
        .fold(f64::INFINITY, f64::min)
}

/// `4√3·area / Σ edge²`: 1 for equilateral, 0 for degenerate; `area2` is twice the area (the
/// length of the edge cross product, which the caller has at hand).
#[inline]
fn triangle_quality(area2: f64, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if sum > 0.0 { 2.0 * 3f64.sqrt() * area2 / sum } else { 0.0 }
}

impl<'o> State<'o> {
    pub(crate) fn point(&self, v: u32) -> DVec3 {
        to_f64(self.vertices[v as usize].position)
    }

    pub(crate) fn face_normal(&self, f: u32) -> DVec3 {
        debug_assert!(self.track_triangles, "the triangle array is not being kept current");
        let [a, b, c] = self.triangles[f as usize];
        let (pa, pb, pc) = (self.point(a), self.point(b), self.point(c));
        (pb - pa).cross(pc - pa).normalize_or_zero()
    }

    /// Mean of the unit normals of the faces around `v` (Gouraud).
    pub(crate) fn fan_normal(&self, v: u32) -> DVec3 {
        let p = self.point(v);
        let sum: DVec3 = self.fans[v as usize]
            .iter()
            .map(|c| (self.point(c.next) - p).cross(self.point(c.prev) - p).normalize_or_zero())
            .sum();
        sum.normalize_or_zero()
    }

    /// Faces on edge (a, b), as corners of `a`'s fan, and how many there are.
    fn edge_corners(&self, a: u32, b: u32) -> ([Corner; 2], usize) {
        self.fans[a as usize].touching(b)
    }

    /// The collapse of edge {a, b} the metric prefers, or `None` if the rules forbid every
    /// direction and placement. Geometry-independent rules only; the rest is in `is_legal`.
    pub(crate) fn evaluate(&self, a: u32, b: u32) -> Option<Candidate> {
        let choice = self.choose(a, b)?;
        let (survivor, removed) = match choice.keep {
            Keep::A => (a, b),
            Keep::B => (b, a),
            // The survivor of a moving collapse: the endpoint that already has more faces, so
            // fewer faces change corners (smaller vertex split).
            Keep::Larger if self.fans[a as usize].len() >= self.fans[b as usize].len() => (a, b),
            Keep::Larger => (b, a),
        };
        Some(Candidate { cost: choice.cost, survivor, removed, position: to_f32(choice.position) })
    }

    /// The queue key of edge {a, b} with the distance guard's term added: never below the key
    /// [`State::entry`] gives it, which leaves the term out.
    fn guarded_key(&self, guard: &DistanceGuard, a: u32, b: u32) -> Option<u32> {
        let choice = self.choose(a, b)?;
        let (va, vb) = (&self.vertices[a as usize], &self.vertices[b as usize]);
        let area = va.quadric.weight + vb.quadric.weight;
        let d2 = self.guard_distance2(guard, a, b, choice.position);
        let factor = self.normal_factor(va, vb);
        let length2 = (to_f64(va.position) - to_f64(vb.position)).length_squared();
        Some(order_key((choice.error + self.options.guard * area * d2) * factor, choice.error, length2))
    }

    /// The squared distance the guard charges for collapsing {a, b} to `p`: the larger of the
    /// farthest witness of `a` or `b` from the new fan (input → result) and the farthest of `p` and
    /// the new faces' centroids from the input surface (result → input).
    fn guard_distance2(&self, guard: &DistanceGuard, a: u32, b: u32, p: DVec3) -> f64 {
        let mut far_edges: SmallVec<[(DVec3, DVec3); 16]> = SmallVec::new();
        let mut far_hints: SmallVec<[[u32; 2]; 16]> = SmallVec::new();
        for (v, other) in [(a, b), (b, a)] {
            for corner in &self.fans[v as usize] {
                if !corner.touches(other) {
                    far_edges.push((self.point(corner.next), self.point(corner.prev)));
                    far_hints.push([corner.next, corner.prev].map(|x| guard.hint[x as usize]));
                }
            }
        }
        // Only the maximum matters: a witness with a face within `worst` cannot raise it, so its
        // search stops there, starting from the face that was nearest to the witness before.
        let mut worst: f64 = 0.0;
        let mut start = 0;
        let witnesses = guard.witnesses[a as usize].iter().chain(&guard.witnesses[b as usize]);
        for &w in witnesses.filter(|&&w| w != NONE) {
            let q = to_f64(guard.origin[w as usize]);
            let mut nearest = (f64::INFINITY, start);
            for k in (start..far_edges.len()).chain(0..start) {
                let (x, y) = far_edges[k];
                let d = (crate::bvh::closest_point_on_triangle(q, p, x, y) - q).length_squared();
                if d < nearest.0 {
                    nearest = (d, k);
                    if d <= worst {
                        break;
                    }
                }
            }
            worst = worst.max(nearest.0);
            start = nearest.1;
        }
        let (ha, hb) = (guard.hint[a as usize], guard.hint[b as usize]);
        let (d, near_p) = guard.nearest_face(p, &[ha, hb], worst);
        worst = worst.max(guard.exact(p, d, near_p, worst));
        for (&(px, py), &[hx, hy]) in far_edges.iter().zip(&far_hints) {
            let q = (p + px + py) / 3.0;
            let (d, f) = guard.nearest_face(q, &[near_p, hx, hy], worst);
            worst = worst.max(guard.exact(q, d, f, worst));
        }
        worst
    }

    /// After `a` took over a collapse: its witnesses become the [`WITNESSES`] of both endpoints'
    /// that are farthest from its new fan, and its hint the input face nearest to it.
    fn update_guard(&mut self, a: u32, b: u32) {
        let Some(mut guard) = self.guard.take() else { return };
        let p = self.point(a);
        let far_edges: SmallVec<[(DVec3, DVec3); 16]> =
            self.fans[a as usize].iter().map(|c| (self.point(c.next), self.point(c.prev))).collect();
        let mut ranked: SmallVec<[(f64, u32); 2 * WITNESSES]> = guard.witnesses[a as usize]
            .iter()
            .chain(&guard.witnesses[b as usize])
            .filter(|&&w| w != NONE)
            .map(|&w| (fan_distance2(to_f64(guard.origin[w as usize]), p, &far_edges), w))
            .collect();
        // Farthest first; equal distances by index, so the choice never depends on the order.
        ranked.sort_unstable_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        let mut kept = [NONE; WITNESSES];
        for (slot, &(_, w)) in kept.iter_mut().zip(&ranked) {
            *slot = w;
        }
        guard.witnesses[a as usize] = kept;
        guard.witnesses[b as usize] = [NONE; WITNESSES];
        let (ha, hb) = (guard.hint[a as usize], guard.hint[b as usize]);
        guard.hint[a as usize] = guard.nearest_face(p, &[ha, hb], 0.0).1;
        guard.hint[b as usize] = NONE;
        self.guard = Some(guard);
    }

    /// QFVP's normal term `(1 − cos θ)^w` of an edge with these endpoints (1 for QEM and w = 0).
    #[inline]
    fn normal_factor(&self, va: &VertexData, vb: &VertexData) -> f64 {
        let w = self.options.metric.w().unwrap_or(0.0);
        if w == 0.0 {
            return 1.0;
        }
        let x = 1.0 - va.normal.dot(vb.normal).clamp(-1.0, 1.0);
        match w {
            0.5 => x.sqrt(),
            1.0 => x,
            1.5 => x * x.sqrt(),
            2.0 => x * x,
            _ => x.powf(w),
        }
    }

    /// The metric's preferred collapse of edge {a, b} as cost, error and position, the survivor
    /// left open where either endpoint may move: the queue key needs no more, so queueing an edge
    /// never reads the fans.
    #[inline]
    fn choose(&self, a: u32, b: u32) -> Option<Choice> {
        let (va, vb) = (&self.vertices[a as usize], &self.vertices[b as usize]);
        let (ka, kb) = (va.kind, vb.kind);
        if ka == VertexKind::Frozen || kb == VertexKind::Frozen {
            return None;
        }
        let lock = self.options.boundary == BoundaryMode::Lock;
        // Which endpoints may survive, and whether the survivor may move.
        let (may_keep_a, may_keep_b, may_move) = match (ka, kb) {
            (VertexKind::Boundary, VertexKind::Boundary) => {
                if lock || self.edge_corners(a, b).1 != 1 {
                    return None; // interior edge joining two boundary points, or locked border
                }
                (true, true, true)
            }
            (VertexKind::Boundary, _) => (true, false, false),
            (_, VertexKind::Boundary) => (false, true, false),
            _ => (true, true, true),
        };
        let (pa, pb) = (to_f64(va.position), to_f64(vb.position));
        let mut best: Option<Choice> = None;
        // Keeps the choice with the lower (cost, error); the first one considered wins a tie.
        let mut consider = |keep: Keep, position: DVec3, cost: f64, error: f64| {
            if best.as_ref().is_none_or(|c| (cost, error) < (c.cost, c.error)) {
                best = Some(Choice { cost, error, keep, position });
            }
        };
        let q = va.quadric + vb.quadric;
        match self.options.metric {
            Metric::Melax => {
                if may_keep_b {
                    consider(Keep::B, pb, self.melax_cost(a, b), q.error(pb));
                }
                if may_keep_a {
                    consider(Keep::A, pa, self.melax_cost(b, a), q.error(pa));
                }
            }
            Metric::Qem | Metric::Qfvp { .. } => {
                // The normal term depends on the edge only, not on where the merged vertex goes,
                // so every placement of this edge is ranked by its quadric error alone.
                let factor = self.normal_factor(va, vb);
                let mover = match (may_keep_a, may_keep_b) {
                    (true, false) => Keep::A,
                    (false, true) => Keep::B,
                    _ => Keep::Larger,
                };
                let on_boundary = ka == VertexKind::Boundary && kb == VertexKind::Boundary;
                let optimal = may_move && self.options.placement == Placement::Optimal;
                if optimal
                    && !on_boundary
                    && let Some(p) = q.minimizer()
                    && (p - (pa + pb) * 0.5).length_squared() <= (pa - pb).length_squared()
                {
                    // The minimiser of vᵀQv, when well conditioned and within one edge length of
                    // the midpoint (a nearly singular system can run far off), has the lowest
                    // error of all placements: nothing else needs evaluating.
                    let error = q.error(p);
                    return Some(Choice { cost: error * factor, error, keep: mover, position: p });
                }
                let (e_a, e_b) = (q.error(pa), q.error(pb));
                if may_keep_a {
                    consider(Keep::A, pa, e_a * factor, e_a);
                }
                if may_keep_b {
                    consider(Keep::B, pb, e_b * factor, e_b);
                }
                if may_move && self.options.placement != Placement::Endpoint {
                    let mid = (pa + pb) * 0.5;
                    let e_mid = q.error(mid);
                    consider(mover, mid, e_mid * factor, e_mid);
                    if optimal && on_boundary {
                        // A boundary edge's vertex stays on the edge: the best point of the segment
                        // (the error along it is a parabola through its values at 0, ½ and 1).
                        let curvature = e_a - 2.0 * e_mid + e_b;
                        if curvature > 0.0 {
                            let t = (0.25 * (3.0 * e_a - 4.0 * e_mid + e_b) / curvature).clamp(0.0, 1.0);
                            let p = pa + (pb - pa) * t;
                            let error = q.error(p);
                            consider(mover, p, error * factor, error);
                        }
                    }
                }
            }
        }
        best
    }

    /// Melax's cost of moving `u` onto `v`: |u − v| × max over faces f at u of
    /// min over faces n on edge uv of (1 − f·n) / 2.
    fn melax_cost(&self, u: u32, v: u32) -> f64 {
        let length = (self.point(u) - self.point(v)).length();
        let (shared, count) = self.edge_corners(u, v);
        let shared = &shared[..count.min(2)];
        let mut curvature: f64 = 0.0;
        for c in &self.fans[u as usize] {
            let nf = self.face_normal(c.face);
            let min = shared.iter().map(|s| (1.0 - nf.dot(self.face_normal(s.face))) / 2.0).fold(1.0f64, f64::min);
            curvature = curvature.max(min);
        }
        length * curvature
    }

    /// Link condition, fan size, normal-change and quality checks for a candidate.
    pub(crate) fn is_legal(&mut self, c: &Candidate) -> bool {
        self.checked = None;
        let (a, b) = (c.survivor, c.removed);
        self.prefetch_ring(a, b);
        let (shared, shared_count) = self.edge_corners(a, b);
        if shared_count == 0 || shared_count > 2 {
            return false;
        }
        // Link condition: common neighbours are exactly the opposite vertices of the edge faces.
        let opposite = [shared[0].other(b), if shared_count == 2 { shared[1].other(b) } else { NONE }];
        let stamp = self.next_stamp();
        for corner in &self.fans[a as usize] {
            self.mark[corner.next as usize] = stamp;
            self.mark[corner.prev as usize] = stamp;
        }
        // Counted without a branch on the data (whether a neighbour of b is one of a's is as good
        // as random): each common neighbour once, and whether any is not opposite the edge.
        let mut common = 0;
        let mut stray = false;
        for corner in &self.fans[b as usize] {
            for v in [corner.next, corner.prev] {
                let mark = &mut self.mark[v as usize];
                let hit = (v != a) & (*mark == stamp);
                *mark = if hit { stamp.wrapping_sub(1) } else { *mark }; // count each neighbour once
                stray |= hit & (v != opposite[0]) & (v != opposite[1]);
                common += hit as usize;
            }
        }
        if stray || common != shared_count {
            return false;
        }
        // The merged vertex keeps enough faces.
        let remaining = self.fans[a as usize].len() + self.fans[b as usize].len() - 2 * shared_count;
        let interior = self.vertices[a as usize].kind == VertexKind::Interior
            && self.vertices[b as usize].kind == VertexKind::Interior;
        if remaining < if interior { 3 } else { 1 } {
            return false;
        }
        // Surviving faces: no flip beyond the threshold, no needle.
        let p = to_f64(c.position);
        let mut fan = std::mem::take(&mut self.fan_scratch);
        fan.clear();
        for (v, other) in [(a, b), (b, a)] {
            let pv = self.point(v);
            for corner in &self.fans[v as usize] {
                if corner.touches(other) {
                    continue;
                }
                let (x, y) = (corner.next, corner.prev);
                let (px, py) = (self.point(x), self.point(y));
                let n_old = (px - pv).cross(py - pv);
                let n_new = (px - p).cross(py - p);
                let (lo, ln) = (n_old.length(), n_new.length());
                if ln == 0.0 || triangle_quality(ln, p, px, py) < MIN_TRIANGLE_QUALITY {
                    self.fan_scratch = fan;
                    return false;
                }
                if lo > 0.0 && n_old.dot(n_new) < self.cos_max_normal_change * lo * ln {
                    self.fan_scratch = fan;
                    return false;
                }
                let n_new = n_new / ln;
                // The face across the far edge (x, y) keeps its normal; the moved face must not
                // fold onto it. Looked at only when the cones of x and y cannot rule that out.
                let (vx, vy) = (&self.vertices[x as usize], &self.vertices[y as usize]);
                let ruled_out = vx.cone.excludes_fold(vx.normal, n_new) || vy.cone.excludes_fold(vy.normal, n_new);
                debug_assert!(!ruled_out || !self.folds_across(corner.face, a, b, [x, y], [px, py], n_new));
                if !ruled_out && self.folds_across(corner.face, a, b, [x, y], [px, py], n_new) {
                    self.fan_scratch = fan;
                    return false;
                }
                fan.push(([x, y], n_new));
            }
        }
        // No fold: two faces of the new fan that share an edge must not turn back onto each other
        // (a sequence of small per-face normal changes can otherwise fold a pair over). The link
        // condition holds, so the new fan is a disk (or half of one) in which the spoke (merged
        // vertex, x) is the `x` of one face and the `y` of the next: each face finds the face it
        // follows through `spoke`, indexed by vertex, in one pass without a data-dependent branch
        // (checking all pairs cost a mispredicted branch per shared edge). A `spoke` entry left by
        // an earlier check is told apart by the face it names not having that `x`.
        for (i, &([x, _], _)) in fan.iter().enumerate() {
            self.spoke[x as usize] = i as u32;
        }
        let mut folded = false;
        for &([_, y], n) in fan.iter() {
            let before = fan.get(self.spoke[y as usize] as usize);
            folded |= before.is_some_and(|&([x, _], m)| (x == y) & (m.dot(n) < FOLD_DOT));
        }
        debug_assert_eq!(folded, folds_pairwise(&fan), "spoke pairing disagrees with the pairwise check");
        self.fan_scratch = fan;
        if folded {
            return false;
        }
        self.checked = Some((a, b, c.position.map(f32::to_bits)));
        true
    }

    /// Asks the cache, all at once, for what the checks, the collapse of (a, b) and the re-ranking
    /// of its edges will read of the ring around the edge: each neighbour's block (both lines) and
    /// fan. The misses then overlap instead of following one another through the data-dependent
    /// branches of the checks (real loads did this too, 3–7% less well: they stall the core).
    #[inline]
    fn prefetch_ring(&self, a: u32, b: u32) {
        // Not a nor b (each is a `next` around the other: their data is in cache already). A
        // hint that has to wait for a free fill buffer stalls the core, so none is wasted.
        for (v, other) in [(a, b), (b, a)] {
            for corner in &self.fans[v as usize] {
                let x = corner.next;
                if x != other {
                    self.vertices[x as usize].prefetch();
                    self.fans[x as usize].prefetch();
                }
            }
        }
    }

    /// Asks the cache for what checking the collapse of (a, b) reads first: the version stamps,
    /// both lines of each endpoint's block and both lines of each fan (the fan after `v`'s starts
    /// where `v`'s ends). A hint only: it never faults and changes nothing.
    #[inline]
    fn prefetch_edge(&self, a: u32, b: u32) {
        for v in [a as usize, b as usize] {
            prefetch(&self.version[v]);
            self.vertices[v].prefetch();
            self.fans[v].prefetch();
        }
    }

    /// Whether the moved face `face` (now with unit normal `n_new`, far edge (x, y) at `px`, `py`)
    /// folds onto the face across its far edge, which is not a face of the collapsing edge (a, b).
    fn folds_across(&self, face: u32, a: u32, b: u32, [x, y]: [u32; 2], [px, py]: [DVec3; 2], n_new: DVec3) -> bool {
        let across = self.fans[x as usize].iter().find(|d| {
            d.face != face && d.touches(y) && {
                let z = d.other(y);
                z != a && z != b
            }
        });
        across.is_some_and(|d| {
            // One corner of the face across is y, already at hand: only its third is read.
            let (pn, pp) = if d.next == y { (py, self.point(d.prev)) } else { (self.point(d.next), py) };
            let n_across = (pn - px).cross(pp - px).normalize_or_zero();
            n_across.dot(n_new) < FOLD_DOT
        })
    }

    /// Applies a legal collapse and returns its log record.
    pub(crate) fn collapse(&mut self, c: &Candidate) -> CollapseRecord {
        let (a, b) = (c.survivor, c.removed);
        let (shared, shared_count) = self.edge_corners(a, b);
        let mut record = CollapseRecord {
            survivor: a,
            removed: b,
            left: NONE,
            right: NONE,
            left_face: NONE,
            right_face: NONE,
            survivor_position: self.vertices[a as usize].position,
            removed_position: self.vertices[b as usize].position,
            collapsed_position: c.position,
            error: 0.0,
        };
        let mut dead = [NONE; 2];
        for (slot, corner) in dead.iter_mut().zip(&shared[..shared_count]) {
            let (f, third) = (corner.face, corner.other(b));
            // The face with half-edge a→b is the left face of the split (vs = a, vt = b).
            if corner.next == b {
                record.left = third;
                record.left_face = f;
            } else {
                record.right = third;
                record.right_face = f;
            }
            self.face_alive[f as usize] = false;
            *slot = f;
            let fan = &mut self.fans[third as usize];
            if let Some(i) = fan.find_face(f) {
                fan.remove(i);
            }
        }
        let is_dead = |d: &Corner| (d.face == dead[0]) | (d.face == dead[1]);
        self.fans[a as usize].retain(|d| !is_dead(d));
        let moved = std::mem::take(&mut self.fans[b as usize]);
        let count_a = self.fans[a as usize].len() as f64;
        // b's fan holds each face at b once, the shared faces among them.
        let count_b = moved.len() - shared_count;
        debug_assert_eq!(count_b, moved.iter().filter(|d| !is_dead(d)).count());
        for corner in moved.iter().filter(|d| !is_dead(d)) {
            let f = corner.face;
            if self.track_triangles {
                for slot in self.triangles[f as usize].iter_mut() {
                    if *slot == b {
                        *slot = a;
                    }
                }
            }
            // The face's corners at its two other vertices name b: they now name a.
            for x in [corner.next, corner.prev] {
                let fan = &mut self.fans[x as usize];
                if let Some(d) = fan.find_face(f).map(|i| &mut fan[i]) {
                    // One of the two names b: which one is as good as random, so no branch.
                    d.next = if d.next == b { a } else { d.next };
                    d.prev = if d.prev == b { a } else { d.prev };
                }
            }
            self.fans[a as usize].push(*corner);
        }
        self.vertex_alive[b as usize] = false;
        let removed = self.vertices[b as usize];
        let survivor = &mut self.vertices[a as usize];
        survivor.position = c.position;
        survivor.quadric += removed.quadric;
        // The linear estimate, unless it cancels out (opposite normals): then Gouraud on the new fan.
        let linear = (survivor.normal * count_a + removed.normal * count_b as f64).normalize_or_zero();
        self.vertices[a as usize].normal = match self.options.normals {
            NormalUpdate::Linear if linear != DVec3::ZERO => linear,
            NormalUpdate::Linear | NormalUpdate::Recompute => self.fan_normal(a),
        };
        let checked = self.checked.take() == Some((a, b, c.position.map(f32::to_bits)));
        self.update_cones(a, checked);
        self.update_guard(a, b);
        self.version[a as usize] = self.version[a as usize].wrapping_add(1);
        self.version[b as usize] = self.version[b as usize].wrapping_add(1);
        record
    }

    /// Keeps the [`NormalCone`]s exact after `a` moved and took over faces: each face around `a`
    /// widens the cones of its two other corners, and `a`'s own cone is rebuilt around its new
    /// normal from these faces alone (they are all its faces). With `checked`, the new normals are
    /// the ones [`State::is_legal`] just computed for this collapse (its scratch holds exactly the
    /// faces of `a`'s new fan); otherwise they are computed here.
    fn update_cones(&mut self, a: u32, checked: bool) {
        let axis = self.vertices[a as usize].normal;
        let mut cone = NormalCone::EMPTY;
        if checked {
            debug_assert_eq!(self.fan_scratch.len(), self.fans[a as usize].len());
            for &([x, y], n) in &self.fan_scratch {
                cone.widen(axis, n);
                for v in [x, y] {
                    let vertex = &mut self.vertices[v as usize];
                    vertex.cone.widen(vertex.normal, n);
                }
            }
            self.vertices[a as usize].cone = cone;
            return;
        }
        let p = self.point(a);
        for i in 0..self.fans[a as usize].len() {
            let Corner { next: x, prev: y, .. } = self.fans[a as usize][i];
            let (px, py) = (self.point(x), self.point(y));
            let cross = (px - p).cross(py - p);
            let area2 = cross.length();
            // `is_legal` refuses collapses that make a face this poor; a caller that skipped it
            // gets cones that never rule a fold out, not wrong ones.
            if area2 == 0.0 || triangle_quality(area2, p, px, py) < CONE_MIN_QUALITY {
                cone = NormalCone::NEVER;
                self.vertices[x as usize].cone = NormalCone::NEVER;
                self.vertices[y as usize].cone = NormalCone::NEVER;
                continue;
            }
            let n = cross / area2;
            cone.widen(axis, n);
            for v in [x, y] {
                let vertex = &mut self.vertices[v as usize];
                vertex.cone.widen(vertex.normal, n);
            }
        }
        self.vertices[a as usize].cone = cone;
    }

    /// A fresh stamp for the scratch marks (every mark is older).
    fn next_stamp(&mut self) -> u32 {
        self.mark_stamp = self.mark_stamp.wrapping_add(2);
        if self.mark_stamp < 2 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.mark_stamp = 2;
        }
        self.mark_stamp
    }

    /// The one-ring of `v`, sorted, into `out`.
    pub(crate) fn neighbours(&self, v: u32, out: &mut Vec<u32>) {
        // Around a closed manifold fan every neighbour is the `next` corner of exactly one face, so
        // those alone are the ring; an open fan adds its last `prev`. Sorting the `next` corners
        // and adding only the missing `prev` ones sorts half as much as sorting both.
        let fan = &self.fans[v as usize];
        out.clear();
        out.extend(fan.iter().map(|c| c.next));
        out.sort_unstable();
        out.dedup();
        let nexts = out.len();
        for c in fan {
            let missing = if nexts <= 16 {
                !out[..nexts].contains(&c.prev)
            } else {
                out[..nexts].binary_search(&c.prev).is_err()
            };
            if missing {
                out.push(c.prev);
            }
        }
        if out.len() > nexts {
            out.sort_unstable();
            out.dedup();
        }
    }

    fn push_edges_of(&mut self, v: u32, heap: &mut TieredQueue, neighbours: &mut Vec<u32>) {
        // Unique neighbours by mark stamps (no sort: the heap's total order makes push order moot).
        // Written unconditionally and kept by advancing the count: whether a corner's vertex was
        // seen already is as good as random (each is seen twice around an interior vertex).
        let stamp = self.next_stamp();
        let fan = &self.fans[v as usize];
        neighbours.clear();
        neighbours.resize(2 * fan.len(), NONE);
        let mut count = 0;
        for c in fan {
            for u in [c.next, c.prev] {
                let mark = &mut self.mark[u as usize];
                neighbours[count] = u;
                count += (*mark != stamp) as usize;
                *mark = stamp;
            }
        }
        neighbours.truncate(count);
        let mut pairs = neighbours.chunks_exact(2);
        for pair in &mut pairs {
            for entry in self.entry_pair(v, [pair[0], pair[1]]).into_iter().flatten() {
                heap.push(entry);
            }
        }
        for &u in pairs.remainder() {
            self.push_edge(v, u, heap);
        }
    }

    /// [`State::entry`] of edges {v, us[0]} and {v, us[1]}: in the usual case (interior ends, a
    /// quadric cost, optimal placement) both quadric sums are minimised side by side
    /// ([`QuadricPair`]); an edge outside it, or whose minimiser is refused, is ranked alone. The
    /// same keys to the bit: the pair performs the scalar operations lane by lane, and the sums,
    /// the midpoint, the squared edge length and the normals' dot product do not depend on which
    /// end comes first.
    #[inline]
    fn entry_pair(&self, v: u32, us: [u32; 2]) -> [Option<QueueEntry>; 2] {
        let vv = &self.vertices[v as usize];
        let (v0, v1) = (&self.vertices[us[0] as usize], &self.vertices[us[1] as usize]);
        let quadric_cost = self.options.metric != Metric::Melax && self.options.placement == Placement::Optimal;
        let interior = quadric_cost & (vv.kind == VertexKind::Interior);
        let usual = [interior & (v0.kind == VertexKind::Interior), interior & (v1.kind == VertexKind::Interior)];
        if !(usual[0] || usual[1]) {
            return [self.entry(v, us[0]), self.entry(v, us[1])];
        }
        let pair = QuadricPair::sums(&vv.quadric, [&v0.quadric, &v1.quadric]);
        let (points, solved) = pair.minimizers();
        let errors = pair.errors(points);
        let pv = to_f64(vv.position);
        let mut out = [None; 2];
        for (i, vu) in [v0, v1].into_iter().enumerate() {
            let pu = to_f64(vu.position);
            let length2 = (pv - pu).length_squared();
            let near = (points[i] - (pv + pu) * 0.5).length_squared() <= length2;
            out[i] = if usual[i] && solved[i] && near {
                let (a, b) = (v.min(us[i]), v.max(us[i]));
                let key = order_key(errors[i] * self.normal_factor(vv, vu), errors[i], length2);
                Some(QueueEntry::new(key, a, b, self.stamp(a, b)))
            } else {
                self.entry(v, us[i])
            };
        }
        out
    }

    fn push_edge(&self, a: u32, b: u32, heap: &mut TieredQueue) {
        if let Some(entry) = self.entry(a, b) {
            heap.push(entry);
        }
    }

    fn entry(&self, a: u32, b: u32) -> Option<QueueEntry> {
        let (a, b) = (a.min(b), a.max(b));
        let choice = self.choose(a, b)?;
        let length2 = (self.point(a) - self.point(b)).length_squared();
        Some(QueueEntry::new(order_key(choice.cost, choice.error, length2), a, b, self.stamp(a, b)))
    }

    /// Whether neither endpoint of `entry` changed since it was queued.
    #[inline]
    fn is_current(&self, entry: &QueueEntry) -> bool {
        self.stamp(entry.a(), entry.b & !GUARDED) == entry.stamp
    }

    /// Sum of the version stamps of `a` and `b` (see [`QueueEntry::stamp`]).
    #[inline]
    fn stamp(&self, a: u32, b: u32) -> u32 {
        self.version[a as usize].wrapping_add(self.version[b as usize])
    }
}

impl<'o> State<'o> {
    /// Working state for `mesh` (prepared: no repeated-index faces, no unreferenced vertices):
    /// fans, vertex classes, area-weighted quadrics with boundary constraint planes, Gouraud
    /// normals. Also returns every undirected edge once, as `[low, high]`, sorted.
    pub(crate) fn new(mesh: &Mesh, options: &'o SimplifyOptions) -> (State<'o>, Vec<[u32; 2]>) {
        State::with_tracking(mesh, options, true)
    }

    /// [`State::new`], keeping the triangle array current through the collapses or (without
    /// `track`) leaving it empty until [`State::rebuild_triangles`].
    pub(crate) fn with_tracking(mesh: &Mesh, options: &'o SimplifyOptions, track: bool) -> (State<'o>, Vec<[u32; 2]>) {
        let vertex_count = mesh.vertex_count();
        // The passes over the faces below write to their corners' fans and blocks, in the input's
        // vertex order, which can be far from its face order: each asks for the data of the face
        // `AHEAD` places on while it works on this one.
        const AHEAD: usize = 8;
        let mut fans = vec![FanSlot::default(); vertex_count];
        for (f, &[x, y, z]) in mesh.triangles.iter().enumerate() {
            if let Some(t) = mesh.triangles.get(f + AHEAD) {
                t.iter().for_each(|&v| fans[v as usize].prefetch());
            }
            let face = f as u32;
            fans[x as usize].push(Corner { face, next: y, prev: z });
            fans[y as usize].push(Corner { face, next: z, prev: x });
            fans[z as usize].push(Corner { face, next: x, prev: y });
        }
        let Scan { kind, edges, boundary_edges } = scan_fans(&fans);

        let mut state = State {
            options,
            vertices: mesh
                .positions
                .iter()
                .zip(kind)
                .map(|(&position, kind)| VertexData { position, kind, ..Default::default() })
                .collect(),
            triangles: if track { mesh.triangles.clone() } else { Vec::new() },
            track_triangles: track,
            face_alive: vec![true; mesh.face_count()],
            fans,
            vertex_alive: vec![true; vertex_count],
            version: vec![0; vertex_count],
            mark: vec![0; vertex_count],
            mark_stamp: 0,
            fan_scratch: Vec::new(),
            spoke: vec![0; vertex_count],
            checked: None,
            cos_max_normal_change: options.max_normal_change_degrees.to_radians().cos(),
            guard: None,
        };
        if options.guard > 0.0 {
            state.guard = DistanceGuard::new(mesh, &state.fans);
        }
        if options.boundary == BoundaryMode::Lock {
            for vertex in state.vertices.iter_mut() {
                if vertex.kind == VertexKind::Boundary {
                    vertex.kind = VertexKind::Frozen;
                }
            }
        }
        // Quadrics: area-weighted face planes, plus boundary planes perpendicular to boundary faces.
        // Vertex normals (Gouraud: the mean of the unit normals of the faces around) gathered in the
        // same pass, and each face's unit normal kept for the normal cones, which need the vertex
        // normals first: NaN where the face is too poor for a cone (NaN makes the cone unusable).
        let mut face_units = Vec::with_capacity(mesh.face_count());
        for (f, t) in mesh.triangles.iter().enumerate() {
            if let Some(t) = mesh.triangles.get(f + AHEAD) {
                t.iter().for_each(|&v| state.vertices[v as usize].prefetch());
            }
            let [pa, pb, pc] = mesh.triangle_points(f);
            let n = (pb - pa).cross(pc - pa);
            let area = 0.5 * n.length();
            if area == 0.0 {
                face_units.push(DVec3::NAN);
                continue;
            }
            let unit = n / (2.0 * area);
            let usable = triangle_quality(2.0 * area, pa, pb, pc) >= CONE_MIN_QUALITY;
            face_units.push(if usable { unit } else { DVec3::NAN });
            // `n.normalize()` rather than `unit` (equal up to the last bit): the collapse order,
            // and so the documented figures, follow these exact bits — bunny at 90% moves from
            // 0.006502 to 0.007331 with `unit` (see docs/simplify-report.md, sensitivity).
            let q = Quadric::from_plane(n.normalize(), pa, area);
            for &v in t {
                let vertex = &mut state.vertices[v as usize];
                vertex.quadric += q;
                vertex.normal += unit;
            }
        }
        for vertex in state.vertices.iter_mut() {
            vertex.normal = vertex.normal.normalize_or_zero();
        }
        for (f, (t, &unit)) in mesh.triangles.iter().zip(&face_units).enumerate() {
            if let Some(t) = mesh.triangles.get(f + AHEAD) {
                t.iter().for_each(|&v| prefetch(&state.vertices[v as usize].normal));
            }
            for &v in t {
                let vertex = &mut state.vertices[v as usize];
                vertex.cone.widen(vertex.normal, unit);
            }
        }
        for &(a, b, f) in &boundary_edges {
            let [p0, p1, p2] = mesh.triangle_points(f as usize);
            let face_normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
            let (pa, pb) = (mesh.point(a), mesh.point(b));
            let edge = pb - pa;
            let plane_normal = edge.cross(face_normal).normalize_or_zero();
            if plane_normal == DVec3::ZERO {
                continue;
            }
            let q = Quadric::constraint(plane_normal, pa, BOUNDARY_WEIGHT * edge.length_squared());
            state.vertices[a as usize].quadric += q;
            state.vertices[b as usize].quadric += q;
        }
        (state, edges)
    }

    /// Brings `triangles` up to date after a run without tracking: every corner names the vertex
    /// its input vertex was merged into, last merge first (the same as renaming at each collapse).
    /// Built from the input's triangles (`mesh`, the one the state was made from): the state
    /// holds no copy while it does not track them.
    pub(crate) fn rebuild_triangles(&mut self, mesh: &Mesh, log: &[CollapseRecord]) {
        if self.track_triangles {
            return;
        }
        let mut last: Vec<u32> = (0..self.vertices.len() as u32).collect();
        for record in log.iter().rev() {
            last[record.removed as usize] = last[record.survivor as usize];
        }
        self.triangles = mesh.triangles.iter().map(|t| t.map(|v| last[v as usize])).collect();
        self.track_triangles = true;
    }

    /// The surviving mesh: live vertices in input order, live faces in input order.
    pub(crate) fn output_mesh(&self) -> Mesh {
        let mut new_index = vec![NONE; self.vertices.len()];
        let mut positions = Vec::new();
        for (v, slot) in new_index.iter_mut().enumerate() {
            if self.vertex_alive[v] && !self.fans[v].is_empty() {
                *slot = positions.len() as u32;
                positions.push(self.vertices[v].position);
            }
        }
        let triangles: Vec<[u32; 3]> = (0..self.triangles.len())
            .filter(|&f| self.face_alive[f])
            .map(|f| self.triangles[f].map(|v| new_index[v as usize]))
            .collect();
        let mesh = Mesh { positions, triangles, corners: Default::default() };
        debug_assert!(mesh.check().is_ok());
        mesh
    }
}

/// Checks options against the mesh and returns the face target.
fn target_faces(options: &SimplifyOptions, faces: usize) -> Result<usize, MeshError> {
    if let Some(r) = options.target_ratio
        && !(0.0..1.0).contains(&r)
    {
        return Err(MeshError::InvalidParameter {
            name: "ratio",
            reason: format!("{r} is outside [0, 1): it is the fraction of faces removed"),
        });
    }
    if let Metric::Qfvp { w } = options.metric
        && !(0.0..=2.0).contains(&w)
    {
        return Err(MeshError::InvalidParameter { name: "w", reason: format!("{w} is outside [0, 2]") });
    }
    if let Some(e) = options.max_error
        && (e.is_nan() || e < 0.0)
    {
        return Err(MeshError::InvalidParameter { name: "max_error", reason: format!("{e} must be ≥ 0") });
    }
    let guard = options.guard;
    if !(guard.is_finite() && guard >= 0.0) {
        return Err(MeshError::InvalidParameter {
            name: "guard",
            reason: format!("{guard} must be a finite number ≥ 0"),
        });
    }
    if guard > 0.0 && options.metric == Metric::Melax {
        return Err(MeshError::InvalidParameter {
            name: "guard",
            reason: "the distance guard adds to the quadric costs (QFVP, QEM), not to Melax's".into(),
        });
    }
    let angle = options.max_normal_change_degrees;
    if !(angle > 0.0 && angle <= 180.0) {
        return Err(MeshError::InvalidParameter {
            name: "max_normal_change_degrees",
            reason: format!("{angle} is outside (0, 180]"),
        });
    }
    let by_ratio = options.target_ratio.map(|r| ((faces as f64) * (1.0 - r)).round() as usize);
    Ok(match (options.target_faces, by_ratio) {
        (Some(n), Some(m)) => n.max(m),
        (Some(n), None) => n,
        (None, Some(m)) => m,
        (None, None) => 0,
    })
}

/// [`prepare`], borrowing the mesh itself when there is nothing to drop (the usual input); the
/// input index of each vertex is then the identity.
fn prepare_in_place(mesh: &Mesh) -> (Cow<'_, Mesh>, Vec<u32>, usize) {
    let repeats_a_vertex = |t: &[u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    let mut new_index = vec![NONE; mesh.vertex_count()];
    let mut dropped = 0;
    for t in &mesh.triangles {
        if repeats_a_vertex(t) {
            dropped += 1;
            continue;
        }
        for &v in t {
            new_index[v as usize] = 0;
        }
    }
    let mut input_vertex = Vec::with_capacity(mesh.vertex_count());
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot != NONE {
            *slot = input_vertex.len() as u32;
            input_vertex.push(v as u32);
        }
    }
    if dropped == 0 && input_vertex.len() == mesh.vertex_count() {
        return (Cow::Borrowed(mesh), input_vertex, 0);
    }
    let positions = input_vertex.iter().map(|&v| mesh.positions[v as usize]).collect();
    let triangles =
        mesh.triangles.iter().filter(|t| !repeats_a_vertex(t)).map(|t| t.map(|v| new_index[v as usize])).collect();
    (Cow::Owned(Mesh { positions, triangles, corners: Default::default() }), input_vertex, dropped)
}

/// Drops faces that repeat a vertex and vertices that no face uses. Returns the prepared mesh
/// (without per-corner attributes), the input index of each kept vertex, and the number of
/// dropped faces.
pub fn prepare(mesh: &Mesh) -> (Mesh, Vec<u32>, usize) {
    let (prepared, input_vertex, dropped) = prepare_in_place(mesh);
    let prepared = match prepared {
        Cow::Borrowed(m) => {
            Mesh { positions: m.positions.clone(), triangles: m.triangles.clone(), corners: Default::default() }
        }
        Cow::Owned(m) => m,
    };
    (prepared, input_vertex, dropped)
}

/// What one pass over the fans finds.
struct Scan {
    kind: Vec<VertexKind>,
    /// Every undirected edge once, `[low, high]`, sorted.
    edges: Vec<[u32; 2]>,
    /// Edges with one face: `(low, high, face)`, sorted.
    boundary_edges: Vec<(u32, u32, u32)>,
}

/// Classifies every vertex from its fan: an edge with one face makes its ends boundary vertices;
/// an edge with more than two faces, or two faces that disagree on orientation, and a vertex whose
/// faces form more than one fan (two surface sheets touching at a point) make it frozen. Each
/// vertex looks only at its own fan (both ends of an edge see the same faces, so they agree).
/// Fans of the usual size are scanned by counting ([`scan_small_fan`]); a hub vertex by sorting
/// ([`scan_large_fan`]), so that the time stays O(valence · log valence).
fn scan_fans(fans: &[FanSlot]) -> Scan {
    let mut scan = Scan { kind: Vec::with_capacity(fans.len()), edges: Vec::new(), boundary_edges: Vec::new() };
    let mut scratch = LargeFanScratch::default();
    for (v, fan) in fans.iter().enumerate() {
        let v = v as u32;
        let closed = fan.inline_slots().and_then(|slots| scan_closed_fan(v, slots, fan.len(), &mut scan));
        let kind = match (closed, fan.len()) {
            (Some(kind), _) => kind,
            (None, 0..=SMALL_FAN) => scan_small_fan(v, fan, &mut scan),
            (None, _) => scan_large_fan(v, fan, &mut scan, &mut scratch),
        };
        scan.kind.push(kind);
    }
    scan
}

/// [`scan_fans`] for the usual vertex: an inline fan (the slots past `n` padded with
/// [`Corner::NONE`]) whose faces close around it, each `next` neighbour being exactly one face's
/// `prev`. Then the only question is whether the faces form one cycle or several (two cones
/// touching at the vertex), and the neighbours are the `next` corners. `None` when the fan is not
/// closed in this way (a boundary, a non-manifold edge): [`scan_small_fan`] sorts those out.
///
/// Every slot is compared with every other (fixed bounds, no branch on the data): on
/// stanford-bunny this takes about a quarter of the instructions of the general count.
fn scan_closed_fan(v: u32, slots: &[Corner; FAN_INLINE], n: usize, scan: &mut Scan) -> Option<VertexKind> {
    const N: usize = FAN_INLINE;
    if n < 2 {
        return None;
    }
    let live = (1u32 << n) - 1;
    let next = slots.map(|c| c.next);
    let prev = slots.map(|c| c.prev);
    // after[i]: the face whose `prev` is face i's `next` (the face that follows i around v).
    let mut after = [0u8; N];
    let mut closed = true;
    let mut followed = 0u32;
    for i in 0..N {
        let mut followers = 0u32;
        for (j, &p) in prev.iter().enumerate() {
            followers |= ((p == next[i]) as u32) << j;
        }
        followers &= live;
        let exactly_one = (followers != 0) & (followers & followers.wrapping_sub(1) == 0);
        closed &= (i >= n) | (exactly_one & (next[i] != v) & (prev[i] != v));
        followed |= followers;
        after[i] = followers.trailing_zeros().min(N as u32 - 1) as u8;
    }
    // Each `next` has exactly one follower and every face follows one: the follower map is a
    // permutation, so the `next` corners are distinct and are exactly the `prev` corners.
    if !closed || followed != live {
        return None;
    }
    // Every edge has two faces, one each way, and the neighbours are the `next` corners: those
    // above v, sorted by a network over all slots (the rest set to NONE), are its edges.
    let mut upper = next.map(|x| if x > v { x } else { NONE });
    for (i, slot) in upper.iter_mut().enumerate() {
        if i >= n {
            *slot = NONE;
        }
    }
    sort8(&mut upper);
    let count = upper.iter().filter(|&&x| x != NONE).count();
    scan.edges.extend(upper[..count].iter().map(|&u| [v, u]));
    // One cycle through all n faces, or several: then the vertex joins separate fans.
    let (mut current, mut steps) = (0usize, 0usize);
    loop {
        current = after[current] as usize;
        steps += 1;
        if current == 0 || steps == n {
            break;
        }
    }
    if current != 0 || steps != n {
        return Some(VertexKind::Frozen);
    }
    Some(VertexKind::Interior)
}

/// Sorts eight values with a fixed network of 19 compare-exchanges (no branch on the data), each
/// written out on locals so that they stay in registers.
fn sort8(values: &mut [u32; 8]) {
    let [mut v0, mut v1, mut v2, mut v3, mut v4, mut v5, mut v6, mut v7] = *values;
    macro_rules! exchange {
        ($x:ident, $y:ident) => {
            let (lo, hi) = ($x.min($y), $x.max($y));
            $x = lo;
            $y = hi;
        };
    }
    exchange!(v0, v2);
    exchange!(v1, v3);
    exchange!(v4, v6);
    exchange!(v5, v7);
    exchange!(v0, v4);
    exchange!(v1, v5);
    exchange!(v2, v6);
    exchange!(v3, v7);
    exchange!(v0, v1);
    exchange!(v2, v3);
    exchange!(v4, v5);
    exchange!(v6, v7);
    exchange!(v2, v4);
    exchange!(v3, v5);
    exchange!(v1, v4);
    exchange!(v3, v6);
    exchange!(v1, v2);
    exchange!(v3, v4);
    exchange!(v5, v6);
    *values = [v0, v1, v2, v3, v4, v5, v6, v7];
}

/// [`scan_fans`] for one fan of at most [`SMALL_FAN`] faces. Every corner's two edges are counted
/// against all corners at once, without a branch on the data: the edge (v, u) is manifold when
/// exactly one face runs v → u and at most one u → v; it is a boundary edge when it has one face.
/// Sorting the corner ends instead, as [`scan_large_fan`] does, mispredicts about a branch per
/// comparison: on stanford-bunny the whole scan takes 2.6 ms this way and took 5.0 ms by sorting.
/// Out of line, so that there is one copy of the vectorised count loop.
#[inline(never)]
fn scan_small_fan(v: u32, fan: &[Corner], scan: &mut Scan) -> VertexKind {
    const N: usize = SMALL_FAN;
    let n = fan.len();
    debug_assert!(n <= N);
    // Padding never matches: NONE is no vertex.
    let (mut next, mut prev) = ([NONE; N], [NONE; N]);
    for (i, c) in fan.iter().enumerate() {
        next[i] = c.next;
        prev[i] = c.prev;
    }
    let mut frozen = false;
    let mut on_boundary = false;
    // The first face whose `prev` edge no other face shares: where an open fan starts.
    let mut open_start = NONE as usize;
    // Neighbours above v (each edge is listed by its lower end), and the boundary edges among them.
    // Written unconditionally, kept by advancing the count: no branch on the data.
    let mut upper = [NONE; 2 * N];
    let mut upper_count = 0;
    let mut boundary = [(NONE, NONE); 2 * N];
    let mut boundary_count = 0;
    // Per face i, counted over all faces k at once (lane i of each array, so the loop runs on
    // vectors): faces running v → x and x → v, where x is i's `next`; v → y and y → v, where y is
    // its `prev`; and the face after i around v (whose `prev` is x), meaningful when there is one.
    let (mut out_x, mut in_x, mut out_y, mut in_y, mut after) = ([0u32; N], [0u32; N], [0u32; N], [0u32; N], [0u32; N]);
    // Only the groups of four lanes that hold faces (two for the usual valence).
    let groups = n.div_ceil(4).min(N / 4);
    for k in 0..n {
        let (x, y) = (next[k], prev[k]);
        for group in 0..groups {
            for i in 4 * group..4 * group + 4 {
                let follows = ((next[i] == y) as u32).wrapping_neg();
                out_x[i] += (next[i] == x) as u32;
                in_x[i] += follows & 1;
                after[i] |= follows & k as u32;
                out_y[i] += (prev[i] == x) as u32;
                in_y[i] += (prev[i] == y) as u32;
            }
        }
    }
    for i in 0..n {
        let (x, y, face) = (next[i], prev[i], fan[i].face);
        let (out_x, in_x, out_y, in_y) = (out_x[i], in_x[i], out_y[i], in_y[i]);
        frozen |= (x == v) | (y == v) | (out_x > 1) | (in_x > 1) | (out_y > 1) | (in_y > 1);
        open_start = if out_y == 0 && open_start == NONE as usize { i } else { open_start };
        // Edge (v, x) has this face alone when no other face names x; likewise (v, y).
        let x_alone = (out_x == 1) & (in_x == 0) & (x != v);
        let y_alone = (in_y == 1) & (out_y == 0) & (y != v);
        on_boundary |= x_alone | y_alone;
        upper[upper_count] = x;
        upper_count += (x > v) as usize;
        boundary[boundary_count] = (x, face);
        boundary_count += ((x > v) & x_alone) as usize;
        // y is listed here only when no face runs v → y (then it was listed as some face's x).
        upper[upper_count] = y;
        upper_count += ((y > v) & (out_y == 0)) as usize;
        boundary[boundary_count] = (y, face);
        boundary_count += ((y > v) & y_alone) as usize;
    }
    // A handful of values: insertion sort. Repeats only where a face pair repeats (frozen).
    let upper = &mut upper[..upper_count];
    insertion_sort(upper);
    let mut last = NONE;
    for &u in upper.iter() {
        if u != last {
            scan.edges.push([v, u]);
            last = u;
        }
    }
    let boundary = &mut boundary[..boundary_count];
    insertion_sort(boundary);
    scan.boundary_edges.extend(boundary.iter().map(|&(u, face)| (v, u, face)));
    if frozen {
        return VertexKind::Frozen;
    }
    // One fan: walking from face to face across shared edges, from the open end if there is one,
    // reaches every face.
    let start = if open_start == NONE as usize { 0 } else { open_start };
    let (mut current, mut reached) = (start, 1);
    while n > 1 && in_x[current] == 1 {
        let next_face = after[current] as usize;
        if next_face == start || reached == n {
            break;
        }
        current = next_face;
        reached += 1;
    }
    if reached < n {
        VertexKind::Frozen
    } else if on_boundary {
        VertexKind::Boundary
    } else {
        VertexKind::Interior
    }
}

/// Sorts a few values (a fan's neighbours above its vertex: about three).
fn insertion_sort<T: Copy + Ord>(values: &mut [T]) {
    for i in 1..values.len() {
        let x = values[i];
        let mut j = i;
        while j > 0 && values[j - 1] > x {
            values[j] = values[j - 1];
            j -= 1;
        }
        values[j] = x;
    }
}

/// Reused buffers of [`scan_large_fan`].
#[derive(Default)]
struct LargeFanScratch {
    ends: Vec<u64>,
    by_next: Vec<(u32, u32)>,
    by_prev: Vec<(u32, u32)>,
}

/// [`scan_fans`] for a fan of any size, by sorting its corner ends.
fn scan_large_fan(v: u32, fan: &[Corner], scan: &mut Scan, scratch: &mut LargeFanScratch) -> VertexKind {
    // Both edges of each corner, packed to sort as one integer: neighbour (high bits), whether the
    // face runs v → neighbour (bit 32), face (low 32 bits).
    const OUTGOING: u64 = 1 << 32;
    let ends = &mut scratch.ends;
    ends.clear();
    ends.extend(
        fan.iter().flat_map(|c| {
            [((c.next as u64) << 33) | OUTGOING | c.face as u64, ((c.prev as u64) << 33) | c.face as u64]
        }),
    );
    ends.sort_unstable();
    let mut frozen = false;
    let mut on_boundary = false;
    for group in ends.chunk_by(|x, y| x >> 33 == y >> 33) {
        let u = (group[0] >> 33) as u32;
        match group {
            _ if u == v => frozen = true,
            [end] => {
                on_boundary = true;
                if v < u {
                    scan.boundary_edges.push((v, u, *end as u32));
                }
            }
            [x, y] if (x ^ y) & OUTGOING != 0 => {}
            _ => frozen = true,
        }
        if v < u {
            scan.edges.push([v, u]);
        }
    }
    if frozen || !single_fan(fan, &mut scratch.by_next, &mut scratch.by_prev) {
        VertexKind::Frozen
    } else if on_boundary {
        VertexKind::Boundary
    } else {
        VertexKind::Interior
    }
}

/// Whether the faces around a vertex (all of whose edges are manifold) form one fan: walking from
/// face to face across shared edges, starting at a face with a free edge if there is one, reaches
/// every face. Through sorted indices, to stay O(n log n) on a hub vertex.
fn single_fan(fan: &[Corner], by_next: &mut Vec<(u32, u32)>, by_prev: &mut Vec<(u32, u32)>) -> bool {
    let n = fan.len();
    if n <= 1 {
        return true;
    }
    // The face after face i shares the edge (v, i.next) as its `prev` edge.
    by_next.clear();
    by_next.extend(fan.iter().enumerate().map(|(i, c)| (c.next, i as u32)));
    by_next.sort_unstable();
    by_prev.clear();
    by_prev.extend(fan.iter().enumerate().map(|(i, c)| (c.prev, i as u32)));
    by_prev.sort_unstable();
    let find = |index: &[(u32, u32)], key: u32| {
        let j = index.partition_point(|e| e.0 < key);
        (j < index.len() && index[j].0 == key).then(|| index[j].1 as usize)
    };
    // A face whose `prev` edge no other face shares starts an open fan.
    let start = (0..n).find(|&i| find(by_next, fan[i].prev).is_none()).unwrap_or(0);
    let mut current = start;
    let mut reached = 1;
    while let Some(next) = find(by_prev, fan[current].next) {
        if next == start || reached == n {
            break;
        }
        current = next;
        reached += 1;
    }
    reached == n
}

/// Simplifies `mesh` by edge collapses until a target is met; see the module documentation.
pub fn simplify(mesh: &Mesh, options: &SimplifyOptions) -> Result<Simplified, MeshError> {
    let started = Instant::now();
    mesh.check()?;
    let (prepared, input_vertex, dropped) = prepare_in_place(mesh);
    if prepared.triangles.is_empty() {
        return Err(MeshError::Empty { what: "no faces" });
    }
    let faces_in = prepared.face_count();
    let target = target_faces(options, faces_in)?;
    if options.guard > 0.0 && prepared.vertex_count() >= GUARDED as usize {
        return Err(MeshError::InvalidParameter {
            name: "guard",
            reason: format!("{} vertices: the distance guard handles fewer than 2³¹", prepared.vertex_count()),
        });
    }
    // Every vertex of the prepared mesh is on a face: its bounds are its surface's.
    let units = DistanceUnits::new(&prepared.bounds().expect("has faces"));
    // Melax's cost reads face normals through the triangle array; the quadric costs never do.
    let (mut state, edges) = State::with_tracking(&prepared, options, options.metric == Metric::Melax);
    let vertex_count = prepared.vertex_count();

    // Heapify once (linear) rather than pushing edge by edge.
    // The edges come sorted by their lower end, so the higher end's block is the one not in cache:
    // those of the next chunk are asked for while this one is ranked.
    const CHUNK: usize = 16;
    // Room for the queue's growth to its sweep bound (2 entries per face, below) from the start:
    // growing it later copies every entry into freshly faulted pages.
    let mut entries = Vec::with_capacity(edges.len().max(2 * faces_in + 16));
    for (i, chunk) in edges.chunks(CHUNK).enumerate() {
        let ahead = edges.get((i + 1) * CHUNK..((i + 2) * CHUNK).min(edges.len())).unwrap_or_default();
        ahead.iter().for_each(|e| state.vertices[e[1] as usize].prefetch());
        entries.extend(chunk.iter().filter_map(|&[a, b]| state.entry(a, b)));
    }
    let mut heap = TieredQueue::new(entries);
    drop(edges);

    let mut faces_alive = faces_in;
    // A collapse removes two faces (one on a boundary): sized for the usual case up front.
    let mut log: Vec<CollapseRecord> = Vec::with_capacity((faces_in - target.min(faces_in)) / 2 + 16);
    let mut neighbours = Vec::new();
    let mut rejected = 0;
    let mut pops = 0usize;
    let mut passes = 1;
    let mut collapses_this_pass = 0;
    let mut max_collapse_error: f64 = 0.0;
    let stop_reason = loop {
        if faces_alive <= target {
            break StopReason::TargetReached;
        }
        pops += 1;
        if pops.is_multiple_of(CANCEL_CHECK_INTERVAL)
            && let Some(flag) = &options.cancel
            && flag.load(AtomicOrdering::Relaxed)
        {
            return Err(MeshError::Cancelled);
        }
        let current = |e: &QueueEntry| state.is_current(e);
        let Some(entry) = heap.pop(current) else {
            // Dry before the target: refused candidates may have become legal since.
            if passes >= MAX_PASSES || collapses_this_pass == 0 {
                break StopReason::NoLegalCollapse;
            }
            passes += 1;
            collapses_this_pass = 0;
            for v in 0..vertex_count as u32 {
                if state.vertex_alive[v as usize] {
                    neighbours.clear();
                    state.push_edges_of(v, &mut heap, &mut neighbours);
                }
            }
            continue;
        };
        let (a, b) = (entry.a(), entry.b & !GUARDED);
        // The next top is most often the next candidate: its data is on the way while this one is
        // checked and collapsed.
        if let Some(next) = heap.peek() {
            state.prefetch_edge(next.a(), next.b & !GUARDED);
        }
        if !state.is_current(&entry) {
            continue; // stale: an endpoint changed (or was removed) since this entry was queued
        }
        if let Some(guard) = &state.guard
            && entry.b & GUARDED == 0
        {
            // Queued without the guard's term, which only adds: rank it with the term now, and
            // put it back unless it still comes first (the result is the greedy order of the
            // guarded costs, at one measurement per candidate that reaches the top).
            let Some(key) = state.guarded_key(guard, a, b) else { continue };
            let guarded = QueueEntry::new(key, a, b | GUARDED, entry.stamp);
            if heap.top(current).is_some_and(|top| top.rank() < guarded.rank()) {
                heap.push(guarded);
                continue;
            }
        }
        let Some(candidate) = state.evaluate(a, b) else { continue };
        let merged = state.vertices[a as usize].quadric + state.vertices[b as usize].quadric;
        let error_paper = units.to_paper(merged.distance(to_f64(candidate.position)));
        if let Some(limit) = options.max_error
            && error_paper > limit
        {
            break StopReason::MaxErrorReached;
        }
        if !state.is_legal(&candidate) {
            rejected += 1;
            continue;
        }
        let mut record = state.collapse(&candidate);
        max_collapse_error = max_collapse_error.max(error_paper);
        record.error = max_collapse_error as f32;
        faces_alive -= (record.left_face != NONE) as usize + (record.right_face != NONE) as usize;
        log.push(record);
        collapses_this_pass += 1;
        state.push_edges_of(candidate.survivor, &mut heap, &mut neighbours);
        // The queue's refills drop the stale entries they pass over; where its heap takes most
        // pushes (refills then come seldom: fandisk's planar regions) they pile up instead. A mesh
        // has about 1.5 edges per face, so once the queue holds more than 2 entries per face a
        // quarter or more are stale: one linear sweep drops them.
        if heap.len() > 2 * faces_alive {
            heap.sweep(|e| state.is_current(e));
        }
    };

    // The guard's tree and tables are done with: their memory goes back before the outputs'.
    state.guard = None;
    state.rebuild_triangles(&prepared, &log);
    let simplified = state.output_mesh();
    let progressive = options.record_progressive.then(|| {
        ProgressiveMesh::from_log(
            &prepared,
            &input_vertex,
            |v| state.vertices[v as usize].position,
            &state.triangles,
            &state.face_alive,
            &log,
        )
    });
    let frozen_vertices = state.vertices.iter().filter(|v| v.kind == VertexKind::Frozen).count();
    let stats = SimplifyStats {
        faces_in,
        faces_out: simplified.face_count(),
        vertices_in: vertex_count,
        vertices_out: simplified.vertex_count(),
        target_faces: target,
        collapses: log.len(),
        stop_reason,
        max_collapse_error,
        rejected,
        frozen_vertices,
        dropped_degenerate_faces: dropped,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok(Simplified { mesh: simplified, progressive, stats })
}

/// Outcome of [`simplify_search_w`].
#[derive(Debug, Clone)]
pub struct WSearch {
    /// The simplification with the lowest error; its `stats.seconds` is the wall time of the whole
    /// search.
    pub best: Simplified,
    /// Its w.
    pub w: f64,
    /// Every candidate: (w, symmetric Hausdorff distance to the input in paper units), in the
    /// order given.
    pub errors: Vec<(f64, f64)>,
    /// The measurement that chose `best` (input vs `best.mesh`, default options): callers that
    /// report it need not measure again.
    pub hausdorff: HausdorffReport,
}

/// Simplifies with QFVP once per candidate w (in parallel) and keeps the result closest to the
/// input by symmetric Hausdorff distance; ties go to the earlier candidate. The exact answer the
/// predictor only estimates, at the price of one simplification and one measurement per candidate.
/// `options.metric` must be QFVP or QEM (its w is replaced by each candidate in turn).
pub fn simplify_search_w(mesh: &Mesh, options: &SimplifyOptions, candidates: &[f64]) -> Result<WSearch, MeshError> {
    use rayon::prelude::*;
    if options.metric == Metric::Melax {
        return Err(MeshError::InvalidParameter {
            name: "metric",
            reason: "a w search needs the QFVP metric (Melax has no w)".into(),
        });
    }
    if candidates.is_empty() {
        return Err(MeshError::InvalidParameter { name: "w", reason: "no candidate w to search".into() });
    }
    let started = Instant::now();
    let runs: Vec<(f64, Simplified, HausdorffReport)> = candidates
        .par_iter()
        .map(|&w| {
            let run = simplify(mesh, &SimplifyOptions { metric: Metric::Qfvp { w }, ..options.clone() })?;
            let measured =
                hausdorff(mesh, &run.mesh, &HausdorffOptions { cancel: options.cancel.clone(), ..Default::default() })?;
            Ok((w, run, measured))
        })
        .collect::<Result<_, MeshError>>()?;
    let errors = runs.iter().map(|(w, _, d)| (*w, d.hausdorff)).collect();
    let (w, mut best, hausdorff) = runs
        .into_iter()
        .reduce(|best, next| if next.2.hausdorff < best.2.hausdorff { next } else { best })
        .expect("at least one candidate");
    best.stats.seconds = started.elapsed().as_secs_f64();
    Ok(WSearch { best, w, errors, hausdorff })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;
    use crate::topology::Topology;

    fn random_unit(rng: &mut crate::rng::SplitMix64) -> DVec3 {
        loop {
            let v = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - DVec3::ONE;
            if (0.01..=1.0).contains(&v.length_squared()) {
                return v.normalize();
            }
        }
    }

    #[test]
    fn normal_cone_rounds_down_and_refuses_nan() {
        let mut rng = crate::rng::SplitMix64::new(7);
        for c in [-1.0, -0.9, 0.0, 0.5, 1.0, 1.0 + 1e-12, -1.0 - 1e-12]
            .into_iter()
            .chain((0..1000).map(|_| rng.next_f64() * 2.0 - 1.0))
        {
            assert!(NormalCone::at_least(c).cos() <= c, "{c}");
            assert!(NormalCone::at_least(c).cos() > c - 1e-4, "{c}: too loose");
        }
        assert_eq!(NormalCone::at_least(f64::NAN), NormalCone::NEVER);
        // NEVER rules nothing out, not even a face with the axis' own normal.
        assert!(!NormalCone::NEVER.excludes_fold(DVec3::Z, DVec3::Z));
        assert!(NormalCone::EMPTY.excludes_fold(DVec3::Z, DVec3::Z));
    }

    /// Whenever a cone rules a fold out, no normal it was widened with folds onto the moved face;
    /// and it does rule out most of the harmless cases and none of the folds.
    #[test]
    fn normal_cone_rules_out_only_impossible_folds() {
        let mut rng = crate::rng::SplitMix64::new(11);
        let (mut ruled_out, mut folds) = (0, 0);
        for _ in 0..2000 {
            let axis = random_unit(&mut rng);
            // Faces within a random spread of the axis, as around a vertex.
            let spread = rng.next_f64() * 1.5;
            let faces: Vec<DVec3> =
                (0..6).map(|_| (axis + random_unit(&mut rng) * spread * rng.next_f64()).normalize()).collect();
            let mut cone = NormalCone::EMPTY;
            faces.iter().for_each(|&f| cone.widen(axis, f));
            for _ in 0..8 {
                let n = (axis + random_unit(&mut rng) * rng.next_f64() * 3.0).normalize();
                let folded = faces.iter().any(|f| f.dot(n) < FOLD_DOT);
                folds += folded as usize;
                if cone.excludes_fold(axis, n) {
                    assert!(!folded, "cone {cone:?} around {axis} ruled out a fold of {n}");
                    ruled_out += 1;
                }
            }
        }
        assert!(folds > 100, "the cases include folds ({folds})");
        assert!(ruled_out > 8000, "the cone rules out most harmless cases ({ruled_out} of 16000)");
    }

    /// The classification from the edge table (sorted half-edges) and the validator's fan count:
    /// an independent route to what [`scan_fans`] finds from the fans alone.
    type Classification = (Vec<VertexKind>, Vec<[u32; 2]>, Vec<(u32, u32)>);

    fn reference_kinds(mesh: &Mesh) -> Classification {
        let topology = Topology::new(mesh);
        let mut kind = vec![VertexKind::Interior; mesh.vertex_count()];
        let mut boundary = Vec::new();
        for (e, &[a, b]) in topology.edges.iter().enumerate() {
            let faces = topology.edge_faces.get(e);
            let k = match faces.len() {
                1 => {
                    boundary.push((a, b));
                    VertexKind::Boundary
                }
                2 => {
                    let forward = |f: usize| {
                        let t = mesh.triangles[f];
                        (0..3).any(|i| t[i] == a && t[(i + 1) % 3] == b)
                    };
                    if forward(faces[0].index()) == forward(faces[1].index()) {
                        VertexKind::Frozen
                    } else {
                        continue;
                    }
                }
                _ => VertexKind::Frozen,
            };
            for v in [a, b] {
                if kind[v as usize] != VertexKind::Frozen {
                    kind[v as usize] = k;
                }
            }
        }
        for (v, k) in kind.iter_mut().enumerate() {
            if *k != VertexKind::Frozen && crate::validate::fan_count(mesh, &topology, v as u32) > 1 {
                *k = VertexKind::Frozen;
            }
        }
        (kind, topology.edges.clone(), boundary)
    }

    fn assert_scan_matches(name: &str, mesh: &Mesh) {
        let (mesh, _, _) = prepare(mesh);
        let options = SimplifyOptions::default();
        let (state, edges) = State::new(&mesh, &options);
        let (kind, reference_edges, reference_boundary) = reference_kinds(&mesh);
        let classes: Vec<VertexKind> = state.vertices.iter().map(|v| v.kind).collect();
        assert_eq!(classes, kind, "{name}: vertex classes");
        assert_eq!(edges, reference_edges, "{name}: edge list");
        let Scan { boundary_edges, .. } = scan_fans(&state.fans);
        let boundary: Vec<(u32, u32)> = boundary_edges.iter().map(|&(a, b, _)| (a, b)).collect();
        assert_eq!(boundary, reference_boundary, "{name}: boundary edges");
    }

    /// The counting scan of small fans and the sorting scan agree on every vertex: class, edges and
    /// boundary edges with their faces, in order.
    fn assert_small_scan_matches_large(name: &str, mesh: &Mesh) {
        let (mesh, _, _) = prepare(mesh);
        let options = SimplifyOptions::default();
        let (state, _) = State::new(&mesh, &options);
        let mut scratch = LargeFanScratch::default();
        let empty = || Scan { kind: Vec::new(), edges: Vec::new(), boundary_edges: Vec::new() };
        for (v, fan) in state.fans.iter().enumerate().filter(|(_, fan)| fan.len() <= SMALL_FAN) {
            let (mut small, mut large) = (empty(), empty());
            let small_kind = scan_small_fan(v as u32, fan, &mut small);
            let large_kind = scan_large_fan(v as u32, fan, &mut large, &mut scratch);
            assert_eq!(small_kind, large_kind, "{name}: class of vertex {v}");
            assert_eq!(small.edges, large.edges, "{name}: edges of vertex {v}");
            assert_eq!(small.boundary_edges, large.boundary_edges, "{name}: boundary edges of vertex {v}");
            // The closed-fan scan, where it answers, answers as the counting scan does.
            if let Some(slots) = fan.inline_slots() {
                let mut closed = empty();
                if let Some(closed_kind) = scan_closed_fan(v as u32, slots, fan.len(), &mut closed) {
                    assert_eq!(closed_kind, small_kind, "{name}: closed-fan class of vertex {v}");
                    assert_eq!(closed.edges, small.edges, "{name}: closed-fan edges of vertex {v}");
                    assert!(small.boundary_edges.is_empty(), "{name}: vertex {v} has boundary edges");
                } else {
                    assert!(
                        small_kind != VertexKind::Interior || fan.len() < 2,
                        "{name}: interior vertex {v} left to the counting scan"
                    );
                }
            }
        }
    }

    #[test]
    fn fan_scan_agrees_with_the_edge_table() {
        // Closed, open, and the three kinds of trouble: two sheets touching at a vertex, an edge
        // with three faces, a face turned the wrong way.
        let square = |positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>| Mesh {
            positions,
            triangles,
            corners: Default::default(),
        };
        let p = |x: f32, y: f32, z: f32| [x, y, z];
        let bowtie = square(
            vec![
                p(0., 0., 0.),
                p(1., 0., 0.),
                p(0., 1., 0.),
                p(-1., 0., 0.),
                p(0., -1., 0.),
                p(1., 1., 0.),
                p(-1., -1., 0.),
            ],
            vec![[0, 1, 5], [0, 5, 2], [0, 3, 6], [0, 6, 4]],
        );
        let fin = square(
            vec![p(0., 0., 0.), p(1., 0., 0.), p(0., 1., 0.), p(0., -1., 0.), p(0., 0., 1.)],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        let flipped =
            square(vec![p(0., 0., 0.), p(1., 0., 0.), p(0., 1., 0.), p(1., 1., 0.)], vec![[0, 1, 2], [1, 2, 3]]);
        // A hub: one vertex with more faces than the counting scan takes (the sorting scan's case),
        // closed into a cone by a second hub.
        let ring = 3 * SMALL_FAN as u32;
        let mut hub_positions = vec![p(0., 0., 1.), p(0., 0., -1.)];
        hub_positions.extend((0..ring).map(|i| {
            let t = i as f32 / ring as f32 * std::f32::consts::TAU;
            p(t.cos(), t.sin(), 0.)
        }));
        let hub_faces: Vec<[u32; 3]> = (0..ring).map(|i| [0, 2 + i, 2 + (i + 1) % ring]).collect();
        let mut cone_faces = hub_faces.clone();
        cone_faces.extend((0..ring).map(|i| [1, 2 + (i + 1) % ring, 2 + i]));
        // Two closed cones sharing their apex: each fan at the apex closes, but into two cycles.
        let double_cone = square(
            vec![
                p(0., 0., 0.),
                p(1., 0., 1.),
                p(-1., 1., 1.),
                p(-1., -1., 1.),
                p(1., 0., -1.),
                p(-1., 1., -1.),
                p(-1., -1., -1.),
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [0, 5, 4], [0, 6, 5], [0, 4, 6], [1, 3, 2], [4, 5, 6]],
        );
        let hub_disc = square(hub_positions.clone(), hub_faces);
        let hub_cone = square(hub_positions, cone_faces);
        let mut cases: Vec<(String, Mesh)> = vec![
            ("icosphere".into(), procedural::icosphere(3)),
            ("torus".into(), procedural::torus(24, 12, 0.3)),
            ("terrain".into(), procedural::terrain(20, 3)),
            ("sharp box".into(), procedural::sharp_box(6)),
            ("bowtie".into(), bowtie),
            ("fin".into(), fin),
            ("flipped".into(), flipped),
            ("hub disc".into(), hub_disc),
            ("hub cone".into(), hub_cone),
            ("double cone".into(), double_cone),
        ];
        if let Some(dir) = crate::datasets::require_shared_meshes("fan_scan_agrees_with_the_edge_table") {
            for name in crate::datasets::SHARED_MESHES {
                let mesh = crate::io::read_mesh(dir.join(format!("{name}.obj"))).expect("shared mesh reads");
                cases.push((name.to_string(), mesh));
            }
        }
        for (name, mesh) in &cases {
            assert_scan_matches(name, mesh);
            assert_small_scan_matches_large(name, mesh);
        }
        let frozen = |mesh: &Mesh| {
            let options = SimplifyOptions::default();
            let (state, _) = State::new(mesh, &options);
            (0..mesh.vertex_count()).filter(|&v| state.vertices[v].kind == VertexKind::Frozen).collect::<Vec<_>>()
        };
        assert_eq!(frozen(&cases[4].1), vec![0], "bowtie centre");
        assert_eq!(frozen(&cases[5].1), vec![0, 1], "fin edge");
        assert_eq!(frozen(&cases[6].1), vec![1, 2], "edge between faces of opposite orientation");
        assert_eq!(frozen(&cases[9].1), vec![0], "apex of two closed cones");
        let options = SimplifyOptions::default();
        let (state, _) = State::new(&cases[9].1, &options);
        let mut scan = Scan { kind: Vec::new(), edges: Vec::new(), boundary_edges: Vec::new() };
        let apex = &state.fans[0];
        assert_eq!(
            scan_closed_fan(0, apex.inline_slots().expect("six faces are inline"), apex.len(), &mut scan),
            Some(VertexKind::Frozen),
            "the closed-fan scan sees the two cycles"
        );
    }
}
