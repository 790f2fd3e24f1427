//! `manylights gen NAME -o FILE.glb|.gltf [--lights N] [--seed S]`: write a built-in scene as
//! glTF 2.0, or `manylights gen sky -o FILE.exr`: the sun-and-sky environment map. `--lights`
//! counts emissive triangles; each generator states which counts it takes, and any other is a
//! usage error (exit 2).

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::output::check_output_path;
use super::UsageError;
use crate::gen::gltf_write::GltfBuilder;
use crate::gen::{generate, sky};
use crate::image::write_exr;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SceneName {
    /// A Cornell-like box lit by one ceiling quad (2 emissive triangles); with --lights N the
    /// quad is cut into N ≥ 2 triangles of varied radiance (0.1× … 10×).
    Cornell,
    /// A night town: box buildings and thousands of small emissive quads over 5 decades of
    /// radiance (default 12,000 lights, rounded up to even).
    Town,
    /// A night city: lit windows, street lamps and neon strips over 8 decades, most hidden
    /// from most points (exactly --lights emissive triangles, default 50,000, up to 2,000,000).
    City,
    /// n × n equal quads over a floor: --lights = 2·n² (default 8,192 = 2·64²); uniform
    /// selection is optimal.
    Grid,
    /// Numerical extremes, one per open box (a fixed set of 17 emissive triangles; no --lights).
    Extremes,
    /// A ceiling panel with a mostly black emissive texture: --lights = 2·n² triangles
    /// (default 512 = 2·16²).
    Textured,
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
    /// Emissive triangles (see each scene for the counts it takes).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=2_000_000))]
    pub lights: Option<u32>,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: &GenArgs) -> anyhow::Result<()> {
    if args.name == SceneName::Sky {
        if args.lights.is_some() {
            return Err(UsageError("gen sky: an environment map has no --lights".into()).into());
        }
        check_output_path(&args.output, "exr")?;
        write_exr(&args.output, &sky::sun_and_sky(256, 128), None)?;
        println!("wrote {}", args.output.display());
        return Ok(());
    }
    let is_gltf = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
    check_output_path(&args.output, if is_gltf { "gltf" } else { "glb" })?;
    let builder = build(args.name, args.lights.map(|n| n as usize), args.seed)?;
    builder.write(&args.output)?;
    println!("wrote {}", args.output.display());
    Ok(())
}

/// The scene `name` with `lights` emissive triangles (None: its default), or a usage error
/// naming the counts it accepts.
pub fn build(name: SceneName, lights: Option<usize>, seed: u64) -> anyhow::Result<GltfBuilder> {
    let usage = |what: String| UsageError(format!("gen {}: {what}", scene_label(name)));
    let square = |lights: usize, side: fn(usize) -> Option<usize>| {
        side(lights).ok_or_else(|| {
            let n = ((lights / 2) as f64).sqrt().floor().max(1.0) as usize;
            usage(format!(
                "--lights {lights} is not 2·n² (n × n quads of 2 triangles); nearest: {} or {}",
                2 * n * n,
                2 * (n + 1) * (n + 1)
            ))
        })
    };
    Ok(match name {
        SceneName::Cornell => match lights {
            None => generate::cornell(),
            Some(1) => return Err(usage("the split light needs --lights ≥ 2".into()).into()),
            Some(n) => generate::cornell_split(n, seed),
        },
        SceneName::Town => generate::many_lights(seed, lights.unwrap_or(12_000)),
        SceneName::City => generate::city(lights.unwrap_or(50_000), seed),
        SceneName::Grid => generate::grid(square(lights.unwrap_or(8_192), generate::grid_side)?),
        SceneName::Extremes => match lights {
            None => generate::extremes(),
            Some(_) => return Err(usage("has a fixed set of lights; drop --lights".into()).into()),
        },
        SceneName::Textured => {
            let n = square(lights.unwrap_or(512), generate::textured_side)?;
            generate::textured(n, seed)
        }
        SceneName::Outdoor => match lights {
            None => sky::outdoor(),
            Some(_) => return Err(usage("has one lamp; drop --lights".into()).into()),
        },
        SceneName::Sky => {
            return Err(
                usage("is an environment map, not a glTF scene (-o FILE.exr)".into()).into(),
            )
        }
    })
}

/// The scene's name as typed on the command line.
fn scene_label(name: SceneName) -> String {
    name.to_possible_value()
        .map_or_else(|| format!("{name:?}"), |v| v.get_name().to_owned())
}
