//! STL reader (binary and ascii).
//!
//! STL stores a triangle soup: every facet repeats its three corner positions. The reader welds
//! corners with bit-identical positions (after folding −0 into +0) into one vertex, which gives
//! back the connectivity the exporter had, so the simplifier sees a surface rather than loose
//! triangles. Facet normals are not kept (they follow from the corners).
//!
//! Binary or ascii is decided by size first: a binary file is exactly 84 + 50 · n bytes for the n
//! facets its header counts. Many binary files also begin with the word `solid`, so that word alone
//! does not make a file ascii.

use std::collections::HashMap;
use std::path::Path;

use super::options::ReadLimits;
use crate::error::MeshError;
use crate::mesh::Mesh;

const HEADER: usize = 80;
const FACET: usize = 50;

/// Whether the bytes are a binary STL: 84 + 50 · n bytes for the n its header counts.
pub(crate) fn is_binary(bytes: &[u8]) -> bool {
    bytes.len() >= HEADER + 4
        && binary_count(bytes).is_some_and(|n| (HEADER + 4) as u64 + FACET as u64 * n as u64 == bytes.len() as u64)
}

/// Whether the bytes look like an ascii STL: `solid`, then `facet` or `endsolid`, in a first 4 KiB
/// that is text (a character cut at the window's end aside).
pub(crate) fn is_ascii(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    let text = match std::str::from_utf8(head) {
        Ok(_) => true,
        Err(e) => e.error_len().is_none(),
    };
    text && head.trim_ascii_start().starts_with(b"solid") && head.windows(5).any(|w| w == b"facet" || w == b"endso")
}

fn binary_count(bytes: &[u8]) -> Option<u32> {
    bytes.get(HEADER..HEADER + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Welds facet corners by position into a mesh.
struct Welder {
    index: HashMap<[u32; 3], u32>,
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

impl Welder {
    fn new(facets: usize) -> Welder {
        // A closed surface has about half as many vertices as facets.
        Welder {
            index: HashMap::with_capacity(facets / 2 + 1),
            positions: Vec::with_capacity(facets / 2 + 1),
            triangles: Vec::with_capacity(facets),
        }
    }

    fn vertex(&mut self, p: [f32; 3], limits: &ReadLimits, path: &Path) -> Result<u32, MeshError> {
        // −0 and +0 are the same point.
        let p = p.map(|c| c + 0.0);
        let next = self.positions.len() as u32;
        let v = *self.index.entry(p.map(f32::to_bits)).or_insert(next);
        if v == next {
            limits.check_vertices(next as u64 + 1, path)?;
            self.positions.push(p);
        }
        Ok(v)
    }

    fn facet(&mut self, corners: [[f32; 3]; 3], limits: &ReadLimits, path: &Path) -> Result<(), MeshError> {
        limits.check_faces(self.triangles.len() as u64 + 1, path)?;
        let t = [
            self.vertex(corners[0], limits, path)?,
            self.vertex(corners[1], limits, path)?,
            self.vertex(corners[2], limits, path)?,
        ];
        self.triangles.push(t);
        Ok(())
    }

    fn finish(self) -> Result<Mesh, MeshError> {
        Mesh::new(self.positions, self.triangles)
    }
}

fn finite(p: [f32; 3], path: &Path, facet: usize) -> Result<[f32; 3], MeshError> {
    match p.iter().find(|c| !c.is_finite()) {
        Some(c) => Err(MeshError::parse(path, format!("facet {facet}"), format!("non-finite coordinate {c}"))),
        None => Ok(p),
    }
}

/// Reads an STL file's bytes (binary or ascii).
pub fn read_stl(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    if is_binary(bytes) {
        return read_binary(bytes, path, limits);
    }
    if is_ascii(bytes) {
        return read_ascii(bytes, path, limits);
    }
    match binary_count(bytes) {
        None => {
            Err(MeshError::parse(path, "header", format!("{} bytes: shorter than an STL header (84)", bytes.len())))
        }
        Some(n) => Err(MeshError::parse(
            path,
            "header",
            format!(
                "not ascii STL, and as binary STL the header counts {n} facets ({} bytes) but the file has {} bytes",
                (HEADER + 4) as u64 + FACET as u64 * n as u64,
                bytes.len()
            ),
        )),
    }
}

fn read_binary(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let count = binary_count(bytes).expect("checked") as usize;
    limits.check_faces(count as u64, path)?;
    let mut welder = Welder::new(count);
    for (facet, record) in bytes[HEADER + 4..].chunks_exact(FACET).enumerate() {
        let float = |k: usize| {
            let at = 12 + 4 * k;
            f32::from_le_bytes([record[at], record[at + 1], record[at + 2], record[at + 3]])
        };
        let corner = |c: usize| finite([float(3 * c), float(3 * c + 1), float(3 * c + 2)], path, facet);
        welder.facet([corner(0)?, corner(1)?, corner(2)?], limits, path)?;
    }
    welder.finish()
}

fn read_ascii(bytes: &[u8], path: &Path, limits: &ReadLimits) -> Result<Mesh, MeshError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        MeshError::parse(path, format!("line {line}"), "not valid UTF-8 text")
    })?;
    let mut welder = Welder::new(0);
    let mut corners: Vec<[f32; 3]> = Vec::with_capacity(3);
    let mut in_loop = false;
    let mut facets_open = 0usize;
    for (i, line) in text.lines().enumerate() {
        let at = || format!("line {}", i + 1);
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else { continue };
        match keyword {
            "solid" | "endsolid" | "facet" => {
                if keyword == "facet" {
                    facets_open += 1;
                }
            }
            "outer" => {
                if in_loop {
                    return Err(MeshError::parse(path, at(), "'outer loop' inside a loop"));
                }
                in_loop = true;
                corners.clear();
            }
            "vertex" => {
                if !in_loop {
                    return Err(MeshError::parse(path, at(), "'vertex' outside 'outer loop'"));
                }
                let mut p = [0f32; 3];
                for (k, slot) in p.iter_mut().enumerate() {
                    let token = tokens
                        .next()
                        .ok_or_else(|| MeshError::parse(path, at(), format!("vertex needs 3 numbers, found {k}")))?;
                    *slot = token
                        .parse()
                        .map_err(|_| MeshError::parse(path, at(), format!("vertex: '{token}' is not a number")))?;
                }
                if corners.len() == 3 {
                    return Err(MeshError::parse(path, at(), "a facet with more than 3 vertices"));
                }
                corners.push(finite(p, path, welder.triangles.len()).map_err(|_| {
                    MeshError::parse(path, at(), format!("vertex has a non-finite coordinate: {line}"))
                })?);
            }
            "endloop" => {
                if !in_loop {
                    return Err(MeshError::parse(path, at(), "'endloop' without 'outer loop'"));
                }
                if corners.len() != 3 {
                    return Err(MeshError::parse(
                        path,
                        at(),
                        format!("a facet with {} vertices; STL needs 3", corners.len()),
                    ));
                }
                welder.facet([corners[0], corners[1], corners[2]], limits, path)?;
                in_loop = false;
            }
            "endfacet" => facets_open = facets_open.saturating_sub(1),
            other => {
                return Err(MeshError::parse(path, at(), format!("unexpected '{other}' in ascii STL")));
            }
        }
    }
    if in_loop || facets_open > 0 {
        return Err(MeshError::parse(path, "end of file", "truncated: the last facet is not closed"));
    }
    welder.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(facets: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut bytes = b"solid but binary".to_vec();
        bytes.resize(HEADER, 0);
        bytes.extend_from_slice(&(facets.len() as u32).to_le_bytes());
        for f in facets {
            bytes.extend_from_slice(&[0u8; 12]);
            for c in f.iter().flatten() {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
            bytes.extend_from_slice(&[0, 0]);
        }
        bytes
    }

    const TETRA: [[[f32; 3]; 3]; 4] = [
        [[0., 0., 0.], [0., 1., 0.], [1., 0., 0.]],
        [[0., 0., 0.], [1., 0., 0.], [0., 0., 1.]],
        [[0., 0., 0.], [0., 0., 1.], [0., 1., 0.]],
        [[1., 0., 0.], [0., 1., 0.], [-0., 0., 1.]],
    ];

    #[test]
    fn binary_facets_are_welded_into_a_closed_surface() {
        let mesh = read_stl(&binary(&TETRA), Path::new("t.stl"), &ReadLimits::default()).unwrap();
        assert_eq!((mesh.vertex_count(), mesh.face_count()), (4, 4));
        let report = crate::validate::validate(&mesh);
        assert!(report.is_manifold_oriented && report.boundary_edges == 0, "{report:?}");
    }

    #[test]
    fn ascii_is_read_and_agrees_with_binary() {
        let mut text = String::from("solid tetra\n");
        for f in TETRA {
            text += "  facet normal 0 0 0\n    outer loop\n";
            for c in f {
                text += &format!("      vertex {} {} {}\n", c[0], c[1], c[2]);
            }
            text += "    endloop\n  endfacet\n";
        }
        text += "endsolid tetra\n";
        let a = read_stl(text.as_bytes(), Path::new("t.stl"), &ReadLimits::default()).unwrap();
        let b = read_stl(&binary(&TETRA), Path::new("t.stl"), &ReadLimits::default()).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn lying_truncated_and_broken_files_are_refused_by_name() {
        let path = Path::new("bad.stl");
        let limits = ReadLimits::default();
        let mut lying = binary(&TETRA);
        lying[HEADER..HEADER + 4].copy_from_slice(&1000u32.to_le_bytes());
        let err = read_stl(&lying, path, &limits).unwrap_err().to_string();
        assert!(err.contains("1000 facets") && err.contains("bad.stl"), "{err}");
        let truncated = &binary(&TETRA)[..150];
        assert!(read_stl(truncated, path, &limits).unwrap_err().to_string().contains("header counts 4 facets"));
        assert!(read_stl(b"short", path, &limits).unwrap_err().to_string().contains("shorter than an STL header"));

        let mut nan = TETRA;
        nan[2][1][0] = f32::NAN;
        let err = read_stl(&binary(&nan), path, &limits).unwrap_err().to_string();
        assert!(err.contains("facet 2") && err.contains("non-finite"), "{err}");

        let open = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n";
        assert!(read_stl(open.as_bytes(), path, &limits).unwrap_err().to_string().contains("truncated"));
        let quad = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n";
        assert!(read_stl(quad.as_bytes(), path, &limits).unwrap_err().to_string().contains("line 7"));
        let word = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zero\n";
        assert!(read_stl(word.as_bytes(), path, &limits).unwrap_err().to_string().contains("'zero' is not a number"));
    }

    #[test]
    fn limits_apply_before_reading_the_facets() {
        let limits = ReadLimits { max_faces: 3, ..ReadLimits::default() };
        let err = read_stl(&binary(&TETRA), Path::new("t.stl"), &limits).unwrap_err();
        assert!(matches!(err, MeshError::TooLarge { what: "faces", count: 4, limit: 3, .. }), "{err}");
        let limits = ReadLimits { max_vertices: 3, ..ReadLimits::default() };
        let err = read_stl(&binary(&TETRA), Path::new("t.stl"), &limits).unwrap_err();
        assert!(matches!(err, MeshError::TooLarge { what: "vertices", .. }), "{err}");
    }
}
