//! Helpers shared by the test crates (each uses some of them).
#![allow(dead_code)]

use std::path::Path;

pub mod invariants;

use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes};
use meshlod_engine::{Mesh, MeshError};

pub fn obj(text: &str) -> Result<Mesh, MeshError> {
    read_mesh_bytes(text.as_bytes(), Some(MeshFormat::Obj), Path::new("test.obj"), &ReadLimits::default())
}

pub fn ply(bytes: &[u8]) -> Result<Mesh, MeshError> {
    read_mesh_bytes(bytes, Some(MeshFormat::Ply), Path::new("test.ply"), &ReadLimits::default())
}

/// Asserts a parse error at `location` whose reason contains `needle`.
pub fn assert_parse_error(result: Result<Mesh, MeshError>, location: &str, needle: &str) {
    match result {
        Err(MeshError::Parse { location: loc, reason, path }) => {
            assert_eq!(loc, location, "reason was: {reason}");
            assert!(reason.contains(needle), "reason '{reason}' lacks '{needle}'");
            assert!(path.to_string_lossy().starts_with("test."), "error must name the file");
        }
        other => panic!("expected parse error at {location}, got {other:?}"),
    }
}

/// `bin` as a glTF buffer's data URI (base64, embedded).
pub fn data_uri(bin: &[u8]) -> String {
    use base64::Engine as _;
    format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bin))
}

/// A glTF document read as if from the file `name`.
pub fn read_gltf(json: &str, name: &str) -> Result<Mesh, MeshError> {
    read_mesh_bytes(json.as_bytes(), Some(MeshFormat::Gltf), Path::new(name), &ReadLimits::default())
}

pub fn tempdir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("meshlod-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `pm` in the compact form and checks what comes back: every level has the same faces,
/// positions within half a grid step, texture coordinates and colours within half theirs, normals
/// within 0.1° and the same materials; writing it again gives the same bytes; any cut is
/// refused. Returns the bytes per split, the materials section (with its images) left out.
pub fn assert_compact_round_trip(name: &str, pm: &meshlod_engine::pm::ProgressiveMesh) -> f64 {
    use meshlod_engine::pm_format::{decode, encode, encode_on};
    let bytes = encode(pm);
    assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 3, "{name}: the compact form is version 3");
    let (back, q) = decode(&bytes, Path::new("compact.pm")).unwrap_or_else(|e| panic!("{name}: {e}"));
    let q = q.expect("read from a compact file");
    assert_eq!(back.levels(), pm.levels(), "{name}");
    assert_eq!(encode_on(&back, &q), bytes, "{name}: written again on its grids, the same bytes");
    // Half a step, plus the rounding of grid values to f32s.
    let close = |a: f32, b: f32, step: f32| {
        ((a as f64) - (b as f64)).abs() <= 0.505 * step as f64 + 4.0 * f32::EPSILON as f64 * a.abs().max(b.abs()) as f64
    };
    let (mut a_cursor, mut b_cursor) = (pm.cursor(), back.cursor());
    let levels = pm.levels();
    for level in [0, 1.min(levels), levels / 3, 2 * levels / 3, levels, levels / 2] {
        a_cursor.seek_level(level).unwrap();
        b_cursor.seek_level(level).unwrap();
        let (a, b) = (a_cursor.mesh(), b_cursor.mesh());
        assert_eq!(a.triangles, b.triangles, "{name}: level {level} faces");
        for (p, r) in a.positions.iter().zip(&b.positions) {
            for k in 0..3 {
                assert!(close(p[k], r[k], q.positions.step[k]), "{name}: level {level} position {p:?} → {r:?}");
            }
        }
        let (x, y) = (&a.corners, &b.corners);
        assert_eq!(x.names(), y.names(), "{name}: level {level}");
        assert_eq!(x.materials(), y.materials(), "{name}: level {level} materials");
        assert_eq!(x.uv_origin_top, y.uv_origin_top, "{name}");
        if let (Some(u), Some(v), Some(g)) = (x.uvs(), y.uvs(), &q.uvs) {
            for (s, t) in u.iter().zip(v) {
                assert!(close(s[0], t[0], g.step[0]) && close(s[1], t[1], g.step[1]), "{name}: uv {s:?} → {t:?}");
            }
        }
        if let (Some(u), Some(v), Some(g)) = (x.uvs1(), y.uvs1(), &q.uvs1) {
            for (s, t) in u.iter().zip(v) {
                assert!(close(s[0], t[0], g.step[0]) && close(s[1], t[1], g.step[1]), "{name}: uv1 {s:?} → {t:?}");
            }
        }
        if let (Some(c), Some(d), Some(g)) = (x.colors(), y.colors(), &q.colors) {
            for (s, t) in c.iter().zip(d) {
                assert!((0..4).all(|k| close(s[k], t[k], g.step[k])), "{name}: colour {s:?} → {t:?}");
            }
        }
        // Skins: weights within a 255th, normalised, the joints of every weight kept.
        if let (Some(jx), Some(wx), Some(jy), Some(wy)) = (x.joints(), x.weights(), y.joints(), y.weights()) {
            for k in 0..jx.len() {
                let total: f32 = wx[k].iter().sum();
                assert!((wy[k].iter().sum::<f32>() - 1.0).abs() < 1e-5, "{name}: weights {:?}", wy[k]);
                for i in 0..4 {
                    assert!((wx[k][i] / total - wy[k][i]).abs() <= 1.0 / 255.0 + 1e-6, "{name}: {wx:?} → {wy:?}");
                    assert!(wy[k][i] == 0.0 || jx[k][i] == jy[k][i], "{name}: joints {:?} → {:?}", jx[k], jy[k]);
                }
            }
        }
        if let (Some(t), Some(u)) = (x.tangents(), y.tangents()) {
            for (s, r) in t.iter().zip(u) {
                let length = (s[..3].iter().map(|c| (*c as f64).powi(2)).sum::<f64>()).sqrt();
                assert_eq!(s[3] < 0.0, r[3] < 0.0, "{name}: tangent handedness {s:?} → {r:?}");
                if length < 1e-6 {
                    continue;
                }
                let dot = (0..3).map(|k| s[k] as f64 * r[k] as f64).sum::<f64>() / length;
                assert!(dot.min(1.0).acos().to_degrees() <= 0.1, "{name}: tangent {s:?} → {r:?}");
            }
        }
        if let (Some(n), Some(m)) = (x.normals(), y.normals()) {
            for (s, t) in n.iter().zip(m) {
                let length = (s.iter().map(|c| (*c as f64).powi(2)).sum::<f64>()).sqrt();
                if length < 1e-6 {
                    continue;
                }
                let dot = s.iter().zip(t).map(|(a, b)| *a as f64 * *b as f64).sum::<f64>() / length;
                assert!(dot.min(1.0).acos().to_degrees() <= 0.1, "{name}: normal {s:?} → {t:?}");
            }
        }
    }
    for cut in [bytes.len() - 1, bytes.len() - 9, bytes.len() / 2, 30] {
        assert!(decode(&bytes[..cut], Path::new("cut.pm")).is_err(), "{name}: cut at {cut} was read");
    }
    let records = bytes.len() - meshlod_engine::pm_format::materials_section_len(pm);
    (records as f64) / (pm.levels().max(1) as f64)
}

/// The pieces of the graph of boundary edges (edges with one face), and whether some vertex has
/// more than two boundary edges (pinches the boundary).
pub fn boundary_graph(mesh: &Mesh) -> (usize, bool) {
    let topology = meshlod_engine::topology::Topology::new(mesh);
    let mut sets = meshlod_engine::topology::UnionFind::new(mesh.vertex_count());
    let mut degree = vec![0u32; mesh.vertex_count()];
    for (e, &[a, b]) in topology.edges.iter().enumerate() {
        if topology.edge_faces.get(e).len() == 1 {
            sets.union(a, b);
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
    }
    let mut roots: Vec<u32> =
        (0..mesh.vertex_count() as u32).filter(|&v| degree[v as usize] > 0).map(|v| sets.find(v)).collect();
    roots.sort_unstable();
    roots.dedup();
    (roots.len(), degree.iter().any(|&d| d > 2))
}
