//! Helpers shared by the reader and attribute tests.

use std::path::Path;

use meshlod_engine::io::{MeshFormat, ReadLimits, read_mesh_bytes};
use meshlod_engine::{Mesh, MeshError};

pub fn obj(text: &str) -> Result<Mesh, MeshError> {
    read_mesh_bytes(text.as_bytes(), Some(MeshFormat::Obj), Path::new("test.obj"), &ReadLimits::default())
}

pub fn ply(bytes: &[u8]) -> Result<Mesh, MeshError> {
    read_mesh_bytes(bytes, Some(MeshFormat::Ply), Path::new("test.ply"), &ReadLimits::default())
}

/// Asserts a parse error at `location` whose reason contains `needle`.
pub fn assert_parse_error(result: Result<Mesh, MeshError>, location: &str, needle: &str) {
    match result {
        Err(MeshError::Parse { location: loc, reason, path }) => {
            assert_eq!(loc, location, "reason was: {reason}");
            assert!(reason.contains(needle), "reason '{reason}' lacks '{needle}'");
            assert!(path.to_string_lossy().starts_with("test."), "error must name the file");
        }
        other => panic!("expected parse error at {location}, got {other:?}"),
    }
}

pub fn tempdir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("meshlod-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
