//! The OpenEXR readers on arbitrary bytes: `read_exr_rgb` (references for `diff`, `bench` and
//! `converge`) and, when it succeeds, the environment map built from the image (`--env`). The
//! bytes go through a file in /dev/shm because both readers take a path. They must return a
//! value or an error, never panic, hang or allocate beyond libFuzzer's `-malloc_limit_mb`.
#![no_main]

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use libfuzzer_sys::fuzz_target;
use manylights::image::read_exr_rgb;
use manylights::lights::EnvironmentMap;
use manylights::scene::EnvironmentImage;

/// One file per fuzzing process.
fn input_path() -> &'static PathBuf {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        PathBuf::from(format!(
            "/dev/shm/manylights-fuzz-{}.exr",
            std::process::id()
        ))
    })
}

fuzz_target!(|bytes: &[u8]| {
    let path = input_path();
    if std::fs::write(path, bytes).is_err() {
        return;
    }
    if let Ok((image, _)) = read_exr_rgb(path) {
        if let Ok(env) = EnvironmentImage::from_rgb(&image, 1.0, 30.0) {
            let _ = EnvironmentMap::new(Arc::new(env));
        }
    }
});
