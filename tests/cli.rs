//! End-to-end tests of the `meshlod` command line: real processes, real files.

mod common;

use std::path::Path;
use std::process::Command;

use common::{fails_with, meshlod, ok_json, s, tempdir};
use serde_json::Value;

#[test]
fn a_reader_that_closes_the_pipe_early_ends_the_command_quietly() {
    // `meshlod info x.obj | head -0`: stdout's reader is gone before the first line is written.
    // The pipe's read end is closed before the command starts (closing it after the spawn raced
    // with the other tests' spawns, whose forks hold a copy of it until they exec).
    let dir = tempdir("pipe");
    let obj = dir.join("torus.obj");
    assert!(meshlod(&["generate", "torus", "-o", s(&obj), "--resolution", "16"]).status.success());
    for json in [false, true] {
        let mut args = vec!["info", s(&obj)];
        args.extend(json.then_some("--json"));
        let (reader, writer) = std::io::pipe().expect("a pipe");
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_meshlod"))
            .args(&args)
            .stdout(writer)
            .stderr(std::process::Stdio::piped())
            .output()
            .expect("meshlod runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.is_empty(), "{args:?}: stderr '{stderr}'");
        assert_eq!(out.status.code(), Some(141), "{args:?}");
    }
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
    for key in [
        "hausdorff_paper",
        "hausdorff_lower_paper",
        "hausdorff_absolute",
        "tolerance",
        "mean_paper",
        "rms_paper",
        "hausdorff_diag_pct",
        "samples",
        "a_to_b",
        "seconds",
    ] {
        assert!(same.get(key).is_some(), "hausdorff lacks {key}");
    }
    assert_eq!(same["hausdorff_paper"], 0.0);
    assert_eq!(same["mean_paper"], 0.0);

    let coarse = dir.join("coarse.obj");
    assert!(meshlod(&["generate", "torus", "-o", s(&coarse), "--resolution", "6"]).status.success());
    let d = ok_json(&["hausdorff", s(&obj), s(&coarse), "--json", "--samples", "2000"]);
    assert!(d["hausdorff_paper"].as_f64().unwrap() > 0.01);
    assert!(d["mean_paper"].as_f64().unwrap() < d["hausdorff_paper"].as_f64().unwrap());
    // Certified: the lower bound is a distance reached, the upper bound within the tolerance of it.
    let (upper, lower) = (d["hausdorff_paper"].as_f64().unwrap(), d["hausdorff_lower_paper"].as_f64().unwrap());
    assert!(lower <= upper && upper - lower <= 1e-3 * lower, "[{lower}, {upper}]");
    assert_eq!(d["converged"], true);
    // One direction on its own: its bounds meet too, and the symmetric figure is the larger one.
    let one = ok_json(&["hausdorff", s(&obj), s(&coarse), "--json", "--directed"]);
    let (one_upper, one_lower) = (one["max_upper_paper"].as_f64().unwrap(), one["max_lower_paper"].as_f64().unwrap());
    assert!(one_lower <= one_upper && one_upper - one_lower <= 1e-3 * one_lower, "[{one_lower}, {one_upper}]");
    assert!(one_upper <= upper * (1.0 + 1e-3) && one["direction"] == "a_to_b");
    let loose = ok_json(&["hausdorff", s(&obj), s(&coarse), "--json", "--tolerance", "0.1"]);
    let loose_upper = loose["hausdorff_paper"].as_f64().unwrap();
    assert!(loose_upper >= lower && loose_upper <= 1.1 * loose["hausdorff_lower_paper"].as_f64().unwrap());
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
    // Errors about the input mesh name its file.
    fails_with(&["simplify", s(&empty), "-o", s(&dir.join("e.ply"))], "empty.obj: mesh is empty");
    fails_with(&["refine", s(&empty), "-o", s(&dir.join("e.ply")), "--etc", "1"], "empty.obj: mesh is empty");
    fails_with(&["convert", s(&nan), s(&dir.join("out.ply"))], "line 2");
    let good = dir.join("good.obj");
    std::fs::write(&good, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    fails_with(&["convert", s(&good), s(&dir.join("out.stl"))], "unsupported format");
    fails_with(&["hausdorff", s(&good), s(&good), "--samples", "0"], "samples");
    fails_with(&["hausdorff", s(&good), s(&good), "--tolerance", "0"], "tolerance");
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
    assert_eq!(zero["hausdorff_paper"], 0.0);
}

#[test]
fn demo_runs_without_any_files() {
    let dir = tempdir("demo");
    let out = meshlod(&["demo", "--out-dir", s(&dir)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("Hausdorff"));
}

#[test]
fn simplify_pm_lod_chain() {
    let dir = tempdir("simplify");
    let input = dir.join("blob.obj");
    assert!(meshlod(&["generate", "blob", "-o", s(&input), "--resolution", "24"]).status.success());
    let out = dir.join("low.ply");
    let pm = dir.join("blob.pm");
    let report =
        ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--pm", s(&pm), "--hausdorff", "--json"]);
    for key in [
        "faces_in",
        "faces_out",
        "metric",
        "w",
        "seconds",
        "stop_reason",
        "hausdorff_paper",
        "mean_paper",
        "bytes_per_split",
    ] {
        assert!(report.get(key).is_some(), "simplify lacks {key}");
    }
    assert_eq!(report["stop_reason"], "target_reached");
    let faces_in = report["faces_in"].as_u64().unwrap();
    assert!(report["faces_out"].as_u64().unwrap() * 10 <= faces_in + 10);
    // The compact progressive mesh rebuilds the original on its 16-bit grid: every vertex within
    // half a grid cell (half of 2/65535 paper units per axis, 2.64e-5 across the cell).
    let full = dir.join("full.obj");
    let lod = ok_json(&["lod", s(&pm), "--faces", &faces_in.to_string(), "-o", s(&full), "--json"]);
    assert_eq!(lod["faces"], faces_in);
    let d = ok_json(&["hausdorff", s(&input), s(&full), "--json"]);
    let grid_error = d["hausdorff_paper"].as_f64().unwrap();
    assert!(grid_error > 0.0 && grid_error <= 2.7e-5, "{grid_error}");
    // The lossless one rebuilds it exactly: zero distance at full resolution.
    let lossless = dir.join("lossless.pm");
    let args =
        ["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--pm", s(&lossless), "--pm-lossless", "--json"];
    let exact = ok_json(&args);
    assert!(exact["bytes_per_split"].as_f64().unwrap() > 2.0 * report["bytes_per_split"].as_f64().unwrap());
    ok_json(&["lod", s(&lossless), "--faces", &faces_in.to_string(), "-o", s(&full), "--json"]);
    let d = ok_json(&["hausdorff", s(&input), s(&full), "--json"]);
    assert_eq!(d["hausdorff_paper"], 0.0);
    let mid = dir.join("mid.obj");
    let lod = ok_json(&["lod", s(&pm), "--faces", "1000", "-o", s(&mid), "--json"]);
    assert!(lod["faces"].as_u64().unwrap() <= 1000 && lod["faces"].as_u64().unwrap() >= 998);
    // Errors: bad ratio, corrupt .pm.
    fails_with(&["simplify", s(&input), "-o", s(&out), "--ratio", "1.5"], "ratio");
    fails_with(&["simplify", s(&input), "-o", s(&out), "--attribute-weights", "uv=-1"], "attribute_weights.uv");
    fails_with(&["simplify", s(&input), "-o", s(&out), "--attribute-weights", "gloss=1"], "unknown attribute");
    ok_json(&["simplify", s(&input), "-o", s(&out), "--attribute-weights", "uv=4,normal=2", "--json"]);
    // --prune: a part far smaller than the error (a tetrahedron on the blob's first vertex) goes
    // whole, said in the report and the text; not with --pm.
    let blob = std::fs::read_to_string(&input).unwrap();
    let n = blob.lines().filter(|l| l.starts_with("v ")).count();
    let first: Vec<f64> = blob.lines().find(|l| l.starts_with("v ")).unwrap()[2..]
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    let mut two = blob.clone();
    for d in [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]] {
        two += &format!("v {} {} {}\n", first[0] + d[0], first[1] + d[1], first[2] + d[2]);
    }
    for f in [[1, 3, 2], [1, 2, 4], [1, 4, 3], [2, 3, 4]] {
        two += &format!("f {} {} {}\n", n + f[0], n + f[1], n + f[2]);
    }
    let two_parts = dir.join("two-parts.obj");
    std::fs::write(&two_parts, two).unwrap();
    let pruned = ok_json(&["simplify", s(&two_parts), "-o", s(&out), "--ratio", "0.95", "--prune", "--json"]);
    assert_eq!(pruned["parts_removed"], 1);
    assert_eq!(ok_json(&["info", s(&out), "--json"])["components"], 1);
    assert_eq!(ok_json(&["simplify", s(&two_parts), "-o", s(&out), "--ratio", "0.95", "--json"])["parts_removed"], 0);
    let text = meshlod(&["simplify", s(&two_parts), "-o", s(&out), "--ratio", "0.95", "--prune"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("1 part taken out"));
    fails_with(&["simplify", s(&two_parts), "-o", s(&out), "--prune", "--pm", s(&pm)], "--pm");
    std::fs::write(dir.join("bad.pm"), b"MLPM garbage").unwrap();
    fails_with(&["lod", s(&dir.join("bad.pm")), "--faces", "10", "-o", s(&mid)], "bad.pm");
    for metric in ["qem", "melax", "qfvp"] {
        let r = ok_json(&["simplify", s(&input), "-o", s(&out), "--faces", "500", "--metric", metric, "--json"]);
        assert_eq!(r["metric"], metric);
    }
    // The distance guard: `--guard` alone is weight 1, a value sets it; refused with Melax.
    assert_eq!(report["guard"], 0.0);
    let guarded = ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--guard", "--json"]);
    assert_eq!(guarded["guard"], 1.0);
    assert_eq!(guarded["faces_out"], report["faces_out"]);
    let weighted = ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--guard", "0.3", "--json"]);
    assert_eq!(weighted["guard"], 0.3);
    fails_with(&["simplify", s(&input), "-o", s(&out), "--guard=-1"], "guard");
    fails_with(&["simplify", s(&input), "-o", s(&out), "--metric", "melax", "--guard"], "guard");
    // The fan-distance term: on (weight 1) by default, set or turned off by its flag, reported as
    // 0 where it does not apply (the guard replaces it).
    assert_eq!(report["distance_term"], 1.0);
    assert_eq!(guarded["distance_term"], 0.0);
    let paper = ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--distance-term", "0", "--json"]);
    assert_eq!(paper["distance_term"], 0.0);
    let heavier = ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--distance-term", "2", "--json"]);
    assert_eq!(heavier["distance_term"], 2.0);
    fails_with(&["simplify", s(&input), "-o", s(&out), "--distance-term=-1"], "--distance-term");
    fails_with(&["simplify", s(&input), "-o", s(&out), "--distance-term", "NaN"], "distance_term");
}

/// A run that stops above its target says which rules held its edges: the refusals by rule sum to
/// `rejected`, and the text names them.
#[test]
fn simplify_names_the_rules_that_refused_its_last_collapses() {
    let dir = tempdir("refusals");
    let tetra = dir.join("tetra.obj");
    std::fs::write(&tetra, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n").unwrap();
    let out = dir.join("out.obj");
    let report = ok_json(&["simplify", s(&tetra), "-o", s(&out), "--faces", "1", "--json"]);
    assert_eq!(report["stop_reason"], "no_legal_collapse", "{report}");
    let refused = report["refused"].as_object().expect("refused by rule");
    let total: u64 = refused.values().map(|n| n.as_u64().unwrap()).sum();
    // Every edge of a tetrahedron leaves its merged vertex two faces: rule 3 refuses them all.
    assert!(total > 0 && refused["too_few_faces"].as_u64() == Some(total), "{report}");
    assert_eq!(report["rejected"].as_u64(), Some(total), "{report}");
    let text = meshlod(&["simplify", s(&tetra), "-o", s(&out), "--faces", "1"]);
    assert!(text.status.success());
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains(&format!("{total} refused ({total} too few faces)")), "{text}");
}

/// A double-sided sheet modelled with two faces simplifies, both sides kept, and the report says
/// so; asked for a progressive mesh, it warns that the file holds the front.
#[test]
fn a_double_sided_sheet_simplifies_and_says_what_the_progressive_mesh_holds() {
    let dir = tempdir("double-sided");
    let sheet = dir.join("sheet.obj");
    let mut obj = String::new();
    for j in 0..5 {
        for i in 0..5 {
            obj += &format!("v {i} {j} {}\n", ((i * 7 + j * 3) % 5) as f32 * 0.1);
        }
    }
    let mut faces = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            let v = j * 5 + i + 1;
            faces.extend([[v, v + 1, v + 6], [v, v + 6, v + 5]]);
        }
    }
    for [a, b, c] in faces.iter().chain(faces.iter().map(|[a, b, c]| [*a, *c, *b]).collect::<Vec<_>>().iter()) {
        obj += &format!("f {a} {b} {c}\n");
    }
    std::fs::write(&sheet, obj).unwrap();
    let (out, pm) = (dir.join("out.obj"), dir.join("out.pm"));
    let report = ok_json(&["simplify", s(&sheet), "-o", s(&out), "--ratio", "0.5", "--pm", s(&pm), "--json"]);
    assert_eq!(report["back_faces"], 32, "{report}");
    assert_eq!(report["stop_reason"], "target_reached", "{report}");
    assert!(report["warnings"].to_string().contains("the progressive mesh and its levels the one sheet"), "{report}");
    let info = ok_json(&["info", s(&out), "--json"]);
    assert_eq!(info["faces"], report["faces_out"], "{info}");
    // Without a progressive mesh nothing is lost, and nothing is said.
    let report = ok_json(&["simplify", s(&sheet), "-o", s(&out), "--ratio", "0.5", "--json"]);
    assert_eq!(report["warnings"], serde_json::json!([]), "{report}");
}

#[test]
fn refine_both_directions() {
    let dir = tempdir("refine");
    let input = dir.join("blob.obj");
    assert!(meshlod(&["generate", "blob", "-o", s(&input), "--resolution", "20"]).status.success());
    let out = dir.join("out.obj");
    let up = ok_json(&["refine", s(&input), "-o", s(&out), "--etc", "1.0", "--json", "--reference", s(&input)]);
    for key in ["faces_in", "faces_out", "etc", "mode", "seconds", "reference_mean_paper", "reference_hausdorff_paper"]
    {
        assert!(up.get(key).is_some(), "refine lacks {key}");
    }
    assert_eq!(up["mode"], "subdivide");
    assert!(up["faces_out"].as_u64() > up["faces_in"].as_u64());
    let down = ok_json(&["refine", s(&input), "-o", s(&out), "--faces", "400", "--json"]);
    assert_eq!(down["mode"], "simplify");
    assert!(down["faces_out"].as_u64().unwrap().abs_diff(400) <= 4);
    fails_with(&["refine", s(&input), "-o", s(&out), "--etc", "1", "--rounds", "0"], "rounds");
}

#[test]
fn predictor_drives_w_and_etc() {
    let dir = tempdir("predict");
    let input = dir.join("blob.obj");
    assert!(meshlod(&["generate", "blob", "-o", s(&input), "--resolution", "20"]).status.success());
    let p = ok_json(&["predict", s(&input), "--ratio", "0.9", "--json"]);
    let w = p["w"].as_f64().unwrap();
    assert!([0.0, 0.5, 1.0, 1.5, 2.0].contains(&w), "{p}");
    let total: f64 = p["probabilities"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).sum();
    assert!((total - 1.0).abs() < 1e-4);
    assert!(p["etc"].as_f64().unwrap() > 0.0 && !p["model_version"].as_str().unwrap().is_empty());
    let out = dir.join("out.ply");
    let simplified = ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--w", "auto", "--json"]);
    assert_eq!(simplified["w_source"], "predicted");
    assert_eq!(simplified["w"], p["w"]);
    let refined = ok_json(&["refine", s(&input), "-o", s(&out), "--faces", "10000", "--etc", "auto", "--json"]);
    assert_eq!(refined["etc_source"], "predicted");
    assert!(refined["faces_out"].as_u64().unwrap() > refined["faces_in"].as_u64().unwrap());
    fails_with(&["refine", s(&input), "-o", s(&out), "--etc", "auto"], "--faces");
    fails_with(&["simplify", s(&input), "-o", s(&out), "--w", "sometimes"], "neither a number, 'auto' nor 'search'");
    // The measured alternative: every class tried, the lowest Hausdorff kept.
    let searched =
        ok_json(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--w", "search", "--hausdorff", "--json"]);
    assert_eq!(searched["w_source"], "searched");
    let candidates = searched["w_candidates"].as_array().expect("candidates listed");
    let ws: Vec<f64> = candidates.iter().map(|c| c["w"].as_f64().unwrap()).collect();
    assert_eq!(ws, [0.0, 0.5, 1.0, 1.5, 2.0]);
    let lowest = candidates.iter().map(|c| c["hausdorff_paper"].as_f64().unwrap()).fold(f64::INFINITY, f64::min);
    let chosen = candidates.iter().find(|c| c["w"] == searched["w"]).expect("the chosen w is a candidate");
    assert_eq!(chosen["hausdorff_paper"].as_f64().unwrap(), lowest);
    assert_eq!(searched["hausdorff_paper"].as_f64().unwrap(), lowest, "the output is the chosen run");
    fails_with(&["simplify", s(&input), "-o", s(&out), "--w", "search", "--metric", "melax"], "Melax has no w");
    fails_with(&["predict", s(&input), "--ratio", "3"], "ratio");
}

#[test]
fn batch_runs_jobs_reports_each_and_resumes() {
    let dir = tempdir("batch");
    let input = dir.join("torus.obj");
    assert!(meshlod(&["generate", "torus", "-o", s(&input), "--resolution", "16"]).status.success());
    // Textured: its OBJ output gets an MTL file and the texture beside it.
    let torus = std::fs::read_to_string(&input).unwrap();
    std::fs::write(&input, format!("mtllib torus.mtl\nusemtl skin\n{torus}")).unwrap();
    std::fs::write(dir.join("torus.mtl"), "newmtl skin\nmap_Kd skin.png\n").unwrap();
    std::fs::write(dir.join("skin.png"), b"\x89PNG\r\n\x1a\n").unwrap();
    let manifest = dir.join("jobs.jsonl");
    std::fs::write(
        &manifest,
        concat!(
            "{\"op\": \"simplify\", \"input\": \"torus.obj\", \"output\": \"out/low.ply\", \"args\": [\"--ratio\", \"0.9\"]}\n",
            "# comments and blank lines are ignored\n\n",
            "{\"op\": \"refine\", \"input\": \"torus.obj\", \"output\": \"out/fine.obj\", \"args\": [\"--etc\", \"1.0\"]}\n",
        ),
    )
    .unwrap();
    let results = dir.join("results.jsonl");
    let run = |extra: &[&str]| {
        let mut args = vec!["batch", s(&manifest), "--results", s(&results), "--quiet", "--jobs", "2"];
        args.extend_from_slice(extra);
        let out = meshlod(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = std::fs::read_to_string(&results).unwrap();
        text.lines().map(|l| serde_json::from_str::<Value>(l).unwrap()).collect::<Vec<_>>()
    };
    let first = run(&[]);
    assert_eq!(first.len(), 2);
    assert!(first.iter().all(|r| r["status"] == "ok"), "{first:?}");
    assert!(dir.join("out/low.ply").is_file() && dir.join("out/fine.obj").is_file());
    // Resumable: up-to-date outputs are skipped, --force redoes them.
    assert!(run(&[]).iter().all(|r| r["status"] == "skipped"));
    assert!(run(&["--force"]).iter().all(|r| r["status"] == "ok"));
    // A job whose OBJ has lost its texture is not up to date: it is run again, the texture back.
    let texture = dir.join("out/skin.png");
    assert!(dir.join("out/fine.mtl").is_file() && texture.is_file());
    std::fs::remove_file(&texture).unwrap();
    let mut statuses: Vec<(u64, String)> =
        run(&[]).iter().map(|r| (r["line"].as_u64().unwrap(), r["status"].as_str().unwrap().to_string())).collect();
    statuses.sort();
    assert_eq!(statuses, [(1, "skipped".to_string()), (4, "ok".to_string())]);
    assert!(texture.is_file());
    // A bad job is reported and fails the batch, without stopping the others.
    std::fs::write(&manifest, "{\"op\": \"simplify\", \"input\": \"missing.obj\", \"output\": \"x.ply\"}\n").unwrap();
    let out = meshlod(&["batch", s(&manifest), "--results", s(&results), "--quiet"]);
    assert!(!out.status.success());
    let text = std::fs::read_to_string(&results).unwrap();
    assert!(text.contains("\"status\":\"error\"") && text.contains("missing.obj"), "{text}");
}

#[test]
fn samples_read_several_folders_skip_bad_meshes_and_resume() {
    let dir = tempdir("samples");
    let (a, b) = (dir.join("a"), dir.join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    assert!(meshlod(&["generate", "torus", "-o", s(&a.join("torus.obj")), "--resolution", "8"]).status.success());
    assert!(meshlod(&["generate", "blob", "-o", s(&b.join("blob.ply")), "--resolution", "8"]).status.success());
    std::fs::write(b.join("broken.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let out_csv = dir.join("samples.csv");
    let run = |only: &[&str], resume: bool| {
        let mut args = vec!["samples", "--meshes", s(&a), s(&b), "--out", s(&out_csv), "--per-mesh", "2"];
        args.extend_from_slice(&["--etc-per-mesh", "1"]);
        if !only.is_empty() {
            args.push("--only");
            args.extend_from_slice(only);
        }
        if resume {
            args.push("--resume");
        }
        let out = meshlod(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let rows = |path: &Path| std::fs::read_to_string(path).unwrap().lines().map(str::to_owned).collect::<Vec<_>>();
    let stderr = run(&["torus", "broken"], false);
    assert!(stderr.contains("skipping broken") && stderr.contains("vertex 9"), "{stderr}");
    let first = rows(&out_csv);
    assert_eq!(first.len(), 3, "{first:?}");
    let header: Vec<&str> = first[0].split(',').collect();
    let errors: Vec<usize> = (0..header.len()).filter(|&i| header[i].starts_with("error_w")).collect();
    assert_eq!(errors.len(), 5);
    for row in &first[1..] {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells[0], "torus");
        let e: Vec<f64> = errors.iter().map(|&i| cells[i].parse().unwrap()).collect();
        assert!(e.iter().all(|v| v.is_finite() && *v > 0.0), "{row}");
        let best: f64 = cells.last().unwrap().parse().unwrap();
        let k = [0.0, 0.5, 1.0, 1.5, 2.0].iter().position(|w| *w == best).unwrap();
        assert!(e.iter().all(|v| e[k] <= *v), "best_w is the lowest error: {row}");
    }
    assert_eq!(rows(&dir.join("samples.etc.csv")).len(), 3);
    // Resuming keeps the rows there and adds only the mesh they lack.
    let stderr = run(&[], true);
    assert!(stderr.contains("1 meshes done"), "{stderr}");
    let second = rows(&out_csv);
    assert_eq!(second[..3], first[..]);
    assert_eq!(second.len(), 5);
    assert!(second[3].starts_with("blob,") && second[4].starts_with("blob,"));
    let provenance: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("samples.meta.json")).unwrap()).unwrap();
    assert!(
        provenance["seconds"].as_f64().unwrap() > 0.0
            && provenance["command"].as_str().unwrap().contains("--per-mesh 2")
    );
    // --refeature rewrites the feature columns from the meshes and keeps every measured column.
    let measured = |line: &str| line.split(',').rev().take(6).map(str::to_owned).collect::<Vec<_>>();
    let mut tampered = second.clone();
    let mut cells: Vec<&str> = second[1].split(',').collect();
    cells[4] = "7"; // a feature column (log10_faces_target)
    tampered[1] = cells.join(",");
    std::fs::write(&out_csv, tampered.join("\n") + "\n").unwrap();
    let refeatured = {
        let out = meshlod(&["samples", "--meshes", s(&a), s(&b), "--out", s(&out_csv), "--refeature"]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        rows(&out_csv)
    };
    assert_eq!(refeatured, second, "the features come back as the engine computes them");
    assert!(second.iter().zip(&refeatured).all(|(a, b)| measured(a) == measured(b)));
    fails_with(&["samples", "--meshes", s(&a), "--out", s(&out_csv), "--refeature"], "blob");
    fails_with(&["samples", "--meshes", s(&a), "--out", s(&out_csv), "--per-mesh", "0"], "--per-mesh");
}

#[test]
fn stl_and_off_inputs_are_read_and_outputs_are_refused() {
    let dir = tempdir("stl-off");
    let obj = dir.join("torus.obj");
    assert!(meshlod(&["generate", "torus", "-o", s(&obj), "--resolution", "12"]).status.success());
    let mesh = meshlod_engine::io::read_mesh(&obj).unwrap();
    // Binary STL: a facet soup, which the reader welds back into the torus.
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&(mesh.face_count() as u32).to_le_bytes());
    for t in &mesh.triangles {
        stl.extend_from_slice(&[0u8; 12]);
        for &v in t {
            for c in mesh.positions[v as usize] {
                stl.extend_from_slice(&c.to_le_bytes());
            }
        }
        stl.extend_from_slice(&[0, 0]);
    }
    let stl_path = dir.join("torus.stl");
    std::fs::write(&stl_path, &stl).unwrap();
    let mut off = format!("OFF\n{} {} 0\n", mesh.vertex_count(), mesh.face_count());
    for p in &mesh.positions {
        off += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in &mesh.triangles {
        off += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    let off_path = dir.join("torus.off");
    std::fs::write(&off_path, off).unwrap();

    for input in [&stl_path, &off_path] {
        let info = ok_json(&["info", s(input), "--json"]);
        assert_eq!(
            (info["vertices"].as_u64(), info["faces"].as_u64()),
            (Some(mesh.vertex_count() as u64), Some(mesh.face_count() as u64))
        );
        assert_eq!(info["boundary_loops"], 0, "{input:?} was not welded into a closed torus");
        let same = ok_json(&["hausdorff", s(&obj), s(input), "--json"]);
        assert_eq!(same["hausdorff_paper"], 0.0);
        let out = dir.join("lod.ply");
        let report = ok_json(&["simplify", s(input), "-o", s(&out), "--ratio", "0.5", "--json"]);
        assert!(report["faces_out"].as_u64().unwrap() <= mesh.face_count() as u64 / 2 + 1, "{report}");
    }
    fails_with(&["convert", s(&obj), s(&dir.join("out.stl"))], "read only");
    std::fs::write(dir.join("lying.stl"), &stl[..stl.len() - 7]).unwrap();
    fails_with(&["info", s(&dir.join("lying.stl"))], "header counts");
}

#[test]
fn attributes_are_listed_converted_kept_by_simplify_and_their_loss_is_said() {
    let dir = tempdir("attributes");
    let cube = dir.join("cube.obj");
    // A cube whose six faces each have their own texture square and flat normal.
    std::fs::write(
        &cube,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn 1 0 0\nvn -1 0 0\n\
         f 1/1/1 4/4/1 3/3/1 2/2/1\nf 5/1/2 6/2/2 7/3/2 8/4/2\nf 1/1/3 2/2/3 6/3/3 5/4/3\n\
         f 3/1/4 4/2/4 8/3/4 7/4/4\nf 2/1/5 3/2/5 7/3/5 6/4/5\nf 1/1/6 5/2/6 8/3/6 4/4/6\n",
    )
    .unwrap();
    let info = ok_json(&["info", s(&cube), "--json"]);
    assert_eq!(info["attributes"], serde_json::json!(["normal", "uv"]));
    assert_eq!(info["seam_edges"], 12);
    for out in ["copy.obj", "copy.ply"] {
        let out = dir.join(out);
        assert!(meshlod(&["convert", s(&cube), s(&out)]).status.success());
        let copy = ok_json(&["info", s(&out), "--json"]);
        // PLY writes a seam vertex once per side (one value per vertex) and joins them back by
        // position when it reads: the same vertices and seams either way.
        for key in ["attributes", "faces", "vertices", "seam_edges", "boundary_edges"] {
            assert_eq!(copy[key], info[key], "{out:?}: {key}");
        }
    }
    let bare = dir.join("bare.obj");
    assert!(meshlod(&["convert", s(&cube), s(&bare), "--drop-attributes"]).status.success());
    assert_eq!(ok_json(&["info", s(&bare), "--json"])["attributes"], serde_json::json!([]));
    // Every cube vertex is on a texture seam (its normals are flat, each face's own, and do not
    // count): simplification keeps every face, with their values.
    let lod = dir.join("lod.obj");
    let pm = dir.join("lod.pm");
    let out = meshlod(&["simplify", s(&cube), "-o", s(&lod), "--ratio", "0.5", "--pm", s(&pm), "--json"]);
    assert!(out.status.success());
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((report["faces_out"].as_u64(), report["flat_normals"].as_bool()), (Some(12), Some(true)), "{report}");
    let kept = ok_json(&["info", s(&lod), "--json"]);
    for key in ["attributes", "faces", "seam_edges"] {
        assert_eq!(kept[key], info[key], "{key}");
    }
    // The progressive mesh carries them too but the flat normals, as it says (a viewer draws a
    // mesh without normals flat): a level rebuilt from the file has the texture coordinates and
    // their seams.
    let warnings = report["warnings"].as_array().unwrap();
    assert!(warnings.len() == 1 && warnings[0].as_str().unwrap().contains("flat-shaded"), "{report}");
    let level = dir.join("level.ply");
    assert!(meshlod(&["lod", s(&pm), "--faces", "12", "-o", s(&level)]).status.success());
    let rebuilt = ok_json(&["info", s(&level), "--json"]);
    assert_eq!((&rebuilt["attributes"], &rebuilt["faces"]), (&serde_json::json!(["uv"]), &info["faces"]));
    assert!(rebuilt["seam_edges"].as_u64().unwrap() > 0, "{rebuilt}");
    // Refinement carries them: subdivision interpolates them face by face, seams kept.
    for mode in ["subdivide", "simplify", "both"] {
        let fine = dir.join(format!("fine-{mode}.obj"));
        let refined = ok_json(&["refine", s(&cube), "-o", s(&fine), "--etc", "1", "--mode", mode, "--json"]);
        assert_eq!(refined["warnings"], serde_json::json!([]), "{mode}: {refined}");
        let kept = ok_json(&["info", s(&fine), "--json"]);
        assert_eq!(kept["attributes"], info["attributes"], "{mode}");
        assert!(kept["seam_edges"].as_u64().unwrap() >= 12, "{mode}: {kept}");
    }
}

#[test]
fn textured_gltf_assets_convert_to_obj_with_their_attributes() {
    let Some(textured) = meshlod_engine::datasets::require_shared_textured("textured_gltf_convert") else { return };
    let dir = tempdir("gltf");
    for (asset, attributes) in [
        ("draco__Duck/Duck.gltf", serde_json::json!(["normal", "uv", "material"])),
        ("draco__CesiumMan/CesiumMan.gltf", serde_json::json!(["normal", "uv", "joints", "weights", "material"])),
    ] {
        let input = textured.join(asset);
        let info = ok_json(&["info", s(&input), "--json"]);
        assert_eq!(info["attributes"], attributes, "{asset}");
        assert_eq!(
            (info["boundary_edges"].as_u64(), info["components"].as_u64()),
            (Some(0), Some(1)),
            "{asset}: one closed surface"
        );
        for out in ["asset.obj", "asset.glb", "asset.gltf"] {
            let out = dir.join(out);
            let run = meshlod(&["convert", s(&input), s(&out)]);
            assert!(run.status.success(), "{asset}");
            let copy = ok_json(&["info", s(&out), "--json"]);
            for key in ["vertices", "faces", "seam_edges"] {
                assert_eq!(copy[key], info[key], "{asset} → {}: {key}", out.display());
            }
            // OBJ has no skin: the joints and weights go, and the warning says so.
            let mut kept = attributes.as_array().unwrap().clone();
            if out.extension().unwrap() == "obj" {
                kept.retain(|a| a != "joints" && a != "weights");
                let skinned = kept.len() < attributes.as_array().unwrap().len();
                let stderr = String::from_utf8_lossy(&run.stderr);
                assert_eq!(stderr.contains("no place for the mesh's joints, weights"), skinned, "{asset}: {stderr}");
            }
            assert_eq!(copy["attributes"], serde_json::Value::Array(kept), "{asset} → {}", out.display());
        }
    }
    fails_with(&["convert", s(&textured.join("draco__Duck/Duck.gltf")), s(&dir.join("duck.stl"))], "read only");
    // What a result cannot carry is said: CesiumMan (its skin and animations carried) has nothing
    // left out, only its weights mended (a fifteenth of them do not sum to 1), and a skinned result
    // written as OBJ says what it lost.
    let warnings = |asset: &str| {
        let out = dir.join("lod.glb");
        let report = ok_json(&["simplify", s(&textured.join(asset)), "-o", s(&out), "--ratio", "0.9", "--json"]);
        assert_eq!(report["placement"], "endpoint", "{asset}: texture coordinates keep vertices in place");
        report["warnings"].as_array().unwrap().iter().map(|w| w.as_str().unwrap().to_string()).collect::<Vec<_>>()
    };
    let said = warnings("draco__CesiumMan/CesiumMan.gltf");
    assert!(said.len() == 1 && said[0].contains("WEIGHTS_0") && said[0].contains("at 210 vertices"), "{said:?}");
    // `info` says the same before anything is written.
    let info = ok_json(&["info", s(&textured.join("draco__CesiumMan/CesiumMan.gltf")), "--json"]);
    assert_eq!(info["warnings"], serde_json::json!(said));
    // A progressive mesh's bytes per split leave its materials and images out (Fox's texture is
    // most of its file).
    let (out, pm) = (dir.join("fox.glb"), dir.join("fox.pm"));
    let fox = textured.join("draco__Fox/Fox.gltf");
    let report = ok_json(&["simplify", s(&fox), "-o", s(&out), "--ratio", "0.5", "--pm", s(&pm), "--json"]);
    let materials = report["pm_materials_bytes"].as_f64().unwrap();
    let png = std::fs::metadata(textured.join("draco__Fox/Texture.png")).unwrap().len() as f64;
    assert!(materials > png, "{report}");
    assert!(report["bytes_per_split"].as_f64().unwrap() < 64.0, "{report}");
    let out = dir.join("lod.obj");
    let cesium = textured.join("draco__CesiumMan/CesiumMan.gltf");
    let report = ok_json(&["simplify", s(&cesium), "-o", s(&out), "--ratio", "0.9", "--json"]);
    let said = report["warnings"].as_array().unwrap();
    assert!(said.iter().any(|w| w.as_str().unwrap().contains("joints, weights")), "{said:?}");
    assert_eq!(warnings("draco__Lantern/Lantern.gltf"), Vec::<String>::new());
    assert_eq!(warnings("draco__Duck/Duck.gltf"), Vec::<String>::new());
}
