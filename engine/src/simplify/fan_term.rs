//! The fan-distance term ([`super::SimplifyOptions::distance_term`]), on by default: how far a
//! collapse moves the surface, estimated from the faces it moves alone (no search of the input).
//! It is measured once a run has removed 70% of the input's faces ([`FAN_TERM_FROM`]).

use glam::DVec3;

use super::kernel::State;
use super::vertex::VertexKind;

/// The share of the input's faces a run removes before the fan-distance term is measured: the
/// collapses before rank by their quadric error per unit of area alone. On a dense mesh those
/// early collapses move the surface so little that the term changes little but their order, and
/// measuring it costs a second queue pop and a fan walk per collapse. A share of the input rather
/// than of the way to the target keeps the collapse order the same whatever the target, so that a
/// progressive mesh's levels are the meshes a run straight to their face count gives. Measured
/// beside meshoptimizer's and MeshLab's error over the shared meshes and the corpus, and beside
/// meshoptimizer's time (docs/benchmarks.md).
pub const FAN_TERM_FROM: f64 = 0.7;

impl State<'_> {
    /// The squared distance the fan-distance term charges for collapsing {a, b} to `p`: the
    /// largest of, over the faces that move (corner v → p, far edge x y, both endpoints' faces
    /// off the edge),
    /// - result → current surface: the distance from the moved face's new centroid to the plane
    ///   of the face it was, `|n_old·(p − v)| / 3`;
    /// - current surface → result: per endpoint v, the distance from its position to the nearest
    ///   of the planes of its moved faces, `min |n_new·(v − p)|` (v's departure from the new fan,
    ///   where the fan is flat enough for a plane to stand for it);
    /// - along a border, for a collapse of two border vertices: how far each endpoint is from the
    ///   border's new line (its neighbours across the border, c and d, joined through p), its
    ///   square weighed [`BORDER_WEIGHT`] times: the faces alone do not see a border cut across a
    ///   bend (a move within their planes), which lays faces over the hole beside it (a small
    ///   hole's border loop cut to a few chords).
    ///
    /// Only the moved faces are read, all of which [`State::is_legal`] reads next anyway. Zero for
    /// a collapse that leaves the surface where it was (a flat neighbourhood, a move along a
    /// straight boundary); never looks at the input, so it does not see error that earlier
    /// collapses left (the quadric does).
    pub(super) fn moved_fan_distance2(&self, a: u32, b: u32, p: DVec3) -> f64 {
        let mut worst: f64 = 0.0;
        for (v, other) in [(a, b), (b, a)] {
            let pv = self.point(v);
            let (moved, departure) = (p - pv, pv - p);
            let mut nearest = f64::INFINITY;
            for corner in &self.topo.fans[v as usize] {
                if corner.touches(other) {
                    continue;
                }
                let (px, py) = (self.point(corner.next), self.point(corner.prev));
                let n_old = (px - pv).cross(py - pv);
                let n_new = (px - p).cross(py - p);
                let (o2, n2) = (n_old.length_squared(), n_new.length_squared());
                if o2 > 0.0 {
                    let d = n_old.dot(moved);
                    worst = worst.max(d * d / (9.0 * o2));
                }
                if n2 > 0.0 {
                    let d = n_new.dot(departure);
                    nearest = nearest.min(d * d / n2);
                }
            }
            if nearest.is_finite() {
                worst = worst.max(nearest);
            }
        }
        let border = |v: u32| self.vertices[v as usize].kind == VertexKind::Boundary;
        if border(a)
            && border(b)
            && let (Some(c), Some(d)) = (self.across_border(a, b), self.across_border(b, a))
        {
            let (pc, pd) = (self.point(c), self.point(d));
            for q in [self.point(a), self.point(b)] {
                let off_line = segment_distance2(q, pc, p).min(segment_distance2(q, p, pd));
                worst = worst.max(BORDER_WEIGHT * off_line);
            }
        }
        worst
    }

    /// The neighbour of border vertex `v` across its border edge other than the one to `other`:
    /// the one neighbour whose edge to `v` has a single face.
    fn across_border(&self, v: u32, other: u32) -> Option<u32> {
        let fan = &self.topo.fans[v as usize];
        fan.iter().flat_map(|c| [c.next, c.prev]).find(|&u| u != other && self.edge_corners(v, u).1 == 1)
    }
}

/// How many times the squared distance a collapse moves a border off its line counts beside the
/// faces' distances in the fan-distance term (a border's move counts double). Measured over the
/// shared meshes and the corpus beside other weights (docs/benchmarks.md).
const BORDER_WEIGHT: f64 = 4.0;

/// The squared distance from `q` to the segment `a`–`b`.
fn segment_distance2(q: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let length2 = ab.length_squared();
    let t = if length2 > 0.0 { ((q - a).dot(ab) / length2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t - q).length_squared()
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::super::SimplifyOptions;
    use super::super::kernel::State;
    use super::super::legality::tests::wheel;

    #[test]
    fn a_collapse_within_a_flat_fan_costs_nothing_and_a_lift_costs_about_its_square() {
        // The wheel is flat: the centre 0 merged into its neighbour 1 anywhere in the plane moves
        // no surface off its plane.
        let mesh = wheel();
        let options = SimplifyOptions::default();
        let (state, _) = State::new(&mesh, &options);
        let p1 = state.point(1);
        assert_eq!(state.moved_fan_distance2(1, 0, p1), 0.0);
        assert_eq!(state.moved_fan_distance2(1, 0, (p1 + state.point(0)) / 2.0), 0.0);
        // Lifted by h off the plane: every moved face's new centroid is h/3 off its old plane, and
        // each endpoint is less than h from the planes of its new faces (which pass through p).
        let lifted = |h: f64| state.moved_fan_distance2(1, 0, p1 + DVec3::Z * h);
        for h in [1e-3, 0.1, 1.0] {
            let d2 = lifted(h);
            assert!(d2 >= (h / 3.0).powi(2) * (1.0 - 1e-12) && d2 < h * h, "h {h}: {d2}");
        }
        // Small lifts: quadratic in h, as the quadric error is.
        let ratio = lifted(2e-3) / lifted(1e-3);
        assert!((3.9..4.1).contains(&ratio), "{ratio}");
    }

    /// Collapses within a flat fan move no face off its plane; along a border, the term charges
    /// how far the border leaves its line: nothing along a straight side, and across one of the
    /// wheel's 60° bends the chord's distance from the removed corner (radius 2: 1).
    #[test]
    fn a_border_cut_across_a_bend_costs_its_chords_distance_and_a_straight_one_nothing() {
        let options = SimplifyOptions::default();
        let mesh = wheel();
        let (state, _) = State::new(&mesh, &options);
        // Outer vertices 7..=12 are the border, 8 between 7 and 9.
        let d2 = state.moved_fan_distance2(7, 8, state.point(7));
        assert!((d2 - super::BORDER_WEIGHT * 1.0).abs() < 1e-5, "{d2}"); // (f32 positions)
        // A flat 4 × 3 grid: its bottom side 0, 1, 2, 3 is straight.
        let positions = (0..3).flat_map(|j| (0..4).map(move |i| [i as f32, j as f32, 0.0])).collect();
        let mut triangles = Vec::new();
        for j in 0..2u32 {
            for i in 0..3u32 {
                let v = j * 4 + i;
                triangles.extend([[v, v + 1, v + 5], [v, v + 5, v + 4]]);
            }
        }
        let grid = crate::Mesh::new(positions, triangles).unwrap();
        let (state, _) = State::new(&grid, &options);
        assert_eq!(state.moved_fan_distance2(1, 2, state.point(1)), 0.0);
        // The same side collapsed onto a point off it: charged.
        assert!(state.moved_fan_distance2(1, 2, DVec3::new(1.5, 0.5, 0.0)) > 0.0);
    }
}
