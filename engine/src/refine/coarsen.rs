//! Energy-driven triangle collapse: the faces of lowest energy are merged into single vertices,
//! lowest first, while their energy is below the threshold.
//!
//! A triangle collapse {a, b, c} → p is done as two edge collapses through the simplifier's state
//! (`crate::simplify`), so it passes the same legality checks: link condition, no flip or fold,
//! no needle, boundaries kept. The first collapses the triangle's cheapest legal edge at its
//! quadric-optimal point, which already removes the triangle; the second merges the third vertex
//! at the quadric-optimal point of all three (the sum of their quadrics): the point nearest, in
//! the least-squares sense, to the planes of the original faces around them — unlike the
//! centroid, it does not shrink curved regions. If the second collapse is illegal the triangle is
//! still gone (as an edge collapse). Faces with two or more boundary vertices are left alone.
//!
//! Energies are kept per vertex and updated locally: a collapse changes the positions and edges
//! of the merged vertex, so the mean edge lengths of it and its neighbours change, and with them
//! the energies of its two-ring.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::energy::vertex_energy;
use crate::error::MeshError;
use crate::mesh::Mesh;
use crate::simplify::{BoundaryMode, Metric, Placement, SimplifyOptions, State, VertexKind};

/// How often (in queue pops) the cancel flag is read.
const CANCEL_CHECK_INTERVAL: usize = 256;

/// What a coarsening run did.
#[derive(Debug, Clone)]
pub(crate) struct Coarsened {
    pub mesh: Mesh,
    pub collapses: usize,
    /// Energy of every face popped, in order (the threshold of an ETC run stops at the first one
    /// at or above it).
    pub popped: Vec<f64>,
}

/// Mean length of the edges from `v` to `ring` (its sorted one-ring).
fn mean_edge_length(state: &State, v: u32, ring: &[u32]) -> f64 {
    if ring.is_empty() {
        return 0.0;
    }
    let p = state.point(v);
    ring.iter().map(|&u| (state.point(u) - p).length()).sum::<f64>() / ring.len() as f64
}

/// The sorted one-rings read during one step, each computed once: a step reads the rings of the
/// survivor and its neighbours three times each (mean lengths, the two-ring, energies), and the
/// rings do not change within a step.
struct RingCache {
    rings: Vec<u32>,
    /// Where each vertex's ring lies in `rings`, valid when its stamp is the current one.
    span: Vec<(u32, u32)>,
    stamp_of: Vec<u32>,
    stamp: u32,
    scratch: Vec<u32>,
}

impl RingCache {
    fn new(vertex_count: usize) -> RingCache {
        RingCache {
            rings: Vec::new(),
            span: vec![(0, 0); vertex_count],
            stamp_of: vec![0; vertex_count],
            stamp: 0,
            scratch: Vec::new(),
        }
    }

    /// Forgets every ring (the mesh changed).
    fn clear(&mut self) {
        self.rings.clear();
        self.stamp += 1;
        if self.stamp == u32::MAX {
            self.stamp_of.iter_mut().for_each(|s| *s = 0);
            self.stamp = 1;
        }
    }

    /// The range of `v`'s ring in `self.rings`.
    fn ring(&mut self, state: &State, v: u32) -> std::ops::Range<usize> {
        if self.stamp_of[v as usize] != self.stamp {
            state.neighbours(v, &mut self.scratch);
            self.span[v as usize] = (self.rings.len() as u32, self.scratch.len() as u32);
            self.rings.extend_from_slice(&self.scratch);
            self.stamp_of[v as usize] = self.stamp;
        }
        let (start, len) = self.span[v as usize];
        start as usize..(start + len) as usize
    }
}

/// The simplifier's options for a triangle collapse: QEM at the optimal place, borders kept.
fn collapse_options() -> SimplifyOptions {
    SimplifyOptions {
        metric: Metric::Qem,
        placement: Placement::Optimal,
        boundary: BoundaryMode::Preserve,
        ..Default::default()
    }
}

/// The energy of vertex `v` with its `ring`, from the mean edge lengths around each vertex.
fn energy_of(state: &State, mean_length: &[f64], v: u32, ring: &[u32]) -> f64 {
    vertex_energy(state.point(v), ring.iter().map(|&u| (state.point(u), mean_length[u as usize])))
}

/// Each vertex's mean edge length and energy at the start.
fn initial_energies(state: &State) -> (Vec<f64>, Vec<f64>) {
    let vertex_count = state.vertex_count();
    let mut scratch = Vec::new();
    let mean_length: Vec<f64> = (0..vertex_count as u32)
        .map(|v| {
            state.neighbours(v, &mut scratch);
            mean_edge_length(state, v, &scratch)
        })
        .collect();
    let energy: Vec<f64> = (0..vertex_count as u32)
        .map(|v| {
            state.neighbours(v, &mut scratch);
            energy_of(state, &mean_length, v, &scratch)
        })
        .collect();
    (mean_length, energy)
}

/// The triangle collapse of face `t`: its cheapest legal edge (step 1), then, while more than
/// `target_faces` of the `faces_alive` remain, its third vertex merged into the survivor at the
/// optimum of the three quadrics (step 2). The survivor, the faces removed and the collapses made;
/// `None` when no edge of the face may collapse.
fn collapse_triangle(
    state: &mut State,
    t: [u32; 3],
    faces_alive: usize,
    target_faces: usize,
) -> Option<(u32, usize, usize)> {
    let mut candidates: Vec<_> =
        [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])].iter().filter_map(|&(x, y)| state.evaluate(x, y)).collect();
    candidates.sort_by(|x, y| x.cost.total_cmp(&y.cost));
    let first = candidates.into_iter().find_map(|c| state.is_legal(&c).ok())?;
    let (kept, gone) = (first.candidate().survivor, first.candidate().removed);
    let third = *t.iter().find(|&&v| v != kept && v != gone).expect("three");
    let faces_of =
        |r: &crate::pm::CollapseRecord| (r.left_face != u32::MAX) as usize + (r.right_face != u32::MAX) as usize;
    let mut removed = faces_of(&state.collapse(first));
    let mut collapses = 1;
    let mut survivor = kept;
    if faces_alive - removed > target_faces
        && state.is_vertex_alive(third)
        && let Some(second) = state.evaluate(survivor.min(third), survivor.max(third))
        && let Ok(second) = state.is_legal(&second)
    {
        let next = second.candidate().survivor;
        removed += faces_of(&state.collapse(second));
        collapses += 1;
        survivor = next;
    }
    Some((survivor, removed, collapses))
}

/// Collapses faces in increasing energy while their energy is below `threshold` (absolute) and
/// more than `target_faces` faces remain.
pub(crate) fn coarsen(
    mesh: &Mesh,
    threshold: f64,
    target_faces: usize,
    cancel: Option<&std::sync::atomic::AtomicBool>,
) -> Result<Coarsened, MeshError> {
    let options = collapse_options();
    let (mut state, _) = State::new(mesh, &options);
    // Attributes ride along as in the simplifier: a seam vertex collapses only along its seam.
    state.carry_attributes(mesh);
    let vertex_count = mesh.vertex_count();
    let (mut mean_length, mut energy) = initial_energies(&state);
    let mut rings = RingCache::new(vertex_count);
    let face_energy =
        |state: &State, energy: &[f64], f: u32| -> f64 { state.triangle(f).iter().map(|&v| energy[v as usize]).sum() };
    let mut face_version = vec![0u32; mesh.face_count()];
    let key = |e: f64| Reverse(e.max(0.0).to_bits());
    let mut heap: BinaryHeap<(Reverse<u64>, Reverse<u32>, u32)> =
        (0..mesh.face_count() as u32).map(|f| (key(face_energy(&state, &energy, f)), Reverse(f), 0)).collect();

    let (mut faces_alive, mut collapses, mut pops) = (mesh.face_count(), 0, 0usize);
    let (mut popped, mut touched): (Vec<f64>, Vec<u32>) = (Vec::new(), Vec::new());
    // Stamps for de-duplicating the touched vertices and faces of one step; the queue's order is
    // total (energy, face id), so the push order of re-queued faces does not matter.
    let mut vertex_mark = vec![0u32; vertex_count];
    let mut face_mark = vec![0u32; mesh.face_count()];
    let mut stamp = 0u32;
    while faces_alive > target_faces {
        pops += 1;
        if pops.is_multiple_of(CANCEL_CHECK_INTERVAL)
            && cancel.is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
        {
            return Err(MeshError::Cancelled);
        }
        let Some((Reverse(bits), Reverse(f), version)) = heap.pop() else { break };
        if !state.is_face_alive(f) || version != face_version[f as usize] {
            continue;
        }
        let e = f64::from_bits(bits);
        if e >= threshold {
            break;
        }
        popped.push(e);
        let t = state.triangle(f);
        let kinds = t.map(|v| state.kind(v));
        if kinds.iter().any(|k| matches!(k, VertexKind::Frozen | VertexKind::Anchored))
            || kinds.iter().filter(|&&k| k == VertexKind::Boundary).count() >= 2
        {
            continue;
        }
        let Some((survivor, removed, steps)) = collapse_triangle(&mut state, t, faces_alive, target_faces) else {
            continue;
        };
        faces_alive -= removed;
        collapses += steps;
        // Local energy update: mean lengths of the survivor and its ring, energies of the 2-ring.
        rings.clear();
        let ring1 = rings.ring(&state, survivor);
        touched.clear();
        touched.push(survivor);
        touched.extend_from_slice(&rings.rings[ring1.clone()]);
        for &v in &touched {
            let ring = rings.ring(&state, v);
            mean_length[v as usize] = mean_edge_length(&state, v, &rings.rings[ring]);
        }
        for i in ring1 {
            let v = rings.rings[i];
            let ring2 = rings.ring(&state, v);
            touched.extend_from_slice(&rings.rings[ring2]);
        }
        // Each vertex once (marks, not a sort: energies do not depend on the order).
        stamp += 1;
        touched.retain(|&v| std::mem::replace(&mut vertex_mark[v as usize], stamp) != stamp);
        for &v in &touched {
            let ring = rings.ring(&state, v);
            energy[v as usize] = energy_of(&state, &mean_length, v, &rings.rings[ring]);
        }
        // Each face around the touched vertices is re-queued once.
        for &v in &touched {
            for g in state.faces_around(v) {
                if std::mem::replace(&mut face_mark[g as usize], stamp) != stamp {
                    face_version[g as usize] = face_version[g as usize].wrapping_add(1);
                    heap.push((key(face_energy(&state, &energy, g)), Reverse(g), face_version[g as usize]));
                }
            }
        }
        // Every step re-queues the ~50 faces of a 2-ring, so most entries go stale; drop them in
        // one linear sweep once they outnumber the live faces three to one (the queue's order is
        // total, so what pops next is unchanged).
        if heap.len() > 4 * faces_alive {
            heap.retain(|&(_, Reverse(f), version)| state.is_face_alive(f) && version == face_version[f as usize]);
        }
    }
    Ok(Coarsened { mesh: state.output_mesh(), collapses, popped })
}
