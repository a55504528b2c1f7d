//! Validation and cleaning on crafted broken meshes, procedural shapes and the shared meshes.

use meshlod_engine::io::read_mesh;
use meshlod_engine::validate::{clean, validate};
use meshlod_engine::{Mesh, MeshError, procedural};

mod common;

/// Two triangles sharing only vertex 0 (a bowtie), drawn:
///
/// ```text
///   3---4       1---2
///    \ /   and   \ /     joined at 0
///     0           0
/// ```
fn bowtie() -> Mesh {
    Mesh::new(vec![[0., 0., 0.], [1., 1., 0.], [2., 1., 0.], [-2., 1., 0.], [-1., 1., 0.]], vec![[0, 2, 1], [0, 4, 3]])
        .unwrap()
}

#[test]
fn constructor_refuses_nan_and_out_of_range() {
    let e = Mesh::new(vec![[0., f32::NAN, 0.]], vec![]).unwrap_err();
    assert!(matches!(e, MeshError::NonFiniteCoordinate { vertex: 0, .. }), "{e}");
    let e = Mesh::new(vec![[0.; 3]; 3], vec![[0, 1, 2], [0, 1, 3]]).unwrap_err();
    assert_eq!(e, MeshError::IndexOutOfRange { face: 1, index: 3, vertex_count: 3 });
    assert!(e.to_string().contains("face 1 refers to vertex 3"));
}

#[test]
fn procedural_meshes_are_clean_closed_or_bounded_as_designed() {
    for (name, mesh, loops, euler) in [
        ("icosphere", procedural::icosphere(3), 0, 2),
        ("torus", procedural::torus(30, 12, 0.3), 0, 0),
        ("box", procedural::sharp_box(6), 0, 2),
        ("terrain", procedural::terrain(20, 1), 1, 1),
        ("blob", procedural::bumpy_blob(20, 30, 2), 0, 2),
    ] {
        let r = validate(&mesh);
        assert!(r.is_manifold_oriented, "{name}: {r:?}");
        assert_eq!(r.boundary_loops, loops, "{name}");
        assert_eq!(r.euler_characteristic, euler, "{name}");
        assert_eq!(
            (r.degenerate_faces, r.duplicate_faces, r.unreferenced_vertices, r.components),
            (0, 0, 0, 1),
            "{name}"
        );
    }
}

#[test]
fn crafted_defects_are_counted() {
    let r = validate(&bowtie());
    assert_eq!(r.non_manifold_vertices, 1);
    assert_eq!(r.non_manifold_edges, 0);
    assert_eq!(r.components, 1);
    assert_eq!(r.boundary_loops, 2);

    // Three faces on edge 0-1 (a fin), one face flipped, a duplicate, a degenerate and an
    // unreferenced vertex.
    let positions =
        vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., -1., 0.], [0., 0., 1.], [5., 5., 5.], [2., 0., 0.]];
    let triangles = vec![
        [0, 1, 2], // fin 1
        [0, 3, 1], // fin 2 (consistent with fin 1)
        [0, 1, 4], // fin 3: third face on 0-1
        [2, 1, 0], // duplicate of fin 1, opposite winding
        [0, 1, 6], // zero area (collinear)
        [2, 2, 4], // repeated index
    ];
    let m = Mesh::new(positions, triangles).unwrap();
    let r = validate(&m);
    assert_eq!(r.non_manifold_edges, 1, "{r:?}");
    assert_eq!(r.duplicate_faces, 1);
    assert_eq!(r.degenerate_faces, 2);
    assert_eq!(r.repeated_index_faces, 1);
    assert_eq!(r.unreferenced_vertices, 1);
    assert!(!r.is_manifold_oriented);

    let (cleaned, report) = clean(&m);
    assert_eq!(report.removed_degenerate_faces, 2);
    assert_eq!(report.removed_duplicate_faces, 1);
    // Vertex 5 is unreferenced; vertex 6 only by the removed degenerate face.
    assert_eq!(report.removed_unreferenced_vertices, 2);
    assert_eq!(cleaned.face_count(), 3);
    assert_eq!(cleaned.vertex_count(), 5);
}

#[test]
fn inconsistent_orientation_is_detected() {
    let m =
        Mesh::new(vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]], vec![[0, 1, 2], [1, 2, 3]]).unwrap();
    let r = validate(&m);
    assert_eq!(r.inconsistently_oriented_edges, 1);
    assert!(!r.is_manifold_oriented);
}

#[test]
fn clean_welds_exact_duplicates_and_keeps_attributes_aligned() {
    // A quad stored as two triangles that do not share vertices (as OBJ exporters split seams).
    let m = Mesh::new(
        vec![[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 0., 0.], [1., 1., 0.], [0., 1., -0.0]],
        vec![[0, 1, 2], [3, 4, 5]],
    )
    .unwrap();
    assert_eq!(validate(&m).components, 2);
    let (c, report) = clean(&m);
    assert_eq!(report.welded_vertices, 2);
    assert_eq!(c.vertex_count(), 4);
    assert_eq!(c.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    let r = validate(&c);
    assert_eq!((r.components, r.boundary_loops), (1, 1));
    assert!(r.is_manifold_oriented);
}

#[test]
fn shared_meshes_report_their_known_defects() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("shared_meshes_report_their_known_defects") else {
        return;
    };
    let load = |name: &str| read_mesh(dir.join(format!("{name}.obj"))).unwrap();

    let cow = validate(&load("cow"));
    assert_eq!((cow.vertices, cow.faces), (2903, 5804));
    assert_eq!(cow.non_manifold_vertices, 1, "cow has one bowtie vertex");
    assert_eq!(cow.non_manifold_edges, 0);

    let bunny_mesh = load("stanford-bunny");
    let bunny = validate(&bunny_mesh);
    assert_eq!((bunny.vertices, bunny.faces), (35947, 69451));
    assert_eq!(bunny.unreferenced_vertices, 1113);
    assert!(bunny.boundary_loops >= 1, "bunny has holes at its base");
    let (cleaned, report) = clean(&bunny_mesh);
    assert_eq!(report.removed_unreferenced_vertices, 1113);
    assert_eq!(validate(&cleaned).unreferenced_vertices, 0);

    let teapot = validate(&load("teapot"));
    assert!(teapot.components > 1 && teapot.boundary_loops > 0, "{teapot:?}");

    let rocker = validate(&load("rocker-arm"));
    assert!(rocker.euler_characteristic < 2, "rocker-arm has genus > 0: {rocker:?}");

    for name in meshlod_engine::datasets::SHARED_MESHES {
        let mesh = load(name);
        let r = validate(&mesh);
        let (c, _) = clean(&mesh);
        let rc = validate(&c);
        assert_eq!(
            (rc.degenerate_faces, rc.duplicate_faces, rc.unreferenced_vertices),
            (0, 0, 0),
            "{name} after clean"
        );
        assert!(rc.faces <= r.faces && rc.faces > 0, "{name}");
    }
}

#[test]
fn a_hub_vertex_is_validated_in_n_log_n() {
    // A disk fanned from its centre: one vertex with 200 000 faces. Its fan count was quadratic in
    // the valence (4·10¹⁰ steps here); it is one flood fill with sorted lookups now.
    let n = 200_000u32;
    let mut positions = vec![[0.0f32, 0.0, 0.0]];
    positions.extend((0..n).map(|i| {
        let a = std::f32::consts::TAU * i as f32 / n as f32;
        [a.cos(), a.sin(), 0.0]
    }));
    let triangles = (0..n).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
    let report = validate(&Mesh::new(positions, triangles).unwrap());
    assert_eq!(report.faces, n as usize);
    assert_eq!(report.non_manifold_vertices, 0);
    assert_eq!(report.boundary_loops, 1);
    assert!(report.is_manifold_oriented);
}

#[test]
fn a_boundary_loop_whose_faces_turn_over_along_it_is_one_loop_in_any_numbering() {
    // A grid (one boundary loop) with a band of faces from one border to the opposite one wound
    // the other way: along the loop the faces' direction flips four times. It is still one loop,
    // and so is the same mesh numbered backwards. Walked only in the faces' direction the count
    // was 22 here, and it moved with the numbering.
    let n = 12;
    let grid = procedural::terrain(n, 1);
    let mut triangles = grid.triangles.clone();
    let mut flipped = 0;
    for t in triangles.iter_mut() {
        let x = t.iter().map(|&v| grid.positions[v as usize][0]).sum::<f32>() / 3.0;
        if (0.0..0.3).contains(&x) {
            t.swap(1, 2);
            flipped += 1;
        }
    }
    assert!(flipped > 0 && flipped < triangles.len());
    let mesh = Mesh::new(grid.positions.clone(), triangles.clone()).unwrap();
    let last = mesh.vertex_count() as u32 - 1;
    let backwards = Mesh::new(
        grid.positions.iter().rev().copied().collect(),
        triangles.iter().rev().map(|t| t.map(|v| last - v)).collect(),
    )
    .unwrap();
    for (name, m) in [("grid", &mesh), ("grid numbered backwards", &backwards)] {
        let r = validate(m);
        assert!(r.inconsistently_oriented_edges > 0, "{name}: the band is turned over");
        assert_eq!(r.boundary_loops, 1, "{name}: {r:?}");
    }
    // Two such grids side by side, apart: two loops.
    let mut positions = mesh.positions.clone();
    positions.extend(mesh.positions.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
    let offset = mesh.vertex_count() as u32;
    let mut both = triangles.clone();
    both.extend(triangles.iter().map(|t| t.map(|v| v + offset)));
    assert_eq!(validate(&Mesh::new(positions, both).unwrap()).boundary_loops, 2);
}

#[test]
fn boundary_loops_are_the_boundary_graphs_pieces_where_no_vertex_pinches_them() {
    // Where every vertex has at most two boundary edges the boundary is a set of cycles and of
    // chains ending at non-manifold edges (beetle has six such ends): each is one loop, whichever
    // way its faces run and wherever the walk starts.
    let Some(meshes) = meshlod_engine::datasets::require_shared_meshes("boundary_loops_are_pieces") else { return };
    let mut files: Vec<std::path::PathBuf> =
        meshlod_engine::datasets::SHARED_MESHES.iter().map(|n| meshes.join(format!("{n}.obj"))).collect();
    if let Some(corpus) = meshlod_engine::datasets::require_shared_corpus("boundary_loops_are_pieces") {
        files.extend(meshlod_engine::datasets::corpus_meshes(&corpus, 150_000).into_iter().map(|(_, path)| path));
    }
    let mut checked = 0;
    for path in files {
        let mesh = read_mesh(&path).unwrap();
        let (pieces, pinched) = common::boundary_graph(&mesh);
        if !pinched {
            assert_eq!(validate(&mesh).boundary_loops, pieces, "{}", path.display());
            checked += 1;
        }
    }
    assert!(checked >= 50, "only {checked} meshes without pinched boundaries");
}
