//! Unwritable output places refused by every output of every command, before any work.

use super::*;

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
