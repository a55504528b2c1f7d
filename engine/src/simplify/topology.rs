//! The run's connectivity, owned by one part of the state ([`Topology`]): the faces around each
//! vertex (fans), the faces' corners, alive flags and version stamps. The collapse changes it;
//! every stage reads it.

use crate::fan::{Corner, FanSlot};
use crate::mesh::Mesh;
use crate::pm::CollapseRecord;

use super::vertex::NONE;

/// The passes over the faces write to their corners' fans and blocks, in the input's vertex order,
/// which can be far from its face order: each asks for the data of the face `AHEAD` places on
/// while it works on this one.
pub(crate) const AHEAD: usize = 8;

/// Fans, faces, alive flags and version stamps of a run.
pub(crate) struct Topology {
    /// Each face's corners, kept current by every collapse while `track_triangles` is set; the
    /// simplifier's own loop does without (the fans carry what the loop reads) and builds it once
    /// at the end from the log ([`Topology::rebuild_triangles`]).
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) track_triangles: bool,
    pub(crate) face_alive: Vec<bool>,
    /// The live faces around each vertex, with their other two corners.
    pub(crate) fans: Vec<FanSlot>,
    pub(crate) vertex_alive: Vec<bool>,
    /// Per vertex, a stamp that every collapse touching it moves on: a queue entry made before is
    /// stale.
    pub(crate) version: Vec<u32>,
}

impl Topology {
    /// Takes out the faces `shared` of the edge whose end `b` goes (as corners of the other end's
    /// fan), each from its third corner's fan, and names them and their third corners in `record`:
    /// the face with half-edge a→b is the split's left face (vs = a, vt = b). Returns the faces,
    /// [`NONE`] for a missing second one.
    pub(crate) fn remove_edge_faces(&mut self, b: u32, shared: &[Corner], record: &mut CollapseRecord) -> [u32; 2] {
        let mut dead = [NONE; 2];
        for (slot, corner) in dead.iter_mut().zip(shared) {
            let (f, third) = (corner.face, corner.other(b));
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
        dead
    }

    /// The topology of `mesh` around `fans` (its fans, built by [`build_fans`]); `track` keeps the
    /// faces' corners current through the collapses.
    pub(crate) fn new(mesh: &Mesh, fans: Vec<FanSlot>, track: bool) -> Topology {
        let vertex_count = mesh.vertex_count();
        Topology {
            triangles: if track { mesh.triangles.clone() } else { Vec::new() },
            track_triangles: track,
            face_alive: vec![true; mesh.face_count()],
            fans,
            vertex_alive: vec![true; vertex_count],
            version: vec![0; vertex_count],
        }
    }

    /// Faces on edge (a, b), as corners of `a`'s fan, and how many there are.
    pub(crate) fn edge_corners(&self, a: u32, b: u32) -> ([Corner; 2], usize) {
        self.fans[a as usize].touching(b)
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

    /// Corners of face `f` (kept current only for a state made with `State::new`).
    pub(crate) fn triangle(&self, f: u32) -> [u32; 3] {
        debug_assert!(self.track_triangles, "the triangle array is not being kept current");
        self.triangles[f as usize]
    }

    /// Whether face `f` is still in the mesh.
    pub(crate) fn is_face_alive(&self, f: u32) -> bool {
        self.face_alive[f as usize]
    }

    /// Whether vertex `v` is still in the mesh.
    pub(crate) fn is_vertex_alive(&self, v: u32) -> bool {
        self.vertex_alive[v as usize]
    }

    /// The live faces around vertex `v`.
    pub(crate) fn faces_around(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.fans[v as usize].iter().map(|c| c.face)
    }
    /// Brings `triangles` up to date after a run without tracking: every corner names the vertex
    /// its input vertex was merged into, last merge first (the same as renaming at each collapse).
    /// Built from the input's triangles (`mesh`, the one the state was made from): the state
    /// holds no copy while it does not track them.
    pub(crate) fn rebuild_triangles(&mut self, mesh: &Mesh, log: &[CollapseRecord]) {
        if self.track_triangles {
            return;
        }
        let mut last: Vec<u32> = (0..self.fans.len() as u32).collect();
        for record in log.iter().rev() {
            last[record.removed as usize] = last[record.survivor as usize];
        }
        self.triangles = mesh.triangles.iter().map(|t| t.map(|v| last[v as usize])).collect();
        self.track_triangles = true;
    }
}

/// The faces around each vertex, in face order.
pub(crate) fn build_fans(mesh: &Mesh) -> Vec<FanSlot> {
    let mut fans = vec![FanSlot::default(); mesh.vertex_count()];
    for (f, &[x, y, z]) in mesh.triangles.iter().enumerate() {
        if let Some(t) = mesh.triangles.get(f + AHEAD) {
            t.iter().for_each(|&v| fans[v as usize].prefetch());
        }
        let face = f as u32;
        fans[x as usize].push(Corner { face, next: y, prev: z });
        fans[y as usize].push(Corner { face, next: z, prev: x });
        fans[z as usize].push(Corner { face, next: x, prev: y });
    }
    fans
}
