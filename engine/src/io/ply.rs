//! Stanford PLY reader (ascii, binary little endian, binary big endian) and binary writer.
//!
//! The header is parsed first; before anything is allocated from its element counts, those counts
//! are checked against the configured limits and against the bytes that actually follow, so a
//! header that lies ("1e12 vertices" in a 1 kB file) is refused at once.

use std::io::Write;
use std::path::Path;

use super::options::ReadLimits;
use super::triangulate::triangulate_face;
use crate::error::MeshError;
use crate::mesh::{CornerAttributes, Mesh};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar { name: String, kind: Scalar },
    List { name: String, count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

impl Element {
    /// Fewest bytes one element can take in the binary encodings (lists may be empty).
    fn min_binary_size(&self) -> u64 {
        self.properties
            .iter()
            .map(|p| match p {
                Property::Scalar { kind, .. } => kind.size() as u64,
                Property::List { count, .. } => count.size() as u64,
            })
            .sum()
    }
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    body_offset: usize,
    body_line: usize,
}

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, MeshError> {
    const MAX_HEADER: usize = 1 << 20;
    let search = &bytes[..bytes.len().min(MAX_HEADER)];
    let end = find_subslice(search, b"end_header")
        .ok_or_else(|| MeshError::parse(path, "header", "no 'end_header' line in the first 1 MiB"))?;
    let line_end = search[end..].iter().position(|&b| b == b'\n').map(|p| end + p + 1).unwrap_or(bytes.len());
    let text =
        std::str::from_utf8(&bytes[..line_end]).map_err(|_| MeshError::parse(path, "header", "header is not text"))?;

    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, l)) if l.trim() == "ply" => {}
        _ => return Err(MeshError::parse(path, "line 1", "missing 'ply' magic")),
    }
    let mut body_line = 1;
    for (i, l) in lines {
        let line = i + 1;
        body_line = line + 1;
        let loc = || format!("line {line}");
        let tokens: Vec<&str> = l.split_ascii_whitespace().collect();
        match tokens.as_slice() {
            [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                encoding = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::LittleEndian,
                    "binary_big_endian" => Encoding::BigEndian,
                    other => {
                        return Err(MeshError::parse(path, loc(), format!("unknown format '{other}'")));
                    }
                })
            }
            ["element", name, count] => {
                let count: u64 = count.parse().map_err(|_| {
                    MeshError::parse(path, loc(), format!("element count '{count}' is not a non-negative integer"))
                })?;
                elements.push(Element { name: name.to_string(), count, properties: Vec::new() });
            }
            ["property", "list", count, item, name] => {
                let element =
                    elements.last_mut().ok_or_else(|| MeshError::parse(path, loc(), "property before any element"))?;
                let count = Scalar::parse(count).filter(|s| s.is_integer()).ok_or_else(|| {
                    MeshError::parse(path, loc(), format!("list count type '{count}' is not an integer type"))
                })?;
                let item = Scalar::parse(item)
                    .ok_or_else(|| MeshError::parse(path, loc(), format!("unknown type '{item}'")))?;
                element.properties.push(Property::List { name: name.to_string(), count, item });
            }
            ["property", kind, name] => {
                let element =
                    elements.last_mut().ok_or_else(|| MeshError::parse(path, loc(), "property before any element"))?;
                let kind = Scalar::parse(kind)
                    .ok_or_else(|| MeshError::parse(path, loc(), format!("unknown type '{kind}'")))?;
                element.properties.push(Property::Scalar { name: name.to_string(), kind });
            }
            ["end_header"] => break,
            _ => {
                return Err(MeshError::parse(path, loc(), format!("unrecognised header line '{}'", l.trim())));
            }
        }
    }
    let encoding = encoding.ok_or_else(|| MeshError::parse(path, "header", "no 'format' line"))?;
    Ok(Header { encoding, elements, body_offset: line_end, body_line })
}

fn find_subslice(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// Source of property values for one element: ascii tokens or binary bytes.
trait ValueSource {
    fn next_value(&mut self, kind: Scalar) -> Result<f64, String>;
    fn end_element(&mut self) -> Result<(), String> {
        Ok(())
    }
}

struct BinarySource<'a> {
    bytes: &'a [u8],
    offset: usize,
    big_endian: bool,
}

impl ValueSource for BinarySource<'_> {
    fn next_value(&mut self, kind: Scalar) -> Result<f64, String> {
        let size = kind.size();
        let Some(raw) = self.bytes.get(self.offset..self.offset + size) else {
            return Err(format!("file ends at byte {} in the middle of the data (truncated)", self.bytes.len()));
        };
        self.offset += size;
        let mut buf = [0u8; 8];
        buf[..size].copy_from_slice(raw);
        if self.big_endian {
            buf[..size].reverse();
        }
        Ok(match kind {
            Scalar::I8 => buf[0] as i8 as f64,
            Scalar::U8 => buf[0] as f64,
            Scalar::I16 => i16::from_le_bytes([buf[0], buf[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([buf[0], buf[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(buf),
        })
    }
}

struct AsciiSource<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    first_line: usize,
    current: Option<(usize, std::str::SplitAsciiWhitespace<'a>)>,
}

impl AsciiSource<'_> {
    fn line(&self) -> usize {
        self.current.as_ref().map(|(l, _)| self.first_line + l).unwrap_or(self.first_line)
    }
}

impl ValueSource for AsciiSource<'_> {
    fn next_value(&mut self, kind: Scalar) -> Result<f64, String> {
        loop {
            if self.current.is_none() {
                match self.lines.next() {
                    Some((i, l)) if !l.trim().is_empty() => self.current = Some((i, l.split_ascii_whitespace())),
                    Some(_) => continue,
                    None => {
                        return Err("file ends before all declared elements were read (truncated)".into());
                    }
                }
            }
            let line = self.line();
            let (_, tokens) = self.current.as_mut().expect("set above");
            let Some(token) = tokens.next() else {
                return Err(format!("line {line} has too few values"));
            };
            let value: f64 = token.parse().map_err(|_| format!("line {line}: '{token}' is not a number"))?;
            if kind.is_integer() && value.fract() != 0.0 {
                return Err(format!("line {line}: '{token}' should be an integer"));
            }
            return Ok(value);
        }
    }

    fn end_element(&mut self) -> Result<(), String> {
        // Each element is one line; a line with leftover values means the header lies about its
        // properties.
        let line = self.line();
        if let Some((_, mut tokens)) = self.current.take()
            && let Some(extra) = tokens.next()
        {
            return Err(format!("line {line} has an unexpected extra value '{extra}'"));
        }
        Ok(())
    }
}

/// Reads a PLY file's bytes.
pub fn read_ply(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let header = parse_header(bytes, path)?;
    let body = &bytes[header.body_offset..];

    check_room(&header, body.len(), path, limits)?;

    let mut source: Box<dyn ValueSource> = match header.encoding {
        Encoding::Ascii => {
            let text =
                std::str::from_utf8(body).map_err(|_| MeshError::parse(path, "body", "ascii PLY body is not text"))?;
            Box::new(AsciiSource { lines: text.lines().enumerate(), first_line: header.body_line, current: None })
        }
        Encoding::LittleEndian => Box::new(BinarySource { bytes: body, offset: 0, big_endian: false }),
        Encoding::BigEndian => Box::new(BinarySource { bytes: body, offset: 0, big_endian: true }),
    };

    let mut positions: Vec<[f32; 3]> = Vec::new();
    // Per-vertex attributes: normal, texture coordinate, colour (each all or nothing).
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let mut polygons: Vec<(usize, Vec<i64>)> = Vec::new();
    let mut saw_vertex = false;
    let mut face_list_seen = false;
    for element in &header.elements {
        let is_vertex = element.name == "vertex";
        let is_face = element.name == "face";
        let (xyz_slots, normal_slots, uv_slots, color_slots) = vertex_slots(element);
        if is_vertex {
            saw_vertex = true;
            if xyz_slots.contains(&usize::MAX) {
                return Err(MeshError::parse(path, "header", "vertex element lacks scalar x, y and z properties"));
            }
            // A header can claim any count: room only for what the body could hold (a vertex takes
            // at least one byte per property), the rest grows as values are really read.
            let could_hold = body.len() / element.properties.len().max(1);
            positions.reserve((element.count as usize).min(could_hold));
        }
        let index_list = if is_face { Some(face_list_slot(element, path)?) } else { None };
        face_list_seen |= is_face;
        for i in 0..element.count {
            limits.check_cancel()?;
            let loc = |k: u64| format!("{} {k}", element.name);
            let slots = (xyz_slots, normal_slots, uv_slots, color_slots);
            let (xyz, normal, uv, color, indices) = read_values(source.as_mut(), element, slots, index_list)
                .map_err(|r| MeshError::parse(path, loc(i), r))?;
            source.end_element().map_err(|r| MeshError::parse(path, loc(i), r))?;
            if is_vertex {
                let p = [xyz[0] as f32, xyz[1] as f32, xyz[2] as f32];
                check_finite(xyz, p, [&normal[..], &uv[..], &color[..]])
                    .map_err(|r| MeshError::parse(path, loc(i), r))?;
                positions.push(p);
                if !normal_slots.contains(&usize::MAX) {
                    normals.push(normal);
                }
                if !uv_slots.contains(&usize::MAX) {
                    uvs.push(uv);
                }
                if !color_slots[..3].contains(&usize::MAX) {
                    colors.push(color);
                }
            } else if is_face {
                if indices.len() < 3 {
                    return Err(MeshError::parse(
                        path,
                        loc(i),
                        format!("face has {} corners; a face needs at least 3", indices.len()),
                    ));
                }
                polygons.push((i as usize, indices));
            }
        }
    }
    if !saw_vertex {
        return Err(MeshError::parse(path, "header", "no vertex element"));
    }
    if !face_list_seen {
        // A point cloud: valid PLY, but meshlod needs faces. Returned as an empty-face mesh; the
        // algorithms refuse it with an "empty mesh" error.
    }

    let triangles = triangles_of(&polygons, &positions, path, limits)?;
    let mesh = with_corner_values(positions, triangles, normals, uvs, colors);
    mesh.check()?;
    Ok(mesh)
}

/// The slot of a face element's list of vertex indices: `vertex_indices` (or `vertex_index`),
/// else its first list.
fn face_list_slot(element: &Element, path: &Path) -> Result<usize, MeshError> {
    let by_name = element
        .properties
        .iter()
        .position(|p| matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index"));
    let any_list = element.properties.iter().position(|p| matches!(p, Property::List { .. }));
    by_name.or(any_list).ok_or_else(|| MeshError::parse(path, "header", "face element has no list of vertex indices"))
}

/// One element's values and what a vertex or face keeps of them: position, normal, texture
/// coordinate and colour (by their `slots`), and the vertex indices of the list at `index_list`.
type ElementValues = ([f64; 3], [f32; 3], [f32; 2], [f32; 4], Vec<i64>);

/// Reads one element's values from `source`.
fn read_values(
    source: &mut dyn ValueSource,
    element: &Element,
    (xyz_slots, normal_slots, uv_slots, color_slots): ([usize; 3], [usize; 3], [usize; 2], [usize; 4]),
    index_list: Option<usize>,
) -> Result<ElementValues, String> {
    let mut xyz = [0f64; 3];
    let (mut normal, mut uv, mut color) = ([0f32; 3], [0f32; 2], [0f32, 0.0, 0.0, 1.0]);
    let mut indices: Vec<i64> = Vec::new();
    for (k, property) in element.properties.iter().enumerate() {
        match property {
            Property::Scalar { kind, .. } => {
                let v = source.next_value(*kind)?;
                if let Some(axis) = xyz_slots.iter().position(|&s| s == k) {
                    xyz[axis] = v;
                } else if let Some(axis) = normal_slots.iter().position(|&s| s == k) {
                    normal[axis] = v as f32;
                } else if let Some(axis) = uv_slots.iter().position(|&s| s == k) {
                    uv[axis] = v as f32;
                } else if let Some(channel) = color_slots.iter().position(|&s| s == k) {
                    // Integer channels span their type's range; float channels are [0, 1].
                    color[channel] = match kind {
                        Scalar::U8 => (v / 255.0) as f32,
                        Scalar::U16 => (v / 65535.0) as f32,
                        _ => v as f32,
                    };
                }
            }
            Property::List { count, item, .. } => {
                let n = source.next_value(*count)?;
                if n < 0.0 {
                    return Err(format!("negative list length {n}"));
                }
                let keep = index_list == Some(k);
                for _ in 0..n as u64 {
                    let v = source.next_value(*item)?;
                    if keep {
                        indices.push(v as i64);
                    }
                }
            }
        }
    }
    Ok((xyz, normal, uv, color, indices))
}

/// The mesh with its per-vertex values as per-corner values: a PLY vertex has one of each. Seams
/// (two vertices at one position) are joined again.
fn with_corner_values(
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[f32; 4]>,
) -> Mesh {
    let vertex_count = positions.len();
    // Per-vertex values become per-corner values: a PLY vertex has one of each.
    fn per_corner<T: Copy>(per_vertex: Vec<T>, vertex_count: usize, triangles: &[[u32; 3]]) -> Option<Vec<T>> {
        (per_vertex.len() == vertex_count && vertex_count > 0)
            .then(|| triangles.iter().flatten().map(|&v| per_vertex[v as usize]).collect())
    }
    let mut corners = CornerAttributes::default();
    corners.set_uvs(per_corner(uvs, vertex_count, &triangles));
    corners.set_normals(per_corner(normals, vertex_count, &triangles));
    corners.set_colors(per_corner(colors, vertex_count, &triangles));
    let mut mesh = Mesh { positions, triangles, corners };
    if !mesh.corners.is_empty() {
        // One value per vertex means a seam is two vertices at one position: joined again, so a
        // seam is a seam (see `Mesh::join_cut_seams`), as the writer's split round-trips.
        mesh.join_cut_seams();
    }
    mesh
}

/// Refuses counts that the bytes after the header (`body_len`) cannot hold, and counts over the
/// limits, before anything is allocated.
fn check_room(header: &Header, body_len: usize, path: &Path, limits: &ReadLimits) -> Result<(), MeshError> {
    let mut needed: u64 = 0;
    for e in &header.elements {
        let per_element = match header.encoding {
            Encoding::Ascii => 2, // at least one digit and a newline
            _ => e.min_binary_size().max(1),
        };
        needed = needed.saturating_add(e.count.saturating_mul(per_element));
        match e.name.as_str() {
            "vertex" => limits.check_vertices(e.count, path)?,
            "face" => limits.check_faces(e.count, path)?,
            _ => {}
        }
    }
    if needed > body_len as u64 {
        return Err(MeshError::parse(
            path,
            "header",
            format!(
                "declared elements need at least {needed} bytes but only {} follow the header (truncated or lying header)",
                body_len
            ),
        ));
    }
    Ok(())
}

/// The slots of a vertex element's scalar properties: position, normal, texture coordinate and
/// colour (`usize::MAX` where the element has none).
fn vertex_slots(element: &Element) -> ([usize; 3], [usize; 3], [usize; 2], [usize; 4]) {
    let mut xyz_slots = [usize::MAX; 3];
    let mut normal_slots = [usize::MAX; 3];
    let mut uv_slots = [usize::MAX; 2];
    let mut color_slots = [usize::MAX; 4];
    for (k, p) in element.properties.iter().enumerate() {
        if let Property::Scalar { name, .. } = p {
            match name.as_str() {
                "x" => xyz_slots[0] = k,
                "y" => xyz_slots[1] = k,
                "z" => xyz_slots[2] = k,
                "nx" => normal_slots[0] = k,
                "ny" => normal_slots[1] = k,
                "nz" => normal_slots[2] = k,
                "u" | "s" | "texture_u" | "texture_s" => uv_slots[0] = k,
                "v" | "t" | "texture_v" | "texture_t" => uv_slots[1] = k,
                "red" | "diffuse_red" => color_slots[0] = k,
                "green" | "diffuse_green" => color_slots[1] = k,
                "blue" | "diffuse_blue" => color_slots[2] = k,
                "alpha" | "diffuse_alpha" => color_slots[3] = k,
                _ => {}
            }
        }
    }
    (xyz_slots, normal_slots, uv_slots, color_slots)
}

/// `Err` naming the first value of a vertex (its position `xyz`, as `p` in single precision, and
/// its normal, texture coordinate and colour) that is not a finite number.
fn check_finite(xyz: [f64; 3], p: [f32; 3], values: [&[f32]; 3]) -> Result<(), String> {
    if p.iter().any(|c| !c.is_finite()) {
        return Err(format!("non-finite coordinate {xyz:?}"));
    }
    for (name, values) in ["normal", "texture coordinate", "colour"].into_iter().zip(values) {
        if values.iter().any(|c| !c.is_finite()) {
            return Err(format!("non-finite {name} {values:?}"));
        }
    }
    Ok(())
}

/// The faces' polygons (face number, vertex indices) triangulated, every index checked against the
/// vertices and the triangle count against the limits before each polygon is triangulated.
fn triangles_of(
    polygons: &[(usize, Vec<i64>)],
    positions: &[[f32; 3]],
    path: &Path,
    limits: &ReadLimits,
) -> Result<Vec<[u32; 3]>, MeshError> {
    let vertex_count = positions.len();
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(polygons.len());
    let mut local = Vec::new();
    let mut points = Vec::new();
    for (face, indices) in polygons {
        if let Some(&bad) = indices.iter().find(|&&v| v < 0 || v as usize >= vertex_count) {
            return Err(MeshError::parse(
                path,
                format!("face {face}"),
                format!("refers to vertex {bad} but the file has {vertex_count} vertices"),
            ));
        }
        if indices.len() > super::options::MAX_POLYGON_CORNERS {
            return Err(MeshError::parse(
                path,
                format!("face {face}"),
                format!("has {} corners; at most {} are accepted", indices.len(), super::options::MAX_POLYGON_CORNERS),
            ));
        }
        // Checked before triangulating: n corners always make n − 2 triangles.
        limits.check_faces((triangles.len() + indices.len().saturating_sub(2)) as u64, path)?;
        triangulate_face(indices.iter().map(|&v| positions[v as usize]), &mut points, &mut local);
        triangles.extend(local.iter().map(|t| [indices[t[0]] as u32, indices[t[1]] as u32, indices[t[2]] as u32]));
    }
    Ok(triangles)
}

/// Writes a binary little-endian PLY: float x, y, z per vertex; uchar count + int indices per face.
/// A mesh with per-corner attributes is written with float nx, ny, nz / u, v and uchar red,
/// green, blue, alpha per vertex: PLY has one value per vertex, so a vertex whose corners differ
/// (a seam) is written once per distinct value, as glTF and every GPU buffer do.
pub fn write_ply(out: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    let c = &mesh.corners;
    // PLY colours are bytes: values that make the same bytes make one vertex.
    let mut quantised = c.clone();
    let uvs = c.uvs_with_origin(false);
    if let Some(colors) = quantised.colors_mut() {
        colors.iter_mut().for_each(|col| *col = col.map(|x| colour_byte(x) as f32));
    }
    // PLY has no materials: a vertex is split by its values only.
    let wedges = quantised.value_wedges(&mesh.triangles, mesh.vertex_count());
    let (source, corner_vertex) = (&wedges.source, &wedges.corner_vertex);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by meshlod\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        source.len()
    );
    if c.normals().is_some() {
        header += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if c.uvs().is_some() {
        header += "property float u\nproperty float v\n";
    }
    if c.colors().is_some() {
        header += "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n";
    }
    header += &format!("element face {}\nproperty list uchar int vertex_indices\nend_header\n", mesh.face_count());
    out.write_all(header.as_bytes())?;
    let mut buf = Vec::with_capacity(source.len() * 12 + mesh.face_count() * 13);
    for (i, &k) in source.iter().enumerate() {
        let v = wedges.vertex(&mesh.triangles, i);
        let floats = mesh.positions[v]
            .into_iter()
            .chain(c.normals().into_iter().flat_map(|n| n[k]))
            .chain(uvs.iter().flat_map(|u| u[k]));
        for f in floats {
            buf.extend_from_slice(&f.to_le_bytes());
        }
        buf.extend(c.colors().into_iter().flat_map(|col| col[k].map(colour_byte)));
    }
    for t in corner_vertex.chunks_exact(3) {
        buf.push(3);
        for &i in t {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out.write_all(&buf)
}

/// A colour channel in [0, 1] as a byte.
fn colour_byte(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}
