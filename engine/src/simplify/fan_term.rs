//! The fan-distance term ([`super::SimplifyOptions::distance_term`]), on by default: how far a
//! collapse moves the surface, estimated from the faces it moves alone (no search of the input).
//! It is measured once a run has removed half the input's faces ([`FAN_TERM_FROM`]).

use glam::DVec3;

use super::kernel::State;

/// The share of the input's faces a run removes before the fan-distance term is measured: the
/// collapses before rank by the paper's cost alone. On a dense mesh those early collapses move the
/// surface so little that the term changes little but their order, and measuring it costs a second
/// queue pop and a fan walk per collapse. A share of the input rather than of the way to the
/// target keeps the collapse order the same whatever the target, so that a progressive mesh's
/// levels are the meshes a run straight to their face count gives. Measured beside
/// meshoptimizer's and MeshLab's error over the shared meshes and the corpus, and beside
/// meshoptimizer's time (docs/benchmarks.md).
pub(super) const FAN_TERM_FROM: f64 = 0.5;

impl State<'_> {
    /// The squared distance the fan-distance term charges for collapsing {a, b} to `p`: the
    /// largest of, over the faces that move (corner v → p, far edge x y, both endpoints' faces
    /// off the edge),
    /// - result → current surface: the distance from the moved face's new centroid to the plane
    ///   of the face it was, `|n_old·(p − v)| / 3`;
    /// - current surface → result: per endpoint v, the distance from its position to the nearest
    ///   of the planes of its moved faces, `min |n_new·(v − p)|` (v's departure from the new fan,
    ///   where the fan is flat enough for a plane to stand for it).
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
            for corner in &self.fans[v as usize] {
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
        worst
    }
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
}
