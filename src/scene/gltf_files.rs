//! The files a glTF names (external buffers and images), and the policy that decides which may be
//! read.
//!
//! A glTF URI is either a `data:` URI (base64 payload, read from the JSON itself) or a reference
//! relative to the scene file (glTF 2.0 §3.3.1). A scene is input from whoever wrote it, so a URI
//! must not make the program read other files of the machine (a rendered image can carry a
//! file's bytes as geometry or texels). The rule: after percent-decoding and canonicalisation
//! (symbolic links followed, `.` and `..` removed), the file must lie inside the scene's folder,
//! or inside one of the folders the user admitted explicitly (`--allow-external-files DIR`).
//! Refused with the rule in the message: any scheme but `data:` (`file:`, `http:`, a drive
//! letter), absolute paths, `..` that climbs out (also percent-encoded as `%2e%2e`), and symbolic
//! links that point out. A symbolic-link loop or a missing file fails canonicalisation and is
//! reported as unreadable. Only regular files are read (a FIFO or a device would block or never
//! end), and never more than their declared length.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use base64::Engine;

/// Where a scene's external files may come from: its own folder, and the folders admitted with
/// `--allow-external-files` (canonical paths).
#[derive(Clone, Copy, Debug)]
pub struct FileAccess<'a> {
    /// The folder relative URIs resolve against (the scene file's folder).
    pub scene_folder: &'a Path,
    /// Further folders whose files may be read, canonicalised by the caller.
    pub allowed: &'a [PathBuf],
}

/// Image files (which declare no length) larger than this are refused before reading.
const MAX_IMAGE_FILE_BYTES: u64 = 1 << 30;

/// The bytes of a URI: a base64 data URI, or a regular file the policy admits — for a buffer the
/// first `length` bytes (its byteLength), refused before reading when the file is shorter; for
/// an image (None) the whole file, refused before reading beyond MAX_IMAGE_FILE_BYTES.
pub fn read_uri(uri: &str, length: Option<usize>, access: FileAccess) -> Result<Vec<u8>, String> {
    if let Some(scheme) = uri_scheme(uri) {
        if !scheme.eq_ignore_ascii_case("data") {
            return Err(format!(
                "refused: '{uri}' has the URI scheme '{scheme}:'; a scene may name only data: \
                 URIs and files inside its own folder"
            ));
        }
        let rest = &uri[scheme.len() + 1..];
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or_else(|| "data URI is not base64-encoded".to_string())?;
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| format!("data URI is not valid base64: {e}"));
    }
    let file = admitted_file(uri, access)?;
    let cannot =
        |e: &dyn std::fmt::Display| format!("cannot read '{uri}' ({}): {e}", file.display());
    // Only regular files: a device such as /dev/zero or a FIFO would never end or never answer.
    // Checked before opening: opening a FIFO for reading blocks until a writer appears.
    let meta = std::fs::metadata(&file).map_err(|e| cannot(&e))?;
    if !meta.is_file() {
        return Err(cannot(&"not a regular file"));
    }
    let mut reader = std::fs::File::open(&file).map_err(|e| cannot(&e))?;
    let Some(length) = length else {
        if meta.len() > MAX_IMAGE_FILE_BYTES {
            return Err(cannot(&format_args!(
                "{} bytes, more than the {MAX_IMAGE_FILE_BYTES} an image may have",
                meta.len()
            )));
        }
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).map_err(|e| cannot(&e))?;
        return Ok(bytes);
    };
    if meta.len() < length as u64 {
        return Err(format!(
            "declares {length} bytes but '{uri}' ({}) has only {}",
            file.display(),
            meta.len()
        ));
    }
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(length).map_err(|e| cannot(&e))?;
    (&mut reader)
        .take(length as u64)
        .read_to_end(&mut bytes)
        .map_err(|e| cannot(&e))?;
    Ok(bytes)
}

/// The canonical path of the file a relative URI names, when the policy admits it; otherwise an
/// error stating the rule it breaks.
fn admitted_file(uri: &str, access: FileAccess) -> Result<PathBuf, String> {
    let decoded = PathBuf::from(percent_decode(uri));
    let joined = access.scene_folder.join(&decoded);
    let canonical = joined.canonicalize().map_err(|e| {
        format!(
            "cannot read '{uri}' ({}): cannot resolve the path: {e}",
            joined.display()
        )
    })?;
    let folder = access.scene_folder.canonicalize().map_err(|e| {
        format!(
            "cannot resolve the scene's folder {}: {e}",
            access.scene_folder.display()
        )
    })?;
    let inside = |dir: &Path| canonical.starts_with(dir);
    if inside(&folder) || access.allowed.iter().any(|d| inside(d)) {
        return Ok(canonical);
    }
    let how = if decoded.is_absolute() {
        "is an absolute path".to_string()
    } else if decoded.components().any(|c| c == Component::ParentDir) {
        format!(
            "climbs out of the scene's folder to {}",
            canonical.display()
        )
    } else {
        format!(
            "leads through a symbolic link to {}, outside the scene's folder",
            canonical.display()
        )
    };
    Err(format!(
        "refused: '{uri}' {how}; external files must lie inside the scene's folder {} \
         (--allow-external-files DIR admits another folder)",
        folder.display()
    ))
}

/// The scheme of an absolute URI (RFC 3986 §3.1: a letter, then letters, digits, '+', '-' or
/// '.', then ':' before any '/', '?' or '#'), None for a relative reference.
fn uri_scheme(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once(':')?;
    let mut chars = scheme.chars();
    let first = chars.next()?;
    let valid = first.is_ascii_alphabetic()
        && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
    valid.then_some(scheme)
}

/// Decodes %XX escapes in a relative URI (spaces are commonly written as %20).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_are_decoded() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("x%2"), "x%2");
        assert_eq!(percent_decode("%2e%2E/x"), "../x");
    }

    #[test]
    fn schemes_are_told_from_relative_references() {
        assert_eq!(
            uri_scheme("data:application/octet-stream;base64,"),
            Some("data")
        );
        assert_eq!(uri_scheme("file:///etc/passwd"), Some("file"));
        assert_eq!(uri_scheme("C:/x.bin"), Some("C"));
        assert_eq!(uri_scheme("svn+ssh://h/x"), Some("svn+ssh"));
        assert_eq!(uri_scheme("a b:x"), None);
        assert_eq!(uri_scheme("./a:b.bin"), None);
        assert_eq!(uri_scheme("mesh.bin"), None);
        assert_eq!(uri_scheme(":x"), None);
    }
}
