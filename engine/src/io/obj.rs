//! Wavefront OBJ reader and writer.
//!
//! Written here rather than through `tobj` because tobj renumbers vertices per object and drops
//! unreferenced ones (so `v` counts and cross-object sharing are lost) and reports errors without
//! line numbers. This reader keeps the file's global vertex numbering (welded position indices),
//! supports `v/vt/vn` corners and negative (relative) indices, triangulates polygons, and keeps
//! texture coordinates and normals per corner when every face has them. With those (or materials),
//! seams that the file cut open are joined again ([`Mesh::join_cut_seams`]), as the glTF and PLY
//! readers join them: the first of the joined vertices keeps its number.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::options::{ReadLimits, Target};
use super::triangulate::triangulate_polygon;
use crate::error::MeshError;
use crate::mesh::{CornerAttributes, Mesh, NO_MATERIAL};

/// A corner without a texture coordinate (in the per-corner index list).
const NO_VALUE: i64 = -1;

/// One polygon corner as written in the file, resolved to 0-based indices.
#[derive(Clone, Copy)]
struct Corner {
    position: i64,
    uv: Option<i64>,
    normal: Option<i64>,
}

fn parse_floats<const N: usize>(
    mut tokens: std::str::SplitAsciiWhitespace<'_>,
    path: &Path,
    line: usize,
    what: &str,
) -> Result<[f32; N], MeshError> {
    let mut out = [0f32; N];
    for (k, slot) in out.iter_mut().enumerate() {
        let token = tokens.next().ok_or_else(|| {
            MeshError::parse(path, format!("line {line}"), format!("{what} needs {N} numbers, found {k}"))
        })?;
        let value: f32 = token.parse().map_err(|_| {
            MeshError::parse(path, format!("line {line}"), format!("{what}: '{token}' is not a number"))
        })?;
        if !value.is_finite() {
            return Err(MeshError::parse(
                path,
                format!("line {line}"),
                format!("{what} has a non-finite coordinate '{token}'"),
            ));
        }
        *slot = value;
    }
    Ok(out)
}

/// Resolves a 1-based or negative OBJ index against the number of elements seen so far.
fn resolve(token: &str, seen: usize, path: &Path, line: usize) -> Result<i64, MeshError> {
    let raw: i64 = token.parse().map_err(|_| {
        MeshError::parse(path, format!("line {line}"), format!("face index '{token}' is not an integer"))
    })?;
    match raw {
        0 => Err(MeshError::parse(path, format!("line {line}"), "face index 0 (OBJ indices start at 1)")),
        r if r > 0 => Ok(r - 1),
        r => {
            let resolved = seen as i64 + r;
            if resolved < 0 {
                return Err(MeshError::parse(
                    path,
                    format!("line {line}"),
                    format!("relative index {r} reaches before the first of {seen} elements"),
                ));
            }
            Ok(resolved)
        }
    }
}

/// Reads an OBJ file's bytes. `folder`: where `mtllib` files are found (the file's folder); with
/// `None` (bytes from the network) materials keep their names only.
pub fn read_obj(bytes: &[u8], path: &Path, folder: Option<&Path>, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        MeshError::parse(path, format!("line {line}"), "not valid UTF-8 text (binary file?)")
    })?;
    let mut obj = ObjReader::new(path, limits);
    for (line_index, raw_line) in text.lines().enumerate() {
        let line = line_index + 1;
        let mut tokens = raw_line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            "v" => {
                limits.check_vertices(obj.positions.len() as u64 + 1, path)?;
                obj.positions.push(parse_floats::<3>(tokens, path, line, "vertex")?);
            }
            "vt" => obj.uvs.push(parse_floats::<2>(tokens, path, line, "texture coordinate")?),
            "vn" => obj.normals.push(parse_floats::<3>(tokens, path, line, "normal")?),
            "f" | "fo" => obj.face(tokens, line)?,
            "usemtl" => obj.use_material(raw_line.trim()["usemtl".len()..].trim()),
            "mtllib" => obj.libraries.push(raw_line.trim()["mtllib".len()..].trim().to_string()),
            _ => {} // o, g, s, l, p, comments: not geometry we keep
        }
    }
    obj.finish(folder)
}

/// What an OBJ file has said so far, as [`read_obj`] reads it line by line.
struct ObjReader<'a> {
    path: &'a Path,
    limits: &'a ReadLimits,
    positions: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    corner_uv: Vec<i64>,
    corner_normal: Vec<i64>,
    uv_corners: usize,
    all_have_normal: bool,
    /// Line of each triangle, to name it when a forward reference turns out to be out of range.
    triangle_lines: Vec<u32>,
    polygon: Vec<Corner>,
    polygon_points: Vec<DVec3>,
    local_triangles: Vec<[usize; 3]>,
    /// `usemtl` names in order of first use, the one in force, and each triangle's.
    material_names: Vec<String>,
    material: u32,
    triangle_materials: Vec<u32>,
    libraries: Vec<String>,
}

impl<'a> ObjReader<'a> {
    /// Nothing read yet of the file `path`.
    fn new(path: &'a Path, limits: &'a ReadLimits) -> ObjReader<'a> {
        ObjReader {
            path,
            limits,
            positions: Vec::new(),
            uvs: Vec::new(),
            normals: Vec::new(),
            triangles: Vec::new(),
            corner_uv: Vec::new(),
            corner_normal: Vec::new(),
            uv_corners: 0,
            all_have_normal: true,
            triangle_lines: Vec::new(),
            polygon: Vec::new(),
            polygon_points: Vec::new(),
            local_triangles: Vec::new(),
            material_names: Vec::new(),
            material: NO_MATERIAL,
            triangle_materials: Vec::new(),
            libraries: Vec::new(),
        }
    }

    /// A `usemtl` statement: the material `name` is in force from here.
    fn use_material(&mut self, name: &str) {
        self.material = match self.material_names.iter().position(|n| n == name) {
            Some(i) => i as u32,
            None => {
                self.material_names.push(name.to_string());
                self.material_names.len() as u32 - 1
            }
        };
    }

    /// An `f` statement on `line`: its corners resolved, the polygon triangulated.
    fn face<'t>(&mut self, tokens: impl Iterator<Item = &'t str>, line: usize) -> Result<(), MeshError> {
        let path = self.path;
        self.polygon.clear();
        for token in tokens {
            let mut parts = token.split('/');
            let position = resolve(parts.next().unwrap_or(""), self.positions.len(), path, line)?;
            let uv = match parts.next() {
                Some("") | None => None,
                Some(t) => Some(resolve(t, self.uvs.len(), path, line)?),
            };
            let normal = match parts.next() {
                Some("") | None => None,
                Some(t) => Some(resolve(t, self.normals.len(), path, line)?),
            };
            self.polygon.push(Corner { position, uv, normal });
        }
        let corners = self.polygon.len();
        if corners < 3 {
            let reason = format!("face has {corners} corners; a face needs at least 3");
            return Err(MeshError::parse(path, format!("line {line}"), reason));
        }
        if corners > super::options::MAX_POLYGON_CORNERS {
            let most = super::options::MAX_POLYGON_CORNERS;
            let reason = format!("face has {corners} corners; at most {most} are accepted");
            return Err(MeshError::parse(path, format!("line {line}"), reason));
        }
        // Checked before triangulating: n corners always make n − 2 triangles.
        self.limits.check_faces((self.triangles.len() + corners - 2) as u64, path)?;
        self.triangulate();
        for t in &self.local_triangles {
            let mut tri = [0u32; 3];
            for (slot, &k) in tri.iter_mut().zip(t) {
                let c = self.polygon[k];
                *slot = u32::try_from(c.position).map_err(|_| {
                    MeshError::parse(path, format!("line {line}"), format!("vertex index {} too large", c.position + 1))
                })?;
                // (A corner without one is marked: see the texture coordinates in `finish`.)
                self.corner_uv.push(c.uv.unwrap_or(NO_VALUE));
                self.uv_corners += c.uv.is_some() as usize;
                match c.normal {
                    Some(i) => self.corner_normal.push(i),
                    None => self.all_have_normal = false,
                }
            }
            self.triangles.push(tri);
            self.triangle_lines.push(line as u32);
            self.triangle_materials.push(self.material);
        }
        Ok(())
    }

    /// The polygon's triangles (as corner numbers) into `local_triangles`.
    fn triangulate(&mut self) {
        self.local_triangles.clear();
        if self.polygon.len() == 3 {
            self.local_triangles.push([0, 1, 2]);
            return;
        }
        // Positions of forward references are unknown yet; such polygons are fanned.
        let known = self.polygon.iter().all(|c| (c.position as usize) < self.positions.len());
        self.polygon_points.clear();
        let positions = &self.positions;
        self.polygon_points.extend(self.polygon.iter().map(|c| {
            if known {
                let p = positions[c.position as usize];
                DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
            } else {
                DVec3::ZERO
            }
        }));
        triangulate_polygon(&self.polygon_points, &mut self.local_triangles);
    }

    /// The mesh, once every line is read: forward references checked, per-corner values looked up,
    /// the materials' library read (`folder`: where its files are).
    fn finish(self, folder: Option<&Path>) -> Result<Mesh, MeshError> {
        let path = self.path;
        let vertex_count = self.positions.len();
        let triangle_lines = &self.triangle_lines;
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(MeshError::parse(
                    path,
                    format!("line {}", triangle_lines[t]),
                    format!("face refers to vertex {} but the file has {vertex_count} vertices", i as u64 + 1),
                ));
            }
        }
        let lookup = |indices: &[i64], table_len: usize, what: &str| -> Result<(), MeshError> {
            if let Some((k, &i)) = indices.iter().enumerate().find(|&(_, &i)| i != NO_VALUE && i as usize >= table_len)
            {
                return Err(MeshError::parse(
                    path,
                    format!("line {}", triangle_lines[k / 3]),
                    format!("face refers to {what} {} but the file has {table_len}", i + 1),
                ));
            }
            Ok(())
        };
        let mut corners = CornerAttributes::default();
        // Texture coordinates on some faces only: the others get zero, as a glTF primitive without
        // them beside one with them does (such a face has no texture to sample; dropping them all
        // would take the texture from the faces that have one).
        if self.uv_corners > 0 {
            lookup(&self.corner_uv, self.uvs.len(), "texture coordinate")?;
            let uvs = &self.uvs;
            corners.set_uvs(Some(
                self.corner_uv.iter().map(|&i| if i == NO_VALUE { [0.0; 2] } else { uvs[i as usize] }).collect(),
            ));
        }
        if self.all_have_normal && !self.triangles.is_empty() {
            lookup(&self.corner_normal, self.normals.len(), "normal")?;
            corners.set_normals(Some(self.corner_normal.iter().map(|&i| self.normals[i as usize]).collect()));
        }
        // Normals on some faces and not on others are left out (faces without them are drawn flat,
        // which per-corner values could hold but the simplifier could then not move), and said (the
        // warnings of every command that writes a result).
        let corner_count = 3 * self.triangles.len();
        let partial = !self.all_have_normal && !self.corner_normal.is_empty();
        let not_carried: Vec<String> = partial
            .then(|| format!("normals (given at {} of {corner_count} face corners)", self.corner_normal.len()))
            .into_iter()
            .collect();
        if !self.material_names.is_empty() || !not_carried.is_empty() {
            let mut library = super::mtl::library(&self.material_names, &self.libraries, folder);
            library.not_carried = not_carried;
            if !self.material_names.is_empty() {
                corners.set_materials(Some(self.triangle_materials.iter().flat_map(|&m| [m; 3]).collect()));
            }
            corners.library = Some(std::sync::Arc::new(library));
        }
        let mut mesh = Mesh { positions: self.positions, triangles: self.triangles, corners };
        if !mesh.corners.is_empty() {
            // Exporters that write one `v` per combination of values (trimesh, as glTF and PLY store
            // them) cut the surface open along every seam: joined again, a seam is a seam, which the
            // simplifier moves both sides of together, not two borders it would move apart (a crack).
            mesh.join_cut_seams();
        }
        debug_assert!(mesh.check().is_ok());
        Ok(mesh)
    }
}

/// Writes positions and triangles as OBJ (1-based indices), with the texture coordinates (`vt`)
/// and normals (`vn`) the mesh carries per corner, each distinct value written once and the faces
/// as `v/vt/vn`. Floats use the shortest representation that reads back to the same `f32`, so a
/// write/read round trip is exact. Colours have no OBJ form and are not written. Materials are
/// named by `usemtl`; their MTL file is written only beside a file ([`super::write_mesh`]).
pub fn write_obj(out: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    write_obj_with_library(out, mesh, None)
}

/// The codec's writer: [`write_obj`], and when the target is a file and the mesh has materials,
/// their MTL file beside it (`OUT.mtl`, named by `mtllib`) with their textures.
pub(super) fn write_obj_to(mut out: &mut dyn Write, mesh: &Mesh, target: &Target) -> std::io::Result<()> {
    if let (Some(path), Some(_), Some(library)) = (target.path, &mesh.corners.materials(), &mesh.corners.library)
        && !library.materials.is_empty()
    {
        let mtl = path.with_extension("mtl");
        super::mtl::write_library(&mtl, library)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", mtl.display())))?;
        let name = mtl.file_name().map(|n| n.to_string_lossy().into_owned());
        return write_obj_with_library(&mut out, mesh, name.as_deref());
    }
    write_obj_with_library(&mut out, mesh, None)
}

/// [`write_obj`], the materials' MTL file named by `mtllib` when given.
pub(super) fn write_obj_with_library(out: &mut impl Write, mesh: &Mesh, mtllib: Option<&str>) -> std::io::Result<()> {
    writeln!(out, "# meshlod: {} vertices, {} triangles", mesh.vertex_count(), mesh.face_count())?;
    if let Some(name) = mtllib {
        writeln!(out, "mtllib {name}")?;
    }
    for p in &mesh.positions {
        writeln!(out, "v {} {} {}", p[0], p[1], p[2])?;
    }
    // Each distinct value once, numbered in order of first use.
    fn table<const N: usize>(values: Option<&[[f32; N]]>) -> Option<(Vec<[f32; N]>, Vec<u32>)> {
        let values = values?;
        let mut seen: HashMap<[u32; N], u32> = HashMap::new();
        let mut distinct = Vec::new();
        let index = values
            .iter()
            .map(|v| {
                *seen.entry(v.map(f32::to_bits)).or_insert_with(|| {
                    distinct.push(*v);
                    distinct.len() as u32 - 1
                })
            })
            .collect();
        Some((distinct, index))
    }
    let uvs = table(mesh.corners.uvs_with_origin(false).as_deref());
    let normals = table(mesh.corners.normals().map(Vec::as_slice));
    for uv in uvs.iter().flat_map(|(d, _)| d) {
        writeln!(out, "vt {} {}", uv[0], uv[1])?;
    }
    for n in normals.iter().flat_map(|(d, _)| d) {
        writeln!(out, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    let mut material = NO_MATERIAL;
    for (f, t) in mesh.triangles.iter().enumerate() {
        if let (Some(materials), Some(library)) = (&mesh.corners.materials(), &mesh.corners.library)
            && materials[3 * f] != material
            && materials[3 * f] != NO_MATERIAL
        {
            material = materials[3 * f];
            writeln!(out, "usemtl {}", super::mtl::one_line(&library.material_name(material)))?;
        }
        write!(out, "f")?;
        for (k, &v) in t.iter().enumerate() {
            let c = 3 * f + k;
            match (&uvs, &normals) {
                (None, None) => write!(out, " {}", v + 1)?,
                (Some((_, u)), None) => write!(out, " {}/{}", v + 1, u[c] + 1)?,
                (None, Some((_, n))) => write!(out, " {}//{}", v + 1, n[c] + 1)?,
                (Some((_, u)), Some((_, n))) => write!(out, " {}/{}/{}", v + 1, u[c] + 1, n[c] + 1)?,
            }
        }
        writeln!(out)?;
    }
    Ok(())
}
