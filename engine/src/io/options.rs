//! What a reader may accept and how a writer writes: the limits every reader checks before it
//! allocates, and the options and destination of a write.

use std::path::Path;

use crate::error::MeshError;

/// Most corners one polygon of a file may have (its triangulation costs linear work whatever its
/// shape; this bounds the memory of one face).
pub const MAX_POLYGON_CORNERS: usize = 1 << 20;

/// Limits that protect a reader from files that claim (or contain) absurd amounts of data, and
/// the flag that stops a read.
#[derive(Debug, Clone)]
pub struct ReadLimits {
    /// Largest number of vertices accepted.
    pub max_vertices: u64,
    /// Largest number of triangles accepted (after triangulating polygons).
    pub max_faces: u64,
    /// Set to `true` by another thread to stop the read: [`MeshError::Cancelled`]. Read at every
    /// vertex and face (a relaxed load).
    pub cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl Default for ReadLimits {
    /// 50 million vertices and 100 million triangles: about 2.4 GB of mesh in memory.
    fn default() -> Self {
        ReadLimits { max_vertices: 50_000_000, max_faces: 100_000_000, cancel: None }
    }
}

impl ReadLimits {
    /// [`MeshError::Cancelled`] once the cancel flag is raised.
    pub(crate) fn check_cancel(&self) -> Result<(), MeshError> {
        match &self.cancel {
            Some(flag) if flag.load(std::sync::atomic::Ordering::Relaxed) => Err(MeshError::Cancelled),
            _ => Ok(()),
        }
    }

    /// [`MeshError::TooLarge`], naming `path`, when `count` vertices are over the limit.
    pub(crate) fn check_vertices(&self, count: u64, path: &Path) -> Result<(), MeshError> {
        self.check_cancel()?;
        if count > self.max_vertices {
            return Err(MeshError::TooLarge {
                file: Some(path.to_path_buf()),
                what: "vertices",
                count,
                limit: self.max_vertices,
            });
        }
        Ok(())
    }

    /// [`MeshError::TooLarge`], naming `path`, when `count` faces are over the limit.
    pub(crate) fn check_faces(&self, count: u64, path: &Path) -> Result<(), MeshError> {
        self.check_cancel()?;
        if count > self.max_faces {
            return Err(MeshError::TooLarge {
                file: Some(path.to_path_buf()),
                what: "faces",
                count,
                limit: self.max_faces,
            });
        }
        Ok(())
    }
}

/// How a mesh file is written.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WriteOptions {
    /// glTF only: the vertex data as integers under `KHR_mesh_quantization` (positions on a 16-bit
    /// grid, normals and tangents in 8 bits, texture coordinates and colours in 16;
    /// [`super::write_gltf_with`]), about half the bytes per vertex.
    pub quantize: bool,
}

/// Where a writer writes: the file (none for a stream), whether glTF goes as GLB, and the options.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Target<'a> {
    /// The file being written, when it is one: the files it refers to go beside it (an OBJ's MTL
    /// file and textures) or are referred to from its folder (a glTF's images that cannot be
    /// embedded).
    pub path: Option<&'a Path>,
    /// glTF only: the binary container (`.glb`) rather than JSON (`.gltf`).
    pub binary: bool,
    /// How the data is written.
    pub options: &'a WriteOptions,
}
