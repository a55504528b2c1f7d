//! Versions 1 and 2 of the `.pm` file: every position and value the `f32` it is (version 2 adds
//! the attribute section), so that levels read back bit for bit.

use std::collections::HashMap;

use super::bits::{unzigzag, zigzag};
use super::header::*;
use crate::error::MeshError;
use crate::mesh::Mesh;
use crate::pm::{Hole, NO_VERTEX, PmAttributes, ProgressiveMesh, SplitAttributes, StreamedSplit, faces_added};

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
    finish(out, library.map(super::library_json::to_text))
}

/// The attribute section (docs/pm-format.md): the distinct values in order of first use, then
/// each base face's corners, then per split its new faces' corners and its moved faces.
/// Materials are not written.
fn encode_attributes(out: &mut Vec<u8>, pm: &ProgressiveMesh, a: &PmAttributes) {
    let v = &a.values;
    let mask = attribute_mask(v);
    // A value as the 4-byte words it is written as: each channel's in file order (floats as
    // their bits, a joint or a material number one word each).
    let channels = file_order(v);
    let floats = |k: u32| -> Vec<u32> {
        let mut f = Vec::with_capacity(18);
        for c in &channels {
            c.values.words(k as usize, &mut f);
        }
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
    if extra_channels(v).next().is_some() {
        put_channel_table(out, v);
    }
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

/// Reads the attribute section written by [`encode_attributes`] (`extra`: the header says a
/// channel table follows the mask).
fn decode_attributes(
    r: &mut Reader,
    base_faces: usize,
    added: &[usize],
    extra: bool,
) -> Result<PmAttributes, MeshError> {
    let mask = r.take(1)?[0];
    check_mask(r, mask, extra)?;
    let mut channels = masked_channels(mask);
    if extra {
        channels.extend(read_channel_table(r)?);
    }
    if channels.is_empty() {
        return Err(r.error("an attribute section without channels"));
    }
    let width: usize = channels.iter().map(|c| c.values.words_per_value()).sum();
    let count = r.varint()?;
    // Each value takes 4 bytes per word: a count the remaining bytes cannot hold is refused
    // before anything is allocated from it.
    if count.saturating_mul(4 * width as u64) > (r.bytes.len() - r.offset) as u64 {
        return Err(r.error(format!("{count} attribute values do not fit in the file")));
    }
    let mut words = Vec::with_capacity(width);
    for _ in 0..count {
        for c in &mut channels {
            let at = r.offset;
            words.clear();
            for _ in 0..c.values.words_per_value() {
                words.push(r.u32()?);
            }
            if !c.values.push_words(&words) {
                r.offset = at;
                return Err(
                    r.error(format!("a {} value that is not one (not finite, or out of range)", c.semantic.name()))
                );
            }
        }
    }
    let values = attributes_of(channels, mask & ATTRIBUTE_UV_ORIGIN_TOP != 0);
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

/// Decodes the body of a version 1 or 2 file after its header (`flags` and the counts read from
/// it); `named` gives an error of the progressive mesh's checks the file's name.
pub(super) fn decode(
    mut r: Reader,
    flags: u16,
    (vertex_count, face_count, split_count): (usize, usize, usize),
    named: impl Fn(MeshError) -> MeshError,
) -> Result<ProgressiveMesh, MeshError> {
    let (path, r_bytes) = (r.path, r.bytes);
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
        Some(decode_attributes(&mut r, face_count, &added, flags & HAS_CHANNELS != 0)?)
    } else {
        None
    };
    if let Some(a) = &mut attributes
        && flags & HAS_MATERIALS != 0
    {
        super::library_json::read_library(&mut r, a)?;
    }
    if r.offset != r_bytes.len() {
        return Err(r.error(format!("{} unexpected bytes after the last section", r_bytes.len() - r.offset)));
    }
    let base = Mesh { positions, triangles, corners: Default::default() };
    let pm = ProgressiveMesh::from_stream(base, splits).map_err(&named)?;
    match attributes {
        Some(a) => pm.with_attributes(a).map_err(&named),
        None => Ok(pm),
    }
}
