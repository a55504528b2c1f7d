//! Certified bounds of the one-sided Hausdorff distance h(A → B) = max over p in A of d(p, B), by
//! branch and bound over A's triangles.
//!
//! - **Lower bound L**: the largest exact point-to-B distance at any point evaluated so far (A's
//!   vertices first, then face samples, piece centroids and edge midpoints).
//! - **Upper bound U of a piece** (a triangle of A, or part of one): for any one triangle t of B,
//!   d(·, t) is convex, so its maximum over the piece is reached at a corner; and d(p, B) ≤ d(p, t).
//!   Hence max over the piece of d(·, B) ≤ min over candidate t of max over corners d(corner, t).
//!   Candidates are the closest triangles of the piece's corners (found by the BVH), of its
//!   centroid where that is needed, and the best candidate of its parent (so a child's bound never
//!   exceeds its parent's).
//!
//! Pieces wait in a max-heap by U. The top piece is split 1 → 4 at its edge midpoints (each
//! midpoint evaluated exactly, raising L); a piece whose U is at most the threshold
//! max(L · (1 + tolerance), floor) is dropped, its U remembered. The search ends when the heap's
//! top is at or below the threshold; the reported upper bound is the largest U of any piece
//! dropped or left, so it is certified even when a work budget stops the search early (it is then
//! wider than the tolerance, and said so).
//!
//! Batches of pieces are split in parallel; batch composition depends only on the heap's order
//! (ties broken by a sequence number), so the result does not depend on the number of threads.
//!
//! The same approach, with other candidate rules: M. Tang, M. Lee, Y. J. Kim, "Interactive
//! Hausdorff distance computation for general polygonal models", SIGGRAPH 2009; Y. Zheng et al.,
//! "Economic upper bound estimation in Hausdorff distance computation for triangle meshes",
//! Computer Graphics Forum 2021.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;

use super::patch::{Scratch, patch_bound, query};
use super::sampling::CHUNK;
use crate::bvh::TriangleBvh;
use crate::mesh::Mesh;

/// Pieces split per parallel batch.
const BATCH: usize = 256;
/// A piece this many 1 → 4 splits below its face is not split further (its edges are then about
/// 2⁻⁴⁰ of the face's: beyond f64's resolution of any useful distance).
const MAX_DEPTH: u8 = 40;

/// Limits and tolerances of one directed search.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Search {
    /// Relative tolerance: done when U ≤ L · (1 + tolerance).
    pub tolerance: f64,
    /// Absolute distance below which the gap is not worth closing (below the inputs' resolution).
    pub floor: f64,
    /// Most pieces split before the search gives up on the tolerance (U stays certified).
    pub budget: usize,
}

/// Outcome of one directed search, in the meshes' own units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Bounds {
    /// Largest exact distance found on A by the search (the vertices' not included).
    pub own_lower: f64,
    /// Certified upper bound of the one-sided distance.
    pub upper: f64,
    /// Exact point-to-surface evaluations (vertices, centroids, midpoints).
    pub evaluations: usize,
    /// Pieces split.
    pub splits: usize,
    /// Whether U ≤ max(L · (1 + tolerance), floor).
    pub converged: bool,
}

/// A triangle of A or part of one, with the exact distance and closest B slot of each corner.
#[derive(Debug, Clone, Copy)]
struct Piece {
    corners: [DVec3; 3],
    distance: [f64; 3],
    slot: [u32; 3],
    /// The candidates that gave `upper` (the second is `u32::MAX` for a single one).
    best: [u32; 2],
    upper: f64,
    depth: u8,
    sequence: u64,
}

impl PartialEq for Piece {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Piece {}
impl PartialOrd for Piece {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Piece {
    /// Largest bound first; among equal bounds the earlier piece.
    fn cmp(&self, other: &Self) -> Ordering {
        self.upper.total_cmp(&other.upper).then_with(|| other.sequence.cmp(&self.sequence))
    }
}

/// Exact distance and closest slot of a point.
#[inline]
fn evaluate(bvh: &TriangleBvh, p: DVec3, hint: u32) -> (f64, u32) {
    let hit = bvh.closest_point(p, Some(hint));
    (hit.distance(), hit.slot)
}

/// Most candidate triangles a piece's bound weighs.
const CANDIDATES: usize = 6;

/// The piece's bound over candidate slots (its corners' closest triangles and `extra`): the
/// upper bound and the one or two candidates that give it.
///
/// For one candidate t, d(·, t) is convex, so max over the piece ≤ max over corners of d(c, t).
/// For two, min(d(·, t), d(·, u)) ≤ λ d(·, t) + (1 − λ) d(·, u) for every λ in [0, 1], and the right
/// side is convex too: the bound is min over λ of max over corners, a one-dimensional linear
/// programme. It is exact where the farthest point is equidistant from two planes (a piece
/// straddling the medial axis of a ridge), where any single triangle is off by the piece's size.
///
/// Stops at the first candidate whose bound is at most `enough` (a distance already reached:
/// a smaller bound would change nothing).
fn bound(bvh: &TriangleBvh, piece: &Piece, extra: &[u32], enough: f64) -> (f64, [u32; 2]) {
    let mut slots = [u32::MAX; CANDIDATES];
    let mut count = 0;
    for &s in piece.slot.iter().chain(extra) {
        if s != u32::MAX && count < CANDIDATES && !slots[..count].contains(&s) {
            slots[count] = s;
            count += 1;
        }
    }
    // Distance of each corner to each candidate, a column at a time; single candidates first.
    let mut d = [[0f64; 3]; CANDIDATES];
    let mut best = (f64::INFINITY, [u32::MAX; 2]);
    for (column, &slot) in d.iter_mut().zip(&slots[..count]) {
        for (i, cell) in column.iter_mut().enumerate() {
            *cell = if piece.slot[i] == slot {
                piece.distance[i]
            } else {
                bvh.slot_distance_squared(piece.corners[i], slot).sqrt()
            };
        }
        let worst = column[0].max(column[1]).max(column[2]);
        if worst < best.0 {
            best = (worst, [slot, u32::MAX]);
            if worst <= enough {
                return best;
            }
        }
    }
    for j in 0..count {
        for k in j + 1..count {
            let value = pair_bound(d[j], d[k]);
            if value < best.0 {
                best = (value, [slots[j], slots[k]]);
            }
        }
    }
    best
}

/// min over λ ∈ [0, 1] of max over i of λ a_i + (1 − λ) b_i.
fn pair_bound(a: [f64; 3], b: [f64; 3]) -> f64 {
    let at = |l: f64| (0..3).map(|i| b[i] + l * (a[i] - b[i])).fold(0f64, f64::max);
    let mut best = at(0.0).min(at(1.0));
    for i in 0..3 {
        for k in i + 1..3 {
            let slope = (a[i] - b[i]) - (a[k] - b[k]);
            if slope != 0.0 {
                let l = (b[k] - b[i]) / slope;
                if l > 0.0 && l < 1.0 {
                    best = best.min(at(l));
                }
            }
        }
    }
    best
}

/// Tries the patch bound on a piece still above `threshold`.
fn tighten(bvh: &TriangleBvh, piece: &mut Piece, threshold: f64, candidates: Option<&[u32]>, scratch: &mut Scratch) {
    if piece.upper > threshold
        && let Some(upper) = patch_bound(bvh, &piece.corners, piece.upper, candidates, scratch)
        && upper < piece.upper
    {
        piece.upper = upper;
    }
}

/// What a chunk of work found: the largest exact distance, pieces still above the threshold,
/// the largest bound dropped, and the evaluation count.
#[derive(Default)]
struct Found {
    lower: f64,
    open: Vec<Piece>,
    dropped: f64,
    evaluations: usize,
}

impl Found {
    fn merge(mut self, other: Found) -> Found {
        self.lower = self.lower.max(other.lower);
        self.open.extend(other.open);
        self.dropped = self.dropped.max(other.dropped);
        self.evaluations += other.evaluations;
        self
    }

    /// Keeps `piece` if its bound is above `threshold`, else remembers the bound.
    fn offer(&mut self, piece: Piece, threshold: f64) {
        if piece.upper > threshold {
            self.open.push(piece);
        } else {
            self.dropped = self.dropped.max(piece.upper);
        }
    }
}

/// Per vertex of A: exact distance to B and the closest B slot.
pub(crate) type VertexDistances = Vec<(f64, u32)>;

/// Exact distance to B and closest B slot of every vertex of A that a face uses (unused
/// vertices get (0, 0)), and the largest of those distances. `None` when cancelled.
pub(crate) fn vertex_distances(
    a: &Mesh,
    b: &TriangleBvh,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<(VertexDistances, f64, usize)> {
    let mut used = vec![false; a.vertex_count()];
    for t in &a.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let vertices: Vec<u32> = (0..a.vertex_count() as u32).filter(|&v| used[v as usize]).collect();
    let mut at_vertex = vec![(0f64, 0u32); a.vertex_count()];
    let measured: Vec<Vec<(u32, f64, u32)>> = vertices
        .par_chunks(CHUNK)
        .map(|chunk| {
            if cancelled() {
                return None;
            }
            let mut hint = 0;
            Some(
                chunk
                    .iter()
                    .map(|&v| {
                        let (d, slot) = evaluate(b, a.point(v), hint);
                        hint = slot;
                        (v, d, slot)
                    })
                    .collect(),
            )
        })
        .collect::<Option<_>>()?;
    let mut lower = 0f64;
    for &(v, d, slot) in measured.iter().flatten() {
        at_vertex[v as usize] = (d, slot);
        lower = lower.max(d);
    }
    Some((at_vertex, lower, vertices.len()))
}

/// Certified bounds of h(A → B), from the distances of A's vertices ([`vertex_distances`]).
/// `lower` is a distance already known to be reached, on A or (when only the symmetric distance
/// is wanted) on B: the search only proves that nothing of A is farther than the tolerance above
/// it. Returns `None` when `cancelled` reports true.
pub(crate) fn directed_bounds(
    a: &Mesh,
    b: &TriangleBvh,
    at_vertex: &[(f64, u32)],
    lower: f64,
    search: Search,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<Bounds> {
    let threshold = |lower: f64| (lower * (1.0 + search.tolerance)).max(search.floor);
    let mut lower = lower;
    let mut own = 0f64;
    let mut evaluations = 0;

    // 2. Every face: its bound from its corners' candidates, then its centroid's if that is not enough.
    let start = threshold(lower);
    let faces: Vec<usize> = (0..a.face_count()).collect();
    let found = faces
        .par_chunks(CHUNK)
        .map_init(Scratch::default, |scratch, chunk| {
            if cancelled() {
                return None;
            }
            let mut found = Found::default();
            for &f in chunk {
                face_piece(a, b, at_vertex, f, lower, start, scratch, &mut found);
            }
            Some(found)
        })
        .try_reduce(Found::default, |x, y| Some(x.merge(y)))?;
    own = own.max(found.lower);
    lower = lower.max(found.lower);
    evaluations += found.evaluations;
    let mut dropped = found.dropped;
    let mut heap: BinaryHeap<Piece> = found.open.into_iter().filter(|p| p.upper > threshold(lower)).collect();
    let mut sequence = a.face_count() as u64;

    // 3. Split the worst pieces until the top bound meets the lower bound.
    let mut splits = 0usize;
    let mut batch = Vec::with_capacity(BATCH);
    while heap.peek().is_some_and(|p| p.upper > threshold(lower)) && splits < search.budget {
        if cancelled() {
            return None;
        }
        batch.clear();
        while batch.len() < BATCH && heap.peek().is_some_and(|p| p.upper > threshold(lower)) {
            batch.push(heap.pop().expect("peeked"));
        }
        splits += batch.len();

        let limit = threshold(lower);
        let found = batch
            .par_iter()
            .map_init(Scratch::default, |scratch, piece| split(b, piece, lower, limit, scratch))
            .reduce(Found::default, Found::merge);
        own = own.max(found.lower);
        lower = lower.max(found.lower);
        evaluations += found.evaluations;
        dropped = dropped.max(found.dropped);
        let limit = threshold(lower);
        for mut child in found.open {
            child.sequence = sequence;
            sequence += 1;
            if child.upper > limit {
                heap.push(child);
            } else {
                dropped = dropped.max(child.upper);
            }
        }
    }
    let left = heap.peek().map_or(0.0, |p| p.upper);
    // Every piece of A was either dropped or is left: the largest of their bounds covers all of A.
    let upper = own.max(dropped).max(left);
    Some(Bounds { own_lower: own, upper, evaluations, splits, converged: upper <= threshold(lower) })
}

/// Step 2 for face `f` of A: its bound from its corners' candidates, then, where that is not within
/// `start`, from a patch of B around it and its centroid's distance (which may raise the lower
/// bound); offered to `found`.
#[allow(clippy::too_many_arguments)]
fn face_piece(
    a: &Mesh,
    b: &TriangleBvh,
    at_vertex: &[(f64, u32)],
    f: usize,
    lower: f64,
    start: f64,
    scratch: &mut Scratch,
    found: &mut Found,
) {
    let t = a.triangles[f];
    let mut piece = Piece {
        corners: a.triangle_points(f),
        distance: t.map(|v| at_vertex[v as usize].0),
        slot: t.map(|v| at_vertex[v as usize].1),
        best: [u32::MAX; 2],
        upper: 0.0,
        depth: 0,
        sequence: f as u64,
    };
    (piece.upper, piece.best) = bound(b, &piece, &[], lower);
    // First the cheap question: is the piece within the threshold? (A thin prism
    // holds few of B's triangles.)
    if piece.upper > start
        && let Some(upper) = patch_bound(b, &piece.corners, start, None, scratch)
    {
        piece.upper = upper;
    }
    // If not, its centroid (which may raise L) and its bound at its own limit.
    if piece.upper > start {
        let centroid = (piece.corners[0] + piece.corners[1] + piece.corners[2]) / 3.0;
        let (d, slot) = evaluate(b, centroid, piece.best[0]);
        found.evaluations += 1;
        found.lower = found.lower.max(d);
        let (upper, best) = bound(b, &piece, &[slot, piece.best[0], piece.best[1]], lower);
        if upper < piece.upper {
            (piece.upper, piece.best) = (upper, best);
        }
        tighten(b, &mut piece, start, None, scratch);
    }
    found.offer(piece, start);
}

/// Splits a piece 1 → 4 at its edge midpoints, each evaluated exactly.
fn split(b: &TriangleBvh, piece: &Piece, lower: f64, threshold: f64, scratch: &mut Scratch) -> Found {
    let mut found = Found::default();
    if piece.depth >= MAX_DEPTH {
        // Too small to split: its bound stands as it is.
        found.dropped = piece.upper;
        return found;
    }
    let [p0, p1, p2] = piece.corners;
    let mids = [(p0 + p1) * 0.5, (p1 + p2) * 0.5, (p2 + p0) * 0.5];
    let mut at_mid = [(0f64, 0u32); 3];
    for k in 0..3 {
        at_mid[k] = evaluate(b, mids[k], piece.slot[k]);
        found.lower = found.lower.max(at_mid[k].0);
    }
    found.evaluations = 3;
    let corner = |i: usize| (piece.corners[i], piece.distance[i], piece.slot[i]);
    let mid = |k: usize| (mids[k], at_mid[k].0, at_mid[k].1);
    // Children keep the parent's orientation: corner i with the midpoints on its two edges, and
    // the middle triangle.
    let children = [
        [corner(0), mid(0), mid(2)],
        [mid(0), corner(1), mid(1)],
        [mid(2), mid(1), corner(2)],
        [mid(0), mid(1), mid(2)],
    ];
    // One query of B for the parent serves its four children (same plane, smaller prisms).
    let mut shared = std::mem::take(&mut scratch.shared);
    let mut queried = None;
    for c in children {
        let mut child = Piece {
            corners: c.map(|x| x.0),
            distance: c.map(|x| x.1),
            slot: c.map(|x| x.2),
            best: piece.best,
            upper: 0.0,
            depth: piece.depth + 1,
            sequence: 0,
        };
        (child.upper, child.best) = bound(b, &child, &piece.best, lower);
        if child.upper > threshold {
            let ok = *queried.get_or_insert_with(|| query(b, &piece.corners, piece.upper, &mut shared));
            if ok {
                tighten(b, &mut child, threshold, Some(&shared), scratch);
            }
        }
        found.offer(child, threshold);
    }
    scratch.shared = shared;
    found
}
