//! Flat shading: a mesh whose every corner's normal is its face's own (low-poly art, CAD exports,
//! glTF written without smoothing) is drawn flat whatever its faces become. Its normals are then
//! not values to keep, and as values they would make every edge a seam and every vertex a corner
//! of three or more sets, so that nothing could collapse: the run goes without them, and the
//! result is given its faces' normals again.

use crate::mesh::Mesh;

/// Largest angle between a corner's normal and its face's for the mesh to count as flat-shaded.
const FLAT_DEGREES: f64 = 1.0;

/// Whether `mesh` has normals and every one is its face's own (within [`FLAT_DEGREES`]); faces
/// without area are passed over, and one face with area is needed.
pub(super) fn is_flat_shaded(mesh: &Mesh) -> bool {
    let Some(normals) = mesh.corners.normals() else { return false };
    let cos = FLAT_DEGREES.to_radians().cos();
    let mut with_area = 0usize;
    for f in 0..mesh.face_count() {
        let face = mesh.face_area_vector(f).normalize_or_zero();
        if face == glam::DVec3::ZERO {
            continue;
        }
        with_area += 1;
        let flat = (3 * f..3 * f + 3).all(|k| {
            let n = glam::DVec3::from(normals[k].map(f64::from)).normalize_or_zero();
            n.dot(face) >= cos
        });
        if !flat {
            return false;
        }
    }
    with_area > 0
}

/// `mesh` without its normals.
pub(super) fn without_normals(mesh: &Mesh) -> Mesh {
    let mut out = mesh.clone();
    out.corners.set_normals(None);
    out
}

/// Gives every corner its face's unit normal (a face without area: +z, so that every normal is a
/// unit vector). Each component is rounded to a multiple of 2⁻²⁰ (and −0 made +0), so that
/// coplanar faces, whose computed normals differ in their last bits, get the same one and no seam
/// between them.
pub(super) fn with_flat_normals(mesh: &mut Mesh) {
    const STEP: f64 = (1u64 << 20) as f64;
    let normals = (0..mesh.face_count())
        .flat_map(|f| {
            let n = mesh.face_area_vector(f).normalize_or_zero();
            let n = if n == glam::DVec3::ZERO { glam::DVec3::Z } else { n };
            [n.to_array().map(|c| ((c * STEP).round() / STEP + 0.0) as f32); 3]
        })
        .collect();
    mesh.corners.set_normals(Some(normals));
}
