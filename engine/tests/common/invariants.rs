//! The simplifier's output invariants and the exact progressive-mesh round trip, shared by the
//! simplification test crates.

use std::collections::HashMap;

use meshlod_engine::Mesh;
use meshlod_engine::pm::{Hole, ProgressiveMesh};
use meshlod_engine::simplify::{Simplified, prepare};
use meshlod_engine::validate::validate;

pub fn canonical(t: [u32; 3]) -> [u32; 3] {
    let i = (0..3).min_by_key(|&i| t[i]).unwrap();
    [t[i], t[(i + 1) % 3], t[(i + 2) % 3]]
}

/// Refining all the way must give back the prepared input: positions bit for bit, the same faces
/// with the same orientation (up to rotation), but for the `aside` faces that the run set aside as
/// stacked on another (copies and back faces: each on the same three vertices as a face kept).
pub fn assert_exact_round_trip(name: &str, input: &Mesh, pm: &ProgressiveMesh, aside: usize) {
    let (prepared, _, _) = prepare(input);
    let full = pm.at_level(pm.levels());
    let map = pm.input_vertex().expect("built by the simplifier");
    assert_eq!(full.vertex_count(), prepared.vertex_count(), "{name}: vertex count");
    // prepare() keeps referenced vertices in input order: map input index → prepared index.
    let mut prepared_of_input = HashMap::new();
    let mut k = 0;
    let mut used = vec![false; input.vertex_count()];
    for t in &input.triangles {
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            for &v in t {
                used[v as usize] = true;
            }
        }
    }
    for (v, &u) in used.iter().enumerate() {
        if u {
            prepared_of_input.insert(v as u32, k);
            k += 1;
        }
    }
    for (v, p) in full.positions.iter().enumerate() {
        let original = input.positions[map[v] as usize];
        assert_eq!(p.map(f32::to_bits), original.map(f32::to_bits), "{name}: vertex {v} moved");
    }
    let mut got: Vec<[u32; 3]> =
        full.triangles.iter().map(|t| canonical(t.map(|v| prepared_of_input[&map[v as usize]]))).collect();
    let mut want: Vec<[u32; 3]> = prepared.triangles.iter().map(|&t| canonical(t)).collect();
    got.sort_unstable();
    want.sort_unstable();
    // The faces set aside: in the input and not in the full level, each stacked on a face there.
    let mut missing = Vec::new();
    let mut kept = got.iter().peekable();
    for face in &want {
        if kept.peek() == Some(&face) {
            kept.next();
        } else {
            missing.push(*face);
        }
    }
    assert_eq!(kept.next(), None, "{name}: a face after refining all splits that the input lacks");
    let sets: std::collections::HashSet<[u32; 3]> = got.iter().map(|t| sorted(*t)).collect();
    assert!(missing.iter().all(|t| sets.contains(&sorted(*t))), "{name}: a face lost that stacks on none kept");
    assert_eq!(missing.len(), aside, "{name}: faces differ after refining all splits");
}

pub fn sorted(mut t: [u32; 3]) -> [u32; 3] {
    t.sort_unstable();
    t
}

/// Output invariants: edge-manifold, no new non-manifold vertices, consistently oriented, no
/// degenerate faces, boundaries kept but for the triangular holes the run says it closed, no
/// folded-over face pairs.
pub fn assert_valid_output(name: &str, input: &Mesh, out: &Simplified) {
    let output = &out.mesh;
    let holes = out.stats.holes_closed;
    if let Some(pm) = &out.progressive {
        let opened = pm.splits().iter().filter(|s| s.hole != Hole::None).count();
        assert_eq!(opened, holes, "{name}: splits that open a hole");
    }
    let before = validate(input);
    let after = validate(output);
    assert_eq!(after.non_manifold_edges, before.non_manifold_edges.min(after.non_manifold_edges), "{name}");
    if before.non_manifold_edges == 0 {
        assert_eq!(after.non_manifold_edges, 0, "{name}: non-manifold edge created");
    }
    assert!(after.non_manifold_vertices <= before.non_manifold_vertices, "{name}: non-manifold vertex created");
    if before.inconsistently_oriented_edges == 0 {
        assert_eq!(after.inconsistently_oriented_edges, 0, "{name}: orientation broken");
    }
    // (Corpus inputs may have their own; none is added.)
    assert!(after.degenerate_faces <= before.degenerate_faces, "{name}: degenerate face created");
    assert!(after.duplicate_faces <= before.duplicate_faces, "{name}: duplicate face created");
    if before.non_manifold_edges == 0 && before.non_manifold_vertices == 0 {
        assert_eq!(after.boundary_loops + holes, before.boundary_loops, "{name}: boundary loops changed");
    }
    // Where loops meet at non-manifold vertices "loops" are ambiguous; the pieces of the
    // boundary-edge graph are not (a closed hole's three vertices were on no other loop).
    assert_eq!(
        super::boundary_graph(output).0 + holes,
        super::boundary_graph(input).0,
        "{name}: boundary pieces changed"
    );
    assert_eq!(after.components, before.components, "{name}: a component vanished or split");
    // Folded pairs: two faces sharing an edge whose normals point (almost) opposite ways. Scans
    // may already have some; simplification must not add any.
    assert!(
        folded_pairs(output) <= folded_pairs(input),
        "{name}: {} folded face pairs, input had {}",
        folded_pairs(output),
        folded_pairs(input)
    );
}

/// `mesh` without the faces that copy an earlier one (the same corners the same way round).
pub fn without_copies(mesh: &Mesh) -> Mesh {
    let mut seen = std::collections::HashSet::new();
    let triangles = mesh.triangles.iter().filter(|&&t| seen.insert(canonical(t))).copied().collect();
    Mesh::new(mesh.positions.clone(), triangles).unwrap()
}

/// The faces a run set aside as stacked on another.
pub fn set_aside(out: &Simplified) -> usize {
    out.stats.dropped_duplicate_faces + out.stats.back_faces
}

pub fn folded_pairs(mesh: &Mesh) -> usize {
    let mut edge_faces: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (f, t) in mesh.triangles.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            edge_faces.entry((a.min(b), a.max(b))).or_default().push(f);
        }
    }
    let normal = |f: usize| mesh.face_area_vector(f).normalize_or_zero();
    // (A face and its back, on the same three vertices, are one double-sided face, not a fold.)
    let back_to_back = |f: usize, g: usize| sorted(mesh.triangles[f]) == sorted(mesh.triangles[g]);
    edge_faces
        .values()
        .filter(|faces| {
            faces.len() == 2 && !back_to_back(faces[0], faces[1]) && normal(faces[0]).dot(normal(faces[1])) < -0.999
        })
        .count()
}

/// A mesh's faces as sorted corner positions, sorted: equal for the same faces whatever the
/// vertex numbering and corner rotation.
pub fn face_key(m: &Mesh) -> Vec<[[u32; 3]; 3]> {
    let mut faces: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let mut c = t.map(|v| m.positions[v as usize].map(f32::to_bits));
            c.sort_unstable();
            c
        })
        .collect();
    faces.sort_unstable();
    faces
}
