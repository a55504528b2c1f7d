//! glTF primitives that are not surface (POINTS, LINES, LINE_LOOP, LINE_STRIP), read into
//! [`OtherPrimitive`]s that the library carries beside the mesh and the writer puts back beside its
//! triangles. Positions are placed in the world as the mesh's are (normals and tangents turned with
//! them) and kept as floats, as are texture coordinates and colours, so that no integer type of
//! KHR_mesh_quantization is left in an output that does not declare it; every other attribute and
//! the indices keep their data as it was.

use glam::{DMat3, DMat4, DVec3};
use gltf::Semantic;
use serde_json::{Value, json};

use super::accessor::{self, finite, quantized};
use super::checks;
use crate::mesh::{OtherPrimitive, RigAccessor};

/// Accessor `index`'s elements packed one after another, with its JSON (`bufferView`, `byteOffset`
/// and `sparse` taken out); `Err` for a sparse one.
pub(super) fn packed(
    raw: &Value,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    index: usize,
) -> Result<RigAccessor, String> {
    let accessor = document.accessors().nth(index).ok_or("an accessor that does not exist")?;
    if accessor.sparse().is_some() {
        return Err(format!("accessor {index} is sparse"));
    }
    let element = accessor.size();
    let mut bytes = vec![0u8; element * accessor.count()];
    if let Some(view) = accessor.view() {
        let stride = view.stride().unwrap_or(element);
        let data = &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
        for (i, chunk) in bytes.chunks_exact_mut(element).enumerate() {
            let start = accessor.offset() + i * stride;
            chunk.copy_from_slice(&data[start..start + element]);
        }
    }
    let mut json = raw["accessors"][index].clone();
    if let Some(object) = json.as_object_mut() {
        for key in ["bufferView", "byteOffset", "sparse"] {
            object.remove(key);
        }
    }
    Ok(RigAccessor { json, bytes })
}

/// Float values as a carried accessor, with their per-component minimum and maximum when `bounds`
/// (glTF asks them of POSITION); `Err` naming the first value that is not a finite number.
fn floats<const N: usize>(name: &str, values: Vec<[f32; N]>, bounds: bool) -> Result<RigAccessor, String> {
    finite(name, &values)?;
    let kind = ["SCALAR", "VEC2", "VEC3", "VEC4"][N - 1];
    let mut json = json!({ "componentType": 5126, "count": values.len(), "type": kind });
    if bounds && !values.is_empty() {
        let (min, max) = accessor::bounds(&values);
        json["min"] = json!(min.to_vec());
        json["max"] = json!(max.to_vec());
    }
    Ok(RigAccessor { json, bytes: accessor::floats(values.into_iter()) })
}

/// Point or line primitive `primitive`, placed by `world`; `raw`: the document's JSON.
pub(super) fn read(
    primitive: &gltf::Primitive,
    raw: &Value,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    world: &DMat4,
) -> Result<OtherPrimitive, String> {
    checks::types(primitive)?;
    let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let positions: Vec<[f32; 3]> = match quantized::<3>(primitive, &Semantic::Positions, buffers)? {
        Some(values) => values,
        None => reader.read_positions().ok_or("POSITION cannot be read")?.collect(),
    };
    let n = positions.len();
    let linear = DMat3::from_mat4(*world);
    let normal_matrix = linear.inverse().transpose();
    let turn = |m: DMat3, v: [f32; 3]| (m * DVec3::from(v.map(f64::from))).normalize_or_zero().as_vec3().to_array();
    let mut attributes = Vec::new();
    for (semantic, accessor) in primitive.attributes() {
        let name = semantic.to_string();
        let carried = match &semantic {
            Semantic::Positions => {
                let placed = positions
                    .iter()
                    .map(|p| world.transform_point3(DVec3::from(p.map(f64::from))).as_vec3().to_array());
                floats(&name, placed.collect(), true)?
            }
            Semantic::Normals => {
                let values = quantized::<3>(primitive, &semantic, buffers)?
                    .or_else(|| reader.read_normals().map(|r| r.collect()))
                    .ok_or("NORMAL cannot be read")?;
                floats(&name, values.into_iter().map(|v| turn(normal_matrix, v)).collect(), false)?
            }
            Semantic::Tangents => {
                let values = quantized::<4>(primitive, &semantic, buffers)?
                    .or_else(|| reader.read_tangents().map(|r| r.collect()))
                    .ok_or("TANGENT cannot be read")?;
                let handedness = if linear.determinant() < 0.0 { -1.0 } else { 1.0 };
                let placed = values.into_iter().map(|t| {
                    let [x, y, z] = turn(linear, [t[0], t[1], t[2]]);
                    [x, y, z, t[3] * handedness]
                });
                floats(&name, placed.collect(), false)?
            }
            Semantic::TexCoords(set) => {
                let values = quantized::<2>(primitive, &semantic, buffers)?
                    .or_else(|| reader.read_tex_coords(*set).map(|r| r.into_f32().collect()))
                    .ok_or_else(|| format!("{name} cannot be read"))?;
                floats(&name, values, false)?
            }
            Semantic::Colors(set) => {
                let values = reader.read_colors(*set).ok_or_else(|| format!("{name} cannot be read"))?;
                floats(&name, values.into_rgba_f32().collect(), false)?
            }
            _ => packed(raw, document, buffers, accessor.index())?,
        };
        let count = carried.json["count"].as_u64().unwrap_or(0);
        if count != n as u64 {
            return Err(format!("{name} has {count} values for {n} positions"));
        }
        attributes.push((name, carried));
    }
    let indices = match primitive.indices() {
        Some(accessor) => {
            let values = reader.read_indices().ok_or("the indices cannot be read")?.into_u32();
            if let Some(bad) = values.into_iter().find(|&i| i as usize >= n) {
                return Err(format!("index {bad} is out of range ({n} vertices)"));
            }
            Some(packed(raw, document, buffers, accessor.index())?)
        }
        None => None,
    };
    Ok(OtherPrimitive {
        mode: primitive.mode().as_gl_enum(),
        material: primitive.material().index().map(|m| m as u32),
        attributes,
        indices,
    })
}
