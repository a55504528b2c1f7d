//! What the run knows of each vertex, in one block per vertex ([`VertexData`]): its quadric,
//! normal, position, class ([`VertexKind`]) and normal cone ([`NormalCone`]); and the sentinel
//! [`NONE`] that stands for no vertex, face or slot.

use glam::DVec3;

use crate::prefetch::prefetch;
use crate::quadric::Quadric;

/// Two faces sharing an edge at the merged vertex may not end up with normals whose dot product is
/// below this (a fold of more than ~154°).
pub const FOLD_DOT: f64 = -0.9;

pub(crate) use crate::mesh::NONE;

/// A position as the run computes with it.
#[inline]
pub(super) fn to_f64(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[inline]
pub(super) fn to_f32(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Vertex classification, fixed at the start except for anchors released
/// (`State::relax`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum VertexKind {
    #[default]
    Interior,
    Boundary,
    /// Non-manifold or inconsistently oriented: never moves or disappears, and takes in a neighbour
    /// only where its edges to the collapse's opposite vertices are manifold and consistently
    /// oriented (rule 1 of the module doc).
    Frozen,
    /// Never moves or disappears, but a neighbour may collapse into it (along the boundary, for a
    /// boundary neighbour): where three or more sets of attribute values meet, a locked seam's
    /// vertices and a locked border's. Assigned by the kernel, not by the scan; released when
    /// collapses leave its faces fewer sets of values (`State::relax`).
    Anchored,
    /// Never moves, disappears or takes in a neighbour: a vertex of the band along the cut between
    /// two halves of a large mesh while they are simplified apart (`super::halves`).
    Locked,
}

/// What ranking an edge reads of each endpoint, in one 128-byte block (two adjacent cache lines)
/// rather than a line or two in each of four arrays. The cost is evaluated about twelve times per
/// collapse, mostly with a neighbour whose data is not in cache: one block halves the misses where
/// the vertex order is far from the surface order (measured in docs/history/benchmarks-log.md).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct VertexData {
    pub(super) quadric: Quadric,
    /// Unit vertex normal: Gouraud at the start, then the linear estimate (or the recomputed mean).
    pub(super) normal: DVec3,
    pub(super) position: [f32; 3],
    pub(super) kind: VertexKind,
    /// A lower bound on the cosine between `normal` and the unit normal of every live face around
    /// the vertex ([`NormalCone`]), in the block's last spare bytes.
    pub(super) cone: NormalCone,
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

/// Faces whose quality (`4√3·area / Σ edge²`) is below this at the start make their corners'
/// [`NormalCone`]s unusable: the normal of such a face depends on which corner its cross product
/// starts from by more than the cone test's margin. Every face a collapse creates is far above it
/// ([`MIN_TRIANGLE_QUALITY`]).
pub(super) const CONE_MIN_QUALITY: f64 = 1e-4;

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
/// vertex of each face a collapse moves (`State::collapse`), and recomputed for the survivor,
/// whose normal changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct NormalCone(i16);

impl NormalCone {
    /// No face yet: every normal is within 0° (the first face widens it).
    pub(super) const EMPTY: NormalCone = NormalCone(i16::MAX);
    /// Never usable: below −FOLD_DOT's reach, so the test never passes.
    pub(super) const NEVER: NormalCone = NormalCone(i16::MIN);

    pub(super) fn at_least(cos: f64) -> NormalCone {
        // One step below the truncated value, so never above `cos` (a float-to-int cast
        // truncates toward zero and saturates; `floor` would be a library call). `max` maps NaN
        // to the lowest value, which no test passes.
        NormalCone((cos * 32767.0 - 1.0).max(NormalCone::NEVER.0 as f64) as i16)
    }

    pub(super) fn cos(self) -> f64 {
        self.0 as f64 / 32767.0
    }

    /// Widens the cone around `axis` to take in the unit normal `n`.
    pub(super) fn widen(&mut self, axis: DVec3, n: DVec3) {
        *self = NormalCone(self.0.min(NormalCone::at_least(axis.dot(n)).0));
    }

    /// Whether no face of this cone (around the unit `axis`) can be folded onto a face with unit
    /// normal `n`: the angle between `n` and the axis plus the cone's half-angle stays below the
    /// fold angle, with a margin.
    #[inline]
    pub(super) fn excludes_fold(self, axis: DVec3, n: DVec3) -> bool {
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

/// `4√3·area / Σ edge²`: 1 for equilateral, 0 for degenerate; `area2` is twice the area (the
/// length of the edge cross product, which the caller has at hand).
#[inline]
pub(super) fn triangle_quality(area2: f64, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if sum > 0.0 { 2.0 * 3f64.sqrt() * area2 / sum } else { 0.0 }
}
