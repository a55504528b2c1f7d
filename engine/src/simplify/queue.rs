//! Queue keys: how an edge enters the priority queue ([`State::entry`], two at a time in the usual
//! case), and how a popped entry is known to be stale (version stamps). The queue itself is
//! `crate::queue`.

use crate::quadric::QuadricPair;
use crate::queue::{QueueEntry, TieredQueue, order_key};

use super::guard::GUARDED;
use super::kernel::State;
use super::options::{Metric, Placement};
use super::placement::Choice;
use super::vertex::VertexKind;
use super::vertex::{NONE, to_f64};

impl State<'_> {
    pub(super) fn push_edges_of(&mut self, v: u32, heap: &mut TieredQueue, neighbours: &mut Vec<u32>) {
        self.push_edges_above(v, 0, heap, neighbours);
    }

    /// [`State::push_edges_of`] for the neighbours numbered `from` or above: a rebuild of the whole
    /// queue passes `v + 1`, so that each edge is queued once (twice, its two entries would pop
    /// one after the other and be checked twice).
    pub(super) fn push_edges_above(&mut self, v: u32, from: u32, heap: &mut TieredQueue, neighbours: &mut Vec<u32>) {
        self.push_edges_where(v, from, heap, neighbours, |_| true);
    }

    /// [`State::push_edges_above`] for the neighbours `keep` accepts.
    #[inline]
    pub(super) fn push_edges_where(
        &mut self,
        v: u32,
        from: u32,
        heap: &mut TieredQueue,
        neighbours: &mut Vec<u32>,
        keep: impl Fn(u32) -> bool,
    ) {
        // Unique neighbours by mark stamps (no sort: the heap's total order makes push order moot).
        // Written unconditionally and kept by advancing the count: whether a corner's vertex was
        // seen already is as good as random (each is seen twice around an interior vertex).
        let stamp = self.next_stamp();
        let fan = &self.topo.fans[v as usize];
        neighbours.clear();
        neighbours.resize(2 * fan.len(), NONE);
        let mut count = 0;
        for c in fan {
            for u in [c.next, c.prev] {
                let mark = &mut self.scratch.mark[u as usize];
                neighbours[count] = u;
                count += ((*mark != stamp) & (u >= from) && keep(u)) as usize;
                *mark = stamp;
            }
        }
        neighbours.truncate(count);
        let mut pairs = neighbours.chunks_exact(2);
        for pair in &mut pairs {
            for entry in self.entry_pair(v, [pair[0], pair[1]]).into_iter().flatten() {
                heap.push(entry);
            }
        }
        for &u in pairs.remainder() {
            self.push_edge(v, u, heap);
        }
    }

    /// [`State::entry`] of edges {v, us[0]} and {v, us[1]}: in the usual case (interior ends, a
    /// quadric cost, optimal placement, not one end on a seam and the other off it, which
    /// [`State::choose`] keeps in place) both quadric sums are minimised side by side
    /// ([`QuadricPair`]); an edge outside it, or whose minimiser is refused, is ranked alone. The
    /// same keys to the bit: the pair performs the scalar operations lane by lane, and the sums,
    /// the midpoint, the squared edge length and the normals' dot product do not depend on which
    /// end comes first.
    #[inline]
    pub(super) fn entry_pair(&self, v: u32, us: [u32; 2]) -> [Option<QueueEntry>; 2] {
        let vv = &self.vertices[v as usize];
        let (v0, v1) = (&self.vertices[us[0] as usize], &self.vertices[us[1] as usize]);
        // (The attribute quadrics need the wedges: an edge with them is ranked alone.)
        let quadric_cost = self.config.options.metric != Metric::Melax
            && self.config.options.placement == Placement::Optimal
            && self.terms.wedges.is_none();
        let interior = quadric_cost & (vv.kind == VertexKind::Interior);
        let free =
            |u: u32| self.seams.on_seam.is_empty() || self.seams.on_seam[v as usize] == self.seams.on_seam[u as usize];
        let usual = [
            interior & (v0.kind == VertexKind::Interior) && free(us[0]),
            interior & (v1.kind == VertexKind::Interior) && free(us[1]),
        ];
        if !(usual[0] || usual[1]) {
            return [self.entry(v, us[0]), self.entry(v, us[1])];
        }
        let pair = QuadricPair::sums(&vv.quadric, [&v0.quadric, &v1.quadric]);
        let (points, solved) = pair.minimizers();
        let errors = pair.errors(points);
        let pv = to_f64(vv.position);
        let mut out = [None; 2];
        for (i, vu) in [v0, v1].into_iter().enumerate() {
            let pu = to_f64(vu.position);
            let length2 = (pv - pu).length_squared();
            let near = (points[i] - (pv + pu) * 0.5).length_squared() <= length2;
            out[i] = if usual[i] && solved[i] && near {
                let (a, b) = (v.min(us[i]), v.max(us[i]));
                let cost = self.ranked_cost(errors[i], vv.quadric.weight + vu.quadric.weight);
                let key = order_key(cost * self.normal_factor(vv, vu), errors[i], length2);
                Some(QueueEntry::new(key, a, b, self.stamp(a, b)))
            } else {
                self.entry(v, us[i])
            };
        }
        out
    }

    pub(super) fn push_edge(&self, a: u32, b: u32, heap: &mut TieredQueue) {
        if let Some(entry) = self.entry(a, b) {
            heap.push(entry);
        }
    }

    pub(super) fn entry(&self, a: u32, b: u32) -> Option<QueueEntry> {
        let (a, b) = (a.min(b), a.max(b));
        let choice = self.choose(a, b)?;
        let (va, vb) = (&self.vertices[a as usize], &self.vertices[b as usize]);
        let length2 = (to_f64(va.position) - to_f64(vb.position)).length_squared();
        let cost = self.ranked_cost(choice.cost, va.quadric.weight + vb.quadric.weight);
        Some(QueueEntry::new(order_key(cost, choice.error, length2), a, b, self.stamp(a, b)))
    }

    /// Whether neither endpoint of `entry` changed since it was queued.
    #[inline]
    pub(super) fn is_current(&self, entry: &QueueEntry) -> bool {
        self.stamp(entry.a(), entry.b & !GUARDED) == entry.stamp
    }

    /// Sum of the version stamps of `a` and `b` (see [`QueueEntry::stamp`]).
    #[inline]
    pub(super) fn stamp(&self, a: u32, b: u32) -> u32 {
        self.topo.version[a as usize].wrapping_add(self.topo.version[b as usize])
    }

    /// The queue key of edge {a, b} with its distance term added (the distance guard's when it is
    /// on, else the fan-distance term): never below the key [`State::entry`] gives it, which
    /// leaves the term out; with the choice it was computed for. The attribute quadrics' part of
    /// the choice's cost stays in the key.
    pub(super) fn guarded_key(&self, a: u32, b: u32) -> Option<(u32, Choice)> {
        let choice = self.choose(a, b)?;
        let (va, vb) = (&self.vertices[a as usize], &self.vertices[b as usize]);
        let area = va.quadric.weight + vb.quadric.weight;
        let factor = self.normal_factor(va, vb);
        let length2 = (to_f64(va.position) - to_f64(vb.position)).length_squared();
        let (weight, d2) = match &self.terms.guard {
            Some(guard) => {
                (self.config.options.guard, guard.distance2(&self.topo, &self.vertices, a, b, choice.position))
            }
            None => (self.terms.fan_term, self.moved_fan_distance2(a, b, choice.position)),
        };
        // The cost before the normal factor: the quadric error, plus the attribute quadrics' error
        // where they are on (their cost is `(error + attributes) · factor`).
        let cost = match self.terms.wedges {
            Some(_) if factor > 0.0 => choice.cost / factor,
            _ => choice.error,
        };
        Some((order_key((self.ranked_cost(cost, area) + weight * d2) * factor, choice.error, length2), choice))
    }
}

#[cfg(test)]
mod tests {
    use super::super::kernel::State;
    use super::super::{Placement, SimplifyOptions};
    use crate::procedural;

    /// With a distance term (the default) an edge's key is its key under the paper's cost (the term
    /// off) over the area behind the merged quadric: a mean squared distance, which the term's own
    /// squared distance adds to; the collapse chosen is the same.
    #[test]
    fn with_a_distance_term_keys_are_per_unit_area() {
        let mesh = procedural::bumpy_blob(12, 20, 4);
        let defaults = SimplifyOptions::default();
        let paper = SimplifyOptions { distance_term: 0.0, ..defaults.clone() };
        let (per_area, _) = State::new(&mesh, &defaults);
        let (summed, edges) = State::new(&mesh, &paper);
        let cost = |entry: Option<crate::queue::QueueEntry>| {
            f32::from_bits((entry.expect("ranked").rank() >> 32) as u32 & 0x7fff_ffff)
        };
        let mut ranked = 0;
        for [a, b] in edges {
            let area = summed.vertices[a as usize].quadric.weight + summed.vertices[b as usize].quadric.weight;
            let (key, paper_key) = (cost(per_area.entry(a, b)), cost(summed.entry(a, b)));
            assert!(area > 0.0 && paper_key > 0.0, "edge {a}-{b}: a curved blob has no flat collapse");
            let expected = (paper_key as f64 / area) as f32;
            assert!((key - expected).abs() <= 1e-6 * expected, "edge {a}-{b}: {key} for {expected}");
            assert_eq!(per_area.evaluate(a, b).map(|c| c.position), summed.evaluate(a, b).map(|c| c.position));
            ranked += 1;
        }
        assert!(ranked > 500, "{ranked} edges");
    }

    /// Every pair of edges from one vertex, ranked side by side, gets the keys each gets alone: on
    /// a smooth blob, and on the same blob whose upper and lower halves carry different normals
    /// (a seam round its middle, where an edge from a seam vertex to one off the seam keeps the
    /// seam end in place).
    #[test]
    fn ranking_two_edges_side_by_side_gives_the_keys_of_one_at_a_time() {
        let blob = procedural::bumpy_blob(12, 20, 4);
        let mut halves = blob.clone();
        let normals = (0..halves.face_count())
            .flat_map(|f| {
                let upper = halves.triangle_points(f).iter().map(|p| p.z).sum::<f64>() > 0.0;
                [[0.0, 0.0, if upper { 1.0 } else { -1.0 }]; 3]
            })
            .collect();
        halves.corners.set_normals(Some(normals));
        // (As `simplify` resolves `Auto` for a mesh without texture coordinates.)
        let options = SimplifyOptions { placement: Placement::Optimal, ..Default::default() };
        let mut seam_pairs = 0;
        for (name, mesh) in [("blob", blob), ("two-chart blob", halves)] {
            let (mut state, _) = State::new(&mesh, &options);
            state.carry_attributes(&mesh);
            let mut ring = Vec::new();
            for v in 0..mesh.vertex_count() as u32 {
                state.neighbours(v, &mut ring);
                for pair in ring.windows(2) {
                    let together = state.entry_pair(v, [pair[0], pair[1]]);
                    let alone = [state.entry(v, pair[0]), state.entry(v, pair[1])];
                    assert_eq!(together, alone, "{name}: vertex {v}, neighbours {pair:?}");
                    let on_seam = |u: u32| state.seams.on_seam.get(u as usize).copied().unwrap_or(false);
                    seam_pairs += pair.iter().any(|&u| on_seam(u) != on_seam(v)) as usize;
                }
            }
        }
        assert!(seam_pairs > 0, "edges from a seam vertex to one off the seam were ranked");
    }
}
