//! Large meshes simplified in two halves first (`SimplifyOptions::halves`): when it applies, that
//! the result is the same on any number of threads, valid, restorable exactly from its progressive
//! mesh, and as accurate as one sequence over the whole mesh.

use meshlod_engine::hausdorff::{HausdorffOptions, hausdorff};
use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{HALVES_FROM_FACES, Metric, Simplified, SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};

mod common;

use common::invariants::{assert_exact_round_trip, assert_valid_output, set_aside};

/// A closed, bumpy blob of 68 400 faces: above the size from which runs go in halves.
fn large_blob() -> Mesh {
    let mesh = procedural::bumpy_blob(190, 180, 3);
    assert!(mesh.face_count() >= HALVES_FROM_FACES);
    mesh
}

fn to_faces(faces: usize, halves: bool) -> SimplifyOptions {
    SimplifyOptions {
        target_faces: Some(faces),
        target_ratio: None,
        record_progressive: true,
        halves,
        ..Default::default()
    }
}

fn on_threads(threads: usize, mesh: &Mesh, options: &SimplifyOptions) -> Simplified {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| simplify(mesh, options).unwrap())
}

fn error(input: &Mesh, out: &Mesh) -> f64 {
    hausdorff(input, out, &HausdorffOptions::default()).unwrap().hausdorff
}

#[test]
fn a_large_mesh_goes_in_halves_the_same_on_one_and_two_threads_validly_and_restorably() {
    let mesh = large_blob();
    let options = to_faces(mesh.face_count() / 50, true);
    let (one, two) = (on_threads(1, &mesh, &options), on_threads(2, &mesh, &options));
    assert!(one.stats.halves && two.stats.halves);
    assert_eq!(one.mesh.face_count(), options.target_faces.unwrap());
    assert_eq!(one.mesh.positions, two.mesh.positions);
    assert_eq!(one.mesh.triangles, two.mesh.triangles);
    let (pm1, pm2) = (one.progressive.as_ref().unwrap(), two.progressive.as_ref().unwrap());
    assert_eq!(pm1.splits(), pm2.splits());
    assert_eq!(one.stats.collapses, pm1.splits().len());
    assert_valid_output("blob in halves", &mesh, &one);
    assert_exact_round_trip("blob in halves", &mesh, pm1, set_aside(&one));
    // Every level replays: the splits of the two halves interleave into one valid sequence.
    if let Err(e) = meshlod_engine::pm::ProgressiveMesh::from_parts(pm1.base().clone(), pm1.splits().to_vec()) {
        panic!("the splits do not replay: {e}");
    }
    // The errors the splits carry never fall (each half's rise; the second stage's start above both).
    assert!(pm1.splits().windows(2).all(|w| w[0].error >= w[1].error));
}

#[test]
fn halves_stay_as_accurate_as_one_sequence() {
    let blob = large_blob();
    let mut cases = vec![("blob".to_string(), blob)];
    if let Some(dir) = meshlod_engine::datasets::require_shared_meshes("halves_stay_as_accurate_as_one_sequence") {
        cases.push(("stanford-bunny".into(), read_mesh(dir.join("stanford-bunny.obj")).unwrap()));
    }
    for (name, mesh) in cases {
        for keep in [0.1, 0.01] {
            let faces = (mesh.face_count() as f64 * keep).round() as usize;
            let halves = simplify(&mesh, &to_faces(faces, true)).unwrap();
            let whole = simplify(&mesh, &to_faces(faces, false)).unwrap();
            assert!(halves.stats.halves && !whole.stats.halves, "{name}");
            assert!(halves.mesh.face_count().abs_diff(whole.mesh.face_count()) <= 2, "{name} at {keep}");
            let (h, w) = (error(&mesh, &halves.mesh), error(&mesh, &whole.mesh));
            assert!(h <= 1.25 * w, "{name} at {keep}: {h} in halves against {w} in one sequence");
        }
    }
}

#[test]
fn small_light_and_other_runs_go_as_one_sequence() {
    let blob = large_blob();
    let n = blob.face_count();
    let one_sequence = |mesh: &Mesh, options: SimplifyOptions| !simplify(mesh, &options).unwrap().stats.halves;
    // Asked not to.
    assert!(one_sequence(&blob, to_faces(n / 50, false)));
    // Too light a reduction: above an eighth of the faces.
    assert!(one_sequence(&blob, to_faces(n / 7, true)));
    assert!(!one_sequence(&blob, to_faces(n / 8, true)));
    // Too small a mesh.
    let sphere = procedural::icosphere(5);
    assert!(sphere.face_count() < HALVES_FROM_FACES);
    assert!(one_sequence(&sphere, to_faces(100, true)));
    // Options the halves do not take: Melax, the guard, an error limit, pruning.
    let fewer = || to_faces(n / 50, true);
    assert!(one_sequence(&blob, SimplifyOptions { metric: Metric::Melax, ..fewer() }));
    assert!(one_sequence(&blob, SimplifyOptions { guard: 1.0, ..fewer() }));
    assert!(one_sequence(&blob, SimplifyOptions { max_error: Some(1.0), ..fewer() }));
    assert!(one_sequence(&blob, SimplifyOptions { prune: true, record_progressive: false, ..fewer() }));
}
