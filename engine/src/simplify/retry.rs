//! Which edges a new pass queues again ([`super::run`]): when the queue runs dry before the
//! target, a candidate refused earlier may have become legal since, but only if a collapse changed
//! something its checks read. Those checks read the faces around its two ends, the corners and
//! normal cones of their neighbours and the faces across their far edges: everything within two
//! edges of the candidate's ends. So a candidate refused after the last collapse within two edges
//! of both its ends would be refused again, and the pass leaves it out. On small meshes that end
//! in refusals (a textured asset whose seams stop it above its target) the passes after the first
//! cost a quarter of the run; this leaves out about half of each later pass's edges (the rest
//! are near the few collapses those passes still find).
//!
//! Collapses only merge vertices, so a vertex within two edges of a survivor when it took its
//! collapse is within two edges of that survivor (or of the vertex it later went into) when the
//! pass ends: marking the current two-ring of each survivor's current vertex marks a superset of
//! what the collapse could have changed.

use crate::pm::CollapseRecord;

use super::kernel::State;
use super::vertex::NONE;

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
            for corner in &state.topo.fans[r as usize] {
                for x in [corner.next, corner.prev] {
                    mark(x);
                    for far in &state.topo.fans[x as usize] {
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

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use super::super::SimplifyOptions;
    use super::super::candidate::Candidate;
    use super::super::kernel::State;
    use super::super::vertex::NONE;
    use super::Retry;

    /// Edge distances from `from` over the live fans.
    fn distances(state: &State, from: u32) -> Vec<u32> {
        let mut d = vec![NONE; state.vertices.len()];
        d[from as usize] = 0;
        let mut queue = VecDeque::from([from]);
        while let Some(v) = queue.pop_front() {
            for corner in &state.topo.fans[v as usize] {
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
        let alive = |e: &&[u32; 2]| e.iter().all(|&v| state.topo.vertex_alive[v as usize]);
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
