//! The peer every simplification figure is measured beside: meshoptimizer's `simplify` (positions
//! only, no error limit), shared by the simplify bench and the examples that run it.

use meshlod_engine::Mesh;

/// meshoptimizer's simplification of `mesh` towards `target_faces` (it may stop above); the result
/// keeps the input's vertex array, unused vertices included.
pub fn meshopt_simplify(mesh: &Mesh, target_faces: usize) -> Mesh {
    let bytes: Vec<u8> = mesh.positions.iter().flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes())).collect();
    let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("valid vertex data");
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let out = meshopt::simplify(&indices, &adapter, target_faces * 3, f32::MAX, meshopt::SimplifyOptions::None, None);
    Mesh::new(mesh.positions.clone(), out.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()).expect("valid")
}
