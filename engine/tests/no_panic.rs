//! Randomised no-panic tests: mutated files through every reader, random triangle soups through
//! every algorithm. Each call must return `Ok` or a clean `Err`, never panic or hang.

use std::path::Path;

use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes, write_mesh_to};
use meshlod_engine::pm_format::{decode, encode, encode_lossless};
use meshlod_engine::refine::{RefineMode, RefineOptions, refine};
use meshlod_engine::rng::SplitMix64;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::validate::{clean, validate};
use meshlod_engine::{Mesh, procedural};

fn mutate(bytes: &[u8], rng: &mut SplitMix64) -> Vec<u8> {
    let mut out = bytes.to_vec();
    match rng.next_u64() % 4 {
        0 => {
            // flip a few bytes
            for _ in 0..1 + rng.next_u64() % 8 {
                let i = (rng.next_u64() as usize) % out.len().max(1);
                if let Some(b) = out.get_mut(i) {
                    *b ^= 1 << (rng.next_u64() % 8);
                }
            }
        }
        1 => out.truncate((rng.next_u64() as usize) % (out.len() + 1)),
        2 => {
            // duplicate a slice somewhere
            let a = (rng.next_u64() as usize) % (out.len() + 1);
            let b = (a + (rng.next_u64() as usize) % 64).min(out.len());
            let piece = out[a..b].to_vec();
            let at = (rng.next_u64() as usize) % (out.len() + 1);
            out.splice(at..at, piece);
        }
        _ => {
            // replace a digit run with a huge or negative number
            if let Some(i) = out.iter().position(|b| b.is_ascii_digit()) {
                let repl: &[u8] = if rng.next_u64().is_multiple_of(2) { b"4294967295999" } else { b"-7" };
                out.splice(i..i + 1, repl.iter().copied());
            }
        }
    }
    out
}

#[test]
fn mutated_files_never_panic_any_reader() {
    let mesh = procedural::bumpy_blob(8, 12, 1);
    let mut rng = SplitMix64::new(42);
    let limits = ReadLimits { max_vertices: 100_000, max_faces: 100_000, cancel: None };
    for format in [MeshFormat::Obj, MeshFormat::Ply] {
        let mut bytes = Vec::new();
        write_mesh_to(&mut bytes, &mesh, format).unwrap();
        let ascii_ply = {
            let mut s = format!(
                "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
                mesh.vertex_count(),
                mesh.face_count()
            );
            for p in &mesh.positions {
                s += &format!("{} {} {}\n", p[0], p[1], p[2]);
            }
            for t in &mesh.triangles {
                s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
            }
            s.into_bytes()
        };
        for source in [&bytes, &ascii_ply] {
            for _ in 0..400 {
                let input = mutate(source, &mut rng);
                let _ = read_mesh_bytes(&input, Some(format), Path::new("fuzz"), &limits);
                let _ = read_mesh_bytes(&input, None, Path::new("fuzz"), &limits);
            }
        }
    }
    let pm =
        simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), record_progressive: true, ..Default::default() })
            .unwrap()
            .progressive
            .unwrap();
    for bytes in [encode(&pm), encode_lossless(&pm)] {
        for _ in 0..1000 {
            let input = mutate(&bytes, &mut rng);
            if let Ok((decoded, _)) = decode(&input, Path::new("fuzz.pm")) {
                // Whatever decodes must also refine without trouble.
                let _ = decoded.at_level(decoded.levels());
            }
        }
    }
}

#[test]
fn random_triangle_soups_never_panic_any_algorithm() {
    let mut rng = SplitMix64::new(7);
    for round in 0..120 {
        let vertices = 3 + (rng.next_u64() % 40) as usize;
        let faces = 1 + (rng.next_u64() % 80) as usize;
        let positions: Vec<[f32; 3]> = (0..vertices)
            .map(|_| {
                // Some coincident and collinear points on purpose.
                let snap = |x: f64| if rng_bit(round) { (x * 2.0).round() as f32 / 2.0 } else { x as f32 };
                [snap(rng.next_f64()), snap(rng.next_f64()), snap(rng.next_f64() * 0.1)]
            })
            .collect();
        let triangles: Vec<[u32; 3]> =
            (0..faces).map(|_| [0, 1, 2].map(|_| (rng.next_u64() % vertices as u64) as u32)).collect();
        let mesh = Mesh::new(positions, triangles).unwrap();
        let _ = validate(&mesh);
        let (cleaned, _) = clean(&mesh);
        for m in [&mesh, &cleaned] {
            let _ = simplify(
                m,
                &SimplifyOptions { target_ratio: Some(0.8), record_progressive: true, ..Default::default() },
            )
            .map(|r| r.progressive.map(|pm| pm.at_level(pm.levels())));
            for mode in [RefineMode::Subdivide, RefineMode::Simplify, RefineMode::Both] {
                let _ = refine(m, &RefineOptions { etc: Some(1.0), mode, ..Default::default() });
            }
            let _ = refine(
                m,
                &RefineOptions { etc: None, target_faces: Some(m.face_count() * 2 + 1), ..Default::default() },
            );
            let _ = meshlod_engine::hausdorff::hausdorff(m, &mesh, &Default::default());
            let _ = meshlod_engine::features::shape_features(m);
        }
    }
}

fn rng_bit(round: usize) -> bool {
    round.is_multiple_of(3)
}
