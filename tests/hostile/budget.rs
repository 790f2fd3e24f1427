//! Scenes over the memory budget refused before their buffers are read; a closed output pipe
//! ends the program quietly.

use super::*;

/// `--max-memory`: a scene whose estimated memory (from the sizes its file declares) exceeds the
/// budget is refused with exit 3 before its buffers are read, with the estimate, its peak phase
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
            "error: {}: scene 0: rendering it needs an estimated 11.1 MB, at the light BVH's \
             build (program 10.5 MB; scene 2.74 kB for 36 triangles at 76 B; geometry BVH kept \
             4.32 kB at 120 B; light BVH build 540 B for 2 emitters at 270 B; film 655 kB for \
             4096 pixels at 160 B; other phases: loading 10.5 MB, the geometry BVH's build 10.5 \
             MB), more than the 1.00 MB allowed (--max-memory; by default the memory the system \
             has available)",
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
            "declares.gltf: scene 0: rendering it needs an estimated 2.36 GB, at the light \
             BVH's build (program 10.5 MB; scene 912 MB for 12000000 triangles at 76 B; \
             geometry BVH kept 1.44 GB at 120 B;",
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
    // The read end is closed before the program starts, so its first write fails whatever the
    // scheduling (closing it after the spawn raced with a program that had already written its
    // report into the pipe's buffer and exited 0).
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_manylights"))
        .args(["info", &s(&town)])
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.signal(),
        Some(13),
        "status {:?}: {stderr}",
        out.status
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
