//! Procedurally generated meshes for tests, examples and a fresh user without data.
//!
//! Every generator is deterministic, returns a clean, manifold, consistently (outward) oriented
//! mesh, and takes a resolution parameter so tests can pick their size.

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use glam::DVec3;

use crate::mesh::Mesh;

fn to_mesh(points: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    let positions = points.into_iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
    let mesh = Mesh { positions, triangles, corners: Default::default() };
    debug_assert!(mesh.check().is_ok());
    mesh
}

/// Unit sphere by repeated 1→4 subdivision of an icosahedron: `20 · 4^level` triangles.
pub fn icosphere(level: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut points: Vec<DVec3> = [
        (-1., t, 0.),
        (1., t, 0.),
        (-1., -t, 0.),
        (1., -t, 0.),
        (0., -1., t),
        (0., 1., t),
        (0., -1., -t),
        (0., 1., -t),
        (t, 0., -1.),
        (t, 0., 1.),
        (-t, 0., -1.),
        (-t, 0., 1.),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, points: &mut Vec<DVec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                points.push(((points[a as usize] + points[b as usize]) * 0.5).normalize());
                points.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut points);
            let bc = midpoint(b, c, &mut points);
            let ca = midpoint(c, a, &mut points);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    to_mesh(points, triangles)
}

/// Grid-parameterised closed surface: `u` wraps, `v` wraps (torus-like topology).
fn wrapped_grid(u_steps: u32, v_steps: u32, point: impl Fn(f64, f64) -> DVec3) -> Mesh {
    let mut points = Vec::with_capacity((u_steps * v_steps) as usize);
    for i in 0..u_steps {
        for j in 0..v_steps {
            points.push(point(i as f64 / u_steps as f64, j as f64 / v_steps as f64));
        }
    }
    let id = |i: u32, j: u32| (i % u_steps) * v_steps + (j % v_steps);
    let mut triangles = Vec::with_capacity((2 * u_steps * v_steps) as usize);
    for i in 0..u_steps {
        for j in 0..v_steps {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    to_mesh(points, triangles)
}

/// Torus with major radius 1 and minor radius `minor`, `2 · major_steps · minor_steps` triangles.
pub fn torus(major_steps: u32, minor_steps: u32, minor: f64) -> Mesh {
    wrapped_grid(major_steps.max(3), minor_steps.max(3), |u, v| {
        let (su, cu) = (u * TAU).sin_cos();
        let (sv, cv) = (v * TAU).sin_cos();
        DVec3::new((1.0 + minor * cv) * cu, (1.0 + minor * cv) * su, minor * sv)
    })
}

/// Axis-aligned box `[-1, 1] × [-0.5, 0.5] × [-0.25, 0.25]` with each face an `n × n` grid: flat
/// faces meeting at sharp 90° edges, `12 n²` triangles.
pub fn sharp_box(n: u32) -> Mesh {
    let n = n.max(1);
    let half = DVec3::new(1.0, 0.5, 0.25);
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    // Each face: a fixed axis and sign; the two other axes span the grid (ordered for outward
    // normals).
    for axis in 0..3 {
        for sign in [-1i64, 1] {
            let (mut ua, mut va) = ((axis + 1) % 3, (axis + 2) % 3);
            if sign < 0 {
                std::mem::swap(&mut ua, &mut va);
            }
            let mut grid = vec![0u32; ((n + 1) * (n + 1)) as usize];
            for i in 0..=n {
                for j in 0..=n {
                    // Integer lattice key so that vertices on shared box edges weld exactly.
                    let mut key = [0i64; 3];
                    key[axis] = sign * n as i64;
                    key[ua] = 2 * i as i64 - n as i64;
                    key[va] = 2 * j as i64 - n as i64;
                    let v = *index.entry(key).or_insert_with(|| {
                        points.push(DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64) / n as f64 * half);
                        points.len() as u32 - 1
                    });
                    grid[(i * (n + 1) + j) as usize] = v;
                }
            }
            for i in 0..n {
                for j in 0..n {
                    let g = |a: u32, b: u32| grid[(a * (n + 1) + b) as usize];
                    triangles.push([g(i, j), g(i + 1, j), g(i + 1, j + 1)]);
                    triangles.push([g(i, j), g(i + 1, j + 1), g(i, j + 1)]);
                }
            }
        }
    }
    to_mesh(points, triangles)
}

/// `mesh` with faces taken out to make triangular holes: of every `every`-th face (`every` ≥ 1),
/// each that shares no vertex with a face taken out before, so that every hole is a boundary loop
/// of three edges whose vertices are on no other boundary (each keeps one open fan). For the
/// hole-closing collapses of the simplifier, in tests and examples.
pub fn with_triangular_holes(mesh: &Mesh, every: usize) -> Mesh {
    let every = every.max(1);
    let mut used = vec![false; mesh.vertex_count()];
    let mut out = mesh.clone();
    out.triangles.clear();
    for (f, t) in mesh.triangles.iter().enumerate() {
        if f % every == 0 && t.iter().all(|&v| !used[v as usize]) {
            t.iter().for_each(|&v| used[v as usize] = true);
        } else {
            out.triangles.push(*t);
        }
    }
    out
}

/// Deterministic value noise in [-1, 1] from an integer lattice hash, smoothly interpolated.
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let hash = |i: i64, j: i64| {
        let mut h =
            (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F) ^ seed;
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let (i, j) = (x.floor() as i64, y.floor() as i64);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let smooth = |t: f64| t * t * (3.0 - 2.0 * t);
    let (sx, sy) = (smooth(fx), smooth(fy));
    let top = hash(i, j) * (1.0 - sx) + hash(i + 1, j) * sx;
    let bottom = hash(i, j + 1) * (1.0 - sx) + hash(i + 1, j + 1) * sx;
    top * (1.0 - sy) + bottom * sy
}

/// A square height-field patch `[-1, 1]²` with fractal noise: one open boundary loop,
/// `2 n²` triangles.
pub fn terrain(n: u32, seed: u64) -> Mesh {
    let n = n.max(1);
    let mut points = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (2.0 * i as f64 / n as f64 - 1.0, 2.0 * j as f64 / n as f64 - 1.0);
            let height: f64 = (0..5)
                .map(|octave| {
                    let f = 2f64.powi(octave);
                    value_noise(x * 2.0 * f, y * 2.0 * f, seed + octave as u64) / f
                })
                .sum();
            points.push(DVec3::new(x, y, 0.25 * height));
        }
    }
    let id = |i: u32, j: u32| i * (n + 1) + j;
    let mut triangles = Vec::with_capacity((2 * n * n) as usize);
    for i in 0..n {
        for j in 0..n {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    to_mesh(points, triangles)
}

/// A closed "bumpy blob": a latitude/longitude sphere (dense near the poles, sparse at the
/// equator: non-uniform density) displaced by smooth bumps. `2 · rings · segments` triangles.
pub fn bumpy_blob(rings: u32, segments: u32, seed: u64) -> Mesh {
    let (rings, segments) = (rings.max(3), segments.max(3));
    let radius = |dir: DVec3| {
        let bumps = 0.15 * (5.0 * dir.x).sin() * (4.0 * dir.y).cos()
            + 0.08 * value_noise(3.0 * dir.x + 7.0, 3.0 * dir.y + 3.0 * dir.z, seed);
        1.0 + bumps + 0.1 * dir.z * dir.z
    };
    let mut points = vec![DVec3::new(0.0, 0.0, radius(DVec3::Z)), DVec3::new(0.0, 0.0, -radius(-DVec3::Z))];
    for r in 1..rings {
        let theta = PI * r as f64 / rings as f64;
        for s in 0..segments {
            let phi = TAU * s as f64 / segments as f64;
            let dir = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            points.push(dir * radius(dir));
        }
    }
    let ring = |r: u32, s: u32| 2 + (r - 1) * segments + (s % segments);
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s), ring(1, s + 1)]);
        triangles.push([1, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    to_mesh(points, triangles)
}
