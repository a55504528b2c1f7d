//! The deploy files work: the Dockerfile's build stage has every file `cargo` needs, the compose
//! health check passes under dash (the image's /bin/sh) against a live server and fails without
//! one, and the Dockerfile passes hadolint where it is installed.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::Server;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A tool the test needs: its path, or — when missing — a loud note, and under CI a failure.
fn require_tool(name: &str) -> Option<PathBuf> {
    let found = std::env::var_os("PATH")
        .map(|paths| std::env::split_paths(&paths).map(|d| d.join(name)).find(|p| p.is_file()))
        .unwrap_or_default();
    if found.is_none() {
        assert!(std::env::var_os("CI").is_none(), "{name} is not installed: CI must run this check");
        meshlod_engine::datasets::note_skipped("deploy", &format!("{name} is not installed"));
    }
    found
}

fn copy_tree(from: &Path, to: &Path) {
    if from.is_dir() {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap() {
            let entry = entry.unwrap();
            copy_tree(&entry.path(), &to.join(entry.file_name()));
        }
    } else {
        std::fs::copy(from, to).unwrap_or_else(|e| panic!("copying {}: {e}", from.display()));
    }
}

/// The `COPY` sources of the build stage (before the runtime stage's `FROM`), with their targets.
fn build_stage_copies(dockerfile: &str) -> Vec<(String, String)> {
    let mut copies = Vec::new();
    for line in dockerfile.lines().skip_while(|l| !l.starts_with("FROM")).skip(1) {
        if line.starts_with("FROM") {
            break;
        }
        if let Some(args) = line.strip_prefix("COPY ") {
            let parts: Vec<&str> = args.split_whitespace().filter(|p| !p.starts_with("--")).collect();
            let (target, sources) = parts.split_last().expect("COPY has a target");
            copies.extend(sources.iter().map(|s| (s.to_string(), target.to_string())));
        }
    }
    copies
}

#[test]
fn the_docker_build_stage_has_the_whole_workspace() {
    let dockerfile = std::fs::read_to_string(repo().join("deploy/Dockerfile")).unwrap();
    let copies = build_stage_copies(&dockerfile);
    assert!(copies.len() >= 5, "{copies:?}");
    let context = std::env::temp_dir().join(format!("meshlod-docker-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&context);
    std::fs::create_dir_all(&context).unwrap();
    for (source, target) in &copies {
        let to = if target.ends_with('/') || target == "./" {
            context.join(target).join(Path::new(source).file_name().unwrap())
        } else {
            context.join(target)
        };
        copy_tree(&repo().join(source), &to);
    }
    // What `cargo build --locked` reads first: every member's manifest and the lock file.
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--locked", "--format-version", "1"])
        .current_dir(&context)
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "cargo metadata in the build stage's files: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let metadata: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let members = metadata["workspace_members"].as_array().unwrap().len();
    assert_eq!(members, 3, "engine, predictor and service");
    // The shipped model file is among what was copied (the predictor embeds it).
    assert!(context.join("predictor/model/predictor.onnx").is_file());
    let _ = std::fs::remove_dir_all(&context);
}

#[test]
fn the_compose_health_check_runs_under_dash() {
    let Some(dash) = require_tool("dash") else { return };
    let compose = std::fs::read_to_string(repo().join("deploy/compose.yaml")).unwrap();
    let line = compose.lines().find(|l| l.trim_start().starts_with("test:")).expect("a health check");
    let command = line
        .split_once("\"CMD-SHELL\", \"")
        .map(|(_, rest)| rest.trim_end().trim_end_matches("\"]").to_string())
        .expect("a CMD-SHELL health check");
    let bin_dir = PathBuf::from(env!("CARGO_BIN_EXE_meshlod")).parent().unwrap().to_path_buf();
    let path =
        std::env::join_paths(std::iter::once(bin_dir).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap())))
            .unwrap();
    let server = Server::start();
    let check = |server: &str| {
        Command::new(&dash).args(["-c", &command]).env("PATH", &path).env("MESHLOD_SERVER", server).output().unwrap()
    };
    let healthy = check(&server.address);
    assert!(healthy.status.success(), "`{command}` under dash: {}", String::from_utf8_lossy(&healthy.stderr));
    let address = server.address.clone();
    drop(server);
    assert!(!check(&address).status.success(), "`{command}` passes without a server");
}

#[test]
fn the_dockerfile_passes_hadolint_where_installed() {
    let Some(hadolint) = std::env::var_os("PATH")
        .and_then(|paths| std::env::split_paths(&paths).map(|d| d.join("hadolint")).find(|p| p.is_file()))
    else {
        // Optional by design: the schema checks of the manifests run in scripts/test.sh.
        eprintln!("\n!!! hadolint is not installed: the Dockerfile lint did not run !!!\n");
        return;
    };
    let out = Command::new(hadolint).arg(repo().join("deploy/Dockerfile")).output().unwrap();
    assert!(out.status.success(), "hadolint: {}", String::from_utf8_lossy(&out.stdout));
}
