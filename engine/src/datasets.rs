//! Where the shared real meshes live, for tests, benchmarks and sample generation.
//!
//! The meshes are never copied into the repository: they are read from `$MESHLOD_MESHES`, or from
//! `../shared/meshes` next to the workspace.

use std::path::PathBuf;

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
    match shared_meshes_dir() {
        Some(dir) => Some(dir),
        None if std::env::var_os("CI").is_some() => {
            panic!("{test}: shared meshes not found (set {MESHES_ENV}); CI must run with them")
        }
        None => {
            eprintln!(
                "\n!!! {test}: SKIPPED — shared meshes not found (set {MESHES_ENV} or provide ../shared/meshes) !!!\n"
            );
            None
        }
    }
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
