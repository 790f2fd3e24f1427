//! The integration tests in one binary (one link instead of one per file): each file or
//! folder under `tests/` is a module here, named as the file; run one with
//! `cargo test --release --test suite <module>::`. Shared helpers are in `tests/common/`.
//! The two fuzz tests stay binaries of their own: each installs a global allocator that
//! refuses oversized requests.

// Shared helpers, once for every module.
#[path = "common/color.rs"]
mod color;
mod common;
#[path = "common/lambert.rs"]
mod lambert;
#[path = "common/run.rs"]
mod run;
#[path = "common/shapes.rs"]
mod shapes;
#[path = "common/top_view.rs"]
mod top_view;

mod analytic;
mod blender;
mod cli;
mod converge;
mod environment;
#[path = "extremes/main.rs"]
mod extremes;
mod generators;
#[path = "hostile/main.rs"]
mod hostile;
mod lit_mask;
mod loader;
mod loader_fuzz_regressions;
mod measure_cli;
mod noise_correction;
mod occlusion;
mod resume;
mod ris;
mod room;
mod samplers;
mod selection;
mod selectors;
#[path = "textures/main.rs"]
mod textures;
mod uri_policy;

/// Every file and folder of tests under `tests/` is a module of this binary or one of the two
/// fuzz binaries (with `autotests` off, one left out would silently never run).
#[test]
fn every_test_file_is_compiled() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let suite = std::fs::read_to_string(dir.join("suite.rs")).unwrap();
    let cargo = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"),
    )
    .unwrap();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let is_test = if path.is_dir() {
            path.join("main.rs").is_file()
        } else {
            path.extension().is_some_and(|e| e == "rs") && name != "suite"
        };
        if is_test {
            let declared = suite.lines().any(|l| l == format!("mod {name};"));
            let own_binary = cargo.contains(&format!("name = \"{name}\""));
            assert!(
                declared || own_binary,
                "tests/{name} is not compiled into any test binary"
            );
        }
    }
}
