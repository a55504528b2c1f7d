//! End-to-end tests of the `meshlod` command line: real processes, real files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn meshlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshlod")).args(args).output().expect("meshlod runs")
}

fn ok_json(args: &[&str]) -> Value {
    let out = meshlod(args);
    assert!(out.status.success(), "{args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{args:?}: bad JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)))
}

fn fails_with(args: &[&str], needle: &str) {
    let out = meshlod(args);
    assert!(!out.status.success(), "{args:?} should fail");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(needle), "{args:?}: stderr '{stderr}' lacks '{needle}'");
}

fn tempdir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meshlod-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn generate_info_convert_hausdorff_chain() {
    let dir = tempdir("chain");
    let obj = dir.join("torus.obj");
    let ply = dir.join("torus.ply");
    assert!(meshlod(&["generate", "torus", "-o", s(&obj), "--resolution", "16"]).status.success());
    let info = ok_json(&["info", s(&obj), "--json"]);
    for key in [
        "vertices",
        "faces",
        "degenerate_faces",
        "duplicate_faces",
        "non_manifold_edges",
        "non_manifold_vertices",
        "boundary_loops",
        "components",
        "bbox_min",
        "bbox_max",
    ] {
        assert!(info.get(key).is_some(), "info lacks {key}");
    }
    assert_eq!(info["faces"], 2 * 32 * 16);
    assert!(meshlod(&["convert", s(&obj), s(&ply), "--clean"]).status.success());
    let same = ok_json(&["hausdorff", s(&obj), s(&ply), "--json"]);
    for key in ["hausdorff", "mean", "rms", "hausdorff_diag_pct", "samples"] {
        assert!(same.get(key).is_some(), "hausdorff lacks {key}");
    }
    assert_eq!(same["hausdorff"], 0.0);
    assert_eq!(same["mean"], 0.0);

    let coarse = dir.join("coarse.obj");
    assert!(meshlod(&["generate", "torus", "-o", s(&coarse), "--resolution", "6"]).status.success());
    let d = ok_json(&["hausdorff", s(&obj), s(&coarse), "--json", "--samples", "2000"]);
    assert!(d["hausdorff"].as_f64().unwrap() > 0.01);
    assert!(d["mean"].as_f64().unwrap() < d["hausdorff"].as_f64().unwrap());
}

#[test]
fn errors_are_clear_and_nonzero() {
    let dir = tempdir("errors");
    fails_with(&["info", s(&dir.join("nope.obj"))], "nope.obj");
    let nan = dir.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    fails_with(&["info", s(&nan)], "line 2");
    let bad = dir.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    fails_with(&["hausdorff", s(&bad), s(&bad)], "vertex 7");
    let empty = dir.join("empty.obj");
    std::fs::write(&empty, "v 0 0 0\n").unwrap();
    fails_with(&["hausdorff", s(&empty), s(&empty)], "no faces");
    fails_with(&["convert", s(&nan), s(&dir.join("out.stl"))], "line 2");
    let good = dir.join("good.obj");
    std::fs::write(&good, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    fails_with(&["convert", s(&good), s(&dir.join("out.stl"))], "unsupported format");
    fails_with(&["hausdorff", s(&good), s(&good), "--samples", "0"], "--samples");
}

#[test]
fn info_matches_known_counts_of_shared_meshes() {
    let Some(dir) = meshlod_engine::datasets::require_shared_meshes("info_matches_known_counts_of_shared_meshes")
    else {
        return;
    };
    for (name, vertices, faces) in [("cow", 2903, 5804), ("stanford-bunny", 35947, 69451)] {
        let info = ok_json(&["info", s(&dir.join(format!("{name}.obj"))), "--json"]);
        assert_eq!(info["vertices"], vertices, "{name}");
        assert_eq!(info["faces"], faces, "{name}");
    }
    let cow = dir.join("cow.obj");
    let zero = ok_json(&["hausdorff", s(&cow), s(&cow), "--json"]);
    assert_eq!(zero["hausdorff"], 0.0);
}

#[test]
fn demo_runs_without_any_files() {
    let dir = tempdir("demo");
    let out = meshlod(&["demo", "--out-dir", s(&dir)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("Hausdorff"));
}
