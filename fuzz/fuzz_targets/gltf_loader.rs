//! The glTF/GLB loader on arbitrary bytes (textures, samplers, cameras, punctual lights, KHR
//! extensions, external URIs under the file policy): it must return a scene or an error, never
//! panic, hang or allocate beyond libFuzzer's `-malloc_limit_mb`. A scene that loads is also
//! turned into lights, as `render` would.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use manylights::lights::Lights;
use manylights::scene::load_gltf_bytes;

fuzz_target!(|bytes: &[u8]| {
    // External URIs resolve inside this (empty) folder only; the policy refuses the rest.
    let folder = Path::new("/nonexistent-manylights-fuzz");
    let path = if bytes.starts_with(b"glTF") {
        Path::new("input.glb")
    } else {
        Path::new("input.gltf")
    };
    if let Ok(scene) = load_gltf_bytes(bytes, path, folder, &Default::default()) {
        let _ = Lights::from_scene(&scene);
    }
});
