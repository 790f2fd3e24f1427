//! Missing, corrupt and oversized images and TEXCOORD_1 as errors naming the image, from the
//! loader and the CLI.

use super::*;

/// The error's text, which must name the image; the load must not panic.
pub(crate) fn load_error(path: &Path) -> String {
    match load(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e @ LoadError::Invalid { .. }) => e.to_string(),
        Err(e) => panic!("{}: unexpected error kind: {e}", path.display()),
    }
}

#[test]
pub(crate) fn missing_corrupt_and_oversized_images_are_errors_naming_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let uri = |name: &str| EmissiveImage::Uri(name.into());

    let path = write_scene(
        dir.path(),
        "missing",
        Uvs::Continuous(FINE),
        uri("glow.png"),
        0,
    );
    let err = load_error(&path);
    assert!(err.contains("image 0") && err.contains("glow.png"), "{err}");
    // The same file once the image exists beside it: it loads, with the texture's size.
    std::fs::write(
        dir.path().join("glow.png"),
        png(TEX, TEX, &emissive_codes()),
    )
    .unwrap();
    let scene = load(&path).unwrap();
    assert_eq!(scene.textures.len(), 2);
    assert_eq!((scene.textures[0].width, scene.textures[0].height), (8, 8));

    let mut corrupt = png(TEX, TEX, &emissive_codes());
    let len = corrupt.len();
    corrupt[len / 2..].iter_mut().for_each(|b| *b = 0x5A);
    let path = write_scene(
        dir.path(),
        "corrupt",
        Uvs::Continuous(FINE),
        EmissiveImage::View(corrupt),
        0,
    );
    let err = load_error(&path);
    assert!(err.contains("image 0") && err.contains("PNG"), "{err}");

    let path = write_scene(
        dir.path(),
        "text",
        Uvs::Continuous(FINE),
        EmissiveImage::View(b"hello".to_vec()),
        0,
    );
    let err = load_error(&path);
    assert!(
        err.contains("image 0") && err.contains("neither PNG nor JPEG"),
        "{err}"
    );

    // A well-formed header declaring 2^17 × 2^17 texels: refused before decoding.
    let mut huge = png(TEX, TEX, &emissive_codes());
    huge[16..20].copy_from_slice(&(1u32 << 17).to_be_bytes());
    huge[20..24].copy_from_slice(&(1u32 << 17).to_be_bytes());
    let crc = crc32fast::hash(&huge[12..29]);
    huge[29..33].copy_from_slice(&crc.to_be_bytes());
    let path = write_scene(
        dir.path(),
        "huge",
        Uvs::Continuous(FINE),
        EmissiveImage::View(huge),
        0,
    );
    let err = load_error(&path);
    assert!(
        err.contains("image 0") && err.contains("131072×131072"),
        "{err}"
    );

    let image = EmissiveImage::View(png(TEX, TEX, &emissive_codes()));
    let path = write_scene(dir.path(), "texcoord1", Uvs::Continuous(FINE), image, 1);
    let err = load_error(&path);
    assert!(
        err.contains("emissiveTexture") && err.contains("TEXCOORD_1"),
        "{err}"
    );
}

#[test]
pub(crate) fn cli_reports_textures_and_exits_3_on_a_missing_image() {
    let dir = tempfile::tempdir().unwrap();
    let image = EmissiveImage::View(png(TEX, TEX, &emissive_codes()));
    let good = write_scene(dir.path(), "good", Uvs::Continuous(FINE), image, 0);
    let run = |path: &Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_manylights"))
            .args(["info", path.to_str().unwrap()])
            .output()
            .unwrap()
    };
    let out = run(&good);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("textures           2 (8×8, 1×1)"),
        "{stdout}"
    );
    let bad = write_scene(
        dir.path(),
        "bad",
        Uvs::Continuous(FINE),
        EmissiveImage::Uri("nope.png".into()),
        0,
    );
    let out = run(&bad);
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("image 0") && stderr.contains("nope.png"),
        "{stderr}"
    );
}
