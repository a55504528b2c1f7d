//! Every flag that says it works, working: the client against a real `meshlod serve` (same
//! flags, same report keys as the local commands), options checked before the work, options
//! without effect said, the batch manifest's rules, and output for people.

mod common;

use std::collections::BTreeSet;

use common::{Server, fails_with, keys, meshlod, ok, ok_json, s, tempdir};
use serde_json::Value;

#[test]
fn client_honours_every_flag_and_reports_as_local_does() {
    let dir = tempdir("client");
    let input = dir.join("blob.obj");
    ok(&["generate", "blob", "-o", s(&input), "--resolution", "24"]);
    let server = Server::start();
    let client = |args: &[&str]| {
        let mut all = vec!["client", "--server", server.address.as_str()];
        all.extend_from_slice(args);
        ok_json(&all)
    };
    // Simplify: the same flags here and there, the same keys, the same result; --pm is written.
    let (local_pm, remote_pm) = (dir.join("local.pm"), dir.join("remote.pm"));
    let (local_out, remote_out) = (dir.join("local.ply"), dir.join("remote.ply"));
    let flags = ["--ratio", "0.9", "--hausdorff", "--json"];
    let mut args = vec!["simplify", s(&input), "-o", s(&local_out), "--pm", s(&local_pm)];
    args.extend_from_slice(&flags);
    let local = ok_json(&args);
    let mut args = vec!["simplify", s(&input), "-o", s(&remote_out), "--pm", s(&remote_pm)];
    args.extend_from_slice(&flags);
    let remote = client(&args);
    assert_eq!(keys(&local), keys(&remote), "local and client simplify reports");
    for key in ["faces_out", "vertices_out", "collapses", "w_source", "pm_bytes", "pm_splits", "hausdorff_paper"] {
        assert_eq!(local[key], remote[key], "{key}");
    }
    assert_eq!(std::fs::read(&local_pm).unwrap(), std::fs::read(&remote_pm).unwrap(), "the same .pm bytes");
    let full = dir.join("full.obj");
    ok(&["lod", s(&remote_pm), "--faces", &local["faces_in"].to_string(), "-o", s(&full)]);
    // Refine with --reference: measured on the client against the reference.
    let r_local =
        ok_json(&["refine", s(&input), "-o", s(&dir.join("a.obj")), "--etc", "1", "--reference", s(&input), "--json"]);
    let r_remote =
        client(&["refine", s(&input), "-o", s(&dir.join("b.obj")), "--etc", "1", "--reference", s(&input), "--json"]);
    assert_eq!(keys(&r_local), keys(&r_remote), "local and client refine reports");
    assert!(r_remote.get("reference_hausdorff_paper").is_some());
    assert_eq!(r_local["faces_out"], r_remote["faces_out"]);
    // Predict: --json accepted by the client, the same report.
    let p_local = ok_json(&["predict", s(&input), "--ratio", "0.9", "--json"]);
    let p_remote = client(&["predict", s(&input), "--ratio", "0.9", "--json"]);
    assert_eq!(p_local, p_remote);
    // Text output, and errors that name the field and the flag.
    let text = ok(&["client", "--server", &server.address, "simplify", s(&input), "-o", s(&dir.join("t.ply"))]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("faces"));
    fails_with(
        &["client", "--server", &server.address, "simplify", s(&input), "-o", s(&dir.join("t.ply")), "--ratio", "2"],
        "--ratio (options.target_ratio): 2 is outside",
    );
    // A URL works as well as host:port; a closed port is reported, not hung on.
    let url = format!("http://{}", server.address);
    ok(&["client", "--server", &url, "predict", s(&input), "--faces", "100"]);
    drop(server);
    fails_with(&["health", "--server", "127.0.0.1:1", "--timeout", "2"], "127.0.0.1:1");
}

#[test]
fn local_and_client_runs_of_a_gltf_with_a_warning_print_the_same_report_and_write_the_same_bytes() {
    let dir = tempdir("client-parity");
    let obj = dir.join("torus.obj");
    ok(&["generate", "torus", "-o", s(&obj), "--resolution", "24"]);
    let plain = dir.join("plain.gltf");
    ok(&["convert", s(&obj), "-o", s(&plain)]);
    // A morph target: read, passed over, and said in the warnings. An application-specific
    // attribute beside it: carried into the result.
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&plain).unwrap()).unwrap();
    let position = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].clone();
    for primitive in doc["meshes"][0]["primitives"].as_array_mut().unwrap() {
        primitive["attributes"]["_SENSOR"] = position.clone();
        primitive["targets"] = serde_json::json!([{ "POSITION": position.clone() }]);
    }
    let input = dir.join("warned.gltf");
    std::fs::write(&input, serde_json::to_vec(&doc).unwrap()).unwrap();
    let server = Server::start();
    let run = |remote: bool, json: bool| {
        let output = dir.join(format!("{}-{json}.glb", if remote { "remote" } else { "local" }));
        let mut args = if remote { vec!["client", "--server", server.address.as_str()] } else { vec![] };
        args.extend_from_slice(&[
            "simplify",
            s(&input),
            "-o",
            s(&output),
            "--keep",
            "0.25",
            "--hausdorff",
            "--compare",
        ]);
        if json {
            args.push("--json");
        }
        let out = ok(&args);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let warnings: Vec<String> =
            stderr.lines().filter(|l| l.starts_with("meshlod: warning:")).map(str::to_string).collect();
        (String::from_utf8_lossy(&out.stdout).to_string(), warnings, std::fs::read(&output).unwrap())
    };
    let (local_json, local_warnings, local_bytes) = run(false, true);
    let (remote_json, remote_warnings, remote_bytes) = run(true, true);
    assert!(
        local_warnings.iter().any(|w| w.contains("morph targets")),
        "the local run says what it passed over: {local_warnings:?}"
    );
    assert_eq!(local_warnings, remote_warnings, "the same warnings on stderr");
    let mut local: Value = serde_json::from_str(&local_json).unwrap();
    let mut remote: Value = serde_json::from_str(&remote_json).unwrap();
    for report in [&mut local, &mut remote] {
        report.as_object_mut().unwrap().remove("seconds");
    }
    assert_eq!(local, remote, "the same report, but for the engine's time");
    assert!((local["kept_fraction"].as_f64().unwrap() - 0.25).abs() < 0.01, "{local}");
    // The comparison in pixels, measured on the server as here (the same figures: deterministic).
    assert!(local["pixels_mae"].as_f64().unwrap() > 0.0 && local["pixels_views"] == 12, "{local}");
    assert_eq!(local_bytes, remote_bytes, "the same GLB bytes");
    let json_length = u32::from_le_bytes(local_bytes[12..16].try_into().unwrap()) as usize;
    let written = String::from_utf8_lossy(&local_bytes[20..20 + json_length]).to_string();
    assert!(written.contains("\"_SENSOR\"") && !written.contains("targets"), "{written}");
    // The text reports agree too, but for the time and the output's name (`…; 0.012 s → out.glb`).
    let scrub = |text: &str| -> String {
        let without_time = |l: &str| match l.split_once(" s → ") {
            Some((before, _)) => before.rsplit_once("; ").map_or(before, |(kept, _)| kept).to_string(),
            None => l.to_string(),
        };
        text.lines().map(without_time).collect::<Vec<_>>().join("\n")
    };
    let (local_text, _, _) = run(false, false);
    let (remote_text, _, _) = run(true, false);
    assert_eq!(
        scrub(&local_text).replace(|c: char| c.is_ascii_digit(), "#"),
        scrub(&remote_text).replace(|c: char| c.is_ascii_digit(), "#")
    );
}

#[test]
fn keep_is_the_fraction_kept_and_ratio_the_fraction_removed() {
    let dir = tempdir("keep");
    let input = dir.join("blob.obj");
    ok(&["generate", "blob", "-o", s(&input), "--resolution", "24"]);
    let keep = ok_json(&["simplify", s(&input), "-o", s(&dir.join("k.obj")), "--keep", "0.1", "--json"]);
    let ratio = ok_json(&["simplify", s(&input), "-o", s(&dir.join("r.obj")), "--ratio", "0.9", "--json"]);
    assert_eq!(keep["target_faces"], ratio["target_faces"]);
    assert_eq!(keep["faces_out"], ratio["faces_out"]);
    let faces_in = keep["faces_in"].as_f64().unwrap();
    assert!((keep["target_faces"].as_f64().unwrap() - 0.1 * faces_in).abs() <= 1.0, "{keep}");
    let kept = keep["kept_fraction"].as_f64().unwrap();
    assert!((kept + keep["removed_fraction"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!((kept - 0.1).abs() < 0.01, "{keep}");
    fails_with(&["simplify", s(&input), "-o", s(&dir.join("x.obj")), "--keep", "1.5"], "--keep");
    fails_with(&["simplify", s(&input), "-o", s(&dir.join("x.obj")), "--keep", "0"], "--keep");
    fails_with(&["simplify", s(&input), "-o", s(&dir.join("x.obj")), "--keep", "0.1", "--ratio", "0.9"], "--ratio");
    let predicted = ok_json(&["predict", s(&input), "--keep", "0.1", "--json"]);
    assert_eq!(predicted, ok_json(&["predict", s(&input), "--ratio", "0.9", "--json"]));
    // convert takes -o as every other command does; the positional form still works.
    ok(&["convert", s(&input), "-o", s(&dir.join("a.ply"))]);
    ok(&["convert", s(&input), s(&dir.join("b.ply"))]);
    assert_eq!(std::fs::read(dir.join("a.ply")).unwrap(), std::fs::read(dir.join("b.ply")).unwrap());
    fails_with(&["convert", s(&input)], "OUTPUT");
    // The help's figures come from the engine's constants (one home each).
    let help = String::from_utf8_lossy(&ok(&["simplify", "--help"]).stdout).to_string();
    let share = format!("once {}% of the input's faces", (meshlod_engine::simplify::FAN_TERM_FROM * 100.0).round());
    assert!(help.contains(&share), "{help}");
    assert!(help.contains(&format!("{} faces or more", meshlod_engine::simplify::HALVES_FROM_FACES)), "{help}");
    assert!(help.contains("--keep <FRACTION>"), "{help}");
}

#[test]
fn client_sends_and_gets_back_materials() {
    let dir = tempdir("client-materials");
    let plain = dir.join("plain.obj");
    ok(&["generate", "torus", "-o", s(&plain), "--resolution", "16"]);
    // Two materials, one on each half of the faces.
    let text = std::fs::read_to_string(&plain).unwrap();
    let half = text.lines().filter(|l| l.starts_with("f ")).count() / 2;
    let (mut obj, mut faces) = (String::from("mtllib two.mtl\nusemtl red\n"), 0);
    for line in text.lines() {
        if line.starts_with("f ") {
            faces += 1;
            if faces == half + 1 {
                obj += "usemtl blue\n";
            }
        }
        obj += line;
        obj += "\n";
    }
    let input = dir.join("two.obj");
    std::fs::write(&input, obj).unwrap();
    std::fs::write(dir.join("two.mtl"), "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n").unwrap();
    let server = Server::start();
    let (local, remote) = (dir.join("local.glb"), dir.join("remote.glb"));
    let l = ok_json(&["simplify", s(&input), "-o", s(&local), "--ratio", "0.8", "--json"]);
    let r = ok_json(&[
        "client",
        "--server",
        &server.address,
        "simplify",
        s(&input),
        "-o",
        s(&remote),
        "--ratio",
        "0.8",
        "--json",
    ]);
    assert_eq!((&l["faces_out"], &l["vertices_out"]), (&r["faces_out"], &r["vertices_out"]));
    // The GLB's JSON chunk: its materials, and which primitive draws with which.
    let materials = |path: &std::path::Path| {
        let bytes = std::fs::read(path).unwrap();
        let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let json: Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
        let names: Vec<Value> = json["materials"].as_array().unwrap().iter().map(|m| m["name"].clone()).collect();
        let used: Vec<Value> =
            json["meshes"][0]["primitives"].as_array().unwrap().iter().map(|p| p["material"].clone()).collect();
        (names, used)
    };
    let (names, used) = materials(&remote);
    assert_eq!(names.len(), 2, "{names:?}");
    assert_eq!(used.len(), 2, "one primitive per material: {used:?}");
    assert_eq!(materials(&local), (names, used));
    let same = ok_json(&["hausdorff", s(&local), s(&remote), "--json"]);
    assert_eq!(same["hausdorff_paper"], 0.0, "the server's result is the local one");
}

#[test]
fn outputs_are_checked_before_any_work() {
    let dir = tempdir("outputs");
    // The input does not even exist: the output's error comes first, so no work was done.
    let missing = dir.join("missing.obj");
    fails_with(&["simplify", s(&missing), "-o", s(&dir.join("out.stl"))], "output extension");
    fails_with(&["simplify", s(&missing), "-o", s(&dir.join("no/such/dir/out.ply"))], "folder does not exist");
    fails_with(&["simplify", s(&missing), "-o", s(&dir.join("o.ply")), "--pm", s(&dir.join("no/x.pm"))], "x.pm");
    fails_with(&["refine", s(&missing), "-o", s(&dir.join("out.stl")), "--etc", "1"], "output extension");
    fails_with(&["convert", s(&missing), s(&dir.join("out.stl"))], "output extension");
    fails_with(&["generate", "sphere", "-o", s(&dir.join("s.stl"))], "output extension");
    // Options are checked before the mesh is read as well.
    let input = dir.join("t.obj");
    ok(&["generate", "torus", "-o", s(&input), "--resolution", "8"]);
    fails_with(&["simplify", s(&input), "-o", s(&dir.join("o.ply")), "--max-normal-change", "0"], "max_normal_change");
    fails_with(&["lod", s(&missing), "-o", s(&dir.join("l.ply")), "--max-error", "nan"], "--max-error");
}

#[test]
fn options_without_effect_are_said() {
    let dir = tempdir("warnings");
    let input = dir.join("t.obj");
    ok(&["generate", "torus", "-o", s(&input), "--resolution", "12"]);
    let out = dir.join("o.ply");
    let run = ok(&["simplify", s(&input), "-o", s(&out), "--metric", "qem", "--w", "1", "--json"]);
    let report: Value = serde_json::from_slice(&run.stdout).unwrap();
    assert!(String::from_utf8_lossy(&run.stderr).contains("warning: w has no effect"), "{run:?}");
    assert_eq!(report["warnings"].as_array().unwrap().len(), 1);
    let run = ok(&["simplify", s(&input), "-o", s(&out), "--normals", "recompute"]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("no effect at w = 0"));
    let quiet = ok(&["simplify", s(&input), "-o", s(&out), "--w", "1", "--normals", "recompute"]);
    assert!(!String::from_utf8_lossy(&quiet.stderr).contains("warning"), "{quiet:?}");
    // A level below the base mesh: the base, said.
    let pm = dir.join("t.pm");
    ok(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.9", "--pm", s(&pm)]);
    let lod = ok(&["lod", s(&pm), "--faces", "1", "-o", s(&dir.join("l.obj"))]);
    assert!(String::from_utf8_lossy(&lod.stderr).contains("below the coarsest level"));
}

#[test]
fn output_is_for_people_and_generate_stays_small() {
    let dir = tempdir("people");
    for shape in ["sphere", "torus", "box", "terrain", "blob"] {
        let path = dir.join(format!("{shape}.ply"));
        ok(&["generate", shape, "-o", s(&path)]);
        let info = ok_json(&["info", s(&path), "--json"]);
        let faces = info["faces"].as_u64().unwrap();
        assert!(faces > 1000 && faces < 1_000_000, "{shape}: {faces} faces by default");
    }
    fails_with(&["generate", "sphere", "-o", s(&dir.join("big.ply")), "--resolution", "10"], "at most 9");
    // Text: counts first, in the report's order; no debug quotes; at most 6 significant digits.
    let info = ok(&["info", s(&dir.join("torus.ply"))]);
    let text = String::from_utf8_lossy(&info.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[1].trim_start().starts_with("vertices") && lines[2].trim_start().starts_with("faces"), "{text}");
    let out = ok(&["simplify", s(&dir.join("torus.ply")), "-o", s(&dir.join("o.obj")), "--hausdorff"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains('"'), "{text}");
    let long = text
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter(|t| t.contains('.'))
        .map(|t| t.chars().filter(char::is_ascii_digit).collect::<String>().trim_start_matches('0').len())
        .max()
        .unwrap_or(0);
    assert!(long <= 6, "a number with {long} significant digits in: {text}");
    // The Hausdorff report names its units in every distance key.
    let d = ok_json(&["hausdorff", s(&dir.join("torus.ply")), s(&dir.join("o.obj")), "--json"]);
    for key in keys(&d) {
        let distance = ["hausdorff", "mean", "rms"].iter().any(|k| key.starts_with(k)) && key != "hausdorff_tolerance";
        if distance {
            assert!(
                key.ends_with("_paper") || key.ends_with("_absolute") || key.ends_with("_diag_pct"),
                "{key} names no unit"
            );
        }
    }
}

#[test]
fn batch_manifest_rules() {
    let dir = tempdir("batch");
    let input = dir.join("torus.obj");
    ok(&["generate", "torus", "-o", s(&input), "--resolution", "12"]);
    let manifest = dir.join("jobs.jsonl");
    let results = dir.join("results.jsonl");
    let batch = |extra: &[&str]| {
        let mut args = vec!["batch", s(&manifest), "--results", s(&results), "--quiet"];
        args.extend_from_slice(extra);
        let out = meshlod(&args);
        let text = std::fs::read_to_string(&results).unwrap_or_default();
        (out, text.lines().map(|l| serde_json::from_str::<Value>(l).unwrap()).collect::<Vec<_>>())
    };
    // Unknown keys are refused before anything runs (a "ratio" key would otherwise be ignored).
    std::fs::write(
        &manifest,
        "{\"op\": \"simplify\", \"input\": \"torus.obj\", \"output\": \"a.ply\", \"ratio\": 0.9}\n",
    )
    .unwrap();
    let (out, _) = batch(&[]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown field `ratio`"), "{out:?}");
    assert!(!dir.join("a.ply").exists());
    // Paths in args are relative to the manifest, like input and output.
    std::fs::write(
        &manifest,
        "{\"op\": \"simplify\", \"input\": \"torus.obj\", \"output\": \"out/a.ply\", \"args\": [\"--ratio\", \"0.9\", \"--pm\", \"out/a.pm\"]}\n",
    )
    .unwrap();
    let (out, records) = batch(&[]);
    assert!(out.status.success(), "{out:?}");
    assert!(dir.join("out/a.pm").is_file(), "{records:?}");
    assert_eq!(records[0]["report"]["faces_out"], records[0]["report"]["target_faces"]);
    // A job that fails after writing its mesh (the reference is missing) leaves nothing behind,
    // so a rerun runs it again instead of skipping it; the batch fails both times.
    std::fs::write(
        &manifest,
        "{\"op\": \"refine\", \"input\": \"torus.obj\", \"output\": \"fine.obj\", \"args\": [\"--etc\", \"1\", \"--reference\", \"gone.obj\"]}\n",
    )
    .unwrap();
    for _ in 0..2 {
        let (out, records) = batch(&[]);
        assert!(!out.status.success());
        assert_eq!(records[0]["status"], "error", "{records:?}");
        assert!(!dir.join("fine.obj").exists());
    }
    // Shards: each index runs every count-th job, together all of them once.
    let lines: String = (0..5)
        .map(|i| format!("{{\"op\": \"simplify\", \"input\": \"torus.obj\", \"output\": \"s/{i}.ply\"}}\n"))
        .collect();
    std::fs::write(&manifest, lines).unwrap();
    let (_, first) = batch(&["--shard-index", "0", "--shard-count", "2"]);
    let (_, second) = batch(&["--shard-index", "1", "--shard-count", "2"]);
    let lines_of = |r: &[Value]| r.iter().map(|x| x["line"].as_u64().unwrap()).collect::<BTreeSet<_>>();
    assert_eq!(lines_of(&first), BTreeSet::from([1, 3, 5]));
    assert_eq!(lines_of(&second), BTreeSet::from([2, 4]));
    let (out, _) = batch(&["--shard-index", "2", "--shard-count", "2"]);
    assert!(!out.status.success());
    // The manifest format is in --help.
    let help = ok(&["batch", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("Any other key is an error"));
}

#[test]
fn quantize_writes_khr_mesh_quantization_locally_and_through_the_client_and_only_to_gltf() {
    let dir = tempdir("quantize");
    // Refused before any work (the input does not exist) where the output is not glTF.
    let missing = dir.join("missing.obj");
    let ply = dir.join("o.ply");
    fails_with(&["simplify", s(&missing), "-o", s(&ply), "--quantize"], "quantize");
    fails_with(&["refine", s(&missing), "-o", s(&ply), "--etc", "1", "--quantize"], "quantize");
    fails_with(&["convert", s(&missing), s(&ply), "--quantize"], "quantize");
    fails_with(&["lod", s(&missing), "-o", s(&ply), "--faces", "10", "--quantize"], "quantize");

    let input = dir.join("blob.obj");
    ok(&["generate", "blob", "-o", s(&input), "--resolution", "24"]);
    let document = |path: &std::path::Path| {
        let bytes = std::fs::read(path).unwrap();
        let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let json: Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
        (json, bytes.len())
    };
    let required = |path: &std::path::Path| document(path).0["extensionsRequired"].clone();
    let quantization = serde_json::json!(["KHR_mesh_quantization"]);
    let (plain, local, remote, pm) =
        (dir.join("plain.glb"), dir.join("local.glb"), dir.join("remote.glb"), dir.join("blob.pm"));
    ok(&["simplify", s(&input), "-o", s(&plain), "--ratio", "0.8"]);
    ok(&["simplify", s(&input), "-o", s(&local), "--ratio", "0.8", "--quantize", "--pm", s(&pm)]);
    let server = Server::start();
    let remote_args = ["simplify", s(&input), "-o", s(&remote), "--ratio", "0.8", "--quantize"];
    ok(&[&["client", "--server", server.address.as_str()][..], &remote_args[..]].concat());
    assert_eq!(required(&plain), Value::Null);
    assert_eq!(required(&local), quantization);
    assert_eq!(std::fs::read(&local).unwrap(), std::fs::read(&remote).unwrap(), "the client writes what local does");
    assert!(document(&local).1 < document(&plain).1, "smaller");
    // The grid moves a vertex by at most √3/2 of a step of 2/65535 paper units.
    let moved = ok_json(&["hausdorff", s(&plain), s(&local), "--json"]);
    let bound = 3f64.sqrt() / 65535.0;
    assert!(moved["hausdorff_paper"].as_f64().unwrap() <= bound, "{moved}");
    let (converted, level, refined) = (dir.join("c.gltf"), dir.join("l.glb"), dir.join("r.glb"));
    ok(&["convert", s(&input), s(&converted), "--quantize"]);
    ok(&["lod", s(&pm), "--faces", "500", "-o", s(&level), "--quantize"]);
    ok(&["refine", s(&input), "-o", s(&refined), "--etc", "1", "--quantize"]);
    for path in [&level, &refined] {
        assert_eq!(required(path), quantization, "{path:?}");
    }
    let text: Value = serde_json::from_slice(&std::fs::read(&converted).unwrap()).unwrap();
    assert_eq!(text["extensionsRequired"], quantization);
}

#[test]
fn whole_runs_one_sequence_and_the_report_says_when_a_run_went_in_halves() {
    let dir = tempdir("halves");
    let input = dir.join("sphere.ply");
    // 81 920 faces: large enough to go in halves.
    ok(&["generate", "sphere", "-o", s(&input)]);
    let out = dir.join("out.ply");
    let run = |extra: &[&str]| {
        let mut args = vec!["simplify", s(&input), "-o", s(&out), "--ratio", "0.95", "--json"];
        args.extend_from_slice(extra);
        ok_json(&args)
    };
    let (halves, whole) = (run(&[]), run(&["--whole"]));
    assert_eq!(halves["halves"], Value::Bool(true));
    assert_eq!(whole["halves"], Value::Bool(false));
    assert_eq!(halves["faces_out"], whole["faces_out"]);
    let text = ok(&["simplify", s(&input), "-o", s(&out), "--ratio", "0.95"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("in two halves first"));
    // Over gRPC: SimplifyOptions.whole, and SimplifyStats.halves in the report.
    let server = Server::start();
    let client = |extra: &[&str]| {
        let mut args = vec![
            "client",
            "--server",
            server.address.as_str(),
            "simplify",
            s(&input),
            "-o",
            s(&out),
            "--ratio",
            "0.95",
        ];
        args.extend_from_slice(extra);
        args.push("--json");
        ok_json(&args)
    };
    assert_eq!(client(&[])["halves"], Value::Bool(true));
    assert_eq!(client(&["--whole"])["halves"], Value::Bool(false));
    assert_eq!(client(&[])["collapses"], halves["collapses"]);
}

#[test]
fn compare_prints_pixels_and_distance_and_writes_the_pictures() {
    let dir = tempdir("compare");
    let obj = dir.join("torus.obj");
    ok(&["generate", "torus", "-o", s(&obj), "--resolution", "24"]);
    let lod = dir.join("lod.glb");
    ok(&["simplify", s(&obj), "-o", s(&lod), "--keep", "0.3"]);
    let png = dir.join("compare.png");
    let report = ok_json(&["compare", s(&obj), s(&lod), "--views", "3", "--size", "32", "--png", s(&png), "--json"]);
    let expected = ["faces_a", "faces_b", "hausdorff", "hausdorff_diag_pct", "hausdorff_lower", "mae", "notes"];
    let expected: BTreeSet<String> =
        expected.iter().chain(&["psnr", "silhouette", "size", "views"]).map(|k| k.to_string()).collect();
    assert_eq!(keys(&report), expected);
    assert!(report["mae"].as_f64().unwrap() > 0.0 && report["hausdorff"].as_f64().unwrap() > 0.0, "{report}");
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let (width, height) =
        (u32::from_be_bytes(bytes[16..20].try_into().unwrap()), u32::from_be_bytes(bytes[20..24].try_into().unwrap()));
    assert_eq!((width, height), (3 * 32, 3 * 32), "three tiles per view, a row per view");
    let text = String::from_utf8(ok(&["compare", s(&obj), s(&obj), "--no-hausdorff"]).stdout).unwrap();
    assert!(text.starts_with("pixels: mean difference 0 levels") && !text.contains("Hausdorff"), "{text}");
    fails_with(&["compare", s(&obj), s(&lod), "--views", "0"], "views");
}
