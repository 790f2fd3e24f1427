//! The `manylights` command line: one file per subcommand.
//!
//! Exit codes: 0 success; 1 a run-time failure (e.g. an output file cannot be written);
//! 2 bad command-line usage (from clap, or a [`UsageError`]); 3 an input that cannot be read or
//! is invalid (a scene's [`crate::scene::LoadError`], an environment map's
//! [`crate::scene::EnvironmentError`], or a [`BadInput`] image or reference);
//! 4 a `converge` check failed; 130 a `reference` interrupted by SIGINT or SIGTERM (after
//! writing its checkpoint).

pub mod bench;
pub mod converge;
pub mod diff;
pub mod gen;
pub mod info;
pub mod options;
pub mod output;
pub mod reference;
pub mod render;

use clap::{Parser, Subcommand};

pub const EXIT_FAILURE: i32 = 1;
pub const EXIT_USAGE: i32 = 2;
pub const EXIT_BAD_INPUT: i32 = 3;
pub const EXIT_CHECK_FAILED: i32 = 4;
pub const EXIT_INTERRUPTED: i32 = 130;

#[derive(Parser, Debug)]
#[command(
    name = "manylights",
    version,
    about = "Direct lighting with many emissive triangles: render and measure"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render the direct lighting of a glTF scene to an OpenEXR file.
    Render(render::RenderArgs),
    /// Render a high-spp reference (with variance layer and JSON sidecar) progressively.
    Reference(reference::ReferenceArgs),
    /// Render configurations repeatedly and report error, variance, time and efficiency.
    Bench(bench::BenchArgs),
    /// Check convergence: the MSE's log-log slope, unbiasedness and finite samples (exit 4 on
    /// failure).
    Converge(converge::ConvergeArgs),
    /// Print a scene's triangle and light counts, emitted power, bounds and camera.
    Info(info::InfoArgs),
    /// Write one of the built-in scenes as glTF 2.0 (.glb or .gltf).
    Gen(gen::GenArgs),
    /// Error of an image against a reference: MSE, relMSE, max abs error, PSNR.
    Diff(diff::DiffArgs),
}

/// Runs a parsed command line and returns the process exit code, printing any error.
pub fn run(cli: Cli) -> i32 {
    let result = match cli.command {
        Command::Render(args) => render::run(&args),
        Command::Reference(args) => reference::run(&args),
        Command::Bench(args) => bench::run_bench(&args),
        Command::Converge(args) => match converge::run_converge(&args) {
            Ok(true) => Ok(()),
            Ok(false) => return EXIT_CHECK_FAILED,
            Err(e) => Err(e),
        },
        Command::Info(args) => info::run(&args),
        Command::Gen(args) => gen::run(&args),
        Command::Diff(args) => diff::run(&args),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            if e.downcast_ref::<UsageError>().is_some() {
                EXIT_USAGE
            } else if e.downcast_ref::<reference::Interrupted>().is_some() {
                EXIT_INTERRUPTED
            } else if e.downcast_ref::<crate::scene::LoadError>().is_some()
                || e.downcast_ref::<crate::scene::EnvironmentError>().is_some()
                || e.downcast_ref::<BadInput>().is_some()
            {
                EXIT_BAD_INPUT
            } else {
                EXIT_FAILURE
            }
        }
    }
}

/// An error and its causes joined by ": ", leaving out a cause whose text the message already
/// ends with (many errors print their source as part of their own text).
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !out.ends_with(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
    }
    out
}

/// An input file other than the scene (an image, a reference or its sidecar) that cannot be
/// read, is not what it should be (wrong size, non-finite pixels); exits with code 3 like a bad
/// scene. Holds the whole message, causes included.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

impl BadInput {
    /// Wraps an error (with its causes) as bad input.
    pub fn from_error(e: anyhow::Error) -> anyhow::Error {
        BadInput(message(&e)).into()
    }
}

/// A combination of options clap cannot reject by itself (e.g. a list where one value is
/// expected); exits with code 2 like clap's own usage errors.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);
