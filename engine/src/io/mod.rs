//! Reading and writing meshes: OBJ, PLY (ascii, binary little and big endian) and glTF 2.0
//! (`.gltf`, `.glb`) in and out; STL (binary and ascii) and OFF (ascii) in.
//!
//! Readers treat every file as untrusted: nothing is allocated from a header count before the data
//! that backs it has been seen, every index is range-checked, every coordinate must be finite, and
//! errors name the file and the line, byte or element at fault.
//!
//! Rooms, in data-flow order: `format` tells a file's format; `options` holds the read limits and
//! the write options; `codec` is the table that maps a format to its reader and writer; the
//! readers and writers (`obj` with `mtl`, `ply`, `stl`, `off`, `gltf/`) and what they share
//! (`triangulate`, `files`). This file only names what the crate offers.

mod codec;
mod files;
mod format;
mod gltf;
mod mtl;
mod obj;
mod off;
mod options;
mod ply;
mod stl;
mod triangulate;

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::MeshError;
use crate::mesh::Mesh;

pub use codec::{output_format, unwritten_warning};
pub use format::MeshFormat;
pub use gltf::read::read_gltf;
pub use gltf::write::{write_gltf, write_gltf_with};
pub use obj::{read_obj, write_obj};
pub use off::read_off;
pub use options::{MAX_POLYGON_CORNERS, ReadLimits, WriteOptions};
pub use ply::{read_ply, write_ply};
pub use stl::read_stl;

/// Reads a mesh from bytes in a known or sniffed format. `name` is used in error messages.
pub fn read_mesh_bytes(
    bytes: &[u8],
    format: Option<MeshFormat>,
    name: &Path,
    limits: &ReadLimits,
) -> Result<Mesh, MeshError> {
    let format = format.or_else(|| MeshFormat::sniff(bytes)).ok_or_else(|| MeshError::UnsupportedFormat {
        path: name.to_path_buf(),
        reason: "neither the extension nor the content says OBJ, PLY, STL, OFF or glTF".into(),
    })?;
    // Bytes alone: files outside them are not read.
    codec::read(format, bytes, name, None, limits)
}

/// Reads a mesh file, choosing the format by extension and falling back to the content.
pub fn read_mesh(path: impl AsRef<Path>) -> Result<Mesh, MeshError> {
    read_mesh_with_limits(path, &ReadLimits::default())
}

/// [`read_mesh`] with explicit limits.
pub fn read_mesh_with_limits(path: impl AsRef<Path>, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| files::io_error(path, e))?;
    let format = MeshFormat::from_extension(path).or_else(|| MeshFormat::sniff(&bytes));
    match format {
        // A file on disk: its external buffers, images and material files are found next to it.
        Some(format) => codec::read(format, &bytes, path, Some(files::folder_of(path)), limits),
        None => read_mesh_bytes(&bytes, None, path, limits),
    }
}

/// Writes a mesh in the given format to any writer (glTF as GLB, its images embedded);
/// `Unsupported` for a read-only format.
pub fn write_mesh_to(mut out: impl Write, mesh: &Mesh, format: MeshFormat) -> std::io::Result<()> {
    let target = options::Target { path: None, binary: true, options: &WriteOptions::default() };
    codec::write(&mut out, mesh, format, &target)
}

/// Writes a mesh to a file whose extension (`.obj`, `.ply`, `.gltf`, `.glb`) picks the format.
/// An OBJ with materials gets its MTL file beside it (`OUT.mtl`, named by `mtllib`), with the
/// materials' textures.
pub fn write_mesh(path: impl AsRef<Path>, mesh: &Mesh) -> Result<(), MeshError> {
    write_mesh_with(path, mesh, &WriteOptions::default())
}

/// [`write_mesh`] with the [`WriteOptions`].
pub fn write_mesh_with(path: impl AsRef<Path>, mesh: &Mesh, options: &WriteOptions) -> Result<(), MeshError> {
    codec::write_file(path.as_ref(), mesh, options)
}

/// The files beside `path` that a mesh file written there by [`write_mesh`] refers to and needs to
/// draw as it was written: an OBJ's MTL files and their textures (a glTF's images are referred
/// to where they were, not written). A tool that skips up-to-date outputs checks these too.
pub fn referenced_files(path: impl AsRef<Path>) -> Vec<PathBuf> {
    codec::referenced_files(path.as_ref())
}

#[cfg(all(test, unix))]
mod tests {
    #[test]
    fn a_referenced_file_is_read_only_when_regular() {
        // A device is refused before any read (this one would never end).
        let e = super::files::read_referenced(std::path::Path::new("/dev/zero")).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        let file = std::env::temp_dir().join(format!("meshlod-referenced-{}", std::process::id()));
        std::fs::write(&file, b"bytes").unwrap();
        assert_eq!(super::files::read_referenced(&file).unwrap(), b"bytes");
        std::fs::remove_file(file).unwrap();
    }
}
