//! Reading and writing meshes: OBJ, PLY (ascii, binary little and big endian) and glTF 2.0
//! (`.gltf`, `.glb`) in and out; STL (binary and ascii) and OFF (ascii) in.
//!
//! Readers treat every file as untrusted: nothing is allocated from a header count before the data
//! that backs it has been seen, every index is range-checked, every coordinate must be finite, and
//! errors name the file and the line, byte or element at fault.

mod gltf;
mod gltf_checks;
mod gltf_other;
mod gltf_write;
mod mtl;
mod obj;
mod off;
mod ply;
mod stl;
mod triangulate;

/// Most corners one polygon of a file may have (its triangulation costs linear work whatever its
/// shape; this bounds the memory of one face).
pub const MAX_POLYGON_CORNERS: usize = 1 << 20;

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::MeshError;
use crate::mesh::Mesh;

pub use gltf::read_gltf;
pub(crate) use gltf_other::check as check_other_primitive;
pub use gltf_write::{write_gltf, write_gltf_with};
pub use obj::{read_obj, write_obj};
pub use off::read_off;
pub use ply::{read_ply, write_ply};
pub use stl::read_stl;

/// Mesh file formats meshlod reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ (text).
    Obj,
    /// Stanford PLY (ascii or binary; written as binary little endian).
    Ply,
    /// STL, binary or ascii (read only): facets welded by position.
    Stl,
    /// Object File Format, ascii (read only).
    Off,
    /// glTF 2.0, `.gltf` (JSON) or `.glb` (binary container); written as GLB to a stream, and as
    /// the file's extension says to a file.
    Gltf,
}

impl MeshFormat {
    /// Format implied by a file name's extension, if any.
    pub fn from_extension(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(MeshFormat::Obj),
            "ply" => Some(MeshFormat::Ply),
            "stl" => Some(MeshFormat::Stl),
            "off" => Some(MeshFormat::Off),
            "gltf" | "glb" => Some(MeshFormat::Gltf),
            _ => None,
        }
    }

    /// Whether meshlod can write this format (STL and OFF are read only).
    pub fn writable(self) -> bool {
        matches!(self, MeshFormat::Obj | MeshFormat::Ply | MeshFormat::Gltf)
    }

    /// Format recognised from a file's bytes: PLY and OFF have a magic word, binary STL a size
    /// that matches its facet count, ascii STL begins with `solid`, OBJ is text.
    pub fn sniff(bytes: &[u8]) -> Option<MeshFormat> {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            return Some(MeshFormat::Ply);
        }
        if gltf::is_gltf(bytes) {
            return Some(MeshFormat::Gltf);
        }
        if off::is_off(bytes) {
            return Some(MeshFormat::Off);
        }
        if stl::is_binary(bytes) || stl::is_ascii(bytes) {
            return Some(MeshFormat::Stl);
        }
        let head = &bytes[..bytes.len().min(4096)];
        let is_text =
            head.iter().all(|&b| b == b'\n' || b == b'\r' || b == b'\t' || (0x20..0x7f).contains(&b) || b >= 0x80);
        (is_text && starts_with_obj_statement(bytes)).then_some(MeshFormat::Obj)
    }
}

/// Statements an OBJ file may begin with (after comments and blank lines).
const OBJ_KEYWORDS: [&[u8]; 20] = [
    b"v", b"vt", b"vn", b"vp", b"f", b"l", b"p", b"o", b"g", b"s", b"mtllib", b"usemtl", b"usemap", b"maplib",
    b"cstype", b"deg", b"curv", b"surf", b"call", b"csh",
];

/// Whether the first line of `bytes` that is neither blank nor a comment starts with an OBJ
/// statement. A comment alone does not make a text an OBJ file: a Markdown heading starts
/// with `#` too.
fn starts_with_obj_statement(bytes: &[u8]) -> bool {
    let first = bytes.split(|&b| b == b'\n').map(<[u8]>::trim_ascii).find(|l| !l.is_empty() && !l.starts_with(b"#"));
    first.is_some_and(|line| {
        let keyword = line.split(|b| b.is_ascii_whitespace()).next().unwrap_or_default();
        OBJ_KEYWORDS.contains(&keyword)
    })
}

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

fn io_error(path: &Path, err: std::io::Error) -> MeshError {
    MeshError::Io { path: path.to_path_buf(), message: err.to_string() }
}

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
    match format {
        MeshFormat::Obj => read_obj(bytes, name, None, limits),
        MeshFormat::Ply => read_ply(bytes, name, limits),
        MeshFormat::Stl => read_stl(bytes, name, limits),
        MeshFormat::Off => read_off(bytes, name, limits),
        // Bytes alone: buffers outside them are not read.
        MeshFormat::Gltf => read_gltf(bytes, name, None, limits),
    }
}

/// Reads a file that a mesh file refers to (a glTF buffer, a texture image): only a regular file,
/// so that a reference to a device or a pipe (`/dev/zero`) is refused rather than read forever.
pub(crate) fn read_referenced(path: &Path) -> std::io::Result<Vec<u8>> {
    if !std::fs::metadata(path)?.is_file() {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"));
    }
    std::fs::read(path)
}

/// The folder of file `path` (`.` for a bare file name): where the files it refers to are found
/// or written.
pub(super) fn folder_of(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Reads a mesh file, choosing the format by extension and falling back to the content.
pub fn read_mesh(path: impl AsRef<Path>) -> Result<Mesh, MeshError> {
    read_mesh_with_limits(path, &ReadLimits::default())
}

/// [`read_mesh`] with explicit limits.
pub fn read_mesh_with_limits(path: impl AsRef<Path>, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
    let format = MeshFormat::from_extension(path).or_else(|| MeshFormat::sniff(&bytes));
    // A file on disk: its external buffers, images and material files are found next to it.
    let folder = Some(folder_of(path));
    match format {
        Some(MeshFormat::Gltf) => return read_gltf(&bytes, path, folder, limits),
        Some(MeshFormat::Obj) => return read_obj(&bytes, path, folder, limits),
        _ => {}
    }
    read_mesh_bytes(&bytes, format, path, limits)
}

/// Writes a mesh in the given format to any writer (glTF as GLB, its images embedded);
/// `Unsupported` for a read-only format.
pub fn write_mesh_to(mut out: impl Write, mesh: &Mesh, format: MeshFormat) -> std::io::Result<()> {
    match format {
        MeshFormat::Obj => write_obj(&mut out, mesh),
        MeshFormat::Ply => write_ply(&mut out, mesh),
        MeshFormat::Gltf => write_gltf(&mut out, mesh, true, None),
        MeshFormat::Stl | MeshFormat::Off => Err(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            format!("{format:?} is read only: write .obj, .ply, .gltf or .glb"),
        )),
    }
}

/// The warning for what of `mesh`'s attributes `format` has no place for (OBJ: second texture
/// coordinates, tangents, colours, joints and weights; PLY: the same but colours, and materials),
/// or `None` when it holds them all.
pub fn unwritten_warning(format: MeshFormat, mesh: &Mesh) -> Option<String> {
    let holds: &[&str] = match format {
        MeshFormat::Obj => &["normal", "uv", "material"],
        MeshFormat::Ply => &["normal", "uv", "color"],
        _ => return None,
    };
    let mut lost: Vec<&str> = mesh.corners.names().into_iter().filter(|n| !holds.contains(n)).collect();
    if mesh.corners.library.as_ref().is_some_and(|l| !l.other_primitives.is_empty()) {
        lost.push("point and line primitives");
    }
    (!lost.is_empty())
        .then(|| format!("{format:?} has no place for the mesh's {}: write .glb to keep them", lost.join(", ")))
}

/// The format an output file asks for by its extension, checked before any work is done: a
/// known extension, and a folder that exists.
pub fn output_format(path: impl AsRef<Path>) -> Result<MeshFormat, MeshError> {
    let path = path.as_ref();
    let format =
        MeshFormat::from_extension(path).filter(|f| f.writable()).ok_or_else(|| MeshError::UnsupportedFormat {
            path: PathBuf::from(path),
            reason: "output extension must be .obj, .ply, .gltf or .glb (STL and OFF are read only)".into(),
        })?;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        return Err(MeshError::Io { path: PathBuf::from(path), message: "its folder does not exist".into() });
    }
    Ok(format)
}

/// How a mesh file is written.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WriteOptions {
    /// glTF only: the vertex data as integers under `KHR_mesh_quantization` (positions on a 16-bit
    /// grid, normals and tangents in 8 bits, texture coordinates and colours in 16;
    /// [`write_gltf_with`]), about half the bytes per vertex.
    pub quantize: bool,
}

impl WriteOptions {
    /// Checks the options against the output's format before any work is done.
    pub fn check(&self, format: MeshFormat) -> Result<(), MeshError> {
        if self.quantize && format != MeshFormat::Gltf {
            return Err(MeshError::InvalidParameter {
                name: "quantize",
                reason: format!(
                    "KHR_mesh_quantization is a glTF extension: {format:?} output has no place for it; write .glb or .gltf"
                ),
            });
        }
        Ok(())
    }
}

/// Writes a mesh to a file whose extension (`.obj`, `.ply`, `.gltf`, `.glb`) picks the format.
/// An OBJ with materials gets its MTL file beside it (`OUT.mtl`, named by `mtllib`), with the
/// materials' base-colour textures (`mtl::write_library`).
pub fn write_mesh(path: impl AsRef<Path>, mesh: &Mesh) -> Result<(), MeshError> {
    write_mesh_with(path, mesh, &WriteOptions::default())
}

/// The files beside `path` that a mesh file written there by [`write_mesh`] refers to and needs to
/// draw as it was written: an OBJ's MTL files and their textures (a glTF's images are referred
/// to where they were, not written). A tool that skips up-to-date outputs checks these too.
pub fn referenced_files(path: impl AsRef<Path>) -> Vec<PathBuf> {
    let path = path.as_ref();
    match output_format(path) {
        Ok(MeshFormat::Obj) => mtl::referenced_files(path),
        _ => Vec::new(),
    }
}

/// [`write_mesh`] with the [`WriteOptions`].
pub fn write_mesh_with(path: impl AsRef<Path>, mesh: &Mesh, options: &WriteOptions) -> Result<(), MeshError> {
    let path = path.as_ref();
    let format = output_format(path)?;
    options.check(format)?;
    let file = std::fs::File::create(path).map_err(|e| io_error(path, e))?;
    let mut writer = std::io::BufWriter::new(file);
    if format == MeshFormat::Gltf {
        let binary = !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
        write_gltf_with(&mut writer, mesh, binary, Some(folder_of(path)), options).map_err(|e| io_error(path, e))?;
    } else if let (MeshFormat::Obj, Some(_), Some(library)) = (format, &mesh.corners.materials, &mesh.corners.library)
        && !library.materials.is_empty()
    {
        // The materials in an MTL file of the same stem, their textures beside it.
        let mtl = path.with_extension("mtl");
        mtl::write_library(&mtl, library).map_err(|e| io_error(&mtl, e))?;
        let name = mtl.file_name().map(|n| n.to_string_lossy().into_owned());
        obj::write_obj_with_library(&mut writer, mesh, name.as_deref()).map_err(|e| io_error(path, e))?;
    } else {
        write_mesh_to(&mut writer, mesh, format).map_err(|e| io_error(path, e))?;
    }
    writer.flush().map_err(|e| io_error(path, e))
}

#[cfg(all(test, unix))]
mod tests {
    #[test]
    fn a_referenced_file_is_read_only_when_regular() {
        // A device is refused before any read (this one would never end).
        let e = super::read_referenced(std::path::Path::new("/dev/zero")).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        let file = std::env::temp_dir().join(format!("meshlod-referenced-{}", std::process::id()));
        std::fs::write(&file, b"bytes").unwrap();
        assert_eq!(super::read_referenced(&file).unwrap(), b"bytes");
        std::fs::remove_file(file).unwrap();
    }
}
