//! Which edges a new pass queues again ([`super::run`]): when the queue runs dry before the
//! target, a candidate refused earlier may have become legal since, but only if a collapse changed
//! something its checks read. Those checks read the faces around its two ends, the corners and
//! normal cones of their neighbours and the faces across their far edges: everything within two
//! edges of the candidate's ends. So a candidate refused after the last collapse within two edges
//! of both its ends would be refused again, and the pass leaves it out. On small meshes that end
//! in refusals (a textured asset whose seams stop it above its target) the passes after the first
//! cost a quarter of the run; on Fox this leaves out about half of each later pass's edges (the
//! rest are near the few collapses those passes still find), 4% of its time
//! (docs/attributes-report.md). The one other change a pass can see is in a vertex's kind: an
//! anchor whose faces lost all but two sets of values is released when a pass begins
//! ([`State::release_anchors`]), and every edge of a released vertex is queued again.
//!
//! Collapses only merge vertices, so a vertex within two edges of a survivor when it took its
//! collapse is within two edges of that survivor (or of the vertex it later went into) when the
//! pass ends: marking the current two-ring of each survivor's current vertex marks a superset of
//! what the collapse could have changed.

use crate::pm::CollapseRecord;

use super::classify::VertexKind;
use super::kernel::{NONE, State};
use super::options::BoundaryMode;

/// Refusals and the collapses near each vertex, kept for the passes after the first.
#[derive(Default)]
pub(super) struct Retry {
    /// (edge key, collapses made when it was refused), in order of refusal.
    refusals: Vec<(u64, u32)>,
    /// Per vertex, 1 + the index of the latest collapse whose survivor is within two edges of it,
    /// 0 for none (allocated at the first new pass).
    changed: Vec<u32>,
    /// Per removed vertex, the survivor it went into (for the collapses marked so far).
    into: Vec<u32>,
    /// Per vertex, scratch: the latest collapse whose survivor it is now, [`NONE`] if none.
    latest: Vec<u32>,
    /// Collapses of the log marked in `changed` so far.
    marked: usize,
}

fn key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

impl Retry {
    /// Notes that edge {a, b} was refused after `collapses` collapses.
    #[inline]
    pub(super) fn refused(&mut self, a: u32, b: u32, collapses: usize) {
        self.refusals.push((key(a, b), collapses as u32));
    }

    /// Brings the marks up to the end of `log`, before a new pass asks [`Retry::needs`].
    pub(super) fn prepare(&mut self, state: &State, log: &[CollapseRecord]) {
        let n = state.vertices.len();
        if self.changed.is_empty() {
            self.changed = vec![0; n];
            self.into = vec![NONE; n];
            self.latest = vec![NONE; n];
        }
        let fresh = &log[self.marked..];
        for record in fresh {
            self.into[record.removed as usize] = record.survivor;
        }
        let mut survivors = Vec::new();
        for (i, record) in fresh.iter().enumerate() {
            let mut r = record.survivor;
            while self.into[r as usize] != NONE {
                r = self.into[r as usize];
            }
            // (The chain's first link is shortened to its end, for the next lookups.)
            if r != record.survivor {
                self.into[record.survivor as usize] = r;
            }
            if self.latest[r as usize] == NONE {
                survivors.push(r);
            }
            self.latest[r as usize] = (self.marked + i) as u32;
        }
        for r in survivors {
            let stamp = self.latest[r as usize] + 1;
            self.latest[r as usize] = NONE;
            let mut mark = |v: u32| {
                let c = &mut self.changed[v as usize];
                *c = (*c).max(stamp);
            };
            mark(r);
            for corner in &state.fans[r as usize] {
                for x in [corner.next, corner.prev] {
                    mark(x);
                    for far in &state.fans[x as usize] {
                        mark(far.next);
                        mark(far.prev);
                    }
                }
            }
        }
        self.marked = log.len();
        // The latest refusal of each edge (first among its own once sorted), by edge for the
        // lookups.
        self.refusals.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(y.1.cmp(&x.1)));
        self.refusals.dedup_by_key(|r| r.0);
    }

    /// Whether edge {a, b} may have become legal since it was last refused (always, if it never
    /// was). Valid after [`Retry::prepare`] until the next refusal is noted.
    pub(super) fn needs(&self, a: u32, b: u32) -> bool {
        let k = key(a, b);
        match self.refusals.binary_search_by_key(&k, |r| r.0) {
            Ok(i) => self.changed[a as usize].max(self.changed[b as usize]) > self.refusals[i].1,
            Err(_) => true,
        }
    }
}

impl State<'_> {
    /// Anchors whose faces now carry at most two sets of values: made ordinary vertices again
    /// (interior or boundary, as their fan is closed or not), still on their seam, and returned.
    /// A vertex is anchored where three or more sets of values meet at the start; collapses into
    /// it take faces away, and with them, at times, every corner of a set. Called when a pass
    /// after the first begins (the first keeps the order it always had). Not with locked borders
    /// or seams, whose anchors stay whatever their corners.
    pub(super) fn release_anchors(&mut self) -> Vec<u32> {
        if self.corner_source.is_empty() || self.options.boundary == BoundaryMode::Lock || self.options.lock_seams {
            return Vec::new();
        }
        let mut released = Vec::new();
        for v in 0..self.vertices.len() as u32 {
            if !self.vertex_alive[v as usize] || self.vertices[v as usize].kind != VertexKind::Anchored {
                continue;
            }
            let fan = &self.fans[v as usize];
            let mut sets = [NONE; 3];
            for corner in fan {
                let value = self.value_id[self.source_at(corner.face, v) as usize];
                if let Some(slot) = sets.iter_mut().find(|s| **s == NONE || **s == value) {
                    *slot = value;
                }
            }
            if sets[2] != NONE {
                continue;
            }
            let closed = fan.iter().all(|c| fan.iter().any(|d| d.prev == c.next));
            self.vertices[v as usize].kind = if closed { VertexKind::Interior } else { VertexKind::Boundary };
            released.push(v);
        }
        released
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use super::super::SimplifyOptions;
    use super::super::classify::VertexKind;
    use super::super::cost::Candidate;
    use super::super::kernel::{NONE, State};
    use super::Retry;

    /// Edge distances from `from` over the live fans.
    fn distances(state: &State, from: u32) -> Vec<u32> {
        let mut d = vec![NONE; state.vertices.len()];
        d[from as usize] = 0;
        let mut queue = VecDeque::from([from]);
        while let Some(v) = queue.pop_front() {
            for corner in &state.fans[v as usize] {
                for u in [corner.next, corner.prev] {
                    if d[u as usize] == NONE {
                        d[u as usize] = d[v as usize] + 1;
                        queue.push_back(u);
                    }
                }
            }
        }
        d
    }

    /// The wheel (centre 0, six faces around it, a ring of twelve outside) with texture
    /// coordinates in three charts, each two of the centre's faces and the ring faces beyond them:
    /// the centre is where three sets of values meet.
    fn wheel_in_three_charts() -> crate::Mesh {
        let mut mesh = super::super::legality::tests::wheel();
        // Faces come three per sector k (the centre's, then two ring faces); chart k / 2.
        let uvs = (0..3 * mesh.face_count())
            .map(|corner| {
                let chart = (corner / 3 / 3 / 2) as f32;
                let p = mesh.positions[mesh.triangles[corner / 3][corner % 3] as usize];
                [p[0] / 8.0 + chart, p[1] / 8.0]
            })
            .collect();
        mesh.corners.uvs = Some(uvs);
        mesh
    }

    #[test]
    fn an_anchor_whose_faces_keep_two_sets_of_values_is_released() {
        let mesh = wheel_in_three_charts();
        let options = SimplifyOptions::default();
        let (mut state, _) = State::new(&mesh, &options);
        state.carry_attributes(&mesh);
        assert_eq!(state.vertices[0].kind, VertexKind::Anchored, "three charts meet at the centre");
        assert!(state.release_anchors().is_empty(), "all three sets are still there");
        // The centre's corners in the third chart (sectors 4 and 5) take its values of the
        // second, as they would once collapses took the third chart's faces at the centre away.
        let second = state.source_at(3 * 2, 0);
        for sector in [4u32, 5] {
            let face = 3 * sector;
            let k = state.triangles[face as usize].iter().position(|&v| v == 0).unwrap();
            state.corner_source[3 * face as usize + k] = second;
        }
        assert_eq!(state.release_anchors(), vec![0]);
        assert_eq!(state.vertices[0].kind, VertexKind::Interior, "its fan is closed");
        assert!(state.on_seam[0], "still on the seam between its two charts");
        // With seams locked an anchor stays one, whatever its corners.
        let locked = SimplifyOptions { lock_seams: true, ..SimplifyOptions::default() };
        let (mut state, _) = State::new(&mesh, &locked);
        state.carry_attributes(&mesh);
        for sector in [4u32, 5] {
            let face = 3 * sector as usize;
            let k = state.triangles[face].iter().position(|&v| v == 0).unwrap();
            state.corner_source[3 * face + k] = state.source_at(3 * 2, 0);
        }
        assert!(state.release_anchors().is_empty());
    }

    #[test]
    fn a_refused_edge_is_queued_again_only_after_a_collapse_within_two_edges() {
        let mesh = crate::procedural::torus(24, 12, 0.3);
        let options = SimplifyOptions::default();
        let (mut state, edges) = State::new(&mesh, &options);
        // Collapse 1 into 0, in place.
        let candidate = Candidate { cost: 0.0, survivor: 0, removed: 1, position: state.vertices[0].position };
        let legal = state.is_legal(&candidate).expect("a torus edge collapses");
        let log = vec![state.collapse(legal)];
        let d = distances(&state, 0);
        let alive = |e: &&[u32; 2]| e.iter().all(|&v| state.vertex_alive[v as usize]);
        let near = edges.iter().filter(alive).find(|e| d[e[0] as usize] == 2 && d[e[1] as usize] == 3).unwrap();
        let far = edges.iter().filter(alive).find(|e| d[e[0] as usize] >= 3 && d[e[1] as usize] >= 3).unwrap();
        let late = edges.iter().filter(alive).find(|e| d[e[0] as usize] == 1).unwrap();
        let mut retry = Retry::default();
        // Refused before the collapse (none made yet), and `late` once more after it.
        for e in [near, far, late] {
            retry.refused(e[0], e[1], 0);
        }
        retry.refused(late[1], late[0], 1);
        retry.prepare(&state, &log);
        assert!(retry.needs(near[1], near[0]), "two edges from the survivor: its checks may read what changed");
        assert!(!retry.needs(far[0], far[1]), "three edges away: refused with the same neighbourhood");
        assert!(!retry.needs(late[0], late[1]), "refused again after the collapse");
        let never = edges.iter().filter(alive).find(|e| ![near, far, late].contains(e)).unwrap();
        assert!(retry.needs(never[0], never[1]), "never refused");
    }
}
