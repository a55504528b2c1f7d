//! Readers and writers: round trips, every refusal case with its error, real files.

use std::path::Path;

use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh, read_mesh_bytes, write_mesh, write_mesh_to};
use meshlod_engine::{MeshError, procedural};

mod common;
use common::{assert_parse_error, data_uri, obj, ply, read_gltf, tempdir};

const SQUARE_OBJ: &str = "# square\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

#[test]
fn obj_reads_polygons_negative_indices_and_corner_attributes() {
    let m = obj(SQUARE_OBJ).unwrap();
    assert_eq!(m.vertex_count(), 4);
    assert_eq!(m.face_count(), 2);
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\nf -3/1/1 -2/2/1 -1/3/1\n";
    let m = obj(text).unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2]]);
    assert_eq!(m.corners.uvs().unwrap()[2], [1.0, 1.0]);
    assert_eq!(m.corners.normals().unwrap().len(), 3);
    // Unreferenced vertices keep their place: the file's numbering is the mesh's numbering.
    let m = obj("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 3 4\n").unwrap();
    assert_eq!(m.vertex_count(), 4);
    assert_eq!(m.triangles, vec![[1, 2, 3]]);
}

#[test]
fn obj_refusals_name_the_line() {
    assert_parse_error(obj("v 0 0 0\nv nan 0 0\n"), "line 2", "non-finite");
    assert_parse_error(obj("v 0 0 inf\n"), "line 1", "non-finite");
    assert_parse_error(obj("v 0 0\n"), "line 1", "needs 3 numbers");
    assert_parse_error(obj("v 0 zero 0\n"), "line 1", "not a number");
    assert_parse_error(obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n"), "line 4", "vertex 99");
    assert_parse_error(obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), "line 4", "index 0");
    assert_parse_error(obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n"), "line 4", "before the first");
    assert_parse_error(obj("v 0 0 0\nv 1 0 0\nf 1 2\n"), "line 3", "at least 3");
    assert_parse_error(obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/4 2/4 3/4\nvt 0 0\n"), "line 4", "texture coordinate 4");
    let binary = [0xffu8, 0xfe, 0x00, b'\n'];
    assert!(matches!(
        read_mesh_bytes(&binary, Some(MeshFormat::Obj), Path::new("test.obj"), &ReadLimits::default()),
        Err(MeshError::Parse { .. })
    ));
}

#[test]
fn obj_limits_are_enforced() {
    let limits = ReadLimits { max_vertices: 3, max_faces: 1, cancel: None };
    let r = read_mesh_bytes(SQUARE_OBJ.as_bytes(), Some(MeshFormat::Obj), Path::new("t.obj"), &limits);
    assert!(matches!(r, Err(MeshError::TooLarge { what: "vertices", count: 4, limit: 3, .. })), "{r:?}");
    // The message names the file, as every other read error does.
    let message = r.unwrap_err().to_string();
    assert_eq!(message, "t.obj: mesh too large: 4 vertices exceeds the limit of 3");
    let limits = ReadLimits { max_vertices: 10, max_faces: 1, cancel: None };
    let r = read_mesh_bytes(SQUARE_OBJ.as_bytes(), Some(MeshFormat::Obj), Path::new("t.obj"), &limits);
    assert!(matches!(r, Err(MeshError::TooLarge { what: "faces", .. })), "{r:?}");
}

fn ply_header(format: &str, vertex_props: &str, vertices: u64, face_prop: &str, faces: u64) -> Vec<u8> {
    format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {vertices}\n{vertex_props}element face {faces}\n{face_prop}end_header\n"
    )
    .into_bytes()
}

#[test]
fn ply_ascii_with_extra_properties_elements_and_polygons() {
    let mut bytes = ply_header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty list uchar int extra\n",
        4,
        "property list uchar int vertex_indices\nproperty float quality\n",
        1,
    );
    bytes.extend_from_slice(b"0 0 0 255 0\n1 0 0 255 2 7 8\n1 1 0 0 0\n0 1 0 1 1 5\n4 0 1 2 3 0.5\n");
    let m = ply(&bytes).unwrap();
    assert_eq!(m.vertex_count(), 4);
    assert_eq!(m.face_count(), 2);
    assert_eq!(m.positions[2], [1.0, 1.0, 0.0]);
}

fn binary_triangle(big_endian: bool, double: bool, count_type: &str) -> Vec<u8> {
    let format = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
    let ty = if double { "double" } else { "float" };
    let mut bytes = ply_header(
        format,
        &format!("property {ty} x\nproperty {ty} y\nproperty {ty} z\nproperty short flags\n"),
        3,
        &format!("property list {count_type} uint vertex_indices\n"),
        1,
    );
    let coords: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0, 2.25, -1.0]];
    for c in coords {
        for x in c {
            let raw = if double { x.to_le_bytes().to_vec() } else { (x as f32).to_le_bytes().to_vec() };
            bytes.extend(if big_endian { raw.into_iter().rev().collect() } else { raw });
        }
        bytes.extend([0u8, 0]);
    }
    let count: Vec<u8> = match count_type {
        "uchar" => vec![3],
        _ if big_endian => 3i32.to_be_bytes().to_vec(),
        _ => 3i32.to_le_bytes().to_vec(),
    };
    bytes.extend(count);
    for i in [0u32, 1, 2] {
        bytes.extend(if big_endian { i.to_be_bytes() } else { i.to_le_bytes() });
    }
    bytes
}

#[test]
fn ply_binary_endianness_types_and_count_widths() {
    for big in [false, true] {
        for double in [false, true] {
            for count in ["uchar", "int"] {
                let m =
                    ply(&binary_triangle(big, double, count)).unwrap_or_else(|e| panic!("{big} {double} {count}: {e}"));
                assert_eq!(m.positions, vec![[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0, 2.25, -1.0]]);
                assert_eq!(m.triangles, vec![[0, 1, 2]]);
            }
        }
    }
}

#[test]
fn ply_refusals() {
    // Truncated binary data.
    let full = binary_triangle(false, false, "uchar");
    assert!(matches!(ply(&full[..full.len() - 5]), Err(MeshError::Parse { .. })));
    // A header that claims more data than follows is refused before anything is allocated.
    let mut lying = ply_header(
        "binary_little_endian",
        "property float x\nproperty float y\nproperty float z\n",
        1_000_000,
        "property list uchar int vertex_indices\n",
        1,
    );
    lying.extend([0u8; 64]);
    assert_parse_error(ply(&lying), "header", "only 64 follow");
    // An absurd count hits the configured limit.
    let absurd = ply_header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\n",
        1_000_000_000_000,
        "property list uchar int vertex_indices\n",
        0,
    );
    assert!(matches!(ply(&absurd), Err(MeshError::TooLarge { what: "vertices", .. })));
    // Index out of range.
    let mut bad_index = ply_header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\n",
        3,
        "property list uchar int vertex_indices\n",
        1,
    );
    bad_index.extend_from_slice(b"0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
    assert_parse_error(ply(&bad_index), "face 0", "vertex 3");
    // Negative index.
    let mut negative = ply_header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\n",
        3,
        "property list uchar int vertex_indices\n",
        1,
    );
    negative.extend_from_slice(b"0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
    assert_parse_error(ply(&negative), "face 0", "vertex -1");
    // NaN coordinate.
    let mut nan = ply_header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\n",
        3,
        "property list uchar int vertex_indices\n",
        1,
    );
    nan.extend_from_slice(b"0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n");
    assert_parse_error(ply(&nan), "vertex 1", "non-finite");
    // Ascii data shorter than the header says.
    let mut short = ply_header(
        "ascii",
        "property float x\nproperty float y\nproperty float z\n",
        3,
        "property list uchar int vertex_indices\n",
        1,
    );
    short.extend_from_slice(b"0 0 0\n1 0 0\n0 1 0\n3 0 1\n");
    assert_parse_error(ply(&short), "face 0", "too few values");
    // Header problems.
    assert_parse_error(ply(b"ply\nformat ascii 1.0\nelement vertex 0\n"), "header", "end_header");
    assert_parse_error(ply(b"ply\nformat fancy 1.0\nend_header\n"), "line 2", "unknown format");
    assert_parse_error(
        ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n"),
        "header",
        "x, y and z",
    );
    assert_parse_error(ply(b"ply\nformat ascii 1.0\nelement vertex -5\nend_header\n"), "line 3", "non-negative");
    assert_parse_error(ply(b"plx\nformat ascii 1.0\nend_header\n"), "line 1", "magic");
}

#[test]
fn round_trips_are_exact() {
    let dir = tempdir("round_trips_are_exact");
    let mesh = procedural::bumpy_blob(20, 40, 3);
    for ext in ["obj", "ply"] {
        let path = dir.join(format!("blob.{ext}"));
        write_mesh(&path, &mesh).unwrap();
        let back = read_mesh(&path).unwrap();
        assert_eq!(back.positions, mesh.positions, "{ext}: positions must be bit-exact");
        assert_eq!(back.triangles, mesh.triangles, "{ext}");
    }
    // Content sniffing when the extension says nothing.
    let mut bytes = Vec::new();
    write_mesh_to(&mut bytes, &mesh, MeshFormat::Ply).unwrap();
    let odd = dir.join("blob.mesh");
    std::fs::write(&odd, &bytes).unwrap();
    assert_eq!(read_mesh(&odd).unwrap().triangles, mesh.triangles);
    // An OBJ is sniffed by its first statement after the comments; a text whose first line that
    // is not a comment is no OBJ statement (a Markdown file: its headings start with `#`) is
    // refused, not read as an empty mesh.
    let obj = dir.join("commented.mesh");
    std::fs::write(&obj, "# exported\n\no part\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_eq!(read_mesh(&obj).unwrap().face_count(), 1);
    let notes = dir.join("README.md");
    std::fs::write(&notes, "# Meshes\n\nReal meshes for the tests.\n## Sources\n").unwrap();
    let refused = read_mesh(&notes).unwrap_err();
    assert!(matches!(refused, MeshError::UnsupportedFormat { .. }), "{refused}");
    // Unknown output extension and missing input file are clear errors.
    assert!(matches!(write_mesh(dir.join("x.stl"), &mesh), Err(MeshError::UnsupportedFormat { .. })));
    let missing = read_mesh(dir.join("missing.obj")).unwrap_err();
    assert!(missing.to_string().contains("missing.obj"), "{missing}");
}

#[test]
fn shared_meshes_load_with_known_counts() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("shared_meshes_load_with_known_counts") else {
        return;
    };
    // (name, vertices, polygons in the file); triangulated meshes have at least as many faces.
    let expected = [
        ("cow", 2903, 5804),
        ("stanford-bunny", 35947, 69451),
        ("spot", 2930, 5856),
        ("fandisk", 6475, 12946),
        ("homer", 6002, 12000),
        ("rocker-arm", 10044, 20088),
        ("teapot", 3644, 6320),
        ("nefertiti", 49971, 99938),
        ("ogre", 62194, 124008),
        ("beetle", 1148, 2053),
        ("suzanne", 507, 500),
    ];
    for (name, vertices, polygons) in expected {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(mesh.vertex_count(), vertices, "{name} vertices");
        if name == "suzanne" {
            assert!(mesh.face_count() > polygons, "{name}: quads must be triangulated");
        } else if name == "beetle" {
            assert!(mesh.face_count() >= polygons, "{name}: polygons must be triangulated");
        } else {
            assert_eq!(mesh.face_count(), polygons, "{name} faces");
        }
    }
    // spot has texture coordinates: kept per corner, geometry still welded.
    let spot = read_mesh(dir.join("spot.obj")).unwrap();
    assert_eq!(spot.corners.uvs().map(Vec::len), Some(3 * spot.face_count()));
}

#[test]
fn huge_polygons_are_triangulated_in_bounded_work_or_refused() {
    // A 100 000-corner face (OBJ and binary PLY) becomes n − 2 triangles; one over the face limit
    // is refused before it is triangulated, naming the line.
    let n = 100_000usize;
    let mut text = String::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        text.push_str(&format!("v {} {} 0\n", a.cos(), a.sin()));
    }
    text.push('f');
    for i in 0..n {
        text.push_str(&format!(" {}", i + 1));
    }
    text.push('\n');
    assert_eq!(obj(&text).unwrap().face_count(), n - 2);
    let tight = ReadLimits { max_faces: 1000, ..ReadLimits::default() };
    let refused = read_mesh_bytes(text.as_bytes(), Some(MeshFormat::Obj), Path::new("test.obj"), &tight);
    assert!(matches!(refused, Err(MeshError::TooLarge { what: "faces", .. })), "{refused:?}");
    // `f 1 2 3 1 2 3 …`: a polygon repeating its corners ends too (fanned: no area to clip).
    let mut repeated = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
    for i in 0..30_000 {
        repeated.push_str(&format!(" {}", i % 3 + 1));
    }
    repeated.push('\n');
    assert_eq!(obj(&repeated).unwrap().face_count(), 30_000 - 2);
}

#[test]
fn a_read_stops_when_cancelled() {
    let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let limits = ReadLimits { cancel: Some(flag), ..ReadLimits::default() };
    let mut ply_bytes = Vec::new();
    write_mesh_to(&mut ply_bytes, &procedural::icosphere(3), MeshFormat::Ply).unwrap();
    for (bytes, format) in [(SQUARE_OBJ.as_bytes().to_vec(), MeshFormat::Obj), (ply_bytes, MeshFormat::Ply)] {
        let r = read_mesh_bytes(&bytes, Some(format), Path::new("test"), &limits);
        assert!(matches!(r, Err(MeshError::Cancelled)), "{format:?}: {r:?}");
    }
}

#[test]
fn hostile_gltf_is_refused_by_name() {
    let gltf = |json: &str| read_gltf(json, "test.gltf");
    // One triangle: 3 positions (36 bytes) and 3 u16 indices (6 bytes), embedded as base64.
    let mut bin = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uri = data_uri(&bin);
    let doc = |buffer_length: usize, count: usize, extra: &str| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},{extra}"buffers":[{{"byteLength":{buffer_length},"uri":"{uri}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":{count},"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}]}}"#
        )
    };
    let ok = gltf(&doc(42, 3, "")).unwrap();
    assert_eq!((ok.vertex_count(), ok.face_count()), (3, 1));
    let err = |json: String| gltf(&json).unwrap_err().to_string();
    let e = err(doc(42, 4, ""));
    assert!(e.contains("accessor 0") && e.contains("overrun"), "{e}");
    let e = err(doc(420, 3, ""));
    assert!(e.contains("buffer 0") && e.contains("declares 420 bytes but holds 42"), "{e}");
    let e = err(doc(
        42,
        3,
        r#""extensionsRequired":["KHR_draco_mesh_compression"],"extensionsUsed":["KHR_draco_mesh_compression"],"#,
    ));
    assert!(e.contains("KHR_draco_mesh_compression"), "{e}");
    let e = err(doc(42, 3, "").replace(&uri, "outside.bin"));
    assert!(e.contains("cannot be read here"), "{e}");
    // A primitive's references out of range: the element and the count named (the `gltf`
    // crate's own validation would panic on the first).
    let e = err(doc(42, 3, "").replace(r#""POSITION":0"#, r#""POSITION":7"#));
    assert!(
        e.contains("mesh 0 primitive 0 attribute POSITION") && e.contains("accessor 7, but the document has 2"),
        "{e}"
    );
    let e = err(doc(42, 3, "").replace(r#""indices":1"#, r#""indices":65536"#));
    assert!(e.contains("mesh 0 primitive 0 indices") && e.contains("accessor 65536"), "{e}");
    let e = err(doc(42, 3, "").replace(r#""componentType":5123"#, r#""componentType":5120"#));
    assert!(e.contains("indices (accessor 1) holds Scalar I8"), "{e}");
    let e = err(doc(42, 3, "").replace(r#""type":"VEC3""#, r#""type":"VEC2""#));
    assert!(e.contains("POSITION (accessor 0) holds Vec2 F32: glTF allows 3 floats"), "{e}");
    let e = err(doc(42, 3, "").replace(r#""count":3,"type":"SCALAR""#, r#""count":0,"type":"SCALAR""#));
    assert!(e.contains("accessor 1: has a count of 0"), "{e}");
    let e = err(doc(42, 3, "").replace(r#""indices":1"#, r#""indices":1,"material":3"#));
    assert!(e.contains("mesh 0 primitive 0") && e.contains("material 3, but the document has 0"), "{e}");
    // A GLB header whose length does not cover the header, or runs past the file.
    for declared in [5u32, 4000] {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(declared.to_le_bytes());
        glb.extend([0u8; 8]);
        let e = read_mesh_bytes(&glb, Some(MeshFormat::Gltf), Path::new("test.glb"), &ReadLimits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("GLB container") && e.contains(&format!("declares {declared} bytes")), "{e}");
    }
    let e = err("{\"asset\": ".into());
    assert!(e.contains("test.gltf"), "{e}");
}

#[test]
fn sparse_accessors_substitute_values_and_bad_indices_are_refused() {
    // Three positions, one replaced through a sparse accessor: [1, 0, 0] at `index` becomes [2, 0, 0].
    let read = |indices: [u8; 2], count: usize| {
        let mut bin = Vec::new();
        for c in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
        bin.extend_from_slice(&[indices[0], indices[1], 0, 0]);
        for c in [2f32, 0., 0., 0., 1., 0.] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
        let uri = data_uri(&bin);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"{uri}"}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":4}},{{"buffer":0,"byteOffset":40,"byteLength":24}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[2,1,0],
                "sparse":{{"count":{count},"indices":{{"bufferView":1,"componentType":5121}},"values":{{"bufferView":2}}}}}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}]}}"#,
            bin.len()
        );
        read_gltf(&json, "sparse.gltf")
    };
    let mesh = read([1, 0], 1).unwrap();
    assert!(
        mesh.positions.contains(&[2.0, 0.0, 0.0]) && !mesh.positions.contains(&[1.0, 0.0, 0.0]),
        "{:?}",
        mesh.positions
    );
    let e = read([7, 0], 1).unwrap_err().to_string();
    assert!(e.contains("accessor 0: sparse index 0 is 7, but the accessor has 3 elements"), "{e}");
    let e = read([2, 1], 2).unwrap_err().to_string();
    assert!(e.contains("sparse index 1 (1) does not follow the one before in increasing order"), "{e}");
}

/// A glTF buffer on a device is not read from it (`/dev/zero` would never end): `/dev/null`,
/// which ends at once, tells the refusal from a read.
#[cfg(unix)]
#[test]
fn a_buffer_on_a_device_is_refused_not_read() {
    let dir = tempdir("device-references");
    let doc = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":42,"uri":"/dev/null"}],
        "bufferViews":[{"buffer":0,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#;
    std::fs::write(dir.join("null.gltf"), doc).unwrap();
    let e = read_mesh(dir.join("null.gltf")).unwrap_err().to_string();
    assert!(e.contains("buffer 0: '/dev/null': not a regular file"), "{e}");
}

#[test]
fn quantized_gltf_is_read_as_floats() {
    // KHR_mesh_quantization as gltfpack writes it: positions as unsigned shorts placed by the node's
    // scale, normals as normalised bytes, texture coordinates as normalised unsigned shorts.
    let mut bin = Vec::new();
    for p in [[0u16, 0, 0], [1000, 0, 0], [0, 1000, 0]] {
        p.iter().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
        bin.extend_from_slice(&[0, 0]); // each element padded to 4 bytes (stride 8)
    }
    for _ in 0..3 {
        bin.extend_from_slice(&[0, 0, 127u8, 0]); // +z, padded to 4 bytes
    }
    for uv in [[0u16, 0], [65535, 0], [0, 32768]] {
        uv.iter().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    }
    let uri = data_uri(&bin);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],
        "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"scale":[0.001,0.001,0.001]}}],
        "buffers":[{{"byteLength":{},"uri":"{uri}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":24,"byteStride":8}},{{"buffer":0,"byteOffset":24,"byteLength":12,"byteStride":4}},
                       {{"buffer":0,"byteOffset":36,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5123,"count":3,"type":"VEC3","min":[0,0,0],"max":[1000,1000,0]}},
                     {{"bufferView":1,"componentType":5120,"normalized":true,"count":3,"type":"VEC3"}},
                     {{"bufferView":2,"componentType":5123,"normalized":true,"count":3,"type":"VEC2"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}}}}]}}]}}"#,
        bin.len()
    );
    let mesh = read_gltf(&json, "q.gltf").unwrap();
    assert_eq!(mesh.face_count(), 1);
    let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(
        close(mesh.positions[1], [1.0, 0.0, 0.0]) && close(mesh.positions[2], [0.0, 1.0, 0.0]),
        "{:?}",
        mesh.positions
    );
    assert!(mesh.corners.normals().unwrap().iter().all(|&n| close(n, [0.0, 0.0, 1.0])));
    let uvs = mesh.corners.uvs().unwrap();
    assert_eq!((uvs[1], uvs[2][1]), ([1.0, 0.0], 32768.0 / 65535.0));
    // Written out, it needs no extension: the values are floats.
    let mut glb = Vec::new();
    write_mesh_to(&mut glb, &mesh, MeshFormat::Gltf).unwrap();
    let text = String::from_utf8_lossy(&glb);
    assert!(!text.contains("KHR_mesh_quantization"), "the output still names the extension");
    // A quantized attribute of the wrong shape is refused by name.
    let bad = json.replace(
        r#""componentType":5120,"normalized":true,"count":3,"type":"VEC3""#,
        r#""componentType":5120,"normalized":true,"count":3,"type":"VEC2""#,
    );
    let e = read_gltf(&bad, "q.gltf").unwrap_err().to_string();
    assert!(e.contains("NORMAL"), "{e}");
}

#[test]
fn gltf_attribute_faults_name_the_primitive() {
    // Positions (`vertices` of them) without indices, and TEXCOORD_0 with `uvs` values.
    let read = |vertices: usize, uvs: &[[f32; 2]]| {
        let mut bin = Vec::new();
        for v in 0..vertices {
            for c in [v as f32, (v % 2) as f32, 0.0] {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        uvs.iter().flatten().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
        let uri = data_uri(&bin);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"{uri}"}}],
            "bufferViews":[{{"buffer":0,"byteLength":{}}},{{"buffer":0,"byteOffset":{},"byteLength":{}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":{vertices},"type":"VEC3","min":[0,0,0],"max":[{},1,0]}},
                         {{"bufferView":1,"componentType":5126,"count":{},"type":"VEC2"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}}}}]}}]}}"#,
            bin.len(),
            12 * vertices,
            12 * vertices,
            8 * uvs.len(),
            vertices - 1,
            uvs.len()
        );
        read_gltf(&json, "faults.gltf")
    };
    // Without indices, each three vertices are a triangle, with their own texture coordinates.
    let mesh = read(3, &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]).unwrap();
    assert_eq!((mesh.face_count(), mesh.corners.uvs().unwrap()[1]), (1, [1.0, 0.0]));
    let e = read(3, &[[0.0, 0.0], [1.0, 0.0]]).unwrap_err().to_string();
    assert!(e.contains("mesh 0 primitive 0") && e.contains("TEXCOORD_0 has 2 values for 3 positions"), "{e}");
    let e = read(3, &[[0.0, 0.0], [f32::NAN, 0.0], [0.0, 1.0]]).unwrap_err().to_string();
    assert!(e.contains("mesh 0 primitive 0: TEXCOORD_0 of vertex 1 is not a finite number"), "{e}");
    let e = read(4, &[[0.0, 0.0]; 4]).unwrap_err().to_string();
    assert!(e.contains("mesh 0 primitive 0: 4 indices: not a whole number of triangles"), "{e}");
}

/// An OBJ written to a file gets its materials in an MTL file beside it, with their base-colour
/// textures: an image held in memory or a file elsewhere is written beside it, a file already
/// there is named as it is, and all of it reads back.
#[test]
fn obj_files_come_with_their_materials_and_textures() {
    use meshlod_engine::mesh::{Image, ImageSource, MaterialLibrary};
    use serde_json::json;
    let (dir, elsewhere) = (tempdir("obj-materials"), tempdir("obj-materials-elsewhere"));
    let png = b"\x89PNG\r\n\x1a\n held in memory".to_vec();
    let jpeg = b"\xFF\xD8\xFF a file elsewhere".to_vec();
    std::fs::write(elsewhere.join("wood grain.jpg"), &jpeg).unwrap();
    let mut sphere = procedural::icosphere(1);
    sphere.corners.set_materials(Some((0..sphere.face_count() as u32).flat_map(|f| [f % 3; 3]).collect()));
    let library = MaterialLibrary {
        materials: vec![
            json!({ "name": "painted", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }),
            json!({ "name": "wood", "pbrMetallicRoughness": { "baseColorTexture": { "index": 1 } } }),
            json!({ "name": "glass\nv 9 9 9", "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.25, 1.0, 0.5] } }),
        ],
        textures: vec![json!({ "source": 0 }), json!({ "source": 1 })],
        images: vec![
            Image { json: json!({ "name": "paint" }), source: ImageSource::Bytes(png.clone()), mime_type: None },
            Image { json: json!({}), source: ImageSource::File(elsewhere.join("wood grain.jpg")), mime_type: None },
        ],
        ..Default::default()
    };
    sphere.corners.library = Some(std::sync::Arc::new(library));
    write_mesh(dir.join("sphere.obj"), &sphere).unwrap();
    let mtl = std::fs::read_to_string(dir.join("sphere.mtl")).unwrap();
    assert!(mtl.contains("map_Kd paint.png") && mtl.contains("map_Kd wood_grain.jpg"), "{mtl}");
    assert!(mtl.contains("Kd 0.5 0.25 1\nd 0.5"), "{mtl}");
    let back = read_mesh(dir.join("sphere.obj")).unwrap();
    assert_eq!(back.corners.materials(), sphere.corners.materials());
    let read = back.corners.library.as_deref().unwrap();
    let names: Vec<String> = (0..3).map(|m| read.material_name(m)).collect();
    // (A name is one line in both files: the one that tried to add a vertex stays a name.)
    assert_eq!(names, ["painted", "wood", "glass v 9 9 9"]);
    assert_eq!(back.vertex_count(), sphere.vertex_count());
    assert_eq!(read.materials[2]["pbrMetallicRoughness"]["baseColorFactor"], json!([0.5, 0.25, 1.0, 0.5]));
    let bytes = |image: &Image| match &image.source {
        ImageSource::File(file) => std::fs::read(file).unwrap(),
        other => panic!("{other:?}"),
    };
    assert_eq!((bytes(&read.images[0]), bytes(&read.images[1])), (png.clone(), jpeg));
    // Written again into the same folder, the images already there are named, not copied; an
    // image of the same name and other bytes takes the stem in front, leaving the first alone.
    write_mesh(dir.join("again.obj"), &back).unwrap();
    let mtl = std::fs::read_to_string(dir.join("again.mtl")).unwrap();
    assert!(mtl.contains("map_Kd paint.png") && mtl.contains("map_Kd wood_grain.jpg"), "{mtl}");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 6, "two OBJ, two MTL, two images");
    let mut other = sphere.clone();
    let mut library = other.corners.library.as_deref().unwrap().clone();
    library.images[0].source = ImageSource::Bytes(b"\x89PNG\r\n\x1a\n another paint".to_vec());
    other.corners.library = Some(std::sync::Arc::new(library));
    write_mesh(dir.join("other.obj"), &other).unwrap();
    let mtl = std::fs::read_to_string(dir.join("other.mtl")).unwrap();
    assert!(mtl.contains("map_Kd other_paint.png") && mtl.contains("map_Kd wood_grain.jpg"), "{mtl}");
    assert_eq!(bytes(&read.images[0]), png, "the first paint is left as it was");
    // To a stream (no folder): the materials by name only.
    let mut text = Vec::new();
    write_mesh_to(&mut text, &sphere, MeshFormat::Obj).unwrap();
    let text = String::from_utf8(text).unwrap();
    assert!(text.contains("usemtl wood") && !text.contains("mtllib"));
}

/// Texture coordinates on some faces only are kept, the other faces' set to zero (as a glTF
/// primitive without them beside one with them); normals on some faces only are left out (a face
/// without them is drawn flat), and the warning every command prints says so.
#[test]
fn obj_values_on_some_faces_only() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n\
        f 1/1/1 2/2/1 3/3/1\nf 1//1 3//1 4//1\nf 1 4 5\n";
    let mesh = obj(text).unwrap();
    let uvs = mesh.corners.uvs().expect("kept");
    assert_eq!(uvs[..3], [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
    assert!(uvs[3..].iter().all(|&uv| uv == [0.0, 0.0]));
    assert!(mesh.corners.normals().is_none());
    let warning = mesh.corners.not_carried_warning().expect("said");
    assert!(warning.contains("normals (given at 6 of 9 face corners)") && !warning.contains("texture"), "{warning}");
    // A texture coordinate out of range is refused where some faces have none too.
    let e = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/2 3/1\nf 1 2 3\n").unwrap_err().to_string();
    assert!(e.contains("line 5") && e.contains("texture coordinate 2 but the file has 1"), "{e}");
    // Given everywhere, nothing is said.
    let whole = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n").unwrap();
    assert!(whole.corners.normals().is_some() && whole.corners.not_carried_warning().is_none());
}

/// A glTF mesh whose primitives differ in their attributes: texture coordinates and colours are
/// kept (a primitive without them takes zero and white, as glTF draws it), normals only when
/// every primitive has them (said otherwise).
#[test]
fn gltf_primitives_with_different_attributes() {
    // Two triangles side by side: the first with NORMAL, TEXCOORD_0 and COLOR_0, the second with
    // positions only.
    let mut bin = Vec::new();
    let floats =
        |bin: &mut Vec<u8>, values: &[f32]| values.iter().for_each(|c| bin.extend_from_slice(&c.to_le_bytes()));
    floats(&mut bin, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    floats(&mut bin, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    floats(&mut bin, &[0.25, 0.5, 0.75, 0.5, 0.25, 1.0]);
    floats(&mut bin, &[0.5, 0.5, 0.5, 1.0, 0.5, 0.5, 0.5, 1.0, 0.5, 0.5, 0.5, 1.0]);
    floats(&mut bin, &[1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
    let view = |offset: usize, length: usize| format!(r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{length}}}"#);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"{}"}}],
        "bufferViews":[{},{},{},{},{}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"}},
                     {{"bufferView":2,"componentType":5126,"count":3,"type":"VEC2"}},
                     {{"bufferView":3,"componentType":5126,"count":3,"type":"VEC4"}},
                     {{"bufferView":4,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2,"COLOR_0":3}}}},
                                  {{"attributes":{{"POSITION":4}}}}]}}]}}"#,
        bin.len(),
        data_uri(&bin),
        view(0, 36),
        view(36, 36),
        view(72, 24),
        view(96, 48),
        view(144, 36)
    );
    let mesh = read_gltf(&json, "mixed.gltf").unwrap();
    assert_eq!(mesh.face_count(), 2);
    let uvs = mesh.corners.uvs().expect("texture coordinates kept");
    assert_eq!((uvs[1], &uvs[3..]), ([0.75, 0.5], &[[0.0, 0.0]; 3][..]));
    let colors = mesh.corners.colors().expect("colours kept");
    assert_eq!((colors[0], &colors[3..]), ([0.5, 0.5, 0.5, 1.0], &[[1.0; 4]; 3][..]));
    assert!(mesh.corners.normals().is_none());
    let warning = mesh.corners.not_carried_warning().expect("said");
    assert!(warning.contains("normals (a primitive has no NORMAL)"), "{warning}");
}

/// A glTF point or line primitive is not surface: it is carried as it was (its positions placed
/// in the world as the triangles' are, its colours and texture coordinates as floats, its indices
/// with their bytes), said, written back beside the triangles (on the quantization grid's frame
/// too), and kept by a progressive mesh's file.
#[test]
fn gltf_point_and_line_primitives_are_carried_as_they_were() {
    use meshlod_engine::io::{WriteOptions, write_gltf_with};
    let mut bin = Vec::new();
    for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0] {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    bin.extend_from_slice(&[255, 128, 0, 255, 0, 0, 255, 255]); // COLOR_0, normalised bytes
    bin.extend_from_slice(&[255, 0, 0, 255]); // TEXCOORD_0, normalised bytes
    bin.extend_from_slice(&[0, 1]); // indices
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"{}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":24}},
                       {{"buffer":0,"byteOffset":60,"byteLength":8}},{{"buffer":0,"byteOffset":68,"byteLength":4}},
                       {{"buffer":0,"byteOffset":72,"byteLength":2}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5126,"count":2,"type":"VEC3","min":[0,0,1],"max":[1,1,1]}},
                     {{"bufferView":2,"componentType":5121,"normalized":true,"count":2,"type":"VEC4"}},
                     {{"bufferView":3,"componentType":5121,"normalized":true,"count":2,"type":"VEC2"}},
                     {{"bufferView":4,"componentType":5121,"count":2,"type":"SCALAR"}}],
        "materials":[{{"name":"wire"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}},
            {{"mode":1,"material":0,"attributes":{{"POSITION":1,"COLOR_0":2,"TEXCOORD_0":3}},"indices":4}}]}}],
        "nodes":[{{"mesh":0,"translation":[10,0,0]}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        bin.len(),
        data_uri(&bin)
    );
    let mesh = read_gltf(&json, "lines.gltf").unwrap();
    assert_eq!(mesh.face_count(), 1);
    let others = |m: &meshlod_engine::Mesh| m.corners.library.as_ref().unwrap().other_primitives.clone();
    let read = others(&mesh);
    assert_eq!(read.len(), 1);
    let (line, attribute) =
        (&read[0], |name: &str| read[0].attributes.iter().find(|(n, _)| n == name).unwrap().1.clone());
    assert_eq!((line.mode, line.material), (1, Some(0)));
    let floats =
        |bytes: &[u8]| bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect::<Vec<_>>();
    assert_eq!(floats(&attribute("POSITION").bytes), [10.0, 0.0, 1.0, 11.0, 1.0, 1.0], "placed by its node");
    assert_eq!(attribute("POSITION").json["min"], serde_json::json!([10.0, 0.0, 1.0]));
    assert_eq!(floats(&attribute("COLOR_0").bytes), [1.0, 128.0 / 255.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0]);
    assert_eq!(floats(&attribute("TEXCOORD_0").bytes), [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(line.indices.as_ref().unwrap().bytes, [0, 1], "indices as they were");
    assert_eq!(meshlod_engine::validate::validate(&mesh).point_and_line_primitives, 1);
    let note = mesh.corners.passed_through_note().expect("said");
    assert!(note.contains("1 point and line primitive"), "{note}");
    // Written back as they were, beside the triangles; on the grid's frame when quantized.
    for quantize in [false, true] {
        let mut glb = Vec::new();
        write_gltf_with(&mut glb, &mesh, true, None, &WriteOptions { quantize }).unwrap();
        let back = read_mesh_bytes(&glb, None, Path::new("lines.glb"), &ReadLimits::default()).unwrap();
        let again = others(&back);
        assert_eq!(again.len(), 1);
        let position = |p: &meshlod_engine::mesh::OtherPrimitive| {
            floats(&p.attributes.iter().find(|(n, _)| n == "POSITION").unwrap().1.bytes)
        };
        let moved = position(&again[0]).iter().zip(position(line)).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(moved < 1e-5, "quantize {quantize}: moved {moved}");
        if !quantize {
            assert_eq!(again, read, "the same primitive, bytes and all");
        }
    }
    // A progressive mesh's file keeps them.
    use meshlod_engine::simplify::{SimplifyOptions, simplify};
    let options = SimplifyOptions { record_progressive: true, ..Default::default() };
    let pm = simplify(&mesh, &options).unwrap().progressive.unwrap();
    let decoded =
        meshlod_engine::pm_format::decode(&meshlod_engine::pm_format::encode(&pm), Path::new("x.pm")).unwrap().0;
    assert_eq!(others(decoded.base()), read);
    // A primitive that names a material the library lacks is refused by name.
    let mut bad = mesh.clone();
    let mut library = bad.corners.library.as_deref().unwrap().clone();
    library.other_primitives[0].material = Some(3);
    bad.corners.library = Some(std::sync::Arc::new(library));
    let e = bad.check().unwrap_err().to_string();
    assert!(e.contains("point or line primitive 0: names material 3; there are 1"), "{e}");
}

/// Two things glTF allows that the `gltf` crate's validation refuses: an application-specific
/// attribute (`_BATCHID`, as 3D Tiles writes) and a primitive without POSITION (it draws
/// nothing). The file is read, the attribute carried as a channel, what is not carried said, and
/// the result written as GLB reads back with the channel.
#[test]
fn gltf_custom_attributes_and_primitives_without_positions_are_read_and_said() {
    let mut bin = Vec::new();
    for c in [0f32, 0., 0., 1., 0., 0., 0., 1., 0., 7., 7., 7.] {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"{}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5126,"count":3,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"_BATCHID":1}}}},
                                  {{"attributes":{{"_BATCHID":1}},"mode":0}}]}}]}}"#,
        bin.len(),
        data_uri(&bin)
    );
    let mesh = read_gltf(&json, "tiles.gltf").unwrap();
    assert_eq!((mesh.face_count(), mesh.vertex_count()), (1, 3));
    let warning = mesh.corners.not_carried_warning().expect("said");
    assert!(!warning.contains("_BATCHID") && warning.contains("primitives without POSITION"), "{warning}");
    let batch = meshlod_engine::mesh::Semantic::Custom("_BATCHID".into());
    let ids = meshlod_engine::mesh::Values::F1(vec![[7.0]; 3]);
    assert_eq!(mesh.corners.channel(&batch), Some(&ids));
    let mut glb = Vec::new();
    write_mesh_to(&mut glb, &mesh, MeshFormat::Gltf).unwrap();
    let back = read_mesh_bytes(&glb, Some(MeshFormat::Gltf), Path::new("back.glb"), &ReadLimits::default()).unwrap();
    assert_eq!((back.face_count(), back.positions), (1, mesh.positions));
    assert_eq!(back.corners.channel(&batch), Some(&ids), "carried into the GLB");
    // A POSITION that is there is still checked: one without its bounds is refused by name.
    let e = read_gltf(&json.replace(r#","min":[0,0,0],"max":[1,1,0]"#, ""), "tiles.gltf").unwrap_err().to_string();
    assert!(e.contains("POSITION") && e.contains("min"), "{e}");
}

/// A file may name one accessor under many application-specific names: the first
/// `MAX_EXTRA_CHANNELS` (16) become channels, the others are said and left out, so that a few
/// bytes cannot ask for a value per corner times thousands.
#[test]
fn gltf_further_attributes_beyond_sixteen_are_said_and_left_out() {
    let mut bin = Vec::new();
    for c in [0f32, 0., 0., 1., 0., 0., 0., 1., 0., 7., 7., 7.] {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    let names: Vec<String> = (0..20).map(|i| format!(r#""_A{i:02}":1"#)).collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{},"uri":"{}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5126,"count":3,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,{}}}}}]}}]}}"#,
        bin.len(),
        data_uri(&bin),
        names.join(",")
    );
    let mesh = read_gltf(&json, "many.gltf").unwrap();
    let custom = mesh.corners.names().into_iter().filter(|n| n.starts_with("_A")).count();
    assert_eq!(custom, 16, "{:?}", mesh.corners.names());
    let warning = mesh.corners.not_carried_warning().expect("said");
    assert!(
        warning.contains("_A16 values") && warning.contains("_A19 values") && !warning.contains("_A15"),
        "{warning}"
    );
}
