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
//! Data flows in this order, one room each, and [`simplify`] below reads the same way:
//! 1. `options` — the options checked ([`SimplifyOptions::validate`]) and the face target;
//! 2. `classify` — preparation (faces that repeat a vertex dropped) and one scan of the fans that
//!    classifies every vertex; `sheets` — faces stacked on another (a copy, or the back of a
//!    double-sided sheet modelled with two faces) freeze their vertices: where the scan found
//!    frozen vertices, such faces are set aside (a copy dropped, a back written again reversed beside
//!    its front's output face) and the state made again without them;
//! 3. `kernel` — the working state: fans, quadrics, Gouraud normals, alive flags, version stamps;
//! 4. `cost` and `placement` — the cost of an edge and where its merged vertex goes;
//!    `queue` — the key an edge is queued under (stale entries skipped by per-vertex version
//!    stamps, as in the paper); `fan_term` — the fan-distance term (on by default); `guard` —
//!    the distance guard's term, when it is on (in place of the fan-distance term);
//! 5. `run` — the loop: pop, check (`legality`, rules below), collapse (`kernel`), re-rank;
//!    when the queue runs dry before the target, a new pass queues again the refused edges that
//!    a collapse came within two edges of since (`retry`);
//! 6. the output mesh and, if asked, the progressive mesh built from the log (`crate::pm`);
//!    `search` runs the whole pipeline once per candidate w.
//!
//! The loop (5) runs on the calling thread. On a large mesh the passes of 2–4 and 6 that need
//! nothing of each other run side by side where the rayon pool has more than one thread
//! (`crate::parallel`); each gives what one pass gives, so the output never depends on the threads.
//!
//! ## Ordering and ties
//! For QFVP with w > 0 the cost is exactly zero where both endpoint normals agree (flat regions):
//! those collapses all cost nothing. The queue puts every zero-cost candidate first, ordered among
//! themselves by quadric error, so flat regions are simplified in the order plain QEM would use;
//! positive costs follow in cost order (`crate::queue::order_key`, costs kept as `f32`). Where the
//! quadric error itself vanishes (an exactly planar neighbourhood: zero, or too small for an `f32`)
//! the shorter edge goes first, which keeps the triangles of planar regions well shaped and refuses
//! far fewer candidates there than leaving them tied did (docs/history/benchmarks-log.md).
//! Remaining ties go to the lower first vertex id, then to the queue's layout, which the sequence
//! of pushes, pops, refills and sweeps fixes (not push order: a heap is not stable): a run is
//! deterministic, which the progressive mesh's `at_faces` relies on, but a change to the queue
//! moves ties among equal keys.
//!
//! ## The fan-distance term (default, [`SimplifyOptions::distance_term`])
//! Quadric error sums squared distances to planes over the whole area behind a vertex, so a
//! collapse that moves a few faces far (a thin tip shortened along its own faces, a ridge cut
//! across) can cost less than one that moves many faces a little, and a small part of the surface
//! (a thin wall, the tunnel of a small hole) is cheap to move for being small. With the term, a
//! candidate is ranked by `(vᵀQv / A + distance_term · d²)` (then the QFVP normal factor): its
//! quadric error per unit of A, the area behind the merged quadric (a mean squared distance to its
//! planes), plus d², d the farthest the collapse moves the surface as its moved faces alone show it
//! (`fan_term`): from each moved face's new centroid to the plane it had, and from each endpoint to
//! the planes of its moved faces; for a collapse of two border vertices, also how far each endpoint
//! is from the border's new line. It reads only what the legality checks read next, and is queued
//! lazily like the guard below. It is measured once the share [`FAN_TERM_FROM`] of the input's
//! faces is gone: before that, collapses move the surface so little that the term
//! bought little accuracy for its time (they are ranked per unit of area all the same); with it the
//! default beats both meshoptimizer and MeshLab's quadric collapse on most cells of
//! docs/meshlab-comparison.md, at the price in time given in docs/benchmarks.md. 0 gives the
//! paper's cost unchanged (`vᵀQv`, not over the area). Meshes with texture coordinates go without
//! it (their placement keeps endpoints): on two of the eight textured assets the term raised the
//! position error, at 2–5× meshoptimizer's time (docs/attributes-report.md).
//!
//! ## The distance guard (optional, [`SimplifyOptions::guard`])
//! Quadric error has a blind spot: shortening a thin tip (a cow's horn, a finger) moves its apex
//! along planes nearly parallel to the move, so the collapse looks cheap while the Hausdorff
//! distance jumps. With the guard a candidate is ranked by `(vᵀQv / A + guard · d²)` (then the
//! QFVP normal factor as usual), per unit of area as with the fan-distance term, with d a measured
//! distance, both ways: from the input vertices merged into the endpoints (up to
//! `guard::WITNESSES` each, the farthest) to the fan the collapse would create, and from the new
//! position and the new faces' centroids to the input surface (`guard::DistanceGuard`). The term only
//! adds, so entries are queued without it and measured when they reach the top: one that is no
//! longer the cheapest goes back with its measured key (a lazy queue: the greedy order of the
//! guarded costs, measuring ~3 candidates per collapse instead of ~12). Its price in time is in
//! docs/benchmarks.md and its effect on the error in docs/simplify-report.md (Table 1b).
//!
//! ## Legality of a collapse (a, b) → a at position p
//! Rules 1 and 2 are applied when an edge is ranked (an edge they forbid is never queued); rules
//! 3–7 when a candidate reaches the top of the queue (`legality`), each refusal counted under the
//! first rule that refuses it ([`SimplifyStats::refused`]): 7 (on meshes with attributes: the
//! cheaper check, and the one that refuses most there), then 3 to 6 in their order.
//! ```text
//!        vl                  vl
//!       /  \                 |
//!      /    \                |
//!     a------b     ==>       a (at p)
//!      \    /                |
//!       \  /                 |
//!        vr                  vr
//! ```
//! 1. a frozen endpoint (non-manifold or inconsistently oriented neighbourhood) and an anchored
//!    one (where three or more sets of attribute values meet, a locked seam's or a locked border's
//!    vertex) stays where it is and only takes in the other end, and two such endpoints never
//!    collapse into each other; a frozen survivor also needs its edges to the collapse's opposite
//!    vertices to have one face besides the collapsing one, crossing them the other way, so that
//!    the faces it takes in join one sheet and the vertex split that undoes the collapse finds
//!    them unambiguously (checked with rule 3). Frozen vertices that took nothing in had left the
//!    rest of a non-manifold CAD mesh to make up the face count with far costlier collapses;
//! 2. boundaries: an interior edge with both ends on the boundary is refused (it would pinch the
//!    surface); a boundary vertex is never removed in favour of an interior one and does not move
//!    off its boundary (into an anchor, only along the boundary); with [`BoundaryMode::Lock`]
//!    boundary vertices are anchors: they never move or disappear;
//! 3. link condition: the common neighbours of a and b are exactly vl and vr (Dey et al.), and the
//!    merged vertex keeps at least one face (three for an interior vertex), so the surface stays a
//!    2-manifold and no component collapses to nothing. One exception closes a triangular hole (a
//!    boundary loop of three edges a, b, c, which boundary-preserving collapses leave of every
//!    small loop): collapsing its edge (a, b) makes the third corner c a common neighbour too, and
//!    is legal where a, b and c are plain boundary vertices, the faces on (a, c) and (b, c) meet
//!    as a manifold edge once b is renamed a (they run the hole's way round, have different third
//!    corners, agree on attribute values at a and c), and c keeps three faces. The hole is gone
//!    (a and c are interior vertices from then on; [`SimplifyStats::holes_closed`] counts them)
//!    and the vertex split that undoes the collapse names c as its hole's corner
//!    (`crate::pm::Hole`). Without it a mesh with many small holes stops above its target (as
//!    meshoptimizer and MeshLab do); with [`BoundaryMode::Lock`] no hole closes;
//! 4. every face that survives around a or b keeps a normal within
//!    [`SimplifyOptions::max_normal_change_degrees`] of its old one (no flips);
//! 5. no surviving face becomes a needle or zero-area triangle ([`MIN_TRIANGLE_QUALITY`]);
//! 6. no fold: no moved face turns back onto the unmoved face across its far edge, and no two moved
//!    faces that share an edge turn back onto each other (normals' dot product below [`FOLD_DOT`]).
//!    The face across is looked at only when the normal cones of the far edge's two ends
//!    (`NormalCone`: how far the faces around a vertex stray from its normal) leave a fold
//!    possible (rarely: counts in docs/history/benchmarks-log.md); debug builds check every skipped one
//!    anyway;
//! 7. with per-corner attributes (texture coordinates, normals, colours), no values cross a seam:
//!    b's corners take a's values on the same side, so an edge into a seam vertex must run along
//!    the seam, and a vertex where three or more sets of values meet is anchored: it never goes,
//!    and a neighbour that goes into it takes its values on the side it comes from
//!    (`State::carry_attributes`, `State::seam_sides`); once collapses leave an anchor two sets
//!    that differ in normals only, or a seam vertex one set, the rule lets go of it
//!    (`State::relax`). Without attributes the rule costs nothing.

mod attribute_quadric;
mod candidate;
mod classify;
mod cost;
mod fan_term;
mod flat;
mod guard;
mod halves;
pub(crate) mod kernel;
mod legality;
mod options;
mod pipeline;
mod placement;
mod prune;
mod queue;
mod retry;
mod run;
mod scratch;
mod seams;
mod search;
mod sheets;
mod terms;
mod topology;
mod vertex;

pub use classify::prepare;
pub(crate) use classify::prepare_with_attributes;
pub use fan_term::FAN_TERM_FROM;
pub use halves::{HALVES_FROM_FACES, HALVES_TO_SHARE};
pub(crate) use kernel::State;
pub use legality::MIN_TRIANGLE_QUALITY;
pub use options::{
    AttributeWeights, BoundaryMode, DEFAULT_DISTANCE_TERM, Metric, NormalUpdate, Placement, Refusals, Simplified,
    SimplifyOptions, SimplifyStats, StopReason,
};
pub use pipeline::simplify;
pub use run::MAX_PASSES;
pub use search::{WSearch, simplify_search_w};
pub use vertex::FOLD_DOT;
pub(crate) use vertex::VertexKind;
