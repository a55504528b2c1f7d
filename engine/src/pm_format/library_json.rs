//! The materials section of a `.pm` file: the materials, textures, samplers and images (and a
//! skinned asset's rig, and the point and line primitives carried beside the mesh) as JSON.

use super::header::Reader;
use crate::error::MeshError;
use crate::mesh::{Image, ImageSource, MaterialLibrary, NO_MATERIAL, OtherPrimitive, Rig, RigAccessor};
use crate::pm::PmAttributes;

/// The section's JSON text, keys in a fixed order (so the same library gives the same bytes).
pub(super) fn to_text(library: &MaterialLibrary) -> String {
    canonical(library_to_json(library)).to_string()
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

/// Reads the materials section into the attributes' values, checking their material numbers.
pub(super) fn read_library(r: &mut Reader, a: &mut PmAttributes) -> Result<(), MeshError> {
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
    if let Some(&m) = a.values.materials().into_iter().flatten().find(|&&m| m != NO_MATERIAL && m >= known) {
        return Err(r.error(format!("material {m} out of range ({known} materials)")));
    }
    a.values.library = Some(std::sync::Arc::new(library));
    Ok(())
}
