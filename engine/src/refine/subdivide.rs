//! Adaptive modified-butterfly subdivision with crack-free transitions.
//!
//! D. Zorin, P. Schröder, W. Sweldens, "Interpolating subdivision for meshes with arbitrary
//! topology", SIGGRAPH 1996; topology rules of the energy-operator LOD paper (Fig. 4).
//!
//! Decisions are made per **edge**: an edge is split when either of its faces is hot, so both
//! faces of an edge always agree on its new vertex (no crack, no T-junction). Each face is then
//! re-triangulated by how many of its edges are split:
//!
//! ```text
//!  0 split: kept     1 split: 1→2        2 split: 1→3             3 split: 1→4
//!      c                 c                   c                        c
//!     / \               /|\                 / \                      / \
//!    /   \             / | \               /   m2                  m3---m2
//!   a-----b           a--m--b             a----\ \                 / \ / \
//!                                           \  m1-b               a---m1--b
//!                                  (better-shaped diagonal of quad a-m1-m2-c)
//! ```
//!
//! New edge points, by edge type (weights always sum to 1, so planes are reproduced exactly):
//!
//! | edge | rule |
//! |---|---|
//! | interior, both ends interior of valence 6 | 8-point butterfly: ½(a+b) + ⅛(c+d) − 1⁄16(e+f+g+h) |
//! | interior, one end interior of valence n ≠ 6 | ¾·v + Σ sⱼ vⱼ around that end (n = 3: 5⁄12, −1⁄12, −1⁄12; n = 4: ⅜, 0, −⅛, 0; n ≥ 5: sⱼ = (¼ + cos(2πj/n) + ½ cos(4πj/n))/n) |
//! | interior, both ends extraordinary | the average of the two stencils |
//! | interior, one end on the boundary | the stencil around the interior end (its ring is closed), whatever its valence |
//! | interior, both ends on the boundary | ⅜(a+b) + ⅛(c+d): the butterfly's wings are not all there |
//! | boundary | 4-point: −1⁄16(v₁+v₄) + 9⁄16(v₂+v₃) along the boundary |
//! | non-manifold | midpoint |
//!
//! Old vertices keep their positions (the scheme is interpolating).

use glam::DVec3;

use crate::mesh::Mesh;
use crate::topology::{NO_EDGE, Topology};

/// Cyclic neighbour ring of a vertex, and whether it is open (boundary).
#[derive(Debug, Clone)]
pub(crate) struct Ring {
    pub neighbours: Vec<u32>,
    pub is_boundary: bool,
}

/// Rings of all vertices; `None` where the fan is not a single disk or half-disk.
pub(crate) fn vertex_rings(mesh: &Mesh, topology: &Topology) -> Vec<Option<Ring>> {
    (0..mesh.vertex_count() as u32)
        .map(|v| {
            let faces = topology.vertex_faces.get(v as usize);
            if faces.is_empty() {
                return None;
            }
            // next[x] = y for each face (v, x, y) in counter-clockwise order around v.
            let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(faces.len());
            for f in faces {
                let t = mesh.triangles[f.index()];
                let i = t.iter().position(|&x| x == v)?;
                pairs.push((t[(i + 1) % 3], t[(i + 2) % 3]));
            }
            let next = |x: u32| pairs.iter().find(|p| p.0 == x).map(|p| p.1);
            let starts: Vec<u32> = pairs.iter().map(|p| p.0).filter(|&x| !pairs.iter().any(|q| q.1 == x)).collect();
            let (start, is_boundary) = match starts.as_slice() {
                [] => (pairs[0].0, false),
                [s] => (*s, true),
                _ => return None, // several fans: non-manifold
            };
            let mut ring = vec![start];
            let mut at = start;
            while let Some(n) = next(at) {
                if n == start {
                    break;
                }
                if ring.len() > pairs.len() {
                    return None;
                }
                ring.push(n);
                at = n;
            }
            let expected = if is_boundary { pairs.len() + 1 } else { pairs.len() };
            (ring.len() == expected).then_some(Ring { neighbours: ring, is_boundary })
        })
        .collect()
}

/// Weights sⱼ of the extraordinary-vertex stencil for valence `n` (the centre weighs ¾).
pub fn extraordinary_weights(n: usize) -> Vec<f64> {
    match n {
        3 => vec![5.0 / 12.0, -1.0 / 12.0, -1.0 / 12.0],
        4 => vec![3.0 / 8.0, 0.0, -1.0 / 8.0, 0.0],
        _ => (0..n)
            .map(|j| {
                let x = std::f64::consts::TAU * j as f64 / n as f64;
                (0.25 + x.cos() + 0.5 * (2.0 * x).cos()) / n as f64
            })
            .collect(),
    }
}

/// Butterfly stencil centred on `v` for its edge to `other`.
fn centred_stencil(mesh: &Mesh, v: u32, ring: &Ring, other: u32) -> Option<DVec3> {
    let n = ring.neighbours.len();
    let start = ring.neighbours.iter().position(|&u| u == other)?;
    let weights = extraordinary_weights(n);
    let mut p = mesh.point(v) * 0.75;
    for (j, w) in weights.iter().enumerate() {
        p += mesh.point(ring.neighbours[(start + j) % n]) * *w;
    }
    Some(p)
}

/// Third vertex of the face on the other side of edge (x, y) from `not`.
fn across(mesh: &Mesh, topology: &Topology, x: u32, y: u32, not: u32) -> Option<u32> {
    topology.vertex_faces.get(x as usize).iter().find_map(|f| {
        let t = mesh.triangles[f.index()];
        (t.contains(&y) && !t.contains(&not)).then(|| *t.iter().find(|&&u| u != x && u != y).expect("three"))
    })
}

/// New position on edge `e` by the rules of the module table.
pub(crate) fn edge_point(mesh: &Mesh, topology: &Topology, rings: &[Option<Ring>], e: usize) -> DVec3 {
    let [a, b] = topology.edges[e];
    let (pa, pb) = (mesh.point(a), mesh.point(b));
    let midpoint = (pa + pb) * 0.5;
    let faces = topology.edge_faces.get(e);
    let third = |f: usize| *mesh.triangles[f].iter().find(|&&u| u != a && u != b).expect("three");
    match faces.len() {
        1 => {
            // Boundary: the neighbours of a and b along the boundary.
            let along = |v: u32, not: u32| -> Option<u32> {
                let ring = rings[v as usize].as_ref()?;
                if !ring.is_boundary {
                    return None;
                }
                let (first, last) = (ring.neighbours[0], *ring.neighbours.last().expect("non-empty"));
                if first == not {
                    Some(last)
                } else if last == not {
                    Some(first)
                } else {
                    None
                }
            };
            match (along(a, b), along(b, a)) {
                (Some(v1), Some(v4)) => (pa + pb) * (9.0 / 16.0) - (mesh.point(v1) + mesh.point(v4)) * (1.0 / 16.0),
                _ => midpoint,
            }
        }
        2 => {
            let (c, d) = (third(faces[0].index()), third(faces[1].index()));
            let (ra, rb) = (rings[a as usize].as_ref(), rings[b as usize].as_ref());
            let interior = |r: Option<&Ring>| r.is_some_and(|r| !r.is_boundary);
            match (interior(ra), interior(rb)) {
                (true, true) => {
                    let (ra, rb) = (ra.expect("interior"), rb.expect("interior"));
                    let (na, nb) = (ra.neighbours.len(), rb.neighbours.len());
                    if na == 6 && nb == 6 {
                        let wings = [
                            across(mesh, topology, a, c, b),
                            across(mesh, topology, b, c, a),
                            across(mesh, topology, a, d, b),
                            across(mesh, topology, b, d, a),
                        ];
                        if let [Some(e1), Some(e2), Some(e3), Some(e4)] = wings {
                            return midpoint + (mesh.point(c) + mesh.point(d)) * 0.125
                                - (mesh.point(e1) + mesh.point(e2) + mesh.point(e3) + mesh.point(e4)) * 0.0625;
                        }
                        return midpoint;
                    }
                    let sa = (na != 6).then(|| centred_stencil(mesh, a, ra, b)).flatten();
                    let sb = (nb != 6).then(|| centred_stencil(mesh, b, rb, a)).flatten();
                    match (sa, sb) {
                        (Some(x), Some(y)) => (x + y) * 0.5,
                        (Some(x), None) | (None, Some(x)) => x,
                        (None, None) => midpoint,
                    }
                }
                (true, false) => centred_stencil(mesh, a, ra.expect("interior"), b).unwrap_or(midpoint),
                (false, true) => centred_stencil(mesh, b, rb.expect("interior"), a).unwrap_or(midpoint),
                (false, false) => (pa + pb) * 0.375 + (mesh.point(c) + mesh.point(d)) * 0.125,
            }
        }
        _ => midpoint,
    }
}

fn quality(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let area2 = (b - a).cross(c - a).length();
    let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if sum > 0.0 { area2 / sum } else { 0.0 }
}

/// Splits the edges marked in `split_edge` (indexed like `topology.edges`) and re-triangulates
/// every face accordingly. Returns the new mesh.
pub(crate) fn subdivide_edges(mesh: &Mesh, topology: &Topology, split_edge: &[bool]) -> Mesh {
    let rings = vertex_rings(mesh, topology);
    let mut positions = mesh.positions.clone();
    let mut edge_vertex = vec![u32::MAX; topology.edges.len()];
    for (e, &split) in split_edge.iter().enumerate() {
        if split {
            let p = edge_point(mesh, topology, &rings, e);
            edge_vertex[e] = positions.len() as u32;
            positions.push([p.x as f32, p.y as f32, p.z as f32]);
        }
    }
    let point = |v: u32, positions: &Vec<[f32; 3]>| {
        let p = positions[v as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    };
    // Each new face as local corners of its parent: 0–2 its corners, 3–5 the midpoints of its
    // edges (k, k + 1), whose values are the average of the parent's at the edge's two corners —
    // in that face, so the two sides of a seam each keep their own values.
    let mut triangles = Vec::with_capacity(mesh.face_count() * 2);
    let mut locals: Vec<(usize, [usize; 3])> = Vec::new();
    let carry = !mesh.corners.is_empty();
    for (f, &t) in mesh.triangles.iter().enumerate() {
        let mid: [u32; 3] =
            topology.face_edges[f].map(|e| if e == NO_EDGE { u32::MAX } else { edge_vertex[e as usize] });
        let global = |l: usize| if l < 3 { t[l] } else { mid[l - 3] };
        let mut push = |l: [usize; 3]| {
            triangles.push(l.map(global));
            if carry {
                locals.push((f, l));
            }
        };
        let count = mid.iter().filter(|&&m| m != u32::MAX).count();
        match count {
            0 => push([0, 1, 2]),
            1 => {
                let i = mid.iter().position(|&m| m != u32::MAX).expect("one");
                let (a, b, c, m) = (i, (i + 1) % 3, (i + 2) % 3, 3 + i);
                push([a, m, c]);
                push([m, b, c]);
            }
            2 => {
                // Rotate so that edges a-b (m1) and b-c (m2) are split and c-a is not.
                let i = mid.iter().position(|&m| m == u32::MAX).expect("one unsplit");
                let (c, a, b) = (i, (i + 1) % 3, (i + 2) % 3);
                let (m1, m2) = (3 + (i + 1) % 3, 3 + (i + 2) % 3);
                push([m1, b, m2]);
                let q = |x, y, z| {
                    let p = |l| point(global(l), &positions);
                    quality(p(x), p(y), p(z))
                };
                // Quad a-m1-m2-c: the diagonal whose worse triangle is better.
                if q(a, m1, m2).min(q(a, m2, c)) >= q(a, m1, c).min(q(m1, m2, c)) {
                    push([a, m1, m2]);
                    push([a, m2, c]);
                } else {
                    push([a, m1, c]);
                    push([m1, m2, c]);
                }
            }
            _ => {
                for l in [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]] {
                    push(l);
                }
            }
        }
    }
    let corners = if carry { interpolate_corners(&mesh.corners, &locals) } else { Default::default() };
    Mesh { positions, triangles, corners }
}

/// The corner values of new faces given as (parent face, local corners): a parent corner's value,
/// or for a midpoint the mean of its edge's two corners (normals and tangent directions made unit
/// again, a tangent's handedness the first corner's, skins blended; an integer value, such as a
/// material, the first corner's).
fn interpolate_corners(
    parent: &crate::mesh::CornerAttributes,
    locals: &[(usize, [usize; 3])],
) -> crate::mesh::CornerAttributes {
    use crate::attributes::mean;
    use crate::mesh::{Semantic, Values};
    // The two parent corners a local corner averages (the same one twice for a corner).
    let ends = |f: usize, l: usize| if l < 3 { (3 * f + l, 3 * f + l) } else { (3 * f + l - 3, 3 * f + (l - 2) % 3) };
    let corners = || locals.iter().flat_map(|&(f, l)| l.map(|l| ends(f, l)));
    let unit = |n: [f32; 3]| {
        let length = n.iter().map(|c| c * c).sum::<f32>().sqrt();
        if length > 0.0 && (length - 1.0).abs() > 1e-6 { n.map(|c| c / length) } else { n }
    };
    let mut out = parent.pick(std::iter::empty());
    for c in parent.channels() {
        let values = match (&c.semantic, &c.values) {
            (Semantic::Normal, Values::F3(v)) => {
                Values::F3(corners().map(|e| if e.0 == e.1 { v[e.0] } else { unit(mean(v, e)) }).collect())
            }
            (Semantic::Tangent, Values::F4(v)) => Values::F4(
                corners()
                    .map(|e| {
                        if e.0 == e.1 {
                            return v[e.0];
                        }
                        let [x, y, z, _] = mean(v, e);
                        let [x, y, z] = unit([x, y, z]);
                        [x, y, z, v[e.0][3]]
                    })
                    .collect(),
            ),
            (Semantic::Joints(set), Values::U16x4(j)) => match parent.channel(&Semantic::Weights(*set)) {
                Some(Values::F4(w)) => Values::U16x4(corners().map(|e| blend_skin(j, w, e).0).collect()),
                _ => c.values.means(corners()),
            },
            (Semantic::Weights(set), Values::F4(w)) => match parent.channel(&Semantic::Joints(*set)) {
                Some(Values::U16x4(j)) => Values::F4(corners().map(|e| blend_skin(j, w, e).1).collect()),
                _ => c.values.means(corners()),
            },
            (_, values) => values.means(corners()),
        };
        out.set(c.semantic.clone(), Some(values));
    }
    out
}

/// The skin of a midpoint between corners `x` and `y`: each joint's weight averaged over the two,
/// the four heaviest kept and their weights scaled to sum to 1 (a corner's own skin unchanged).
fn blend_skin(joints: &[[u16; 4]], weights: &[[f32; 4]], (x, y): (usize, usize)) -> ([u16; 4], [f32; 4]) {
    if x == y {
        return (joints[x], weights[x]);
    }
    let mut sum: Vec<(u16, f32)> = Vec::with_capacity(8);
    for c in [x, y] {
        for (&j, &w) in joints[c].iter().zip(&weights[c]) {
            if w == 0.0 {
                continue;
            }
            match sum.iter_mut().find(|s| s.0 == j) {
                Some(s) => s.1 += 0.5 * w,
                None => sum.push((j, 0.5 * w)),
            }
        }
    }
    sum.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    sum.truncate(4);
    let (mut j, mut w) = ([0u16; 4], [0f32; 4]);
    for (k, &(joint, weight)) in sum.iter().enumerate() {
        (j[k], w[k]) = (joint, weight);
    }
    crate::mesh::normalize_weights(&mut w);
    (j, w)
}

/// Uniform modified-butterfly subdivision: every edge split, every face 1→4.
pub fn subdivide_uniform(mesh: &Mesh) -> Mesh {
    let topology = Topology::new(mesh);
    subdivide_edges(mesh, &topology, &vec![true; topology.edges.len()])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural;
    use crate::validate::validate;

    #[test]
    fn weights_sum_to_a_quarter() {
        for n in 3..12 {
            let s: f64 = extraordinary_weights(n).iter().sum();
            assert!((s - 0.25).abs() < 1e-12, "n = {n}: {s}");
        }
    }

    #[test]
    fn planes_are_reproduced_exactly() {
        // A flat terrain patch (regular interior, boundary, corners of valence 2 and 3) tilted
        // into a general plane: every new vertex must lie on it.
        let grid = procedural::terrain(6, 0);
        let plane = |x: f32, y: f32| 0.3 * x - 0.7 * y + 0.25;
        let mesh = Mesh::new(grid.positions.iter().map(|p| [p[0], p[1], plane(p[0], p[1])]).collect(), grid.triangles)
            .unwrap();
        let fine = subdivide_uniform(&mesh);
        assert_eq!(fine.face_count(), 4 * mesh.face_count());
        for p in &fine.positions {
            assert!((p[2] - plane(p[0], p[1])).abs() < 1e-5, "{p:?} is off the plane");
        }
    }

    #[test]
    fn regular_lattice_reproduces_the_butterfly_weights() {
        // Heights 0 everywhere but 1 at one interior vertex of a regular lattice: the new points
        // around it take exactly the stencil weights (½ on its edges, ⅛ and −1⁄16 elsewhere).
        let grid = procedural::terrain(10, 0);
        let centre = 5 * 11 + 5;
        let positions: Vec<[f32; 3]> =
            grid.positions.iter().enumerate().map(|(v, p)| [p[0], p[1], if v == centre { 1.0 } else { 0.0 }]).collect();
        let mesh = Mesh::new(positions, grid.triangles).unwrap();
        let fine = subdivide_uniform(&mesh);
        let mut heights: Vec<f32> =
            fine.positions[mesh.vertex_count()..].iter().map(|p| p[2]).filter(|h| h.abs() > 1e-9).collect();
        heights.sort_by(|a, b| a.total_cmp(b));
        let count = |h: f32| heights.iter().filter(|&&x| (x - h).abs() < 1e-6).count();
        assert_eq!(count(0.5), 6, "six edges at the centre: {heights:?}");
        assert_eq!(count(0.125), 6, "six edges opposite the centre in its faces");
        assert_eq!(count(-0.0625), 12, "twelve edges with the centre as a wing");
        assert_eq!(heights.len(), 24);
    }

    #[test]
    fn uniform_subdivision_keeps_topology() {
        for (name, mesh) in [
            ("sphere", procedural::icosphere(2)),
            ("terrain", procedural::terrain(5, 2)),
            ("box", procedural::sharp_box(2)),
        ] {
            let before = validate(&mesh);
            let fine = subdivide_uniform(&mesh);
            let after = validate(&fine);
            assert!(after.is_manifold_oriented, "{name}");
            assert_eq!(after.boundary_loops, before.boundary_loops, "{name}");
            assert_eq!(after.euler_characteristic, before.euler_characteristic, "{name}");
        }
    }
}
