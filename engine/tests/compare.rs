//! `compare`: renders of two meshes from the same views, their pixel differences and silhouettes,
//! on procedural meshes with known answers and on the shared textured assets.

use meshlod_engine::compare::{CompareOptions, compare};
use meshlod_engine::io::read_mesh;
use meshlod_engine::simplify::{SimplifyOptions, simplify};
use meshlod_engine::{Mesh, procedural};

mod common;
use common::{obj, tempdir};

/// A square of side 2 in the plane x = 0, centred on the origin, moved by `dy` along y.
fn square(dy: f32) -> Mesh {
    let text = format!(
        "v 0 {} -1\nv 0 {} -1\nv 0 {} 1\nv 0 {} 1\nf 1 2 3\nf 1 3 4\n",
        -1.0 + dy,
        1.0 + dy,
        1.0 + dy,
        -1.0 + dy
    );
    obj(&text).unwrap()
}

#[test]
fn identical_meshes_compare_equal() {
    let mesh = procedural::bumpy_blob(24, 32, 7);
    let report = compare(&mesh, &mesh.clone(), &CompareOptions::default()).unwrap().report;
    assert_eq!((report.mae, report.psnr, report.silhouette), (0.0, None, 0.0), "{report:?}");
    assert_eq!(report.hausdorff, Some(0.0), "{report:?}");
    assert_eq!((report.views, report.faces_a, report.faces_b), (12, mesh.face_count(), mesh.face_count()));
}

#[test]
fn a_moved_copy_gives_the_silhouette_share_its_move_implies() {
    // One view, along x: the square is seen face on. Moved by s along y, the union of the two
    // squares is (2 + s) × 2 and the part only one covers 2s × 2 (the view spans A's bounding
    // sphere, radius √2, so moves up to 0.4 stay in the picture).
    let options = CompareOptions { views: 1, hausdorff: false, ..Default::default() };
    for s in [0.05f32, 0.2, 0.4] {
        let report = compare(&square(0.0), &square(s), &options).unwrap().report;
        let expected = 2.0 * f64::from(s) / (2.0 + f64::from(s));
        assert!((report.silhouette - expected).abs() < 0.01, "move {s}: silhouette {} ≠ {expected}", report.silhouette);
        assert!(report.mae > 0.0 && report.psnr.is_some_and(f64::is_finite), "{report:?}");
    }
    // The certified distance of the move: s, in paper units of the square (side 2 spans [−1, 1]).
    let report = compare(&square(0.0), &square(0.25), &CompareOptions { hausdorff: true, ..options }).unwrap().report;
    let (lower, upper) = (report.hausdorff_lower.unwrap(), report.hausdorff.unwrap());
    assert!(lower <= 0.25 + 1e-6 && upper >= 0.25 - 1e-6 && upper - lower < 0.01, "{lower} {upper}");
}

#[test]
fn the_picture_has_three_tiles_a_view_and_the_figures_do_not_depend_on_threads() {
    let a = procedural::torus(32, 16, 0.3);
    let b = simplify(&a, &SimplifyOptions { target_ratio: Some(0.8), ..Default::default() }).unwrap().mesh;
    let options = CompareOptions { views: 5, size: 64, hausdorff: false };
    let first = compare(&a, &b, &options).unwrap();
    let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let again = one_thread.install(|| compare(&a, &b, &options).unwrap());
    assert_eq!(first.report, again.report);
    assert_eq!(first.picture().into_raw(), again.picture().into_raw(), "the same pictures");
    assert!(first.report.mae > 0.0, "a simplified torus looks different: {:?}", first.report);
    let path = tempdir("compare").join("torus.png");
    first.write_png(&path).unwrap();
    let written = image::open(&path).unwrap();
    assert_eq!((written.width(), written.height()), (3 * 64, 5 * 64));
}

#[test]
fn bad_options_and_empty_meshes_are_refused_by_name() {
    let mesh = square(0.0);
    let e = compare(&mesh, &mesh, &CompareOptions { views: 0, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("views"), "{e}");
    let e = compare(&mesh, &mesh, &CompareOptions { size: 1, ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("size"), "{e}");
    let e = compare(&Mesh::default(), &mesh, &CompareOptions::default()).unwrap_err().to_string();
    assert!(e.contains("no faces"), "{e}");
    // An empty B is all silhouette, and has no distance (said).
    let report = compare(&mesh, &Mesh::default(), &CompareOptions::default()).unwrap().report;
    assert_eq!((report.silhouette, report.hausdorff), (1.0, None));
    assert!(report.notes.iter().any(|n| n.contains("no faces")), "{:?}", report.notes);
}

#[test]
fn textured_assets_are_drawn_with_their_textures() {
    let Some(dir) = meshlod_engine::datasets::require_shared_textured("compare_textured_assets") else { return };
    let options = CompareOptions { views: 6, size: 96, hausdorff: false };
    for name in ["draco__Duck/Duck.gltf", "trimesh__fuze/fuze.obj"] {
        let mesh = read_mesh(dir.join(name)).unwrap();
        let same = compare(&mesh, &mesh, &options).unwrap();
        assert!(same.report.notes.is_empty(), "{name}: every texture decoded: {:?}", same.report.notes);
        assert_eq!(same.report.mae, 0.0, "{name}");
        // Drawn with its texture: more colours than shading alone gives a white surface.
        let picture = same.picture();
        let colours: std::collections::HashSet<[u8; 3]> =
            picture.pixels().map(|p| p.0).filter(|&[r, g, b]| !(r == g && g == b)).collect();
        assert!(colours.len() > 50, "{name}: {} colours", colours.len());
        let lod = simplify(&mesh, &SimplifyOptions { target_ratio: Some(0.9), ..Default::default() }).unwrap().mesh;
        let report = compare(&mesh, &lod, &options).unwrap().report;
        assert!(report.mae > 0.0 && report.mae < 40.0, "{name}: {report:?}");
        // Without its texture coordinates the same LOD is further from the input.
        let mut bare = lod.clone();
        bare.corners.set_uvs(None);
        let worse = compare(&mesh, &bare, &options).unwrap().report;
        assert!(worse.mae > report.mae, "{name}: {} ≤ {}", worse.mae, report.mae);
    }
}
