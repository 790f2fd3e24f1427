//! Hostile scenes (malformed, truncated, claiming gigabytes) refused by every scene command.

use super::*;

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
