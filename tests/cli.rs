//! Whole-program behaviour of the `manylights` binary: bad input gives a clear message naming
//! the file and element, a documented non-zero exit code and no output file; the image does not
//! depend on the thread count.

use crate::run;
use manylights::cli::{EXIT_BAD_INPUT, EXIT_FAILURE};
use run::manylights;

use std::path::{Path, PathBuf};

use crate::common;
use common::{write_gltf, U32};

fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(path)
        .to_string_lossy()
        .into_owned()
}

/// Renders `scene` into `dir`/out.exr and returns (exit code, stderr, output path).
fn render_into(dir: &Path, scene: &str, extra: &[&str]) -> (i32, String, PathBuf) {
    let out = dir.join("out.exr");
    let mut args = vec![
        "render",
        scene,
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--spp",
        "2",
    ];
    args.extend_from_slice(extra);
    let o = manylights(&args);
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        out,
    )
}

const TRIANGLE: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

fn assert_refused(code: i32, stderr: &str, out: &Path, expected_code: i32, must_mention: &[&str]) {
    assert_eq!(code, expected_code, "stderr: {stderr}");
    for m in must_mention {
        assert!(stderr.contains(m), "message should mention {m:?}: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists(), "no output file may be written");
    let leftovers: Vec<_> = std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("out."))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn missing_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.glb");
    let (code, err, out) = render_into(dir.path(), missing.to_str().unwrap(), &[]);
    assert_refused(
        code,
        &err,
        &out,
        EXIT_BAD_INPUT,
        &["nope.glb", "cannot read"],
    );
}

#[test]
fn file_that_is_not_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("notes.gltf");
    std::fs::write(&path, "this is not a scene").unwrap();
    let (code, err, out) = render_into(dir.path(), path.to_str().unwrap(), &[]);
    assert_refused(
        code,
        &err,
        &out,
        EXIT_BAD_INPUT,
        &["notes.gltf", "not a valid glTF"],
    );
}

#[test]
fn missing_buffer_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_gltf(
        dir.path(),
        "lost",
        &TRIANGLE,
        Some((&[0, 1, 2], U32)),
        false,
    );
    let (code, err, out) = render_into(dir.path(), &scene, &[]);
    assert_refused(
        code,
        &err,
        &out,
        EXIT_BAD_INPUT,
        &["lost.gltf", "buffer 0", "lost.bin"],
    );
}

#[test]
fn nan_positions() {
    let dir = tempfile::tempdir().unwrap();
    let mut positions = TRIANGLE;
    positions[4] = f32::NAN;
    let scene = write_gltf(dir.path(), "nan", &positions, Some((&[0, 1, 2], U32)), true);
    let (code, err, out) = render_into(dir.path(), &scene, &[]);
    assert_refused(
        code,
        &err,
        &out,
        EXIT_BAD_INPUT,
        &[
            "nan.gltf",
            "mesh 0 'plate' primitive 0",
            "POSITION (accessor 0) vertex 1 is not finite",
        ],
    );
}

#[test]
fn indices_past_the_vertex_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_gltf(dir.path(), "idx", &TRIANGLE, Some((&[0, 1, 7], U32)), true);
    let (code, err, out) = render_into(dir.path(), &scene, &[]);
    assert_refused(
        code,
        &err,
        &out,
        EXIT_BAD_INPUT,
        &[
            "idx.gltf",
            "mesh 0 'plate'",
            "index 7 at position 2 of accessor 1 is past the vertex count 3",
        ],
    );
}

#[test]
fn unwritable_output_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("missing-folder").join("out.exr");
    let o = manylights(&[
        "render",
        &repo("scenes/cornell.glb"),
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(EXIT_FAILURE), "{err}");
    assert!(
        err.contains("missing-folder") && err.contains("does not exist"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn usage_errors_exit_with_2() {
    let o = manylights(&["render", "x.glb", "-o", "y.exr", "--spp", "0"]);
    assert_eq!(o.status.code(), Some(2));
    let o = manylights(&["render", "x.glb", "-o", "y.exr", "--selector", "psychic"]);
    assert_eq!(o.status.code(), Some(2));
}

/// Renders a small town image with the given thread count, seed and sampler; returns the EXR
/// bytes.
fn render_town(dir: &Path, threads: &str, seed: &str, sampler: &str) -> Vec<u8> {
    let out = dir.join(format!("t{threads}-{seed}-{sampler}.exr"));
    let town = repo("scenes/town.glb");
    let o = manylights(&[
        "render",
        &town,
        "-o",
        out.to_str().unwrap(),
        "--width",
        "40",
        "--spp",
        "3",
        "--k",
        "2",
        "--threads",
        threads,
        "--variance",
        "--seed",
        seed,
        "--sampler",
        sampler,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read(&out).unwrap()
}

#[test]
fn image_is_bit_identical_for_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    for sampler in ["independent", "sobol"] {
        let one = render_town(dir.path(), "1", "5", sampler);
        assert_eq!(one, render_town(dir.path(), "2", "5", sampler), "{sampler}");
        // A different seed gives a different image: the comparison above is not vacuous.
        assert_ne!(one, render_town(dir.path(), "2", "6", sampler), "{sampler}");
    }
    // And a different sampler another image.
    assert_ne!(
        render_town(dir.path(), "2", "5", "independent"),
        render_town(dir.path(), "2", "5", "halton")
    );
}

#[test]
fn render_writes_exr_png_and_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("c.exr");
    let png = dir.path().join("c.png");
    let json = dir.path().join("c.json");
    let o = manylights(&[
        "render",
        &repo("scenes/cornell.glb"),
        "-o",
        exr.to_str().unwrap(),
        "--width",
        "32",
        "--spp",
        "4",
        "--png",
        png.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    for key in [
        "load",
        "bvh build",
        "light build",
        "(selector ",
        "render",
        "rays",
        "camera samples/s",
        "µs per camera sample",
        "NaN",
    ] {
        assert!(stdout.contains(key), "summary lacks {key:?}: {stdout}");
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(summary["width"], 32);
    assert_eq!(summary["height"], 32);
    assert_eq!(summary["stats"]["camera_samples"], 32 * 32 * 4);
    assert_eq!(summary["lights"], 2);
    assert!(summary["seconds"]["render"].as_f64().unwrap() > 0.0);
    // The selector's build is part of the light build.
    let (lights, selector) = (
        summary["seconds"]["light_build"].as_f64().unwrap(),
        summary["seconds"]["selector_build"].as_f64().unwrap(),
    );
    assert!((0.0..=lights).contains(&selector), "{lights} {selector}");
    // The render's CPU seconds, and the same per camera sample.
    let cpu = summary["seconds"]["render_cpu"].as_f64().unwrap();
    assert!(cpu.is_finite() && cpu >= 0.0, "render_cpu {cpu}");
    // The whole process's CPU holds the render's.
    let process = summary["seconds"]["process_cpu"].as_f64().unwrap();
    assert!(
        process.is_finite() && process >= cpu,
        "process_cpu {process}, render {cpu}"
    );
    let per_sample = summary["cpu_us_per_camera_sample"].as_f64().unwrap();
    assert!((per_sample * f64::from(32 * 32 * 4) - 1e6 * cpu).abs() <= 1e-9 * (1e6 * cpu));
    assert!(png.exists() && exr.exists());
}
