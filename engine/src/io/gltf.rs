//! glTF 2.0 reader (`.gltf` with embedded or external buffers, and `.glb`), through the `gltf`
//! crate's document model.
//!
//! Every triangle primitive (TRIANGLES, and TRIANGLE_STRIP / TRIANGLE_FAN unrolled) of every mesh
//! instance in the default scene (else the first, else every mesh once) is read, placed by its
//! node's world transform (normals by the inverse transpose; mirrored nodes keep their faces
//! counter-clockwise) and merged into one mesh. Kept per corner: NORMAL, TEXCOORD_0 and COLOR_0,
//! each when every primitive has it. glTF splits a vertex wherever its attributes differ (seams,
//! hard edges) and exporters often between primitives too: vertices at bit-identical positions are
//! joined ([`Mesh::weld_positions`]), so the surface is one piece with seams, not cut open.
//! POINTS and LINES primitives are not surface and are left out.
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

use super::ReadLimits;
use crate::error::MeshError;
use crate::mesh::{CornerAttributes, Mesh};

/// Extensions whose data meshlod cannot decode; a file that requires one is refused by name.
const UNSUPPORTED: [&str; 3] = ["KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_mesh_quantization"];

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
    uvs: Option<Vec<[f32; 2]>>,
    colors: Option<Vec<[f32; 4]>>,
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
    // The crate's validation (every index in the document refers to something that exists). It
    // can panic on some out-of-range indices: that is reported as the invalid document it is.
    let gltf = std::panic::catch_unwind(|| gltf::Gltf::from_slice(bytes))
        .map_err(|_| err("document", "refers to an element that does not exist".into()))?
        .map_err(|e| err("document", e.to_string()))?;
    let document = &gltf.document;

    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in document.buffers() {
        let at = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                gltf.blob.clone().ok_or_else(|| err(&at, "refers to the GLB binary chunk, which is missing".into()))?
            }
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) =
                        rest.split_once(";base64,").ok_or_else(|| err(&at, "data URI is not base64".into()))?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| err(&at, format!("data URI: {e}")))?
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
                    std::fs::read(&file).map_err(|e| err(&at, format!("'{}': {e}", file.display())))?
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
        check_accessor(&accessor).map_err(|reason| err(&format!("accessor {}", accessor.index()), reason))?;
    }

    // Mesh instances with their world transforms.
    let mut instances: Vec<(gltf::Mesh, DMat4)> = Vec::new();
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
                    instances.push((mesh, world));
                }
                stack.extend(node.children().map(|c| (c, world)));
            }
        }
        None => instances.extend(document.meshes().map(|m| (m, DMat4::IDENTITY))),
    }

    // Counts first, against the limits, before reading any data.
    let (mut vertices, mut corners) = (0u64, 0u64);
    for (mesh, _) in &instances {
        for primitive in mesh.primitives().filter(|p| is_surface(p.mode())) {
            let positions = primitive.get(&gltf::Semantic::Positions).ok_or_else(|| {
                err(&format!("mesh {} primitive {}", mesh.index(), primitive.index()), "has no POSITION".into())
            })?;
            vertices += positions.count() as u64;
            corners += primitive.indices().map_or(positions.count(), |a| a.count()) as u64;
        }
    }
    limits.check_vertices(vertices)?;
    limits.check_faces(corners / 3)?;

    let mut parts = Vec::new();
    for (mesh, world) in &instances {
        for primitive in mesh.primitives().filter(|p| is_surface(p.mode())) {
            limits.check_cancel()?;
            let at = format!("mesh {} primitive {}", mesh.index(), primitive.index());
            // The checks above make the reads in range; a panic in the crate would still be a bug
            // of this reader, reported as one rather than taking the caller down.
            let part =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read_primitive(&primitive, &buffers, world)))
                    .map_err(|_| err(&at, "could not be read (malformed accessor data)".into()))?
                    .map_err(|reason| err(&at, reason))?;
            parts.push(part);
        }
    }
    merge(parts, path)
}

/// Whether a primitive mode describes a surface.
fn is_surface(mode: Mode) -> bool {
    matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
}

/// Checks that an accessor's elements (and its sparse parts) lie inside their buffer views.
fn check_accessor(accessor: &gltf::Accessor) -> Result<(), String> {
    let element = accessor.size();
    let count = accessor.count();
    if let Some(view) = accessor.view() {
        let stride = view.stride().unwrap_or(element);
        if stride < element {
            return Err(format!("stride {stride} is shorter than its {element}-byte elements"));
        }
        if count > 0 {
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
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let index_size = match sparse.indices().index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let indices_end = n.checked_mul(index_size).and_then(|x| x.checked_add(sparse.indices().offset()));
        if indices_end.is_none_or(|end| end > sparse.indices().view().length()) {
            return Err("its sparse indices overrun their bufferView".into());
        }
        let values_end = n.checked_mul(element).and_then(|x| x.checked_add(sparse.values().offset()));
        if values_end.is_none_or(|end| end > sparse.values().view().length()) {
            return Err("its sparse values overrun their bufferView".into());
        }
    }
    Ok(())
}

fn read_primitive(primitive: &gltf::Primitive, buffers: &[Vec<u8>], world: &DMat4) -> Result<Part, String> {
    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
    let positions: Vec<[f32; 3]> = reader.read_positions().ok_or("POSITION cannot be read")?.collect();
    let n = positions.len();
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(format!("index {bad} is out of range ({n} vertices)"));
    }
    let mut triangles: Vec<[u32; 3]> = match primitive.mode() {
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
    };
    let same_count = |what: &str, got: usize| -> Result<(), String> {
        if got == n { Ok(()) } else { Err(format!("{what} has {got} values for {n} positions")) }
    };
    let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(|r| r.collect());
    let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(0).map(|r| r.into_f32().collect());
    let colors: Option<Vec<[f32; 4]>> = reader.read_colors(0).map(|r| r.into_rgba_f32().collect());
    if let Some(v) = &normals {
        same_count("NORMAL", v.len())?;
    }
    if let Some(v) = &uvs {
        same_count("TEXCOORD_0", v.len())?;
    }
    if let Some(v) = &colors {
        same_count("COLOR_0", v.len())?;
    }
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
    let uvs = uvs.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    let colors = colors.map(|v| triangles.iter().flatten().map(|&i| v[i as usize]).collect());
    Ok(Part { positions, triangles, normals, uvs, colors })
}

/// Joins the parts into one mesh; an attribute is kept when every part has it.
fn merge(parts: Vec<Part>, path: &Path) -> Result<Mesh, MeshError> {
    let keep_normals = parts.iter().all(|p| p.normals.is_some());
    let keep_uvs = parts.iter().all(|p| p.uvs.is_some());
    let keep_colors = parts.iter().all(|p| p.colors.is_some());
    let mut mesh = Mesh::default();
    let mut corners = CornerAttributes {
        normals: keep_normals.then(Vec::new),
        uvs: keep_uvs.then(Vec::new),
        colors: keep_colors.then(Vec::new),
    };
    for part in parts {
        let offset = mesh.positions.len() as u32;
        mesh.positions.extend(part.positions);
        mesh.triangles.extend(part.triangles.iter().map(|t| t.map(|v| v + offset)));
        if let (Some(all), Some(these)) = (&mut corners.normals, part.normals) {
            all.extend(these);
        }
        if let (Some(all), Some(these)) = (&mut corners.uvs, part.uvs) {
            all.extend(these);
        }
        if let (Some(all), Some(these)) = (&mut corners.colors, part.colors) {
            all.extend(these);
        }
    }
    if mesh.positions.is_empty() {
        corners = CornerAttributes::default();
    }
    mesh.corners = corners;
    mesh.weld_positions();
    mesh.check().map_err(|e| MeshError::parse(path, "data", e.to_string()))?;
    Ok(mesh)
}
