//! Structured errors for everything the engine refuses.
//!
//! Each variant names the element at fault (vertex, face, line, byte offset) so that a user — or the
//! gRPC layer that maps these onto field-level `INVALID_ARGUMENT` messages — can act on it.

use std::path::PathBuf;

/// Why a mesh was refused or an operation could not run.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum MeshError {
    /// The mesh has no vertices or no faces where some are required.
    #[error("mesh is empty: {what}")]
    Empty {
        /// What is missing ("no faces", "no vertices").
        what: &'static str,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({value})")]
    NonFiniteCoordinate {
        /// Index of the offending vertex.
        vertex: usize,
        /// The offending value, as text.
        value: String,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but the mesh has only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Index of the offending face.
        face: usize,
        /// The out-of-range vertex index.
        index: i64,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// The mesh exceeds a configured size limit.
    #[error("{}mesh too large: {count} {what} exceeds the limit of {limit}", in_file(file))]
    TooLarge {
        /// The file that holds (or claims) it, when it was read from one.
        file: Option<PathBuf>,
        /// "vertices" or "faces".
        what: &'static str,
        /// The count found or claimed.
        count: u64,
        /// The configured limit.
        limit: u64,
    },
    /// A parameter is outside its documented range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name as the user spells it.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A file could not be parsed.
    #[error("{}: {location}: {reason}", path.display())]
    Parse {
        /// File being read (or `<memory>`).
        path: PathBuf,
        /// Where in the file: "line 12", "byte 4096", "header", "vertex 17".
        location: String,
        /// What is wrong there.
        reason: String,
    },
    /// The file's format is unknown or unsupported.
    #[error("{}: unsupported format: {reason}", path.display())]
    UnsupportedFormat {
        /// File being read or written.
        path: PathBuf,
        /// Why it is not supported.
        reason: String,
    },
    /// An I/O error while reading or writing a file.
    #[error("{}: {message}", path.display())]
    Io {
        /// File being read or written.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// The operation was cancelled by its caller.
    #[error("operation cancelled")]
    Cancelled,
}

/// "PATH: " for an error about a file, nothing otherwise.
fn in_file(file: &Option<PathBuf>) -> String {
    file.as_ref().map(|path| format!("{}: ", path.display())).unwrap_or_default()
}

impl MeshError {
    /// Builds a [`MeshError::Parse`] error.
    pub(crate) fn parse(path: &std::path::Path, location: impl Into<String>, reason: impl Into<String>) -> Self {
        MeshError::Parse { path: path.to_path_buf(), location: location.into(), reason: reason.into() }
    }
}
