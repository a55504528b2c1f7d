//! The appearance term of a collapse's cost: how far the values that the moved corners take are
//! from what the faces' own attribute fields give at the merged vertex's position.
//!
//! Each face that survives around the removed vertex b (and, if the survivor moves, around a)
//! has a linear field of texture coordinates, normals and colours over its plane, set by its
//! corners' values. After the collapse its corner at b sits at the new position p and carries
//! the survivor's value on that side (rule 7). The term is, over those faces, the face's area
//! times the weighted squared difference between that value and the face's field at p: zero
//! where the attributes vary linearly across the collapse (an undistorted chart), large where
//! the collapse would stretch or fold the texture or bend a normal. It is memoryless (each
//! collapse is charged what it does to the current faces), in the spirit of Hoppe's
//! appearance-preserving attribute error and meshoptimizer's attribute metric, at the cost of one
//! pass over the two fans.

use glam::DVec3;

use super::kernel::{NONE, State};
use crate::appearance::barycentric;

impl State<'_> {
    /// The appearance term of collapsing `b` into `a` at `p` (0 without attributes, without
    /// weights, or when rule 7 refuses the collapse: the legality check says so later).
    pub(super) fn attribute_error(&self, a: u32, b: u32, p: DVec3) -> f64 {
        let weights = self.attribute_weights;
        if self.corner_source.is_empty() || weights == [0.0; 3] {
            return 0.0;
        }
        let (shared, count) = self.edge_corners(a, b);
        if count == 0 || count > 2 {
            return 0.0;
        }
        let dead = [shared[0].face, if count == 2 { shared[1].face } else { NONE }];
        let Some(sides) = self.seam_sides(a, b, &dead[..count]) else { return 0.0 };
        let mut total = 0.0;
        let moved = p != self.point(a);
        for (v, other) in [(b, a), (a, b)] {
            if v == a && !moved {
                break;
            }
            let pv = self.point(v);
            for corner in &self.fans[v as usize] {
                if corner.face == dead[0] || corner.face == dead[1] || corner.touches(other) {
                    continue;
                }
                let (x, y) = (corner.next, corner.prev);
                let (px, py) = (self.point(x), self.point(y));
                let area = 0.5 * (px - pv).cross(py - pv).length();
                let Some(w) = barycentric(p, [pv, px, py]) else { continue };
                let f = corner.face;
                let sv = self.source_at(f, v);
                let (sx, sy) = (self.source_at(f, x), self.source_at(f, y));
                // The value the corner carries after the collapse.
                let carried = if v == a {
                    sv
                } else if self.same_values(sv, sides[0].0) {
                    sides[0].1
                } else {
                    sides[1].1
                };
                total += area * self.value_gap(carried, [sv, sx, sy], w);
            }
        }
        total
    }

    /// Weighted squared difference between value `carried` and the field through `corners` at
    /// barycentric `w`.
    fn value_gap(&self, carried: u32, corners: [u32; 3], w: [f64; 3]) -> f64 {
        fn gap<const N: usize>(values: &[[f32; N]], carried: u32, corners: [u32; 3], w: [f64; 3]) -> f64 {
            let at = |k: u32| values[k as usize].map(f64::from);
            let (c, [p, q, r]) = (at(carried), corners.map(at));
            (0..N).map(|i| (c[i] - (w[0] * p[i] + w[1] * q[i] + w[2] * r[i])).powi(2)).sum()
        }
        let [wu, wn, wc] = self.attribute_weights;
        let a = &self.attributes;
        a.uvs.as_deref().map_or(0.0, |v| wu * gap(v, carried, corners, w))
            + a.normals.as_deref().map_or(0.0, |v| wn * gap(v, carried, corners, w))
            + a.colors.as_deref().map_or(0.0, |v| wc * gap(v, carried, corners, w))
    }
}
