//! `manylights gen NAME -o FILE.glb|.gltf`: write a built-in scene as glTF 2.0, or
//! `manylights gen sky -o FILE.exr`: the sun-and-sky environment map.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::render::check_output_path;
use crate::image::write_exr;
use crate::scene::{generate, generate_sky};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SceneName {
    /// A Cornell-like box lit by one ceiling quad (2 emissive triangles).
    Cornell,
    /// A night town: box buildings and thousands of small emissive quads over 5 decades of radiance.
    Town,
    /// Boxes on a ground plane with one small lamp, for an environment map (--env).
    Outdoor,
    /// A 256×128 equirectangular sun-and-sky environment map (OpenEXR, -o FILE.exr).
    Sky,
}

#[derive(Args, Debug)]
pub struct GenArgs {
    pub name: SceneName,
    /// Output file: .glb (binary) or .gltf (JSON with an embedded buffer); .exr for sky.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Emissive triangles to aim for (town only).
    #[arg(long, default_value_t = 12_000, value_parser = clap::value_parser!(u32).range(2..=2_000_000))]
    pub lights: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: &GenArgs) -> anyhow::Result<()> {
    let builder = match args.name {
        SceneName::Cornell => generate::cornell(),
        SceneName::Town => generate::many_lights(args.seed, args.lights as usize),
        SceneName::Outdoor => generate_sky::outdoor(),
        SceneName::Sky => {
            check_output_path(&args.output, "exr")?;
            write_exr(&args.output, &generate_sky::sun_and_sky(256, 128), None)?;
            println!("wrote {}", args.output.display());
            return Ok(());
        }
    };
    builder.write(&args.output)?;
    println!("wrote {}", args.output.display());
    Ok(())
}
