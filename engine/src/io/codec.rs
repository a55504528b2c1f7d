//! The codec table: one row per format, saying how it reads, how it writes (if it does) and what
//! it holds. Every read and write of [`super`] goes through a row, so a new format is one row and
//! its reader and writer.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::files::{folder_of, io_error};
use super::format::MeshFormat;
use super::options::{ReadLimits, Target, WriteOptions};
use crate::error::MeshError;
use crate::mesh::Mesh;

/// Reads a file's bytes; `folder` is where the files it refers to are found (`None` for bytes
/// alone, which then refer to nothing outside them).
type Read = fn(&[u8], &Path, Option<&Path>, &ReadLimits) -> Result<Mesh, MeshError>;
/// Writes a mesh to a stream.
type WriteFn = fn(&mut dyn Write, &Mesh, &Target) -> std::io::Result<()>;

/// One format's row.
pub(crate) struct Codec {
    /// The format.
    pub format: MeshFormat,
    /// Its reader.
    pub read: Read,
    /// Its writer; `None` for a format meshlod only reads.
    pub write: Option<WriteFn>,
    /// The per-corner attributes it holds, by [`crate::mesh::CornerAttributes::names`]; `None`:
    /// all of them, and the point and line primitives carried beside the triangles.
    pub holds: Option<&'static [&'static str]>,
    /// Whether it can store vertex data as integers ([`WriteOptions::quantize`]).
    pub quantizes: bool,
}

/// The table.
const CODECS: [Codec; 5] = [
    Codec {
        format: MeshFormat::Obj,
        read: super::obj::read_obj,
        write: Some(super::obj::write_obj_to),
        holds: Some(&["normal", "uv", "material"]),
        quantizes: false,
    },
    Codec {
        format: MeshFormat::Ply,
        read: |bytes, path, _, limits| super::ply::read_ply(bytes, path, limits),
        write: Some(|mut out, mesh, _| super::ply::write_ply(&mut out, mesh)),
        holds: Some(&["normal", "uv", "color"]),
        quantizes: false,
    },
    Codec {
        format: MeshFormat::Stl,
        read: |bytes, path, _, limits| super::stl::read_stl(bytes, path, limits),
        write: None,
        holds: Some(&[]),
        quantizes: false,
    },
    Codec {
        format: MeshFormat::Off,
        read: |bytes, path, _, limits| super::off::read_off(bytes, path, limits),
        write: None,
        holds: Some(&[]),
        quantizes: false,
    },
    Codec {
        format: MeshFormat::Gltf,
        read: super::gltf::read::read_gltf,
        write: Some(|out, mesh, target| {
            let folder = target.path.map(folder_of);
            super::gltf::write::write_gltf_with(out, mesh, target.binary, folder, target.options)
        }),
        holds: None,
        quantizes: true,
    },
];

/// The row of `format`.
pub(crate) fn codec(format: MeshFormat) -> &'static Codec {
    CODECS.iter().find(|c| c.format == format).expect("every format has a row")
}

/// Reads bytes in `format`; `folder` as [`Codec::read`].
pub(crate) fn read(
    format: MeshFormat,
    bytes: &[u8],
    path: &Path,
    folder: Option<&Path>,
    limits: &ReadLimits,
) -> Result<Mesh, MeshError> {
    (codec(format).read)(bytes, path, folder, limits)
}

/// Writes `mesh` in `format` to `out`; `Unsupported` for a read-only format.
pub(crate) fn write(out: &mut dyn Write, mesh: &Mesh, format: MeshFormat, target: &Target) -> std::io::Result<()> {
    match codec(format).write {
        Some(write) => write(out, mesh, target),
        None => Err(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            format!("{format:?} is read only: write .obj, .ply, .gltf or .glb"),
        )),
    }
}

impl MeshFormat {
    /// Whether meshlod can write this format (STL and OFF are read only): whether its row has a
    /// writer.
    pub fn writable(self) -> bool {
        codec(self).write.is_some()
    }
}

impl WriteOptions {
    /// Checks the options against the output's format before any work is done.
    pub fn check(&self, format: MeshFormat) -> Result<(), MeshError> {
        if self.quantize && !codec(format).quantizes {
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

/// The warning for what of `mesh`'s attributes `format` has no place for (OBJ: second texture
/// coordinates, tangents, colours, joints and weights; PLY: the same but colours, and materials),
/// or `None` when it holds them all.
pub fn unwritten_warning(format: MeshFormat, mesh: &Mesh) -> Option<String> {
    let holds = codec(format).holds.filter(|_| format.writable())?;
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

/// Writes `mesh` to the file `path`, in the format its extension names.
pub(crate) fn write_file(path: &Path, mesh: &Mesh, options: &WriteOptions) -> Result<(), MeshError> {
    let format = output_format(path)?;
    options.check(format)?;
    let file = std::fs::File::create(path).map_err(|e| io_error(path, e))?;
    let mut writer = std::io::BufWriter::new(file);
    let binary = !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
    let target = Target { path: Some(path), binary, options };
    write(&mut writer, mesh, format, &target).map_err(|e| io_error(path, e))?;
    writer.flush().map_err(|e| io_error(path, e))
}

/// The files beside `path` that a mesh file written there refers to and needs to draw as it was
/// written.
pub(crate) fn referenced_files(path: &Path) -> Vec<PathBuf> {
    match output_format(path) {
        Ok(MeshFormat::Obj) => super::mtl::referenced_files(path),
        _ => Vec::new(),
    }
}
