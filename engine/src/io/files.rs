//! Files a mesh file refers to or is written beside: reading them safely, naming them relative to
//! each other, and telling an image's type from its bytes.

use std::path::{Component, Path, PathBuf};

use crate::error::MeshError;

/// An I/O error on `path`, as the readers and writers report it.
pub(crate) fn io_error(path: &Path, err: std::io::Error) -> MeshError {
    MeshError::Io { path: path.to_path_buf(), message: err.to_string() }
}

/// Reads a file that a mesh file refers to (a glTF buffer, a texture image): only a regular file,
/// so that a reference to a device or a pipe (`/dev/zero`) is refused rather than read forever.
pub(crate) fn read_referenced(path: &Path) -> std::io::Result<Vec<u8>> {
    if !std::fs::metadata(path)?.is_file() {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"));
    }
    std::fs::read(path)
}

/// The folder of file `path` (`.` for a bare file name): where the files it refers to are found
/// or written.
pub(crate) fn folder_of(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// The media type of image bytes, from their magic numbers.
pub(crate) fn sniff_image(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB\r\n\x1a\n") {
        Some("image/ktx2")
    } else {
        None
    }
}

/// `path` as a URI relative to `folder` (both made absolute first), spaces and the like escaped.
pub(crate) fn relative_uri(path: &Path, folder: Option<&Path>) -> Option<String> {
    let joined = relative_path(path, folder?)?;
    let mut uri = String::new();
    for ch in joined.chars() {
        match ch {
            'A'..='Z' | 'a'..='z' | '0'..='9' | '-' | '_' | '.' | '~' | '/' => uri.push(ch),
            other => {
                let mut utf8 = [0u8; 4];
                for byte in other.encode_utf8(&mut utf8).bytes() {
                    uri.push_str(&format!("%{byte:02X}"));
                }
            }
        }
    }
    Some(uri)
}

/// `path` relative to `folder` (both made absolute first, `.` and `..` resolved by hand: the file
/// may not exist), its parts joined by `/`.
pub(crate) fn relative_path(path: &Path, folder: &Path) -> Option<String> {
    let absolute = |p: &Path| -> Option<PathBuf> {
        let p = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir().ok()?.join(p) };
        let mut out = PathBuf::new();
        for c in p.components() {
            match c {
                Component::ParentDir => {
                    out.pop();
                }
                Component::CurDir => {}
                other => out.push(other),
            }
        }
        Some(out)
    };
    let (target, base) = (absolute(path)?, absolute(folder)?);
    let (t, b): (Vec<_>, Vec<_>) = (target.components().collect(), base.components().collect());
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".into(); b.len() - common];
    parts.extend(t[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    Some(parts.join("/"))
}
