//! OFF (Object File Format) reader, ascii.
//!
//! Header keyword `[ST][C][N]OFF` (the prefixes announce per-vertex texture coordinates, colours
//! and normals after x y z; only the positions are kept), then `vertices faces edges` (on the
//! keyword's line or the next), the vertices one per line, and the faces one per line as
//! `n i₁ … iₙ` with optional colour values after the indices. `#` starts a comment. Polygons are
//! triangulated as in OBJ and PLY. Binary OFF and the 4D / nD variants are refused by name.

use std::path::Path;

use super::options::ReadLimits;
use super::triangulate::triangulate_face;
use crate::error::MeshError;
use crate::mesh::Mesh;

/// Whether the bytes begin with an OFF keyword.
pub(crate) fn is_off(bytes: &[u8]) -> bool {
    let head = bytes.trim_ascii_start();
    let word = head.split(|b| b.is_ascii_whitespace()).next().unwrap_or(b"");
    word.ends_with(b"OFF") && word[..word.len() - 3].iter().all(|b| b"STCN4n".contains(b))
}

/// Reads an ascii OFF file's bytes.
pub fn read_off(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        MeshError::parse(path, format!("line {line}"), "not valid UTF-8 text (binary OFF is not supported)")
    })?;
    // Lines with their numbers, comments and blank lines left out.
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());

    let (vertex_count, face_count) = read_header(&mut lines, path)?;
    limits.check_vertices(vertex_count, path)?;
    limits.check_faces(face_count, path)?;

    // Reserve no more than the text could hold: a vertex line has at least 6 bytes.
    let positions = read_vertices(&mut lines, vertex_count, bytes.len() / 6, path, limits)?;

    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity((face_count as usize).min(bytes.len() / 8));
    let (mut indices, mut local, mut points) = (Vec::new(), Vec::new(), Vec::new());
    for f in 0..face_count {
        let (n, l) = lines
            .next()
            .ok_or_else(|| MeshError::parse(path, "end of file", format!("truncated: {f} of {face_count} faces")))?;
        let at = || format!("line {n}");
        let mut tokens = l.split_ascii_whitespace();
        let corners: usize = tokens
            .next()
            .expect("line is not empty")
            .parse()
            .map_err(|_| MeshError::parse(path, at(), format!("face {f}: the corner count is not a count")))?;
        if corners < 3 {
            return Err(MeshError::parse(
                path,
                at(),
                format!("face {f} has {corners} corners; a face needs at least 3"),
            ));
        }
        if corners > super::options::MAX_POLYGON_CORNERS {
            return Err(MeshError::parse(
                path,
                at(),
                format!("face {f} has {corners} corners; at most {} are accepted", super::options::MAX_POLYGON_CORNERS),
            ));
        }
        // n corners make n − 2 triangles: checked before any work on them.
        limits.check_faces((triangles.len() + corners - 2) as u64, path)?;
        indices.clear();
        for k in 0..corners {
            let token = tokens.next().ok_or_else(|| {
                MeshError::parse(path, at(), format!("face {f} announces {corners} corners but lists {k}"))
            })?;
            let v: u64 = token.parse().map_err(|_| {
                MeshError::parse(path, at(), format!("face {f}: index '{token}' is not a vertex index"))
            })?;
            if v >= positions.len() as u64 {
                return Err(MeshError::parse(
                    path,
                    at(),
                    format!("face {f} refers to vertex {v} but the file has {} vertices", positions.len()),
                ));
            }
            indices.push(v as u32);
        }
        triangulate_face(indices.iter().map(|&v| positions[v as usize]), &mut points, &mut local);
        triangles.extend(local.iter().map(|t| [indices[t[0]], indices[t[1]], indices[t[2]]]));
        if f % 4096 == 0 {
            limits.check_cancel()?;
        }
    }
    Mesh::new(positions, triangles)
}

/// The header: the OFF keyword (4D, nD and binary OFF refused by name) and the vertex and face
/// counts, on its line or the next.
fn read_header<'a>(lines: &mut impl Iterator<Item = (usize, &'a str)>, path: &Path) -> Result<(u64, u64), MeshError> {
    let (first, header) = lines.next().ok_or_else(|| MeshError::parse(path, "header", "empty file"))?;
    let mut tokens = header.split_ascii_whitespace();
    let keyword = tokens.next().expect("line is not empty");
    if !keyword.ends_with("OFF") || !keyword[..keyword.len() - 3].chars().all(|c| "STCN".contains(c)) {
        let reason = if keyword.contains('4') || keyword.contains('n') {
            format!("'{keyword}': 4D and nD OFF are not supported")
        } else {
            format!("'{keyword}' is not an OFF keyword")
        };
        return Err(MeshError::parse(path, format!("line {first}"), reason));
    }
    let mut rest: Vec<&str> = tokens.collect();
    if rest.first() == Some(&"BINARY") {
        return Err(MeshError::parse(path, format!("line {first}"), "binary OFF is not supported"));
    }
    let mut counts_line = first;
    if rest.is_empty() {
        let (n, l) = lines.next().ok_or_else(|| MeshError::parse(path, "header", "no 'vertices faces edges' line"))?;
        counts_line = n;
        rest = l.split_ascii_whitespace().collect();
    }
    let count = |k: usize, what: &str| -> Result<u64, MeshError> {
        let token = rest.get(k).ok_or_else(|| {
            MeshError::parse(path, format!("line {counts_line}"), format!("the counts line has no {what} count"))
        })?;
        token.parse().map_err(|_| {
            MeshError::parse(path, format!("line {counts_line}"), format!("{what} count '{token}' is not a count"))
        })
    };
    Ok((count(0, "vertex")?, count(1, "face")?))
}

/// The `vertex_count` vertex lines that follow the header (`room`: the most the text could hold).
fn read_vertices<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    vertex_count: u64,
    room: usize,
    path: &Path,
    limits: &ReadLimits,
) -> Result<Vec<[f32; 3]>, MeshError> {
    let mut positions: Vec<[f32; 3]> = Vec::with_capacity((vertex_count as usize).min(room));
    for v in 0..vertex_count {
        let (n, l) = lines.next().ok_or_else(|| {
            MeshError::parse(path, "end of file", format!("truncated: {v} of {vertex_count} vertices"))
        })?;
        let mut p = [0f32; 3];
        let mut tokens = l.split_ascii_whitespace();
        for (k, slot) in p.iter_mut().enumerate() {
            let token = tokens.next().ok_or_else(|| {
                MeshError::parse(path, format!("line {n}"), format!("vertex {v} needs 3 numbers, found {k}"))
            })?;
            *slot = token.parse().map_err(|_| {
                MeshError::parse(path, format!("line {n}"), format!("vertex {v}: '{token}' is not a number"))
            })?;
            if !slot.is_finite() {
                return Err(MeshError::parse(
                    path,
                    format!("line {n}"),
                    format!("vertex {v} has a non-finite coordinate"),
                ));
            }
        }
        if v % 4096 == 0 {
            limits.check_cancel()?;
        }
        positions.push(p);
    }
    Ok(positions)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE: &str = "OFF\n# a cube of quads\n8 6 12\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n\
        4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3 255 0 0\n";

    #[test]
    fn quads_are_triangulated_into_a_closed_cube() {
        let mesh = read_off(CUBE.as_bytes(), Path::new("cube.off"), &ReadLimits::default()).unwrap();
        assert_eq!((mesh.vertex_count(), mesh.face_count()), (8, 12));
        let report = crate::validate::validate(&mesh);
        assert!(report.is_manifold_oriented && report.boundary_edges == 0, "{report:?}");
        // Counts on the keyword's line, and the colour and normal prefixes, read the same.
        let inline = CUBE.replacen("OFF\n# a cube of quads\n8 6 12", "OFF 8 6 12", 1);
        assert_eq!(read_off(inline.as_bytes(), Path::new("c.off"), &ReadLimits::default()).unwrap(), mesh);
        let coloured = CUBE.replacen("OFF", "COFF", 1).replace("\n0 0 0\n", "\n0 0 0 1 1 1 1\n");
        assert_eq!(read_off(coloured.as_bytes(), Path::new("c.off"), &ReadLimits::default()).unwrap(), mesh);
    }

    #[test]
    fn bad_files_are_refused_by_name() {
        let path = Path::new("bad.off");
        let limits = ReadLimits::default();
        let err = |text: &str| read_off(text.as_bytes(), path, &limits).unwrap_err().to_string();
        assert!(err("OFF\n3 1 0\n0 0 0\n1 0 0\n").contains("truncated: 2 of 3 vertices"));
        assert!(err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n").contains("truncated: 0 of 1 faces"));
        assert!(err("OFF\n3 1 0\n0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n").contains("vertex 1 has a non-finite"));
        let e = err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
        assert!(e.contains("line 6") && e.contains("vertex 7 but the file has 3"), "{e}");
        assert!(err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n").contains("announces 4 corners but lists 3"));
        assert!(err("OFF BINARY\n").contains("binary OFF"));
        assert!(err("4OFF\n1 0 0\n").contains("4D and nD"));
        assert!(err("OFF\nmany 1 0\n").contains("vertex count 'many'"));
        let huge = ReadLimits { max_vertices: 10, ..ReadLimits::default() };
        let e = read_off(b"OFF\n4000000000 1 0\n", path, &huge).unwrap_err();
        assert!(matches!(e, MeshError::TooLarge { what: "vertices", .. }), "{e}");
    }

    #[test]
    fn the_keyword_is_recognised() {
        assert!(is_off(b"OFF\n") && is_off(b"  COFF 3 1 0") && is_off(b"STCNOFF\n"));
        assert!(!is_off(b"solid x") && !is_off(b"v 0 0 0\n") && !is_off(b"OFFSET"));
    }
}
