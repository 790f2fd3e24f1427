//! Resumable references: a reference stopped at a pass boundary (library) or killed or
//! interrupted at any moment (binary: SIGKILL, SIGINT, SIGTERM) and resumed from its checkpoint
//! is byte-identical to one rendered without interruption; a checkpoint of another scene or
//! other options, a damaged one, a missing one, and a forgotten `--resume` are refused with
//! messages saying what is wrong.

use crate::run;
use manylights::cli::{EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_USAGE};
use run::manylights;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use manylights::measure::checkpoint::{checkpoint_path, read_checkpoint, write_checkpoint};
use manylights::measure::progressive::Flow;
use manylights::measure::reference::{
    finish_reference, render_reference_passes, ReferenceOptions, DEFAULT_ESTIMATOR, PASS_SPP,
};
use manylights::measure::SceneSetup;
use manylights::sampling::sampler::SamplerKind;

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb")
}

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// The bits of a finished reference: every mean and variance value.
fn bits(
    setup: &SceneSetup,
    options: &ReferenceOptions,
    p: &manylights::measure::progressive::Progressive,
) -> Vec<u32> {
    let r = finish_reference(setup, options, Path::new("unused.exr"), p);
    let variance = r.variance.expect("a variance layer");
    r.mean
        .pixels
        .iter()
        .chain(&variance.pixels)
        .flat_map(|px| px.map(f32::to_bits))
        .collect()
}

#[test]
fn a_reference_stopped_at_a_pass_boundary_resumes_to_the_same_bits() {
    let setup = SceneSetup::load(&cornell(), None, 24, None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let checkpoint = dir.path().join("r.exr.checkpoint");
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        let options = ReferenceOptions {
            width: setup.width,
            height: setup.height,
            camera: None,
            estimator: manylights::measure::EstimatorChoice {
                sampler,
                ..DEFAULT_ESTIMATOR
            },
            seed: 7,
            spp: Some(5 * PASS_SPP + 3),
            time: None,
        };
        let whole = render_reference_passes(&setup, &options, None, |_| Flow::Continue);
        assert_eq!(whole.count.spp, 5 * PASS_SPP + 3);
        for stop_after in [1, 3, 5] {
            let part = render_reference_passes(&setup, &options, None, |p| {
                if p.count.passes == stop_after {
                    Flow::Stop
                } else {
                    Flow::Continue
                }
            });
            assert_eq!(part.count.passes, stop_after);
            write_checkpoint(&checkpoint, &setup, &options, PASS_SPP, &part).unwrap();
            let (header, state) = read_checkpoint(&checkpoint).unwrap();
            assert_eq!(
                (header.passes, header.spp),
                (stop_after, stop_after * PASS_SPP)
            );
            assert_eq!(
                state.film.pixels, part.film.pixels,
                "the checkpoint keeps every bit"
            );
            let resumed =
                render_reference_passes(&setup, &options, Some(state), |_| Flow::Continue);
            assert_eq!(resumed.count, whole.count);
            assert_eq!(resumed.stats.nan_samples, whole.stats.nan_samples);
            assert!(
                bits(&setup, &options, &resumed) == bits(&setup, &options, &whole),
                "{sampler:?}: resumed after pass {stop_after} differs"
            );
        }
        // A control: stopping without resuming gives other bits (the test can fail).
        let part = render_reference_passes(&setup, &options, None, |_| Flow::Stop);
        assert!(bits(&setup, &options, &part) != bits(&setup, &options, &whole));
    }
}

fn spawn(args: &[String]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_manylights"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary starts")
}

/// A reference command line writing `out` (32 passes of a small image: long enough to
/// interrupt); `extra` options replace the defaults of the same name.
fn reference_args(scene: &Path, out: &Path, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = ["reference", &s(scene), "-o", &s(out)]
        .iter()
        .map(|a| a.to_string())
        .collect();
    let defaults = [
        ("--width", "40"),
        ("--spp", "256"),
        ("--seed", "3"),
        ("--threads", "1"),
    ];
    for (key, value) in defaults {
        if !extra.contains(&key) {
            args.extend([key.to_string(), value.to_string()]);
        }
    }
    args.extend(extra.iter().map(|a| a.to_string()));
    args
}

/// Waits until `path` exists (the child's first checkpoint).
fn wait_for(path: &Path, child: &mut Child) {
    let start = Instant::now();
    while !path.exists() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the reference ended before its checkpoint"
        );
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no checkpoint appeared"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn killed_or_interrupted_references_resume_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell();
    let whole = dir.path().join("whole.exr");
    let o = manylights(&reference_args(&scene, &whole, &[]));
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = fs::read(&whole).unwrap();

    for how in ["SIGKILL", "SIGINT", "SIGTERM"] {
        let out = dir.path().join(format!("{how}.exr"));
        let checkpoint = checkpoint_path(&out);
        let mut child = spawn(&reference_args(&scene, &out, &["--checkpoint-every", "0"]));
        wait_for(&checkpoint, &mut child);
        // Somewhere inside a later pass (a pass takes tens of milliseconds here).
        std::thread::sleep(Duration::from_millis(37));
        if how == "SIGKILL" {
            child.kill().unwrap();
        } else {
            let sent = Command::new("kill")
                .args([&format!("-{}", &how[3..]), &child.id().to_string()])
                .status()
                .unwrap();
            assert!(sent.success());
        }
        let o = child.wait_with_output().unwrap();
        let message = stderr(&o);
        if how != "SIGKILL" {
            assert_eq!(o.status.code(), Some(EXIT_INTERRUPTED), "{message}");
            for m in [
                &format!("interrupted by {how}"),
                "checkpoint written to",
                "--resume",
            ] {
                assert!(
                    message.contains(m),
                    "{how}: should mention {m:?}: {message}"
                );
            }
        }
        assert!(
            !out.exists(),
            "{how}: an interrupted reference wrote its image"
        );
        assert!(checkpoint.exists());
        // Resumed with another thread count: the image does not depend on it.
        let o = manylights(&reference_args(
            &scene,
            &out,
            &["--resume", "--threads", "2"],
        ));
        assert!(o.status.success(), "{how}: {}", stderr(&o));
        assert!(stderr(&o).contains("resuming"), "{}", stderr(&o));
        assert!(
            fs::read(&out).unwrap() == expected,
            "{how}: resumed reference differs"
        );
        assert!(
            !checkpoint.exists(),
            "the checkpoint is removed once the reference is done"
        );
    }
}

#[test]
fn checkpoints_of_other_runs_and_damaged_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell();
    let other_scene = dir.path().join("other.glb");
    let cornell64 = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell64.glb");
    fs::copy(cornell64, &other_scene).unwrap();
    let out = dir.path().join("r.exr");
    let checkpoint = checkpoint_path(&out);
    let mut child = spawn(&reference_args(&scene, &out, &["--checkpoint-every", "0"]));
    wait_for(&checkpoint, &mut child);
    child.kill().unwrap();
    child.wait().unwrap();
    let saved = fs::read(&checkpoint).unwrap();

    let refused = |args: Vec<String>, code: i32, mentions: &[&str]| {
        let o = manylights(&args);
        let message = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{message}");
        assert!(message.starts_with("error"), "{message}");
        for m in mentions {
            assert!(message.contains(m), "should mention {m:?}: {message}");
        }
        assert!(!out.exists());
    };
    let ckpt = s(&checkpoint);
    refused(
        reference_args(&scene, &out, &["--resume", "--seed", "4"]),
        EXIT_BAD_INPUT,
        &[
            &ckpt,
            "belongs to another run",
            "--seed (checkpoint: 3, now: 4)",
        ],
    );
    refused(
        reference_args(
            &scene,
            &out,
            &["--resume", "--selector", "power", "--k", "2"],
        ),
        EXIT_BAD_INPUT,
        &[
            "--selector (checkpoint: Bvh, now: Power)",
            "--k (checkpoint: 1, now: 2)",
        ],
    );
    refused(
        reference_args(&scene, &out, &["--resume", "--width", "41"]),
        EXIT_BAD_INPUT,
        &["--width (checkpoint: 40, now: 41)"],
    );
    refused(
        reference_args(&other_scene, &out, &["--resume"]),
        EXIT_BAD_INPUT,
        &["the scene (checkpoint:", "cornell.glb", "other.glb"],
    );
    refused(
        reference_args(&scene, &out, &[]),
        EXIT_USAGE,
        &[&ckpt, "exists from an interrupted run", "--resume"],
    );
    let mut damaged = saved.clone();
    let at = damaged.len() / 2;
    damaged[at] ^= 0x10;
    fs::write(&checkpoint, &damaged).unwrap();
    refused(
        reference_args(&scene, &out, &["--resume"]),
        EXIT_BAD_INPUT,
        &[&ckpt, "checksum does not match"],
    );
    fs::write(&checkpoint, &saved[..saved.len() - 100]).unwrap();
    refused(
        reference_args(&scene, &out, &["--resume"]),
        EXIT_BAD_INPUT,
        &[&ckpt, "truncated or corrupt"],
    );
    fs::write(&checkpoint, b"{\"not\": \"a checkpoint\"}").unwrap();
    refused(
        reference_args(&scene, &out, &["--resume"]),
        EXIT_BAD_INPUT,
        &[&ckpt, "not a manylights checkpoint"],
    );
    fs::remove_file(&checkpoint).unwrap();
    refused(
        reference_args(&scene, &out, &["--resume"]),
        EXIT_BAD_INPUT,
        &["cannot read checkpoint", &ckpt],
    );
    // The untouched checkpoint still resumes.
    fs::write(&checkpoint, &saved).unwrap();
    let o = manylights(&reference_args(&scene, &out, &["--resume"]));
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn every_mutated_checkpoint_is_refused_without_panic() {
    let setup = SceneSetup::load(&cornell(), None, 6, None).unwrap();
    let options = ReferenceOptions {
        width: setup.width,
        height: setup.height,
        camera: None,
        estimator: DEFAULT_ESTIMATOR,
        seed: 1,
        spp: Some(3 * PASS_SPP),
        time: None,
    };
    let part = render_reference_passes(&setup, &options, None, |_| Flow::Stop);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.exr.checkpoint");
    write_checkpoint(&path, &setup, &options, PASS_SPP, &part).unwrap();
    let saved = fs::read(&path).unwrap();
    // Every single-bit flip (1 in 13 positions, all 8 bits), every 11th truncation, and huge or
    // zero header lengths: each an error, never a panic or a wrong state.
    let mut mutants: Vec<Vec<u8>> = Vec::new();
    for at in (0..saved.len()).step_by(13) {
        for bit in 0..8 {
            let mut m = saved.clone();
            m[at] ^= 1 << bit;
            mutants.push(m);
        }
    }
    mutants.extend((0..saved.len()).step_by(11).map(|n| saved[..n].to_vec()));
    for length in [0u64, 1, u32::MAX as u64, u64::MAX, saved.len() as u64] {
        let mut m = saved.clone();
        m[8..16].copy_from_slice(&length.to_le_bytes());
        mutants.push(m);
    }
    for m in &mutants {
        fs::write(&path, m).unwrap();
        let result = std::panic::catch_unwind(|| read_checkpoint(&path));
        let Ok(result) = result else {
            panic!("read_checkpoint panicked on a mutant of {} bytes", m.len())
        };
        let Err(e) = result else {
            panic!("a damaged checkpoint of {} bytes was accepted", m.len())
        };
        assert!(format!("{e:#}").contains(&s(&path)), "{e:#}");
    }
    fs::write(&path, &saved).unwrap();
    assert!(read_checkpoint(&path).is_ok());
}
