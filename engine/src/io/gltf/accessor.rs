//! Accessor data, both ways: integers (KHR_mesh_quantization, normalised types) read as floats,
//! floats and bounds packed for writing, and the checks both sides share.

/// `Err` naming the first of `values` (an attribute `what`'s, per vertex) that is not a finite
/// number.
pub(crate) fn finite<const N: usize>(what: &str, values: &[[f32; N]]) -> Result<(), String> {
    match values.iter().position(|v| v.iter().any(|c| !c.is_finite())) {
        Some(vertex) => Err(format!("{what} of vertex {vertex} is not a finite number")),
        None => Ok(()),
    }
}

/// A primitive's attribute `semantic` when it is stored as integers (KHR_mesh_quantization, and
/// texture coordinates in core glTF), converted to floats: normalised values to [0, 1] or [−1, 1]
/// as glTF defines them, others as they are. `None` when the primitive stores it as floats (or
/// not at all): the crate's reader reads those.
pub(crate) fn quantized<const N: usize>(
    primitive: &gltf::Primitive,
    semantic: &gltf::Semantic,
    buffers: &[Vec<u8>],
) -> Result<Option<Vec<[f32; N]>>, String> {
    use gltf::accessor::DataType;
    let Some(accessor) = primitive.get(semantic) else { return Ok(None) };
    let kind = accessor.data_type();
    if kind == DataType::F32 {
        return Ok(None);
    }
    let name = semantic.to_string();
    if accessor.dimensions().multiplicity() != N {
        return Err(format!("{name} has {} components, not {N}", accessor.dimensions().multiplicity()));
    }
    if accessor.sparse().is_some() {
        return Err(format!("{name} is a sparse quantized accessor, which meshlod does not read"));
    }
    let width = kind.size();
    let normalized = accessor.normalized();
    // One component: its integer, scaled as glTF's normalised types are.
    let value = |b: &[u8]| -> f32 {
        match kind {
            DataType::I8 => {
                let x = b[0] as i8 as f32;
                if normalized { (x / 127.0).max(-1.0) } else { x }
            }
            DataType::U8 => {
                let x = b[0] as f32;
                if normalized { x / 255.0 } else { x }
            }
            DataType::I16 => {
                let x = i16::from_le_bytes([b[0], b[1]]) as f32;
                if normalized { (x / 32767.0).max(-1.0) } else { x }
            }
            DataType::U16 => {
                let x = u16::from_le_bytes([b[0], b[1]]) as f32;
                if normalized { x / 65535.0 } else { x }
            }
            DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            DataType::F32 => unreachable!("floats are read by the crate"),
        }
    };
    let count = accessor.count();
    let Some(view) = accessor.view() else { return Ok(Some(vec![[0.0; N]; count])) };
    // In range: `super::checks::accessor` checked every element against its view.
    let stride = view.stride().unwrap_or(accessor.size());
    let data = &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
    Ok(Some(
        (0..count)
            .map(|i| {
                let at = accessor.offset() + i * stride;
                std::array::from_fn(|k| value(&data[at + k * width..]))
            })
            .collect(),
    ))
}

/// Any accessor's elements as floats, whatever its component type: floats through the crate's
/// reader (sparse ones too), integers as [`quantized`] converts them. `Err` when it does not have
/// `N` components.
pub(crate) fn any_floats<const N: usize>(
    primitive: &gltf::Primitive,
    semantic: &gltf::Semantic,
    buffers: &[Vec<u8>],
) -> Result<Option<Vec<[f32; N]>>, String> {
    let Some(accessor) = primitive.get(semantic) else { return Ok(None) };
    if let Some(values) = quantized::<N>(primitive, semantic, buffers)? {
        return Ok(Some(values));
    }
    if accessor.dimensions().multiplicity() != N {
        return Err(format!(
            "{} has {} components, not {N}",
            semantic.to_string(),
            accessor.dimensions().multiplicity()
        ));
    }
    use gltf::accessor::Iter;
    let data = |b: gltf::Buffer| buffers.get(b.index()).map(Vec::as_slice);
    let flat: Option<Vec<f32>> = match N {
        1 => Iter::<f32>::new(accessor, data).map(|i| i.collect()),
        2 => Iter::<[f32; 2]>::new(accessor, data).map(|i| i.flatten().collect()),
        3 => Iter::<[f32; 3]>::new(accessor, data).map(|i| i.flatten().collect()),
        4 => Iter::<[f32; 4]>::new(accessor, data).map(|i| i.flatten().collect()),
        _ => None,
    };
    let flat = flat.ok_or_else(|| format!("{} cannot be read", semantic.to_string()))?;
    Ok(Some(flat.chunks_exact(N).map(|c| std::array::from_fn(|k| c[k])).collect()))
}

/// `Err` unless attribute `what` has one value (`got`) for each of the `n` positions.
pub(crate) fn same_count(what: &str, got: usize, n: usize) -> Result<(), String> {
    if got == n { Ok(()) } else { Err(format!("{what} has {got} values for {n} positions")) }
}

/// Little-endian bytes of `values`, one element after another.
pub(crate) fn floats<const N: usize>(values: impl Iterator<Item = [f32; N]>) -> Vec<u8> {
    values.flat_map(|v| v.into_iter().flat_map(f32::to_le_bytes)).collect()
}

/// The per-component minimum and maximum of `values` (infinities when there are none).
pub(crate) fn bounds<const N: usize>(values: &[[f32; N]]) -> ([f32; N], [f32; N]) {
    let (mut min, mut max) = ([f32::INFINITY; N], [f32::NEG_INFINITY; N]);
    for v in values {
        for k in 0..N {
            min[k] = min[k].min(v[k]);
            max[k] = max[k].max(v[k]);
        }
    }
    (min, max)
}
