//! Parts taken out whole ([`super::SimplifyOptions::prune`], off by default).
//!
//! A part is a set of faces joined through shared vertices. Collapses keep every part as at
//! least its smallest manifold form (rule 3: a closed part keeps four faces or more, a ring
//! more), so on an asset of many small pieces those forms hold faces that the large shapes need:
//! Lantern's eight chain links kept 142 of its 860 faces while its beam was cut to 8
//! (docs/attributes-report.md). With `prune`, a part goes whole once the run's largest collapse
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

use super::kernel::State;

/// The parts that may go, with their faces and vertices.
pub(super) struct Parts<'m> {
    mesh: &'m Mesh,
    units: DistanceUnits,
    /// Per part, its triangles and bounding box, built at the first distance measured.
    shapes: Vec<(TriangleBvh, DVec3, DVec3)>,
    /// (radius in paper units, part): every part but the one with the most faces, smallest first.
    by_radius: Vec<(f64, u32)>,
    /// Per part, its radius in paper units (infinite for the one with the most faces, which
    /// stays), and whether it is still there.
    radius: Vec<f64>,
    present: Vec<bool>,
    /// The next entry of `by_radius` whose radius the error has not reached.
    next: usize,
    /// Parts within the error by radius, by a lower bound of their size (paper units, as bits:
    /// non-negative floats order as their bits do).
    waiting: BinaryHeap<Reverse<(u64, u32)>>,
    /// Per part, its faces: `faces[face_start[p]..face_start[p + 1]]`.
    face_start: Vec<u32>,
    faces: Vec<u32>,
    /// Per part, its vertices, in the same layout.
    vertex_start: Vec<u32>,
    vertices: Vec<u32>,
    /// Set once a part would have taken the face count below the target: nothing more goes.
    done: bool,
    /// Parts taken out so far.
    pub(super) removed: usize,
}

/// The root of `v` in a union-find forest, halving the path on the way.
fn root(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        parent[v as usize] = parent[parent[v as usize] as usize];
        v = parent[v as usize];
    }
    v
}

/// Items grouped by part: the start of each part's run and the items in part order.
fn grouped(part_of: impl Iterator<Item = u32> + Clone, parts: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; parts + 1];
    for p in part_of.clone() {
        start[p as usize + 1] += 1;
    }
    for p in 0..parts {
        start[p + 1] += start[p];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; start[parts] as usize];
    for (i, p) in part_of.enumerate() {
        items[fill[p as usize] as usize] = i as u32;
        fill[p as usize] += 1;
    }
    (start, items)
}

impl<'m> Parts<'m> {
    /// The parts of `mesh` (every vertex on a face, as a prepared mesh has them).
    pub(super) fn new(mesh: &'m Mesh, units: &DistanceUnits) -> Parts<'m> {
        let n = mesh.vertex_count();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        for t in &mesh.triangles {
            let mut x = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let y = root(&mut parent, v);
                if x != y {
                    parent[x.max(y) as usize] = x.min(y);
                    x = x.min(y);
                }
            }
        }
        // One part (the usual input): it stays, and there is nothing else to look at.
        if (0..n as u32).filter(|&v| parent[v as usize] == v).take(2).count() < 2 {
            return Parts {
                mesh,
                units: *units,
                shapes: Vec::new(),
                by_radius: Vec::new(),
                radius: Vec::new(),
                present: Vec::new(),
                next: 0,
                waiting: BinaryHeap::new(),
                face_start: vec![0],
                faces: Vec::new(),
                vertex_start: vec![0],
                vertices: Vec::new(),
                done: true,
                removed: 0,
            };
        }
        // Dense part numbers, in the order of each part's lowest vertex.
        let mut number = vec![u32::MAX; n];
        let mut part_of_vertex = vec![0u32; n];
        let mut parts = 0u32;
        for v in 0..n as u32 {
            let r = root(&mut parent, v) as usize;
            if number[r] == u32::MAX {
                number[r] = parts;
                parts += 1;
            }
            part_of_vertex[v as usize] = number[r];
        }
        let parts = parts as usize;
        let (vertex_start, vertices) = grouped(part_of_vertex.iter().copied(), parts);
        let face_part = mesh.triangles.iter().map(|t| part_of_vertex[t[0] as usize]);
        let (face_start, faces) = grouped(face_part, parts);
        let face_count = |p: usize| face_start[p + 1] - face_start[p];
        let largest = (0..parts).max_by_key(|&p| (face_count(p), Reverse(p)));
        let mut by_radius: Vec<(f64, u32)> = (0..parts)
            .filter(|&p| Some(p) != largest)
            .map(|p| {
                let members = &vertices[vertex_start[p] as usize..vertex_start[p + 1] as usize];
                let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                for &v in members {
                    let q = mesh.point(v);
                    (lo, hi) = (lo.min(q), hi.max(q));
                }
                (units.to_paper(0.5 * (hi - lo).length()), p as u32)
            })
            .collect();
        let mut radius = vec![f64::INFINITY; parts];
        for &(r, p) in &by_radius {
            radius[p as usize] = r;
        }
        by_radius.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        Parts {
            mesh,
            units: *units,
            shapes: Vec::new(),
            by_radius,
            radius,
            present: vec![true; parts],
            next: 0,
            waiting: BinaryHeap::new(),
            face_start,
            faces,
            vertex_start,
            vertices,
            done: false,
            removed: 0,
        }
    }

    /// How far part `p`'s farthest vertex is from the triangles of the parts that stay at `error`
    /// (still there, and larger than the error: the one with the most faces at least), paper units.
    fn distance_to_staying(&mut self, p: u32, error: f64) -> f64 {
        let mesh = self.mesh;
        if self.shapes.is_empty() {
            let mut local = vec![0u32; mesh.vertex_count()];
            for part in 0..self.vertex_start.len() - 1 {
                let members = &self.vertices[self.vertex_start[part] as usize..self.vertex_start[part + 1] as usize];
                let mut positions = Vec::with_capacity(members.len());
                for &v in members {
                    local[v as usize] = positions.len() as u32;
                    positions.push(mesh.positions[v as usize]);
                }
                let faces = &self.faces[self.face_start[part] as usize..self.face_start[part + 1] as usize];
                let triangles = faces.iter().map(|&f| mesh.triangles[f as usize].map(|v| local[v as usize])).collect();
                let piece = Mesh::new(positions, triangles).expect("a part of a checked mesh");
                let bounds = piece.bounds().expect("a part has faces");
                let bvh = TriangleBvh::new(&piece).expect("a part has faces");
                self.shapes.push((bvh, DVec3::from(bounds.min), DVec3::from(bounds.max)));
            }
        }
        let members =
            &self.vertices[self.vertex_start[p as usize] as usize..self.vertex_start[p as usize + 1] as usize];
        let mut far: f64 = 0.0;
        let mut order = Vec::with_capacity(self.shapes.len());
        for &v in members {
            let q = mesh.point(v);
            order.clear();
            let stays = |j: usize| j != p as usize && self.present[j] && self.radius[j] > error;
            for (j, (_, lo, hi)) in self.shapes.iter().enumerate().filter(|&(j, _)| stays(j)) {
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
        while let Some(&(radius, part)) = self.by_radius.get(self.next) {
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
            let faces = &self.faces[self.face_start[p] as usize..self.face_start[p + 1] as usize];
            let alive = faces.iter().filter(|&&f| state.face_alive[f as usize]).count();
            if faces_alive < target + taken + alive {
                self.done = true;
                break;
            }
            for &f in faces {
                state.face_alive[f as usize] = false;
            }
            for &v in &self.vertices[self.vertex_start[p] as usize..self.vertex_start[p + 1] as usize] {
                if state.vertex_alive[v as usize] {
                    state.vertex_alive[v as usize] = false;
                    state.fans[v as usize] = Default::default();
                    // Its queue entries are stale from now on.
                    state.version[v as usize] = state.version[v as usize].wrapping_add(1);
                }
            }
            taken += alive;
            self.present[p] = false;
            self.removed += 1;
        }
        taken
    }
}
