//! The seed corpus of a coverage-guided fuzzer, written from a fuzz test's own inputs (shared by
//! `fuzz_exr.rs` and `fuzz_loader.rs`).

use std::path::PathBuf;

/// Writes `inputs` to the folder named by `FUZZ_CORPUS_DIR` as `seed-<i><extension>`.
pub fn write_seed_corpus(inputs: &[Vec<u8>], extension: &str) {
    let dir = PathBuf::from(std::env::var("FUZZ_CORPUS_DIR").expect("FUZZ_CORPUS_DIR is set"));
    std::fs::create_dir_all(&dir).unwrap();
    for (i, input) in inputs.iter().enumerate() {
        std::fs::write(dir.join(format!("seed-{i}{extension}")), input).unwrap();
    }
}
