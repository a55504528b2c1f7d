//! The attribute values of a progressive mesh as SimplifyStream sends them ([`proto::CornerValues`]):
//! a value table that grows message by message, each value sent with the first corner that takes
//! it, and every corner as its value's number. The server writes them from the engine's
//! [`PmAttributes`]; a client reassembling the stream reads them back into one.

use std::collections::HashMap;

use crate::error::JobError;
use meshlod_engine::mesh::{CornerAttributes, MaterialLibrary, NO_MATERIAL, Rig};
use meshlod_engine::pm::{PmAttributes, ProgressiveMesh, SplitAttributes};

use crate::convert::progressive_from_proto;
use crate::proto;

/// Most material numbers a stream may name.
const MAX_MATERIALS: usize = 1 << 16;

/// Rebuilds a streamed progressive mesh (a client reassembling SimplifyStream): the base, its
/// corners' values when the input had attributes, and the splits with theirs; every split and value
/// checked.
pub fn progressive_from_stream(
    base: &proto::Mesh,
    base_corners: Option<&proto::CornerValues>,
    splits: &[proto::VertexSplit],
) -> Result<ProgressiveMesh, JobError> {
    let pm = progressive_from_proto(base, splits)?;
    let Some(base_corners) = base_corners else { return Ok(pm) };
    let values: Vec<proto::CornerValues> = splits
        .iter()
        .enumerate()
        .map(|(j, s)| s.corners.clone().ok_or_else(|| invalid(format!("splits[{j}].corners"), "missing")))
        .collect::<Result<_, JobError>>()?;
    let attributes = values_from_stream(&pm, base_corners, &values)?;
    pm.with_attributes(attributes).map_err(|e| invalid("corners", e.to_string()))
}

/// The base's corners and each split's, in the order the stream sends them; `None` without
/// attributes.
pub fn stream_values(pm: &ProgressiveMesh) -> Option<(proto::CornerValues, Vec<proto::CornerValues>)> {
    let a = pm.attributes()?;
    // Texture coordinates with v up, as the contract has them: flipped once, not per message.
    let flipped = (a.values.uvs_with_origin(false), a.values.uvs1_with_origin(false));
    let mut number: HashMap<u32, u32> = HashMap::new();
    // The message's corners renumbered in order of first use, the values first used here added.
    let mut message = |corners: &[u32], moved: &[(u32, u32)]| -> proto::CornerValues {
        let mut added = Vec::new();
        let mut id = |k: u32| {
            let next = number.len() as u32;
            *number.entry(k).or_insert_with(|| {
                added.push(k as usize);
                next
            })
        };
        let corners = corners.iter().map(|&k| id(k)).collect();
        let moved = moved.iter().flat_map(|&(face, k)| [face, id(k)]).collect();
        proto::CornerValues { added: Some(values_to_proto(&a.values, &flipped, &added)), corners, moved }
    };
    let base: Vec<u32> = a.base.iter().flatten().copied().collect();
    let base = message(&base, &[]);
    let splits = pm
        .splits()
        .iter()
        .zip(&a.splits)
        .map(|(s, sa)| {
            let corners: Vec<u32> = sa.new_faces[..s.added_faces()].iter().flatten().copied().collect();
            message(&corners, &sa.moved)
        })
        .collect();
    Some((base, splits))
}

/// Texture coordinates and second texture coordinates with v up.
type Flipped<'a> = (Option<std::borrow::Cow<'a, [[f32; 2]]>>, Option<std::borrow::Cow<'a, [[f32; 2]]>>);

/// The values `picked` (indices into `values`), as the contract has them (texture coordinates from
/// `flipped`, with v up).
fn values_to_proto(values: &CornerAttributes, flipped: &Flipped<'_>, picked: &[usize]) -> proto::AttributeValues {
    fn flat<T: Copy, const N: usize>(values: Option<&Vec<[T; N]>>, picked: &[usize]) -> Vec<T> {
        values.map_or_else(Vec::new, |v| picked.iter().flat_map(|&k| v[k]).collect())
    }
    let flip = |v: &Option<std::borrow::Cow<'_, [[f32; 2]]>>| {
        v.as_ref().map_or_else(Vec::new, |v| picked.iter().flat_map(|&k| v[k]).collect())
    };
    proto::AttributeValues {
        normals: flat(values.normals(), picked),
        uvs: flip(&flipped.0),
        colors: flat(values.colors(), picked),
        materials: values.materials().map_or_else(Vec::new, |m| picked.iter().map(|&k| m[k]).collect()),
        tangents: flat(values.tangents(), picked),
        uvs1: flip(&flipped.1),
        joints: values.joints().map_or_else(Vec::new, |j| picked.iter().flat_map(|&k| j[k].map(u32::from)).collect()),
        weights: flat(values.weights(), picked),
    }
}

/// Reads the stream's values back: the base's corners (`base`, 3 per base face) and each split's,
/// into the engine's form for [`ProgressiveMesh::with_attributes`]. Errors name the message.
pub fn values_from_stream(
    pm: &ProgressiveMesh,
    base: &proto::CornerValues,
    splits: &[proto::CornerValues],
) -> Result<PmAttributes, JobError> {
    if splits.len() != pm.levels() {
        return Err(invalid("splits", format!("{} carry values for {} splits", splits.len(), pm.levels())));
    }
    let empty = proto::AttributeValues::default();
    let first = base.added.as_ref().unwrap_or(&empty);
    fn present<T, const N: usize>(v: &[f32]) -> Option<Vec<[T; N]>> {
        (!v.is_empty()).then(Vec::new)
    }
    let mut values = CornerAttributes::default();
    values.set_normals(present(&first.normals));
    values.set_uvs(present(&first.uvs));
    values.set_colors(present(&first.colors));
    values.set_materials((!first.materials.is_empty()).then(Vec::new));
    values.set_tangents(present(&first.tangents));
    values.set_uvs1(present(&first.uvs1));
    values.set_joints((!first.joints.is_empty()).then(Vec::new));
    values.set_weights(present(&first.weights));
    let read = |values: &mut CornerAttributes, message: &proto::CornerValues, at: &str| -> Result<(), JobError> {
        let added = message.added.as_ref().unwrap_or(&empty);
        append(values, added).map_err(|reason| invalid(format!("{at}.added"), reason))
    };
    read(&mut values, base, "base_corners")?;
    let index = |k: u32, known: u32, at: &str| -> Result<u32, JobError> {
        if k < known { Ok(k) } else { Err(invalid(at, format!("value {k} is not in the table ({known} values)"))) }
    };
    let faces = pm.base().face_count();
    if base.corners.len() != 3 * faces || !base.moved.is_empty() {
        return Err(invalid("base_corners", format!("{} corners for {faces} base faces", base.corners.len())));
    }
    let known = values.value_count() as u32;
    let base_corners = base
        .corners
        .chunks_exact(3)
        .map(|c| {
            Ok([
                index(c[0], known, "base_corners")?,
                index(c[1], known, "base_corners")?,
                index(c[2], known, "base_corners")?,
            ])
        })
        .collect::<Result<Vec<[u32; 3]>, JobError>>()?;
    let mut out = Vec::with_capacity(splits.len());
    for (j, (s, message)) in pm.splits().iter().zip(splits).enumerate() {
        let at = format!("splits[{j}].corners");
        read(&mut values, message, &at)?;
        let known = values.value_count() as u32;
        let added = s.added_faces();
        if message.corners.len() != 3 * added || !message.moved.len().is_multiple_of(2) {
            return Err(invalid(&at, format!("{} corners for {added} added faces", message.corners.len())));
        }
        let mut new_faces = [[0u32; 3]; 2];
        for (slot, c) in message.corners.chunks_exact(3).enumerate() {
            new_faces[slot] = [index(c[0], known, &at)?, index(c[1], known, &at)?, index(c[2], known, &at)?];
        }
        let moved = message
            .moved
            .chunks_exact(2)
            .map(|m| Ok((m[0], index(m[1], known, &at)?)))
            .collect::<Result<_, JobError>>()?;
        out.push(SplitAttributes { new_faces, moved });
    }
    // The contract's texture coordinates have v up.
    values.uv_origin_top = false;
    // Material and joint numbers are the input's (the stream does not carry the materials or the
    // skeleton themselves): as many default materials, and a skin of as many bare joints, stand for
    // them, so that every level is a valid mesh.
    let materials =
        values.materials().into_iter().flatten().filter(|&&m| m != NO_MATERIAL).map(|&m| m as usize + 1).max();
    let joints = values.joints().into_iter().flatten().flatten().map(|&j| j as usize + 1).max();
    if materials.unwrap_or(0) > MAX_MATERIALS {
        return Err(invalid("base_corners.added.materials", format!("more than {MAX_MATERIALS} materials")));
    }
    if values.materials().is_some() || values.joints().is_some() {
        let rig = values.joints().is_some().then(|| {
            let count = joints.unwrap_or(1);
            let mut nodes = vec![serde_json::json!({}); count];
            nodes.push(serde_json::json!({ "skin": 0 }));
            Rig {
                nodes,
                mesh_node: count,
                skins: vec![serde_json::json!({ "joints": (0..count).collect::<Vec<_>>() })],
                ..Default::default()
            }
        });
        let library = MaterialLibrary {
            materials: vec![serde_json::json!({}); materials.unwrap_or(0)],
            rig,
            ..Default::default()
        };
        values.library = Some(std::sync::Arc::new(library));
    }
    Ok(PmAttributes { values, base: base_corners, splits: out })
}

/// Appends `added`'s values to `values`, checking that every array the table has holds the same
/// number of values and no other array is sent.
fn append(values: &mut CornerAttributes, added: &proto::AttributeValues) -> Result<(), String> {
    fn take<const N: usize>(to: Option<&mut Vec<[f32; N]>>, from: &[f32], name: &str) -> Result<usize, String> {
        match to {
            None if from.is_empty() => Ok(usize::MAX),
            None => Err(format!("{name}: the base sent none")),
            Some(v) => {
                if !from.len().is_multiple_of(N) || from.iter().any(|x| !x.is_finite()) {
                    return Err(format!("{name}: {} values, not finite groups of {N}", from.len()));
                }
                v.extend(from.chunks_exact(N).map(|c| <[f32; N]>::try_from(c).expect("N values")));
                Ok(from.len() / N)
            }
        }
    }
    let mut counts = vec![
        take(values.normals_mut(), &added.normals, "normals")?,
        take(values.uvs_mut(), &added.uvs, "uvs")?,
        take(values.colors_mut(), &added.colors, "colors")?,
        take(values.tangents_mut(), &added.tangents, "tangents")?,
        take(values.uvs1_mut(), &added.uvs1, "uvs1")?,
        take(values.weights_mut(), &added.weights, "weights")?,
    ];
    counts.push(match values.materials_mut() {
        None if added.materials.is_empty() => usize::MAX,
        None => return Err("materials: the base sent none".into()),
        Some(m) => {
            m.extend(added.materials.iter().map(|&x| if x == u32::MAX { NO_MATERIAL } else { x }));
            added.materials.len()
        }
    });
    counts.push(match values.joints_mut() {
        None if added.joints.is_empty() => usize::MAX,
        None => return Err("joints: the base sent none".into()),
        Some(j) => {
            if !added.joints.len().is_multiple_of(4) || added.joints.iter().any(|&x| x > u32::from(u16::MAX)) {
                return Err("joints: not groups of 4 numbers below 65536".into());
            }
            j.extend(added.joints.chunks_exact(4).map(|c| [c[0] as u16, c[1] as u16, c[2] as u16, c[3] as u16]));
            added.joints.len() / 4
        }
    });
    counts.retain(|&c| c != usize::MAX);
    if counts.windows(2).any(|w| w[0] != w[1]) {
        return Err(format!("the arrays hold different numbers of values: {counts:?}"));
    }
    Ok(())
}

fn invalid(field: impl AsRef<str>, reason: impl std::fmt::Display) -> JobError {
    JobError::invalid(field.as_ref(), reason.to_string())
}
