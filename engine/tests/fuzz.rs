//! Mutation fuzzing on stable Rust, deterministic and bounded: the OBJ, PLY, STL, OFF, glTF and `.pm` readers on
//! mutations of the committed seed corpus (`tests/fuzz-corpus/`), and the simplify → progressive
//! mesh → level pipeline on arbitrary small meshes, and the glTF reader on seed documents whose
//! fields are set to wrong values. Every input must end in a value or a clear error: no panic
//! (not even one caught inside the code under test), and every mesh that comes back passes its
//! own check.
//!
//! The count of inputs per target is `MESHLOD_FUZZ_ITERATIONS` (default 20 000, a few seconds
//! in a debug build; the longer run documented in docs/reliability.md uses 200 000) and the seed
//! `MESHLOD_FUZZ_SEED` (default 1): a failure prints both and the input, so it can be replayed and
//! kept as a regression case in `tests/fuzz-corpus/`.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes};
use meshlod_engine::pm_format::{decode, encode, encode_lossless};
use meshlod_engine::rng::SplitMix64;
use meshlod_engine::simplify::{BoundaryMode, Metric, Placement, SimplifyOptions, simplify};
use meshlod_engine::{Mesh, MeshError};

fn setting(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn corpus() -> Vec<(PathBuf, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus");
    let mut files: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    files.sort();
    assert!(files.len() >= 5, "the seed corpus is missing: {}", dir.display());
    // `.pm` files with attributes, made here in the compact (version 3) and lossless (version 2)
    // forms: a sphere whose two halves are two texture charts, half simplified.
    let mut sphere = meshlod_engine::procedural::icosphere(1);
    let uvs = (0..3 * sphere.face_count())
        .map(|k| {
            let upper = sphere.triangle_points(k / 3).iter().map(|p| p.z).sum::<f64>() > 0.0;
            let p = sphere.positions[sphere.triangles[k / 3][k % 3] as usize];
            [p[0] + if upper { 2.0 } else { 0.0 }, p[1]]
        })
        .collect();
    sphere.corners.set_uvs(Some(uvs));
    let options = meshlod_engine::simplify::SimplifyOptions {
        target_ratio: Some(0.5),
        record_progressive: true,
        ..Default::default()
    };
    let pm = meshlod_engine::simplify::simplify(&sphere, &options).unwrap().progressive.unwrap();
    assert!(pm.has_attributes() && pm.levels() > 0);
    files.push((dir.join("generated-sphere-uv.pm"), encode(&pm)));
    files.push((dir.join("generated-sphere-uv-lossless.pm"), encode_lossless(&pm)));
    // And a compact one without attributes.
    let plain = meshlod_engine::procedural::icosphere(2);
    let pm = meshlod_engine::simplify::simplify(&plain, &options).unwrap().progressive.unwrap();
    files.push((dir.join("generated-sphere.pm"), encode(&pm)));
    // And one whose splits open triangular holes again (a sphere with holes, simplified until
    // they close), in both forms.
    let holed = meshlod_engine::procedural::with_triangular_holes(&meshlod_engine::procedural::icosphere(2), 5);
    let options = SimplifyOptions { target_ratio: Some(0.9), ..options };
    let pm = meshlod_engine::simplify::simplify(&holed, &options).unwrap().progressive.unwrap();
    assert!(pm.splits().iter().any(|s| s.hole != meshlod_engine::pm::Hole::None));
    files.push((dir.join("generated-holed-sphere.pm"), encode(&pm)));
    files.push((dir.join("generated-holed-sphere-lossless.pm"), encode_lossless(&pm)));
    files
}

/// The `.pm` checksum (FNV-1a 64 of every byte before the last 8), rewritten so that a mutation
/// reaches the parser instead of stopping at the checksum.
fn fix_checksum(bytes: &mut [u8]) {
    if bytes.len() < 8 {
        return;
    }
    let end = bytes.len() - 8;
    let hash =
        bytes[..end].iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3));
    bytes[end..].copy_from_slice(&hash.to_le_bytes());
}

/// Tokens a mutation may splice in: the values readers get wrong.
const TOKENS: [&[u8]; 16] = [
    b"nan",
    b"inf",
    b"-1",
    b"0",
    b"4294967295",
    b"18446744073709551616",
    b"1e308",
    b"-0",
    b"\n",
    b" ",
    b"/",
    b"f ",
    b"v ",
    b"element vertex 4294967295\n",
    b"property list uchar int vertex_indices\n",
    b"end_header\n",
];

fn mutate(seed: &[u8], rng: &mut SplitMix64) -> Vec<u8> {
    let mut out = seed.to_vec();
    let edits = 1 + rng.next_u64() % 8;
    for _ in 0..edits {
        let len = out.len().max(1);
        let at = (rng.next_u64() as usize) % len;
        match rng.next_u64() % 7 {
            0 if !out.is_empty() => {
                let i = at % out.len();
                out[i] ^= 1 << (rng.next_u64() % 8);
            }
            1 if !out.is_empty() => {
                let i = at % out.len();
                out[i] = rng.next_u64() as u8;
            }
            2 => out.truncate(at),
            3 if !out.is_empty() => {
                let end = (at + 1 + (rng.next_u64() as usize) % 64).min(out.len());
                out.drain(at.min(out.len())..end);
            }
            4 => {
                let token = TOKENS[(rng.next_u64() as usize) % TOKENS.len()];
                let at = at.min(out.len());
                out.splice(at..at, token.iter().copied());
            }
            5 if !out.is_empty() => {
                // Repeat a chunk (many faces, long polygons, big counts).
                let start = at % out.len();
                let end = (start + 1 + (rng.next_u64() as usize) % 32).min(out.len());
                let chunk = out[start..end].to_vec();
                for _ in 0..(1 + rng.next_u64() % 16) {
                    out.splice(end..end, chunk.iter().copied());
                }
            }
            _ => {}
        }
    }
    out
}

std::thread_local! {
    /// The message of the last panic on this thread, caught or not ([`caught_panic`]).
    static PANICKED: std::cell::RefCell<Option<String>> = const { std::cell::RefCell::new(None) };
}

/// The message of a panic on this thread since the last call, even one that a `catch_unwind`
/// inside the code under test turned into an error (the glTF reader guards the `gltf` crate so):
/// the readers' own checks must refuse every input, not the safety net.
fn caught_panic() -> Option<String> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let default_hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICKED.with(|p| *p.borrow_mut() = Some(info.to_string()));
            default_hook(info);
        }));
    });
    PANICKED.with(|p| p.borrow_mut().take())
}

/// Runs `f` and fails the test, with what it needs to replay, if it panics, or if a panic inside
/// it was caught there.
fn no_panic<T>(what: &str, seed: u64, case: u64, input: &[u8], f: impl FnOnce() -> T) -> T {
    caught_panic();
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(v) => {
            if let Some(message) = caught_panic() {
                panic!(
                    "{what}: a panic, caught inside, at MESHLOD_FUZZ_SEED={seed}, case {case}: {message}; input: {:?}",
                    String::from_utf8_lossy(&input[..input.len().min(2000)])
                );
            }
            v
        }
        Err(_) => panic!(
            "{what}: panic at MESHLOD_FUZZ_SEED={seed}, case {case}; input ({} bytes): {:?}",
            input.len(),
            String::from_utf8_lossy(&input[..input.len().min(2000)])
        ),
    }
}

/// Small limits, so that a lying count is refused rather than allocated.
fn limits() -> ReadLimits {
    ReadLimits { max_vertices: 200_000, max_faces: 200_000, cancel: None }
}

#[test]
fn readers_survive_mutated_files() {
    let seed = setting("MESHLOD_FUZZ_SEED", 1);
    let iterations = setting("MESHLOD_FUZZ_ITERATIONS", 20_000);
    let mut rng = SplitMix64::new(seed);
    let corpus = corpus();
    let (mut parsed, mut refused) = (0usize, 0usize);
    for case in 0..iterations {
        let (path, bytes) = &corpus[(rng.next_u64() as usize) % corpus.len()];
        let mut input = mutate(bytes, &mut rng);
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or_default();
        if ext == "pm" {
            if rng.next_u64().is_multiple_of(2) {
                fix_checksum(&mut input);
            }
            let result = no_panic("pm decode", seed, case, &input, || decode(&input, Path::new("fuzz.pm")));
            if let Ok((pm, _)) = result {
                // A file that decodes gives every level.
                no_panic("pm levels", seed, case, &input, || {
                    for level in [0, pm.levels() / 2, pm.levels()] {
                        pm.at_level(level).check().unwrap();
                    }
                });
                parsed += 1;
            } else {
                refused += 1;
            }
            continue;
        }
        for format in [Some(MeshFormat::Obj), Some(MeshFormat::Ply), Some(MeshFormat::Stl), Some(MeshFormat::Off), None]
        {
            let result =
                no_panic("read", seed, case, &input, || read_mesh_bytes(&input, format, Path::new("fuzz"), &limits()));
            match result {
                Ok(mesh) => {
                    assert!(mesh.check().is_ok(), "case {case}: a mesh that fails its own check");
                    parsed += 1;
                }
                Err(e) => {
                    assert!(!e.to_string().is_empty());
                    refused += 1;
                }
            }
        }
    }
    eprintln!("fuzz readers: seed {seed}, {iterations} inputs: {parsed} parsed, {refused} refused");
    assert!(parsed > 0 && refused > 0, "the mutations reach both outcomes ({parsed} parsed, {refused} refused)");
}

/// The JSON values a glTF document's fields are set to: indices in and out of range, counts,
/// the component type codes (valid and not), wrong kinds.
const GLTF_VALUES: [&str; 22] = [
    "0",
    "1",
    "2",
    "3",
    "-1",
    "7",
    "255",
    "256",
    "65535",
    "65536",
    "4294967295",
    "4294967296",
    "1e300",
    "0.5",
    "5120",
    "5121",
    "5122",
    "5125",
    "5126",
    "null",
    "\"VEC2\"",
    "[]",
];

/// Paths (keys and positions) to every value of `value` except the buffers' data.
fn json_paths(value: &serde_json::Value, at: &mut Vec<serde_json::Value>, out: &mut Vec<Vec<serde_json::Value>>) {
    let children: Vec<(serde_json::Value, &serde_json::Value)> = match value {
        serde_json::Value::Object(map) => {
            map.iter().filter(|(k, _)| k.as_str() != "uri").map(|(k, v)| (k.as_str().into(), v)).collect()
        }
        serde_json::Value::Array(items) => items.iter().enumerate().map(|(i, v)| (i.into(), v)).collect(),
        _ => Vec::new(),
    };
    for (key, child) in children {
        at.push(key);
        out.push(at.clone());
        json_paths(child, at, out);
        at.pop();
    }
}

/// The value at `path` in `value`, to be replaced or taken out.
fn json_at<'a>(value: &'a mut serde_json::Value, path: &[serde_json::Value]) -> Option<&'a mut serde_json::Value> {
    path.iter().try_fold(value, |v, key| match key {
        serde_json::Value::String(k) => v.get_mut(k.as_str()),
        k => v.get_mut(k.as_u64()? as usize),
    })
}

#[test]
fn gltf_documents_with_wrong_fields_are_refused_without_a_panic() {
    // Documents that parse as JSON but say wrong things (an accessor that does not exist, an
    // index of a float type, a count that overruns): the byte mutations above rarely keep the
    // JSON whole.
    let seed = setting("MESHLOD_FUZZ_SEED", 1);
    let iterations = setting("MESHLOD_FUZZ_ITERATIONS", 20_000) / 4;
    let mut rng = SplitMix64::new(seed);
    // Each seed document with the paths to its fields.
    let documents: Vec<(serde_json::Value, Vec<Vec<serde_json::Value>>)> = corpus()
        .into_iter()
        .filter(|(p, _)| p.extension().is_some_and(|e| e == "gltf"))
        .map(|(_, bytes)| {
            let document: serde_json::Value = serde_json::from_slice(&bytes).expect("a seed document is JSON");
            let mut paths = Vec::new();
            json_paths(&document, &mut Vec::new(), &mut paths);
            (document, paths)
        })
        .collect();
    assert!(documents.len() >= 3, "the seed corpus's glTF documents");
    let (mut parsed, mut refused) = (0usize, 0usize);
    for case in 0..iterations {
        let (seed_document, paths) = &documents[(rng.next_u64() as usize) % documents.len()];
        let mut document = seed_document.clone();
        for _ in 0..1 + rng.next_u64() % 3 {
            let path = &paths[(rng.next_u64() as usize) % paths.len()];
            let Some(target) = json_at(&mut document, path) else { continue };
            *target = match rng.next_u64() % 4 {
                0 => serde_json::Value::Null,
                1 => target.as_f64().map_or(serde_json::Value::Null, |x| (x + 1.0).into()),
                _ => serde_json::from_str(GLTF_VALUES[(rng.next_u64() as usize) % GLTF_VALUES.len()]).unwrap(),
            };
        }
        let input = serde_json::to_vec(&document).unwrap();
        let result = no_panic("read glTF", seed, case, &input, || {
            read_mesh_bytes(&input, Some(MeshFormat::Gltf), Path::new("fuzz.gltf"), &limits())
        });
        match result {
            Ok(mesh) => {
                assert!(mesh.check().is_ok(), "case {case}: a mesh that fails its own check");
                parsed += 1;
            }
            Err(e) => {
                assert!(e.to_string().contains("fuzz.gltf"), "case {case}: {e}");
                refused += 1;
            }
        }
    }
    eprintln!("fuzz glTF fields: seed {seed}, {iterations} documents: {parsed} parsed, {refused} refused");
    assert!(parsed > 0 && refused > 0, "the mutations reach both outcomes ({parsed} parsed, {refused} refused)");
}

/// A small mesh of arbitrary connectivity: random positions (some repeated, some far), random
/// triangles (some degenerate, some repeated, some sharing edges with many others).
fn arbitrary_mesh(rng: &mut SplitMix64) -> Mesh {
    let vertices = 3 + (rng.next_u64() % 40) as usize;
    let faces = 1 + (rng.next_u64() % 120) as usize;
    let positions = (0..vertices)
        .map(|i| {
            if i > 0 && rng.next_u64().is_multiple_of(8) {
                [0.0, 0.0, 0.0]
            } else {
                let scale = if rng.next_u64().is_multiple_of(16) { 1e6 } else { 1.0 };
                [rng.next_f64() as f32 * scale, rng.next_f64() as f32 * scale, rng.next_f64() as f32 * scale]
            }
        })
        .collect();
    let triangles = (0..faces)
        .map(|_| {
            let mut v = || (rng.next_u64() % vertices as u64) as u32;
            [v(), v(), v()]
        })
        .collect();
    Mesh::new(positions, triangles).unwrap()
}

/// Gives `mesh` per-corner texture coordinates, normals or both, each corner one of up to three
/// values of its vertex: seams where a vertex's corners differ, anchors where three sets meet.
fn arbitrary_corner_attributes(mesh: &mut Mesh, rng: &mut SplitMix64) {
    let (uvs, normals) = match rng.next_u64() % 3 {
        0 => (true, false),
        1 => (false, true),
        _ => (true, true),
    };
    let sets = 1 + rng.next_u64() % 3;
    let palette: Vec<Vec<([f32; 2], [f32; 3])>> = (0..mesh.vertex_count())
        .map(|_| {
            (0..sets)
                .map(|_| {
                    let uv = [rng.next_f64() as f32, rng.next_f64() as f32];
                    let n = [rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() + 0.1];
                    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    (uv, n.map(|x| (x / length) as f32))
                })
                .collect()
        })
        .collect();
    let picks: Vec<([f32; 2], [f32; 3])> =
        mesh.triangles.iter().flatten().map(|&v| palette[v as usize][(rng.next_u64() % sets) as usize]).collect();
    if uvs {
        mesh.corners.set_uvs(Some(picks.iter().map(|p| p.0).collect()));
    }
    if normals {
        mesh.corners.set_normals(Some(picks.iter().map(|p| p.1).collect()));
    }
}

#[test]
fn simplify_pm_and_levels_survive_arbitrary_meshes() {
    let seed = setting("MESHLOD_FUZZ_SEED", 1);
    let iterations = setting("MESHLOD_FUZZ_ITERATIONS", 20_000);
    let mut rng = SplitMix64::new(seed ^ 0x5eed);
    let (mut simplified, mut refused) = (0usize, 0usize);
    for case in 0..iterations {
        let mut mesh = arbitrary_mesh(&mut rng);
        // Half the meshes carry per-corner attributes (seams, anchors, the attribute records).
        let with_attributes = rng.next_u64().is_multiple_of(2);
        if with_attributes {
            arbitrary_corner_attributes(&mut mesh, &mut rng);
        }
        let options = SimplifyOptions {
            target_ratio: Some(rng.next_f64() * 0.99),
            metric: match rng.next_u64() % 3 {
                0 => Metric::Qfvp { w: (rng.next_u64() % 5) as f64 * 0.5 },
                1 => Metric::Qem,
                _ => Metric::Melax,
            },
            placement: [Placement::Optimal, Placement::Paper, Placement::Endpoint][(rng.next_u64() % 3) as usize],
            boundary: if rng.next_u64().is_multiple_of(2) { BoundaryMode::Preserve } else { BoundaryMode::Lock },
            record_progressive: true,
            ..Default::default()
        };
        let text = format!("{mesh:?}");
        let result = no_panic("simplify", seed, case, text.as_bytes(), || simplify(&mesh, &options));
        match result {
            Ok(out) => {
                out.mesh.check().unwrap();
                assert_eq!(out.mesh.corners.names(), mesh.corners.names(), "case {case}: attributes kept");
                let pm = out.progressive.unwrap();
                assert_eq!(pm.has_attributes(), with_attributes, "case {case}");
                no_panic("pm", seed, case, text.as_bytes(), || {
                    for bytes in [encode(&pm), encode_lossless(&pm)] {
                        let back = decode(&bytes, Path::new("fuzz.pm")).unwrap().0;
                        assert_eq!(back.levels(), pm.levels());
                        back.at_level(back.levels()).check().unwrap();
                    }
                    for faces in [0, out.stats.faces_out, mesh.face_count()] {
                        pm.at_faces(faces).check().unwrap();
                    }
                });
                simplified += 1;
            }
            Err(MeshError::Empty { .. }) => refused += 1,
            Err(e) => panic!("case {case}: unexpected error {e} for {text}"),
        }
    }
    eprintln!("fuzz pipeline: seed {seed}, {iterations} meshes: {simplified} simplified, {refused} without faces");
    assert!(simplified > iterations as usize / 2);
}

#[test]
fn holed_spheres_close_holes_validly_and_refine_back_exactly() {
    // Closed spheres with random faces taken out (holes of every shape, some touching at a
    // vertex), half with random per-corner values: wherever triangular holes close, the result
    // stays edge-manifold and consistently oriented, and the progressive mesh, in memory and in
    // both file forms, refines back to the input's faces.
    let seed = setting("MESHLOD_FUZZ_SEED", 1);
    let iterations = setting("MESHLOD_FUZZ_ITERATIONS", 20_000) / 100;
    let mut rng = SplitMix64::new(seed ^ 0x401e);
    let mut closed = 0;
    for case in 0..iterations {
        let mut mesh = meshlod_engine::procedural::icosphere(2 + (case % 2) as u32);
        let keep = 3 + rng.next_u64() % 12;
        mesh.triangles.retain(|_| !rng.next_u64().is_multiple_of(keep));
        if case % 2 == 1 {
            arbitrary_corner_attributes(&mut mesh, &mut rng);
        }
        let options = SimplifyOptions {
            target_ratio: Some(0.5 + 0.49 * rng.next_f64()),
            record_progressive: true,
            ..Default::default()
        };
        let text = format!("{mesh:?}");
        let out = no_panic("simplify holed", seed, case, text.as_bytes(), || simplify(&mesh, &options)).unwrap();
        out.mesh.check().unwrap();
        let report = meshlod_engine::validate::validate(&out.mesh);
        assert_eq!(report.non_manifold_edges, 0, "case {case}");
        assert_eq!(report.inconsistently_oriented_edges, 0, "case {case}");
        closed += out.stats.holes_closed;
        let pm = out.progressive.unwrap();
        let full = pm.at_level(pm.levels());
        assert_eq!(full.face_count(), mesh.face_count(), "case {case}");
        for bytes in [encode(&pm), encode_lossless(&pm)] {
            let back = decode(&bytes, Path::new("holed.pm")).unwrap().0;
            assert_eq!(back.at_level(back.levels()).triangles, full.triangles, "case {case}");
        }
    }
    eprintln!("fuzz holed spheres: seed {seed}, {iterations} meshes: {closed} triangular holes closed, all valid");
    assert!(closed > iterations as usize, "{closed} holes closed in {iterations} runs");
}
