//! The compact `.pm` form (format version 3, docs/pm-format.md): positions and attribute values on
//! integer grids, each split's vertices as small indices into the fan the reader already has, and
//! every number delta-coded against what the reader can predict, in adaptive Golomb–Rice codes.
//!
//! Writer and reader replay the splits with the same [`Fans`], so every choice a record makes is
//! among vertices, faces and values that both sides know at that point.

use std::collections::HashMap;

use super::bits::{BitReader, BitWriter, OutOfBits, Rice, width_for};
use super::grid::{Grid, MAX_BITS, Quantization, from_octahedral, octahedral};
use super::header::{
    ATTRIBUTE_COLOR, ATTRIBUTE_MATERIAL, ATTRIBUTE_NORMAL, ATTRIBUTE_SKIN, ATTRIBUTE_TANGENT, ATTRIBUTE_UV,
    ATTRIBUTE_UV_ORIGIN_TOP, ATTRIBUTE_UV1, Reader, attributes_of, extra_channels, file_order, masked_channels,
    put_channel_table, put_varint, read_channel_table,
};
use crate::error::MeshError;
use crate::mesh::{Channel, CornerAttributes, Mesh, NO_MATERIAL, Semantic, Values};
use crate::pm::{
    Fans, Hole, NO_VERTEX, PmAttributes, ProgressiveMesh, SplitAttributes, StreamedSplit, VertexSplit, faces_added,
};

/// A split's error rounded up to 16 bits (sign, exponent and 7 bits of significand, so within
/// 0.8 % above it): the code keeps the errors' order and never understates one.
fn error_code(error: f32) -> u64 {
    if error.is_nan() || error <= 0.0 {
        return 0;
    }
    (((error.to_bits() as u64) + 0xFFFF) >> 16).min(MAX_ERROR_CODE)
}

/// The largest code of a finite error.
const MAX_ERROR_CODE: u64 = 0x7F7F;

fn error_value(code: u64) -> f32 {
    f32::from_bits((code as u32) << 16)
}

/// How a split's faces change: both added faces, only `(vs, vt, vl)`, only `(vt, vs, vr)`, or one
/// of them and a hole on the other side (a bit after the case says which: 0 the hole on the left).
fn case_of(s: &VertexSplit) -> u64 {
    match (s.vl != NO_VERTEX, s.vr != NO_VERTEX, s.hole) {
        (_, _, Hole::Left | Hole::Right) => 3,
        (true, true, _) => 0,
        (true, false, _) => 1,
        _ => 2,
    }
}

/// The adaptive codes of the geometry stream, one per kind of number.
#[derive(Default)]
struct GeometryCodes {
    new_vertex: [Rice; 3],
    moved_vertex: [Rice; 3],
    error: Rice,
}

/// Writes the positions grid and the geometry stream: base positions and faces, then per split
/// its case, `vs`, `vl` and `vr` as places in `vs`'s ring, the positions as grid deltas from
/// where `vs` sits, and the error.
pub(super) fn encode_geometry(out: &mut Vec<u8>, pm: &ProgressiveMesh, grid: &Grid<3>) {
    grid.write(out, true);
    let base = pm.base();
    let n0 = base.vertex_count();
    let mut w = BitWriter::default();
    let mut at: Vec<[i64; 3]> = base.positions.iter().map(|p| grid.quantize(p)).collect();
    for q in &at {
        for &c in q {
            w.put(c as u64, grid.bits as u32);
        }
    }
    for t in &base.triangles {
        for &v in t {
            w.put(v as u64, width_for(n0 as u64));
        }
    }
    let total_faces = pm.faces_at_level(pm.levels());
    let mut fans = Fans::new(&base.triangles, n0 + pm.levels(), total_faces);
    let mut codes = GeometryCodes::default();
    let mut previous_error = None;
    for (j, s) in pm.splits().iter().enumerate() {
        let vt = (n0 + j) as u32;
        let from = at[s.vs as usize];
        let new = grid.quantize(&s.new_position);
        let moved = grid.quantize(&s.split_position);
        w.put(case_of(s), 2);
        if s.hole != Hole::None {
            w.bit(s.hole == Hole::Right);
        }
        w.bit(moved != from);
        w.put(s.vs as u64, width_for(vt as u64));
        let ring = fans.neighbours(s.vs);
        for v in [s.vl, s.vr].into_iter().filter(|&v| v != NO_VERTEX) {
            match ring.binary_search(&v) {
                Ok(i) => w.put(i as u64, width_for(ring.len() as u64 + 1)),
                Err(_) => {
                    w.put(ring.len() as u64, width_for(ring.len() as u64 + 1));
                    w.put(v as u64, width_for(vt as u64));
                }
            }
        }
        for a in 0..3 {
            codes.new_vertex[a].put_signed(&mut w, new[a] - from[a]);
        }
        if moved != from {
            // With optimal placement vs tends to move the other way from vt, about half as far
            // (measured: 1-2 % smaller than coding the move as it is).
            for a in 0..3 {
                codes.moved_vertex[a].put_signed(&mut w, (moved[a] - from[a]) + (new[a] - from[a]) / 2);
            }
        }
        let code = error_code(s.error);
        match previous_error {
            None => w.put(code, 16),
            Some(p) => codes.error.put_signed(&mut w, p as i64 - code as i64),
        }
        previous_error = Some(code);
        fans.split([s.vs, s.vl, s.vr], s.hole, vt, pm.faces_at_level(j) as u32).expect("a ProgressiveMesh replays");
        at[s.vs as usize] = moved;
        at.push(new);
    }
    let bytes = w.finish();
    put_varint(out, bytes.len() as u64);
    out.extend_from_slice(&bytes);
}

/// Fewest bits a split record takes: case, moves flag, three one-bit codes, a one-bit error.
const MIN_SPLIT_BITS: u64 = 7;

/// Reads what [`encode_geometry`] wrote: the base mesh and the splits, each checked against the
/// fan it applies to.
pub(super) fn decode_geometry(
    r: &mut Reader,
    n0: usize,
    f0: usize,
    k: usize,
) -> Result<(Mesh, Vec<StreamedSplit>, Grid<3>), MeshError> {
    let grid = Grid::<3>::read(r, true, "position")?;
    let length = r.varint()?;
    if length > (r.bytes.len() - r.offset) as u64 {
        return Err(r.error(format!("a geometry section of {length} bytes does not fit in the file")));
    }
    let start = r.offset;
    let bytes = r.take(length as usize)?;
    let needed =
        n0 as u64 * 3 * grid.bits as u64 + f0 as u64 * 3 * width_for(n0 as u64) as u64 + k as u64 * MIN_SPLIT_BITS;
    if needed > 8 * length {
        return Err(MeshError::parse(
            r.path,
            "header",
            format!(
                "declares {n0} vertices, {f0} faces and {k} splits: at least {needed} bits, but the geometry section has {}",
                8 * length
            ),
        ));
    }
    let mut b = BitReader::new(bytes);
    let cut = |_: OutOfBits| MeshError::parse(r.path, format!("byte {start}"), "the geometry section is truncated");
    let (mut at, base) = decode_base(&mut b, &grid, (n0, f0, k), r.path, start)?;
    let mut fans = Fans::new(&base.triangles, n0 + k, f0 + 2 * k);
    let mut codes = GeometryCodes::default();
    let mut splits = Vec::with_capacity(k);
    let mut faces = f0 as u32;
    let mut previous_error: Option<u64> = None;
    for j in 0..k {
        let bad = |reason: String| MeshError::parse(r.path, format!("split {j}"), reason);
        let vt = (n0 + j) as u32;
        let case = b.get(2).map_err(cut)?;
        let hole = match case {
            3 if b.bit().map_err(cut)? => Hole::Right,
            3 => Hole::Left,
            _ => Hole::None,
        };
        let moves = b.bit().map_err(cut)?;
        let vs = b.get(width_for(vt as u64)).map_err(cut)? as u32;
        if vs >= vt {
            return Err(bad(format!("vs {vs} out of range ({vt} vertices)")));
        }
        let ring = fans.neighbours(vs);
        let mut neighbour = |present: bool| -> Result<u32, MeshError> {
            if !present {
                return Ok(NO_VERTEX);
            }
            let i = b.get(width_for(ring.len() as u64 + 1)).map_err(cut)? as usize;
            match i.cmp(&ring.len()) {
                std::cmp::Ordering::Less => Ok(ring[i]),
                std::cmp::Ordering::Equal => {
                    let v = b.get(width_for(vt as u64)).map_err(cut)? as u32;
                    if v >= vt { Err(bad(format!("neighbour {v} out of range"))) } else { Ok(v) }
                }
                std::cmp::Ordering::Greater => Err(bad(format!("neighbour place {i} past the ring of {}", ring.len()))),
            }
        };
        let vl = neighbour(case != 2)?;
        let vr = neighbour(case != 1)?;
        let (new, moved) = split_positions(&mut b, &mut codes, at[vs as usize], moves, grid.bits)
            .map_err(cut)?
            .ok_or_else(|| bad("a position off the grid".into()))?;
        let code = match previous_error {
            None => b.get(16).map_err(cut)?,
            Some(p) => {
                let c = (p as i64).wrapping_sub(codes.error.get_signed(&mut b).map_err(cut)?);
                u64::try_from(c).map_err(|_| bad(format!("error code {c}")))?
            }
        };
        if code > MAX_ERROR_CODE {
            return Err(bad(format!("error code {code:#x} is not a finite error")));
        }
        previous_error = Some(code);
        fans.split([vs, vl, vr], hole, vt, faces).map_err(bad)?;
        faces += faces_added(vl, vr, hole) as u32;
        at[vs as usize] = moved;
        at.push(new);
        splits.push(StreamedSplit {
            vs,
            vl,
            vr,
            hole,
            new_position: grid.value(&new),
            split_position: moves.then(|| grid.value(&moved)),
            error: error_value(code),
        });
    }
    if !b.at_end() {
        return Err(MeshError::parse(r.path, format!("byte {start}"), "unexpected bits after the last split"));
    }
    Ok((base, splits, grid))
}

/// A split's new vertex and the split vertex's place after it, as grid integers.
type SplitPlaces = ([i64; 3], [i64; 3]);

/// A split's new vertex and, when `moves`, the split vertex's new place, as grid integers coded
/// against its place `from`; `None` when either is off the grid of `bits`. Out-of-range deltas (a
/// corrupt file) wrap and then fail the grid check; nothing overflows.
fn split_positions(
    b: &mut BitReader,
    codes: &mut GeometryCodes,
    from: [i64; 3],
    moves: bool,
    bits: u8,
) -> Result<Option<SplitPlaces>, OutOfBits> {
    let fits = |q: &[i64; 3]| on_grid(&mut &q[..], 3, bits).is_some();
    let mut new = [0i64; 3];
    for a in 0..3 {
        new[a] = from[a].wrapping_add(codes.new_vertex[a].get_signed(b)?);
    }
    if !fits(&new) {
        return Ok(None);
    }
    let mut moved = from;
    if moves {
        for a in 0..3 {
            let r = codes.moved_vertex[a].get_signed(b)?;
            moved[a] = (from[a] - (new[a] - from[a]) / 2).wrapping_add(r);
        }
        if !fits(&moved) {
            return Ok(None);
        }
    }
    Ok(Some((new, moved)))
}

/// The base mesh at the start of the geometry section: `n0` positions on `grid` (returned too, as
/// grid integers, with room for the `k` splits' vertices), then `f0` faces, checked.
fn decode_base(
    b: &mut BitReader,
    grid: &Grid<3>,
    (n0, f0, k): (usize, usize, usize),
    path: &std::path::Path,
    start: usize,
) -> Result<(Vec<[i64; 3]>, Mesh), MeshError> {
    let cut = |_: OutOfBits| MeshError::parse(path, format!("byte {start}"), "the geometry section is truncated");
    let mut at: Vec<[i64; 3]> = Vec::with_capacity(n0 + k);
    for _ in 0..n0 {
        let mut q = [0i64; 3];
        for c in &mut q {
            *c = b.get(grid.bits as u32).map_err(cut)? as i64;
        }
        at.push(q);
    }
    let mut triangles = Vec::with_capacity(f0);
    for f in 0..f0 {
        let mut t = [0u32; 3];
        for v in &mut t {
            *v = b.get(width_for(n0 as u64)).map_err(cut)? as u32;
        }
        if let Some(&bad) = t.iter().find(|&&v| v as usize >= n0) {
            return Err(MeshError::parse(path, format!("base face {f}"), format!("vertex {bad} out of range")));
        }
        triangles.push(t);
    }
    let positions: Vec<[f32; 3]> = at.iter().map(|q| grid.value(q)).collect();
    let base = Mesh { positions, triangles, corners: Default::default() };
    base.check().map_err(|e| MeshError::parse(path, "base mesh", e.to_string()))?;
    Ok((at, base))
}

/// A corner not given its value yet.
const UNSET: u32 = crate::mesh::NONE;

/// What a value is made of, as grid integers: octahedral normal, texture coordinates, colour,
/// material (−1 for none), the four joints and the four weights (in 255ths summing to 255, as a
/// GPU's normalised bytes hold them; a joint of weight 0 is written as 0), those present.
struct Layout {
    /// Words of the channels the mask does not name, written as they are.
    raw_words: usize,
    normal: bool,
    uv: bool,
    color: bool,
    material: bool,
    skin: bool,
    tangent: bool,
    uv1: bool,
}

impl Layout {
    fn of(mask: u8, extra: &[Channel]) -> Layout {
        Layout {
            raw_words: extra.iter().map(|c| c.values.words_per_value()).sum(),
            normal: mask & ATTRIBUTE_NORMAL != 0,
            uv: mask & ATTRIBUTE_UV != 0,
            color: mask & ATTRIBUTE_COLOR != 0,
            material: mask & ATTRIBUTE_MATERIAL != 0,
            skin: mask & ATTRIBUTE_SKIN != 0,
            tangent: mask & ATTRIBUTE_TANGENT != 0,
            uv1: mask & ATTRIBUTE_UV1 != 0,
        }
    }

    /// The code each integer of a value uses: 0 normal, 1 uv, 2 colour, 3 material, 4 joint,
    /// 5 weight, 6 tangent direction, 7 tangent handedness, 8 a word of a channel the mask does
    /// not name.
    fn kinds(&self) -> Vec<usize> {
        let mut k = Vec::new();
        k.extend(std::iter::repeat_n(0, 2 * self.normal as usize));
        k.extend(std::iter::repeat_n(1, 2 * self.uv as usize));
        k.extend(std::iter::repeat_n(2, 4 * self.color as usize));
        k.extend(std::iter::repeat_n(3, self.material as usize));
        k.extend(std::iter::repeat_n(4, 4 * self.skin as usize));
        k.extend(std::iter::repeat_n(5, 4 * self.skin as usize));
        k.extend(std::iter::repeat_n(6, 2 * self.tangent as usize));
        k.extend(std::iter::repeat_n(7, self.tangent as usize));
        k.extend(std::iter::repeat_n(1, 2 * self.uv1 as usize));
        k.extend(std::iter::repeat_n(8, self.raw_words));
        k
    }
}

/// The attribute stream's state, the same on both sides: the values introduced so far, the
/// corners' values at the current level and the adaptive codes.
struct AttributeState {
    table: Vec<Vec<i64>>,
    corners: Vec<[u32; 3]>,
    codes: [Rice; 9],
    kinds: Vec<usize>,
    list: Vec<u32>,
    /// Writer only: the table index of each value.
    index: HashMap<Vec<i64>, u32>,
}

impl AttributeState {
    fn new(layout: &Layout, total_faces: usize) -> AttributeState {
        AttributeState {
            table: Vec::new(),
            corners: vec![[UNSET; 3]; total_faces],
            codes: Default::default(),
            kinds: layout.kinds(),
            list: Vec::new(),
            index: HashMap::new(),
        }
    }

    /// Sets the candidates: the values already at `x`'s corners, in the order of the faces around
    /// it, then `also` (a moved corner's value at `vs`) if it is not one of them.
    fn gather(&mut self, fans: &Fans, x: u32, also: Option<u32>) {
        self.list.clear();
        for &f in &fans.vertex_faces[x as usize] {
            let k = fans.triangles[f as usize].iter().position(|&v| v == x).expect("the face has the vertex");
            let c = self.corners[f as usize][k];
            if c != UNSET && !self.list.contains(&c) {
                self.list.push(c);
            }
        }
        if let Some(c) = also.filter(|c| !self.list.contains(c)) {
            self.list.push(c);
        }
    }

    /// The value a new one is coded against: the first candidate, else the last value introduced.
    fn predictor(&self) -> Vec<i64> {
        match self.list.first() {
            Some(&c) => self.table[c as usize].clone(),
            None => self.table.last().cloned().unwrap_or_else(|| vec![0; self.kinds.len()]),
        }
    }

    /// Writes the corner value `value` given the candidates in `self.list`: its place among them
    /// in unary, or past them a flag and either the index of an equal value introduced before or
    /// the new value's deltas from the predictor. Returns its table index.
    fn put(&mut self, w: &mut BitWriter, value: Vec<i64>) -> u32 {
        let m = self.list.len();
        if let Some(i) = self.list.iter().position(|&c| self.table[c as usize] == value) {
            w.ones(i);
            w.bit(false);
            return self.list[i];
        }
        w.ones(m);
        if let Some(&t) = self.index.get(&value) {
            w.bit(true);
            w.put(t as u64, width_for(self.table.len() as u64));
            return t;
        }
        w.bit(false);
        let p = self.predictor();
        for (i, (&v, &p)) in value.iter().zip(&p).enumerate() {
            self.codes[self.kinds[i]].put_signed(w, v - p);
        }
        self.index.insert(value.clone(), self.table.len() as u32);
        self.table.push(value);
        self.table.len() as u32 - 1
    }

    fn get(&mut self, b: &mut BitReader) -> Result<Result<u32, String>, OutOfBits> {
        let m = self.list.len();
        let mut i = 0;
        while i < m && b.bit()? {
            i += 1;
        }
        if i < m {
            return Ok(Ok(self.list[i]));
        }
        if b.bit()? {
            let t = b.get(width_for(self.table.len() as u64))?;
            if t >= self.table.len() as u64 {
                return Ok(Err(format!("attribute value {t} out of range ({} values)", self.table.len())));
            }
            return Ok(Ok(t as u32));
        }
        let p = self.predictor();
        let mut value = Vec::with_capacity(p.len());
        for (i, &p) in p.iter().enumerate() {
            value.push(p.wrapping_add(self.codes[self.kinds[i]].get_signed(b)?));
        }
        self.table.push(value);
        Ok(Ok(self.table.len() as u32 - 1))
    }
}

/// Writes the attribute grids and stream: per base corner and per split corner (each moved
/// face's corner at `vt`, then the new faces' corners) its value, chosen among those already at
/// that vertex or introduced as a delta from one of them.
pub(super) fn encode_attributes(
    out: &mut Vec<u8>,
    pm: &ProgressiveMesh,
    a: &PmAttributes,
    mask: u8,
    quantization: &Quantization,
) {
    out.push(mask);
    let extra: Vec<Channel> = extra_channels(&a.values).cloned().collect();
    if !extra.is_empty() {
        put_channel_table(out, &a.values);
    }
    let layout = Layout::of(mask, &extra);
    if layout.normal || layout.tangent {
        out.push(quantization.normal_bits);
    }
    // The writer fits a grid for every attribute present.
    let uvs = quantization.uvs.filter(|_| layout.uv);
    let colors = quantization.colors.filter(|_| layout.color);
    let uvs1 = quantization.uvs1.filter(|_| layout.uv1);
    assert_eq!(
        (uvs.is_some(), colors.is_some(), uvs1.is_some()),
        (layout.uv, layout.color, layout.uv1),
        "a grid per attribute"
    );
    if let Some(g) = &uvs {
        g.write(out, false);
    }
    if let Some(g) = &colors {
        g.write(out, false);
    }
    if let Some(g) = &uvs1 {
        g.write(out, false);
    }
    let channels = file_order(&a.values);
    let grids = (quantization.normal_bits, uvs.as_ref(), colors.as_ref(), uvs1.as_ref());
    let value_of = |id: u32| grid_value(&a.values, &channels, id as usize, grids);
    let base = pm.base();
    let total_faces = pm.faces_at_level(pm.levels());
    let mut state = AttributeState::new(&layout, total_faces);
    let mut fans = Fans::new(&base.triangles, base.vertex_count() + pm.levels(), total_faces);
    let mut w = BitWriter::default();
    for (f, t) in base.triangles.iter().enumerate() {
        for (k, &x) in t.iter().enumerate() {
            state.gather(&fans, x, None);
            state.corners[f][k] = state.put(&mut w, value_of(a.base[f][k]));
        }
    }
    let n0 = base.vertex_count();
    for (j, (s, sa)) in pm.splits().iter().zip(&a.splits).enumerate() {
        let vt = (n0 + j) as u32;
        let first = pm.faces_at_level(j);
        fans.split([s.vs, s.vl, s.vr], s.hole, vt, first as u32).expect("a ProgressiveMesh replays");
        let moved = std::mem::take(&mut fans.moved);
        let olds = unset_moved(&fans, &mut state.corners, &moved, vt);
        for (&f, &(k, old)) in moved.iter().zip(&olds) {
            state.gather(&fans, vt, Some(old));
            let value = match sa.moved.iter().find(|m| m.0 == f) {
                Some(&(_, id)) => value_of(id),
                None => state.table[old as usize].clone(),
            };
            state.corners[f as usize][k] = state.put(&mut w, value);
        }
        fans.moved = moved;
        for (slot, face) in (first..pm.faces_at_level(j + 1)).enumerate() {
            let t = fans.triangles[face];
            for (k, &x) in t.iter().enumerate() {
                state.gather(&fans, x, None);
                state.corners[face][k] = state.put(&mut w, value_of(sa.new_faces[slot][k]));
            }
        }
    }
    let bytes = w.finish();
    put_varint(out, bytes.len() as u64);
    out.extend_from_slice(&bytes);
}

/// Value `id` of `all` as the grid integers the stream codes: each channel's in file order
/// (`channels`), on the grids `grids` gives (normal bits, texture coordinates, colours, second
/// texture coordinates); a channel the mask does not name as its words.
fn grid_value(
    all: &CornerAttributes,
    channels: &[&Channel],
    id: usize,
    (normal_bits, uvs, colors, uvs1): (u8, Option<&Grid<2>>, Option<&Grid<4>>, Option<&Grid<2>>),
) -> Vec<i64> {
    let mut q = Vec::with_capacity(9);
    for c in channels {
        match (&c.semantic, &c.values) {
            (Semantic::Normal, Values::F3(n)) => q.extend(octahedral(n[id], normal_bits)),
            (Semantic::TexCoord(0), Values::F2(u)) => q.extend(uvs.expect("a grid per set").quantize(&u[id])),
            (Semantic::TexCoord(1), Values::F2(u)) => q.extend(uvs1.expect("a grid per set").quantize(&u[id])),
            (Semantic::Color(0), Values::F4(v)) => q.extend(colors.expect("a grid for colours").quantize(&v[id])),
            (Semantic::Material, Values::U32(m)) => q.push(if m[id] == NO_MATERIAL { -1 } else { m[id] as i64 }),
            (Semantic::Joints(0), Values::U16x4(j)) => {
                // A joint of weight 0 is written as 0.
                let weights = weight_bytes(all.weights().expect("joints come with weights")[id]);
                q.extend((0..4).map(|k| if weights[k] == 0 { 0 } else { i64::from(j[id][k]) }));
            }
            (Semantic::Weights(0), Values::F4(w)) => q.extend(weight_bytes(w[id])),
            (Semantic::Tangent, Values::F4(t)) => {
                let t = t[id];
                q.extend(octahedral([t[0], t[1], t[2]], normal_bits));
                q.push(i64::from(t[3] < 0.0));
            }
            (_, values) => {
                let mut words = Vec::new();
                values.words(id, &mut words);
                q.extend(words.into_iter().map(i64::from));
            }
        }
    }
    q
}

/// Skin weights in 255ths that sum to 255, each within one 255th of its share (the largest
/// remainders rounded up), so that the weights read back are normalised; all zero for a corner
/// with no positive weight.
fn weight_bytes(w: [f32; 4]) -> [i64; 4] {
    let total: f64 = w.iter().map(|&x| f64::from(x.max(0.0))).sum();
    if total.is_nan() || total <= 0.0 {
        return [0; 4];
    }
    let share = w.map(|x| f64::from(x.max(0.0)) / total * 255.0);
    let mut q = share.map(|x| x.floor() as i64);
    let mut order = [0, 1, 2, 3];
    order.sort_by(|&a, &b| (share[b] - share[b].floor()).total_cmp(&(share[a] - share[a].floor())).then(a.cmp(&b)));
    let missing = 255 - q.iter().sum::<i64>();
    for &k in order.iter().take(missing.clamp(0, 4) as usize) {
        q[k] += 1;
    }
    q
}

/// Marks each moved face's corner at `vt` unset; returns (corner, value it had).
fn unset_moved(fans: &Fans, corners: &mut [[u32; 3]], moved: &[u32], vt: u32) -> Vec<(usize, u32)> {
    moved
        .iter()
        .map(|&f| {
            let k = fans.triangles[f as usize].iter().position(|&v| v == vt).expect("moved to vt");
            let old = corners[f as usize][k];
            corners[f as usize][k] = UNSET;
            (k, old)
        })
        .collect()
}

/// The next `n` integers of `rest`, moved past, if every one lies on a `bits` grid.
fn on_grid<'q>(rest: &mut &'q [i64], n: usize, bits: u8) -> Option<&'q [i64]> {
    let (head, tail) = rest.split_at(n);
    *rest = tail;
    head.iter().all(|c| (0..1i64 << bits).contains(c)).then_some(head)
}

/// The attributes read from a compact file, with the normals' bits and the grids they were on
/// (texture coordinates, colours, second texture coordinates).
pub(super) type DecodedAttributes = (PmAttributes, u8, Option<Grid<2>>, Option<Grid<4>>, Option<Grid<2>>);

/// The value table's entries (grid integers, in the order `layout` gives) as the values they
/// stand for, each checked against its grid: normal bits, texture coordinate, colour and second
/// texture coordinate grids in `grids`. `channels`: the channels, empty, in file order.
fn table_values(
    table: &[Vec<i64>],
    mut channels: Vec<Channel>,
    uv_origin_top: bool,
    (normal_bits, uvs, colors, uvs1): (u8, Option<&Grid<2>>, Option<&Grid<4>>, Option<&Grid<2>>),
    path: &std::path::Path,
) -> Result<CornerAttributes, MeshError> {
    for (t, q) in table.iter().enumerate() {
        let bad = |what: &str| MeshError::parse(path, format!("attribute value {t}"), format!("{what} off its grid"));
        let mut rest = &q[..];
        for c in &mut channels {
            let pushed = match (&c.semantic, &mut c.values) {
                (Semantic::Normal, Values::F3(n)) => {
                    n.push(from_octahedral(
                        on_grid(&mut rest, 2, normal_bits).ok_or_else(|| bad("normal"))?,
                        normal_bits,
                    ));
                    true
                }
                (Semantic::TexCoord(set @ (0 | 1)), Values::F2(u)) => {
                    let (grid, what) =
                        if *set == 0 { (uvs, "texture coordinate") } else { (uvs1, "second texture coordinate") };
                    let g = grid.expect("a grid per texture coordinate set");
                    u.push(g.value(on_grid(&mut rest, 2, g.bits).ok_or_else(|| bad(what))?));
                    true
                }
                (Semantic::Color(0), Values::F4(v)) => {
                    let g = colors.expect("a grid for colours");
                    v.push(g.value(on_grid(&mut rest, 4, g.bits).ok_or_else(|| bad("colour"))?));
                    true
                }
                (Semantic::Material, Values::U32(m)) => {
                    m.push(match rest[0] {
                        -1 => NO_MATERIAL,
                        m if (0..NO_MATERIAL as i64).contains(&m) => m as u32,
                        m => {
                            return Err(MeshError::parse(
                                path,
                                format!("attribute value {t}"),
                                format!("material {m}"),
                            ));
                        }
                    });
                    rest = &rest[1..];
                    true
                }
                (Semantic::Joints(0), Values::U16x4(j)) => {
                    let read: Option<Vec<u16>> = rest[..4].iter().map(|&c| u16::try_from(c).ok()).collect();
                    let Some(read) = read else { return Err(bad("joint")) };
                    j.push([read[0], read[1], read[2], read[3]]);
                    rest = &rest[4..];
                    true
                }
                (Semantic::Weights(0), Values::F4(w)) => {
                    let weights = on_grid(&mut &rest[..4], 4, 8).ok_or_else(|| bad("weight"))?;
                    w.push(std::array::from_fn(|k| weights[k] as f32 / 255.0));
                    rest = &rest[4..];
                    true
                }
                (Semantic::Tangent, Values::F4(tangents)) => {
                    let direction =
                        from_octahedral(on_grid(&mut rest, 2, normal_bits).ok_or_else(|| bad("tangent"))?, normal_bits);
                    let handedness = on_grid(&mut rest, 1, 1).ok_or_else(|| bad("tangent handedness"))?[0];
                    let [x, y, z] = direction;
                    tangents.push([x, y, z, if handedness == 1 { -1.0 } else { 1.0 }]);
                    true
                }
                (_, values) => {
                    // A channel the mask does not name: its words as they are.
                    let n = values.words_per_value();
                    let words: Option<Vec<u32>> = rest[..n].iter().map(|&w| u32::try_from(w).ok()).collect();
                    rest = &rest[n..];
                    words.is_some_and(|w| values.push_words(&w))
                }
            };
            if !pushed {
                return Err(MeshError::parse(
                    path,
                    format!("attribute value {t}"),
                    format!("a {} value that is not one", c.semantic.name()),
                ));
            }
        }
    }
    Ok(attributes_of(channels, uv_origin_top))
}

/// Reads what [`encode_attributes`] wrote, replaying the splits of `pm` (already read).
pub(super) fn decode_attributes(
    r: &mut Reader,
    pm: &ProgressiveMesh,
    extra: bool,
) -> Result<DecodedAttributes, MeshError> {
    let mask = r.take(1)?[0];
    super::header::check_mask(r, mask, extra)?;
    let extra = if extra { read_channel_table(r)? } else { Vec::new() };
    let layout = Layout::of(mask, &extra);
    let mut channels = masked_channels(mask);
    channels.extend(extra);
    let normal_bits = if layout.normal || layout.tangent {
        let bits = r.take(1)?[0];
        if bits == 0 || bits > MAX_BITS {
            return Err(r.error(format!("normal grid of {bits} bits (1 to {MAX_BITS})")));
        }
        bits
    } else {
        0
    };
    let uvs = if layout.uv { Some(Grid::<2>::read(r, false, "texture coordinate")?) } else { None };
    let colors = if layout.color { Some(Grid::<4>::read(r, false, "colour")?) } else { None };
    let uvs1 = if layout.uv1 { Some(Grid::<2>::read(r, false, "second texture coordinate")?) } else { None };
    let length = r.varint()?;
    if length > (r.bytes.len() - r.offset) as u64 {
        return Err(r.error(format!("an attribute section of {length} bytes does not fit in the file")));
    }
    let start = r.offset;
    let bytes = r.take(length as usize)?;
    let path = r.path;
    let mut b = BitReader::new(bytes);
    let cut = |_: OutOfBits| MeshError::parse(path, format!("byte {start}"), "the attribute section is truncated");
    let base = pm.base();
    let total_faces = pm.faces_at_level(pm.levels());
    let mut state = AttributeState::new(&layout, total_faces);
    let mut fans = Fans::new(&base.triangles, base.vertex_count() + pm.levels(), total_faces);
    let mut base_corners = Vec::with_capacity(base.face_count());
    for (f, t) in base.triangles.iter().enumerate() {
        for (k, &x) in t.iter().enumerate() {
            state.gather(&fans, x, None);
            state.corners[f][k] = state
                .get(&mut b)
                .map_err(cut)?
                .map_err(|reason| MeshError::parse(path, format!("base face {f}"), reason))?;
        }
        base_corners.push(state.corners[f]);
    }
    let n0 = base.vertex_count();
    let mut splits = Vec::with_capacity(pm.levels());
    for (j, s) in pm.splits().iter().enumerate() {
        let bad = |reason: String| MeshError::parse(path, format!("split {j} attributes"), reason);
        let vt = (n0 + j) as u32;
        let first = pm.faces_at_level(j);
        fans.split([s.vs, s.vl, s.vr], s.hole, vt, first as u32).map_err(bad)?;
        let moved_faces = std::mem::take(&mut fans.moved);
        let olds = unset_moved(&fans, &mut state.corners, &moved_faces, vt);
        let mut moved = Vec::new();
        for (&f, &(k, old)) in moved_faces.iter().zip(&olds) {
            state.gather(&fans, vt, Some(old));
            let value = state.get(&mut b).map_err(cut)?.map_err(bad)?;
            state.corners[f as usize][k] = value;
            if value != old {
                moved.push((f, value));
            }
        }
        fans.moved = moved_faces;
        let mut new_faces = [[0; 3]; 2];
        for (slot, face) in (first..pm.faces_at_level(j + 1)).enumerate() {
            let t = fans.triangles[face];
            for (k, &x) in t.iter().enumerate() {
                state.gather(&fans, x, None);
                state.corners[face][k] = state.get(&mut b).map_err(cut)?.map_err(bad)?;
            }
            new_faces[slot] = state.corners[face];
        }
        splits.push(SplitAttributes { new_faces, moved });
    }
    if !b.at_end() {
        return Err(MeshError::parse(path, format!("byte {start}"), "unexpected bits after the last attribute"));
    }
    let grids = (normal_bits, uvs.as_ref(), colors.as_ref(), uvs1.as_ref());
    let values = table_values(&state.table, channels, mask & ATTRIBUTE_UV_ORIGIN_TOP != 0, grids, path)?;
    Ok((PmAttributes { values, base: base_corners, splits }, normal_bits, uvs, colors, uvs1))
}
