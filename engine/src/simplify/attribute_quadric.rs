//! Attribute quadrics per wedge: the appearance part of a collapse's cost.
//!
//! A wedge is one set of values (texture coordinates, normal, colour) at a vertex: a vertex inside
//! a chart has one, a seam vertex two, a vertex where seams meet more. Every face has a linear
//! field of each attribute over its plane, `s(p) = g·p + d`, set by its corners' values. A wedge's
//! quadric sums, over the faces of its corners (area-weighted, and over the weighted dimensions
//! of the values), `(g·p + d − s)²`: how far a value `s` at position `p` is from what those faces'
//! fields give there. It is a quadric in `(p, s)` stored as a position quadric plus, per
//! dimension, the sums of `g` and `d`, so `error(p, s) = pᵀAp + 2b·p + c + Σₖ (W sₖ² − 2 sₖ
//! (Gₖ·p + Dₖ))` (Hoppe 1999's attribute quadrics with the values fixed, as meshoptimizer
//! keeps them).
//!
//! A collapse of b into a maps each of b's wedges to a's wedge on the same side (rule 7), and the
//! cost pays the sum of the two wedges' quadrics at the merged position with the survivor's
//! values; the collapse adds b's wedge quadric into a's. So a chart that the collapses have
//! stretched remembers it (the memoryless term tried before forgot every earlier collapse:
//! docs/attributes-report.md). The wedges of a vertex never change: a's values are its own, and
//! b's corners take a's.

use glam::DVec3;

use super::seams::SeamCarrier;
use super::topology::Topology;
use super::vertex::NONE;
use crate::mesh::Mesh;

/// At most two texture coordinates, three normal and four colour dimensions.
const MAX_DIMS: usize = 9;
/// The position part: a00 a01 a02 a11 a12 a22, b0 b1 b2, c, and the summed weight W.
const BASE: usize = 11;
const MAX_ROW: usize = BASE + 4 * MAX_DIMS;
/// Below this fraction of the size of its terms, an error is rounding ([`WedgeQuadrics::error`]).
const RELATIVE_NOISE: f64 = 1e-9;

/// The wedges of a run and their quadrics.
#[derive(Debug, Default)]
pub(crate) struct WedgeQuadrics {
    dims: usize,
    stride: usize,
    /// Per wedge, its quadric (`stride` numbers).
    rows: Vec<f64>,
    /// Per wedge, its values (`dims` numbers), each scaled by the square root of its weight.
    values: Vec<f64>,
    /// Per input corner, its wedge.
    wedge_of: Vec<u32>,
    /// Per vertex, its wedge when it has one; [`NONE`] when it has more.
    single: Vec<u32>,
}

impl WedgeQuadrics {
    /// The wedges of `mesh` (its corners numbered by `value_id`, [`crate::mesh::CornerAttributes::
    /// value_ids`]) and their quadrics, each attribute weighted by `weights` (uv, normal, colour;
    /// already in the quadric's units). `None` when no weighted attribute is present.
    pub(super) fn new(mesh: &Mesh, value_id: &[u32], weights: [f64; 3]) -> Option<WedgeQuadrics> {
        let c = &mesh.corners;
        let scale = weights.map(|w| if w.is_finite() && w > 0.0 { w.sqrt() } else { 0.0 });
        let uv = c.uvs().map(Vec::as_slice).filter(|_| scale[0] > 0.0);
        let normal = c.normals().map(Vec::as_slice).filter(|_| scale[1] > 0.0);
        let color = c.colors().map(Vec::as_slice).filter(|_| scale[2] > 0.0);
        let dims = uv.map_or(0, |_| 2) + normal.map_or(0, |_| 3) + color.map_or(0, |_| 4);
        if dims == 0 {
            return None;
        }
        let stride = BASE + 4 * dims;
        let corner_count = value_id.len();
        let mut wedge_of = vec![NONE; corner_count];
        let mut values = Vec::new();
        let mut single = vec![NONE; mesh.vertex_count()];
        let mut wedge_count = 0u32;
        // (While counting: a vertex seen with two wedges.)
        const SEVERAL: u32 = NONE - 1;
        for (k, &v) in mesh.triangles.iter().flatten().enumerate() {
            // A corner's number is the first corner of its vertex with its values.
            let first = value_id[k] as usize;
            if first == k {
                wedge_of[k] = wedge_count;
                wedge_count += 1;
                let row = values.len();
                values.extend(uv.iter().flat_map(|u| u[k]).map(|x| f64::from(x) * scale[0]));
                values.extend(normal.iter().flat_map(|n| n[k]).map(|x| f64::from(x) * scale[1]));
                values.extend(color.iter().flat_map(|x| x[k]).map(|x| f64::from(x) * scale[2]));
                debug_assert_eq!(values.len() - row, dims);
            } else {
                wedge_of[k] = wedge_of[first];
            }
            let slot = &mut single[v as usize];
            *slot = if *slot == NONE || *slot == wedge_of[k] { wedge_of[k] } else { SEVERAL };
        }
        for slot in &mut single {
            if *slot == SEVERAL {
                *slot = NONE;
            }
        }
        let mut rows = vec![0.0; wedge_count as usize * stride];
        let mut face = [0.0; MAX_ROW];
        for f in 0..mesh.face_count() {
            let [p0, p1, p2] = mesh.triangle_points(f);
            let (e1, e2) = (p1 - p0, p2 - p0);
            let area = 0.5 * e1.cross(e2).length();
            let (a, b, cc) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let det = a * cc - b * b;
            if !(area > 0.0 && det > 1e-12 * a * cc) {
                continue; // no plane to spread values over
            }
            face[..stride].fill(0.0);
            face[10] = area;
            let wedges = [0, 1, 2].map(|i| wedge_of[3 * f + i] as usize);
            for dim in 0..dims {
                let s = wedges.map(|w| values[w * dims + dim]);
                let (d1, d2) = (s[1] - s[0], s[2] - s[0]);
                // The gradient in the face's plane: g·e1 = d1, g·e2 = d2.
                let g = (e1 * (cc * d1 - b * d2) + e2 * (a * d2 - b * d1)) / det;
                let d = s[0] - g.dot(p0);
                let (gw, dw) = (g * area, d * area);
                add_outer(&mut face, g, gw, d, dw);
                let at = BASE + 4 * dim;
                face[at] += gw.x;
                face[at + 1] += gw.y;
                face[at + 2] += gw.z;
                face[at + 3] += dw;
            }
            for w in wedges {
                for (r, x) in rows[w * stride..(w + 1) * stride].iter_mut().zip(&face[..stride]) {
                    *r += x;
                }
            }
        }
        Some(WedgeQuadrics { dims, stride, rows, values, wedge_of, single })
    }

    fn row(&self, w: u32) -> &[f64] {
        &self.rows[w as usize * self.stride..(w as usize + 1) * self.stride]
    }

    /// The summed quadric of wedges `x` and `y` at position `p` with the values of wedge `at`.
    fn pair_error(&self, x: u32, y: u32, p: DVec3, at: u32) -> f64 {
        let (qx, qy) = (self.row(x), self.row(y));
        let mut q = [0.0; MAX_ROW];
        for ((s, a), b) in q.iter_mut().zip(qx).zip(qy) {
            *s = a + b;
        }
        self.error(&q, p, at)
    }

    /// `error(p, s)` of quadric row `q` with the values of wedge `at`.
    #[inline]
    fn error(&self, q: &[f64; MAX_ROW], p: DVec3, at: u32) -> f64 {
        let (x, y, z) = (p.x, p.y, p.z);
        let mut e = x * (q[0] * x + 2.0 * (q[1] * y + q[2] * z + q[6]))
            + y * (q[3] * y + 2.0 * (q[4] * z + q[7]))
            + z * (q[5] * z + 2.0 * q[8])
            + q[9];
        let s = &self.values[at as usize * self.dims..(at as usize + 1) * self.dims];
        let mut size = q[9].abs();
        for (k, &sk) in s.iter().enumerate() {
            let g = &q[BASE + 4 * k..BASE + 4 * k + 4];
            let w = q[10] * sk * sk;
            size += w;
            e += w - 2.0 * sk * (g[0] * x + g[1] * y + g[2] * z + g[3]);
        }
        // What is left of terms this size after they cancel is rounding: a field that is exactly
        // linear across the collapse costs nothing, so ties keep the position quadric's order.
        if e > RELATIVE_NOISE * size { e } else { 0.0 }
    }

    /// Adds wedge `from`'s quadric into wedge `into`'s.
    fn absorb(&mut self, into: u32, from: u32) {
        let stride = self.stride;
        let (into, from) = (into as usize * stride, from as usize * stride);
        for i in 0..stride {
            self.rows[into + i] += self.rows[from + i];
        }
    }
}

/// Adds `(g·p + d)²` weighted (the weighted factors `gw`, `dw` given) to the position part.
fn add_outer(q: &mut [f64; MAX_ROW], g: DVec3, gw: DVec3, d: f64, dw: f64) {
    q[0] += gw.x * g.x;
    q[1] += gw.x * g.y;
    q[2] += gw.x * g.z;
    q[3] += gw.y * g.y;
    q[4] += gw.y * g.z;
    q[5] += gw.z * g.z;
    q[6] += gw.x * d;
    q[7] += gw.y * d;
    q[8] += gw.z * d;
    q[9] += dw * d;
}

impl WedgeQuadrics {
    /// The appearance part of collapsing `b` into `a` at `p`: over each pair of b's wedge and the
    /// wedge of a it goes into, their summed quadric at `p` with a's values (0 without attribute
    /// quadrics). A collapse that rule 7 refuses gets some number: the legality check refuses it.
    #[inline]
    pub(crate) fn attribute_error(&self, topo: &Topology, seams: &SeamCarrier, a: u32, b: u32, p: DVec3) -> f64 {
        let q = self;
        let (wa, wb) = (q.single[a as usize], q.single[b as usize]);
        if wa != NONE && wb != NONE {
            return q.pair_error(wa, wb, p, wa);
        }
        // A seam or an anchor: the pairs are the two ends' wedges in the edge's faces.
        let (shared, count) = topo.edge_corners(a, b);
        let mut total = 0.0;
        let mut last = (NONE, NONE);
        for corner in &shared[..count.min(2)] {
            let f = corner.face;
            let pair =
                (q.wedge_of[seams.source_at(topo, f, a) as usize], q.wedge_of[seams.source_at(topo, f, b) as usize]);
            if pair != last {
                total += q.pair_error(pair.0, pair.1, p, pair.0);
                last = pair;
            }
        }
        total
    }

    /// After rule 7's mapping `sides` of b's values (input corners) to a's: each of b's wedge
    /// quadrics added into the wedge of a it went into.
    pub(crate) fn merge(&mut self, sides: [(u32, u32); 2]) {
        let q = self;
        let pairs = sides.map(|(b, a)| (q.wedge_of[a as usize], q.wedge_of[b as usize]));
        q.absorb(pairs[0].0, pairs[0].1);
        if pairs[1] != pairs[0] {
            q.absorb(pairs[1].0, pairs[1].1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A terrain with texture coordinates that vary non-linearly over it.
    fn textured_terrain() -> Mesh {
        let mut mesh = crate::procedural::terrain(12, 7);
        let uvs = mesh.triangles.iter().flatten().map(|&v| {
            let [x, y, z] = mesh.positions[v as usize];
            [x * x + 0.3 * y, (y * 3.0).sin() + z]
        });
        mesh.corners.set_uvs(Some(uvs.collect()));
        mesh
    }

    #[test]
    fn a_wedge_is_exact_at_its_own_vertex_and_charges_a_value_change_by_its_area() {
        let mesh = textured_terrain();
        let ids = mesh.corners.value_ids(&mesh.triangles, mesh.vertex_count());
        let q = WedgeQuadrics::new(&mesh, &ids, [4.0, 0.0, 0.0]).expect("texture coordinates are weighted");
        assert_eq!(q.dims, 2);
        for (v, &w) in q.single.iter().enumerate() {
            assert_ne!(w, NONE, "one set of values per vertex");
            let mut row = [0.0; MAX_ROW];
            row[..q.stride].copy_from_slice(q.row(w));
            let p = mesh.point(v as u32);
            let area = row[10];
            assert!(area > 0.0);
            let scale = row[..10].iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(q.error(&row, p, w) <= 1e-9 * scale, "vertex {v}: {}", q.error(&row, p, w));
            // Every face field through the vertex gives its values: shifting them by δ (in each of
            // two dimensions, scaled by √4) costs W · 4 · 2δ².
            let delta = 0.01;
            let mut shifted = WedgeQuadrics { values: q.values.clone(), ..Default::default() };
            shifted.dims = q.dims;
            for k in 0..q.dims {
                shifted.values[w as usize * q.dims + k] += 2.0 * delta;
            }
            let expected = area * 4.0 * 2.0 * delta * delta;
            let got = shifted.error(&row, p, w);
            assert!((got - expected).abs() <= 1e-6 * expected + 1e-9 * scale, "vertex {v}: {got} vs {expected}");
        }
    }
}
