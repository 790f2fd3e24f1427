//! The integration tests in one binary (one link instead of one per file): each file or
//! folder under `tests/` is a module here, named as the file; run one with
//! `cargo test --release --test suite <module>::`. Shared helpers are in `tests/common/`.
//! The two fuzz tests stay binaries of their own: each installs a global allocator that
//! refuses oversized requests.

// Shared helpers, once for every module.
mod common;
#[path = "common/lambert.rs"]
mod lambert;
#[path = "common/run.rs"]
mod run;
#[path = "common/shapes.rs"]
mod shapes;

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
