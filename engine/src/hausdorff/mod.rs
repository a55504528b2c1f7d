//! Symmetric Hausdorff distance between two meshes, with certified bounds.
//!
//! For each direction A → B the one-sided distance h(A → B) = max over p in A of d(p, B) is
//! bracketed by a lower bound L (an exact distance reached at some point of A) and an upper bound
//! U (proved for every point of A), by branch and bound over A's triangles (`bounds`); the search
//! stops when U ≤ L · (1 + tolerance). The symmetric distance is the larger direction; the
//! published figure `hausdorff` is U, so it is never below the true distance.
//!
//! Mean and RMS distances are integrals over the surface: they are estimated from face samples
//! spread over each mesh by area ([`sampling`]), so they are area-weighted. Vertices, centroids and
//! edge midpoints count for the maximum only. (Corner distances would be free, but a face that
//! crosses the other surface has a smaller mean than its corners': they would bias it upward.)
//!
//! All figures are computed as absolute distances and converted with [`DistanceUnits`] of mesh A.

mod bounds;
mod patch;
pub mod sampling;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use serde::Serialize;

use crate::bvh::TriangleBvh;
use crate::error::MeshError;
use crate::mesh::{DistanceUnits, Mesh};
use sampling::{SampleKinds, directed_sampled, sample_surface};

/// How to measure.
#[derive(Debug, Clone)]
pub struct HausdorffOptions {
    /// Face samples per direction for the mean and RMS. `None`: half the larger vertex count of
    /// the two meshes, at least [`HausdorffOptions::MIN_DEFAULT_SAMPLES`] (checked against MeshLab's
    /// dense Metro sampling in docs/metro-check.txt; more for a finer estimate).
    pub samples: Option<usize>,
    /// Relative gap allowed between the bounds: the search stops when U ≤ L · (1 + tolerance).
    pub tolerance: f64,
    /// Seed of the face sampler; the result is deterministic for a seed.
    pub seed: u64,
    /// Raised by the caller to stop the work; the measurement then fails with
    /// [`MeshError::Cancelled`].
    pub cancel: Option<Arc<AtomicBool>>,
}

impl HausdorffOptions {
    /// Floor of the default sample count.
    pub const MIN_DEFAULT_SAMPLES: usize = 10_000;
    /// Default relative tolerance between the bounds.
    pub const DEFAULT_TOLERANCE: f64 = 1e-3;
    /// Smallest tolerance accepted.
    pub const MIN_TOLERANCE: f64 = 1e-6;

    /// Checks the options; errors name the field.
    pub fn validate(&self) -> Result<(), MeshError> {
        if !(self.tolerance.is_finite() && (Self::MIN_TOLERANCE..=1.0).contains(&self.tolerance)) {
            return Err(MeshError::InvalidParameter {
                name: "tolerance",
                reason: format!("must be in [{}, 1], got {}", Self::MIN_TOLERANCE, self.tolerance),
            });
        }
        if self.samples == Some(0) {
            return Err(MeshError::InvalidParameter { name: "samples", reason: "must be at least 1".into() });
        }
        Ok(())
    }
}

impl Default for HausdorffOptions {
    fn default() -> Self {
        HausdorffOptions { samples: None, tolerance: Self::DEFAULT_TOLERANCE, seed: 0x5eed, cancel: None }
    }
}

/// One direction of the distance, in paper units of A (as every distance of [`HausdorffReport`]
/// not named absolute).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DirectedDistance {
    /// Largest exact point-to-surface distance found: a lower bound of the one-sided distance.
    pub max_lower: f64,
    /// Certified upper bound of the one-sided distance.
    pub max_upper: f64,
    /// Area-weighted mean distance (face samples).
    pub mean: f64,
    /// Area-weighted root mean square distance (face samples).
    pub rms: f64,
    /// Face samples behind the mean and RMS.
    pub samples: usize,
    /// Exact point evaluations behind the bounds (vertices, centroids, edge midpoints).
    pub evaluations: usize,
    /// Pieces split by the bound search.
    pub splits: usize,
    /// Whether the bounds met within the tolerance (false only when the work budget ran out;
    /// `max_upper` is certified either way).
    pub converged: bool,
}

/// Result of [`hausdorff`]. Unless named absolute or percent, distances are in paper units of A.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HausdorffReport {
    /// From A's surface to B's.
    pub a_to_b: DirectedDistance,
    /// From B's surface to A's.
    pub b_to_a: DirectedDistance,
    /// Symmetric Hausdorff distance: the certified upper bound U (never below the true distance).
    pub hausdorff: f64,
    /// Lower bound L of the symmetric distance: a distance actually reached.
    pub hausdorff_lower: f64,
    /// The relative tolerance the bounds were asked to meet.
    pub tolerance: f64,
    /// Whether U ≤ L · (1 + tolerance) (or both are below the inputs' resolution).
    pub converged: bool,
    /// Larger of the two one-sided area-weighted mean distances.
    pub mean: f64,
    /// Larger of the two one-sided area-weighted RMS distances.
    pub rms: f64,
    /// `hausdorff` as % of A's bounding-box diagonal.
    pub hausdorff_diag_pct: f64,
    /// `mean` as % of A's bounding-box diagonal.
    pub mean_diag_pct: f64,
    /// `hausdorff` in absolute units.
    pub hausdorff_absolute: f64,
    /// `hausdorff_lower` in absolute units.
    pub hausdorff_lower_absolute: f64,
    /// Face samples over both directions.
    pub samples: usize,
    /// Wall time of the measurement.
    pub seconds: f64,
}

/// Relative distance (of the bounding-box diagonal) below which a sample counts as on the surface.
pub const NOISE_FLOOR: f64 = 1e-12;

/// Gap between the bounds (relative to the larger diagonal) not worth closing: a millionth of the
/// model's size, a thousandth of the finest error a level of detail is simplified to in practice.
/// Without it, surfaces that coincide (a mesh against a retriangulation of itself) would be
/// split along every edge of the other towards f32 rounding.
pub const RESOLUTION: f64 = 1e-6;

/// What [`measure`] prepares for one direction: the target's tree, the face-sample distances, and
/// the vertices' distances with their largest and their count.
type Prepared = (TriangleBvh, sampling::SampledDistance, (bounds::VertexDistances, f64, usize));

/// Pieces the bound search may split per face of the measured side, beyond a fixed allowance,
/// before it stops and reports the (still certified) wider bracket.
const BUDGET_PER_FACE: usize = 32;
const BUDGET_BASE: usize = 1 << 14;

/// Checks that a mesh has a surface to measure: valid, with faces, not all of them degenerate.
pub fn check_surface(mesh: &Mesh) -> Result<(), MeshError> {
    mesh.check()?;
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty { what: "no faces" });
    }
    if mesh.area() <= 0.0 {
        return Err(MeshError::InvalidParameter {
            name: "mesh",
            reason: "every face is degenerate (zero area): there is no surface to measure".into(),
        });
    }
    Ok(())
}

/// [`check_surface`] with the errors naming mesh A or B.
fn check(mesh: &Mesh, is_a: bool) -> Result<(), MeshError> {
    check_surface(mesh).map_err(|e| match e {
        MeshError::Empty { .. } => {
            MeshError::Empty { what: if is_a { "mesh A has no faces" } else { "mesh B has no faces" } }
        }
        MeshError::InvalidParameter { name: "mesh", reason } => {
            MeshError::InvalidParameter { name: if is_a { "mesh A" } else { "mesh B" }, reason }
        }
        other => other,
    })
}

/// Symmetric Hausdorff distance between `a` and `b` with certified bounds, and area-weighted mean
/// and RMS distances.
///
/// Only the symmetric figure is searched to the tolerance: the smaller direction's upper bound is
/// certified too, but only proved to lie within the tolerance of the larger direction's lower
/// bound. [`directed_hausdorff`] brackets one direction tightly.
pub fn hausdorff(a: &Mesh, b: &Mesh, options: &HausdorffOptions) -> Result<HausdorffReport, MeshError> {
    measure(a, b, options, true)
}

/// The one-sided distance from `a`'s surface to `b`'s, with bounds that meet within the
/// tolerance, in paper units of `a`.
pub fn directed_hausdorff(a: &Mesh, b: &Mesh, options: &HausdorffOptions) -> Result<DirectedDistance, MeshError> {
    Ok(measure(a, b, options, false)?.a_to_b)
}

fn measure(a: &Mesh, b: &Mesh, options: &HausdorffOptions, symmetric: bool) -> Result<HausdorffReport, MeshError> {
    let started = Instant::now();
    options.validate()?;
    check(a, true)?;
    check(b, false)?;
    let bounds_a = a.surface_bounds().expect("a has faces");
    let diagonal = bounds_a.diagonal().max(b.surface_bounds().expect("b has faces").diagonal());
    let n = options
        .samples
        .unwrap_or_else(|| (a.vertex_count().max(b.vertex_count()) / 2).max(HausdorffOptions::MIN_DEFAULT_SAMPLES));
    let cancel = options.cancel.clone();
    let cancelled = move || cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed));
    let search = |faces: usize| bounds::Search {
        tolerance: options.tolerance,
        floor: RESOLUTION * diagonal,
        budget: BUDGET_BASE + BUDGET_PER_FACE * faces,
    };
    // f32 input carries ~1e-7 relative precision; sample distances below 1e-12 of the diagonal are
    // the rounding of the closest-point computation itself (a sample on a face measured against
    // the same face), so they count as exactly zero.
    let noise_floor = NOISE_FLOOR * diagonal;
    // First what is cheap and exact: every vertex, and the face samples of the mean and RMS.
    let prepare = |from: &Mesh, to: &Mesh| {
        let bvh = TriangleBvh::new(to).expect("checked: has faces");
        let samples = sample_surface(from, n, SampleKinds::FACES, options.seed);
        let (sampled, vertices) = rayon::join(
            || directed_sampled(&samples, &bvh, noise_floor, &cancelled),
            || bounds::vertex_distances(from, &bvh, &cancelled),
        );
        Some((bvh, sampled?, vertices?))
    };
    // One-sided: B → A is not measured at all.
    let (ab, ba) = rayon::join(|| prepare(a, b), || symmetric.then(|| prepare(b, a)));
    let ab = ab.ok_or(MeshError::Cancelled)?;
    let ba = ba.map(|x| x.ok_or(MeshError::Cancelled)).transpose()?;
    // The symmetric distance is at least the larger direction's: neither search needs to prove
    // anything below that.
    let reached = |(_, sampled, (_, lower, _)): &(TriangleBvh, sampling::SampledDistance, _)| sampled.max.max(*lower);
    let lower = reached(&ab).max(ba.as_ref().map_or(0.0, reached));
    let one_way = |from: &Mesh, prepared: &Prepared| {
        let (bvh, sampled, (at_vertex, own, vertices)) = prepared;
        let found = bounds::directed_bounds(from, bvh, at_vertex, lower, search(from.face_count()), &cancelled)
            .ok_or(MeshError::Cancelled)?;
        // A direction's own lower bound is what was reached on its side; its upper bound is
        // certified, and within the tolerance of the symmetric lower bound. As for the samples,
        // distances at the noise floor are the rounding of the closest-point computation on
        // coincident surfaces, and count as zero.
        let zero = |d: f64| if d <= noise_floor { 0.0 } else { d };
        Ok::<_, MeshError>(DirectedDistance {
            max_lower: zero(own.max(sampled.max).max(found.own_lower)),
            max_upper: zero(found.upper),
            mean: sampled.mean,
            rms: sampled.rms,
            samples: sampled.samples,
            evaluations: vertices + found.evaluations,
            splits: found.splits,
            converged: found.converged,
        })
    };
    let (a_to_b, b_to_a) = rayon::join(|| one_way(a, &ab), || ba.as_ref().map(|ba| one_way(b, ba)).transpose());
    let a_to_b = a_to_b?;
    // One-sided: the missing direction contributes nothing to the symmetric figures.
    let b_to_a = b_to_a?.unwrap_or(DirectedDistance {
        max_lower: 0.0,
        max_upper: 0.0,
        mean: 0.0,
        rms: 0.0,
        samples: 0,
        evaluations: 0,
        splits: 0,
        converged: true,
    });
    let units = DistanceUnits::new(&bounds_a);
    let paper = |d: DirectedDistance| DirectedDistance {
        max_lower: units.to_paper(d.max_lower),
        max_upper: units.to_paper(d.max_upper),
        mean: units.to_paper(d.mean),
        rms: units.to_paper(d.rms),
        ..d
    };
    let upper = a_to_b.max_upper.max(b_to_a.max_upper);
    let lower = a_to_b.max_lower.max(b_to_a.max_lower);
    let mean = a_to_b.mean.max(b_to_a.mean);
    Ok(HausdorffReport {
        a_to_b: paper(a_to_b),
        b_to_a: paper(b_to_a),
        hausdorff: units.to_paper(upper),
        hausdorff_lower: units.to_paper(lower),
        tolerance: options.tolerance,
        converged: a_to_b.converged && b_to_a.converged,
        mean: units.to_paper(mean),
        rms: units.to_paper(a_to_b.rms.max(b_to_a.rms)),
        hausdorff_diag_pct: units.to_diagonal_percent(upper),
        mean_diag_pct: units.to_diagonal_percent(mean),
        hausdorff_absolute: upper,
        hausdorff_lower_absolute: lower,
        samples: a_to_b.samples + b_to_a.samples,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The Metro-style sampled maximum (vertices, edges and faces, `n` edge and `n` face samples per
/// direction): only a lower bound of the distance, kept as the peer the certified bounds are
/// measured against. Absolute units.
pub fn sampled_max(a: &Mesh, b: &Mesh, n: usize, seed: u64) -> Result<f64, MeshError> {
    check(a, true)?;
    check(b, false)?;
    let diagonal = a.surface_bounds().expect("faces").diagonal();
    let (bvh_a, bvh_b) = rayon::join(|| TriangleBvh::new(a).expect("faces"), || TriangleBvh::new(b).expect("faces"));
    let never = || false;
    let one_way = |from: &Mesh, to: &TriangleBvh| {
        let samples = sample_surface(from, n, SampleKinds::METRO, seed);
        directed_sampled(&samples, to, NOISE_FLOOR * diagonal, &never).expect("not cancellable").max
    };
    let (x, y) = rayon::join(|| one_way(a, &bvh_b), || one_way(b, &bvh_a));
    Ok(x.max(y))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;
    use glam::{DMat3, DVec3};

    fn transformed(mesh: &Mesh, f: impl Fn(DVec3) -> DVec3) -> Mesh {
        let positions = (0..mesh.vertex_count() as u32).map(|v| f(mesh.point(v)).as_vec3().to_array()).collect();
        Mesh::new(positions, mesh.triangles.clone()).unwrap()
    }

    fn rotation() -> DMat3 {
        DMat3::from_axis_angle(DVec3::new(0.3, -0.8, 0.52).normalize(), 1.234)
    }

    /// Asserts the bounds bracket `truth` (up to the f32 rounding of the inputs) and meet.
    fn assert_brackets(lower: f64, upper: f64, truth: f64, tolerance: f64) {
        let slack = 1e-6 * truth.max(1.0);
        assert!(lower <= truth + slack && upper >= truth - slack, "[{lower}, {upper}] does not bracket {truth}");
        assert!(upper - lower <= tolerance * lower, "gap {} over {tolerance} · {lower}", upper - lower);
    }

    #[test]
    fn identical_meshes_are_at_distance_zero() {
        let m = procedural::torus(40, 20, 0.3);
        let r = hausdorff(&m, &m, &HausdorffOptions::default()).unwrap();
        assert_eq!((r.hausdorff, r.hausdorff_lower), (0.0, 0.0));
        assert_eq!(r.mean, 0.0);
        assert!(r.converged);
    }

    #[test]
    fn translated_boxes_are_at_the_translation() {
        // Different tessellations of the same box, one moved by d along an axis: H = d.
        for (axis, d) in [(DVec3::X, 0.1), (DVec3::Z, 0.05), (DVec3::Y, 0.3)] {
            for rotate in [false, true] {
                let r = if rotate { rotation() } else { DMat3::IDENTITY };
                let a = transformed(&procedural::sharp_box(8), |p| r * p);
                let b = transformed(&procedural::sharp_box(5), |p| r * (p + axis * d));
                let report = hausdorff(&a, &b, &HausdorffOptions::default()).unwrap();
                assert_brackets(report.hausdorff_lower_absolute, report.hausdorff_absolute, d, 1e-3);
                assert!(report.converged);
            }
        }
    }

    /// A rectangle in z = 0 over x ∈ [−1, 1] and two triangles standing in the planes x = ±1: every
    /// point of the rectangle is nearer one wall, and the farthest (distance 1) lie on x = 0, inside
    /// the faces, where no vertex and no edge sample need fall.
    fn rectangle_between_walls(r: DMat3) -> (Mesh, Mesh) {
        let h = 0.3;
        let rect = Mesh::new(
            [[-1., -h, 0.], [1., -h, 0.], [1., h, 0.], [-1., h, 0.]]
                .map(|p: [f64; 3]| (r * DVec3::from(p)).as_vec3().to_array())
                .to_vec(),
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        let walls = Mesh::new(
            [
                [-1., -3. * h, -1.],
                [-1., 0., 2.],
                [-1., 3. * h, -1.],
                [1., -3. * h, -1.],
                [1., 3. * h, -1.],
                [1., 0., 2.],
            ]
            .map(|p: [f64; 3]| (r * DVec3::from(p)).as_vec3().to_array())
            .to_vec(),
            vec![[0, 1, 2], [3, 4, 5]],
        )
        .unwrap();
        (rect, walls)
    }

    #[test]
    fn farthest_point_inside_a_face_is_found() {
        for r in [DMat3::IDENTITY, rotation()] {
            let (rect, walls) = rectangle_between_walls(r);
            for tolerance in [1e-3, 1e-5] {
                let d =
                    directed_hausdorff(&rect, &walls, &HausdorffOptions { tolerance, ..Default::default() }).unwrap();
                // Directed figures are in paper units of the (rotated) rectangle.
                let truth = DistanceUnits::new(&rect.surface_bounds().unwrap()).to_paper(1.0);
                assert_brackets(d.max_lower, d.max_upper, truth, tolerance);
                assert!(d.converged);
            }
        }
    }

    #[test]
    fn offset_plane_distance_is_exact() {
        // Two parallel unit squares 0.1 apart: every point is exactly 0.1 away.
        let square = |z: f32| {
            Mesh::new(vec![[0., 0., z], [1., 0., z], [1., 1., z], [0., 1., z]], vec![[0, 1, 2], [0, 2, 3]]).unwrap()
        };
        let r = hausdorff(&square(0.0), &square(0.1), &HausdorffOptions::default()).unwrap();
        let d = 0.1f32 as f64;
        assert!((r.hausdorff_absolute - d).abs() < 1e-9 && (r.hausdorff_lower_absolute - d).abs() < 1e-9);
        // Largest side 1 → paper units double the distance; diagonal of the flat box is √2.
        assert!((r.a_to_b.mean - 2.0 * d).abs() < 1e-9 && (r.b_to_a.rms - 2.0 * d).abs() < 1e-9);
        assert!((r.hausdorff - 2.0 * d).abs() < 1e-9);
        assert!((r.hausdorff_diag_pct - d / 2f64.sqrt() * 100.0).abs() < 1e-7);
    }

    #[test]
    fn bounds_bracket_dense_sampling_on_a_simplified_blob() {
        let mesh = procedural::bumpy_blob(40, 80, 3);
        let coarse = crate::simplify::simplify(
            &mesh,
            &crate::simplify::SimplifyOptions { target_ratio: Some(0.95), ..Default::default() },
        )
        .unwrap()
        .mesh;
        let report = hausdorff(&mesh, &coarse, &HausdorffOptions::default()).unwrap();
        let sampled = sampled_max(&mesh, &coarse, 400_000, 9).unwrap();
        assert!(
            report.hausdorff_absolute >= sampled,
            "U {} below a sampled distance {sampled}",
            report.hausdorff_absolute
        );
        assert!(
            report.hausdorff_lower_absolute >= 0.995 * sampled,
            "L {} vs sampled {sampled}",
            report.hausdorff_lower_absolute
        );
        assert!(report.converged);
        // Deterministic, whatever the thread count.
        let again = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| hausdorff(&mesh, &coarse, &HausdorffOptions::default()).unwrap());
        assert_eq!(
            (again.hausdorff, again.hausdorff_lower, again.mean),
            (report.hausdorff, report.hausdorff_lower, report.mean)
        );
    }

    #[test]
    fn bad_input_is_refused() {
        let m = procedural::icosphere(1);
        let empty = Mesh::default();
        assert!(matches!(hausdorff(&m, &empty, &HausdorffOptions::default()), Err(MeshError::Empty { .. })));
        assert!(matches!(hausdorff(&empty, &m, &HausdorffOptions::default()), Err(MeshError::Empty { .. })));
        let flat = Mesh::new(vec![[0., 0., 0.], [1., 0., 0.], [2., 0., 0.]], vec![[0, 1, 2]]).unwrap();
        let err = hausdorff(&m, &flat, &HausdorffOptions::default()).unwrap_err();
        assert!(err.to_string().contains("mesh B") && err.to_string().contains("degenerate"), "{err}");
        let mut nan = m.clone();
        nan.positions[3][1] = f32::NAN;
        assert!(matches!(
            hausdorff(&nan, &m, &HausdorffOptions::default()),
            Err(MeshError::NonFiniteCoordinate { vertex: 3, .. })
        ));
        for tolerance in [0.0, -1.0, f64::NAN, 2.0] {
            let err = hausdorff(&m, &m, &HausdorffOptions { tolerance, ..Default::default() }).unwrap_err();
            assert!(matches!(err, MeshError::InvalidParameter { name: "tolerance", .. }), "{err}");
        }
    }

    #[test]
    fn a_raised_cancel_flag_stops_the_measurement() {
        let m = procedural::icosphere(4);
        let flag = Arc::new(AtomicBool::new(true));
        let options = HausdorffOptions { cancel: Some(flag), ..Default::default() };
        assert_eq!(hausdorff(&m, &procedural::icosphere(2), &options), Err(MeshError::Cancelled));
    }
}
