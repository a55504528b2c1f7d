//! Energy-operator LOD: validity of every output on the shared meshes, the ETC search, bad input.

use meshlod_engine::io::read_mesh;
use meshlod_engine::refine::{RefineMode, RefineOptions, refine, subdivide_uniform};
use meshlod_engine::validate::validate;
use meshlod_engine::{Mesh, MeshError, procedural};

/// Edge-manifold, consistently oriented, same boundary loops, no degenerate faces. A crack or a
/// T-junction opens a new boundary loop (or boundary edges on a closed mesh), so the loop count
/// catches it wherever loops are well defined.
fn assert_valid(name: &str, input: &Mesh, output: &Mesh, rounds: u32) {
    let before = validate(input);
    let after = validate(output);
    // A non-manifold input edge that is split becomes two non-manifold edges; nothing else may be.
    assert!(after.non_manifold_edges <= before.non_manifold_edges << rounds, "{name}: non-manifold edges created");
    if before.inconsistently_oriented_edges == 0 {
        assert_eq!(after.inconsistently_oriented_edges, 0, "{name}: orientation");
    }
    // Zero-area faces already in the input (ogre has 4) may be split; none may be created.
    assert!(after.degenerate_faces <= before.degenerate_faces << (2 * rounds), "{name}: degenerate faces created");
    if before.non_manifold_vertices == 0 && before.non_manifold_edges == 0 {
        assert_eq!(after.boundary_loops, before.boundary_loops, "{name}: boundary loops (crack or T-junction)");
    }
    if before.boundary_edges == 0 {
        assert_eq!(after.boundary_edges, 0, "{name}: a closed mesh got boundary edges (crack or T-junction)");
    }
    assert_eq!(after.components, before.components, "{name}: components");
}

#[test]
fn every_shared_mesh_refines_and_coarsens_validly() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("every_shared_mesh_refines_and_coarsens_validly")
    else {
        return;
    };
    for name in meshlod_engine::datasets::SHARED_MESHES {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap();
        for (mode, etc, rounds) in [
            (RefineMode::Subdivide, 1.0, 1),
            (RefineMode::Subdivide, 1.5, 2),
            (RefineMode::Simplify, 1.4, 1),
            (RefineMode::Both, 1.0, 1),
        ] {
            let r = refine(&mesh, &RefineOptions { etc: Some(etc), mode, rounds, ..Default::default() }).unwrap();
            let label = format!("{name} {mode:?} etc {etc} rounds {rounds}");
            assert_valid(&label, &mesh, &r.mesh, rounds);
            match mode {
                RefineMode::Subdivide => assert!(r.stats.faces_out > r.stats.faces_in, "{label}"),
                RefineMode::Simplify => assert!(r.stats.faces_out < r.stats.faces_in, "{label}"),
                RefineMode::Both => assert!(r.stats.collapses > 0 && r.stats.split_edges > 0, "{label}"),
            }
        }
    }
}

#[test]
fn every_corpus_mesh_refines_and_coarsens_validly() {
    // The corpus's CAD and robot parts bring what the shared meshes lack: many holes, non-manifold
    // edges, bow-tie vertices, faces wound the wrong way. Meshes with duplicate faces are left
    // out: a pair of equal faces subdivided gives equal children, whose inner edges (new ones)
    // then have four faces each.
    let Some(dir) = meshlod_engine::datasets::require_shared_corpus("every_corpus_mesh_refines_and_coarsens_validly")
    else {
        return;
    };
    let mut checked = 0;
    for (name, path) in meshlod_engine::datasets::corpus_meshes(&dir, 150_000) {
        let mesh = read_mesh(path).unwrap();
        if validate(&mesh).duplicate_faces > 0 {
            continue;
        }
        let r = refine(&mesh, &RefineOptions { etc: Some(1.0), mode: RefineMode::Both, ..Default::default() }).unwrap();
        assert_valid(&name, &mesh, &r.mesh, 1);
        checked += 1;
    }
    assert!(checked >= 60, "only {checked} corpus meshes");
}

#[test]
fn more_etc_means_fewer_subdivided_and_more_collapsed_faces() {
    let mesh = procedural::bumpy_blob(30, 60, 5);
    let run = |mode, etc| {
        refine(&mesh, &RefineOptions { etc: Some(etc), mode, ..Default::default() }).unwrap().stats.faces_out
    };
    let sub: Vec<usize> = [0.3, 0.9, 1.4, 2.0].iter().map(|&e| run(RefineMode::Subdivide, e)).collect();
    let simp: Vec<usize> = [0.3, 0.9, 1.4, 2.0].iter().map(|&e| run(RefineMode::Simplify, e)).collect();
    assert!(sub.windows(2).all(|w| w[0] >= w[1]), "{sub:?}");
    assert!(simp.windows(2).all(|w| w[0] >= w[1]), "{simp:?}");
    assert!(sub[0] > 3 * mesh.face_count(), "ETC 0.3 subdivides nearly everything: {sub:?}");
}

#[test]
fn etc_search_hits_the_target_within_one_percent() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("etc_search_hits_the_target") else { return };
    for name in ["stanford-bunny", "nefertiti", "cow"] {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap();
        let faces = mesh.face_count();
        for (mode, target, rounds) in [
            (RefineMode::Subdivide, faces * 3 / 2, 1),
            (RefineMode::Subdivide, faces * 5, 2),
            (RefineMode::Simplify, faces * 7 / 10, 1),
        ] {
            let r = refine(
                &mesh,
                &RefineOptions { etc: None, target_faces: Some(target), mode, rounds, ..Default::default() },
            )
            .unwrap();
            let label = format!("{name} {mode:?} target {target}");
            assert!(r.stats.faces_out.abs_diff(target) * 100 <= target, "{label}: got {}", r.stats.faces_out);
            // The reported ETC reproduces the result when given explicitly.
            let again =
                refine(&mesh, &RefineOptions { etc: Some(r.stats.etc), mode, rounds, ..Default::default() }).unwrap();
            assert!(
                again.stats.faces_out.abs_diff(target) * 100 <= target,
                "{label}: ETC {} gives {} faces",
                r.stats.etc,
                again.stats.faces_out
            );
        }
    }
}

#[test]
fn uniform_butterfly_quadruples_and_interpolates() {
    let mesh = procedural::icosphere(2);
    let fine = subdivide_uniform(&mesh);
    assert_eq!(fine.face_count(), 4 * mesh.face_count());
    assert_eq!(&fine.positions[..mesh.vertex_count()], &mesh.positions[..], "old vertices stay put");
    // New points of a sphere's butterfly lie near the sphere (interpolating, smooth).
    for p in &fine.positions[mesh.vertex_count()..] {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        assert!((r - 1.0).abs() < 0.02, "radius {r}");
    }
}

#[test]
fn bad_input_is_refused_clearly() {
    let mesh = procedural::icosphere(1);
    let err = |o: RefineOptions| refine(&mesh, &o).unwrap_err();
    assert!(matches!(
        err(RefineOptions { rounds: 0, ..Default::default() }),
        MeshError::InvalidParameter { name: "rounds", .. }
    ));
    assert!(matches!(
        err(RefineOptions { etc: Some(-1.0), ..Default::default() }),
        MeshError::InvalidParameter { name: "etc", .. }
    ));
    assert!(matches!(
        err(RefineOptions { etc: None, target_faces: None, ..Default::default() }),
        MeshError::InvalidParameter { .. }
    ));
    assert!(matches!(
        err(RefineOptions { etc: None, target_faces: Some(10_000_000), ..Default::default() }),
        MeshError::InvalidParameter { name: "target_faces", .. }
    ));
    assert!(matches!(refine(&Mesh::default(), &RefineOptions::default()), Err(MeshError::Empty { .. })));
    let cancelled = RefineOptions {
        cancel: Some(std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true))),
        ..Default::default()
    };
    assert!(matches!(refine(&mesh, &cancelled), Err(MeshError::Cancelled)));
}

#[test]
fn hostile_fans_and_outputs_are_refused_before_the_work() {
    // 100 000 faces on one edge, and 100 000 copies of one triangle: quadratic for the energies and
    // the collapses, refused up front naming the edge.
    let n = 100_000u32;
    let mut book = Mesh { positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], ..Default::default() };
    for i in 0..n {
        book.positions.push([0.5, i as f32 * 1e-3, 1.0]);
        book.triangles.push([0, 1, 2 + i]);
    }
    let copies = Mesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]; n as usize],
        ..Default::default()
    };
    for (name, mesh) in [("book", &book), ("copies", &copies)] {
        for mode in [RefineMode::Simplify, RefineMode::Subdivide, RefineMode::Both] {
            let err = refine(mesh, &RefineOptions { mode, ..Default::default() }).unwrap_err();
            let text = err.to_string();
            assert!(
                matches!(err, MeshError::InvalidParameter { name: "input", .. }) && text.contains("faces on one edge"),
                "{name}: {text}"
            );
        }
    }
    // A fin (three faces on an edge) is still refined.
    let mut fin = procedural::icosphere(2);
    let tip = fin.positions.len() as u32;
    fin.positions.push([0.0, 0.0, 3.0]);
    let [a, b, _] = fin.triangles[0];
    fin.triangles.push([a, b, tip]);
    assert!(refine(&fin, &RefineOptions::default()).is_ok());
    // The output's size is known before each round: ETC 0 at 4 rounds on 5 120 faces would make
    // 1.3 M; with a limit of 500 000 the fourth round is refused before it is built.
    let sphere = procedural::icosphere(4);
    let options = RefineOptions { etc: Some(0.0), rounds: 4, max_faces: Some(500_000), ..Default::default() };
    let err = refine(&sphere, &options).unwrap_err();
    assert!(matches!(err, MeshError::TooLarge { count: 1_310_720, limit: 500_000, .. }), "{err}");
    let ok = RefineOptions { rounds: 3, ..options.clone() };
    assert_eq!(refine(&sphere, &ok).unwrap().mesh.face_count(), 327_680);
    // A target above the limit is refused at once; one the search can reach under it is found.
    let target = RefineOptions { etc: None, target_faces: Some(600_000), ..options.clone() };
    assert!(matches!(refine(&sphere, &target).unwrap_err(), MeshError::TooLarge { .. }));
    let target = RefineOptions { etc: None, target_faces: Some(50_000), rounds: 2, max_faces: Some(60_000), ..options };
    let reached = refine(&sphere, &target).unwrap().mesh.face_count();
    assert!(reached.abs_diff(50_000) <= 1_500, "{reached}");
}
