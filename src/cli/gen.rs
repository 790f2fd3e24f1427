//! `manylights gen NAME -o FILE.glb|.gltf`: write a built-in scene as glTF 2.0.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::output::check_output_path;
use crate::scene::generate;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SceneName {
    /// A Cornell-like box lit by one ceiling quad (2 emissive triangles).
    Cornell,
    /// A night town: box buildings and thousands of small emissive quads over 5 decades of radiance.
    Town,
}

#[derive(Args, Debug)]
pub struct GenArgs {
    pub name: SceneName,
    /// Output file: .glb (binary) or .gltf (JSON with an embedded buffer).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Emissive triangles to aim for (town only).
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u32).range(2..=2_000_000))]
    pub lights: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: &GenArgs) -> anyhow::Result<()> {
    let is_gltf = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
    check_output_path(&args.output, if is_gltf { "gltf" } else { "glb" })?;
    let builder = match args.name {
        SceneName::Cornell => generate::cornell(),
        SceneName::Town => generate::many_lights(args.seed, args.lights as usize),
    };
    builder.write(&args.output)?;
    println!("wrote {}", args.output.display());
    Ok(())
}
