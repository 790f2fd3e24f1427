//! Hostile input to every subcommand (render, info, gen, diff, reference, bench, converge):
//! malformed and truncated scenes, files that claim gigabytes, unwritable outputs, bad reference
//! EXRs and malformed option values. Each must give the documented exit code (1 run-time
//! failure, 2 usage, 3 bad input), a message naming the file and the element or option, no
//! panic, and no output or temporary file (the output folder's listing is compared before and
//! after every run).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use manylights::image::{write_exr, RgbImage};
use serde_json::{json, Value};

mod common;
use common::{write_gltf, U32};

const EXIT_FAILURE: i32 = 1;
const EXIT_USAGE: i32 = 2;
const EXIT_BAD_INPUT: i32 = 3;

/// Sparse files stand for huge inputs: 1 TiB (no machine allocates it, so reading one whole
/// aborts instead of merely being slow), or 8 GiB where the file system refuses 1 TiB.
fn make_sparse(path: &Path, data: &[u8]) {
    fs::write(path, data).unwrap();
    let file = fs::OpenOptions::new().write(true).open(path).unwrap();
    file.set_len(1 << 40)
        .or_else(|_| file.set_len(8 << 30))
        .unwrap();
}

struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    what: String,
}

fn manylights<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Run {
    let o = Command::new(env!("CARGO_BIN_EXE_manylights"))
        .args(args)
        .output()
        .expect("binary runs");
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
fn listing(dir: &Path) -> Vec<String> {
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
fn assert_refused<S: AsRef<std::ffi::OsStr>>(
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

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

fn cornell_bytes() -> Vec<u8> {
    fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb")).unwrap()
}

/// The command lines of every subcommand that reads a scene, writing into `out`.
fn scene_commands(scene: &Path, out: &Path) -> Vec<Vec<String>> {
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
fn edited_gltf(dir: &Path, name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
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
fn patched_glb(dir: &Path, name: &str, at: usize, value: u32) -> PathBuf {
    let mut bytes = cornell_bytes();
    bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
    let path = dir.join(name);
    fs::write(&path, bytes).unwrap();
    path
}

/// Every hostile scene, with what its error message must contain (besides its file name).
fn hostile_scenes(dir: &Path) -> Vec<(PathBuf, Vec<&'static str>)> {
    let mut cases = Vec::new();
    let malformed = dir.join("malformed.gltf");
    fs::write(
        &malformed,
        r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [0"#,
    )
    .unwrap();
    cases.push((malformed, vec!["not a valid glTF 2.0 file", "EOF"]));

    let glb = cornell_bytes();
    let json_length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let bin_header = 20 + json_length;
    for cut in [
        5,
        12,
        19,
        20,
        100,
        bin_header,
        bin_header + 12,
        glb.len() - 1,
    ] {
        let path = dir.join(format!("cut-{cut}.glb"));
        fs::write(&path, &glb[..cut]).unwrap();
        cases.push((path, vec!["not a valid glTF 2.0 file", "truncated"]));
    }
    // Headers claiming 4 GB in a 7 kB file: refused before anything that size is allocated.
    let four_gb = 0xffff_fff0;
    for (name, at, mention) in [
        (
            "claims-4gb-total.glb",
            8,
            "GLB header declares a total length of 4294967280 bytes",
        ),
        (
            "claims-4gb-json.glb",
            12,
            "GLB JSON chunk at byte 12 declares 4294967280 bytes",
        ),
        ("claims-4gb-bin.glb", bin_header, "GLB BIN chunk at byte"),
    ] {
        cases.push((patched_glb(dir, name, at, four_gb), vec![mention]));
    }

    cases.push((
        edited_gltf(dir, "view-out-of-range", |d| {
            d["bufferViews"][0]["byteLength"] = json!(1000)
        }),
        vec!["buffer view 0 (offset 0, length 1000) extends past the 48 bytes of buffer 0"],
    ));
    cases.push((
        edited_gltf(dir, "view-offset-overflow", |d| {
            d["bufferViews"][0]["byteOffset"] = json!(u64::MAX / 2)
        }),
        vec!["buffer view 0", "extends past"],
    ));
    cases.push((
        edited_gltf(dir, "position-vec2", |d| {
            d["accessors"][0]["type"] = json!("VEC2")
        }),
        vec![
            "mesh 0 'plate' primitive 0",
            "POSITION (accessor 0) has type Vec2",
        ],
    ));
    cases.push((
        edited_gltf(dir, "float-indices", |d| {
            d["accessors"][1]["componentType"] = json!(5126)
        }),
        vec!["indices (accessor 1) has type Scalar F32"],
    ));
    cases.push((
        edited_gltf(dir, "count-past-view", |d| {
            d["accessors"][0]["count"] = json!(4)
        }),
        vec![
            "POSITION (accessor 0)",
            "4 elements",
            "do not fit in buffer view 0",
        ],
    ));
    cases.push((
        edited_gltf(dir, "normal-count", |d| {
            let normal =
                json!({"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"});
            d["accessors"].as_array_mut().unwrap().push(normal);
            d["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(2);
        }),
        vec!["NORMAL (accessor 2) has 2 entries but POSITION has 3"],
    ));
    cases.push((
        edited_gltf(dir, "index-past", |_| {}),
        vec!["index 7 at position 2 of accessor 1 is past the vertex count 3"],
    ));
    // write_gltf wrote the indices 0, 1, 2; rewrite the last one as 7.
    let bin = dir.join("index-past.bin");
    let mut bytes = fs::read(&bin).unwrap();
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(&7u32.to_le_bytes());
    fs::write(&bin, bytes).unwrap();

    cases.push((
        edited_gltf(dir, "buffer-claims-4gb", |d| {
            d["buffers"][0]["byteLength"] = json!(4_000_000_000u64)
        }),
        vec![
            "buffer 0",
            "declares 4000000000 bytes but 'buffer-claims-4gb.bin'",
            "has only 48",
        ],
    ));
    // A buffer file of a terabyte (sparse) that is still shorter than its byteLength: refused
    // from its size, never read.
    let huge = edited_gltf(dir, "huge-buffer", |d| {
        d["buffers"][0]["byteLength"] = json!((1u64 << 40) + 1)
    });
    let bin = dir.join("huge-buffer.bin");
    make_sparse(&bin, &fs::read(&bin).unwrap());
    cases.push((
        huge,
        vec!["buffer 0", "bytes but 'huge-buffer.bin'", "has only"],
    ));
    cases.push((
        edited_gltf(dir, "buffer-uri-folder", |d| {
            d["buffers"][0]["uri"] = json!(".")
        }),
        vec!["buffer 0", "not a regular file"],
    ));
    cases
}

#[test]
fn every_scene_command_refuses_every_hostile_scene_with_exit_3() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scenes");
    let out = dir.path().join("out");
    fs::create_dir_all(&scenes).unwrap();
    fs::create_dir_all(&out).unwrap();
    let mut cases = hostile_scenes(&scenes);
    let not_a_file = scenes.join("folder.glb");
    fs::create_dir(&not_a_file).unwrap();
    cases.push((not_a_file, vec!["cannot read", "not a regular file"]));
    cases.push((
        scenes.join("missing.glb"),
        vec!["cannot read", "No such file"],
    ));
    #[cfg(target_os = "linux")]
    {
        cases.push((
            PathBuf::from("/dev/zero"),
            vec!["cannot read", "not a regular file"],
        ));
        // A FIFO (opening it for reading would block until a writer comes), as the scene and
        // as a buffer file.
        let fifo = scenes.join("fifo.glb");
        let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(made.success());
        cases.push((fifo, vec!["cannot read", "not a regular file"]));
        let buffer_fifo = edited_gltf(&scenes, "buffer-fifo", |d| {
            d["buffers"][0]["uri"] = json!("fifo.glb")
        });
        cases.push((
            buffer_fifo,
            vec!["buffer 0", "'fifo.glb'", "not a regular file"],
        ));
    }
    for (scene, mentions) in &cases {
        let name = scene.file_name().unwrap().to_string_lossy().into_owned();
        let mentions: Vec<&str> = mentions.iter().copied().chain([name.as_str()]).collect();
        for args in scene_commands(scene, &out) {
            // The scene folder is watched too: bench and converge must not create SCENE.ref/.
            assert_refused(&args, EXIT_BAD_INPUT, &mentions, dir.path());
        }
    }
}

#[test]
fn huge_sparse_files_are_read_only_as_far_as_their_declared_length() {
    let dir = tempfile::tempdir().unwrap();
    // A buffer file of a terabyte whose first 48 bytes are the buffer (byteLength 48).
    let gltf = edited_gltf(dir.path(), "tail", |_| {});
    let bin = dir.path().join("tail.bin");
    make_sparse(&bin, &fs::read(&bin).unwrap());
    // A .glb followed by a terabyte of zeros: its header says where it ends.
    let glb = dir.path().join("tail.glb");
    make_sparse(&glb, &cornell_bytes());
    let cornell = manylights(&[
        "info",
        &s(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb")),
    ]);
    assert_eq!(cornell.code, Some(0), "{}", cornell.stderr);
    let triangles = |run: &Run| {
        run.stdout
            .lines()
            .find(|l| l.starts_with("triangles"))
            .map(|l| l.split_whitespace().nth(1).unwrap().to_string())
    };
    for (scene, expected) in [(&gltf, Some("1".to_string())), (&glb, triangles(&cornell))] {
        let run = manylights(&["info", &s(scene)]);
        assert_eq!(run.code, Some(0), "{}", run.stderr);
        assert_eq!(triangles(&run), expected, "{}", run.stdout);
    }
    // The measuring commands read (and hash) the scene through the same bounded reader.
    let out = dir.path().join("ref.exr");
    let run = manylights(&[
        "reference",
        &s(&glb),
        "-o",
        &s(&out),
        "--width",
        "8",
        "--spp",
        "1",
    ]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(out.exists());
}

/// Renders an 8-pixel-wide (square) Cornell image with its variance layer.
fn render_small(dir: &Path, name: &str, width: &str) -> PathBuf {
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

/// An 8×8 EXR whose pixel (3, 2) has `value` in G (mean) or in variance.G.
fn poisoned_exr(dir: &Path, name: &str, value: f32, in_variance: bool) -> PathBuf {
    let mut mean = RgbImage {
        width: 8,
        height: 8,
        pixels: vec![[0.5; 3]; 64],
    };
    let mut variance = RgbImage {
        pixels: vec![[1e-3; 3]; 64],
        ..mean.clone()
    };
    let target = if in_variance {
        &mut variance
    } else {
        &mut mean
    };
    target.pixels[2 * 8 + 3][1] = value;
    let path = dir.join(name);
    write_exr(&path, &mean, Some(&variance)).unwrap();
    path
}

#[test]
fn diff_bench_and_converge_refuse_bad_reference_exrs_with_exit_3() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    let out = dir.path().join("out");
    fs::create_dir_all(&inputs).unwrap();
    fs::create_dir_all(&out).unwrap();
    let scene = inputs.join("cornell.glb");
    fs::write(&scene, cornell_bytes()).unwrap();
    let good = render_small(&inputs, "good.exr", "8");
    let wide = render_small(&inputs, "wide.exr", "12");
    let text = inputs.join("text.exr");
    fs::write(&text, "{\"not\": \"an image\"}").unwrap();
    let truncated = inputs.join("truncated.exr");
    let bytes = fs::read(&good).unwrap();
    fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let nan = poisoned_exr(&inputs, "nan.exr", f32::NAN, false);
    let inf = poisoned_exr(&inputs, "inf.exr", f32::INFINITY, false);
    let negative_variance = poisoned_exr(&inputs, "negvar.exr", -1.0, true);
    let bad_sidecar = inputs.join("sidecar.exr");
    fs::copy(&good, &bad_sidecar).unwrap();
    fs::write(inputs.join("sidecar.exr.json"), "{ truncated").unwrap();
    let missing = inputs.join("missing.exr");

    let mean_cases: Vec<(&PathBuf, Vec<&str>)> = vec![
        (&wide, vec!["wide.exr", "12x12", "8x8"]),
        (&text, vec!["text.exr", "not a valid OpenEXR file"]),
        (&truncated, vec!["truncated.exr", "truncated or corrupt"]),
        (
            &nan,
            vec![
                "nan.exr",
                "mean pixel (3, 2) channel G is NaN, expected a finite value",
            ],
        ),
        (&inf, vec!["inf.exr", "mean pixel (3, 2) channel G is inf"]),
        (&missing, vec!["missing.exr", "cannot read", "No such file"]),
    ];
    let diff_image = s(&out.join("d.exr"));
    for (bad, mentions) in &mean_cases {
        // diff: the bad file as the reference, and as the image measured.
        for pair in [[&good, *bad], [*bad, &good]] {
            let args = ["diff", &s(pair[0]), &s(pair[1]), "--image", &diff_image];
            assert_refused(&args, EXIT_BAD_INPUT, mentions, dir.path());
        }
    }
    let reference_only: Vec<(&PathBuf, Vec<&str>)> = vec![
        (
            &negative_variance,
            vec![
                "negvar.exr",
                "variance pixel (3, 2) channel G is -1, expected a finite value ≥ 0",
            ],
        ),
        (
            &bad_sidecar,
            vec!["sidecar.exr.json", "not a reference sidecar"],
        ),
    ];
    let [b_json, b_svg, c_json] = ["b.json", "b.svg", "c.json"].map(|f| s(&out.join(f)));
    for (bad, mentions) in mean_cases.iter().chain(&reference_only) {
        let (scene, bad) = (s(&scene), s(bad));
        let common = ["--width", "8", "--reference", &bad, "--seed", "1"];
        let bench = [
            &["bench", &scene, "--spp", "1", "--repeat", "1"][..],
            &common,
            &["--json", &b_json, "--plot", &b_svg],
        ]
        .concat();
        assert_refused(&bench, EXIT_BAD_INPUT, mentions, dir.path());
        let converge = [
            &["converge", &scene, "--spp", "1,2", "--seeds", "1"][..],
            &common,
            &["--json", &c_json],
        ]
        .concat();
        assert_refused(&converge, EXIT_BAD_INPUT, mentions, dir.path());
    }
    // The inputs are fine: diff succeeds on them, so the refusals above are about the bad files.
    let run = manylights(&["diff", &s(&good), &s(&good), "--image", &diff_image]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains("mse      0.000000e0"), "{}", run.stdout);
}

/// Where an output can never be written: under a regular file, an existing folder of that name,
/// a folder that does not exist, and (unless running as root, who may write anywhere) a
/// read-only folder. Returns (path, what the message must say) for a file named `name`.
fn unwritable_places(dir: &Path, name: &str) -> Vec<(PathBuf, &'static str)> {
    let file = dir.join("regular-file");
    fs::write(&file, "x").unwrap();
    let folder = dir.join(format!("folder-{name}"));
    fs::create_dir_all(folder.join(name)).unwrap();
    let mut places = vec![
        (file.join(name), "is not a folder"),
        (folder.join(name), "is a folder, not a file"),
        (dir.join("no-such-folder").join(name), "does not exist"),
    ];
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let read_only = dir.join("read-only");
        fs::create_dir_all(&read_only).unwrap();
        fs::set_permissions(&read_only, fs::Permissions::from_mode(0o555)).unwrap();
        if fs::write(read_only.join("probe"), "x").is_err() {
            places.push((read_only.join(name), "does not accept new files"));
        }
    }
    places
}

#[test]
fn every_output_of_every_command_refuses_an_unwritable_place_before_working() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let scene = root.join("cornell.glb");
    fs::write(&scene, cornell_bytes()).unwrap();
    let good = render_small(root, "good.exr", "8");
    let ok = |f: &str| s(&root.join("fresh").join(f));
    fs::create_dir(root.join("fresh")).unwrap();
    let (scene, good) = (s(&scene), s(&good));
    let small = ["--width", "8", "--spp", "1"];
    // (file name, command line with the bad path in place of "BAD").
    let commands: Vec<(&str, Vec<String>)> = vec![
        (
            "r.exr",
            [&["render", &scene, "-o", "BAD"][..], &small].concat(),
        ),
        (
            "r.png",
            [
                &["render", &scene, "-o", &ok("r.exr"), "--png", "BAD"][..],
                &small,
            ]
            .concat(),
        ),
        (
            "r.json",
            [
                &["render", &scene, "-o", &ok("r.exr"), "--json", "BAD"][..],
                &small,
            ]
            .concat(),
        ),
        (
            "ref.exr",
            [&["reference", &scene, "-o", "BAD"][..], &small].concat(),
        ),
        (
            "b.json",
            [
                &["bench", &scene, "--reference", &good, "--json", "BAD"][..],
                &small,
            ]
            .concat(),
        ),
        (
            "b.csv",
            [
                &["bench", &scene, "--reference", &good, "--csv", "BAD"][..],
                &small,
            ]
            .concat(),
        ),
        (
            "b.md",
            [
                &["bench", &scene, "--reference", &good, "--markdown", "BAD"][..],
                &small,
            ]
            .concat(),
        ),
        (
            "b.svg",
            [
                &["bench", &scene, "--reference", &good, "--plot", "BAD"][..],
                &small,
            ]
            .concat(),
        ),
        (
            "c.json",
            vec![
                "converge",
                &scene,
                "--reference",
                &good,
                "--json",
                "BAD",
                "--width",
                "8",
                "--spp",
                "1,2",
            ],
        ),
        ("d.exr", vec!["diff", &good, &good, "--image", "BAD"]),
        ("g.glb", vec!["gen", "cornell", "-o", "BAD"]),
        ("g.gltf", vec!["gen", "cornell", "-o", "BAD"]),
    ]
    .into_iter()
    .map(|(name, args)| (name, args.into_iter().map(String::from).collect()))
    .collect();
    for (name, args) in &commands {
        for (bad, mention) in unwritable_places(root, name) {
            let args: Vec<String> = args
                .iter()
                .map(|a| if a == "BAD" { s(&bad) } else { a.clone() })
                .collect();
            assert_refused(
                &args,
                EXIT_FAILURE,
                &[mention, &s(bad.parent().unwrap())],
                root,
            );
        }
    }
    // --error-images names a folder: a regular file, a missing or a read-only folder is refused.
    let mut folders = vec![
        (root.join("regular-file"), "is not a folder"),
        (root.join("no-such-folder"), "does not exist"),
    ];
    let read_only = root.join("read-only");
    if fs::write(read_only.join("probe"), "x").is_err() {
        folders.push((read_only, "does not accept new files"));
    }
    for (bad, mention) in folders {
        let args = [&["bench", &scene, "--reference", &good][..], &small].concat();
        let bad = s(&bad);
        let args = [&args[..], &["--error-images", &bad]].concat();
        assert_refused(&args, EXIT_FAILURE, &["--error-images", mention], root);
    }
    // A reference's sidecar is an output too: a folder named REF.exr.json is refused up front.
    fs::create_dir(root.join("fresh").join("s.exr.json")).unwrap();
    let sidecar_owner = ok("s.exr");
    let args = [&["reference", &scene, "-o", &sidecar_owner][..], &small].concat();
    assert_refused(&args, EXIT_FAILURE, &["s.exr.json", "is a folder"], root);
    // Outputs named with the wrong extension are refused too (exit 1, nothing written).
    for args in [
        vec!["render", &scene, "-o", &ok("r.png")],
        vec!["gen", "cornell", "-o", &ok("g.obj")],
        vec!["diff", &good, &good, "--image", &ok("d.png")],
    ] {
        assert_refused(&args, EXIT_FAILURE, &["expected a ."], root);
    }
}

#[test]
fn malformed_option_values_are_usage_errors_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let scene = root.join("cornell.glb");
    fs::write(&scene, cornell_bytes()).unwrap();
    let scene = s(&scene);
    let out = |f: &str| s(&root.join(f));
    let (r_exr, j) = (out("r.exr"), out("x.json"));
    let with = |head: &[&str], extra: &[&str]| -> Vec<String> {
        [head, extra]
            .concat()
            .into_iter()
            .map(String::from)
            .collect()
    };
    let render = |extra: &[&str]| with(&["render", &scene, "-o", &r_exr, "--spp", "1"], extra);
    let bench = |extra: &[&str]| with(&["bench", &scene, "--json", &j], extra);
    let converge = |extra: &[&str]| with(&["converge", &scene, "--json", &j], extra);
    let reference = |extra: &[&str]| with(&["reference", &scene, "-o", &r_exr], extra);
    let huge = ["--width", "16384", "--height", "16384"];
    let cases: Vec<(Vec<String>, i32, Vec<&str>)> = vec![
        (
            bench(&["--kn", "0x1"]),
            EXIT_USAGE,
            vec!["--kn", "0x1", "1..=4096"],
        ),
        (
            bench(&["--kn", "4"]),
            EXIT_USAGE,
            vec!["--kn", "expected KxN"],
        ),
        (
            bench(&["--kn", "1x5000"]),
            EXIT_USAGE,
            vec!["--kn", "1x5000"],
        ),
        (
            bench(&["--kn", "1x1", "--k", "2"]),
            EXIT_USAGE,
            vec!["--kn or --k/--n"],
        ),
        (
            bench(&["--spp", "0"]),
            EXIT_USAGE,
            vec!["--spp", "0 is not in 1..="],
        ),
        (bench(&["--spp", "1,,2"]), EXIT_USAGE, vec!["--spp"]),
        (bench(&["--repeat", "0"]), EXIT_USAGE, vec!["--repeat"]),
        (
            bench(&["--time-budget", "0"]),
            EXIT_USAGE,
            vec!["--time-budget must be a positive number"],
        ),
        (
            bench(&["--time-budget", "inf"]),
            EXIT_USAGE,
            vec!["--time-budget"],
        ),
        (
            bench(&["--target-relmse", "NaN"]),
            EXIT_USAGE,
            vec!["--target-relmse"],
        ),
        (
            bench(&["--baseline", "oracle:bsdf:9x9"]),
            EXIT_USAGE,
            vec!["--baseline oracle:bsdf:9x9 is not among"],
        ),
        (
            bench(&["--selectors", "psychic"]),
            EXIT_USAGE,
            vec!["--selector", "psychic"],
        ),
        (bench(&["--threads", "0"]), EXIT_USAGE, vec!["--threads"]),
        (
            bench(&["--clamp=-1"]),
            EXIT_USAGE,
            vec!["--clamp", "positive finite"],
        ),
        (
            bench(&["--width", "0"]),
            EXIT_USAGE,
            vec!["--width", "0 is not in 1..=16384"],
        ),
        (
            bench(&["--width", "1000000000"]),
            EXIT_USAGE,
            vec!["--width", "1000000000"],
        ),
        (
            bench(&huge),
            EXIT_USAGE,
            vec!["--width 16384 --height 16384", "268435456 pixels"],
        ),
        (
            converge(&["--spp", "8"]),
            EXIT_USAGE,
            vec!["two distinct --spp"],
        ),
        (
            converge(&["--spp", "8,8"]),
            EXIT_USAGE,
            vec!["two distinct --spp"],
        ),
        (converge(&["--seeds", "0"]), EXIT_USAGE, vec!["--seeds"]),
        (
            converge(&["--tolerance=-1"]),
            EXIT_USAGE,
            vec!["--tolerance"],
        ),
        (
            converge(&["--tolerance", "nan"]),
            EXIT_USAGE,
            vec!["--tolerance"],
        ),
        (
            converge(&["--reference-spp", "0"]),
            EXIT_USAGE,
            vec!["--reference-spp"],
        ),
        (
            converge(&["--selector", "bvh,power"]),
            EXIT_USAGE,
            vec!["--selector takes one value"],
        ),
        (converge(&huge), EXIT_USAGE, vec!["268435456 pixels"]),
        (
            reference(&["--time", "0"]),
            EXIT_USAGE,
            vec!["--time", "positive number of seconds"],
        ),
        (reference(&["--time", "nan"]), EXIT_USAGE, vec!["--time"]),
        (
            reference(&["--time", "1", "--spp", "4"]),
            EXIT_USAGE,
            vec!["--time", "--spp"],
        ),
        (
            reference(&["--spp", "4,8"]),
            EXIT_USAGE,
            vec!["--spp takes one value"],
        ),
        (
            reference(&["--clamp", "1"]),
            EXIT_USAGE,
            vec!["--clamp is not allowed"],
        ),
        (reference(&huge), EXIT_USAGE, vec!["268435456 pixels"]),
        (render(&["--k", "0"]), EXIT_USAGE, vec!["--k"]),
        (render(&["--n", "5000"]), EXIT_USAGE, vec!["--n"]),
        (
            render(&["--exposure", "nan"]),
            EXIT_USAGE,
            vec!["--exposure", "finite"],
        ),
        (
            render(&["--strategy", "mis,bsdf"]),
            EXIT_USAGE,
            vec!["--strategy takes one value"],
        ),
        (render(&["--height", "0"]), EXIT_USAGE, vec!["--height"]),
        (render(&huge), EXIT_USAGE, vec!["268435456 pixels"]),
        (
            render(&["--camera", "99"]),
            EXIT_BAD_INPUT,
            vec!["cornell.glb", "camera", "--camera 99"],
        ),
        (
            with(&["info", &scene, "--camera", "nobody"], &[]),
            EXIT_BAD_INPUT,
            vec!["--camera 'nobody'"],
        ),
        (
            with(
                &["gen", "cornell", "-o", &out("g.glb"), "--lights", "1"],
                &[],
            ),
            EXIT_USAGE,
            vec!["--lights"],
        ),
        (
            with(&["gen", "attic", "-o", &out("g.glb")], &[]),
            EXIT_USAGE,
            vec!["attic"],
        ),
        (with(&["diff", &r_exr], &[]), EXIT_USAGE, vec!["REFERENCE"]),
        (with(&["render", &scene], &[]), EXIT_USAGE, vec!["--output"]),
        (with(&["teleport"], &[]), EXIT_USAGE, vec!["teleport"]),
    ];
    for (args, code, mentions) in &cases {
        assert_refused(args, *code, mentions, root);
    }
}

/// `--max-memory`: a scene whose estimated memory (from the sizes its file declares) exceeds the
/// budget is refused with exit 3 before its buffers are read, with the estimate, its largest part
/// and the budget; an unreadable size is a usage error; a budget the scene fits renders.
#[test]
fn scenes_over_the_memory_budget_are_refused_before_their_buffers_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    fs::create_dir(&out).unwrap();
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let exr = s(&out.join("r.exr"));
    let render = |scene: &Path, budget: &str| -> Vec<String> {
        let scene = s(scene);
        let args = ["render", &scene, "-o", &exr, "--width", "64", "--spp", "1"];
        let args = args.into_iter().chain(["--max-memory", budget]);
        args.map(String::from).collect()
    };
    let run = manylights(&render(&cornell, "1M"));
    assert_eq!(run.code, Some(EXIT_BAD_INPUT), "{}", run.stderr);
    assert_eq!(
        run.stderr.trim_end(),
        format!(
            "error: {}: scene 0: rendering it needs an estimated 7.72 MB, mostly program \
             (program 7.34 MB; film 360 kB for 4096 pixels at 88 B; geometry and BVH 10.2 kB \
             for 36 triangles at 283 B; file 7.08 kB; lights 408 B for 2 emitters at 204 B), \
             more than the 1.00 MB allowed (--max-memory; by default the memory the system has \
             available)",
            cornell.display()
        )
    );
    assert!(listing(&out).is_empty());
    // 12 million triangles declared by a one-triangle file: refused from the declaration, before
    // the 36-byte buffer is read (reading it would fail: the accessor overruns it).
    let declares = edited_gltf(dir.path(), "declares", |doc| {
        doc["accessors"][1]["count"] = json!(36_000_000);
    });
    assert_refused(
        &render(&declares, "1G"),
        EXIT_BAD_INPUT,
        &[
            "declares.gltf: scene 0: rendering it needs an estimated 3.40 GB, mostly geometry \
             and BVH (geometry and BVH 3.40 GB for 12000000 triangles at 283 B;",
            "more than the 1.00 GB allowed (--max-memory",
        ],
        &out,
    );
    assert_refused(
        &render(&cornell, "12Q"),
        EXIT_USAGE,
        &["invalid value '12Q' for '--max-memory <SIZE>': '12Q': unknown unit"],
        &out,
    );
    let run = manylights(&render(&cornell, "1G"));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(out.join("r.exr").is_file());
}

/// Output into a pipe whose reader has gone (`manylights info SCENE | head -1`) ends the program
/// by SIGPIPE, as it ends `cat`, without a panic message.
#[cfg(unix)]
#[test]
fn a_closed_output_pipe_ends_the_program_quietly() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    let town = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/town.glb");
    let mut child = Command::new(env!("CARGO_BIN_EXE_manylights"))
        .args(["info", &s(&town)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.signal(),
        Some(13),
        "status {:?}: {stderr}",
        out.status
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
