//! The external-file policy of glTF URIs, through every subcommand that loads a scene (render,
//! info, reference, bench, converge): a buffer or image URI must resolve, after
//! percent-decoding and canonicalisation, inside the scene's folder; absolute paths, `..`
//! escapes (also percent-encoded), symbolic links that point out and schemes other than `data:`
//! are refused with exit 3 and a message naming the file, the element and the rule, before any
//! output is written; `--allow-external-files DIR` admits the files inside DIR.

use crate::run;

use std::fs;
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::common;
use common::{write_gltf, U32};

const EXIT_USAGE: i32 = 2;
const EXIT_BAD_INPUT: i32 = 3;

struct Run {
    code: Option<i32>,
    stderr: String,
    what: String,
}

fn manylights(args: &[String]) -> Run {
    let o = run::manylights(args);
    Run {
        code: o.status.code(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        what: args.join(" "),
    }
}

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// Every subcommand that loads a scene, tiny, writing into `out`, followed by `extra` options.
fn scene_commands(scene: &Path, out: &Path, extra: &[String]) -> Vec<Vec<String>> {
    let (scene, o) = (s(scene), |f: &str| s(&out.join(f)));
    let small = ["--width", "8", "--spp"];
    let lines: Vec<Vec<String>> = vec![
        [&["render", &scene, "-o", &o("r.exr")][..], &small, &["1"]].concat(),
        vec!["info", &scene],
        [
            &["reference", &scene, "-o", &o("ref.exr")][..],
            &small,
            &["1"],
        ]
        .concat(),
        [
            &["bench", &scene, "--repeat", "1", "--reference-spp", "1"][..],
            &small,
            &["1", "--json", &o("b.json")],
        ]
        .concat(),
        [
            &["converge", &scene, "--seeds", "1", "--reference-spp", "1"][..],
            &small,
            &["1,2", "--json", &o("c.json")],
        ]
        .concat(),
    ]
    .into_iter()
    .map(|l| l.into_iter().map(String::from).collect())
    .collect();
    lines
        .into_iter()
        .map(|l| l.into_iter().chain(extra.iter().cloned()).collect())
        .collect()
}

/// A folder layout: `scenes/` holds the scenes, `outside/secret.bin` a valid buffer that lies
/// outside it, `out/` the outputs.
struct Layout {
    _root: tempfile::TempDir,
    scenes: PathBuf,
    outside: PathBuf,
    out: PathBuf,
}

fn layout() -> Layout {
    let root = tempfile::tempdir().unwrap();
    let (scenes, outside, out) = (
        root.path().join("scenes"),
        root.path().join("outside"),
        root.path().join("out"),
    );
    for d in [&scenes, &outside, &out] {
        fs::create_dir_all(d).unwrap();
    }
    // The buffer of a valid one-triangle scene, moved outside the scene folder.
    let triangle = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    write_gltf(&outside, "secret", &triangle, Some((&[0, 1, 2], U32)), true);
    Layout {
        _root: root,
        scenes,
        outside,
        out,
    }
}

/// A copy of the one-triangle scene in `scenes/name.gltf` whose buffer URI is `uri`.
fn scene_with_buffer_uri(l: &Layout, name: &str, uri: &str) -> PathBuf {
    let mut doc: Value =
        serde_json::from_slice(&fs::read(l.outside.join("secret.gltf")).unwrap()).unwrap();
    doc["buffers"][0]["uri"] = json!(uri);
    let path = l.scenes.join(format!("{name}.gltf"));
    fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// A valid scene in `scenes/name.gltf` (its buffer inside the folder) with a base-colour texture
/// whose image URI is `uri`.
fn scene_with_image_uri(l: &Layout, name: &str, uri: &str) -> PathBuf {
    let mut doc: Value =
        serde_json::from_slice(&fs::read(l.outside.join("secret.gltf")).unwrap()).unwrap();
    fs::copy(l.outside.join("secret.bin"), l.scenes.join("inside.bin")).unwrap();
    doc["buffers"][0]["uri"] = json!("inside.bin");
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": uri}]);
    let path = l.scenes.join(format!("{name}.gltf"));
    fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

#[cfg(unix)]
fn symlink(target: &Path, link: &Path) {
    std::os::unix::fs::symlink(target, link).unwrap();
}

/// The scenes whose buffer escapes the scene folder, each with what its message must contain.
fn escaping_buffers(l: &Layout) -> Vec<(PathBuf, Vec<String>)> {
    let secret = l.outside.join("secret.bin");
    let folder = l.scenes.canonicalize().unwrap();
    let rule = format!(
        "external files must lie inside the scene's folder {}",
        folder.display()
    );
    let mut cases = vec![
        (
            scene_with_buffer_uri(l, "absolute", &s(&secret)),
            vec!["is an absolute path".to_string()],
        ),
        (
            scene_with_buffer_uri(l, "escaping", "../outside/secret.bin"),
            vec!["climbs out of the scene's folder".into()],
        ),
        (
            scene_with_buffer_uri(l, "escaping-deep", "./sub/../../outside/secret.bin"),
            vec!["climbs out of the scene's folder".into()],
        ),
        (
            scene_with_buffer_uri(l, "percent", "%2e%2E%2Foutside%2fsecret.bin"),
            vec!["climbs out of the scene's folder".into()],
        ),
        (
            scene_with_buffer_uri(l, "percent-absolute", &s(&secret).replace('/', "%2F")),
            vec!["is an absolute path".into()],
        ),
    ];
    fs::create_dir_all(l.scenes.join("sub")).unwrap();
    #[cfg(unix)]
    {
        symlink(&secret, &l.scenes.join("link.bin"));
        cases.push((
            scene_with_buffer_uri(l, "symlink-file", "link.bin"),
            vec!["leads through a symbolic link to".into()],
        ));
        symlink(Path::new("../outside"), &l.scenes.join("linked-folder"));
        cases.push((
            scene_with_buffer_uri(l, "symlink-folder", "linked-folder/secret.bin"),
            vec!["leads through a symbolic link to".into()],
        ));
    }
    for case in &mut cases {
        case.1.push(rule.clone());
    }
    cases
}

#[test]
fn uris_leaving_the_scene_folder_are_refused_by_every_command_with_exit_3() {
    let l = layout();
    let mut cases: Vec<(PathBuf, Vec<String>)> = escaping_buffers(&l)
        .into_iter()
        .map(|(p, mut m)| {
            m.extend(["buffer 0".to_string(), "refused".into()]);
            (p, m)
        })
        .collect();
    for (name, uri, rule) in [
        (
            "scheme-file",
            "file:///etc/passwd",
            "the URI scheme 'file:'",
        ),
        (
            "scheme-http",
            "http://example.com/x.bin",
            "the URI scheme 'http:'",
        ),
        ("scheme-drive", "C:/x.bin", "the URI scheme 'C:'"),
    ] {
        let m = vec!["buffer 0".into(), rule.into(), "data: URIs".into()];
        cases.push((scene_with_buffer_uri(&l, name, uri), m));
    }
    let png = l.outside.join("secret.png");
    fs::write(&png, b"not read").unwrap();
    let png = s(&png);
    cases.push((
        scene_with_image_uri(&l, "image-absolute", &png),
        vec![
            "image 0".into(),
            "texture 0".into(),
            "is an absolute path".into(),
        ],
    ));
    #[cfg(unix)]
    {
        symlink(Path::new("loop.bin"), &l.scenes.join("loop.bin"));
        cases.push((
            scene_with_buffer_uri(&l, "symlink-loop", "loop.bin"),
            vec![
                "buffer 0".into(),
                "cannot resolve the path".into(),
                "symbolic links".into(),
            ],
        ));
    }
    for (scene, mentions) in &cases {
        let name = scene.file_name().unwrap().to_string_lossy().into_owned();
        for args in scene_commands(scene, &l.out, &[]) {
            let run = manylights(&args);
            let context = format!("`manylights {}`\nstderr: {}", run.what, run.stderr);
            assert_eq!(run.code, Some(EXIT_BAD_INPUT), "{context}");
            assert!(run.stderr.starts_with("error"), "{context}");
            assert!(!run.stderr.contains("panicked"), "{context}");
            for m in mentions.iter().chain([&name]) {
                assert!(
                    run.stderr.contains(m.as_str()),
                    "should mention {m:?}: {context}"
                );
            }
            assert_eq!(fs::read_dir(&l.out).unwrap().count(), 0, "{context}");
        }
    }
}

#[test]
fn allow_external_files_admits_the_folder_on_every_command() {
    let l = layout();
    let allow = vec!["--allow-external-files".to_string(), s(&l.outside)];
    for (scene, _) in escaping_buffers(&l) {
        for args in scene_commands(&scene, &l.out, &allow) {
            let run = manylights(&args);
            // converge's verdict on a 1-spp reference may be a failed check (exit 4); the
            // scene itself loaded.
            let loaded = run.code == Some(0) || (args[0] == "converge" && run.code == Some(4));
            assert!(loaded, "`{}`: {:?} {}", run.what, run.code, run.stderr);
        }
    }
}

#[test]
fn files_inside_the_scene_folder_load_without_the_option() {
    let l = layout();
    fs::copy(l.outside.join("secret.bin"), l.scenes.join("mine.bin")).unwrap();
    fs::create_dir_all(l.scenes.join("sub")).unwrap();
    let mut scenes = vec![
        scene_with_buffer_uri(&l, "plain", "mine.bin"),
        scene_with_buffer_uri(&l, "dotted", "./sub/../mine.bin"),
        scene_with_buffer_uri(&l, "percent", "sub%2F..%2Fmine.bin"),
    ];
    #[cfg(unix)]
    {
        symlink(Path::new("mine.bin"), &l.scenes.join("alias.bin"));
        scenes.push(scene_with_buffer_uri(&l, "symlink-inside", "alias.bin"));
    }
    for scene in scenes {
        let args = vec!["info".to_string(), s(&scene)];
        let run = manylights(&args);
        assert_eq!(run.code, Some(0), "`{}`: {}", run.what, run.stderr);
    }
}

#[test]
fn allow_external_files_needs_an_existing_folder() {
    let l = layout();
    let scene = scene_with_buffer_uri(&l, "plain", "../outside/secret.bin");
    for (dir, says) in [
        (l.outside.join("missing"), "cannot resolve"),
        (l.outside.join("secret.bin"), "is not a folder"),
    ] {
        let args = vec![
            "info".to_string(),
            s(&scene),
            "--allow-external-files".into(),
            s(&dir),
        ];
        let run = manylights(&args);
        assert_eq!(run.code, Some(EXIT_USAGE), "{}", run.stderr);
        assert!(
            run.stderr.contains("--allow-external-files"),
            "{}",
            run.stderr
        );
        assert!(run.stderr.contains(says), "{}", run.stderr);
    }
}
