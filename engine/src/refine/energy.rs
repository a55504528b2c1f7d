//! The energy operator of the energy-operator LOD paper (`../shared/papers/energy-operator-lod.txt`,
//! Eq. 1–2): for a vertex v with one-ring neighbours v_j,
//!
//! ```text
//! E(v) = | Σ_j (v − v_j) · L̄_j | / Σ_j L̄_j        L̄_j = mean length of the edges at v_j
//! ```
//!
//! a length-weighted umbrella vector: large where the surface bends or the sampling is uneven,
//! near zero on flat, evenly sampled regions. A face's energy is the sum of its three vertex
//! energies; the threshold of a run is `ETC × mean face energy`.

use glam::DVec3;

use crate::mesh::Mesh;
use crate::topology::{Csr, Topology};

/// Vertex and face energies of a mesh.
#[derive(Debug, Clone)]
pub struct EnergyOperator {
    /// Energy of each vertex (0 for unreferenced vertices).
    pub vertex_energy: Vec<f64>,
    /// Energy of each face: the sum of its vertices' energies.
    pub face_energy: Vec<f64>,
    /// Mean face energy: the unit of ETC.
    pub mean_face_energy: f64,
}

/// Energy of one vertex from its position, its neighbours and their mean edge lengths.
pub(crate) fn vertex_energy(p: DVec3, neighbours: impl Iterator<Item = (DVec3, f64)>) -> f64 {
    let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
    for (q, mean_length) in neighbours {
        sum += (p - q) * mean_length;
        weight += mean_length;
    }
    if weight > 0.0 { sum.length() / weight } else { 0.0 }
}

impl EnergyOperator {
    /// Computes all energies of `mesh`.
    pub fn new(mesh: &Mesh) -> EnergyOperator {
        let topology = Topology::new(mesh);
        let neighbours = Csr::from_pairs(
            mesh.vertex_count(),
            topology.edges.iter().flat_map(|&[a, b]| [(a as usize, b), (b as usize, a)]),
        );
        let mean_length: Vec<f64> = (0..mesh.vertex_count())
            .map(|v| {
                let ring = neighbours.get(v);
                if ring.is_empty() {
                    return 0.0;
                }
                let p = mesh.point(v as u32);
                ring.iter().map(|&u| (mesh.point(u) - p).length()).sum::<f64>() / ring.len() as f64
            })
            .collect();
        let vertex_energy: Vec<f64> = (0..mesh.vertex_count())
            .map(|v| {
                vertex_energy(
                    mesh.point(v as u32),
                    neighbours.get(v).iter().map(|&u| (mesh.point(u), mean_length[u as usize])),
                )
            })
            .collect();
        let face_energy: Vec<f64> =
            mesh.triangles.iter().map(|t| t.iter().map(|&v| vertex_energy[v as usize]).sum()).collect();
        let mean_face_energy =
            if face_energy.is_empty() { 0.0 } else { face_energy.iter().sum::<f64>() / face_energy.len() as f64 };
        EnergyOperator { vertex_energy, face_energy, mean_face_energy }
    }

    /// The absolute energy threshold for an energy threshold coefficient.
    pub fn threshold(&self, etc: f64) -> f64 {
        etc * self.mean_face_energy
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;

    #[test]
    fn flat_regular_grid_has_zero_interior_energy() {
        let terrain = procedural::terrain(8, 0);
        let flat = Mesh::new(terrain.positions.iter().map(|p| [p[0], p[1], 0.0]).collect(), terrain.triangles).unwrap();
        let e = EnergyOperator::new(&flat);
        // Vertices whose neighbours all have full rings: the weighted umbrella vector cancels.
        let interior = (0..flat.vertex_count()).filter(|&v| {
            let p = flat.positions[v];
            p[0].abs() < 0.6 && p[1].abs() < 0.6
        });
        for v in interior {
            assert!(e.vertex_energy[v] < 1e-6, "vertex {v}: {}", e.vertex_energy[v]);
        }
        // Border vertices are one-sided: their energy is not zero.
        assert!(e.vertex_energy[0] > 0.01);
    }

    #[test]
    fn curved_regions_have_more_energy() {
        let blob = procedural::bumpy_blob(30, 60, 1);
        let sphere = procedural::icosphere(3);
        let mean = |m: &Mesh| EnergyOperator::new(m).mean_face_energy / m.surface_bounds().unwrap().diagonal();
        // Both are curved; energies are finite and positive.
        assert!(mean(&blob) > 0.0 && mean(&sphere) > 0.0);
        let e = EnergyOperator::new(&sphere);
        assert!((e.threshold(2.0) - 2.0 * e.mean_face_energy).abs() < 1e-15);
    }
}
