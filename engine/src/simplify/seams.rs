//! The per-corner values a run carries, owned by one part of the state ([`SeamCarrier`]): the
//! input's values, which input corner each current corner takes its values from, which vertices
//! sit on a seam, and the journal the progressive mesh's splits restore values from. Rule 7 (no
//! value crosses a seam) reads it.

use crate::fan::Corner;
use crate::mesh::CornerAttributes;

use super::topology::Topology;
use super::vertex::NONE;

/// The values carried through the collapses. Empty when the input has none (the collapse then
/// pays nothing for them).
#[derive(Default)]
pub(crate) struct SeamCarrier {
    /// The input's values.
    pub(crate) attributes: CornerAttributes,
    /// Per input corner, a number shared exactly by the corners of its vertex with the same
    /// values ([`CornerAttributes::value_ids`]): every comparison of values is between corners of
    /// one vertex (a corner's values are always its vertex's own).
    pub(crate) value_id: Vec<u32>,
    /// For each current corner (3 per face), the input corner whose values it has.
    pub(crate) corner_source: Vec<u32>,
    /// Per vertex: whether it has two sets of values (on a seam). Rule 7 lets such a vertex go
    /// only into another on the seam, so with one end on a seam, the ranking keeps that end in
    /// place (`State::choose`) rather than picking a collapse rule 7 refuses.
    pub(crate) on_seam: Vec<bool>,
    /// With a progressive mesh to record: per collapse, the corners of the removed vertex that
    /// took new values, as (face, the input corner whose values it had before), and where each
    /// collapse's entries end. The vertex splits restore them.
    pub(crate) journal: Vec<(u32, u32)>,
    pub(crate) journal_ends: Vec<u32>,
}

impl SeamCarrier {
    /// Whether input corners `x` and `y`, of the same vertex, carry the same values.
    #[inline]
    pub(crate) fn same_values(&self, x: u32, y: u32) -> bool {
        self.value_id[x as usize] == self.value_id[y as usize]
    }

    /// The input corner whose values vertex `v` has in face `f`.
    pub(crate) fn source_at(&self, topo: &Topology, f: u32, v: u32) -> u32 {
        let k = topo.triangles[f as usize].iter().position(|&x| x == v).expect("v is a corner of f");
        self.corner_source[3 * f as usize + k]
    }

    /// Rule 7 for collapsing `b` into `a` over the faces `dead` (one or two) of their edge: the
    /// values each of b's corners takes, as `(b's values, a's values)` pairs for the first and the
    /// second side; `None` when the collapse would carry values across a seam. With one set of
    /// values at b, both sides map it to a's values in the edge's faces, which must agree. With two
    /// (b on a seam) the edge must have two faces that differ at b, each side maps to a's values
    /// in its face, and those must differ too (a on the same seam). More than two: refused.
    pub(crate) fn seam_sides(&self, topo: &Topology, a: u32, b: u32, dead: &[u32]) -> Option<[(u32, u32); 2]> {
        let same = |x: u32, y: u32| self.same_values(x, y);
        let b_first = self.source_at(topo, dead[0], b);
        let a_first = self.source_at(topo, dead[0], a);
        let mut b_other = NONE;
        // (A vertex off the seams has one set of values: nothing to look for.)
        let fan: &[Corner] = if self.on_seam[b as usize] { &topo.fans[b as usize] } else { &[] };
        for corner in fan {
            let s = self.source_at(topo, corner.face, b);
            if same(s, b_first) {
                continue;
            }
            if b_other == NONE {
                b_other = s;
            } else if !same(s, b_other) {
                return None;
            }
        }
        if b_other == NONE {
            // One set at b: a's values must be one across the edge's faces.
            if let Some(&second) = dead.get(1)
                && !same(self.source_at(topo, second, a), a_first)
            {
                return None;
            }
            return Some([(b_first, a_first), (b_first, a_first)]);
        }
        let &[_, second] = dead else { return None };
        let (b_second, a_second) = (self.source_at(topo, second, b), self.source_at(topo, second, a));
        if same(b_second, b_first) || same(a_second, a_first) {
            return None;
        }
        Some([(b_first, a_first), (b_second, a_second)])
    }

    /// Rule 7 in texture space: every face that b keeps (not in `dead`), with b's texture
    /// coordinates replaced as `sides` says, keeps the orientation and a non-zero area of its
    /// texture-space triangle (a flipped one would show the texture mirrored). True without
    /// texture coordinates.
    pub(crate) fn texture_keeps_orientation(
        &self,
        topo: &Topology,
        b: u32,
        dead: &[u32; 2],
        sides: [(u32, u32); 2],
    ) -> bool {
        let Some(uv) = &self.attributes.uvs() else { return true };
        let [(b_first, a_first), (_, a_second)] = sides;
        let area = |s: [u32; 3]| {
            let [p, q, r] = s.map(|k| uv[k as usize].map(f64::from));
            (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
        };
        topo.fans[b as usize].iter().filter(|c| c.face != dead[0] && c.face != dead[1]).all(|c| {
            let f = c.face as usize;
            let k = topo.triangles[f].iter().position(|&x| x == b).expect("b is a corner of its faces");
            let mut sources = [0, 1, 2].map(|i| self.corner_source[3 * f + i]);
            let before = area(sources);
            let first = self.same_values(sources[k], b_first);
            sources[k] = if first { a_first } else { a_second };
            let after = area(sources);
            // A face without texture-space area has no orientation to keep.
            before == 0.0 || after * before > 0.0
        })
    }
}
