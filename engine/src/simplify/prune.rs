//! Parts taken out whole ([`super::SimplifyOptions::prune`], off by default).
//!
//! A part is a set of faces joined through shared vertices. Collapses keep every part as at
//! least its smallest manifold form (rule 3: a closed part keeps four faces or more, a ring
//! more), so on an asset of many small pieces those forms hold faces that the large shapes need
//! (a chain's links keep their faces while the beam they hang from is cut to a few; measured in
//! docs/attributes-report.md). With `prune`, a part goes whole once the run's largest collapse
//! error (paper units) reaches its size: the larger of half its bounding box's diagonal (as
//! meshoptimizer's `SimplifyPrune` weighs its parts by their radius) and how far its farthest
//! vertex is from the parts that stay, the distance its absence opens (a hand modelled apart from
//! the arm it sticks out of goes late, a button on a coat early). The parts that stay are those
//! still there whose radius is above the error (the one with the most faces at least): a part
//! next to another small one does not go on the strength of a neighbour that may go too (a chain
//! of small parts, a robot's links, would go link by link, each near the last, until the surface
//! that was there is far from anything left). Both are measured on the input, so the order does
//! not depend on how far a part itself was simplified.
//!
//! The distance is measured once a part's radius is within the error (most parts of a large asset
//! never are), and again when the error reaches it, as the parts that stay are then fewer: each of
//! its vertices looks for the nearest triangle of those parts, part by part in the order of their
//! bounding boxes' distance.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;

use crate::bvh::TriangleBvh;
use crate::mesh::{DistanceUnits, Mesh};
use crate::topology::{Csr, UnionFind};

use super::kernel::State;

/// The parts that may go, with their faces and vertices.
pub(super) struct Parts<'m> {
    mesh: &'m Mesh,
    units: DistanceUnits,
    /// Per part, its triangles and bounding box, built at the first distance measured.
    shapes: Vec<(TriangleBvh, DVec3, DVec3)>,
    /// Per part, its radius in paper units (infinite for the one with the most faces, which
    /// stays), and whether it is still there.
    radius: Vec<f64>,
    present: Vec<bool>,
    /// Every part but the one with the most faces, smallest radius first.
    by_radius: Vec<u32>,
    /// The next entry of `by_radius` whose radius the error has not reached.
    next: usize,
    /// Parts within the error by radius, by a lower bound of their size (paper units, as bits:
    /// non-negative floats order as their bits do).
    waiting: BinaryHeap<Reverse<(u64, u32)>>,
    /// Per part, its faces and its vertices.
    faces: Csr<u32>,
    vertices: Csr<u32>,
    /// Set once a part would have taken the face count below the target: nothing more goes.
    done: bool,
    /// Parts taken out so far.
    pub(super) removed: usize,
}

impl<'m> Parts<'m> {
    /// The parts of `mesh` (every vertex on a face, as a prepared mesh has them); `None` for one
    /// part (the usual input), which stays.
    pub(super) fn new(mesh: &'m Mesh, units: &DistanceUnits) -> Option<Parts<'m>> {
        let n = mesh.vertex_count();
        let mut sets = UnionFind::new(n);
        for t in &mesh.triangles {
            sets.union(t[0], t[1]);
            sets.union(t[0], t[2]);
        }
        // Dense part numbers, in the order of each part's lowest vertex.
        let mut number = vec![u32::MAX; n];
        let mut part_of_vertex = vec![0u32; n];
        let mut parts = 0u32;
        for v in 0..n as u32 {
            let r = sets.find(v) as usize;
            if number[r] == u32::MAX {
                number[r] = parts;
                parts += 1;
            }
            part_of_vertex[v as usize] = number[r];
        }
        let parts = parts as usize;
        if parts < 2 {
            return None;
        }
        let vertices = Csr::from_pairs(parts, (0..n as u32).map(|v| (part_of_vertex[v as usize] as usize, v)));
        let face_part = |f: usize| part_of_vertex[mesh.triangles[f][0] as usize] as usize;
        let faces = Csr::from_pairs(parts, (0..mesh.face_count()).map(|f| (face_part(f), f as u32)));
        let largest = (0..parts).max_by_key(|&p| (faces.get(p).len(), Reverse(p)));
        let radius: Vec<f64> = (0..parts)
            .map(|p| {
                if Some(p) == largest {
                    return f64::INFINITY;
                }
                let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                for &v in vertices.get(p) {
                    let q = mesh.point(v);
                    (lo, hi) = (lo.min(q), hi.max(q));
                }
                units.to_paper(0.5 * (hi - lo).length())
            })
            .collect();
        let mut by_radius: Vec<u32> = (0..parts as u32).filter(|&p| Some(p as usize) != largest).collect();
        by_radius.sort_by(|&a, &b| radius[a as usize].total_cmp(&radius[b as usize]).then(a.cmp(&b)));
        Some(Parts {
            mesh,
            units: *units,
            shapes: Vec::new(),
            present: vec![true; parts],
            radius,
            by_radius,
            next: 0,
            waiting: BinaryHeap::new(),
            faces,
            vertices,
            done: false,
            removed: 0,
        })
    }

    /// How far part `p`'s farthest vertex is from the triangles of the parts that stay at `error`
    /// (still there, and larger than the error: the one with the most faces at least), paper units.
    fn distance_to_staying(&mut self, p: u32, error: f64) -> f64 {
        let mesh = self.mesh;
        if self.shapes.is_empty() {
            let mut local = vec![0u32; mesh.vertex_count()];
            for part in 0..self.vertices.len() {
                let members = self.vertices.get(part);
                let mut positions = Vec::with_capacity(members.len());
                for &v in members {
                    local[v as usize] = positions.len() as u32;
                    positions.push(mesh.positions[v as usize]);
                }
                let faces = self.faces.get(part);
                let triangles = faces.iter().map(|&f| mesh.triangles[f as usize].map(|v| local[v as usize])).collect();
                let piece = Mesh::new(positions, triangles).expect("a part of a checked mesh");
                let bounds = piece.bounds().expect("a part has faces");
                let bvh = TriangleBvh::new(&piece).expect("a part has faces");
                self.shapes.push((bvh, DVec3::from(bounds.min), DVec3::from(bounds.max)));
            }
        }
        let staying: Vec<usize> =
            (0..self.shapes.len()).filter(|&j| j != p as usize && self.present[j] && self.radius[j] > error).collect();
        let mut far: f64 = 0.0;
        let mut order = Vec::with_capacity(staying.len());
        for &v in self.vertices.get(p as usize) {
            let q = mesh.point(v);
            order.clear();
            for &j in &staying {
                let (_, lo, hi) = &self.shapes[j];
                order.push(((*lo - q).max(q - *hi).max(DVec3::ZERO).length_squared(), j));
            }
            order.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut best = f64::INFINITY;
            for &(box_distance, j) in &order {
                if box_distance >= best {
                    break;
                }
                best = best.min(self.shapes[j].0.closest_point(q, None).distance_squared);
            }
            far = far.max(best.sqrt());
        }
        self.units.to_paper(far)
    }

    /// Takes out every part whose size is within `error` (paper units), as long as `faces_alive`
    /// stays at or above `target`; returns the faces taken out. A part that would take the count
    /// below the target stops the pruning for the rest of the run.
    pub(super) fn prune(&mut self, state: &mut State, error: f64, faces_alive: usize, target: usize) -> usize {
        if self.done {
            return 0;
        }
        while let Some(&part) = self.by_radius.get(self.next) {
            let radius = self.radius[part as usize];
            if radius > error {
                break;
            }
            self.waiting.push(Reverse((radius.to_bits(), part)));
            self.next += 1;
        }
        let mut taken = 0;
        while let Some(&Reverse((bound, part))) = self.waiting.peek() {
            if f64::from_bits(bound) > error {
                break;
            }
            self.waiting.pop();
            let p = part as usize;
            // Measured now, against the parts that stay at this error: fewer as the error grows,
            // so the distance only grows and is a lower bound for the next look.
            let size = self.radius[p].max(self.distance_to_staying(part, error));
            if size > error {
                self.waiting.push(Reverse((size.to_bits(), part)));
                continue;
            }
            let faces = self.faces.get(p);
            let alive = faces.iter().filter(|&&f| state.topo.face_alive[f as usize]).count();
            if faces_alive < target + taken + alive {
                self.done = true;
                break;
            }
            for &f in faces {
                state.topo.face_alive[f as usize] = false;
            }
            for &v in self.vertices.get(p) {
                if state.topo.vertex_alive[v as usize] {
                    state.topo.vertex_alive[v as usize] = false;
                    state.topo.fans[v as usize] = Default::default();
                    // Its queue entries are stale from now on.
                    state.topo.version[v as usize] = state.topo.version[v as usize].wrapping_add(1);
                }
            }
            taken += alive;
            self.present[p] = false;
            self.removed += 1;
        }
        taken
    }
}
