//! `SimplifyOptions::prune`: whole parts taken out once the error reaches their size.

use meshlod_engine::Mesh;
use meshlod_engine::error::MeshError;
use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::read_mesh;
use meshlod_engine::procedural;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::validate::validate;

/// A sphere of radius 1 with a small ring (a chain link) hanging off its side and
/// touching it (0.013 across), as one mesh of two parts.
fn sphere_and_link() -> (Mesh, usize) {
    let sphere = procedural::icosphere(4);
    let link = procedural::torus(24, 8, 0.3);
    let offset = sphere.positions.len() as u32;
    let mut positions = sphere.positions.clone();
    positions.extend(link.positions.iter().map(|p| [1.0 + 0.005 * (p[0] + 1.3), 0.005 * p[1], 0.005 * p[2]]));
    let mut triangles = sphere.triangles.clone();
    triangles.extend(link.triangles.iter().map(|t| t.map(|v| v + offset)));
    (Mesh::new(positions, triangles).expect("a mesh"), link.face_count())
}

/// The sphere with a chain of four such links going outwards from its side, each touching the
/// next: only a link near a part that stays (the sphere) may go.
fn sphere_and_chain() -> Mesh {
    let sphere = procedural::icosphere(4);
    let link = procedural::torus(24, 8, 0.3);
    let mut positions = sphere.positions.clone();
    let mut triangles = sphere.triangles.clone();
    for k in 0..4 {
        let offset = positions.len() as u32;
        let x = 1.0 + 0.012 * k as f32;
        positions.extend(link.positions.iter().map(|p| [x + 0.005 * (p[0] + 1.3), 0.005 * p[1], 0.005 * p[2]]));
        triangles.extend(link.triangles.iter().map(|t| t.map(|v| v + offset)));
    }
    Mesh::new(positions, triangles).expect("a mesh")
}

fn to(faces: usize, prune: bool) -> SimplifyOptions {
    SimplifyOptions { target_ratio: None, target_faces: Some(faces), prune, ..Default::default() }
}

#[test]
fn a_small_part_goes_whole_once_the_error_reaches_its_size_and_only_with_prune() {
    let (mesh, link_faces) = sphere_and_link();
    assert_eq!(validate(&mesh).components, 2);
    let target = 150;
    let kept = simplify(&mesh, &to(target, false)).expect("simplifies");
    assert_eq!(kept.stats.parts_removed, 0);
    assert_eq!(validate(&kept.mesh).components, 2, "without prune every part stays");
    let pruned = simplify(&mesh, &to(target, true)).expect("simplifies");
    assert_eq!(pruned.stats.parts_removed, 1, "{:?}", pruned.stats);
    let report = validate(&pruned.mesh);
    assert_eq!(report.components, 1);
    assert!(report.is_manifold_oriented, "{report:?}");
    assert!(pruned.mesh.face_count() <= target && pruned.mesh.face_count() + 1 >= target);
    // The link's faces went to the sphere: its one part holds more of the budget than before.
    assert!(link_faces > 100);
    let sphere_error = |m: &Mesh| hausdorff(&procedural::icosphere(4), m, &HausdorffOptions::default()).unwrap();
    let (with, without) = (sphere_error(&pruned.mesh), sphere_error(&kept.mesh));
    assert!(with.mean < without.mean, "the sphere alone: mean {} with prune, {} without", with.mean, without.mean);
}

#[test]
fn the_largest_part_stays_and_pruning_never_goes_below_the_target() {
    let (mesh, link_faces) = sphere_and_link();
    // Far below what the sphere can keep: the link goes, the sphere stays at its smallest.
    let out = simplify(&mesh, &to(4, true)).expect("simplifies");
    assert_eq!(out.stats.parts_removed, 1);
    assert!(out.mesh.face_count() >= 4);
    assert_eq!(validate(&out.mesh).components, 1);
    // A target the link's removal would overshoot: the link stays, the count is the target.
    let sphere_faces = mesh.face_count() - link_faces;
    let target = sphere_faces + link_faces / 2;
    let out = simplify(&mesh, &to(target, true)).expect("simplifies");
    assert!(out.mesh.face_count() + 1 >= target, "{} faces for a target of {target}", out.mesh.face_count());
}

#[test]
fn a_chain_of_small_parts_goes_only_where_it_is_near_a_part_that_stays() {
    let mesh = sphere_and_chain();
    assert_eq!(validate(&mesh).components, 5);
    let out = simplify(&mesh, &to(150, true)).expect("simplifies");
    // Each link touches the next, so measured against every other part each would go; measured
    // against the parts that stay, the far ones are too far from the sphere.
    let removed = out.stats.parts_removed;
    assert!((1..4).contains(&removed), "{:?}", out.stats);
    assert_eq!(validate(&out.mesh).components, 5 - removed);
}

#[test]
fn prune_with_a_progressive_mesh_is_refused_naming_the_option() {
    let (mesh, _) = sphere_and_link();
    let options = SimplifyOptions { record_progressive: true, ..to(100, true) };
    match simplify(&mesh, &options) {
        Err(MeshError::InvalidParameter { name, .. }) => assert_eq!(name, "prune"),
        other => panic!("expected the prune option refused, got {:?}", other.map(|s| s.stats)),
    }
}

/// Lantern at 860 faces (where its anchors stop a run asked for 10%): its eight chain links and
/// other small parts held faces that its beam and pole need. With prune its position error drops
/// and every attribute is kept. (Without the attribute quadrics: with the default normal weight
/// the run's error reaches the size of a larger part sooner, prune takes it, and the distance
/// stays where it was without prune.)
#[test]
fn pruning_lantern_gives_its_faces_to_the_large_shapes() {
    let Some(dir) = meshlod_engine::datasets::require_shared_textured("pruning_lantern") else { return };
    let mesh = read_mesh(dir.join("draco__Lantern/Lantern.gltf")).expect("reads");
    let off = |prune| SimplifyOptions { attribute_weights: Some(Default::default()), ..to(860, prune) };
    let kept = simplify(&mesh, &off(false)).expect("simplifies");
    let pruned = simplify(&mesh, &off(true)).expect("simplifies");
    assert!(pruned.stats.parts_removed > 0, "{:?}", pruned.stats);
    assert_eq!(pruned.mesh.corners.names(), mesh.corners.names());
    let report = validate(&pruned.mesh);
    assert!(report.is_manifold_oriented && report.non_manifold_edges == 0, "{report:?}");
    assert!(report.components < validate(&kept.mesh).components);
    let error = |m: &Mesh| hausdorff(&mesh, m, &HausdorffOptions::default()).unwrap().hausdorff;
    let (with, without) = (error(&pruned.mesh), error(&kept.mesh));
    assert!(with < 0.5 * without, "Hausdorff {with} with prune, {without} without");
}
