//! Garland–Heckbert error quadrics.
//!
//! M. Garland, P. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997.
//!
//! A quadric stores `Σ wᵢ (nᵢ·v + dᵢ)²` for planes `(nᵢ, dᵢ)` with weights `wᵢ` (face areas here), as
//! the ten distinct entries of the symmetric 4×4 matrix plus the total weight, so that
//! `error(v) / weight` is a weighted mean squared distance and its square root a distance.

use glam::DVec3;

/// A weighted sum of squared distances to planes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Quadric {
    a2: f64,
    ab: f64,
    ac: f64,
    ad: f64,
    b2: f64,
    bc: f64,
    bd: f64,
    c2: f64,
    cd: f64,
    d2: f64,
    /// Sum of the plane weights.
    pub weight: f64,
}

impl Quadric {
    /// The quadric of one plane through `point` with unit `normal`, scaled by `weight`.
    pub fn from_plane(normal: DVec3, point: DVec3, weight: f64) -> Quadric {
        let (a, b, c) = (normal.x, normal.y, normal.z);
        let d = -normal.dot(point);
        Quadric {
            a2: weight * a * a,
            ab: weight * a * b,
            ac: weight * a * c,
            ad: weight * a * d,
            b2: weight * b * b,
            bc: weight * b * c,
            bd: weight * b * d,
            c2: weight * c * c,
            cd: weight * c * d,
            d2: weight * d * d,
            weight,
        }
    }

    /// A constraint plane: adds `weight · distance²` to the error but nothing to [`Quadric::weight`],
    /// so it shapes where vertices go without counting as surface area in [`Quadric::distance`].
    pub fn constraint(normal: DVec3, point: DVec3, weight: f64) -> Quadric {
        Quadric { weight: 0.0, ..Quadric::from_plane(normal, point, weight) }
    }

    /// `vᵀ Q v`: the weighted sum of squared plane distances at `v` (never negative).
    #[inline(always)]
    pub fn error(&self, v: DVec3) -> f64 {
        let (x, y, z) = (v.x, v.y, v.z);
        let e = x * (self.a2 * x + 2.0 * (self.ab * y + self.ac * z + self.ad))
            + y * (self.b2 * y + 2.0 * (self.bc * z + self.bd))
            + z * (self.c2 * z + 2.0 * self.cd)
            + self.d2;
        e.max(0.0)
    }

    /// Root of the weighted mean squared distance at `v`: an absolute distance estimate.
    pub fn distance(&self, v: DVec3) -> f64 {
        if self.weight > 0.0 { (self.error(v) / self.weight).sqrt() } else { 0.0 }
    }

    /// The point minimising the error, if the 3×3 system is well conditioned.
    ///
    /// The determinant is compared with the cube of the matrix scale so that the test does not
    /// depend on the mesh's units: a flat or cylindrical neighbourhood (rank < 3) has no unique
    /// minimiser and returns `None`.
    pub fn minimizer(&self) -> Option<DVec3> {
        // The matrix is symmetric, so its adjugate has six distinct cofactors; the determinant
        // and the solution `−A⁻¹·(ad, bd, cd)` both come from them (Cramer's rule).
        let (a, b, c, d, e, f) = (self.a2, self.ab, self.ac, self.b2, self.bc, self.c2);
        let c00 = d * f - e * e;
        let c01 = c * e - b * f;
        let c02 = b * e - c * d;
        let c11 = a * f - c * c;
        let c12 = b * c - a * e;
        let c22 = a * d - b * b;
        let det = a * c00 + b * c01 + c * c02;
        let scale = a + d + f;
        if scale.is_nan() || scale <= 0.0 || det.abs() <= 1e-9 * scale * scale * scale {
            return None;
        }
        let r = DVec3::new(self.ad, self.bd, self.cd);
        let v = -DVec3::new(
            c00 * r.x + c01 * r.y + c02 * r.z,
            c01 * r.x + c11 * r.y + c12 * r.z,
            c02 * r.x + c12 * r.y + c22 * r.z,
        ) / det;
        v.is_finite().then_some(v)
    }
}

impl std::ops::Add for Quadric {
    type Output = Quadric;
    fn add(self, o: Quadric) -> Quadric {
        Quadric {
            a2: self.a2 + o.a2,
            ab: self.ab + o.ab,
            ac: self.ac + o.ac,
            ad: self.ad + o.ad,
            b2: self.b2 + o.b2,
            bc: self.bc + o.bc,
            bd: self.bd + o.bd,
            c2: self.c2 + o.c2,
            cd: self.cd + o.cd,
            d2: self.d2 + o.d2,
            weight: self.weight + o.weight,
        }
    }
}

impl std::ops::AddAssign for Quadric {
    fn add_assign(&mut self, o: Quadric) {
        *self = *self + o;
    }
}

/// Two lanes of `f64`, operated on lane by lane: the compiler packs these into one vector
/// instruction per operation where the target has them (SSE2 on x86-64). Each lane sees exactly
/// the operations, in the same order, that the scalar code performs, so its results are the same
/// to the bit.
#[derive(Debug, Clone, Copy)]
struct F2([f64; 2]);

impl F2 {
    #[inline(always)]
    fn splat(x: f64) -> F2 {
        F2([x, x])
    }

    #[inline(always)]
    fn lanes(a: f64, b: f64) -> F2 {
        F2([a, b])
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> F2 {
        F2([f(self.0[0]), f(self.0[1])])
    }
}

macro_rules! f2_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl std::ops::$trait for F2 {
            type Output = F2;
            #[inline(always)]
            fn $method(self, o: F2) -> F2 {
                F2([self.0[0] $op o.0[0], self.0[1] $op o.0[1]])
            }
        }
    };
}
f2_op!(Add, add, +);
f2_op!(Sub, sub, -);
f2_op!(Mul, mul, *);
f2_op!(Div, div, /);

/// Two quadrics summed from a shared one, side by side: [`Quadric::minimizer`] and
/// [`Quadric::error`] for both at once, lane by lane (see [`F2`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct QuadricPair {
    a2: F2,
    ab: F2,
    ac: F2,
    ad: F2,
    b2: F2,
    bc: F2,
    bd: F2,
    c2: F2,
    cd: F2,
    d2: F2,
}

impl QuadricPair {
    /// `[shared + others[0], shared + others[1]]` (the same sums as `Quadric`'s `+`, whose
    /// addition commutes).
    #[inline(always)]
    pub(crate) fn sums(shared: &Quadric, others: [&Quadric; 2]) -> QuadricPair {
        let [p, q] = others;
        let lane = |s: f64, x: f64, y: f64| F2::splat(s) + F2::lanes(x, y);
        QuadricPair {
            a2: lane(shared.a2, p.a2, q.a2),
            ab: lane(shared.ab, p.ab, q.ab),
            ac: lane(shared.ac, p.ac, q.ac),
            ad: lane(shared.ad, p.ad, q.ad),
            b2: lane(shared.b2, p.b2, q.b2),
            bc: lane(shared.bc, p.bc, q.bc),
            bd: lane(shared.bd, p.bd, q.bd),
            c2: lane(shared.c2, p.c2, q.c2),
            cd: lane(shared.cd, p.cd, q.cd),
            d2: lane(shared.d2, p.d2, q.d2),
        }
    }

    /// [`Quadric::minimizer`] of each lane: the points, and whether each is one (well
    /// conditioned and finite).
    #[inline(always)]
    pub(crate) fn minimizers(&self) -> ([DVec3; 2], [bool; 2]) {
        let (a, b, c, d, e, f) = (self.a2, self.ab, self.ac, self.b2, self.bc, self.c2);
        let c00 = d * f - e * e;
        let c01 = c * e - b * f;
        let c02 = b * e - c * d;
        let c11 = a * f - c * c;
        let c12 = b * c - a * e;
        let c22 = a * d - b * b;
        let det = a * c00 + b * c01 + c * c02;
        let scale = a + d + f;
        let bound = F2::splat(1e-9) * scale * scale * scale;
        let (rx, ry, rz) = (self.ad, self.bd, self.cd);
        let x = (c00 * rx + c01 * ry + c02 * rz).map(|v| -v) / det;
        let y = (c01 * rx + c11 * ry + c12 * rz).map(|v| -v) / det;
        let z = (c02 * rx + c12 * ry + c22 * rz).map(|v| -v) / det;
        let mut points = [DVec3::ZERO; 2];
        let mut ok = [false; 2];
        for i in 0..2 {
            let (s, dt) = (scale.0[i], det.0[i]);
            let conditioned = !(s.is_nan() || s <= 0.0 || dt.abs() <= bound.0[i]);
            points[i] = DVec3::new(x.0[i], y.0[i], z.0[i]);
            ok[i] = conditioned && points[i].is_finite();
        }
        (points, ok)
    }

    /// [`Quadric::error`] of each lane at its point.
    #[inline(always)]
    pub(crate) fn errors(&self, points: [DVec3; 2]) -> [f64; 2] {
        let x = F2::lanes(points[0].x, points[1].x);
        let y = F2::lanes(points[0].y, points[1].y);
        let z = F2::lanes(points[0].z, points[1].z);
        let two = F2::splat(2.0);
        let e = x * (self.a2 * x + two * (self.ab * y + self.ac * z + self.ad))
            + y * (self.b2 * y + two * (self.bc * z + self.bd))
            + z * (self.c2 * z + two * self.cd)
            + self.d2;
        [e.0[0].max(0.0), e.0[1].max(0.0)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_error_is_squared_distance() {
        let q = Quadric::from_plane(DVec3::Z, DVec3::new(0.0, 0.0, 1.0), 2.0);
        assert!((q.error(DVec3::new(5.0, -3.0, 4.0)) - 2.0 * 9.0).abs() < 1e-12);
        assert!((q.distance(DVec3::new(0.0, 0.0, -1.0)) - 2.0).abs() < 1e-12);
        assert!(q.minimizer().is_none(), "a single plane has no unique minimiser");
    }

    #[test]
    fn three_planes_meet_at_their_corner() {
        let corner = DVec3::new(1.0, 2.0, 3.0);
        let q = Quadric::from_plane(DVec3::X, corner, 1.0)
            + Quadric::from_plane(DVec3::Y, corner, 1.0)
            + Quadric::from_plane(DVec3::Z, corner, 1.0);
        let v = q.minimizer().unwrap();
        assert!((v - corner).length() < 1e-12);
        assert!(q.error(v) < 1e-20);
    }

    #[test]
    fn minimiser_of_oblique_planes_matches_a_general_solve() {
        let mut rng = crate::rng::SplitMix64::new(5);
        let mut random = || rng.next_f64() * 2.0 - 1.0;
        let mut solved = 0;
        for _ in 0..200 {
            let mut q = Quadric::default();
            for _ in 0..4 {
                let n = DVec3::new(random(), random(), random()).normalize();
                q += Quadric::from_plane(n, DVec3::new(random(), random(), random()), random().abs() + 0.1);
            }
            let Some(v) = q.minimizer() else { continue };
            solved += 1;
            let m = glam::DMat3::from_cols(
                DVec3::new(q.a2, q.ab, q.ac),
                DVec3::new(q.ab, q.b2, q.bc),
                DVec3::new(q.ac, q.bc, q.c2),
            );
            let reference = m.inverse() * -DVec3::new(q.ad, q.bd, q.cd);
            assert!((v - reference).length() <= 1e-9 * (1.0 + reference.length()), "{v} vs {reference}");
            // No step along an axis lowers the error.
            for step in [DVec3::X, DVec3::Y, DVec3::Z] {
                assert!(q.error(v + step * 1e-4) >= q.error(v) - 1e-12);
                assert!(q.error(v - step * 1e-4) >= q.error(v) - 1e-12);
            }
        }
        assert!(solved > 150, "four random planes are almost always of full rank ({solved}/200)");
    }

    /// The paired evaluation is the scalar one, bit for bit, lane by lane, including the refusals
    /// (rank-deficient sums).
    #[test]
    fn pairs_match_the_scalar_minimiser_and_error_to_the_bit() {
        let mut rng = crate::rng::SplitMix64::new(9);
        let mut random = || rng.next_f64() * 2.0 - 1.0;
        let quadric = |planes: usize, random: &mut dyn FnMut() -> f64| {
            let mut q = Quadric::default();
            for _ in 0..planes {
                let n = DVec3::new(random(), random(), random()).normalize();
                q += Quadric::from_plane(n, DVec3::new(random(), random(), random()) * 10.0, random().abs() + 0.1);
            }
            q
        };
        let (mut refused, mut solved) = (0, 0);
        for round in 0..2000 {
            let shared = quadric(round % 3, &mut random);
            let others = [quadric(round % 4, &mut random), quadric((round / 4) % 4, &mut random)];
            let pair = QuadricPair::sums(&shared, [&others[0], &others[1]]);
            let (points, ok) = pair.minimizers();
            let errors = pair.errors(points);
            for lane in 0..2 {
                let q = shared + others[lane];
                match q.minimizer() {
                    Some(v) => {
                        solved += 1;
                        assert!(ok[lane], "round {round} lane {lane}: refused a minimiser");
                        assert_eq!(points[lane].to_array().map(f64::to_bits), v.to_array().map(f64::to_bits));
                        assert_eq!(errors[lane].to_bits(), q.error(v).to_bits(), "round {round} lane {lane}");
                    }
                    None => {
                        refused += 1;
                        assert!(!ok[lane], "round {round} lane {lane}: accepted a refused minimiser");
                    }
                }
            }
        }
        assert!(solved > 1000 && refused > 100, "both outcomes exercised ({solved} solved, {refused} refused)");
    }
}
