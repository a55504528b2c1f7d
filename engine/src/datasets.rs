//! Where the shared real meshes live, for tests, benchmarks and sample generation.
//!
//! The meshes are never copied into the repository: they are read from `$MESHLOD_MESHES`, or from
//! `../shared/meshes` next to the workspace.

use std::path::{Path, PathBuf};

/// Environment variable naming the shared meshes directory.
pub const MESHES_ENV: &str = "MESHLOD_MESHES";

/// The shared meshes directory, if it exists: `$MESHLOD_MESHES`, else `../shared/meshes` relative
/// to the current directory or to the workspace root.
pub fn shared_meshes_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os(MESHES_ENV) {
        let dir = PathBuf::from(dir);
        return dir.is_dir().then_some(dir);
    }
    let workspace = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    [PathBuf::from("../shared/meshes"), workspace.join("../shared/meshes")].into_iter().find(|d| d.is_dir())
}

/// For tests that need the shared meshes: the directory, or — when they are missing — a loud
/// message on stderr and `None`; under CI (`CI` set) a missing directory is a panic, so a test can
/// never pass by silently skipping.
pub fn require_shared_meshes(test: &str) -> Option<PathBuf> {
    require(test, shared_meshes_dir(), "meshes", MESHES_ENV)
}

/// The directory `found`, or — when it is missing — a loud message on stderr and `None`; a panic
/// under CI (`CI` set).
fn require(test: &str, found: Option<PathBuf>, what: &str, env: &str) -> Option<PathBuf> {
    match found {
        Some(dir) => Some(dir),
        None if std::env::var_os("CI").is_some() => {
            panic!("{test}: shared {what} not found (set {env}); CI must run with them")
        }
        None => {
            note_skipped(test, &format!("shared {what} not found (set {env} or provide ../shared)"));
            None
        }
    }
}

/// Environment variable naming a file to which every skipped test adds a line, so that the test
/// command can count and list them at its end (cargo swallows a passing test's stderr).
pub const SKIP_LOG_ENV: &str = "MESHLOD_SKIP_LOG";

/// Says loudly that `test` was skipped and why: on stderr, and as a line `test: why` in the file
/// `$MESHLOD_SKIP_LOG` names, when set.
pub fn note_skipped(test: &str, why: &str) {
    eprintln!("\n!!! {test}: SKIPPED — {why} !!!\n");
    if let Some(log) = std::env::var_os(SKIP_LOG_ENV) {
        use std::io::Write;
        let appended = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .and_then(|mut f| writeln!(f, "{test}: {why}"));
        if let Err(e) = appended {
            eprintln!("!!! {test}: the skip could not be noted in {}: {e} !!!", PathBuf::from(log).display());
        }
    }
}

/// Environment variable naming the shared textured assets directory.
pub const TEXTURED_ENV: &str = "MESHLOD_TEXTURED";

/// The shared textured assets (glTF, OBJ + MTL with images; `MANIFEST.tsv` inside), if present:
/// `$MESHLOD_TEXTURED`, else `textured/` beside the shared meshes, else `../shared/textured`.
pub fn shared_textured_dir() -> Option<PathBuf> {
    shared_manifest_dir(TEXTURED_ENV, "textured")
}

/// A shared folder with a `MANIFEST.tsv`: `$env`, else `name/` beside the shared meshes, else
/// `../shared/name` relative to the current directory or to the workspace root.
fn shared_manifest_dir(env: &str, name: &str) -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os(env) {
        let dir = PathBuf::from(dir);
        return dir.is_dir().then_some(dir);
    }
    let beside = shared_meshes_dir().and_then(|m| m.parent().map(|p| p.join(name)));
    let workspace = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    beside
        .into_iter()
        .chain([PathBuf::from("../shared").join(name), workspace.join("../shared").join(name)])
        .find(|d| d.join("MANIFEST.tsv").is_file())
}

/// [`require_shared_meshes`] for the textured assets: the directory, or a loud message (a panic
/// under CI) when they are missing.
pub fn require_shared_textured(test: &str) -> Option<PathBuf> {
    require(test, shared_textured_dir(), "textured assets", TEXTURED_ENV)
}

/// Environment variable naming the shared glTF assets directory.
pub const GLTF_ENV: &str = "MESHLOD_GLTF";

/// The shared glTF assets (extensions, two texture coordinate sets, compressed and flat-shaded
/// files; `MANIFEST.tsv` inside), if present: `$MESHLOD_GLTF`, else `gltf/` beside the shared
/// meshes, else `../shared/gltf`.
pub fn shared_gltf_dir() -> Option<PathBuf> {
    shared_manifest_dir(GLTF_ENV, "gltf")
}

/// [`require_shared_meshes`] for the glTF assets.
pub fn require_shared_gltf(test: &str) -> Option<PathBuf> {
    require(test, shared_gltf_dir(), "glTF assets", GLTF_ENV)
}

/// Environment variable naming the shared corpus directory (binary PLY, `MANIFEST.tsv` inside).
pub const CORPUS_ENV: &str = "MESHLOD_CORPUS";

/// The shared corpus, if present: `$MESHLOD_CORPUS`, else `corpus/` beside the shared meshes, else
/// `../shared/corpus`.
pub fn shared_corpus_dir() -> Option<PathBuf> {
    shared_manifest_dir(CORPUS_ENV, "corpus")
}

/// [`require_shared_meshes`] for the corpus: the directory, or a loud message (a panic under CI)
/// when it is missing.
pub fn require_shared_corpus(test: &str) -> Option<PathBuf> {
    require(test, shared_corpus_dir(), "corpus", CORPUS_ENV)
}

/// The corpus meshes of at most `max_faces` faces (the count its `MANIFEST.tsv` gives), as (file
/// name, path), in the manifest's order; empty when the manifest cannot be read.
pub fn corpus_meshes(dir: &Path, max_faces: usize) -> Vec<(String, PathBuf)> {
    let manifest = std::fs::read_to_string(dir.join("MANIFEST.tsv")).unwrap_or_default();
    manifest
        .lines()
        .skip(1)
        .filter_map(|line| {
            let fields: Vec<&str> = line.split('\t').collect();
            let faces: usize = fields.get(4)?.parse().ok()?;
            (faces <= max_faces).then(|| (fields[0].to_string(), dir.join(fields[0])))
        })
        .collect()
}

/// Path of one shared mesh file (`name` without extension), if the directory and the file exist.
pub fn shared_mesh(name: &str) -> Option<PathBuf> {
    shared_meshes_dir().map(|d| d.join(format!("{name}.obj"))).filter(|p| p.is_file())
}

/// Names (without extension) of the shared meshes, sorted.
pub const SHARED_MESHES: [&str; 11] = [
    "beetle",
    "cow",
    "fandisk",
    "homer",
    "nefertiti",
    "ogre",
    "rocker-arm",
    "spot",
    "stanford-bunny",
    "suzanne",
    "teapot",
];
