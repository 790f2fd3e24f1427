//! Hostile input to every subcommand (render, info, gen, diff, reference, bench, converge):
//! malformed and truncated scenes, files that claim gigabytes, unwritable outputs, bad reference
//! EXRs and malformed option values. Each must give the documented exit code (1 run-time
//! failure, 2 usage, 3 bad input), a message naming the file and the element or option, no
//! panic, and no output or temporary file (the output folder's listing is compared before and
//! after every run).

use crate::run;

pub(crate) use manylights::cli::{EXIT_BAD_INPUT, EXIT_FAILURE, EXIT_USAGE};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use manylights::image::{write_exr, RgbImage};
use serde_json::{json, Value};

use crate::common;
use common::{write_gltf, U32};

mod budget;
mod options;
mod outputs;
mod references;
mod scenes;

/// Sparse files stand for huge inputs: 1 TiB (no machine allocates it, so reading one whole
/// aborts instead of merely being slow), or 8 GiB where the file system refuses 1 TiB.
pub(crate) fn make_sparse(path: &Path, data: &[u8]) {
    fs::write(path, data).unwrap();
    let file = fs::OpenOptions::new().write(true).open(path).unwrap();
    file.set_len(1 << 40)
        .or_else(|_| file.set_len(8 << 30))
        .unwrap();
}

pub(crate) struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    what: String,
}

pub(crate) fn manylights<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Run {
    let o = run::manylights(args);
    Run {
        code: o.status.code(),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        what: args
            .iter()
            .map(|a| a.as_ref().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" "),
    }
}

/// Names of everything under `dir` (recursively), sorted.
pub(crate) fn listing(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for entry in fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let path = entry.path();
        out.push(path.display().to_string());
        if entry.file_type().unwrap().is_dir() {
            out.extend(listing(&path));
        }
    }
    out.sort();
    out
}

/// Runs `args` and asserts a refusal: `code`, every `mentions` in stderr, no panic, and the
/// listing of `watched` unchanged by the run.
pub(crate) fn assert_refused<S: AsRef<std::ffi::OsStr>>(
    args: &[S],
    code: i32,
    mentions: &[&str],
    watched: &Path,
) {
    let before = listing(watched);
    let run = manylights(args);
    let context = format!("`manylights {}`\nstderr: {}", run.what, run.stderr);
    assert_eq!(run.code, Some(code), "{context}");
    for m in mentions {
        assert!(run.stderr.contains(m), "should mention {m:?}: {context}");
    }
    assert!(!run.stderr.contains("panicked"), "{context}");
    assert!(run.stderr.starts_with("error"), "{context}");
    assert_eq!(listing(watched), before, "files written or left: {context}");
}

pub(crate) fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

pub(crate) fn cornell_bytes() -> Vec<u8> {
    fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb")).unwrap()
}

/// The command lines of every subcommand that reads a scene, writing into `out`.
pub(crate) fn scene_commands(scene: &Path, out: &Path) -> Vec<Vec<String>> {
    let (scene, o) = (s(scene), |f: &str| s(&out.join(f)));
    let small = ["--width", "8", "--spp"].map(String::from);
    let cmd = |head: &[&str], tail: &[String]| -> Vec<String> {
        head.iter()
            .map(|a| a.to_string())
            .chain(tail.iter().cloned())
            .collect()
    };
    vec![
        cmd(
            &["render", &scene, "-o", &o("r.exr"), "--png", &o("r.png")],
            &[&small[..], &["1".into(), "--json".into(), o("r.json")]].concat(),
        ),
        cmd(&["info", &scene], &[]),
        cmd(
            &["reference", &scene, "-o", &o("ref.exr")],
            &[&small[..], &["1".into()]].concat(),
        ),
        cmd(
            &["bench", &scene, "--repeat", "1", "--reference-spp", "1"],
            &[&small[..], &["1".into(), "--json".into(), o("b.json")]].concat(),
        ),
        cmd(
            &["converge", &scene, "--seeds", "1", "--reference-spp", "1"],
            &[&small[..], &["1,2".into(), "--json".into(), o("c.json")]].concat(),
        ),
    ]
}

/// A one-triangle glTF with an external buffer `name`.bin (positions, then u32 indices), its
/// JSON changed by `edit`. Returns the .gltf path.
pub(crate) fn edited_gltf(dir: &Path, name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let triangle = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let path = PathBuf::from(write_gltf(
        dir,
        name,
        &triangle,
        Some((&[0, 1, 2], U32)),
        true,
    ));
    let mut doc: Value = serde_json::from_slice(&fs::read(&path).unwrap()).unwrap();
    edit(&mut doc);
    fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// cornell.glb with the little-endian u32 at `at` replaced by `value`.
pub(crate) fn patched_glb(dir: &Path, name: &str, at: usize, value: u32) -> PathBuf {
    let mut bytes = cornell_bytes();
    bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
    let path = dir.join(name);
    fs::write(&path, bytes).unwrap();
    path
}

/// Renders an 8-pixel-wide (square) Cornell image with its variance layer.
pub(crate) fn render_small(dir: &Path, name: &str, width: &str) -> PathBuf {
    let out = dir.join(name);
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let run = manylights(&[
        "render",
        &s(&cornell),
        "-o",
        &s(&out),
        "--width",
        width,
        "--spp",
        "1",
        "--variance",
    ]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    out
}
