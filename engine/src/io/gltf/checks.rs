//! The glTF reader's checks of a document before the `gltf` crate reads it: the crate's readers
//! and parts of its validation index and match on what a document says without checking it (an
//! accessor index out of range, indices stored as floats, weights as ints), and a panic inside
//! them is no way to refuse a file. Each check names the element it refuses.

use crate::library::unsigned_le;

/// Every accessor and material a mesh primitive names exists: `Err((element, reason))` naming
/// the first that does not.
pub(super) fn primitive_references(root: &gltf::json::Root) -> Result<(), (String, String)> {
    let accessors = root.accessors.len();
    let accessor = |at: String, index: usize| {
        if index < accessors {
            Ok(())
        } else {
            Err((at, format!("refers to accessor {index}, but the document has {accessors}")))
        }
    };
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let at = format!("mesh {m} primitive {p}");
            for (semantic, index) in &primitive.attributes {
                let name = match semantic {
                    gltf::json::validation::Checked::Valid(s) => s.to_string(),
                    gltf::json::validation::Checked::Invalid => "of an unknown name".to_string(),
                };
                accessor(format!("{at} attribute {name}"), index.value())?;
            }
            if let Some(index) = &primitive.indices {
                accessor(format!("{at} indices"), index.value())?;
            }
            for (t, target) in primitive.targets.iter().flatten().enumerate() {
                for (name, index) in
                    [("POSITION", &target.positions), ("NORMAL", &target.normals), ("TANGENT", &target.tangents)]
                {
                    if let Some(index) = index {
                        accessor(format!("{at} morph target {t} {name}"), index.value())?;
                    }
                }
            }
            if let Some(material) = &primitive.material
                && material.value() >= root.materials.len()
            {
                let count = root.materials.len();
                return Err((at, format!("refers to material {}, but the document has {count}", material.value())));
            }
        }
    }
    Ok(())
}

/// Checks that an accessor has elements (glTF requires one at least; the crate's reader counts
/// back from the last) and that they (and its sparse parts) lie inside their buffer views, whose
/// ranges in `buffers` are checked already; and that its sparse indices name its elements in
/// increasing order, as glTF requires (the crate's reader skips one out of range unsaid).
pub(super) fn accessor(accessor: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<(), String> {
    let element = accessor.size();
    let count = accessor.count();
    if count == 0 {
        return Err("has a count of 0: glTF requires at least one element".into());
    }
    if let Some(view) = accessor.view() {
        let stride = view.stride().unwrap_or(element);
        if stride < element {
            return Err(format!("stride {stride} is shorter than its {element}-byte elements"));
        }
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(accessor.offset()))
            .and_then(|x| x.checked_add(element));
        if end.is_none_or(|end| end > view.length()) {
            return Err(format!(
                "{count} elements of {element} bytes (stride {stride}) overrun its bufferView of {} bytes",
                view.length()
            ));
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let index_size = match sparse.indices().index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let indices_start = sparse.indices().offset();
        let indices_end = n.checked_mul(index_size).and_then(|x| x.checked_add(indices_start));
        let view = sparse.indices().view();
        let Some(indices_end) = indices_end.filter(|&end| end <= view.length()) else {
            return Err("its sparse indices overrun their bufferView".into());
        };
        let values_end = n.checked_mul(element).and_then(|x| x.checked_add(sparse.values().offset()));
        if values_end.is_none_or(|end| end > sparse.values().view().length()) {
            return Err("its sparse values overrun their bufferView".into());
        }
        let bytes = buffers
            .get(view.buffer().index())
            .and_then(|b| b.get(view.offset() + indices_start..view.offset() + indices_end))
            .ok_or("its sparse indices lie outside their buffer")?;
        let mut previous = None;
        for (k, b) in bytes.chunks_exact(index_size).enumerate() {
            let index = unsigned_le(b);
            if index >= count {
                return Err(format!("sparse index {k} is {index}, but the accessor has {count} elements"));
            }
            if previous.is_some_and(|p| index <= p) {
                return Err(format!("sparse index {k} ({index}) does not follow the one before in increasing order"));
            }
            previous = Some(index);
        }
    }
    Ok(())
}

/// The element types glTF allows for the indices and for each attribute meshlod reads (the
/// `gltf` crate's readers assume them): `Err` naming the first accessor that holds another.
/// Integer positions, normals, tangents and texture coordinates are read by `quantized` (in `gltf.rs`), which
/// checks their component counts.
pub(super) fn types(primitive: &gltf::Primitive) -> Result<(), String> {
    use gltf::Semantic;
    use gltf::accessor::{DataType, Dimensions};
    let holds = |accessor: &gltf::Accessor, what: &str, kinds: &[DataType], dims: &[Dimensions], allowed: &str| {
        if kinds.contains(&accessor.data_type()) && dims.contains(&accessor.dimensions()) {
            Ok(())
        } else {
            Err(format!(
                "{what} (accessor {}) holds {:?} {:?}: glTF allows {allowed}",
                accessor.index(),
                accessor.dimensions(),
                accessor.data_type()
            ))
        }
    };
    let (float, small) = ([DataType::F32], [DataType::F32, DataType::U8, DataType::U16]);
    if let Some(accessor) = primitive.indices() {
        let kinds = [DataType::U8, DataType::U16, DataType::U32];
        holds(&accessor, "indices", &kinds, &[Dimensions::Scalar], "unsigned byte, short or int scalars")?;
    }
    for (semantic, accessor) in primitive.attributes() {
        let name = semantic.to_string();
        match semantic {
            Semantic::Positions | Semantic::Normals if accessor.data_type() == DataType::F32 => {
                holds(&accessor, &name, &float, &[Dimensions::Vec3], "3 floats")?;
            }
            Semantic::Tangents if accessor.data_type() == DataType::F32 => {
                holds(&accessor, &name, &float, &[Dimensions::Vec4], "4 floats")?;
            }
            Semantic::TexCoords(_) if accessor.data_type() == DataType::F32 => {
                holds(&accessor, &name, &float, &[Dimensions::Vec2], "2 floats")?;
            }
            Semantic::Colors(_) => {
                let dims = [Dimensions::Vec3, Dimensions::Vec4];
                holds(&accessor, &name, &small, &dims, "3 or 4 floats, unsigned bytes or shorts")?;
            }
            Semantic::Joints(_) => {
                let kinds = [DataType::U8, DataType::U16];
                holds(&accessor, &name, &kinds, &[Dimensions::Vec4], "4 unsigned bytes or shorts")?;
            }
            Semantic::Weights(_) => {
                holds(&accessor, &name, &small, &[Dimensions::Vec4], "4 floats, unsigned bytes or shorts")?;
            }
            _ => {}
        }
    }
    Ok(())
}

/// A GLB container's header: the length it declares covers the 12-byte header and no more than
/// the bytes there are (the crate subtracts the header from it unchecked).
pub(super) fn glb_header(bytes: &[u8]) -> Result<(), String> {
    let Some(field) = bytes.get(8..12) else {
        return Err(format!("{} bytes, shorter than the 12-byte header", bytes.len()));
    };
    let declared = u32::from_le_bytes([field[0], field[1], field[2], field[3]]) as usize;
    if declared < 12 || declared > bytes.len() {
        return Err(format!("declares {declared} bytes, but the file holds {} (and the header 12)", bytes.len()));
    }
    Ok(())
}
