//! The collapse loop: pop the cheapest current candidate, re-rank it with the guard's term when
//! the guard is on, check it, collapse it, re-rank the edges around the survivor. Each way out of
//! the loop is one [`StopReason`] (or cancellation), commented where it is taken.

use std::sync::atomic::Ordering as AtomicOrdering;

use crate::error::MeshError;
use crate::mesh::DistanceUnits;
use crate::pm::CollapseRecord;
use crate::queue::{QueueEntry, TieredQueue};

use super::candidate::Candidate;
use super::guard::GUARDED;
use super::kernel::State;
use super::options::{Refusals, StopReason};
use super::prune::Parts as Prune;
use super::retry::Retry;
use super::vertex::{NONE, to_f64};

/// Passes at most: when the queue runs dry before the target, a new pass queues again the edges
/// refused before a collapse came near them (`super::retry`), which may have become legal since.
pub const MAX_PASSES: usize = 4;

/// How often (in queue pops) the cancel flag is read.
const CANCEL_CHECK_INTERVAL: usize = 256;

/// What the loop did.
pub(super) struct Run {
    pub(super) log: Vec<CollapseRecord>,
    pub(super) stop_reason: StopReason,
    pub(super) refused: Refusals,
    /// Largest collapse error estimate, paper units.
    pub(super) max_collapse_error: f64,
    /// Parts taken out whole.
    pub(super) parts_removed: usize,
}

/// The queue of every edge of the fresh state, heapified once (linear) rather than pushed edge by
/// edge. Blocks of [`RANK_BLOCK`] edges may be ranked side by side ([`crate::parallel`]); the
/// entries come in the order of one pass, so the queue (and the run) is the same on any number of
/// threads.
pub(super) fn initial_queue(state: &State, edges: Vec<[u32; 2]>, faces_in: usize) -> TieredQueue {
    // Room for the queue's growth to its sweep bound (2 entries per face, in `run`) from the
    // start: growing it later copies every entry into freshly faulted pages.
    let mut entries = Vec::with_capacity(edges.len().max(2 * faces_in + 16));
    for block in crate::parallel::map_blocks(&edges, RANK_BLOCK, |_, block| rank_block(state, block)) {
        entries.extend(block);
    }
    TieredQueue::new(entries)
}

/// Edges ranked by one block of [`initial_queue`]: enough that handing it to another thread costs
/// nothing beside it, few enough that both threads get work on a small mesh.
const RANK_BLOCK: usize = 4096;

/// The entries of `edges` (sorted by their lower end), in their order.
fn rank_block(state: &State, edges: &[[u32; 2]]) -> Vec<QueueEntry> {
    // The higher end's block is the one not in cache: those of the next chunk are asked for while
    // this one is ranked.
    const CHUNK: usize = 16;
    let mut entries = Vec::with_capacity(edges.len());
    for (i, chunk) in edges.chunks(CHUNK).enumerate() {
        let ahead = edges.get((i + 1) * CHUNK..((i + 2) * CHUNK).min(edges.len())).unwrap_or_default();
        ahead.iter().for_each(|e| state.vertices[e[1] as usize].prefetch());
        // Two edges from the same lower end are ranked side by side ([`State::entry_pair`], the
        // same keys as one at a time), in their order.
        let mut rest = chunk;
        while let [[a, b], tail @ ..] = rest {
            match tail {
                [[a2, b2], after @ ..] if a2 == a => {
                    entries.extend(state.entry_pair(*a, [*b, *b2]).into_iter().flatten());
                    rest = after;
                }
                _ => {
                    entries.extend(state.entry(*a, *b));
                    rest = tail;
                }
            }
        }
    }
    entries
}

/// The most collapses a run from `faces_in` to `target` faces can log: each removes a vertex and
/// two faces, or one face and a vertex on a border (or frozen; `open_vertices` at the start, and
/// collapses make no new ones): at most half the faces to remove plus half the open vertices (one
/// more for the last collapse's overshoot), and never more than the vertices. The log is sized
/// so up front: one that outgrows its reserve is copied whole into one twice its size.
pub(super) fn log_reserve(faces_in: usize, target: usize, open_vertices: usize, vertex_count: usize) -> usize {
    ((faces_in - target.min(faces_in) + open_vertices) / 2 + 1).min(vertex_count)
}

/// Collapses until `target` faces remain (of `faces_in`), the next collapse would exceed the
/// options' `max_error`, or no legal collapse is left.
pub(super) fn run(
    state: &mut State,
    mut heap: TieredQueue,
    mut parts: Option<Prune>,
    units: &DistanceUnits,
    faces_in: usize,
    target: usize,
) -> Result<Run, MeshError> {
    let options = state.config.options;
    let vertex_count = state.vertices.len();
    // The faces left: `faces_alive` counts a face whose back was set aside twice, as the output
    // (and so the target) has both (`super::sheets`); `live` counts the state's faces once each.
    let mut faces_alive = faces_in;
    let mut live = state.topo.face_alive.len();
    let mut log: Vec<CollapseRecord> =
        Vec::with_capacity(log_reserve(faces_in, target, state.open_vertices, vertex_count));
    let (mut neighbours, mut refused, mut retry) = (Vec::new(), Refusals::default(), Retry::default());
    // Seams and anchors are looked at again after each collapse that takes faces from their
    // vertices (meshes with per-corner attributes only: without them there are none).
    let with_attributes = !state.seams.corner_source.is_empty();
    let (mut pops, mut passes, mut collapses_this_pass) = (0usize, 1, 0);
    let mut max_collapse_error: f64 = 0.0;
    let term_from = term_from(state, live);
    let stop_reason = loop {
        // Parts as small as the error reached so far go whole, while the target allows.
        if let Some(parts) = &mut parts {
            let removed = parts.prune(state, max_collapse_error, faces_alive, target);
            faces_alive -= removed;
            live -= removed;
        }
        // Stop: the face target is met.
        if faces_alive <= target {
            break StopReason::TargetReached;
        }
        pops += 1;
        // Stop: cancelled by the caller (checked every few hundred pops).
        if pops.is_multiple_of(CANCEL_CHECK_INTERVAL)
            && options.cancel.as_ref().is_some_and(|f| f.load(AtomicOrdering::Relaxed))
        {
            return Err(MeshError::Cancelled);
        }
        let current = |e: &QueueEntry| state.is_current(e);
        let Some(entry) = heap.pop(current) else {
            // Stop: the queue ran dry before the target, and either the passes are used up or the
            // last pass collapsed nothing (a new one would find the same refusals).
            if passes >= MAX_PASSES || collapses_this_pass == 0 {
                break StopReason::NoLegalCollapse;
            }
            // Otherwise refused candidates may have become legal since: queue again every edge
            // that a collapse came near after its last refusal (`retry`).
            passes += 1;
            collapses_this_pass = 0;
            queue_again(state, &mut retry, &log, &mut heap, &mut neighbours);
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
        let measure = state.has_distance_term() && entry.b & GUARDED == 0 && live <= term_from;
        let Some(candidate) = candidate_at_top(state, &mut heap, &entry, measure) else { continue };
        let merged = state.vertices[a as usize].quadric + state.vertices[b as usize].quadric;
        let error_paper = units.to_paper(merged.distance(to_f64(candidate.position)));
        // Stop: the cheapest collapse left would exceed the error limit (costs are not errors, so
        // this is the first popped candidate over it, not a proof that none is under it).
        if let Some(limit) = options.max_error
            && error_paper > limit
        {
            break StopReason::MaxErrorReached;
        }
        let legal = match state.is_legal(&candidate) {
            Ok(legal) => legal,
            Err(refusal) => {
                refused.count(refusal);
                retry.refused(a, b, log.len());
                continue;
            }
        };
        let mut record = state.collapse(legal);
        max_collapse_error = max_collapse_error.max(error_paper);
        record.error = max_collapse_error as f32;
        faces_alive -= state.output_faces(record.left_face) + state.output_faces(record.right_face);
        live -= (record.left_face != NONE) as usize + (record.right_face != NONE) as usize;
        let (opposite, hole) = ([record.left, record.right], record.hole);
        log.push(record);
        collapses_this_pass += 1;
        rank_again(state, candidate.survivor, opposite, hole, with_attributes, &mut heap, &mut neighbours);
        sweep_when_stale(state, &mut heap, live);
    };
    let parts_removed = parts.map_or(0, |p| p.removed);
    Ok(Run { log, stop_reason, refused, max_collapse_error, parts_removed })
}

/// The queue's refills drop the stale entries they pass over; where its heap takes most pushes
/// (refills then come seldom: large planar regions) they pile up instead. A mesh has about 1.5
/// edges per face, so once the queue holds more than 2 entries per face (of `live`) a quarter or
/// more are stale: one linear sweep drops them.
#[inline]
fn sweep_when_stale(state: &State, heap: &mut TieredQueue, live: usize) {
    if heap.len() > 2 * live {
        heap.sweep(|e| state.is_current(e));
    }
}

/// The face count (of the state's faces alive, `live` at the start) from which the distance term
/// is measured: the guard's from the start, the fan-distance term's once
/// [`super::fan_term::FAN_TERM_FROM`] of the input's faces are gone.
fn term_from(state: &State, live: usize) -> usize {
    if state.terms.guard.is_some() {
        live
    } else {
        (state.terms.term_base as f64 * (1.0 - super::fan_term::FAN_TERM_FROM)).round() as usize
    }
}

/// The candidate of the queue's top `entry`, or `None` when it has none or went back into the
/// queue. With `measure`, it was queued without the distance term, which only adds: it is ranked
/// with the term now and put back unless it still comes first (the result is the greedy order of
/// the full costs, at one measurement per candidate that reaches the top).
#[inline]
fn candidate_at_top(state: &State, heap: &mut TieredQueue, entry: &QueueEntry, measure: bool) -> Option<Candidate> {
    let (a, b) = (entry.a(), entry.b & !GUARDED);
    if !measure {
        return state.evaluate(a, b);
    }
    let (key, choice) = state.guarded_key(a, b)?;
    let guarded = QueueEntry::new(key, a, b | GUARDED, entry.stamp);
    if heap.top(|e: &QueueEntry| state.is_current(e)).is_some_and(|top| top.rank() < guarded.rank()) {
        heap.push(guarded);
        return None;
    }
    Some(state.candidate(a, b, choice))
}

/// A new pass: queues again every edge that a collapse came near after its last refusal
/// (`retry`), since refused candidates may have become legal.
#[cold]
fn queue_again(
    state: &mut State,
    retry: &mut Retry,
    log: &[CollapseRecord],
    heap: &mut TieredQueue,
    neighbours: &mut Vec<u32>,
) {
    retry.prepare(state, log);
    for v in 0..state.vertices.len() as u32 {
        if state.topo.vertex_alive[v as usize] {
            neighbours.clear();
            state.push_edges_where(v, v + 1, heap, neighbours, |u| retry.needs(v, u));
        }
    }
}

/// After a collapse into `survivor`: its edges ranked again, and those of a closed hole's third
/// corner (interior now: its edges rank by other rules). The survivor and the two `opposite`
/// vertices lost faces: one whose faces now carry fewer sets of values may be held by fewer rules
/// (`State::relax`), and its edges are ranked again too.
#[inline]
fn rank_again(
    state: &mut State,
    survivor: u32,
    opposite: [u32; 2],
    hole: u32,
    with_attributes: bool,
    heap: &mut TieredQueue,
    neighbours: &mut Vec<u32>,
) {
    if with_attributes {
        state.relax(survivor);
    }
    state.push_edges_of(survivor, heap, neighbours);
    if hole != NONE {
        state.push_edges_where(hole, 0, heap, neighbours, |u| u != survivor);
    }
    if with_attributes {
        for v in opposite {
            if v != NONE && state.relax(v) {
                state.push_edges_where(v, 0, heap, neighbours, |u| u != survivor);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::kernel::State;
    use super::super::{SimplifyOptions, simplify};
    use super::log_reserve;
    use crate::procedural;

    #[test]
    fn the_log_reserve_holds_every_collapse_of_meshes_with_borders_holes_and_none() {
        let meshes = [
            ("terrain", procedural::terrain(24, 3)),
            ("sphere with holes", procedural::with_triangular_holes(&procedural::icosphere(3), 7)),
            ("torus", procedural::torus(24, 12, 0.3)),
            ("sharp box", procedural::sharp_box(6)),
        ];
        for (name, mesh) in meshes {
            let defaults = SimplifyOptions::default();
            let (state, _) = State::new(&mesh, &defaults);
            assert!(name == "torus" || name == "sharp box" || state.open_vertices > 0, "{name}: has a border");
            for target in [0, mesh.face_count() / 10, mesh.face_count() / 2] {
                let options = SimplifyOptions { target_faces: Some(target), target_ratio: None, ..defaults.clone() };
                let out = simplify(&mesh, &options).expect("simplifies");
                let reserve = log_reserve(mesh.face_count(), target, state.open_vertices, mesh.vertex_count());
                assert!(out.stats.collapses > 0, "{name} to {target}: collapses");
                assert!(out.stats.collapses <= reserve, "{name} to {target}: {} > {reserve}", out.stats.collapses);
            }
        }
    }
}
