//! The `.pm` file: a progressive mesh, little endian, versioned, checksummed.
//! The layout is specified in `docs/pm-format.md`; this module is its reference implementation.
//! [`encode`] writes the compact form (version 3, values on integer grids); [`encode_lossless`]
//! writes every float as it is (version 1, or 2 with attributes). [`decode`] reads all three.
//!
//! Rooms: `header` (what every version shares: header, attribute mask, checksum, the byte
//! reader), `lossless` (versions 1 and 2), `compact` (version 3) on `grid` and `bits`, and
//! `library_json` (the materials section).

mod bits;
mod compact;
mod grid;
mod header;
mod library_json;
mod lossless;

use std::path::Path;

pub use grid::{Grid, Precision, Quantization};
pub use header::{MAGIC, VERSION};
pub use lossless::encode_lossless;

use crate::error::MeshError;
use crate::pm::ProgressiveMesh;
use header::*;

/// Bytes of the materials section (images inside) in `pm`'s file, whichever form: 0 without one.
/// The rest of the file is the records.
pub fn materials_section_len(pm: &ProgressiveMesh) -> usize {
    let (_, library) = header(&mut Vec::new(), pm, false);
    library.map_or(0, |library| {
        let n = library_json::to_text(library).len();
        let mut length = Vec::new();
        put_varint(&mut length, n as u64);
        length.len() + n
    })
}

/// Encodes a progressive mesh in the compact form (version 3) at the default [`Precision`].
pub fn encode(pm: &ProgressiveMesh) -> Vec<u8> {
    encode_on(pm, &Quantization::fit(pm, &Precision::default()))
}

/// Encodes a progressive mesh in the compact form on the grids `quantization` gives: those
/// [`decode`] returns with a compact file, so that writing it again gives the same bytes.
pub fn encode_on(pm: &ProgressiveMesh, quantization: &Quantization) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_SIZE + 8 * pm.base().face_count() + 12 * pm.levels() + CHECKSUM_SIZE);
    let (attributes, library) = header(&mut out, pm, false);
    compact::encode_geometry(&mut out, pm, &quantization.positions);
    if let Some(a) = attributes {
        compact::encode_attributes(&mut out, pm, a, attribute_mask(&a.values), quantization);
    }
    finish(out, library.map(library_json::to_text))
}

/// Encodes a progressive mesh in the compact form with the grids fitted at `precision`.
pub fn encode_compact(pm: &ProgressiveMesh, precision: &Precision) -> Vec<u8> {
    encode_on(pm, &Quantization::fit(pm, precision))
}

/// Writes a `.pm` file.
pub fn write_pm(path: impl AsRef<Path>, pm: &ProgressiveMesh) -> Result<(), MeshError> {
    let path = path.as_ref();
    std::fs::write(path, encode(pm)).map_err(|e| MeshError::Io { path: path.to_path_buf(), message: e.to_string() })
}

/// Decodes and validates a `.pm` file's bytes. `path` names the file in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<(ProgressiveMesh, Option<Quantization>), MeshError> {
    let mut r = Reader { bytes, offset: 0, path };
    if bytes.len() < HEADER_SIZE + CHECKSUM_SIZE {
        return Err(r.error(format!("{} bytes is shorter than a header and checksum (truncated)", bytes.len())));
    }
    if r.take(4)? != MAGIC {
        return Err(MeshError::parse(path, "byte 0", "not a meshlod .pm file (bad magic)"));
    }
    let version = u16::from_le_bytes(r.take(2)?.try_into().expect("2 bytes"));
    if version == 0 || version > VERSION {
        return Err(MeshError::parse(
            path,
            "byte 4",
            format!("format version {version}; this reader knows 1 to {VERSION}"),
        ));
    }
    let flags = u16::from_le_bytes(r.take(2)?.try_into().expect("2 bytes"));
    if flags & !(HAS_ATTRIBUTES | HAS_MATERIALS | HAS_CHANNELS) != 0
        || (version == 1 && flags != 0)
        || (flags & (HAS_MATERIALS | HAS_CHANNELS) != 0 && flags & HAS_ATTRIBUTES == 0)
    {
        return Err(MeshError::parse(path, "byte 6", format!("unknown flags {flags:#06x} for version {version}")));
    }
    let (payload, stored) = bytes.split_at(bytes.len() - CHECKSUM_SIZE);
    if fnv1a(payload) != u64::from_le_bytes(stored.try_into().expect("8 bytes")) {
        return Err(MeshError::parse(path, "checksum", "checksum mismatch: the file is corrupt or truncated"));
    }
    let r_bytes = payload;
    let mut r = Reader { bytes: r_bytes, offset: r.offset, path };
    let vertex_count = r.u32()? as usize;
    let face_count = r.u32()? as usize;
    let split_count = r.u32()? as usize;
    r.u32()?;
    let named = |e: MeshError| match e {
        MeshError::Parse { location, reason, .. } => MeshError::Parse { path: path.to_path_buf(), location, reason },
        other => other,
    };
    if version == 3 {
        let (base, splits, grid) = compact::decode_geometry(&mut r, vertex_count, face_count, split_count)?;
        let mut pm = ProgressiveMesh::from_stream(base, splits).map_err(named)?;
        let mut quantization = Quantization { positions: grid, normal_bits: 0, uvs: None, colors: None, uvs1: None };
        if flags & HAS_ATTRIBUTES != 0 {
            let (mut a, normal_bits, uvs, colors, uvs1) =
                compact::decode_attributes(&mut r, &pm, flags & HAS_CHANNELS != 0)?;
            quantization = Quantization { normal_bits, uvs, colors, uvs1, ..quantization };
            if flags & HAS_MATERIALS != 0 {
                library_json::read_library(&mut r, &mut a)?;
            }
            pm = pm.with_attributes(a).map_err(named)?;
        }
        if r.offset != r_bytes.len() {
            return Err(r.error(format!("{} unexpected bytes after the last section", r_bytes.len() - r.offset)));
        }
        return Ok((pm, Some(quantization)));
    }
    lossless::decode(r, flags, (vertex_count, face_count, split_count), named).map(|pm| (pm, None))
}

/// Reads a `.pm` file (the grids of a compact one are left out: [`decode`] gives them).
pub fn read_pm(path: impl AsRef<Path>) -> Result<ProgressiveMesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| MeshError::Io { path: path.to_path_buf(), message: e.to_string() })?;
    decode(&bytes, path).map(|(pm, _)| pm)
}
