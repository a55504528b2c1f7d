//! The ids and the one sentinel of the engine's `u32` index arrays.

use serde::Serialize;

/// Index of a vertex in `Mesh::positions`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize)]
pub struct VertexId(pub u32);

/// Index of a triangle in `Mesh::triangles`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize)]
pub struct FaceId(pub u32);

impl VertexId {
    /// The id as a `usize` for indexing per-vertex arrays.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl FaceId {
    /// The id as a `usize` for indexing per-face arrays.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// No vertex, face, edge, corner or value: the one sentinel of the engine's `u32` index arrays
/// (an absent `vl` or `vr` of a vertex split, a face corner outside the edge table, an empty slot).
pub const NONE: u32 = u32::MAX;
