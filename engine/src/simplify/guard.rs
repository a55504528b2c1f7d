//! The distance guard ([`super::SimplifyOptions::guard`]): what it measures with and the charge
//! it adds to a candidate's key.

use glam::DVec3;
use smallvec::SmallVec;

use crate::fan::FanSlot;
use crate::mesh::Mesh;

use super::topology::Topology;
use super::vertex::{NONE, VertexData, to_f64};

/// Marks a queue entry's `b` when its key includes the distance guard's term.
pub(super) const GUARDED: u32 = 1 << 31;

/// Input vertices each vertex answers for under the distance guard.
pub(super) const WITNESSES: usize = 8;

/// What the distance guard ([`SimplifyOptions::guard`]) measures with.
///
/// Input → result: each vertex keeps up to [`WITNESSES`] input vertices merged into it, the ones
/// farthest from its fan after its last collapse (at the start, itself); a candidate collapse is
/// charged the largest distance from the witnesses of both endpoints to the fan it would create.
///
/// Result → input: the distance from the new position and from the centroids of the new faces to
/// the input surface. A walk over the input's faces finds it first: from a face known to be near
/// (each vertex keeps one), each step goes to the edge neighbour closest to the probe while that
/// is closer. The walk can stop at a local minimum, so its distance is never below the true one:
/// where it is within the largest distance found so far it cannot change the charge and stands;
/// otherwise a closest-point tree over the input, seeded with the walk's face, gives the exact
/// distance. The charge is therefore exact, and most probes never reach the tree.
///
/// Bounded work per candidate whatever the reduction. Memory: the tree (56 bytes per input
/// triangle) and the face adjacency (12), and 48 bytes per input vertex.
pub(super) struct DistanceGuard {
    origin: Vec<[f32; 3]>,
    witnesses: Vec<[u32; WITNESSES]>,
    bvh: crate::bvh::TriangleBvh,
    /// The tree slots of the faces across the three edges of the face in each slot; NONE at a
    /// boundary or a non-manifold edge.
    across: Vec<[u32; 3]>,
    /// Per vertex, the tree slot of an input face near it (where walks start).
    hint: Vec<u32>,
}

/// Most steps a nearest-face walk takes (each is strictly closer; this only bounds the time).
const WALK_STEPS: usize = 64;

impl DistanceGuard {
    pub(super) fn new(mesh: &Mesh, fans: &[FanSlot]) -> Option<DistanceGuard> {
        let bvh = crate::bvh::TriangleBvh::new(mesh)?;
        let slots = bvh.slots_by_face(mesh.face_count());
        let hint = fans.iter().map(|f| f.first().map_or(NONE, |c| slots[c.face as usize])).collect();
        let witnesses = (0..mesh.vertex_count() as u32)
            .map(|v| {
                let mut w = [NONE; WITNESSES];
                w[0] = v;
                w
            })
            .collect();
        // The face across edge (u → v) of a face is the one at u whose corner comes back from v
        // (prev = v); found in u's fan, which holds the input's faces at this point. Left NONE
        // where the edge has no such face or more than one (boundary, non-manifold).
        let mut across = vec![[NONE; 3]; bvh.len()];
        for (f, t) in mesh.triangles.iter().enumerate() {
            let Some(&slot) = slots.get(f).filter(|&&s| s != NONE) else { continue };
            for i in 0..3 {
                let (u, v) = (t[i], t[(i + 1) % 3]);
                let mut back = fans[u as usize].iter().filter(|c| c.prev == v);
                if let (Some(c), None) = (back.next(), back.next()) {
                    across[slot as usize][i] = slots[c.face as usize];
                }
            }
        }
        Some(DistanceGuard { origin: mesh.positions.clone(), witnesses, bvh, across, hint })
    }

    /// The squared distance from `q` to the input surface where it matters: `walked` (a walk's
    /// result, never below the true distance) when that is within `worst` already, else the
    /// tree's exact answer.
    pub(super) fn exact(&self, q: DVec3, walked: f64, slot: u32, worst: f64) -> f64 {
        if walked <= worst {
            return walked;
        }
        self.bvh.closest_point(q, Some(slot)).distance_squared
    }

    /// The walk's nearest input face to `q` from the nearest of `starts` (NONE entries skipped):
    /// (squared distance, slot); (∞, NONE) without a start. Stops as soon as a face is within
    /// `enough` (squared): the caller only needs to know that.
    pub(super) fn nearest_face(&self, q: DVec3, starts: &[u32], enough: f64) -> (f64, u32) {
        let mut best = (f64::INFINITY, NONE);
        for &f in starts.iter().filter(|&&f| f != NONE) {
            let d = self.bvh.slot_distance_squared(q, f);
            if d < best.0 {
                best = (d, f);
                if d <= enough {
                    return best;
                }
            }
        }
        if best.1 == NONE {
            return best;
        }
        for _ in 0..WALK_STEPS {
            if best.0 <= enough {
                break;
            }
            let mut step = best;
            for &g in self.across[best.1 as usize].iter().filter(|&&g| g != NONE) {
                let d = self.bvh.slot_distance_squared(q, g);
                if d < step.0 {
                    step = (d, g);
                }
            }
            if step.1 == best.1 {
                break;
            }
            best = step;
        }
        best
    }

    /// The squared distance the guard charges for collapsing {a, b} to `p`: the larger of the
    /// farthest witness of `a` or `b` from the new fan (input → result) and the farthest of `p` and
    /// the new faces' centroids from the input surface (result → input).
    pub(crate) fn distance2(&self, topo: &Topology, vertices: &[VertexData], a: u32, b: u32, p: DVec3) -> f64 {
        let guard = self;
        let point = |v: u32| to_f64(vertices[v as usize].position);
        let mut far_edges: SmallVec<[(DVec3, DVec3); 16]> = SmallVec::new();
        let mut far_hints: SmallVec<[[u32; 2]; 16]> = SmallVec::new();
        for (v, other) in [(a, b), (b, a)] {
            for corner in &topo.fans[v as usize] {
                if !corner.touches(other) {
                    far_edges.push((point(corner.next), point(corner.prev)));
                    far_hints.push([corner.next, corner.prev].map(|x| guard.hint[x as usize]));
                }
            }
        }
        // Only the maximum matters: a witness with a face within `worst` cannot raise it, so its
        // search stops there, starting from the face that was nearest to the witness before.
        let mut worst: f64 = 0.0;
        let mut start = 0;
        let witnesses = guard.witnesses[a as usize].iter().chain(&guard.witnesses[b as usize]);
        for &w in witnesses.filter(|&&w| w != NONE) {
            let q = to_f64(guard.origin[w as usize]);
            let mut nearest = (f64::INFINITY, start);
            for k in (start..far_edges.len()).chain(0..start) {
                let (x, y) = far_edges[k];
                let d = (crate::bvh::closest_point_on_triangle(q, p, x, y) - q).length_squared();
                if d < nearest.0 {
                    nearest = (d, k);
                    if d <= worst {
                        break;
                    }
                }
            }
            worst = worst.max(nearest.0);
            start = nearest.1;
        }
        let (ha, hb) = (guard.hint[a as usize], guard.hint[b as usize]);
        let (d, near_p) = guard.nearest_face(p, &[ha, hb], worst);
        worst = worst.max(guard.exact(p, d, near_p, worst));
        for (&(px, py), &[hx, hy]) in far_edges.iter().zip(&far_hints) {
            let q = (p + px + py) / 3.0;
            let (d, f) = guard.nearest_face(q, &[near_p, hx, hy], worst);
            worst = worst.max(guard.exact(q, d, f, worst));
        }
        worst
    }

    /// After `a` took over a collapse: its witnesses become the [`WITNESSES`] of both endpoints'
    /// that are farthest from its new fan, and its hint the input face nearest to it.
    pub(crate) fn follow(&mut self, topo: &Topology, vertices: &[VertexData], a: u32, b: u32) {
        let guard = self;
        let point = |v: u32| to_f64(vertices[v as usize].position);
        let p = point(a);
        let far_edges: SmallVec<[(DVec3, DVec3); 16]> =
            topo.fans[a as usize].iter().map(|c| (point(c.next), point(c.prev))).collect();
        let mut ranked: SmallVec<[(f64, u32); 2 * WITNESSES]> = guard.witnesses[a as usize]
            .iter()
            .chain(&guard.witnesses[b as usize])
            .filter(|&&w| w != NONE)
            .map(|&w| (fan_distance2(to_f64(guard.origin[w as usize]), p, &far_edges), w))
            .collect();
        // Farthest first; equal distances by index, so the choice never depends on the order.
        ranked.sort_unstable_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        let mut kept = [NONE; WITNESSES];
        for (slot, &(_, w)) in kept.iter_mut().zip(&ranked) {
            *slot = w;
        }
        guard.witnesses[a as usize] = kept;
        guard.witnesses[b as usize] = [NONE; WITNESSES];
        let (ha, hb) = (guard.hint[a as usize], guard.hint[b as usize]);
        guard.hint[a as usize] = guard.nearest_face(p, &[ha, hb], 0.0).1;
        guard.hint[b as usize] = NONE;
    }
}

/// Squared distance from `q` to the nearest of the triangles (`p`, x, y) over `far_edges`
/// (infinite when there are none).
pub(super) fn fan_distance2(q: DVec3, p: DVec3, far_edges: &[(DVec3, DVec3)]) -> f64 {
    far_edges
        .iter()
        .map(|&(x, y)| (crate::bvh::closest_point_on_triangle(q, p, x, y) - q).length_squared())
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::super::kernel::State;
    use super::super::{AttributeWeights, SimplifyOptions};
    use crate::procedural;

    /// A distance term only adds to a key: the key a candidate gets at the top of the queue is
    /// never below the one it was queued with, the attribute quadrics' part included (a blob with
    /// normals that wander across it, no texture coordinates, so the fan-distance term applies).
    #[test]
    fn a_key_with_its_distance_term_keeps_the_attribute_quadrics() {
        let mut mesh = procedural::bumpy_blob(12, 20, 4);
        let normals = mesh.triangles.iter().flatten().map(|&v| {
            let [x, y, z] = mesh.positions[v as usize];
            let n = glam::Vec3::new(x + 0.4 * (5.0 * y).sin(), y, z + 0.4 * (4.0 * x).cos()).normalize();
            n.to_array()
        });
        mesh.corners.set_normals(Some(normals.collect()));
        let weights = AttributeWeights { uv: 0.0, normal: 1.0, color: 0.0 };
        for (name, options) in [
            ("fan-distance term", SimplifyOptions { attribute_weights: Some(weights), ..Default::default() }),
            ("distance guard", SimplifyOptions { attribute_weights: Some(weights), guard: 1.0, ..Default::default() }),
        ] {
            let (mut state, edges) = State::new(&mesh, &options);
            state.carry_attributes(&mesh);
            assert!(state.has_distance_term() && state.terms.wedges.is_some(), "{name}");
            let mut ranked = 0;
            for [a, b] in edges {
                let (Some(queued), Some((key, _))) = (state.entry(a, b), state.guarded_key(a, b)) else { continue };
                let queued = (queued.rank() >> 32) as u32;
                assert!(key >= queued, "{name}: edge {a}-{b}: key {key:#x} at the top, {queued:#x} queued");
                ranked += 1;
            }
            assert!(ranked > 500, "{name}: {ranked} edges");
        }
    }
}
