//! The `.pm` file: a progressive mesh, little endian, versioned, checksummed.
//! The layout is specified in `docs/pm-format.md`; this module is its reference implementation.
//! [`encode`] writes the compact form (version 3, values on integer grids); [`encode_lossless`]
//! writes every float as it is (version 1, or 2 with attributes). [`decode`] reads all three.

mod bits;
mod compact;
mod grid;

use std::path::Path;

pub use grid::{Grid, Precision, Quantization};

use std::collections::HashMap;

use crate::error::MeshError;
use crate::mesh::{
    CornerAttributes, Image, ImageSource, MaterialLibrary, Mesh, NO_MATERIAL, OtherPrimitive, Rig, RigAccessor,
};
use crate::pm::{Hole, NO_VERTEX, PmAttributes, ProgressiveMesh, SplitAttributes, StreamedSplit, faces_added};

/// First four bytes of a `.pm` file.
pub const MAGIC: [u8; 4] = *b"MLPM";
/// Newest format version: 3, the compact form. Version 2 adds per-corner attributes to version
/// 1; a lossless progressive mesh without attributes is written as version 1.
pub const VERSION: u16 = 3;
/// Header flag: an attribute section follows the splits (versions 2 and 3).
const HAS_ATTRIBUTES: u16 = 1;
const ATTRIBUTE_NORMAL: u8 = 1;
const ATTRIBUTE_UV: u8 = 2;
const ATTRIBUTE_COLOR: u8 = 4;
const ATTRIBUTE_UV_ORIGIN_TOP: u8 = 8;
const ATTRIBUTE_MATERIAL: u8 = 16;
/// Joints and weights (glTF JOINTS_0 and WEIGHTS_0), always together.
const ATTRIBUTE_SKIN: u8 = 32;
/// Tangents (glTF TANGENT).
const ATTRIBUTE_TANGENT: u8 = 64;
/// Second texture coordinates (glTF TEXCOORD_1).
const ATTRIBUTE_UV1: u8 = 128;
/// Header flag: the materials, textures and images the material numbers refer to follow the
/// attribute section, as JSON (versions 2 and 3).
const HAS_MATERIALS: u16 = 2;
const HEADER_SIZE: usize = 24;
const CHECKSUM_SIZE: usize = 8;
/// Fewest bytes a split takes: flags, a one-byte vs, a position, the error.
const MIN_SPLIT_SIZE: usize = 1 + 1 + 12 + 4;

const HAS_VL: u8 = 1;
const HAS_VR: u8 = 2;
const MOVES_VS: u8 = 4;
/// With both `HAS_VL` and `HAS_VR`: `vl` (or `vr`) is the corner of a hole the split opens.
const HOLE_VL: u8 = 8;
const HOLE_VR: u8 = 16;

/// FNV-1a, 64 bit: detects corruption (not tampering).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn unzigzag(v: u64) -> i64 {
    ((v >> 1) as i64) ^ -((v & 1) as i64)
}

fn put_f32s(out: &mut Vec<u8>, values: &[f32]) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// The header: magic, version, flags (attributes, materials) and counts. Returns the attributes
/// and the materials that the file carries.
fn header<'a>(
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
fn finish(mut out: Vec<u8>, library: Option<&MaterialLibrary>) -> Vec<u8> {
    if let Some(library) = library {
        let text = canonical(library_to_json(library)).to_string();
        put_varint(&mut out, text.len() as u64);
        out.extend_from_slice(text.as_bytes());
    }
    let checksum = fnv1a(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    out
}

/// Bytes of the materials section (images inside) in `pm`'s file, whichever form: 0 without one.
/// The rest of the file is the records.
pub fn materials_section_len(pm: &ProgressiveMesh) -> usize {
    let (_, library) = header(&mut Vec::new(), pm, false);
    library.map_or(0, |library| {
        let n = canonical(library_to_json(library)).to_string().len();
        let mut length = Vec::new();
        put_varint(&mut length, n as u64);
        length.len() + n
    })
}

/// Encodes a progressive mesh in the compact form (version 3) at the default [`Precision`], or
/// on the grids it was read with when it came from a compact file (so that writing again gives
/// the same bytes).
pub fn encode(pm: &ProgressiveMesh) -> Vec<u8> {
    match pm.quantization() {
        Some(q) => encode_on(pm, q),
        None => encode_on(pm, &Quantization::fit(pm, &Precision::default())),
    }
}

/// Encodes a progressive mesh in the compact form with the grids fitted at `precision`.
pub fn encode_compact(pm: &ProgressiveMesh, precision: &Precision) -> Vec<u8> {
    encode_on(pm, &Quantization::fit(pm, precision))
}

fn encode_on(pm: &ProgressiveMesh, quantization: &Quantization) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_SIZE + 8 * pm.base().face_count() + 12 * pm.levels() + CHECKSUM_SIZE);
    let (attributes, library) = header(&mut out, pm, false);
    compact::encode_geometry(&mut out, pm, &quantization.positions);
    if let Some(a) = attributes {
        compact::encode_attributes(&mut out, pm, a, attribute_mask(&a.values), quantization);
    }
    finish(out, library)
}

/// Encodes a progressive mesh with every position and value as the `f32` it is (version 1, or 2
/// with attributes): levels read back bit for bit, at about three times the compact size.
pub fn encode_lossless(pm: &ProgressiveMesh) -> Vec<u8> {
    let base = pm.base();
    let mut out = Vec::with_capacity(HEADER_SIZE + 24 * base.face_count() + 26 * pm.levels() + CHECKSUM_SIZE);
    let (attributes, library) = header(&mut out, pm, true);
    for p in &base.positions {
        put_f32s(&mut out, p);
    }
    for t in &base.triangles {
        for v in t {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for s in pm.splits() {
        let flags = if s.vl != NO_VERTEX { HAS_VL } else { 0 }
            | if s.vr != NO_VERTEX { HAS_VR } else { 0 }
            | if s.moves_vs() { MOVES_VS } else { 0 }
            | match s.hole {
                Hole::None => 0,
                Hole::Left => HOLE_VL,
                Hole::Right => HOLE_VR,
            };
        out.push(flags);
        put_varint(&mut out, s.vs as u64);
        for v in [s.vl, s.vr] {
            if v != NO_VERTEX {
                put_varint(&mut out, zigzag(v as i64 - s.vs as i64));
            }
        }
        put_f32s(&mut out, &s.new_position);
        if s.moves_vs() {
            put_f32s(&mut out, &s.split_position);
        }
        out.extend_from_slice(&s.error.to_le_bytes());
    }
    if let Some(a) = attributes {
        encode_attributes(&mut out, pm, a);
    }
    finish(out, library)
}

/// The attribute mask of a section (docs/pm-format.md).
fn attribute_mask(v: &CornerAttributes) -> u8 {
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
fn check_mask(r: &Reader, mask: u8) -> Result<(), MeshError> {
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

/// The attribute section (docs/pm-format.md): the distinct values in order of first use, then
/// each base face's corners, then per split its new faces' corners and its moved faces.
/// Materials are not written.
fn encode_attributes(out: &mut Vec<u8>, pm: &ProgressiveMesh, a: &PmAttributes) {
    let v = &a.values;
    let mask = attribute_mask(v);
    // A value as the 4-byte words it is written as: floats, the material number, then the joints
    // (one word each) and weights.
    let floats = |k: u32| -> Vec<u32> {
        let k = k as usize;
        let mut f = Vec::with_capacity(18);
        f.extend(v.normals.iter().flat_map(|n| n[k].map(f32::to_bits)));
        f.extend(v.uvs.iter().flat_map(|u| u[k].map(f32::to_bits)));
        f.extend(v.colors.iter().flat_map(|c| c[k].map(f32::to_bits)));
        f.extend(v.materials.iter().map(|m| m[k]));
        f.extend(v.joints.iter().flat_map(|j| j[k].map(u32::from)));
        f.extend(v.weights.iter().flat_map(|w| w[k].map(f32::to_bits)));
        f.extend(v.tangents.iter().flat_map(|t| t[k].map(f32::to_bits)));
        f.extend(v.uvs1.iter().flat_map(|u| u[k].map(f32::to_bits)));
        f
    };
    // Every index in the order it is written, renumbered to distinct values in order of first use.
    let mut ids: Vec<u32> = a.base.iter().flatten().copied().collect();
    for (split, s) in pm.splits().iter().zip(&a.splits) {
        ids.extend(s.new_faces[..split.added_faces()].iter().flatten());
        ids.extend(s.moved.iter().map(|m| m.1));
    }
    let mut number: HashMap<Vec<u32>, u32> = HashMap::new();
    let mut values: Vec<Vec<u32>> = Vec::new();
    let renumbered: Vec<u32> = ids
        .iter()
        .map(|&k| {
            let value = floats(k);
            *number.entry(value.clone()).or_insert_with(|| {
                values.push(value);
                values.len() as u32 - 1
            })
        })
        .collect();
    out.push(mask);
    put_varint(out, values.len() as u64);
    for value in &values {
        for word in value {
            out.extend_from_slice(&word.to_le_bytes());
        }
    }
    let mut next = renumbered.iter();
    let mut id = || *next.next().expect("one renumbered index per index");
    for _ in 0..3 * a.base.len() {
        put_varint(out, id() as u64);
    }
    for (split, s) in pm.splits().iter().zip(&a.splits) {
        for _ in 0..3 * split.added_faces() {
            put_varint(out, id() as u64);
        }
        put_varint(out, s.moved.len() as u64);
        for &(face, _) in &s.moved {
            put_varint(out, face as u64);
            put_varint(out, id() as u64);
        }
    }
}

/// Reads the attribute section written by [`encode_attributes`].
fn decode_attributes(r: &mut Reader, base_faces: usize, added: &[usize]) -> Result<PmAttributes, MeshError> {
    let mask = r.take(1)?[0];
    check_mask(r, mask)?;
    let width = 3 * (mask & ATTRIBUTE_NORMAL != 0) as usize
        + 2 * (mask & ATTRIBUTE_UV != 0) as usize
        + 4 * (mask & ATTRIBUTE_COLOR != 0) as usize
        + (mask & ATTRIBUTE_MATERIAL != 0) as usize
        + 8 * (mask & ATTRIBUTE_SKIN != 0) as usize
        + 4 * (mask & ATTRIBUTE_TANGENT != 0) as usize
        + 2 * (mask & ATTRIBUTE_UV1 != 0) as usize;
    let count = r.varint()?;
    // Each value takes 4 bytes per float: a count the remaining bytes cannot hold is refused
    // before anything is allocated from it.
    if count.saturating_mul(4 * width as u64) > (r.bytes.len() - r.offset) as u64 {
        return Err(r.error(format!("{count} attribute values do not fit in the file")));
    }
    let mut values = CornerAttributes {
        normals: (mask & ATTRIBUTE_NORMAL != 0).then(Vec::new),
        uvs: (mask & ATTRIBUTE_UV != 0).then(Vec::new),
        colors: (mask & ATTRIBUTE_COLOR != 0).then(Vec::new),
        uv_origin_top: mask & ATTRIBUTE_UV_ORIGIN_TOP != 0,
        materials: (mask & ATTRIBUTE_MATERIAL != 0).then(Vec::new),
        joints: (mask & ATTRIBUTE_SKIN != 0).then(Vec::new),
        weights: (mask & ATTRIBUTE_SKIN != 0).then(Vec::new),
        tangents: (mask & ATTRIBUTE_TANGENT != 0).then(Vec::new),
        uvs1: (mask & ATTRIBUTE_UV1 != 0).then(Vec::new),
        library: None,
    };
    for _ in 0..count {
        if let Some(n) = &mut values.normals {
            n.push([r.f32()?, r.f32()?, r.f32()?]);
        }
        if let Some(u) = &mut values.uvs {
            u.push([r.f32()?, r.f32()?]);
        }
        if let Some(c) = &mut values.colors {
            c.push([r.f32()?, r.f32()?, r.f32()?, r.f32()?]);
        }
        if let Some(m) = &mut values.materials {
            m.push(r.u32()?);
        }
        if let Some(j) = &mut values.joints {
            let mut joint = [0u16; 4];
            for x in &mut joint {
                *x = u16::try_from(r.u32()?).map_err(|_| r.error("a joint number above 65535".to_string()))?;
            }
            j.push(joint);
        }
        if let Some(w) = &mut values.weights {
            w.push([r.f32()?, r.f32()?, r.f32()?, r.f32()?]);
        }
        if let Some(t) = &mut values.tangents {
            t.push([r.f32()?, r.f32()?, r.f32()?, r.f32()?]);
        }
        if let Some(u) = &mut values.uvs1 {
            u.push([r.f32()?, r.f32()?]);
        }
    }
    let index = |r: &mut Reader| -> Result<u32, MeshError> {
        let k = r.varint()?;
        if k >= count {
            return Err(r.error(format!("attribute value {k} out of range ({count} values)")));
        }
        Ok(k as u32)
    };
    let mut base = Vec::with_capacity(base_faces);
    for _ in 0..base_faces {
        base.push([index(r)?, index(r)?, index(r)?]);
    }
    let mut splits = Vec::with_capacity(added.len());
    for &faces in added {
        let mut new_faces = [[0; 3]; 2];
        for face in new_faces.iter_mut().take(faces) {
            *face = [index(r)?, index(r)?, index(r)?];
        }
        let moved_count = r.varint()?;
        if moved_count.saturating_mul(2) > (r.bytes.len() - r.offset) as u64 {
            return Err(r.error(format!("{moved_count} moved faces do not fit in the file")));
        }
        let mut moved = Vec::with_capacity(moved_count as usize);
        for _ in 0..moved_count {
            let face = u32::try_from(r.varint()?).map_err(|_| r.error("face index too large"))?;
            moved.push((face, index(r)?));
        }
        splits.push(SplitAttributes { new_faces, moved });
    }
    Ok(PmAttributes { values, base, splits })
}

/// The materials, textures, samplers and images as the `.pm` file keeps them: glTF's JSON, and for
/// each image its bytes (base64), its file or its URI.
fn library_to_json(library: &MaterialLibrary) -> serde_json::Value {
    use base64::Engine as _;
    let images: Vec<serde_json::Value> = library
        .images
        .iter()
        .map(|image| {
            let mut entry = serde_json::json!({ "json": image.json, "mime_type": image.mime_type });
            // A file's bytes travel inside (the `.pm` then draws anywhere, and its bytes do not
            // depend on where the input was); a file that cannot be read keeps its name as a URI.
            let bytes = match &image.source {
                ImageSource::Bytes(bytes) => Some(bytes.clone()),
                ImageSource::File(path) => std::fs::read(path).ok(),
                ImageSource::Uri(_) => None,
            };
            match (&image.source, bytes) {
                (_, Some(bytes)) => {
                    entry["bytes"] = base64::engine::general_purpose::STANDARD.encode(bytes).into();
                    // An unnamed file's name goes with its bytes: an OBJ cut from the `.pm` names it.
                    if let ImageSource::File(path) = &image.source
                        && image.json.get("name").and_then(|n| n.as_str()).is_none_or(str::is_empty)
                        && let (Some(name), Some(json)) = (path.file_name(), entry["json"].as_object_mut())
                    {
                        json.insert("name".into(), name.to_string_lossy().into_owned().into());
                    }
                }
                (ImageSource::File(path), None) => {
                    let name = path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                    entry["uri"] = name.replace(' ', "%20").into();
                }
                (ImageSource::Uri(uri), None) => entry["uri"] = uri.clone().into(),
                (ImageSource::Bytes(_), None) => unreachable!("bytes are bytes"),
            }
            entry
        })
        .collect();
    let mut json = serde_json::json!({
        "materials": library.materials,
        "textures": library.textures,
        "samplers": library.samplers,
        "images": images,
        "extensions_used": library.extensions_used,
        "extensions_required": library.extensions_required,
        "not_carried": library.not_carried,
    });
    // Only when there is one: a file without a skeleton is written as before skeletons were kept
    // (and without point and line primitives as before they were).
    if let Some(rig) = &library.rig {
        json["rig"] = rig_to_json(rig);
    }
    if !library.other_primitives.is_empty() {
        let others = library.other_primitives.iter().map(|p| {
            let attributes: Vec<serde_json::Value> = p
                .attributes
                .iter()
                .map(|(name, a)| serde_json::json!({ "name": name, "accessor": accessor_to_json(a) }))
                .collect();
            serde_json::json!({
                "mode": p.mode,
                "material": p.material,
                "attributes": attributes,
                "indices": p.indices.as_ref().map(accessor_to_json),
            })
        });
        json["other_primitives"] = others.collect();
    }
    json
}

/// A carried accessor as the `.pm` file keeps it: its JSON, its bytes in base64.
fn accessor_to_json(a: &RigAccessor) -> serde_json::Value {
    use base64::Engine as _;
    serde_json::json!({ "json": a.json, "bytes": base64::engine::general_purpose::STANDARD.encode(&a.bytes) })
}

/// Reads [`accessor_to_json`]'s form back.
fn accessor_from_json(entry: &serde_json::Value) -> Option<RigAccessor> {
    use base64::Engine as _;
    let bytes = base64::engine::general_purpose::STANDARD.decode(entry.get("bytes")?.as_str()?).ok()?;
    Some(RigAccessor { json: entry.get("json")?.clone(), bytes })
}

/// Reads the point and line primitives of [`library_to_json`]'s form back.
fn other_primitives_from_json(json: &serde_json::Value) -> Option<Vec<OtherPrimitive>> {
    let Some(list) = json.get("other_primitives") else { return Some(Vec::new()) };
    let mut out = Vec::new();
    for entry in list.as_array()? {
        let mut attributes = Vec::new();
        for a in entry.get("attributes")?.as_array()? {
            attributes.push((a.get("name")?.as_str()?.to_string(), accessor_from_json(a.get("accessor")?)?));
        }
        let indices = match entry.get("indices") {
            None | Some(serde_json::Value::Null) => None,
            Some(i) => Some(accessor_from_json(i)?),
        };
        let material = match entry.get("material") {
            None | Some(serde_json::Value::Null) => None,
            Some(m) => Some(u32::try_from(m.as_u64()?).ok()?),
        };
        out.push(OtherPrimitive {
            mode: u32::try_from(entry.get("mode")?.as_u64()?).ok()?,
            material,
            attributes,
            indices,
        });
    }
    Some(out)
}

/// A [`Rig`] as the `.pm` file keeps it: glTF's JSON, each accessor's bytes in base64.
fn rig_to_json(rig: &Rig) -> serde_json::Value {
    let accessors: Vec<serde_json::Value> = rig.accessors.iter().map(accessor_to_json).collect();
    serde_json::json!({
        "nodes": rig.nodes,
        "mesh_node": rig.mesh_node,
        "scenes": rig.scenes,
        "scene": rig.scene,
        "skins": rig.skins,
        "animations": rig.animations,
        "accessors": accessors,
    })
}

/// Reads [`rig_to_json`]'s form back.
fn rig_from_json(json: &serde_json::Value) -> Option<Rig> {
    let array = |key: &str| json.get(key)?.as_array().cloned();
    let mut accessors = Vec::new();
    for entry in array("accessors")? {
        accessors.push(accessor_from_json(&entry)?);
    }
    Some(Rig {
        nodes: array("nodes")?,
        mesh_node: usize::try_from(json.get("mesh_node")?.as_u64()?).ok()?,
        scenes: array("scenes")?,
        scene: json.get("scene").and_then(|s| s.as_u64()).map(|s| s as usize),
        skins: array("skins")?,
        animations: array("animations")?,
        accessors,
    })
}

/// `value` with every object's keys in sorted order, so that the bytes written do not depend on
/// whether serde_json keeps insertion order (a feature another crate of the build may turn on).
fn canonical(value: serde_json::Value) -> serde_json::Value {
    match value {
        serde_json::Value::Object(map) => {
            let mut entries: Vec<(String, serde_json::Value)> = map.into_iter().collect();
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            serde_json::Value::Object(entries.into_iter().map(|(k, v)| (k, canonical(v))).collect())
        }
        serde_json::Value::Array(items) => serde_json::Value::Array(items.into_iter().map(canonical).collect()),
        other => other,
    }
}

/// Reads [`library_to_json`]'s form back; `None` when it is not that form.
fn library_from_json(json: &serde_json::Value) -> Option<MaterialLibrary> {
    use base64::Engine as _;
    let array = |key: &str| json.get(key)?.as_array().cloned();
    let strings =
        |key: &str| -> Option<Vec<String>> { array(key)?.iter().map(|v| v.as_str().map(str::to_string)).collect() };
    let mut images = Vec::new();
    for entry in array("images")? {
        let source = if let Some(b) = entry.get("bytes").and_then(|b| b.as_str()) {
            ImageSource::Bytes(base64::engine::general_purpose::STANDARD.decode(b).ok()?)
        } else {
            ImageSource::Uri(entry.get("uri")?.as_str()?.to_string())
        };
        let mime_type = entry.get("mime_type").and_then(|m| m.as_str()).map(str::to_string);
        images.push(Image { json: entry.get("json")?.clone(), source, mime_type });
    }
    Some(MaterialLibrary {
        materials: array("materials")?,
        textures: array("textures")?,
        samplers: array("samplers")?,
        images,
        extensions_used: strings("extensions_used")?,
        extensions_required: strings("extensions_required")?,
        not_carried: strings("not_carried")?,
        rig: match json.get("rig") {
            None | Some(serde_json::Value::Null) => None,
            Some(rig) => Some(rig_from_json(rig)?),
        },
        other_primitives: other_primitives_from_json(json)?,
        // (Said when the input was read; the file holds the mended values.)
        mended: Vec::new(),
    })
}

/// Writes a `.pm` file.
pub fn write_pm(path: impl AsRef<Path>, pm: &ProgressiveMesh) -> Result<(), MeshError> {
    let path = path.as_ref();
    std::fs::write(path, encode(pm)).map_err(|e| MeshError::Io { path: path.to_path_buf(), message: e.to_string() })
}

struct Reader<'a> {
    bytes: &'a [u8],
    offset: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn error(&self, reason: impl Into<String>) -> MeshError {
        MeshError::parse(self.path, format!("byte {}", self.offset), reason)
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], MeshError> {
        let end =
            self.offset.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| self.error("truncated"))?;
        let slice = &self.bytes[self.offset..end];
        self.offset = end;
        Ok(slice)
    }

    fn u32(&mut self) -> Result<u32, MeshError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    fn f32(&mut self) -> Result<f32, MeshError> {
        let v = f32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes"));
        if !v.is_finite() {
            self.offset -= 4;
            return Err(self.error(format!("non-finite value {v}")));
        }
        Ok(v)
    }

    fn position(&mut self) -> Result<[f32; 3], MeshError> {
        Ok([self.f32()?, self.f32()?, self.f32()?])
    }

    fn varint(&mut self) -> Result<u64, MeshError> {
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

/// Decodes and validates a `.pm` file's bytes. `path` names the file in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<ProgressiveMesh, MeshError> {
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
    if flags & !(HAS_ATTRIBUTES | HAS_MATERIALS) != 0
        || (version == 1 && flags != 0)
        || (flags & HAS_MATERIALS != 0 && flags & HAS_ATTRIBUTES == 0)
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
            let (mut a, normal_bits, uvs, colors, uvs1) = compact::decode_attributes(&mut r, &pm)?;
            quantization = Quantization { normal_bits, uvs, colors, uvs1, ..quantization };
            if flags & HAS_MATERIALS != 0 {
                read_library(&mut r, &mut a)?;
            }
            pm = pm.with_attributes(a).map_err(named)?;
        }
        if r.offset != r_bytes.len() {
            return Err(r.error(format!("{} unexpected bytes after the last section", r_bytes.len() - r.offset)));
        }
        return Ok(pm.with_quantization(quantization));
    }
    let needed = (vertex_count as u64) * 12 + (face_count as u64) * 12 + (split_count as u64) * MIN_SPLIT_SIZE as u64;
    if needed > (r_bytes.len() - HEADER_SIZE) as u64 {
        return Err(MeshError::parse(
            path,
            "header",
            format!(
                "declares {vertex_count} vertices, {face_count} faces and {split_count} splits: at least {needed} bytes, but {} follow",
                r_bytes.len() - HEADER_SIZE
            ),
        ));
    }
    let mut positions = Vec::with_capacity(vertex_count);
    for _ in 0..vertex_count {
        positions.push(r.position()?);
    }
    let mut triangles = Vec::with_capacity(face_count);
    for f in 0..face_count {
        let t = [r.u32()?, r.u32()?, r.u32()?];
        if let Some(&bad) = t.iter().find(|&&v| v as usize >= vertex_count) {
            return Err(MeshError::parse(path, format!("base face {f}"), format!("vertex {bad} out of range")));
        }
        triangles.push(t);
    }
    let mut splits = Vec::with_capacity(split_count);
    for j in 0..split_count {
        let flags = r.take(1)?[0];
        let hole = match flags & (HOLE_VL | HOLE_VR) {
            0 => Hole::None,
            HOLE_VL => Hole::Left,
            _ => Hole::Right,
        };
        let both = HAS_VL | HAS_VR;
        if flags & !(both | MOVES_VS | HOLE_VL | HOLE_VR) != 0
            || flags & both == 0
            || flags & (HOLE_VL | HOLE_VR) == HOLE_VL | HOLE_VR
            || (hole != Hole::None && flags & both != both)
        {
            return Err(MeshError::parse(path, format!("split {j}"), format!("invalid flags {flags:#04x}")));
        }
        let limit = (vertex_count + j) as u64;
        let vs = r.varint()?;
        if vs >= limit {
            return Err(MeshError::parse(
                path,
                format!("split {j}"),
                format!("vs {vs} out of range ({limit} vertices)"),
            ));
        }
        let neighbour = |present: bool, r: &mut Reader| -> Result<u32, MeshError> {
            if !present {
                return Ok(NO_VERTEX);
            }
            let v = vs as i64 + unzigzag(r.varint()?);
            if v < 0 || v as u64 >= limit {
                return Err(MeshError::parse(path, format!("split {j}"), format!("neighbour {v} out of range")));
            }
            Ok(v as u32)
        };
        let vl = neighbour(flags & HAS_VL != 0, &mut r)?;
        let vr = neighbour(flags & HAS_VR != 0, &mut r)?;
        let new_position = r.position()?;
        let split_position = if flags & MOVES_VS != 0 { Some(r.position()?) } else { None };
        let error = r.f32()?;
        splits.push(StreamedSplit { vs: vs as u32, vl, vr, hole, new_position, split_position, error });
    }
    let mut attributes = if flags & HAS_ATTRIBUTES != 0 {
        let added: Vec<usize> = splits.iter().map(|s| faces_added(s.vl, s.vr, s.hole)).collect();
        Some(decode_attributes(&mut r, face_count, &added)?)
    } else {
        None
    };
    if let Some(a) = &mut attributes
        && flags & HAS_MATERIALS != 0
    {
        read_library(&mut r, a)?;
    }
    if r.offset != r_bytes.len() {
        return Err(r.error(format!("{} unexpected bytes after the last section", r_bytes.len() - r.offset)));
    }
    let base = Mesh { positions, triangles, corners: Default::default() };
    let pm = ProgressiveMesh::from_stream(base, splits).map_err(named)?;
    match attributes {
        Some(a) => pm.with_attributes(a).map_err(named),
        None => Ok(pm),
    }
}

/// Reads the materials section into the attributes' values, checking their material numbers.
fn read_library(r: &mut Reader, a: &mut PmAttributes) -> Result<(), MeshError> {
    let length = r.varint()?;
    if length > (r.bytes.len() - r.offset) as u64 {
        return Err(r.error(format!("a materials section of {length} bytes does not fit in the file")));
    }
    let text = r.take(length as usize)?;
    let library = serde_json::from_slice(text)
        .ok()
        .and_then(|json| library_from_json(&json))
        .ok_or_else(|| r.error("the materials section is not valid"))?;
    let known = library.materials.len() as u32;
    if let Some(&m) = a.values.materials.iter().flatten().find(|&&m| m != NO_MATERIAL && m >= known) {
        return Err(r.error(format!("material {m} out of range ({known} materials)")));
    }
    a.values.library = Some(std::sync::Arc::new(library));
    Ok(())
}

/// Reads a `.pm` file.
pub fn read_pm(path: impl AsRef<Path>) -> Result<ProgressiveMesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| MeshError::Io { path: path.to_path_buf(), message: e.to_string() })?;
    decode(&bytes, path)
}
