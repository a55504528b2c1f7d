//! glTF 2.0 writer: `.glb` (binary container) or `.gltf` (JSON with the buffer embedded).
//!
//! The mesh becomes one node with one mesh, one TRIANGLES primitive per material (positions are
//! already placed in the world by the reader, so no transform is needed). Vertices are split where
//! their corners differ ([`crate::mesh::CornerAttributes::wedges`]), so seams and hard edges come
//! out as glTF expects them, and the primitives share the vertex accessors. Indices are 16-bit when
//! the vertices fit, else 32-bit. The input's materials, textures, samplers and images are carried
//! verbatim ([`MaterialLibrary`]); images are embedded in the buffer, so the output draws without
//! the input's folder. An image whose file cannot be read is kept as a URI relative to the output
//! (and named in the error when there is no output folder to point from).
//!
//! With [`WriteOptions::quantize`] the vertex data is stored as integers under
//! `KHR_mesh_quantization` (required by the file, so a viewer without it refuses it rather than
//! drawing garbage), as gltfpack stores it: positions as 16-bit integers on a grid spanning the
//! mesh's largest side, undone by the node's translation and uniform scale (error at most
//! √3/2 · side / 65 535 per vertex; a skinned mesh keeps float positions, its node's transform
//! being ignored by skinning); normals and tangents as normalised 8-bit integers (within half a
//! degree); texture coordinates in [0, 1] as normalised unsigned 16-bit integers (1/65 535: 0.016
//! texel of a 1024² texture), in [-1, 1] as signed ones (1/32 767), others as floats (a repeating
//! texture); colours as normalised 16-bit integers (core glTF).

use std::io::Write;
use std::path::Path;

use base64::Engine as _;
use serde_json::{Value, json};

use super::accessor::{bounds, floats};
use crate::io::files::{read_referenced, relative_uri, sniff_image};
use crate::io::options::WriteOptions;
use crate::mesh::{
    CornerAttributes, ImageSource, MaterialLibrary, Mesh, NO_MATERIAL, OtherPrimitive, Semantic, Values,
};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const BYTE: u32 = 5120;
const SHORT: u32 = 5122;
const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const QUANTIZATION: &str = "KHR_mesh_quantization";

/// The binary buffer being assembled, with its bufferViews.
#[derive(Default)]
struct Buffer {
    bytes: Vec<u8>,
    views: Vec<Value>,
}

impl Buffer {
    /// Appends `data` as a new bufferView (4-byte aligned), returning its index.
    fn view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        let mut view = json!({ "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len() });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bytes.extend_from_slice(data);
        self.views.push(view);
        self.views.len() - 1
    }

    /// [`Buffer::view`] of vertex data whose elements are `stride` bytes apart.
    fn strided(&mut self, data: &[u8], stride: usize) -> usize {
        let view = self.view(data, Some(ARRAY_BUFFER));
        self.views[view]["byteStride"] = json!(stride);
        view
    }
}

/// A vertex attribute as it is stored: its bytes, their component type, whether they are
/// normalised integers, and the stride between elements where padding makes it more than their
/// size.
struct Stored {
    bytes: Vec<u8>,
    component: u32,
    normalized: bool,
    stride: Option<usize>,
}

impl Stored {
    fn floats<const N: usize>(values: impl Iterator<Item = [f32; N]>) -> Stored {
        Stored { bytes: floats(values), component: FLOAT, normalized: false, stride: None }
    }
}

/// `x` in [-1, 1] as a normalised signed byte (glTF: `max(b / 127, -1)`).
fn snorm8(x: f32) -> u8 {
    ((x.clamp(-1.0, 1.0) * 127.0).round() as i8) as u8
}

/// `x` in [-1, 1] as a normalised signed short (glTF: `max(s / 32767, -1)`).
fn snorm16(x: f32) -> [u8; 2] {
    ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16).to_le_bytes()
}

/// `x` in [0, 1] as a normalised unsigned short (`s / 65535`).
fn unorm16(x: f32) -> [u8; 2] {
    ((x.clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes()
}

/// The positions on a 16-bit grid: the integers (with each element padded to 8 bytes), their
/// per-component minimum and maximum, and the grid's origin and step.
fn quantized_positions(positions: &[[f32; 3]], min: [f32; 3], max: [f32; 3]) -> (Vec<u8>, [u16; 3], [u16; 3], f32) {
    let side = (0..3).map(|k| max[k] - min[k]).fold(0.0f32, f32::max);
    let step = if side > 0.0 { side / 65535.0 } else { 1.0 };
    let (mut qmin, mut qmax) = ([u16::MAX; 3], [0u16; 3]);
    let mut bytes = Vec::with_capacity(8 * positions.len());
    for p in positions {
        for k in 0..3 {
            let q = ((p[k] - min[k]) / step).round().clamp(0.0, 65535.0) as u16;
            qmin[k] = qmin[k].min(q);
            qmax[k] = qmax[k].max(q);
            bytes.extend_from_slice(&q.to_le_bytes());
        }
        bytes.extend_from_slice(&[0, 0]);
    }
    (bytes, qmin, qmax, step)
}

/// Writes `mesh` as glTF: GLB when `binary`, else JSON with a data-URI buffer. `folder`: where the
/// output goes, to point at images that cannot be embedded.
pub fn write_gltf(out: impl Write, mesh: &Mesh, binary: bool, folder: Option<&Path>) -> std::io::Result<()> {
    write_gltf_with(out, mesh, binary, folder, &WriteOptions::default())
}

/// [`write_gltf`] with the [`WriteOptions`] (quantized vertex data, see the module documentation).
pub fn write_gltf_with(
    out: impl Write,
    mesh: &Mesh,
    binary: bool,
    folder: Option<&Path>,
    options: &WriteOptions,
) -> std::io::Result<()> {
    let corners = &mesh.corners;
    let quantize = options.quantize;
    let rig = corners.library.as_ref().and_then(|l| l.rig.as_ref()).filter(|_| corners.joints().is_some());
    // Whether an accessor uses the extension's integer types (a mesh with nothing to quantize
    // does not need it).
    let mut quantized = false;
    // The transform that undoes the positions' grid, on the mesh's node: (origin, step).
    let mut grid = None;
    let wedges = corners.wedges(&mesh.triangles, mesh.vertex_count());
    let count = wedges.source.len();
    let vertex = |i: usize| wedges.vertex(&mesh.triangles, i);
    let mut buffer = Buffer::default();
    let mut accessors: Vec<Value> = Vec::new();
    let mut attributes = serde_json::Map::new();

    // Positions, with the exact min and max the validator checks.
    let positions: Vec<[f32; 3]> = (0..count).map(|i| mesh.positions[vertex(i)]).collect();
    let (min, max) = bounds(&positions);
    let position = if quantize && rig.is_none() && count > 0 {
        let (bytes, qmin, qmax, step) = quantized_positions(&positions, min, max);
        quantized = true;
        grid = Some((min, step));
        let view = buffer.strided(&bytes, 8);
        json!({ "bufferView": view, "componentType": UNSIGNED_SHORT, "count": count, "type": "VEC3",
                "min": qmin, "max": qmax })
    } else {
        let view = buffer.view(&floats(positions.into_iter()), Some(ARRAY_BUFFER));
        let mut position = json!({ "bufferView": view, "componentType": FLOAT, "count": count, "type": "VEC3" });
        if count > 0 {
            position["min"] = json!(min);
            position["max"] = json!(max);
        }
        position
    };
    accessors.push(position);
    attributes.insert("POSITION".into(), json!(accessors.len() - 1));

    let mut vertices =
        VertexAccessors { buffer: &mut buffer, accessors: &mut accessors, attributes: &mut attributes, count };
    quantized |= vertices.add_corner_values(corners, &wedges.source, quantize);

    let mut primitives =
        primitives_by_material(mesh, &wedges.corner_vertex, count, &attributes, &mut accessors, &mut buffer);

    if let Some(library) = &corners.library {
        add_other_primitives(&library.other_primitives, grid, &mut primitives, &mut accessors, &mut buffer);
    }

    let mut document = json!({
        "asset": { "version": "2.0", "generator": concat!("meshlod ", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": primitives }],
    });
    if let Some((origin, step)) = grid {
        document["nodes"][0]["translation"] = json!(origin);
        document["nodes"][0]["scale"] = json!([step, step, step]);
    }
    // A skinned mesh is drawn where its input was, by the node with the skin, in the input's
    // hierarchy, with the input's animations (skin joints only without one: the joints have no
    // skin to refer to, and a mesh without them is the input's bind pose).
    if let Some(rig) = rig {
        add_rig(&mut document, rig, &mut accessors, &mut buffer);
    }
    document["accessors"] = json!(accessors);
    if let Some(library) = &corners.library {
        add_library(&mut document, library, &mut buffer, folder)?;
    }
    if quantized {
        for key in ["extensionsUsed", "extensionsRequired"] {
            let list = document[key].as_array().cloned().unwrap_or_default();
            if !list.iter().any(|e| e == QUANTIZATION) {
                document[key] = json!(list.into_iter().chain([json!(QUANTIZATION)]).collect::<Vec<_>>());
            }
        }
    }
    emit(out, document, buffer, binary)
}

/// The vertex attributes' accessors as they are added: their data into `buffer`, their JSON into
/// `accessors`, their names into the primitives' `attributes`; `count` vertices each.
struct VertexAccessors<'a> {
    buffer: &'a mut Buffer,
    accessors: &'a mut Vec<Value>,
    attributes: &'a mut serde_json::Map<String, Value>,
    count: usize,
}

impl VertexAccessors<'_> {
    /// One attribute, `name`, of glTF type `kind`, stored as `stored` says.
    fn add(&mut self, name: &str, kind: &str, stored: Stored) {
        let view = match stored.stride {
            Some(stride) => self.buffer.strided(&stored.bytes, stride),
            None => self.buffer.view(&stored.bytes, Some(ARRAY_BUFFER)),
        };
        let mut accessor =
            json!({ "bufferView": view, "componentType": stored.component, "count": self.count, "type": kind });
        if stored.normalized {
            accessor["normalized"] = json!(true);
        }
        self.accessors.push(accessor);
        self.attributes.insert(name.into(), json!(self.accessors.len() - 1));
    }

    /// The corners' values (normals, tangents, texture coordinates, colours, joints and weights),
    /// each vertex taking those of its corner `source`; with `quantize` as integers where glTF
    /// allows. Whether any is stored as KHR_mesh_quantization's integer types.
    fn add_corner_values(&mut self, corners: &CornerAttributes, source: &[usize], quantize: bool) -> bool {
        let mut quantized = false;
        if let Some(normals) = &corners.normals() {
            let values = (0..self.count).map(|i| unit(normals[source[i]]));
            let stored = if quantize {
                quantized = true;
                // Each element padded to 4 bytes, as glTF aligns vertex attributes.
                let bytes = values.flat_map(|n| [snorm8(n[0]), snorm8(n[1]), snorm8(n[2]), 0]).collect();
                Stored { bytes, component: BYTE, normalized: true, stride: Some(4) }
            } else {
                Stored::floats(values)
            };
            self.add("NORMAL", "VEC3", stored);
        }
        if let Some(tangents) = &corners.tangents() {
            let values = (0..self.count).map(|i| {
                let t = tangents[source[i]];
                let [x, y, z] = unit([t[0], t[1], t[2]]);
                [x, y, z, if t[3] < 0.0 { -1.0 } else { 1.0 }]
            });
            let stored = if quantize {
                quantized = true;
                Stored {
                    bytes: values.flat_map(|t| t.map(snorm8)).collect(),
                    component: BYTE,
                    normalized: true,
                    stride: None,
                }
            } else {
                Stored::floats(values)
            };
            self.add("TANGENT", "VEC4", stored);
        }
        for (name, uvs) in
            [("TEXCOORD_0", corners.uvs_with_origin(true)), ("TEXCOORD_1", corners.uvs1_with_origin(true))]
        {
            let Some(uvs) = uvs else { continue };
            let values = || (0..self.count).map(|i| uvs[source[i]]);
            // Normalised integers hold [0, 1] (unsigned) or [-1, 1] (signed, at half the precision):
            // a repeating texture's coordinates stay float.
            let within = |range: std::ops::RangeInclusive<f32>| values().flatten().all(|c| range.contains(&c));
            let integers = |component: u32, encode: fn(f32) -> [u8; 2]| {
                let bytes = values().flatten().flat_map(encode).collect();
                Stored { bytes, component, normalized: true, stride: None }
            };
            let stored = match quantize {
                true if within(0.0..=1.0) => integers(UNSIGNED_SHORT, unorm16),
                true if within(-1.0..=1.0) => integers(SHORT, snorm16),
                _ => Stored::floats(values()),
            };
            quantized |= stored.component != FLOAT;
            self.add(name, "VEC2", stored);
        }
        if let Some(colors) = &corners.colors() {
            let values = (0..self.count).map(|i| colors[source[i]].map(|c| c.clamp(0.0, 1.0)));
            let stored = if quantize {
                let bytes = values.flat_map(|c| c.map(unorm16)).flatten().collect();
                Stored { bytes, component: UNSIGNED_SHORT, normalized: true, stride: None }
            } else {
                Stored::floats(values)
            };
            self.add("COLOR_0", "VEC4", stored);
        }
        if let (Some(joints), Some(weights)) = (&corners.joints(), &corners.weights()) {
            let bytes =
                (0..self.count).flat_map(|i| joints[source[i]].into_iter().flat_map(u16::to_le_bytes)).collect();
            self.add("JOINTS_0", "VEC4", Stored { bytes, component: UNSIGNED_SHORT, normalized: false, stride: None });
            self.add("WEIGHTS_0", "VEC4", Stored::floats((0..self.count).map(|i| weights[source[i]])));
        }
        self.add_extra_channels(corners, source);
        quantized
    }

    /// The channels beyond the ones written above, as they are: TEXCOORD_n past the second set
    /// (with v down, as glTF has it), COLOR_n past the first, and custom channels by their name.
    fn add_extra_channels(&mut self, corners: &CornerAttributes, source: &[usize]) {
        for c in corners.channels() {
            let (name, flip) = match &c.semantic {
                Semantic::TexCoord(k @ 2..) => (format!("TEXCOORD_{k}"), !corners.uv_origin_top),
                Semantic::Color(k @ 1..) => (format!("COLOR_{k}"), false),
                Semantic::Custom(name) => (name.clone(), false),
                _ => continue,
            };
            let picked = c.values.pick((0..self.count).map(|i| source[i]));
            let (kind, stored) = match picked {
                Values::F1(v) => ("SCALAR", Stored::floats(v.into_iter())),
                Values::F2(v) if flip => ("VEC2", Stored::floats(v.into_iter().map(|[u, v]| [u, 1.0 - v]))),
                Values::F2(v) => ("VEC2", Stored::floats(v.into_iter())),
                Values::F3(v) => ("VEC3", Stored::floats(v.into_iter())),
                Values::F4(v) => ("VEC4", Stored::floats(v.into_iter())),
                Values::U16x4(v) => {
                    let bytes = v.into_iter().flat_map(|j| j.into_iter().flat_map(u16::to_le_bytes)).collect();
                    ("VEC4", Stored { bytes, component: UNSIGNED_SHORT, normalized: false, stride: None })
                }
                Values::U32(v) => {
                    let bytes = v.into_iter().flat_map(u32::to_le_bytes).collect();
                    ("SCALAR", Stored { bytes, component: UNSIGNED_INT, normalized: false, stride: None })
                }
            };
            self.add(&name, kind, stored);
        }
    }
}

/// One primitive per material of `mesh`, in the order materials first appear, each with the
/// vertex `attributes` and its indices (the corners' vertices, `corner_vertex`, of `count`), all
/// indices in one view.
fn primitives_by_material(
    mesh: &Mesh,
    corner_vertex: &[u32],
    count: usize,
    attributes: &serde_json::Map<String, Value>,
    accessors: &mut Vec<Value>,
    buffer: &mut Buffer,
) -> Vec<Value> {
    let corners = &mesh.corners;
    let material_of = |f: usize| corners.materials().map_or(NO_MATERIAL, |m| m[3 * f]);
    let mut groups: Vec<(u32, Vec<usize>)> = Vec::new();
    let mut group_of: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    for f in 0..mesh.face_count() {
        let m = material_of(f);
        let g = *group_of.entry(m).or_insert_with(|| {
            groups.push((m, Vec::new()));
            groups.len() - 1
        });
        groups[g].1.push(f);
    }
    // 0xFFFF is a primitive-restart value for 16-bit indices: 32-bit from there.
    let wide = count >= 0xFFFF;
    let mut index_bytes = Vec::new();
    let mut primitives = Vec::new();
    let mut index_accessors = Vec::new();
    for (material, faces) in &groups {
        let offset = index_bytes.len();
        for &f in faces {
            for k in 0..3 {
                let v = corner_vertex[3 * f + k];
                if wide {
                    index_bytes.extend_from_slice(&v.to_le_bytes());
                } else {
                    index_bytes.extend_from_slice(&(v as u16).to_le_bytes());
                }
            }
        }
        index_accessors.push((offset, 3 * faces.len()));
        let mut primitive = json!({ "attributes": attributes.clone(), "mode": 4 });
        if *material != NO_MATERIAL {
            primitive["material"] = json!(material);
        }
        primitives.push(primitive);
    }
    if !index_bytes.is_empty() {
        let view = buffer.view(&index_bytes, Some(ELEMENT_ARRAY_BUFFER));
        for ((offset, n), primitive) in index_accessors.into_iter().zip(&mut primitives) {
            let component = if wide { UNSIGNED_INT } else { UNSIGNED_SHORT };
            accessors.push(
                json!({ "bufferView": view, "byteOffset": offset, "componentType": component, "count": n, "type": "SCALAR" }),
            );
            primitive["indices"] = json!(accessors.len() - 1);
        }
    }
    primitives
}

/// Writes the document and its buffer: a GLB when `binary` (JSON and binary chunks, each padded
/// to 4 bytes), else JSON with the buffer as a data URI.
fn emit(mut out: impl Write, mut document: Value, buffer: Buffer, binary: bool) -> std::io::Result<()> {
    document["bufferViews"] = json!(buffer.views);
    let length = buffer.bytes.len();
    if binary {
        document["buffers"] = json!([{ "byteLength": length }]);
        let mut text = serde_json::to_vec(&document).map_err(std::io::Error::other)?;
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let mut bin = buffer.bytes;
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + text.len() + 8 + bin.len();
        let total = u32::try_from(total).map_err(|_| std::io::Error::other("the GLB would exceed 4 GiB"))?;
        out.write_all(b"glTF")?;
        out.write_all(&2u32.to_le_bytes())?;
        out.write_all(&total.to_le_bytes())?;
        out.write_all(&(text.len() as u32).to_le_bytes())?;
        out.write_all(b"JSON")?;
        out.write_all(&text)?;
        out.write_all(&(bin.len() as u32).to_le_bytes())?;
        out.write_all(b"BIN\0")?;
        out.write_all(&bin)
    } else {
        let data = base64::engine::general_purpose::STANDARD.encode(&buffer.bytes);
        document["buffers"] =
            json!([{ "byteLength": length, "uri": format!("data:application/octet-stream;base64,{data}") }]);
        serde_json::to_writer_pretty(&mut out, &document).map_err(std::io::Error::other)?;
        out.write_all(b"\n")
    }
}

/// Appends the input's point and line primitives ([`OtherPrimitive`]) to `primitives`, their
/// accessors to `accessors` and their data to `buffer`, each element padded to a multiple of 4
/// bytes as glTF aligns vertex attributes; their positions moved into the frame of the node's
/// `grid` (origin, step) when the triangles' positions are on one.
fn add_other_primitives(
    others: &[OtherPrimitive],
    grid: Option<([f32; 3], f32)>,
    primitives: &mut Vec<Value>,
    accessors: &mut Vec<Value>,
    buffer: &mut Buffer,
) {
    for other in others {
        let mut primitive = json!({ "mode": other.mode, "attributes": {} });
        for (name, accessor) in &other.attributes {
            let mut json = accessor.json.clone();
            let mut bytes = accessor.bytes.clone();
            if let (Some((origin, step)), "POSITION") = (grid, name.as_str()) {
                let moved: Vec<[f32; 3]> = bytes
                    .chunks_exact(12)
                    .map(|c| {
                        std::array::from_fn(|k| {
                            (f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]) - origin[k])
                                / step
                        })
                    })
                    .collect();
                if !moved.is_empty() {
                    let (min, max) = bounds(&moved);
                    (json["min"], json["max"]) = (json!(min), json!(max));
                }
                bytes = floats(moved.into_iter());
            }
            let count = json["count"].as_u64().unwrap_or(0) as usize;
            let element = bytes.len().checked_div(count).unwrap_or(0);
            let view = if element > 0 && !element.is_multiple_of(4) {
                let stride = element.next_multiple_of(4);
                let padded: Vec<u8> = bytes
                    .chunks_exact(element)
                    .flat_map(|c| c.iter().copied().chain(std::iter::repeat_n(0, stride - element)))
                    .collect();
                buffer.strided(&padded, stride)
            } else {
                buffer.view(&bytes, Some(ARRAY_BUFFER))
            };
            json["bufferView"] = json!(view);
            accessors.push(json);
            primitive["attributes"][name] = json!(accessors.len() - 1);
        }
        if let Some(indices) = &other.indices {
            let mut json = indices.json.clone();
            json["bufferView"] = json!(buffer.view(&indices.bytes, Some(ELEMENT_ARRAY_BUFFER)));
            accessors.push(json);
            primitive["indices"] = json!(accessors.len() - 1);
        }
        if let Some(material) = other.material {
            primitive["material"] = json!(material);
        }
        primitives.push(primitive);
    }
}

/// Puts `rig`'s nodes, scenes, skins and animations into `document`, its accessors after
/// `accessors` (the references renumbered to match) and their data into `buffer`.
fn add_rig(document: &mut Value, rig: &crate::mesh::Rig, accessors: &mut Vec<Value>, buffer: &mut Buffer) {
    let first = accessors.len() as u64;
    for carried in &rig.accessors {
        let mut json = carried.json.clone();
        json["bufferView"] = json!(buffer.view(&carried.bytes, None));
        accessors.push(json);
    }
    let shift = |value: &mut Value| {
        if let Some(k) = value.as_u64() {
            *value = json!(k + first);
        }
    };
    let mut skins = rig.skins.clone();
    for skin in &mut skins {
        if let Some(matrices) = skin.get_mut("inverseBindMatrices") {
            shift(matrices);
        }
    }
    let mut animations = rig.animations.clone();
    for sampler in animations.iter_mut().filter_map(|a| a.get_mut("samplers")?.as_array_mut()).flatten() {
        for key in ["input", "output"] {
            if let Some(value) = sampler.get_mut(key) {
                shift(value);
            }
        }
    }
    let mut nodes = rig.nodes.clone();
    nodes[rig.mesh_node]["mesh"] = json!(0);
    document["nodes"] = json!(nodes);
    document["scenes"] = json!(rig.scenes);
    match rig.scene {
        Some(scene) => document["scene"] = json!(scene),
        None => {
            document.as_object_mut().map(|d| d.remove("scene"));
        }
    }
    document["skins"] = json!(skins);
    if !animations.is_empty() {
        document["animations"] = json!(animations);
    }
}

/// A normal of unit length (glTF requires it): kept bit for bit when it already is one.
fn unit(n: [f32; 3]) -> [f32; 3] {
    let length = n.iter().map(|&c| f64::from(c) * f64::from(c)).sum::<f64>().sqrt();
    if (length - 1.0).abs() < 1e-4 {
        n
    } else if length > 0.0 {
        n.map(|c| (f64::from(c) / length) as f32)
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// Copies the library's materials, textures, samplers and images into `document`, embedding every
/// image whose bytes are at hand.
fn add_library(
    document: &mut Value,
    library: &MaterialLibrary,
    buffer: &mut Buffer,
    folder: Option<&Path>,
) -> std::io::Result<()> {
    let mut images = Vec::new();
    for (index, image) in library.images.iter().enumerate() {
        let mut json = image.json.clone();
        if !json.is_object() {
            json = json!({});
        }
        let bytes = match &image.source {
            ImageSource::Bytes(bytes) => Some(bytes.clone()),
            ImageSource::File(path) => read_referenced(path).ok(),
            ImageSource::Uri(_) => None,
        };
        let mime = bytes.as_deref().and_then(sniff_image).map(str::to_string).or_else(|| image.mime_type.clone());
        match (bytes, mime) {
            (Some(bytes), Some(mime)) => {
                json["bufferView"] = json!(buffer.view(&bytes, None));
                json["mimeType"] = json!(mime);
            }
            _ => {
                let uri = match &image.source {
                    ImageSource::Uri(uri) => uri.clone(),
                    ImageSource::File(path) => relative_uri(path, folder).ok_or_else(|| {
                        std::io::Error::other(format!(
                            "image {index} ('{}') cannot be read, and there is no output folder to refer to it from",
                            path.display()
                        ))
                    })?,
                    ImageSource::Bytes(_) => {
                        return Err(std::io::Error::other(format!("image {index} is of an unknown type")));
                    }
                };
                json["uri"] = json!(uri);
            }
        }
        images.push(json);
    }
    let mut put = |key: &str, values: Vec<Value>| {
        if !values.is_empty() {
            document[key] = Value::Array(values);
        }
    };
    // The MTL statements an OBJ input's materials keep for an OBJ output (`super::mtl`) are
    // nothing to a glTF client: left out.
    let materials = library.materials.iter().map(|m| {
        let mut m = m.clone();
        if let Some(extras) = m.get_mut("extras").and_then(Value::as_object_mut) {
            extras.remove("mtl");
            if extras.is_empty() {
                m.as_object_mut().map(|o| o.remove("extras"));
            }
        }
        m
    });
    put("materials", materials.collect());
    put("textures", library.textures.clone());
    put("samplers", library.samplers.clone());
    put("images", images);
    let strings = |v: &[String]| v.iter().map(|s| json!(s)).collect::<Vec<_>>();
    put("extensionsUsed", strings(&library.extensions_used));
    put("extensionsRequired", strings(&library.extensions_required));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_uris_climb_and_escape() {
        let uri = relative_uri(Path::new("/a/b/tex ture.png"), Some(Path::new("/a/c/d"))).unwrap();
        assert_eq!(uri, "../../b/tex%20ture.png");
        assert_eq!(relative_uri(Path::new("/a/x.png"), Some(Path::new("/a"))).unwrap(), "x.png");
        assert_eq!(relative_uri(Path::new("/a/x.png"), None), None);
    }

    #[test]
    fn image_types_are_known_by_their_bytes() {
        assert_eq!(sniff_image(b"\x89PNG\r\n\x1a\n...."), Some("image/png"));
        assert_eq!(sniff_image(&[0xFF, 0xD8, 0xFF, 0xE0]), Some("image/jpeg"));
        assert_eq!(sniff_image(b"GIF89a"), None);
    }
}
