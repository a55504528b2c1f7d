//! Surface samples: area-spread face samples for the mean and RMS integrals, and the full
//! Metro-style sampler (vertices, edges, faces) kept as the sampled peer of the certified bounds.
//!
//! Reference: P. Cignoni, C. Rocchini, R. Scopigno, "Metro: measuring error on simplified
//! surfaces", Computer Graphics Forum 17(2), 1998.

use glam::DVec3;
use rayon::prelude::*;

use crate::bvh::TriangleBvh;
use crate::mesh::Mesh;
use crate::rng::SplitMix64;
use crate::topology::Topology;

/// Which samples [`sample_surface`] takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleKinds {
    /// Every vertex some face uses (unreferenced vertices are not surface).
    pub vertices: bool,
    /// `n` points spread along the unique edges by length; an edge with k samples is split into
    /// k + 1 equal parts.
    pub edges: bool,
    /// `n` points spread over the faces by area (each face gets its share, carried over), at
    /// uniformly random barycentric positions.
    pub faces: bool,
}

impl SampleKinds {
    /// Metro's sampling: vertices, edges and faces.
    pub const METRO: SampleKinds = SampleKinds { vertices: true, edges: true, faces: true };
    /// Face samples only: an area-weighted estimate of a surface integral.
    pub const FACES: SampleKinds = SampleKinds { vertices: false, edges: false, faces: true };
}

/// Samples points on a mesh's surface. Samples come out in mesh order (spatially coherent),
/// which the BVH query hint exploits; the result is deterministic for a seed.
pub fn sample_surface(mesh: &Mesh, n: usize, kinds: SampleKinds, seed: u64) -> Vec<DVec3> {
    let mut samples = Vec::new();
    if kinds.vertices {
        let mut used = vec![false; mesh.vertex_count()];
        for t in &mesh.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        samples.extend((0..mesh.vertex_count()).filter(|&v| used[v]).map(|v| mesh.point(v as u32)));
    }
    if kinds.edges && n > 0 {
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
    if kinds.faces {
        face_samples(mesh, n, seed, &mut samples);
    }
    samples
}

/// Appends `n` points spread over the faces by area (each face gets its share, carried over), at
/// uniformly random barycentric positions.
fn face_samples(mesh: &Mesh, n: usize, seed: u64, samples: &mut Vec<DVec3>) {
    let total = mesh.area();
    if n == 0 || total <= 0.0 {
        return;
    }
    let per_area = n as f64 / total;
    let mut rng = SplitMix64::new(seed);
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

/// Distances from sample points to a surface: the largest (a lower bound of the one-sided
/// Hausdorff distance, nothing more), the mean and the root mean square.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SampledDistance {
    /// Largest sample distance.
    pub max: f64,
    /// Mean sample distance.
    pub mean: f64,
    /// Root mean square sample distance.
    pub rms: f64,
    /// Number of samples.
    pub samples: usize,
}

/// Samples per parallel chunk: fixed, so the query hints (and so the result) do not depend on the
/// number of threads.
pub(crate) const CHUNK: usize = 2048;

/// One-sided distances from `samples` to the surface in `target`; distances at or below
/// `noise_floor` count as zero. Returns `None` when `cancelled` reports true between chunks.
pub fn directed_sampled(
    samples: &[DVec3],
    target: &TriangleBvh,
    noise_floor: f64,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<SampledDistance> {
    let (max, sum, sum_squares) = samples
        .par_chunks(CHUNK)
        .map(|chunk| {
            if cancelled() {
                return None;
            }
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
            Some((max, sum, sum_squares))
        })
        .try_reduce(|| (0.0, 0.0, 0.0), |x, y| Some((x.0.max(y.0), x.1 + y.1, x.2 + y.2)))?;
    let count = samples.len().max(1) as f64;
    Some(SampledDistance { max, mean: sum / count, rms: (sum_squares / count).sqrt(), samples: samples.len() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;

    #[test]
    fn sample_counts_follow_the_kinds() {
        let m = procedural::icosphere(3);
        let s = sample_surface(&m, 5000, SampleKinds::METRO, 1);
        // vertices + about n edge samples + about n face samples (carry may drop one of each).
        let expected = m.vertex_count() + 10_000;
        assert!(s.len() + 2 >= expected && s.len() <= expected, "{} vs {expected}", s.len());
        let faces = sample_surface(&m, 5000, SampleKinds::FACES, 1);
        assert!(faces.len() + 1 >= 5000 && faces.len() <= 5000, "{}", faces.len());
    }

    #[test]
    fn face_samples_are_spread_by_area() {
        // Two squares side by side, the right one four times the area: 1/5 and 4/5 of the samples.
        let m = Mesh::new(
            vec![[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.], [3., 0., 0.], [3., 2., 0.], [1., 2., 0.]],
            vec![[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 6]],
        )
        .unwrap();
        let s = sample_surface(&m, 10_000, SampleKinds::FACES, 3);
        let left = s.iter().filter(|p| p.x <= 1.0 && p.y <= 1.0 && p.x >= 0.0).count();
        // The second pair of triangles covers [1,3]x[0,2] minus nothing of the first square.
        assert!((left as f64 / s.len() as f64 - 0.2).abs() < 0.01, "{left} of {}", s.len());
    }
}
