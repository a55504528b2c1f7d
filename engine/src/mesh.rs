//! The indexed triangle mesh every algorithm reads and writes.
//!
//! Positions are stored as `f32` exactly as read from a file (so a round trip is bit-exact); every
//! geometric computation widens them to `f64` first (`Mesh::point`).

use glam::DVec3;
use serde::Serialize;

pub use crate::attributes::{Channel, CornerAttributes, NO_MATERIAL, Semantic, Values, Wedges};
use crate::error::MeshError;
pub use crate::ids::{FaceId, NONE, VertexId};
pub use crate::library::{Image, ImageSource, MaterialLibrary, OtherPrimitive, Rig, RigAccessor};

/// Scales a vertex's skin weights to sum to 1, as glTF requires (negative ones taken as 0): the
/// sum taken in order in single precision, as the Khronos validator takes it, is then 1 within its
/// tolerance (2e-7 per weight that is not 0). Whether they changed; weights that already sum to 1
/// or have no positive one are left as they are.
pub fn normalize_weights(w: &mut [f32; 4]) -> bool {
    let sum = |w: &[f32; 4]| w.iter().fold(0f32, |s, &x| s + x);
    let close = |w: &[f32; 4]| {
        let tolerance = 2e-7 * w.iter().filter(|&&x| x != 0.0).count() as f64;
        (sum(w) as f64 - 1.0).abs() <= tolerance && w.iter().all(|&x| x >= 0.0)
    };
    let total: f64 = w.iter().map(|&x| x.max(0.0) as f64).sum();
    if close(w) || !(total > 0.0 && total.is_finite()) {
        return false;
    }
    *w = w.map(|x| (x.max(0.0) as f64 / total) as f32);
    if !close(w) {
        // The rounding left on the largest weight.
        let k = (0..4).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
        w[k] += 1.0 - sum(w);
    }
    true
}

/// An indexed triangle mesh.
///
/// Invariants upheld by [`Mesh::new`]: every coordinate is finite and every index is in range.
/// Degenerate, duplicate or non-manifold faces are allowed (they are reported by
/// [`crate::validate::validate`] and removed by [`crate::validate::clean`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, as read.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as counter-clockwise vertex index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Optional per-corner attributes.
    pub corners: CornerAttributes,
}

/// An axis-aligned bounding box in f64.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    /// Smallest corner.
    pub min: [f64; 3],
    /// Largest corner.
    pub max: [f64; 3],
}

impl Bounds {
    /// Length of the box diagonal.
    pub fn diagonal(&self) -> f64 {
        (DVec3::from(self.max) - DVec3::from(self.min)).length()
    }

    /// Length of the largest side.
    pub fn largest_side(&self) -> f64 {
        (DVec3::from(self.max) - DVec3::from(self.min)).max_element()
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        (DVec3::from(self.max) + DVec3::from(self.min)) * 0.5
    }
}

impl Mesh {
    /// Builds a mesh, checking that coordinates are finite and indices are in range.
    pub fn new(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        let mesh = Mesh { positions, triangles, corners: CornerAttributes::default() };
        mesh.check()?;
        Ok(mesh)
    }

    /// Checks the invariants documented on [`Mesh`].
    pub fn check(&self) -> Result<(), MeshError> {
        if let Some(vertex) = first_non_finite(&self.positions) {
            let value = self.positions[vertex].into_iter().find(|c| !c.is_finite()).unwrap_or(f32::NAN);
            return Err(MeshError::NonFiniteCoordinate { vertex, value: value.to_string() });
        }
        let vertex_count = self.positions.len();
        // The largest index first, in one pass without a branch per index; the face only on failure.
        let largest = self.triangles.iter().flatten().fold(0u32, |m, &i| m.max(i));
        if largest as usize >= vertex_count {
            for (face, t) in self.triangles.iter().enumerate() {
                if let Some(&index) = t.iter().find(|&&i| i as usize >= vertex_count) {
                    return Err(MeshError::IndexOutOfRange { face, index: index as i64, vertex_count });
                }
            }
        }
        self.corners.check(3 * self.triangles.len())
    }

    /// For each vertex, the first vertex at its position (bit-identical, −0 and +0 alike): itself
    /// where it is the first or the only one there.
    pub fn first_at_each_position(&self) -> Vec<u32> {
        let mut first: std::collections::HashMap<[u32; 3], u32> =
            std::collections::HashMap::with_capacity(self.positions.len());
        let key = |p: &[f32; 3]| p.map(|c| (c + 0.0).to_bits());
        (0..self.positions.len() as u32).map(|v| *first.entry(key(&self.positions[v as usize])).or_insert(v)).collect()
    }

    /// Number of vertices (including unreferenced ones).
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn face_count(&self) -> usize {
        self.triangles.len()
    }

    /// Position of a vertex, widened to f64.
    #[inline]
    pub fn point(&self, v: u32) -> DVec3 {
        let p = self.positions[v as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// The three corners of a triangle, widened to f64.
    #[inline]
    pub fn triangle_points(&self, f: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[f];
        [self.point(a), self.point(b), self.point(c)]
    }

    /// Unnormalised face normal (twice the area vector).
    #[inline]
    pub fn face_area_vector(&self, f: usize) -> DVec3 {
        let [a, b, c] = self.triangle_points(f);
        (b - a).cross(c - a)
    }

    /// Area of a triangle.
    pub fn face_area(&self, f: usize) -> f64 {
        0.5 * self.face_area_vector(f).length()
    }

    /// Bounding box of the vertices that some face references; `None` if there are no faces.
    ///
    /// Unreferenced vertices do not count: they are not part of the surface.
    pub fn surface_bounds(&self) -> Option<Bounds> {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for &v in t {
                let p = self.point(v);
                min = min.min(p);
                max = max.max(p);
            }
        }
        (!self.triangles.is_empty()).then(|| Bounds { min: min.into(), max: max.into() })
    }

    /// Bounding box of all vertices; `None` if there are none.
    pub fn bounds(&self) -> Option<Bounds> {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for v in 0..self.positions.len() {
            let p = self.point(v as u32);
            min = min.min(p);
            max = max.max(p);
        }
        (!self.positions.is_empty()).then(|| Bounds { min: min.into(), max: max.into() })
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|f| self.face_area(f)).sum()
    }
}

/// Distances in meshlod are reported in two units, both relative to a reference mesh's bounding box.
///
/// * **paper units**: the mesh centred and scaled so that the largest side of its bounding box spans
///   [−1, 1], i.e. `distance × 2 / largest_side`. This is the unit of the QFVP paper's tables.
/// * **% of diagonal**: `distance / diagonal × 100`, the unit MeshLab's Metro prints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceUnits {
    largest_side: f64,
    diagonal: f64,
}

impl DistanceUnits {
    /// Units relative to `bounds`.
    pub fn new(bounds: &Bounds) -> Self {
        DistanceUnits { largest_side: bounds.largest_side(), diagonal: bounds.diagonal() }
    }

    /// Converts an absolute distance to paper units.
    pub fn to_paper(&self, distance: f64) -> f64 {
        if self.largest_side > 0.0 { distance * 2.0 / self.largest_side } else { 0.0 }
    }

    /// Converts an absolute distance to percent of the bounding-box diagonal.
    pub fn to_diagonal_percent(&self, distance: f64) -> f64 {
        if self.diagonal > 0.0 { distance / self.diagonal * 100.0 } else { 0.0 }
    }

    /// Converts a distance in paper units back to an absolute distance.
    pub fn from_paper(&self, paper: f64) -> f64 {
        paper * self.largest_side / 2.0
    }
}

/// The first of `values` with a component that is not finite: one pass without a branch per
/// component (validation reads every value of every mesh), the position only on failure.
fn first_non_finite<const N: usize>(values: &[[f32; N]]) -> Option<usize> {
    let all_finite = values.iter().flatten().fold(true, |ok, c| ok & c.is_finite());
    if all_finite { None } else { values.iter().position(|v| v.iter().any(|c| !c.is_finite())) }
}
