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
        self.coefficients().error([v.x, v.y, v.z]).max(0.0)
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
    #[inline]
    pub fn minimizer(&self) -> Option<DVec3> {
        let q = self.coefficients();
        let adjugate = q.adjugate();
        if !conditioned(adjugate.scale, adjugate.det) {
            return None;
        }
        let v = DVec3::from_array(q.solve(&adjugate));
        v.is_finite().then_some(v)
    }

    #[inline(always)]
    fn coefficients(&self) -> Coefficients<f64> {
        let q = self;
        Coefficients {
            a2: q.a2,
            ab: q.ab,
            ac: q.ac,
            ad: q.ad,
            b2: q.b2,
            bc: q.bc,
            bd: q.bd,
            c2: q.c2,
            cd: q.cd,
            d2: q.d2,
        }
    }
}

/// Whether a system with this scale (trace) and determinant has a unique, well-conditioned
/// solution: the determinant is compared with the cube of the scale so that the test does not
/// depend on the mesh's units.
#[inline(always)]
fn conditioned(scale: f64, det: f64) -> bool {
    !(scale.is_nan() || scale <= 0.0 || det.abs() <= 1e-9 * scale * scale * scale)
}

/// The arithmetic [`Coefficients`] needs: `f64`, or two `f64` lanes ([`F2`]).
trait Lane:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
{
    fn splat(x: f64) -> Self;
}

impl Lane for f64 {
    #[inline(always)]
    fn splat(x: f64) -> f64 {
        x
    }
}

/// A quadric's ten coefficients, in one lane or in two side by side: the error and the minimiser
/// are written once, for both, so a pair computes exactly what the scalar code does.
#[derive(Debug, Clone, Copy)]
struct Coefficients<T> {
    a2: T,
    ab: T,
    ac: T,
    ad: T,
    b2: T,
    bc: T,
    bd: T,
    c2: T,
    cd: T,
    d2: T,
}

/// The six distinct cofactors of the symmetric 3×3 part, its determinant and its trace.
struct Adjugate<T> {
    c00: T,
    c01: T,
    c02: T,
    c11: T,
    c12: T,
    c22: T,
    det: T,
    scale: T,
}

impl<T: Lane> Coefficients<T> {
    /// `vᵀ Q v` (before clamping at zero).
    #[inline(always)]
    fn error(&self, [x, y, z]: [T; 3]) -> T {
        let two = T::splat(2.0);
        x * (self.a2 * x + two * (self.ab * y + self.ac * z + self.ad))
            + y * (self.b2 * y + two * (self.bc * z + self.bd))
            + z * (self.c2 * z + two * self.cd)
            + self.d2
    }

    /// The matrix is symmetric, so its adjugate has six distinct cofactors; the determinant and
    /// the solution `−A⁻¹·(ad, bd, cd)` both come from them (Cramer's rule).
    #[inline(always)]
    fn adjugate(&self) -> Adjugate<T> {
        let (a, b, c, d, e, f) = (self.a2, self.ab, self.ac, self.b2, self.bc, self.c2);
        let c00 = d * f - e * e;
        let c01 = c * e - b * f;
        let c02 = b * e - c * d;
        let c11 = a * f - c * c;
        let c12 = b * c - a * e;
        let c22 = a * d - b * b;
        let det = a * c00 + b * c01 + c * c02;
        Adjugate { c00, c01, c02, c11, c12, c22, det, scale: a + d + f }
    }

    /// The point minimising the error (meaningful where [`conditioned`] holds).
    #[inline(always)]
    fn solve(&self, m: &Adjugate<T>) -> [T; 3] {
        let (rx, ry, rz) = (self.ad, self.bd, self.cd);
        [
            -(m.c00 * rx + m.c01 * ry + m.c02 * rz) / m.det,
            -(m.c01 * rx + m.c11 * ry + m.c12 * rz) / m.det,
            -(m.c02 * rx + m.c12 * ry + m.c22 * rz) / m.det,
        ]
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
}

impl Lane for F2 {
    #[inline(always)]
    fn splat(x: f64) -> F2 {
        F2::splat(x)
    }
}

impl std::ops::Neg for F2 {
    type Output = F2;
    #[inline(always)]
    fn neg(self) -> F2 {
        F2([-self.0[0], -self.0[1]])
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
pub(crate) struct QuadricPair(Coefficients<F2>);

impl QuadricPair {
    /// `[shared + others[0], shared + others[1]]` (the same sums as `Quadric`'s `+`, whose
    /// addition commutes).
    #[inline(always)]
    pub(crate) fn sums(shared: &Quadric, others: [&Quadric; 2]) -> QuadricPair {
        let (s, p, q) = (shared.coefficients(), others[0].coefficients(), others[1].coefficients());
        let lane = |s: f64, x: f64, y: f64| F2::splat(s) + F2::lanes(x, y);
        QuadricPair(Coefficients {
            a2: lane(s.a2, p.a2, q.a2),
            ab: lane(s.ab, p.ab, q.ab),
            ac: lane(s.ac, p.ac, q.ac),
            ad: lane(s.ad, p.ad, q.ad),
            b2: lane(s.b2, p.b2, q.b2),
            bc: lane(s.bc, p.bc, q.bc),
            bd: lane(s.bd, p.bd, q.bd),
            c2: lane(s.c2, p.c2, q.c2),
            cd: lane(s.cd, p.cd, q.cd),
            d2: lane(s.d2, p.d2, q.d2),
        })
    }

    /// [`Quadric::minimizer`] of each lane: the points, and whether each is one (well
    /// conditioned and finite).
    #[inline(always)]
    pub(crate) fn minimizers(&self) -> ([DVec3; 2], [bool; 2]) {
        let adjugate = self.0.adjugate();
        let [x, y, z] = self.0.solve(&adjugate);
        let points = [DVec3::new(x.0[0], y.0[0], z.0[0]), DVec3::new(x.0[1], y.0[1], z.0[1])];
        let ok = |i: usize| conditioned(adjugate.scale.0[i], adjugate.det.0[i]) && points[i].is_finite();
        (points, [ok(0), ok(1)])
    }

    /// [`Quadric::error`] of each lane at its point.
    #[inline(always)]
    pub(crate) fn errors(&self, points: [DVec3; 2]) -> [f64; 2] {
        let [p, q] = points;
        let e = self.0.error([F2::lanes(p.x, q.x), F2::lanes(p.y, q.y), F2::lanes(p.z, q.z)]);
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
