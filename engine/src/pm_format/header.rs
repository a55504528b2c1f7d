//! What every version of the `.pm` file shares: the header's magic, version, flags and counts,
//! the attribute mask, the materials section and checksum at the end, and the byte reader.

use std::path::Path;

use crate::error::MeshError;
use crate::mesh::{Channel, CornerAttributes, MaterialLibrary, Semantic, Values};
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
/// Header flag: the attribute section has channels the mask does not name, described by a
/// channel table after the mask (versions 2 and 3).
pub(super) const HAS_CHANNELS: u16 = 4;
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
    let library = attributes.and_then(|a| a.values.library.as_deref().filter(|_| a.values.materials().is_some()));
    let flags = match (attributes, library) {
        (None, _) => 0u16,
        (Some(_), None) => HAS_ATTRIBUTES,
        (Some(_), Some(_)) => HAS_ATTRIBUTES | HAS_MATERIALS,
    } | match attributes {
        Some(a) if extra_channels(&a.values).next().is_some() => HAS_CHANNELS,
        _ => 0,
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

/// The channels the attribute mask names, with their bits, in the order a value's parts are
/// written (both forms). Joints and weights share a bit.
pub(super) const MASKED: [(Semantic, u8); 8] = [
    (Semantic::Normal, ATTRIBUTE_NORMAL),
    (Semantic::TexCoord(0), ATTRIBUTE_UV),
    (Semantic::Color(0), ATTRIBUTE_COLOR),
    (Semantic::Material, ATTRIBUTE_MATERIAL),
    (Semantic::Joints(0), ATTRIBUTE_SKIN),
    (Semantic::Weights(0), ATTRIBUTE_SKIN),
    (Semantic::Tangent, ATTRIBUTE_TANGENT),
    (Semantic::TexCoord(1), ATTRIBUTE_UV1),
];

/// The attribute mask of a section (docs/pm-format.md).
pub(super) fn attribute_mask(v: &CornerAttributes) -> u8 {
    let bits = MASKED.iter().filter(|(s, _)| v.channel(s).is_some()).fold(0, |m, (_, bit)| m | bit);
    bits | if v.uv_origin_top { ATTRIBUTE_UV_ORIGIN_TOP } else { 0 }
}

/// The channels the mask does not name (a third texture coordinate set, a custom channel), in
/// their order: written after the masked ones, described by the channel table.
pub(super) fn extra_channels(v: &CornerAttributes) -> impl Iterator<Item = &Channel> {
    v.channels().iter().filter(|c| !MASKED.iter().any(|(s, _)| *s == c.semantic))
}

/// Every channel in the order a value's parts are written: the masked ones, then the others.
pub(super) fn file_order(v: &CornerAttributes) -> Vec<&Channel> {
    let masked = MASKED.iter().filter_map(|(s, _)| v.channels().iter().find(|c| c.semantic == *s));
    masked.chain(extra_channels(v)).collect()
}

/// The channel table (docs/pm-format.md), present when the header has [`HAS_CHANNELS`]: how
/// many channels the mask does not name, then per channel its semantic, its set or name, and the
/// form of its values.
pub(super) fn put_channel_table(out: &mut Vec<u8>, v: &CornerAttributes) {
    let extra: Vec<&Channel> = extra_channels(v).collect();
    put_varint(out, extra.len() as u64);
    for c in extra {
        match &c.semantic {
            Semantic::TexCoord(n) => out.extend_from_slice(&[SEMANTIC_TEXCOORD, *n]),
            Semantic::Color(n) => out.extend_from_slice(&[SEMANTIC_COLOR, *n]),
            Semantic::Joints(n) => out.extend_from_slice(&[SEMANTIC_JOINTS, *n]),
            Semantic::Weights(n) => out.extend_from_slice(&[SEMANTIC_WEIGHTS, *n]),
            Semantic::Custom(name) => {
                out.push(SEMANTIC_CUSTOM);
                put_varint(out, name.len() as u64);
                out.extend_from_slice(name.as_bytes());
            }
            Semantic::Normal | Semantic::Tangent | Semantic::Material => unreachable!("named by the mask"),
        }
        out.push(c.values.code());
    }
}

const SEMANTIC_TEXCOORD: u8 = 1;
const SEMANTIC_COLOR: u8 = 2;
const SEMANTIC_JOINTS: u8 = 3;
const SEMANTIC_WEIGHTS: u8 = 4;
const SEMANTIC_CUSTOM: u8 = 5;
/// Longest custom channel name a file may hold.
const MAX_NAME: u64 = 1024;

/// Reads the channel table: the channels the mask does not name, each with empty values of its
/// form.
pub(super) fn read_channel_table(r: &mut Reader) -> Result<Vec<Channel>, MeshError> {
    let count = r.varint()?;
    if count > 256 {
        return Err(r.error(format!("{count} channels (at most 256)")));
    }
    let mut channels: Vec<Channel> = Vec::new();
    for _ in 0..count {
        let code = r.take(1)?[0];
        let semantic = match code {
            SEMANTIC_TEXCOORD => Semantic::TexCoord(r.take(1)?[0]),
            SEMANTIC_COLOR => Semantic::Color(r.take(1)?[0]),
            SEMANTIC_JOINTS => Semantic::Joints(r.take(1)?[0]),
            SEMANTIC_WEIGHTS => Semantic::Weights(r.take(1)?[0]),
            SEMANTIC_CUSTOM => {
                let length = r.varint()?;
                if length == 0 || length > MAX_NAME {
                    return Err(r.error(format!("a channel name of {length} bytes (1 to {MAX_NAME})")));
                }
                let bytes = r.take(length as usize)?;
                let name = std::str::from_utf8(bytes).map_err(|_| r.error("a channel name that is not UTF-8"))?;
                Semantic::Custom(name.to_string())
            }
            _ => return Err(r.error(format!("unknown channel semantic {code}"))),
        };
        if MASKED.iter().any(|(s, _)| *s == semantic) || channels.iter().any(|c| c.semantic == semantic) {
            return Err(r.error(format!("channel {} named twice", semantic.name())));
        }
        let form = r.take(1)?[0];
        let values = Values::of_code(form).ok_or_else(|| r.error(format!("unknown value form {form}")))?;
        channels.push(Channel { semantic, values });
    }
    Ok(channels)
}

/// The masked channels `mask` names, in file order, each with empty values of its form.
pub(super) fn masked_channels(mask: u8) -> Vec<Channel> {
    MASKED
        .iter()
        .filter(|(_, bit)| mask & bit != 0)
        .map(|(semantic, _)| {
            let values = match semantic {
                Semantic::Normal => Values::F3(Vec::new()),
                Semantic::TexCoord(_) => Values::F2(Vec::new()),
                Semantic::Material => Values::U32(Vec::new()),
                Semantic::Joints(_) => Values::U16x4(Vec::new()),
                _ => Values::F4(Vec::new()),
            };
            Channel { semantic: semantic.clone(), values }
        })
        .collect()
}

/// Attributes from the channels read (their values filled in).
pub(super) fn attributes_of(channels: Vec<Channel>, uv_origin_top: bool) -> CornerAttributes {
    let mut values = CornerAttributes::default();
    values.uv_origin_top = uv_origin_top;
    for c in channels {
        values.set(c.semantic, Some(c.values));
    }
    values
}

/// Refuses a mask with unknown bits, or without any attribute unless the channel table names
/// some (`extra`).
pub(super) fn check_mask(r: &Reader, mask: u8, extra: bool) -> Result<(), MeshError> {
    let values = MASKED.iter().fold(0, |m, (_, bit)| m | bit);
    if mask & !(values | ATTRIBUTE_UV_ORIGIN_TOP) != 0 || (mask & values == 0 && !extra) {
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
