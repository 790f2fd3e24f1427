//! Output paths checked before any work is done, so a run that could never write its result
//! fails in milliseconds instead of after a long render.

use std::fs::OpenOptions;
use std::path::Path;

use anyhow::{bail, Context};

/// Checks that `path` can receive an output file with this extension: the name ends in
/// `.extension`, the path is not an existing folder, and its folder exists, is a folder and
/// accepts a new file (probed by creating and removing an empty hidden file).
pub fn check_output_path(path: &Path, extension: &str) -> anyhow::Result<()> {
    let has_extension = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(extension));
    if !has_extension {
        bail!(
            "output {}: expected a .{extension} file name",
            path.display()
        );
    }
    if path.is_dir() {
        bail!("output {}: is a folder, not a file", path.display());
    }
    let folder = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    check_output_folder(folder).with_context(|| format!("output {}", path.display()))
}

/// Checks that `folder` exists, is a folder and accepts a new file.
pub fn check_output_folder(folder: &Path) -> anyhow::Result<()> {
    match std::fs::metadata(folder) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => bail!("{} is not a folder", folder.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("folder {} does not exist", folder.display())
        }
        Err(e) => {
            return Err(e).with_context(|| format!("cannot access folder {}", folder.display()))
        }
    }
    let probe = folder.join(format!(".manylights-probe-{}", std::process::id()));
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| format!("folder {} does not accept new files", folder.display()))?;
    std::fs::remove_file(&probe)
        .with_context(|| format!("cannot remove the probe file {}", probe.display()))
}
