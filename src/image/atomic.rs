//! Atomic file replacement: write a temporary file in the target's folder, fsync, rename.

use std::fs::{self, File, OpenOptions};
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{bail, Context};

/// Distinguishes temporary files of concurrent writes within one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file
/// `.{file_name}.tmp-{pid}-{counter}` in the same folder, which is then
/// flushed, fsynced and renamed over `path`.
///
/// On any error (or a panic in `write`) the temporary file is removed and
/// `path` is untouched. The folder must exist. If `path` is a symbolic link,
/// the link itself is replaced by the new file.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let file_name = path
        .file_name()
        .with_context(|| format!("{} does not name a file", path.display()))?;
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    check_folder(folder)?;
    let temp_path = folder.join(format!(
        ".{}.tmp-{}-{}",
        file_name.to_string_lossy(),
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp_path)
        .with_context(|| format!("cannot create {}", temp_path.display()))?;
    let mut temp = TempFile {
        path: temp_path,
        keep: false,
    };
    let temp_path = temp.path.clone();

    let mut writer = BufWriter::new(file);
    write(&mut writer).with_context(|| format!("cannot write {}", path.display()))?;
    let file = writer
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(|| format!("cannot write {}", temp_path.display()))?;
    file.sync_all()
        .with_context(|| format!("cannot sync {}", temp_path.display()))?;
    drop(file);
    fs::rename(&temp_path, path).with_context(|| {
        format!(
            "cannot rename {} to {}",
            temp_path.display(),
            path.display()
        )
    })?;
    temp.keep = true;
    sync_folder(folder);
    Ok(())
}

/// Fails with a clear message unless `folder` is an existing directory.
fn check_folder(folder: &Path) -> anyhow::Result<()> {
    match fs::metadata(folder) {
        Ok(meta) if meta.is_dir() => Ok(()),
        Ok(_) => bail!("{} is not a folder", folder.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("folder {} does not exist", folder.display())
        }
        Err(e) => Err(e).with_context(|| format!("cannot access folder {}", folder.display())),
    }
}

/// Makes the rename durable by fsyncing the folder (Unix). Best effort: the
/// new file is already complete and in place, and some file systems refuse to
/// sync a directory, so a failure here is not reported.
fn sync_folder(folder: &Path) {
    #[cfg(unix)]
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
    #[cfg(not(unix))]
    let _ = folder;
}

/// A temporary file that is removed when dropped, unless `keep` was set
/// because it has been renamed to its target.
struct TempFile {
    path: PathBuf,
    keep: bool,
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.keep {
            // Nothing better to do if removal fails while handling an error.
            let _ = fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::test_util::*;
    use crate::image::{write_exr, write_png_preview};
    use std::io::Write;

    #[test]
    fn missing_folder_is_an_error_naming_it_and_creates_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("nope");
        let path = folder.join("out.exr");
        let image = noisy_image(4, 4, 8);
        let error = format!("{:#}", write_exr(&path, &image, None).unwrap_err());
        assert!(error.contains("does not exist"), "{error}");
        assert!(error.contains(&folder.display().to_string()), "{error}");
        let error = format!("{:#}", write_png_preview(&path, &image, 0.0).unwrap_err());
        assert!(error.contains(&folder.display().to_string()), "{error}");
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn failing_writer_keeps_old_target_and_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("result.txt");
        fs::write(&path, b"old").unwrap();
        let error = write_atomically(&path, |out| {
            out.write_all(&[b'x'; 100_000])?;
            bail!("simulated failure")
        })
        .unwrap_err();
        let message = format!("{error:#}");
        assert!(message.contains("simulated failure"), "{message}");
        assert!(message.contains("result.txt"), "{message}");
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(dir.path()), ["result.txt"]);

        let fresh = dir.path().join("fresh.txt");
        assert!(write_atomically(&fresh, |_| bail!("no")).is_err());
        assert_eq!(entries(dir.path()), ["result.txt"]);
    }

    #[test]
    fn panicking_writer_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("result.txt");
        let outcome = std::panic::catch_unwind(|| write_atomically(&path, |_| panic!("boom")));
        assert!(outcome.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn successful_write_replaces_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("result.txt");
        fs::write(&path, b"old").unwrap();
        write_atomically(&path, |out| Ok(out.write_all(b"new")?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(entries(dir.path()), ["result.txt"]);
    }

    #[test]
    fn path_without_file_name_is_an_error() {
        let error = write_atomically(Path::new("/"), |_| Ok(())).unwrap_err();
        assert!(format!("{error:#}").contains("does not name a file"));
    }
}
