//! Symmetric Hausdorff distance between two meshes, sampled the way Metro does it.
//!
//! Reference: P. Cignoni, C. Rocchini, R. Scopigno, "Metro: measuring error on simplified
//! surfaces", Computer Graphics Forum 17(2), 1998.
//!
//! For each direction S → T, points are sampled on S and their distance to the closest point of
//! T's surface is measured through a [`TriangleBvh`]:
//!
//! | samples   | where                                                                  |
//! |-----------|------------------------------------------------------------------------|
//! | vertices  | every vertex some face uses (unreferenced vertices are not surface)     |
//! | edges     | `n` points spread along the unique edges by length; an edge with k     |
//! |           | samples is split into k + 1 equal parts                                 |
//! | faces     | `n` points, area-weighted: each face gets its share (carried over), at  |
//! |           | uniformly random barycentric positions                                  |
//!
//! The one-sided figures are max, mean and RMS over all samples of that direction; the symmetric
//! figures are the larger of the two directions for each. All are reported as absolute distances
//! and converted with [`DistanceUnits`] of mesh A.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::bvh::TriangleBvh;
use crate::error::MeshError;
use crate::mesh::{DistanceUnits, Mesh};
use crate::rng::SplitMix64;
use crate::topology::Topology;

/// How to sample.
#[derive(Debug, Clone, PartialEq)]
pub struct HausdorffOptions {
    /// Edge samples and face samples per direction (each). `None`: the larger vertex count of the
    /// two meshes, at least [`HausdorffOptions::MIN_DEFAULT_SAMPLES`] — Metro's default scaled up
    /// for small meshes.
    pub samples: Option<usize>,
    /// Sample every referenced vertex.
    pub sample_vertices: bool,
    /// Sample along edges.
    pub sample_edges: bool,
    /// Sample inside faces.
    pub sample_faces: bool,
    /// Seed of the face sampler; the result is deterministic for a seed.
    pub seed: u64,
}

impl HausdorffOptions {
    /// Floor of the default sample count.
    pub const MIN_DEFAULT_SAMPLES: usize = 10_000;
}

impl Default for HausdorffOptions {
    fn default() -> Self {
        HausdorffOptions { samples: None, sample_vertices: true, sample_edges: true, sample_faces: true, seed: 0x5eed }
    }
}

/// Distances from samples on one mesh to the other's surface, in the meshes' own units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DirectedDistance {
    /// Largest sample distance.
    pub max: f64,
    /// Mean sample distance.
    pub mean: f64,
    /// Root mean square sample distance.
    pub rms: f64,
    /// Number of samples.
    pub samples: usize,
}

/// Result of [`hausdorff`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HausdorffReport {
    /// Samples on A measured against B.
    pub a_to_b: DirectedDistance,
    /// Samples on B measured against A.
    pub b_to_a: DirectedDistance,
    /// Symmetric Hausdorff distance (max of both directions), paper units.
    pub hausdorff: f64,
    /// Larger of the two one-sided mean distances, paper units.
    pub mean: f64,
    /// Larger of the two one-sided RMS distances, paper units.
    pub rms: f64,
    /// Symmetric Hausdorff distance, % of A's bounding-box diagonal.
    pub hausdorff_diag_pct: f64,
    /// Mean distance, % of A's bounding-box diagonal.
    pub mean_diag_pct: f64,
    /// Symmetric Hausdorff distance in absolute units.
    pub hausdorff_absolute: f64,
    /// Total samples over both directions.
    pub samples: usize,
}

/// Symmetric Metro-style distance between `a` and `b`.
pub fn hausdorff(a: &Mesh, b: &Mesh, options: &HausdorffOptions) -> Result<HausdorffReport, MeshError> {
    let bounds = a.surface_bounds().ok_or(MeshError::Empty { what: "mesh A has no faces" })?;
    if b.triangles.is_empty() {
        return Err(MeshError::Empty { what: "mesh B has no faces" });
    }
    let n = options
        .samples
        .unwrap_or_else(|| a.vertex_count().max(b.vertex_count()).max(HausdorffOptions::MIN_DEFAULT_SAMPLES));
    let ((bvh_a, samples_a), (bvh_b, samples_b)) = rayon::join(
        || (TriangleBvh::new(a).expect("a has faces"), sample_surface(a, n, options)),
        || (TriangleBvh::new(b).expect("b has faces"), sample_surface(b, n, options)),
    );
    // f32 input carries ~1e-7 relative precision; distances below 1e-12 of the diagonal are the
    // rounding of the closest-point computation itself (a sample on a face measured against the
    // same face), so they are reported as exactly zero.
    let noise_floor = NOISE_FLOOR * bounds.diagonal().max(b.surface_bounds().map_or(0.0, |bb| bb.diagonal()));
    let (a_to_b, b_to_a) =
        rayon::join(|| directed(&samples_a, &bvh_b, noise_floor), || directed(&samples_b, &bvh_a, noise_floor));
    let units = DistanceUnits::new(&bounds);
    let max = a_to_b.max.max(b_to_a.max);
    let mean = a_to_b.mean.max(b_to_a.mean);
    Ok(HausdorffReport {
        a_to_b,
        b_to_a,
        hausdorff: units.to_paper(max),
        mean: units.to_paper(mean),
        rms: units.to_paper(a_to_b.rms.max(b_to_a.rms)),
        hausdorff_diag_pct: units.to_diagonal_percent(max),
        mean_diag_pct: units.to_diagonal_percent(mean),
        hausdorff_absolute: max,
        samples: a_to_b.samples + b_to_a.samples,
    })
}

/// Relative distance (of the bounding-box diagonal) below which a sample counts as on the surface.
pub const NOISE_FLOOR: f64 = 1e-12;

/// One-sided distance from `samples` to the surface in `target`; distances at or below
/// `noise_floor` count as zero.
pub fn directed(samples: &[DVec3], target: &TriangleBvh, noise_floor: f64) -> DirectedDistance {
    const CHUNK: usize = 2048;
    let (max, sum, sum_squares) = samples
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut hint = None;
            let (mut max, mut sum, mut sum_squares) = (0f64, 0f64, 0f64);
            for &p in chunk {
                let hit = target.closest_point(p, hint);
                hint = Some(hit.slot);
                let d = hit.distance();
                if d > noise_floor {
                    max = max.max(d);
                    sum += d;
                    sum_squares += hit.distance_squared;
                }
            }
            (max, sum, sum_squares)
        })
        .reduce(|| (0.0, 0.0, 0.0), |x, y| (x.0.max(y.0), x.1 + y.1, x.2 + y.2));
    let count = samples.len().max(1) as f64;
    DirectedDistance { max, mean: sum / count, rms: (sum_squares / count).sqrt(), samples: samples.len() }
}

/// Sample points on a mesh's surface as described in the module documentation. Samples come out
/// in mesh order (spatially coherent), which the BVH query hint exploits.
pub fn sample_surface(mesh: &Mesh, n: usize, options: &HausdorffOptions) -> Vec<DVec3> {
    let mut samples = Vec::new();
    if options.sample_vertices {
        let mut used = vec![false; mesh.vertex_count()];
        for t in &mesh.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        samples.extend((0..mesh.vertex_count()).filter(|&v| used[v]).map(|v| mesh.point(v as u32)));
    }
    if options.sample_edges && n > 0 {
        let topology = Topology::new(mesh);
        let lengths: Vec<f64> = topology.edges.iter().map(|&[a, b]| (mesh.point(a) - mesh.point(b)).length()).collect();
        let total: f64 = lengths.iter().sum();
        if total > 0.0 {
            let per_length = n as f64 / total;
            let mut carry = 0.0;
            for (&[a, b], &len) in topology.edges.iter().zip(&lengths) {
                carry += len * per_length;
                let k = carry.floor();
                carry -= k;
                let (pa, pb) = (mesh.point(a), mesh.point(b));
                // Metro's placement: k samples splitting the edge into k + 1 equal parts.
                for i in 1..=k as usize {
                    let t = i as f64 / (k + 1.0);
                    samples.push(pa + (pb - pa) * t);
                }
            }
        }
    }
    if options.sample_faces && n > 0 {
        let total = mesh.area();
        if total > 0.0 {
            let per_area = n as f64 / total;
            let mut rng = SplitMix64::new(options.seed);
            let mut carry = 0.0;
            for f in 0..mesh.face_count() {
                carry += mesh.face_area(f) * per_area;
                let k = carry.floor();
                carry -= k;
                let [a, b, c] = mesh.triangle_points(f);
                for _ in 0..k as usize {
                    // Uniform point in a triangle: fold the unit square along its diagonal.
                    let (mut u, mut v) = (rng.next_f64(), rng.next_f64());
                    if u + v > 1.0 {
                        u = 1.0 - u;
                        v = 1.0 - v;
                    }
                    samples.push(a + (b - a) * u + (c - a) * v);
                }
            }
        }
    }
    samples
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;

    #[test]
    fn identical_meshes_are_at_distance_zero() {
        let m = procedural::torus(40, 20, 0.3);
        let r = hausdorff(&m, &m, &HausdorffOptions::default()).unwrap();
        assert_eq!(r.hausdorff, 0.0);
        assert_eq!(r.mean, 0.0);
        assert!(r.samples > 20_000);
    }

    #[test]
    fn offset_plane_distance_is_exact() {
        // Two parallel unit squares 0.1 apart: every sample is exactly 0.1 away.
        let square = |z: f32| {
            Mesh::new(vec![[0., 0., z], [1., 0., z], [1., 1., z], [0., 1., z]], vec![[0, 1, 2], [0, 2, 3]]).unwrap()
        };
        let r = hausdorff(&square(0.0), &square(0.1), &HausdorffOptions::default()).unwrap();
        let d = 0.1f32 as f64;
        assert!((r.hausdorff_absolute - d).abs() < 1e-9);
        assert!((r.a_to_b.mean - d).abs() < 1e-9 && (r.b_to_a.rms - d).abs() < 1e-9);
        // Largest side 1 → paper units double the distance; diagonal of the flat box is √2.
        assert!((r.hausdorff - 2.0 * d).abs() < 1e-9);
        assert!((r.hausdorff_diag_pct - d / 2f64.sqrt() * 100.0).abs() < 1e-7);
    }

    #[test]
    fn sample_counts_follow_options() {
        let m = procedural::icosphere(3);
        let opts = HausdorffOptions { samples: Some(5000), ..Default::default() };
        let s = sample_surface(&m, 5000, &opts);
        // vertices + about n edge samples + about n face samples (carry may drop one of each).
        let expected = m.vertex_count() + 10_000;
        assert!(s.len() + 2 >= expected && s.len() <= expected, "{} vs {expected}", s.len());
    }

    #[test]
    fn empty_mesh_is_refused() {
        let m = procedural::icosphere(1);
        let empty = Mesh::default();
        assert!(matches!(hausdorff(&m, &empty, &HausdorffOptions::default()), Err(MeshError::Empty { .. })));
        assert!(matches!(hausdorff(&empty, &m, &HausdorffOptions::default()), Err(MeshError::Empty { .. })));
    }
}
