//! Simplification and progressive meshes: invariants on real and procedural meshes, exact PM
//! round trips, the `.pm` file, and the cost strategies on drawn cases.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use meshlod_engine::io::read_mesh;
use meshlod_engine::pm::{Hole, ProgressiveMesh};
use meshlod_engine::pm_format::{decode, encode, encode_lossless};
use meshlod_engine::simplify::{
    BoundaryMode, Metric, Placement, SimplifyOptions, StopReason, simplify, simplify_search_w,
};
use meshlod_engine::validate::validate;
use meshlod_engine::{Mesh, MeshError, procedural};

mod common;

use common::invariants::{
    assert_exact_round_trip, assert_valid_output, canonical, face_key, set_aside, without_copies,
};

fn options(ratio: f64) -> SimplifyOptions {
    SimplifyOptions { target_ratio: Some(ratio), record_progressive: true, ..Default::default() }
}

fn shared(name: &str) -> Option<Mesh> {
    let dir = meshlod_engine::datasets::require_shared_meshes(name)?;
    Some(read_mesh(dir.join(format!("{name}.obj"))).unwrap())
}

#[test]
fn procedural_meshes_simplify_validly_and_round_trip() {
    for (name, mesh) in [
        ("sphere", procedural::icosphere(4)),
        ("torus", procedural::torus(48, 16, 0.3)),
        ("box", procedural::sharp_box(8)),
        ("terrain", procedural::terrain(32, 5)),
        ("blob", procedural::bumpy_blob(30, 50, 2)),
    ] {
        for metric in [Metric::Qfvp { w: 1.0 }, Metric::Qem, Metric::Melax] {
            let out = simplify(&mesh, &SimplifyOptions { metric, ..options(0.95) }).unwrap();
            let label = format!("{name}/{}", metric.name());
            assert_valid_output(&label, &mesh, &out);
            assert_exact_round_trip(&label, &mesh, out.progressive.as_ref().unwrap(), set_aside(&out));
        }
    }
}

#[test]
fn shared_meshes_at_99_percent_stay_valid_and_round_trip() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("shared_meshes_at_99_percent") else { return };
    for name in meshlod_engine::datasets::SHARED_MESHES {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap();
        let out = simplify(&mesh, &options(0.99)).unwrap();
        let stats = &out.stats;
        assert!(
            stats.faces_out as f64 <= (stats.faces_in as f64 * 0.012).max(stats.target_faces as f64 + 2.0)
                || stats.stop_reason == StopReason::NoLegalCollapse,
            "{name}: {stats:?}"
        );
        assert_valid_output(name, &mesh, &out);
        assert_exact_round_trip(name, &mesh, out.progressive.as_ref().unwrap(), set_aside(&out));
    }
}

/// Simplifies by `ratio` every corpus mesh of at most `max_faces` faces that `pick` accepts, and
/// checks every invariant and the exact round trip; returns how many it checked.
fn corpus_stays_valid_and_round_trips(dir: &Path, max_faces: usize, ratio: f64, pick: fn(&Mesh) -> bool) -> usize {
    let mut checked = 0;
    for (name, path) in meshlod_engine::datasets::corpus_meshes(dir, max_faces) {
        let mesh = read_mesh(path).unwrap();
        if !pick(&mesh) {
            continue;
        }
        let out = simplify(&mesh, &options(ratio)).unwrap();
        // Against the input without the copies the run dropped (a copy closes the edges of the
        // face it copies: without it they may be a border, as they are in the result).
        assert_valid_output(&name, &without_copies(&mesh), &out);
        assert_exact_round_trip(&name, &mesh, out.progressive.as_ref().unwrap(), set_aside(&out));
        checked += 1;
    }
    checked
}

#[test]
fn non_manifold_corpus_meshes_stay_valid_and_round_trip() {
    // CAD and robot parts with non-manifold edges and vertices (frozen: they never move, and take
    // in neighbours only where rule 1 allows), at 80%: every invariant and the exact round trip.
    // (The larger ones add time, not cases.)
    let Some(dir) = meshlod_engine::datasets::require_shared_corpus("non_manifold_corpus_meshes") else { return };
    let checked = corpus_stays_valid_and_round_trips(&dir, 40_000, 0.8, |m| validate(m).non_manifold_vertices > 0);
    assert!(checked >= 10, "only {checked} non-manifold corpus meshes");
}

#[test]
fn every_corpus_mesh_at_90_percent_stays_valid_and_round_trips() {
    // The whole corpus (organic scans, CAD and robot parts; with holes, non-manifold edges,
    // bow-tie vertices, duplicate faces and faces wound the wrong way) with the default options.
    // (A statue whose one boundary loop runs through faces wound both ways was counted as many
    // loops before the count followed edges rather than their direction: this test failed on it.)
    let Some(dir) = meshlod_engine::datasets::require_shared_corpus("every_corpus_mesh_at_90_percent") else { return };
    let checked = corpus_stays_valid_and_round_trips(&dir, 150_000, 0.9, |_| true);
    assert!(checked >= 80, "only {checked} corpus meshes");
}

#[test]
fn a_double_sided_corpus_mesh_simplifies_as_its_front_with_both_sides() {
    // trimesh's chair is modelled double-sided: each face has its reverse on the same three
    // vertices, which froze every vertex (the run kept all 12 756 faces). Its front simplifies as
    // the chair cleaned of the backs (`validate::clean`) does, and each face comes out with its back.
    let Some(dir) = meshlod_engine::datasets::require_shared_corpus("a_double_sided_corpus_mesh") else { return };
    let mesh = read_mesh(dir.join("trimesh__chair_model.ply")).unwrap();
    let out = simplify(&mesh, &options(0.9)).unwrap();
    let stats = &out.stats;
    assert_eq!(stats.stop_reason, StopReason::TargetReached, "{stats:?}");
    assert!(stats.back_faces > 6000 && stats.faces_out.abs_diff(stats.target_faces) <= 2, "{stats:?}");
    let (front, cleaned) = meshlod_engine::validate::clean(&mesh);
    assert_eq!(cleaned.removed_duplicate_faces, stats.back_faces + stats.dropped_duplicate_faces);
    let k = stats.faces_out / 2;
    let alone =
        simplify(&front, &SimplifyOptions { target_faces: Some(k), target_ratio: None, ..options(0.0) }).unwrap();
    assert_eq!(
        face_key(&alone.mesh),
        face_key(&Mesh::new(out.mesh.positions.clone(), out.mesh.triangles[..k].to_vec()).unwrap())
    );
    let faces: std::collections::HashSet<[u32; 3]> = out.mesh.triangles.iter().map(|&t| canonical(t)).collect();
    assert!(
        out.mesh.triangles.iter().all(|&t| faces.contains(&canonical([t[0], t[2], t[1]]))),
        "a face without its back"
    );
}

#[test]
fn at_faces_equals_simplifying_straight_to_that_count() {
    let Some(mesh) = shared("cow") else { return };
    let full = simplify(&mesh, &options(0.99)).unwrap();
    let pm = full.progressive.unwrap();
    for target in [60, 500, 1161, 2900, 5000] {
        let straight =
            simplify(&mesh, &SimplifyOptions { target_faces: Some(target), target_ratio: None, ..options(0.0) })
                .unwrap()
                .mesh;
        let level = pm.at_faces(target);
        assert_eq!(level.face_count(), straight.face_count(), "target {target}");
        assert_eq!(face_key(&level), face_key(&straight), "target {target}: different faces");
    }
    // Incremental moves between levels give the same meshes as fresh rebuilds.
    let mut cursor = pm.cursor();
    for level in [10, 400, 37, 1200, 1199, 0, pm.levels()] {
        cursor.seek_level(level).unwrap();
        assert_eq!(cursor.mesh(), pm.at_level(level), "level {level}");
    }
}

#[test]
fn pm_file_round_trips_and_refuses_corruption() {
    let mesh = procedural::bumpy_blob(24, 40, 9);
    for placement in [Placement::Endpoint, Placement::Optimal] {
        let pm = simplify(&mesh, &SimplifyOptions { placement, ..options(0.97) }).unwrap().progressive.unwrap();
        let bytes = encode_lossless(&pm);
        let back = decode(&bytes, Path::new("t.pm")).unwrap().0;
        assert_eq!(back.base(), pm.base());
        assert_eq!(back.splits(), pm.splits());
        assert_eq!(back.at_level(back.levels()), pm.at_level(pm.levels()));
        let per_split =
            (bytes.len() - 32 - 12 * (pm.base().vertex_count() + pm.base().face_count())) as f64 / pm.levels() as f64;
        if placement == Placement::Endpoint {
            assert!(per_split <= 24.0, "endpoint placement: {per_split} bytes per split");
        }
        // The compact form: the same faces at every level (its positions are checked in
        // tests/pm_compact.rs).
        let compact = encode(&pm);
        let back = decode(&compact, Path::new("t.pm")).unwrap().0;
        assert_eq!(back.at_level(back.levels()).triangles, pm.at_level(pm.levels()).triangles);
        for bytes in [bytes, compact] {
            // Every truncation is refused, never a panic.
            for cut in [0, 3, 10, 30, bytes.len() / 2, bytes.len() - 1] {
                assert!(matches!(decode(&bytes[..cut], Path::new("t.pm")), Err(MeshError::Parse { .. })), "cut {cut}");
            }
            // Flipped bits anywhere are caught by the checksum or the structural checks.
            for at in (0..bytes.len()).step_by(97) {
                let mut bad = bytes.clone();
                bad[at] ^= 0x10;
                assert!(decode(&bad, Path::new("t.pm")).is_err(), "flip at {at}");
            }
        }
    }
}

#[test]
fn triangular_holes_close_and_their_splits_open_them_again_in_every_form() {
    let mesh = procedural::with_triangular_holes(&procedural::bumpy_blob(24, 40, 9), 23);
    let loops = validate(&mesh).boundary_loops;
    assert!(loops >= 30, "{loops} holes");
    let out = simplify(&mesh, &options(0.95)).unwrap();
    assert!(out.stats.holes_closed > 0, "{:?}", out.stats);
    // Both sides of the split record a hole (the collapsed edge's face runs either way).
    let sides: Vec<Hole> = out.progressive.as_ref().unwrap().splits().iter().map(|s| s.hole).collect();
    assert!(sides.contains(&Hole::Left) && sides.contains(&Hole::Right));
    // The invariants (loops lost = holes closed = splits with a hole) and the exact round trip.
    assert_valid_output("holed blob", &mesh, &out);
    let pm = out.progressive.unwrap();
    assert_exact_round_trip("holed blob", &mesh, &pm, 0);
    // Both file forms carry the holes: the same splits (lossless), the same faces at every level.
    let lossless = decode(&encode_lossless(&pm), Path::new("t.pm")).unwrap().0;
    assert_eq!(lossless.splits(), pm.splits());
    let compact = decode(&encode(&pm), Path::new("t.pm")).unwrap().0;
    let holes = |p: &ProgressiveMesh| p.splits().iter().map(|s| s.hole).collect::<Vec<_>>();
    assert_eq!(holes(&compact), holes(&pm));
    for level in (0..=pm.levels()).step_by(97).chain([pm.levels()]) {
        assert_eq!(compact.at_level(level).triangles, pm.at_level(level).triangles, "level {level}");
        assert_eq!(pm.at_level(level).face_count(), pm.faces_at_level(level), "level {level}");
    }
    // A level between two hole closings has the loops the straight run to its count leaves.
    let level = pm.level_for_faces(mesh.face_count() / 2);
    let straight = simplify(
        &mesh,
        &SimplifyOptions { target_faces: Some(pm.faces_at_level(level)), target_ratio: None, ..options(0.0) },
    )
    .unwrap();
    assert_eq!(face_key(&pm.at_level(level)), face_key(&straight.mesh));
    assert_eq!(validate(&straight.mesh).boundary_loops + straight.stats.holes_closed, loops);
    // Locked borders keep every hole.
    let locked = simplify(&mesh, &SimplifyOptions { boundary: BoundaryMode::Lock, ..options(0.95) }).unwrap();
    assert_eq!(locked.stats.holes_closed, 0);
    assert_eq!(validate(&locked.mesh).boundary_loops, loops);
}

#[test]
fn beetle_reaches_its_face_target_at_90_percent() {
    // Its boundary loops shrink to triangles that only closing them takes further (45 frozen
    // vertices on its non-manifold edges hold the rest).
    let Some(mesh) = shared("beetle") else { return };
    let out = simplify(&mesh, &options(0.9)).unwrap();
    assert_eq!(out.stats.stop_reason, StopReason::TargetReached, "{:?}", out.stats);
    // Reached: at the target, or one below it where the last collapse took two faces.
    let (faces, target) = (out.stats.faces_out, out.stats.target_faces);
    assert!(faces <= target && faces + 1 >= target, "{faces} faces for a target of {target}");
    assert!(out.stats.holes_closed > 0);
    assert_valid_output("beetle", &mesh, &out);
    assert_exact_round_trip("beetle", &mesh, out.progressive.as_ref().unwrap(), set_aside(&out));
}

#[test]
fn cost_strategies_differ_where_they_should() {
    // On a curved surface QFVP (w > 0) reorders QEM's collapses: an edge whose endpoint normals
    // agree is cheap whatever its quadric error. Melax ranks by edge length × curvature instead.
    let torus = procedural::torus(40, 16, 0.3);
    let run_on = |mesh: &Mesh, metric| {
        simplify(
            mesh,
            &SimplifyOptions {
                metric,
                target_faces: Some(200),
                target_ratio: None,
                placement: Placement::Paper,
                ..options(0.0)
            },
        )
        .unwrap()
    };
    let run = |metric| run_on(&torus, metric);
    let qem = run(Metric::Qem);
    let qfvp0 = run(Metric::Qfvp { w: 0.0 });
    let qfvp2 = run(Metric::Qfvp { w: 2.0 });
    let melax = run(Metric::Melax);
    // QFVP with w = 0 is QEM exactly.
    assert_eq!(qem.mesh, qfvp0.mesh);
    assert!(qem.mesh.positions != qfvp2.mesh.positions, "w = 2 must change the order of collapses");
    assert!(qem.mesh.positions != melax.mesh.positions, "Melax must differ from QEM");
    // On a box every strategy keeps the 8 corners (collapsing one costs far more than flat edges).
    let box_mesh = procedural::sharp_box(6);
    for metric in [Metric::Qem, Metric::Qfvp { w: 2.0 }, Metric::Melax] {
        let out = run_on(&box_mesh, metric);
        let name = metric.name();
        let corners =
            out.mesh.positions.iter().filter(|p| p[0].abs() == 1.0 && p[1].abs() == 0.5 && p[2].abs() == 0.25).count();
        assert_eq!(corners, 8, "{name} lost a box corner");
    }
}

#[test]
fn boundaries_are_kept_or_locked() {
    let mesh = procedural::terrain(24, 3);
    let locked = simplify(&mesh, &SimplifyOptions { boundary: BoundaryMode::Lock, ..options(0.9) }).unwrap();
    let border = |m: &Mesh| m.positions.iter().filter(|p| p[0].abs() == 1.0 || p[1].abs() == 1.0).count();
    assert_eq!(border(&locked.mesh), border(&mesh), "locked boundary vertices must all stay");
    let preserved = simplify(&mesh, &options(0.9)).unwrap();
    assert_valid_output("terrain/preserve", &mesh, &preserved);
    // Boundary vertices stay on the square's border (their constraint planes hold them there).
    let report = validate(&preserved.mesh);
    assert_eq!(report.boundary_loops, 1);
    let topology = meshlod_engine::topology::Topology::new(&preserved.mesh);
    for (e, &[a, b]) in topology.edges.iter().enumerate() {
        if topology.edge_faces.get(e).len() == 1 {
            for v in [a, b] {
                let p = preserved.mesh.positions[v as usize];
                let off = (1.0 - p[0].abs()).min(1.0 - p[1].abs());
                // Boundary vertices slide along the border; only a cut corner leaves it, slightly.
                assert!(off.abs() < 0.02, "boundary vertex {v} at {p:?} left the border");
            }
        }
    }
}

#[test]
fn bad_options_and_inputs_are_refused() {
    let mesh = procedural::icosphere(2);
    let err = |o: SimplifyOptions| simplify(&mesh, &o).unwrap_err();
    assert!(matches!(
        err(SimplifyOptions { target_ratio: Some(1.5), ..Default::default() }),
        MeshError::InvalidParameter { name: "target_ratio", .. }
    ));
    assert!(matches!(
        err(SimplifyOptions { metric: Metric::Qfvp { w: 3.0 }, ..Default::default() }),
        MeshError::InvalidParameter { name: "w", .. }
    ));
    assert!(matches!(
        err(SimplifyOptions { max_error: Some(f64::NAN), ..Default::default() }),
        MeshError::InvalidParameter { .. }
    ));
    assert!(matches!(simplify(&Mesh::default(), &SimplifyOptions::default()), Err(MeshError::Empty { .. })));
    // Non-manifold input: simplified around its frozen parts, not refused, no panic.
    let mut fin = procedural::icosphere(2);
    let n = fin.positions.len() as u32;
    fin.positions.push([0.0, 0.0, 3.0]);
    let [a, b, _] = fin.triangles[0];
    fin.triangles.push([a, b, n]);
    let out = simplify(&fin, &options(0.8)).unwrap();
    assert!(out.stats.frozen_vertices >= 2);
    assert_exact_round_trip("fin", &fin, out.progressive.as_ref().unwrap(), set_aside(&out));
}

#[test]
fn cancellation_stops_the_work() {
    let mesh = procedural::icosphere(5);
    let flag = Arc::new(AtomicBool::new(true));
    let r = simplify(&mesh, &SimplifyOptions { cancel: Some(flag), ..options(0.99) });
    assert!(matches!(r, Err(MeshError::Cancelled)));
}

#[test]
fn max_error_stops_early_and_errors_are_monotone() {
    let mesh = procedural::bumpy_blob(40, 60, 4);
    let out = simplify(&mesh, &SimplifyOptions { max_error: Some(0.002), ..options(0.99) }).unwrap();
    assert_eq!(out.stats.stop_reason, StopReason::MaxErrorReached);
    assert!(out.stats.max_collapse_error <= 0.002);
    let pm = out.progressive.unwrap();
    // Split order is refinement order: errors never increase along it.
    assert!(pm.splits().windows(2).all(|w| w[0].error >= w[1].error));
}

#[test]
fn w_search_keeps_the_lowest_error_and_matches_a_straight_run() {
    let mesh = procedural::bumpy_blob(24, 48, 5);
    let options = SimplifyOptions { target_ratio: Some(0.9), ..Default::default() };
    let candidates = [0.0, 0.5, 1.0, 1.5, 2.0];
    let search = simplify_search_w(&mesh, &options, &candidates).expect("searches");
    assert_eq!(search.errors.iter().map(|e| e.0).collect::<Vec<_>>(), candidates);
    let lowest = search.errors.iter().map(|e| e.1).fold(f64::INFINITY, f64::min);
    let (_, chosen_error) = search.errors.iter().find(|e| e.0 == search.w).expect("chosen w is a candidate");
    assert_eq!(*chosen_error, lowest, "the search keeps the lowest error: {:?}", search.errors);
    let distinct: std::collections::BTreeSet<u64> = search.errors.iter().map(|e| e.1.to_bits()).collect();
    assert!(distinct.len() > 1, "w changes the result on a bumpy blob: {:?}", search.errors);
    let straight = simplify(&mesh, &SimplifyOptions { metric: Metric::Qfvp { w: search.w }, ..options.clone() })
        .expect("simplifies");
    assert_eq!(straight.mesh.triangles, search.best.mesh.triangles);
    assert_eq!(straight.mesh.positions, search.best.mesh.positions);

    let melax = SimplifyOptions { metric: Metric::Melax, ..options.clone() };
    assert!(matches!(simplify_search_w(&mesh, &melax, &candidates), Err(MeshError::InvalidParameter { .. })));
    assert!(matches!(simplify_search_w(&mesh, &options, &[]), Err(MeshError::InvalidParameter { .. })));
}

/// A sphere with thin spikes: quadric error's blind spot (shortening a spike along its own faces
/// looks cheap to the paper's cost).
fn spiky_sphere() -> Mesh {
    let mut mesh = procedural::icosphere(3);
    // The 12 vertices of the base icosahedron come first; six of them become spike tips.
    for v in [0usize, 2, 4, 6, 8, 10] {
        mesh.positions[v] = mesh.positions[v].map(|c| c * 4.0);
    }
    mesh
}

#[test]
fn distance_terms_keep_thin_tips() {
    let mesh = spiky_sphere();
    let run = |distance_term, guard| {
        let label = format!("spiky/term {distance_term}/guard {guard}");
        let out = simplify(&mesh, &SimplifyOptions { distance_term, guard, ..options(0.95) }).unwrap();
        assert_valid_output(&label, &mesh, &out);
        assert_exact_round_trip(&label, &mesh, out.progressive.as_ref().unwrap(), set_aside(&out));
        assert_eq!(out.stats.distance_term, if guard > 0.0 { 0.0 } else { distance_term }, "{label}");
        let d = meshlod_engine::hausdorff::hausdorff(&mesh, &out.mesh, &Default::default()).unwrap().hausdorff;
        (out, d)
    };
    let (plain, plain_error) = run(0.0, 0.0);
    let (termed, term_error) = run(1.0, 0.0);
    let (guarded, guarded_error) = run(1.0, 1.0);
    assert_eq!(plain.mesh.face_count(), termed.mesh.face_count());
    assert_eq!(plain.mesh.face_count(), guarded.mesh.face_count());
    eprintln!(
        "spiky sphere at 95%: Hausdorff {plain_error:.4} with the paper's cost, {term_error:.4} with the \
         fan-distance term, {guarded_error:.4} guarded"
    );
    // Measured: 0.858 with the paper's cost (whole spikes shortened to stubs), 0.050 with the
    // fan-distance term, 0.055 guarded.
    assert!(term_error < 0.25 * plain_error, "fan-distance term {term_error} vs {plain_error}");
    assert!(guarded_error < 0.25 * plain_error, "guard {guarded_error} vs {plain_error}");
}

#[test]
fn the_fan_distance_term_waits_until_70_percent_of_the_faces_are_gone() {
    // Until 70% of the input's faces are gone, collapses rank by their quadric error per unit of
    // area alone, whatever the term's weight: down to there, weights 1 and 4 make the same mesh;
    // past it they part. The paper's cost (weight 0, not per unit of area) parts from the start.
    let mesh = spiky_sphere();
    let run =
        |distance_term, ratio| simplify(&mesh, &SimplifyOptions { distance_term, ..options(ratio) }).unwrap().mesh;
    for ratio in [0.3, 0.7] {
        assert_eq!(face_key(&run(1.0, ratio)), face_key(&run(4.0, ratio)), "{ratio}");
    }
    assert_ne!(face_key(&run(1.0, 0.95)), face_key(&run(4.0, 0.95)));
    assert_ne!(face_key(&run(1.0, 0.3)), face_key(&run(0.0, 0.3)));
}

#[test]
fn distance_guard_on_shared_meshes_at_99_percent_stays_valid_and_round_trips() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("distance_guard_on_shared_meshes") else { return };
    for name in meshlod_engine::datasets::SHARED_MESHES {
        let mesh = read_mesh(dir.join(format!("{name}.obj"))).unwrap();
        let out = simplify(&mesh, &SimplifyOptions { guard: 1.0, ..options(0.99) }).unwrap();
        let label = format!("{name}/guard");
        assert_valid_output(&label, &mesh, &out);
        assert_exact_round_trip(&label, &mesh, out.progressive.as_ref().unwrap(), set_aside(&out));
    }
}

#[test]
fn distance_terms_beat_the_papers_cost_and_the_guard_its_best_on_cow_and_bunny() {
    // The QFVP paper's best Hausdorff distances at 90% reduction (paper units), over its w grid.
    // The paper measured with Metro (sampling): its figures are lower bounds, so they are compared
    // with the same sampled instrument; the gains over the paper's cost (w = 0, no distance term)
    // are certified. The fan-distance term, measured once 70% of the faces are gone, beats the
    // paper's best on the bunny but not on cow (figures and the choice of that share:
    // docs/benchmarks.md).
    for (name, paper_best, term_beats_paper) in [("cow", 0.032823, false), ("stanford-bunny", 0.006265, true)] {
        let Some(mesh) = shared(name) else { return };
        let run = |distance_term, guard| {
            let options = SimplifyOptions { distance_term, guard, target_ratio: Some(0.9), ..Default::default() };
            simplify(&mesh, &options).unwrap().mesh
        };
        let (plain, termed, guarded) = (run(0.0, 0.0), run(1.0, 0.0), run(0.0, 1.0));
        let certified = |m: &Mesh| meshlod_engine::hausdorff::hausdorff(&mesh, m, &Default::default()).unwrap();
        let (plain_h, term_h, guarded_h) = (certified(&plain), certified(&termed), certified(&guarded));
        let units = meshlod_engine::DistanceUnits::new(&mesh.surface_bounds().unwrap());
        let samples = mesh.vertex_count().max(10_000);
        let sampled =
            |m: &Mesh| units.to_paper(meshlod_engine::hausdorff::sampled_max(&mesh, m, samples, 0x5eed).unwrap());
        let (term_sampled, guard_sampled) = (sampled(&termed), sampled(&guarded));
        eprintln!(
            "{name} at 90%: certified {:.6} with the paper's cost, {:.6} with the fan-distance term, {:.6} guarded; \
             sampled {term_sampled:.6} and {guard_sampled:.6}, paper {paper_best}",
            plain_h.hausdorff, term_h.hausdorff, guarded_h.hausdorff
        );
        if term_beats_paper {
            assert!(term_sampled < paper_best, "{name}: sampled {term_sampled} vs the paper's {paper_best}");
        }
        assert!(guard_sampled < paper_best, "{name}: sampled {guard_sampled} vs the paper's {paper_best}");
        assert!(term_h.hausdorff < plain_h.hausdorff_lower, "{name}: the fan-distance term does not certainly help");
        assert!(guarded_h.hausdorff < plain_h.hausdorff_lower, "{name}: the guard does not certainly help");
    }
}

#[test]
fn distance_guard_levels_equal_straight_runs_and_bad_weights_are_refused() {
    let Some(mesh) = shared("cow") else { return };
    let guarded = |ratio: f64, target: Option<usize>| SimplifyOptions {
        guard: 1.0,
        target_faces: target,
        target_ratio: target.is_none().then_some(ratio),
        ..options(0.0)
    };
    let pm = simplify(&mesh, &guarded(0.99, None)).unwrap().progressive.unwrap();
    for target in [100, 1161, 4000] {
        let straight = simplify(&mesh, &guarded(0.0, Some(target))).unwrap().mesh;
        let level = pm.at_faces(target);
        assert_eq!(level.face_count(), straight.face_count(), "target {target}");
        assert_eq!(face_key(&level), face_key(&straight), "target {target}: different faces");
    }
    for (guard, metric) in
        [(f64::NAN, Metric::Qem), (-1.0, Metric::Qem), (f64::INFINITY, Metric::Qem), (1.0, Metric::Melax)]
    {
        let r = simplify(&mesh, &SimplifyOptions { guard, metric, ..options(0.5) });
        assert!(matches!(r, Err(MeshError::InvalidParameter { name: "guard", .. })), "guard {guard} {metric:?}: {r:?}");
    }
}

/// A flat-shaded mesh (every corner's normal its face's own, as low-poly art and many glTF exports
/// are) simplifies to its target like a mesh without normals, and stays flat-shaded; a mesh with
/// smooth normals keeps them as values.
#[test]
fn flat_shaded_meshes_simplify_and_stay_flat() {
    use meshlod_engine::simplify::{SimplifyOptions, simplify};
    let mut mesh = meshlod_engine::procedural::icosphere(3);
    let flat: Vec<[f32; 3]> =
        (0..mesh.face_count()).flat_map(|f| [mesh.face_area_vector(f).normalize().as_vec3().to_array(); 3]).collect();
    mesh.corners.set_normals(Some(flat));
    assert!(meshlod_engine::validate::validate(&mesh).seam_edges > 0, "every edge a normal seam");
    let options = SimplifyOptions { target_ratio: Some(0.75), record_progressive: true, ..Default::default() };
    let out = simplify(&mesh, &options).unwrap();
    let target = mesh.face_count() / 4;
    assert!(out.mesh.face_count() <= target + target / 50, "{} faces for {target}", out.mesh.face_count());
    assert!(out.stats.flat_normals, "said");
    let normals = out.mesh.corners.normals().expect("the result has normals");
    for f in 0..out.mesh.face_count() {
        let face = out.mesh.face_area_vector(f).normalize();
        for n in &normals[3 * f..3 * f + 3] {
            let angle = face.dot(glam::DVec3::from(n.map(f64::from))).clamp(-1.0, 1.0).acos().to_degrees();
            assert!(angle < 1.0, "face {f}: a corner normal {angle}° off its face's");
        }
    }
    let pm = out.progressive.unwrap();
    assert!(pm.at_level(0).corners.normals().is_none(), "the progressive mesh leaves flat normals out");
    assert_eq!(pm.at_level(pm.levels()).face_count(), mesh.face_count());
    // Smooth normals (the sphere's own) are values: kept, not recomputed.
    let mut smooth = meshlod_engine::procedural::icosphere(3);
    let radial: Vec<[f32; 3]> =
        smooth.triangles.iter().flatten().map(|&v| smooth.point(v).normalize().as_vec3().to_array()).collect();
    smooth.corners.set_normals(Some(radial.clone()));
    let out = simplify(&smooth, &options).unwrap();
    assert!(!out.stats.flat_normals);
    assert!(out.mesh.corners.normals().unwrap().iter().all(|n| radial.contains(n)), "the input's normals");
}

/// The shared flat-shaded shapes (a torus, spheres, a cone, boxes; every edge a normal seam)
/// reach 10% of their faces and stay flat.
#[test]
fn the_shared_flat_shaded_shapes_reach_their_target() {
    use meshlod_engine::simplify::{SimplifyOptions, simplify};
    let Some(dir) = meshlod_engine::datasets::require_shared_gltf("flat_shaded_shapes") else { return };
    let mesh = meshlod_engine::io::read_mesh(dir.join("flat/ShapeCollection.glb")).unwrap();
    let out = simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), ..Default::default() }).unwrap();
    let target = mesh.face_count() / 10;
    assert!(out.mesh.face_count() <= target + target / 50, "{} faces for {target}", out.mesh.face_count());
    assert!(out.stats.flat_normals);
    let normals = out.mesh.corners.normals().unwrap();
    for f in 0..out.mesh.face_count() {
        let face = out.mesh.face_area_vector(f).normalize();
        assert!(normals[3 * f..3 * f + 3].iter().all(|n| face.dot(glam::DVec3::from(n.map(f64::from))) > 0.9998));
    }
    assert!(meshlod_engine::validate::validate(&out.mesh).is_manifold_oriented);
}
