//! Image output: atomic writes, OpenEXR and PNG.

mod io;

pub use io::*;
