//! The formats meshlod knows, told apart by a file's extension or by its first bytes.

use std::path::Path;

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

    /// Format recognised from a file's bytes: PLY and OFF have a magic word, binary STL a size
    /// that matches its facet count, ascii STL begins with `solid`, OBJ is text.
    pub fn sniff(bytes: &[u8]) -> Option<MeshFormat> {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            return Some(MeshFormat::Ply);
        }
        if super::gltf::read::is_gltf(bytes) {
            return Some(MeshFormat::Gltf);
        }
        if super::off::is_off(bytes) {
            return Some(MeshFormat::Off);
        }
        if super::stl::is_binary(bytes) || super::stl::is_ascii(bytes) {
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
