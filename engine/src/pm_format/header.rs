//! What every version of the `.pm` file shares: the header's magic, version, flags and counts,
//! the attribute mask, the materials section and checksum at the end, and the byte reader.

use std::path::Path;

use crate::error::MeshError;
use crate::mesh::{CornerAttributes, MaterialLibrary};
use crate::pm::{PmAttributes, ProgressiveMesh};

/// First four bytes of a `.pm` file.
pub const MAGIC: [u8; 4] = *b"MLPM";
/// Newest format version: 3, the compact form. Version 2 adds per-corner attributes to version
/// 1; a lossless progressive mesh without attributes is written as version 1.
pub const VERSION: u16 = 3;
/// Header flag: an attribute section follows the splits (versions 2 and 3).
pub(super) const HAS_ATTRIBUTES: u16 = 1;
pub(super) const ATTRIBUTE_NORMAL: u8 = 1;
pub(super) const ATTRIBUTE_UV: u8 = 2;
pub(super) const ATTRIBUTE_COLOR: u8 = 4;
pub(super) const ATTRIBUTE_UV_ORIGIN_TOP: u8 = 8;
pub(super) const ATTRIBUTE_MATERIAL: u8 = 16;
/// Joints and weights (glTF JOINTS_0 and WEIGHTS_0), always together.
pub(super) const ATTRIBUTE_SKIN: u8 = 32;
/// Tangents (glTF TANGENT).
pub(super) const ATTRIBUTE_TANGENT: u8 = 64;
/// Second texture coordinates (glTF TEXCOORD_1).
pub(super) const ATTRIBUTE_UV1: u8 = 128;
/// Header flag: the materials, textures and images the material numbers refer to follow the
/// attribute section, as JSON (versions 2 and 3).
pub(super) const HAS_MATERIALS: u16 = 2;
pub(super) const HEADER_SIZE: usize = 24;
pub(super) const CHECKSUM_SIZE: usize = 8;
/// Fewest bytes a split takes: flags, a one-byte vs, a position, the error.
pub(super) const MIN_SPLIT_SIZE: usize = 1 + 1 + 12 + 4;

pub(super) const HAS_VL: u8 = 1;
pub(super) const HAS_VR: u8 = 2;
pub(super) const MOVES_VS: u8 = 4;
/// With both `HAS_VL` and `HAS_VR`: `vl` (or `vr`) is the corner of a hole the split opens.
pub(super) const HOLE_VL: u8 = 8;
pub(super) const HOLE_VR: u8 = 16;

/// FNV-1a, 64 bit: detects corruption (not tampering).
pub(super) fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

pub(super) fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

pub(super) fn put_f32s(out: &mut Vec<u8>, values: &[f32]) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// The header: magic, version, flags (attributes, materials) and counts. Returns the attributes
/// and the materials that the file carries.
pub(super) fn header<'a>(
    out: &mut Vec<u8>,
    pm: &'a ProgressiveMesh,
    lossless: bool,
) -> (Option<&'a PmAttributes>, Option<&'a MaterialLibrary>) {
    let base = pm.base();
    out.extend_from_slice(&MAGIC);
    let attributes = pm.attributes().filter(|a| !a.values.is_empty());
    let library = attributes.and_then(|a| a.values.library.as_deref().filter(|_| a.values.materials.is_some()));
    let flags = match (attributes, library) {
        (None, _) => 0u16,
        (Some(_), None) => HAS_ATTRIBUTES,
        (Some(_), Some(_)) => HAS_ATTRIBUTES | HAS_MATERIALS,
    };
    let version: u16 = match (lossless, attributes) {
        (false, _) => 3,
        (true, None) => 1,
        (true, Some(_)) => 2,
    };
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&flags.to_le_bytes());
    out.extend_from_slice(&(base.vertex_count() as u32).to_le_bytes());
    out.extend_from_slice(&(base.face_count() as u32).to_le_bytes());
    out.extend_from_slice(&(pm.levels() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    (attributes, library)
}

/// The materials section and the checksum that end every version.
pub(super) fn finish(mut out: Vec<u8>, library: Option<String>) -> Vec<u8> {
    if let Some(text) = library {
        put_varint(&mut out, text.len() as u64);
        out.extend_from_slice(text.as_bytes());
    }
    let checksum = fnv1a(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    out
}

/// The attribute mask of a section (docs/pm-format.md).
pub(super) fn attribute_mask(v: &CornerAttributes) -> u8 {
    let bit = |present: bool, bit: u8| if present { bit } else { 0 };
    bit(v.normals.is_some(), ATTRIBUTE_NORMAL)
        | bit(v.uvs.is_some(), ATTRIBUTE_UV)
        | bit(v.colors.is_some(), ATTRIBUTE_COLOR)
        | bit(v.uv_origin_top, ATTRIBUTE_UV_ORIGIN_TOP)
        | bit(v.materials.is_some(), ATTRIBUTE_MATERIAL)
        | bit(v.joints.is_some(), ATTRIBUTE_SKIN)
        | bit(v.tangents.is_some(), ATTRIBUTE_TANGENT)
        | bit(v.uvs1.is_some(), ATTRIBUTE_UV1)
}

/// Refuses a mask with unknown bits or without any attribute.
pub(super) fn check_mask(r: &Reader, mask: u8) -> Result<(), MeshError> {
    let values = ATTRIBUTE_NORMAL
        | ATTRIBUTE_UV
        | ATTRIBUTE_COLOR
        | ATTRIBUTE_MATERIAL
        | ATTRIBUTE_SKIN
        | ATTRIBUTE_TANGENT
        | ATTRIBUTE_UV1;
    if mask & !(values | ATTRIBUTE_UV_ORIGIN_TOP) != 0 || mask & values == 0 {
        return Err(r.error(format!("invalid attribute mask {mask:#04x}")));
    }
    Ok(())
}

/// A cursor over a file's bytes whose errors name the file and the byte.
pub(super) struct Reader<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) offset: usize,
    pub(super) path: &'a Path,
}

impl<'a> Reader<'a> {
    pub(super) fn error(&self, reason: impl Into<String>) -> MeshError {
        MeshError::parse(self.path, format!("byte {}", self.offset), reason)
    }

    pub(super) fn take(&mut self, n: usize) -> Result<&'a [u8], MeshError> {
        let end =
            self.offset.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| self.error("truncated"))?;
        let slice = &self.bytes[self.offset..end];
        self.offset = end;
        Ok(slice)
    }

    pub(super) fn u32(&mut self) -> Result<u32, MeshError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    pub(super) fn f32(&mut self) -> Result<f32, MeshError> {
        let v = f32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes"));
        if !v.is_finite() {
            self.offset -= 4;
            return Err(self.error(format!("non-finite value {v}")));
        }
        Ok(v)
    }

    pub(super) fn position(&mut self) -> Result<[f32; 3], MeshError> {
        Ok([self.f32()?, self.f32()?, self.f32()?])
    }

    pub(super) fn varint(&mut self) -> Result<u64, MeshError> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.take(1)?[0];
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(self.error("varint longer than 10 bytes"))
    }
}
