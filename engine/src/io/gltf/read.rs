//! glTF 2.0 reader (`.gltf` with embedded or external buffers, and `.glb`), through the `gltf`
//! crate's document model.
//!
//! Every triangle primitive (TRIANGLES, and TRIANGLE_STRIP / TRIANGLE_FAN unrolled) of every mesh
//! instance in the default scene (else the first, else every mesh once) is read, placed by its
//! node's world transform (normals by the inverse transpose; mirrored nodes keep their faces
//! counter-clockwise) and merged into one mesh. Kept per corner: NORMAL and TANGENT when every
//! primitive has them, TEXCOORD_0, TEXCOORD_1 and COLOR_0 when some primitive has them (the others
//! given the values glTF draws them with: `merge`), JOINTS_0 / WEIGHTS_0 of a skinned asset, and
//! further texture coordinate and colour sets and application-specific attributes as channels
//! (`super::channels`).
//! What is left out is said. glTF splits a vertex wherever its attributes differ (seams,
//! hard edges) and exporters often between primitives too: the cut is joined again
//! ([`Mesh::join_cut_seams`]), so the surface is one piece with seams, not cut open.
//! POINTS and LINES primitives are not surface: carried as they were (`super::passthrough`).
//!
//! Untrusted input: every accessor and buffer view is checked against the bytes that back it
//! before it is read, counts against the limits before anything is allocated from them, and
//! compressed extensions (Draco, meshopt) are refused by name. Buffers outside the file are read
//! only when the caller gives a folder to resolve them against (a file on disk), never for bytes
//! that came over the network.

use std::path::Path;

use base64::Engine as _;
use glam::{DMat3, DMat4, DVec3};
use gltf::mesh::Mode;

use super::accessor::{finite, quantized, same_count};
use super::channels::{MAX_EXTRA_CHANNELS, extra_channel, extra_channels, merge_extra};
use super::checks;
use crate::error::MeshError;
use crate::io::options::ReadLimits;
use crate::mesh::{Channel, CornerAttributes, Image, ImageSource, MaterialLibrary, Mesh, NO_MATERIAL, Rig};

/// Extensions whose data meshlod cannot decode; a file that requires one is refused by name.
const UNSUPPORTED: [&str; 2] = ["KHR_draco_mesh_compression", "EXT_meshopt_compression"];

/// Quantized vertex attributes (positions, normals, tangents and texture coordinates as 8- or 16-bit
/// integers, normalised or not): read, and written back as floats.
const QUANTIZATION: &str = "KHR_mesh_quantization";

/// Whether the bytes are a GLB container or glTF JSON.
pub(crate) fn is_gltf(bytes: &[u8]) -> bool {
    if bytes.starts_with(b"glTF") {
        return true;
    }
    let head = &bytes[..bytes.len().min(4096)];
    head.trim_ascii_start().starts_with(b"{") && head.windows(7).any(|w| w == b"\"asset\"")
}

/// One primitive's data, read and placed.
struct Part {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    tangents: Option<Vec<[f32; 4]>>,
    uvs: Option<Vec<[f32; 2]>>,
    uvs1: Option<Vec<[f32; 2]>>,
    colors: Option<Vec<[f32; 4]>>,
    joints: Option<Vec<[u16; 4]>>,
    weights: Option<Vec<[f32; 4]>>,
    /// Vertices whose weights were scaled to sum to 1.
    mended: usize,
    material: u32,
    /// The attributes beyond those above ([`extra_channels`]), per corner.
    extra: Vec<Channel>,
}

/// Reads glTF or GLB bytes. `folder`: where relative buffer URIs are resolved (the file's folder);
/// `None` refuses buffers outside the bytes.
pub fn read_gltf(bytes: &[u8], path: &Path, folder: Option<&Path>, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    // The `gltf` crate panics on some malformed containers and accessors (found by
    // engine/tests/fuzz.rs) despite the checks below: a panic there is a malformed file, said so,
    // never a crash of the caller.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(bytes, path, folder, limits))).unwrap_or_else(|_| {
        Err(MeshError::parse(path, "document", "malformed glTF: the glTF parser could not read it"))
    })
}

fn read(bytes: &[u8], path: &Path, folder: Option<&Path>, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let err = |at: &str, reason: String| MeshError::parse(path, at, reason);
    // The extensions first, from the JSON alone (inside the GLB container for .glb), so that a
    // compressed file is refused by name rather than by whatever its data makes fail.
    let json: &[u8] = if bytes.starts_with(b"glTF") {
        checks::glb_header(bytes).map_err(|reason| err("GLB container", reason))?;
        &gltf::Glb::from_slice(bytes).map_err(|e| err("GLB container", e.to_string()))?.json
    } else {
        bytes
    };
    let root = gltf::json::Root::from_slice(json).map_err(|e| err("document", e.to_string()))?;
    for name in root.extensions_required.iter().chain(&root.extensions_used) {
        if UNSUPPORTED.contains(&name.as_str()) {
            return Err(err("document", format!("uses {name}, which meshlod does not decode: export without it")));
        }
    }
    // The references of the meshes' primitives, which the crate's validation reads without
    // checking them (an accessor index out of range there panics inside the crate): named here.
    checks::primitive_references(&root).map_err(|(at, reason)| err(&at, reason))?;
    // The crate's validation (every index in the document refers to something that exists). It
    // can panic on other out-of-range indices: that is reported as the invalid document it is.
    // KHR_mesh_quantization is read here (the crate refuses a document that requires it): taken
    // out of the document's lists before the crate validates the rest.
    let validated = |bytes: &[u8]| -> Result<gltf::Gltf, gltf::Error> {
        let mut gltf = gltf::Gltf::from_slice_without_validation(bytes)?;
        let mut root = gltf.document.clone().into_json();
        root.extensions_required.retain(|e| e != QUANTIZATION);
        root.extensions_used.retain(|e| e != QUANTIZATION);
        gltf.document = validated_document(root)?;
        Ok(gltf)
    };
    let gltf = std::panic::catch_unwind(|| validated(bytes))
        .map_err(|_| err("document", "refers to an element that does not exist".into()))?
        .map_err(|e| err("document", e.to_string()))?;
    let document = &gltf.document;

    let buffers = load_buffers(document, gltf.blob.as_ref(), folder, path)?;
    let mut instances = mesh_instances(document, path)?;
    // A skinned asset keeps its skeleton when every instance is drawn with one skin (a character):
    // its vertices are then in the skin's bind space, where glTF places them (the node's own
    // transform is ignored), and carry their joints and weights.
    let skin_of = |node: usize| document.nodes().nth(node).and_then(|n| n.skin()).map(|s| s.index());
    let rigged = match instances.first() {
        Some(&(_, _, node)) => {
            skin_of(node).filter(|&s| instances.iter().all(|&(_, _, n)| skin_of(n) == Some(s))).map(|_| node)
        }
        None => None,
    };
    let rig = match rigged {
        Some(node) => Some(rig(&raw_json(json).map_err(|r| err("document", r))?, document, &buffers, node)),
        None => None,
    };
    let (rig, rig_refused) = match rig {
        Some(Ok(rig)) => (Some(rig), None),
        Some(Err(reason)) => (None, Some(reason)),
        None => (None, None),
    };
    if rig.is_some() {
        instances.iter_mut().for_each(|i| i.1 = DMat4::IDENTITY);
    }
    let joint_count = rig.as_ref().map_or(0, crate::mesh::Rig::joint_count);
    let library =
        library(json, document, &buffers, folder, rig, rig_refused).map_err(|(at, reason)| err(&at, reason))?;

    check_counts(&instances, limits, path)?;

    let mut parts = Vec::new();
    for (mesh, world, _) in &instances {
        for primitive in mesh.primitives().filter(|p| is_surface(p.mode()) && drawn(p)) {
            limits.check_cancel()?;
            let at = format!("mesh {} primitive {}", mesh.index(), primitive.index());
            // The checks above make the reads in range; a panic in the crate would still be a bug
            // of this reader, reported as one rather than taking the caller down.
            let read = || read_primitive(&primitive, &buffers, world, joint_count);
            let part = std::panic::catch_unwind(std::panic::AssertUnwindSafe(read))
                .map_err(|_| err(&at, "could not be read (malformed accessor data)".into()))?
                .map_err(|reason| err(&at, reason))?;
            parts.push(part);
        }
    }
    let library = carry_other_primitives(&instances, library, json, document, &buffers, path)?;
    merge(parts, library, path)
}

/// The document's buffers (the GLB's binary chunk `blob`, data URIs, or files in `folder`), each
/// checked to hold what it declares, and every buffer view and accessor checked to lie within them.
fn load_buffers(
    document: &gltf::Document,
    blob: Option<&Vec<u8>>,
    folder: Option<&Path>,
    path: &Path,
) -> Result<Vec<Vec<u8>>, MeshError> {
    let err = |at: &str, reason: String| MeshError::parse(path, at, reason);
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in document.buffers() {
        let at = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                blob.cloned().ok_or_else(|| err(&at, "refers to the GLB binary chunk, which is missing".into()))?
            }
            gltf::buffer::Source::Uri(uri) => {
                if let Some(decoded) = data_uri(uri) {
                    decoded.map_err(|reason| err(&at, reason))?.1
                } else {
                    let folder = folder.ok_or_else(|| {
                        err(
                            &at,
                            format!(
                                "refers to the file '{uri}', which cannot be read here: send a GLB or embed the buffer"
                            ),
                        )
                    })?;
                    let file = folder.join(uri.replace("%20", " "));
                    crate::io::files::read_referenced(&file)
                        .map_err(|e| err(&at, format!("'{}': {e}", file.display())))?
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(err(&at, format!("declares {} bytes but holds {}", buffer.length(), data.len())));
        }
        buffers.push(data);
    }
    for view in document.views() {
        let (start, length) = (view.offset(), view.length());
        let held = buffers[view.buffer().index()].len();
        if start.checked_add(length).is_none_or(|end| end > held) {
            return Err(err(
                &format!("bufferView {}", view.index()),
                format!("bytes {start}..{} lie outside its buffer of {held} bytes", start.saturating_add(length)),
            ));
        }
    }
    for accessor in document.accessors() {
        checks::accessor(&accessor, &buffers)
            .map_err(|reason| err(&format!("accessor {}", accessor.index()), reason))?;
    }
    Ok(buffers)
}

/// Mesh instances with their world transforms and the node that draws them: the default scene's
/// (else the first scene's), or every mesh once without a scene.
#[allow(clippy::type_complexity)]
fn mesh_instances<'d>(
    document: &'d gltf::Document,
    path: &Path,
) -> Result<Vec<(gltf::Mesh<'d>, DMat4, usize)>, MeshError> {
    let err = |at: &str, reason: String| MeshError::parse(path, at, reason);
    let mut instances: Vec<(gltf::Mesh, DMat4, usize)> = Vec::new();
    let scene = document.default_scene().or_else(|| document.scenes().next());
    match scene {
        Some(scene) => {
            let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
            let mut visited = 0usize;
            while let Some((node, parent)) = stack.pop() {
                visited += 1;
                if visited > document.nodes().len() * 4 + 16 {
                    return Err(err("nodes", "the node hierarchy has a cycle".into()));
                }
                let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
                let world = parent * local;
                if let Some(mesh) = node.mesh() {
                    instances.push((mesh, world, node.index()));
                }
                stack.extend(node.children().map(|c| (c, world)));
            }
        }
        None => instances.extend(document.meshes().map(|m| (m, DMat4::IDENTITY, usize::MAX))),
    }
    Ok(instances)
}

/// The instances' vertex and face counts against the limits, before any data is read.
fn check_counts(instances: &[(gltf::Mesh, DMat4, usize)], limits: &ReadLimits, path: &Path) -> Result<(), MeshError> {
    let (mut vertices, mut corners) = (0u64, 0u64);
    for (mesh, _, _) in instances {
        for primitive in mesh.primitives() {
            let Some(positions) = primitive.get(&gltf::Semantic::Positions) else { continue };
            vertices += positions.count() as u64;
            if is_surface(primitive.mode()) {
                corners += primitive.indices().map_or(positions.count(), |a| a.count()) as u64;
            }
        }
    }
    limits.check_vertices(vertices, path)?;
    limits.check_faces(corners / 3, path)?;
    Ok(())
}

/// The instances' point and line primitives, carried as they were in `library`; not beside a
/// skin, whose node would move them with joints they do not have (said instead).
fn carry_other_primitives(
    instances: &[(gltf::Mesh, DMat4, usize)],
    mut library: MaterialLibrary,
    json: &[u8],
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<MaterialLibrary, MeshError> {
    let err = |at: &str, reason: String| MeshError::parse(path, at, reason);
    // (The document's JSON, parsed again only for a primitive to carry.)
    let mut raw = None;
    for (mesh, world, _) in instances {
        for primitive in mesh.primitives().filter(|p| !is_surface(p.mode()) && drawn(p)) {
            let at = format!("mesh {} primitive {}", mesh.index(), primitive.index());
            let beside_a_skin = "point and line primitives (beside a skin)";
            if library.rig.is_some() {
                if !library.not_carried.iter().any(|n| n == beside_a_skin) {
                    library.not_carried.push(beside_a_skin.into());
                }
                continue;
            }
            let raw = match &mut raw {
                Some(raw) => raw,
                None => raw.insert(raw_json(json).map_err(|reason| err("document", reason))?),
            };
            let read = || super::passthrough::read(&primitive, raw, document, buffers, world);
            let other = std::panic::catch_unwind(std::panic::AssertUnwindSafe(read))
                .map_err(|_| err(&at, "could not be read (malformed accessor data)".into()))?
                .map_err(|reason| err(&at, reason))?;
            library.other_primitives.push(other);
        }
    }
    Ok(library)
}

/// The document's materials, textures, samplers and images, for a glTF written from the mesh.
/// Image bytes held in a buffer are copied; external ones are found next to the file (read when
/// written), or kept as their URI when the bytes came without a folder.
fn library(
    json: &[u8],
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    folder: Option<&Path>,
    rig: Option<Rig>,
    rig_refused: Option<String>,
) -> Result<MaterialLibrary, (String, String)> {
    let raw = raw_json(json).map_err(|reason| ("document".to_string(), reason))?;
    let array = |key: &str| raw.get(key).and_then(|v| v.as_array()).cloned().unwrap_or_default();
    let mut images = Vec::new();
    for (image, mut json) in document.images().zip(array("images")) {
        let at = format!("image {}", image.index());
        let mime_type = json.get("mimeType").and_then(|m| m.as_str()).map(str::to_string);
        if let Some(object) = json.as_object_mut() {
            for key in ["uri", "bufferView", "mimeType"] {
                object.remove(key);
            }
        }
        let (source, mime_type) = match image.source() {
            gltf::image::Source::View { view, mime_type } => {
                let start = view.offset();
                let bytes = buffers[view.buffer().index()][start..start + view.length()].to_vec();
                (ImageSource::Bytes(bytes), Some(mime_type.to_string()))
            }
            gltf::image::Source::Uri { uri, .. } => {
                if let Some(decoded) = data_uri(uri) {
                    let (kind, bytes) = decoded.map_err(|reason| (at.clone(), reason))?;
                    (ImageSource::Bytes(bytes), Some(kind.to_string()).filter(|k| !k.is_empty()).or(mime_type))
                } else if let Some(folder) = folder {
                    (ImageSource::File(folder.join(uri.replace("%20", " "))), mime_type)
                } else {
                    (ImageSource::Uri(uri.to_string()), mime_type)
                }
            }
        };
        images.push(Image { json, source, mime_type });
    }
    let strings =
        |key: &str| -> Vec<String> { array(key).iter().filter_map(|v| v.as_str().map(str::to_string)).collect() };
    // The extensions that what is carried can use: those named inside materials, textures,
    // samplers and images (a light or a mesh-level extension is not carried).
    let (materials, textures, samplers) = (array("materials"), array("textures"), array("samplers"));
    let mut named = Vec::new();
    for value in materials.iter().chain(&textures).chain(&samplers).chain(images.iter().map(|i| &i.json)) {
        collect_extensions(value, &mut named);
    }
    let extensions_used: Vec<String> = strings("extensionsUsed").into_iter().filter(|e| named.contains(e)).collect();
    let extensions_required =
        strings("extensionsRequired").into_iter().filter(|e| extensions_used.contains(e)).collect();
    let mut not_carried = Vec::new();
    let mut note = |what: String| {
        if !not_carried.contains(&what) {
            not_carried.push(what);
        }
    };
    for primitive in document.meshes().flat_map(|m| m.primitives()) {
        primitive_notes(&primitive, rig.is_some(), &mut note);
    }
    if rig.is_none() && document.skins().next().is_some() {
        note(rig_refused.unwrap_or_else(|| "skins (the meshes are not all drawn with one skin)".into()));
    }
    if rig.is_none() && document.animations().next().is_some() {
        note("animations".into());
    }
    Ok(MaterialLibrary {
        materials,
        textures,
        samplers,
        images,
        extensions_used,
        extensions_required,
        not_carried,
        rig,
        other_primitives: Vec::new(),
        mended: Vec::new(),
    })
}

/// The document's JSON as a value.
/// Says (through `note`) what of `primitive` a mesh does not carry: its morph targets, the
/// attributes read neither as the engine's own nor as channels (joints and weights carried when
/// the asset is `skinned`), and that it draws nothing without POSITION.
fn primitive_notes(primitive: &gltf::Primitive, skinned: bool, note: &mut impl FnMut(String)) {
    if !drawn(primitive) {
        note("primitives without POSITION (drawn by nothing)".into());
    }
    if primitive.morph_targets().next().is_some() {
        note("morph targets".into());
    }
    let mut extras = 0;
    for (semantic, accessor) in primitive.attributes() {
        let name = semantic.to_string();
        let skin = matches!(name.as_str(), "JOINTS_0" | "WEIGHTS_0") && skinned;
        // The further attributes read as channels, the first MAX_EXTRA_CHANNELS of them.
        let carried = extra_channel(&semantic, &accessor).is_some() && {
            extras += 1;
            extras <= MAX_EXTRA_CHANNELS
        };
        let own = matches!(name.as_str(), "POSITION" | "NORMAL" | "TANGENT" | "TEXCOORD_0" | "TEXCOORD_1" | "COLOR_0");
        if !(skin || carried || own) {
            note(format!("{name} values"));
        }
    }
}

fn raw_json(json: &[u8]) -> Result<serde_json::Value, String> {
    serde_json::from_slice(json).map_err(|e| e.to_string())
}

/// The skeleton of a skinned asset drawn by node `mesh_node`: the nodes, scenes, skins and
/// animations, with the data of the accessors these read; `Err` names what cannot be carried.
fn rig(
    raw: &serde_json::Value,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    mesh_node: usize,
) -> Result<Rig, String> {
    let array = |key: &str| raw.get(key).and_then(|v| v.as_array()).cloned().unwrap_or_default();
    let mut accessors: Vec<crate::mesh::RigAccessor> = Vec::new();
    let mut carried: std::collections::HashMap<u64, usize> = std::collections::HashMap::new();
    // An accessor's data, packed, under a new number (the same accessor once).
    let mut carry = |value: &mut serde_json::Value| -> Result<(), String> {
        let Some(index) = value.as_u64() else { return Ok(()) };
        if let Some(&k) = carried.get(&index) {
            *value = k.into();
            return Ok(());
        }
        let packed = super::passthrough::packed(raw, document, buffers, index as usize)
            .map_err(|reason| format!("skins and animations ({reason})"))?;
        accessors.push(packed);
        carried.insert(index, accessors.len() - 1);
        *value = (accessors.len() - 1).into();
        Ok(())
    };
    let mut skins = array("skins");
    for skin in &mut skins {
        if let Some(matrices) = skin.get_mut("inverseBindMatrices") {
            carry(matrices)?;
        }
    }
    let mut animations = Vec::new();
    for mut animation in array("animations") {
        // Channels that drive morph target weights have nothing to drive: the targets are not
        // carried.
        if let Some(channels) = animation.get_mut("channels").and_then(|c| c.as_array_mut()) {
            channels.retain(|c| c["target"]["path"] != "weights");
            if channels.is_empty() {
                continue;
            }
        }
        if let Some(samplers) = animation.get_mut("samplers").and_then(|s| s.as_array_mut()) {
            for sampler in samplers {
                for key in ["input", "output"] {
                    if let Some(value) = sampler.get_mut(key) {
                        carry(value)?;
                    }
                }
            }
        }
        animations.push(animation);
    }
    let mut nodes = array("nodes");
    for node in &mut nodes {
        if let Some(object) = node.as_object_mut() {
            for key in ["mesh", "camera", "weights", "extensions"] {
                object.remove(key);
            }
        }
    }
    let scene = raw.get("scene").and_then(|s| s.as_u64()).map(|s| s as usize);
    Ok(Rig { nodes, mesh_node, scenes: array("scenes"), scene, skins, animations, accessors })
}

/// Every key of every `extensions` object inside `value`.
fn collect_extensions(value: &serde_json::Value, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Object(object) => {
            for (key, inner) in object {
                if key == "extensions"
                    && let Some(names) = inner.as_object()
                {
                    out.extend(names.keys().cloned());
                }
                collect_extensions(inner, out);
            }
        }
        serde_json::Value::Array(items) => items.iter().for_each(|v| collect_extensions(v, out)),
        _ => {}
    }
}

/// A `data:` URI's media type and decoded bytes; `None` for any other URI.
fn data_uri(uri: &str) -> Option<Result<(&str, Vec<u8>), String>> {
    let rest = uri.strip_prefix("data:")?;
    Some(rest.split_once(";base64,").ok_or_else(|| "data URI is not base64".to_string()).and_then(|(kind, payload)| {
        let bytes = base64::engine::general_purpose::STANDARD.decode(payload).map_err(|e| format!("data URI: {e}"))?;
        Ok((kind, bytes))
    }))
}

/// Whether a primitive has positions: glTF allows one without them, which draws nothing.
fn drawn(primitive: &gltf::Primitive) -> bool {
    primitive.get(&gltf::Semantic::Positions).is_some()
}

/// The crate's validation of `root` (every index refers to something that exists), less its one
/// refusal of a valid document: a primitive without POSITION, which glTF allows (it draws nothing,
/// and the reader passes over it, said).
fn validated_document(root: gltf::json::Root) -> Result<gltf::Document, gltf::Error> {
    use gltf::json::validation::{Error, Validate};
    let mut errors = Vec::new();
    root.validate(&root, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        if !(matches!(error, Error::Missing) && path.as_str().ends_with(".attributes[\"POSITION\"]")) {
            errors.push((path, error));
        }
    });
    if errors.is_empty() {
        Ok(gltf::Document::from_json_without_validation(root))
    } else {
        Err(gltf::Error::Validation(errors))
    }
}

/// Whether a primitive mode describes a surface.
fn is_surface(mode: Mode) -> bool {
    matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
}

/// Reads one primitive, placed by `world`; joints and weights when it has them and `joint_count`
/// (the skin's joints) is not zero, every joint index checked against it.
fn read_primitive(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    world: &DMat4,
    joint_count: usize,
) -> Result<Part, String> {
    checks::types(primitive)?;
    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
    let positions: Vec<[f32; 3]> = match quantized::<3>(primitive, &gltf::Semantic::Positions, buffers)? {
        Some(values) => values,
        None => reader.read_positions().ok_or("POSITION cannot be read")?.collect(),
    };
    let n = positions.len();
    finite("POSITION", &positions)?;
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(format!("index {bad} is out of range ({n} vertices)"));
    }
    let mut triangles = triangles_of(primitive.mode(), &indices)?;
    let normals = quantized::<3>(primitive, &gltf::Semantic::Normals, buffers)?
        .or_else(|| reader.read_normals().map(|r| r.collect()));
    let tangents = quantized::<4>(primitive, &gltf::Semantic::Tangents, buffers)?
        .or_else(|| reader.read_tangents().map(|r| r.collect()));
    let uvs = quantized::<2>(primitive, &gltf::Semantic::TexCoords(0), buffers)?
        .or_else(|| reader.read_tex_coords(0).map(|r| r.into_f32().collect()));
    let uvs1 = quantized::<2>(primitive, &gltf::Semantic::TexCoords(1), buffers)?
        .or_else(|| reader.read_tex_coords(1).map(|r| r.into_f32().collect()));
    let colors: Option<Vec<[f32; 4]>> = reader.read_colors(0).map(|r| r.into_rgba_f32().collect());
    per_vertex("NORMAL", normals.as_deref(), n)?;
    per_vertex("TEXCOORD_0", uvs.as_deref(), n)?;
    per_vertex("TEXCOORD_1", uvs1.as_deref(), n)?;
    per_vertex("TANGENT", tangents.as_deref(), n)?;
    per_vertex("COLOR_0", colors.as_deref(), n)?;
    let (joints, weights, mended) = if joint_count > 0 {
        let joints = reader.read_joints(0).map(|r| r.into_u16().collect());
        skin_of(joints, reader.read_weights(0).map(|r| r.into_f32().collect()), n, joint_count)?
    } else {
        (None, None, 0)
    };
    // Placed in the world; normals by the inverse transpose; a mirror flips the winding back.
    let linear = DMat3::from_mat4(*world);
    let normal_matrix = linear.inverse().transpose();
    let positions =
        positions.iter().map(|p| world.transform_point3(DVec3::from(p.map(f64::from))).as_vec3().to_array()).collect();
    if linear.determinant() < 0.0 {
        triangles.iter_mut().for_each(|t| t.swap(1, 2));
    }
    let per_corner =
        |values: Vec<[f32; 3]>| -> Vec<[f32; 3]> { triangles.iter().flatten().map(|&v| values[v as usize]).collect() };
    let normals = normals.map(|v| {
        per_corner(
            v.iter()
                .map(|n| (normal_matrix * DVec3::from(n.map(f64::from))).normalize_or_zero().as_vec3().to_array())
                .collect(),
        )
    });
    // A tangent turns with the surface (the linear part), and a mirror flips its handedness.
    let handedness = if linear.determinant() < 0.0 { -1.0 } else { 1.0 };
    let tangents = tangents.map(|v| {
        let placed: Vec<[f32; 4]> = v
            .iter()
            .map(|t| {
                let [x, y, z] = (linear * DVec3::new(t[0].into(), t[1].into(), t[2].into()))
                    .normalize_or_zero()
                    .as_vec3()
                    .to_array();
                [x, y, z, t[3] * handedness]
            })
            .collect();
        triangles.iter().flatten().map(|&i| placed[i as usize]).collect()
    });
    let uvs = uvs.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    let uvs1 = uvs1.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    let colors = colors.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    let joints = joints.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    let weights = weights.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    let material = primitive.material().index().map_or(NO_MATERIAL, |m| m as u32);
    let extra = extra_channels(primitive, &reader, buffers, n)?
        .into_iter()
        .map(|c| Channel { values: c.values.pick(triangles.iter().flatten().map(|&v| v as usize)), ..c })
        .collect();
    Ok(Part { positions, triangles, normals, tangents, uvs, uvs1, colors, joints, weights, material, mended, extra })
}

/// The triangles of a surface primitive's `indices` in its `mode` (strips and fans unrolled).
fn triangles_of(mode: Mode, indices: &[u32]) -> Result<Vec<[u32; 3]>, String> {
    Ok(match mode {
        Mode::TriangleStrip => indices
            .windows(3)
            .enumerate()
            .map(|(k, w)| if k % 2 == 0 { [w[0], w[1], w[2]] } else { [w[1], w[0], w[2]] })
            .collect(),
        Mode::TriangleFan => indices.windows(2).skip(1).map(|w| [indices[0], w[0], w[1]]).collect(),
        _ => {
            if !indices.len().is_multiple_of(3) {
                return Err(format!("{} indices: not a whole number of triangles", indices.len()));
            }
            indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        }
    })
}

/// A skinned primitive's JOINTS_0 and WEIGHTS_0 as read (both kept, or neither) for its `n`
/// vertices: weights mended to sum to 1, a joint of weight zero read as joint 0, each joint
/// checked against the skin's `joint_count`, and how many vertices' weights had to be mended.
#[allow(clippy::type_complexity)]
fn skin_of(
    mut joints: Option<Vec<[u16; 4]>>,
    mut weights: Option<Vec<[f32; 4]>>,
    n: usize,
    joint_count: usize,
) -> Result<(Option<Vec<[u16; 4]>>, Option<Vec<[f32; 4]>>, usize), String> {
    let mut mended = 0;
    if let (Some(j), Some(w)) = (&mut joints, &mut weights) {
        finite("WEIGHTS_0", w)?;
        // Weights that do not sum to 1 (invalid glTF) are scaled to, a negative one taken as 0.
        mended = w.iter_mut().map(|w| crate::mesh::normalize_weights(w) as usize).sum();
        // A joint of weight zero moves nothing: it is read as joint 0, as glTF asks unused
        // entries to be, so that it neither splits a vertex nor draws a validator warning.
        for (j, w) in j.iter_mut().zip(w.iter()) {
            for k in 0..4 {
                if w[k] == 0.0 {
                    j[k] = 0;
                }
            }
        }
        same_count("JOINTS_0", j.len(), n)?;
        same_count("WEIGHTS_0", w.len(), n)?;
        if let Some((vertex, bad)) =
            j.iter().enumerate().find_map(|(i, j)| j.iter().find(|&&x| x as usize >= joint_count).map(|&x| (i, x)))
        {
            return Err(format!("JOINTS_0 of vertex {vertex} names joint {bad}; the skin has {joint_count}"));
        }
    } else {
        (joints, weights) = (None, None);
    }
    Ok((joints, weights, mended))
}

/// `Err` unless attribute `what`, where the primitive has it, has one finite value for each of the
/// `n` positions.
fn per_vertex<const N: usize>(what: &str, values: Option<&[[f32; N]]>, n: usize) -> Result<(), String> {
    let Some(values) = values else { return Ok(()) };
    same_count(what, values.len(), n)?;
    finite(what, values)
}

/// Joins the parts into one mesh. Texture coordinates and colours are kept when some part has
/// them, a part without them taking the values glTF draws it with: white, and for texture
/// coordinates (which a primitive without them cannot sample a texture by) zero; without that, a
/// textured body beside an untextured part lost its texture. Normals and tangents are kept when
/// every part has them (glTF draws a primitive without normals flat, which per-corner values could
/// hold but the simplifier could then not move), and said otherwise.
fn merge(mut parts: Vec<Part>, library: MaterialLibrary, path: &Path) -> Result<Mesh, MeshError> {
    let keep_normals = parts.iter().all(|p| p.normals.is_some());
    let keep_tangents = parts.iter().all(|p| p.tangents.is_some());
    let keep_uvs = parts.iter().any(|p| p.uvs.is_some());
    let keep_uvs1 = parts.iter().any(|p| p.uvs1.is_some());
    let keep_colors = parts.iter().any(|p| p.colors.is_some());
    let mut library = library;
    if !keep_normals && parts.iter().any(|p| p.normals.is_some()) {
        library.not_carried.push("normals (a primitive has no NORMAL)".into());
    }
    if !keep_tangents && parts.iter().any(|p| p.tangents.is_some()) {
        library.not_carried.push("tangents (a primitive has no TANGENT)".into());
    }
    let keep_skin = library.rig.is_some() && parts.iter().all(|p| p.joints.is_some());
    if !keep_skin && library.rig.take().is_some() {
        library.not_carried.push("skins and animations (a primitive has no JOINTS_0 and WEIGHTS_0)".into());
    }
    let mended: usize = parts.iter().map(|p| p.mended).sum();
    if keep_skin && mended > 0 {
        library.mended.push(format!(
            "the input's skin weights (WEIGHTS_0) summed to other than 1 at {mended} vertices: scaled to sum to 1, as glTF requires"
        ));
    }
    let extra: Vec<Vec<Channel>> = parts.iter_mut().map(|p| std::mem::take(&mut p.extra)).collect();
    let corner_counts: Vec<usize> = parts.iter().map(|p| 3 * p.triangles.len()).collect();
    let extra = merge_extra(&extra, &corner_counts, &mut library);
    let mut mesh = Mesh::default();
    let mut corners = CornerAttributes::default();
    (corners.library, corners.uv_origin_top) = (Some(std::sync::Arc::new(library)), true);
    corners.set_normals(keep_normals.then(Vec::new));
    corners.set_tangents(keep_tangents.then(Vec::new));
    corners.set_uvs(keep_uvs.then(Vec::new));
    corners.set_uvs1(keep_uvs1.then(Vec::new));
    corners.set_colors(keep_colors.then(Vec::new));
    corners.set_joints(keep_skin.then(Vec::new));
    corners.set_weights(keep_skin.then(Vec::new));
    corners.set_materials(Some(Vec::new()));
    for part in parts {
        if let Some(all) = corners.materials_mut() {
            all.extend(std::iter::repeat_n(part.material, 3 * part.triangles.len()));
        }
        let offset = mesh.positions.len() as u32;
        mesh.positions.extend(part.positions);
        mesh.triangles.extend(part.triangles.iter().map(|t| t.map(|v| v + offset)));
        if let (Some(all), Some(these)) = (corners.normals_mut(), part.normals) {
            all.extend(these);
        }
        if let (Some(all), Some(these)) = (corners.tangents_mut(), part.tangents) {
            all.extend(these);
        }
        if let Some(all) = corners.uvs_mut() {
            all.extend(part.uvs.unwrap_or_else(|| vec![[0.0; 2]; 3 * part.triangles.len()]));
        }
        if let Some(all) = corners.uvs1_mut() {
            all.extend(part.uvs1.unwrap_or_else(|| vec![[0.0; 2]; 3 * part.triangles.len()]));
        }
        if let Some(all) = corners.colors_mut() {
            all.extend(part.colors.unwrap_or_else(|| vec![[1.0; 4]; 3 * part.triangles.len()]));
        }
        if let (Some(all), Some(these)) = (corners.joints_mut(), part.joints) {
            all.extend(these);
        }
        if let (Some(all), Some(these)) = (corners.weights_mut(), part.weights) {
            all.extend(these);
        }
    }
    for (semantic, values) in extra {
        corners.set(semantic, Some(values));
    }
    if mesh.positions.is_empty() {
        corners = CornerAttributes::default();
    }
    mesh.corners = corners;
    mesh.join_cut_seams();
    mesh.check().map_err(|e| MeshError::parse(path, "data", e.to_string()))?;
    Ok(mesh)
}
