//! `manylights render SCENE -o OUT.exr`: render direct lighting and print one summary.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use serde::Serialize;

use super::options::{check_resolution, finite, RenderOptionsArgs, RENDER_DEFAULTS};
use super::output::check_output_path;
use crate::image::{write_atomically, write_exr, write_png_preview, RgbImage};
use crate::integrator::{render, PreparedScene, RenderOptions, RenderStats, Strategy};
use crate::measure::cpu_time::{cpu_seconds_between, process_cpu_seconds};
use crate::measure::{camera_or_framing, EstimatorChoice};
use crate::sampling::sampler::SamplerKind;
use crate::scene::load_gltf_allowing;
use crate::select::SelectorKind;

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub options: RenderOptionsArgs,
    /// Output OpenEXR file (float32 RGB of the per-pixel mean).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Add the per-pixel variance of the mean as channels variance.R/G/B.
    #[arg(long)]
    pub variance: bool,
    /// Also write a tone-mapped sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite)]
    pub exposure: f32,
    /// Also write this summary as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Seconds spent in each stage (wall clock), and the CPU seconds of the render stage.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timings {
    pub load: f64,
    pub bvh_build: f64,
    pub light_build: f64,
    /// The part of `light_build` spent on the selector (light tree or alias table), after the
    /// lights themselves were made.
    pub selector_build: f64,
    pub render: f64,
    pub write: f64,
    /// CPU seconds the process used while rendering, user and system, all threads (None where
    /// the system does not say): unlike `render`, it does not grow while other jobs hold the
    /// cores.
    pub render_cpu: Option<f64>,
    /// CPU seconds the whole process had used when the images were written (start-up, load,
    /// builds, render, write; user and system, all threads): what a whole-process measure such
    /// as `/usr/bin/time` counts, but for the exit. `render_cpu` of it is the render's.
    pub process_cpu: Option<f64>,
}

/// What `render` prints, and writes with `--json`.
#[derive(Clone, Debug, Serialize)]
pub struct RenderSummary {
    pub scene: PathBuf,
    pub output: PathBuf,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub k: u32,
    pub n: u32,
    /// RIS candidates per K×N slot (1 for strategies that do not resample).
    pub m: u32,
    pub selector: SelectorKind,
    /// `bvh`'s far-lane sine (`--far-sin`; None for the other selectors).
    pub far_sin: Option<f32>,
    pub strategy: Strategy,
    pub sampler: SamplerKind,
    pub seed: u64,
    /// Per-channel clamp of each camera sample (None: unbiased).
    pub clamp: Option<f32>,
    pub biased: bool,
    pub threads: usize,
    pub triangles: usize,
    pub lights: usize,
    /// The `--env` map lighting the scene (one of the lights), with its scale and rotation.
    pub environment: Option<EnvironmentSummary>,
    pub degenerate_triangles: usize,
    pub total_power: f64,
    /// Heap bytes of the light-selection structure.
    pub selector_bytes: usize,
    pub seconds: Timings,
    pub stats: RenderStats,
    pub rays_total: u64,
    pub rays_per_second: f64,
    pub camera_samples_per_second: f64,
    /// CPU microseconds per camera sample in the render stage (`seconds.render_cpu`).
    pub cpu_us_per_camera_sample: Option<f64>,
    pub image_mean: f64,
}

/// The environment map of a render.
#[derive(Clone, Debug, Serialize)]
pub struct EnvironmentSummary {
    pub file: PathBuf,
    pub width: usize,
    pub height: usize,
    pub scale: f32,
    pub rotate_degrees: f32,
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    check_output_path(&args.output, "exr")?;
    if let Some(p) = &args.png {
        check_output_path(p, "png")?;
    }
    if let Some(p) = &args.json {
        check_output_path(p, "json")?;
    }
    let choice = args.options.estimator(&RENDER_DEFAULTS)?;
    let spp = args.options.single_spp(&RENDER_DEFAULTS)?;
    let pool = args.options.thread_pool()?;
    let summary = pool.install(|| render_scene(args, choice, spp))?;
    print_summary(&summary);
    if let Some(path) = &args.json {
        write_atomically(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &summary)?;
            writeln!(w)?;
            Ok(())
        })?;
    }
    Ok(())
}

fn render_scene(
    args: &RenderArgs,
    choice: EstimatorChoice,
    spp: u32,
) -> anyhow::Result<RenderSummary> {
    let o = &args.options;
    let mut seconds = Timings::default();
    o.check_given_resolution()?;
    let t = Instant::now();
    let scene = load_gltf_allowing(
        &o.scene,
        &o.camera.clone().unwrap_or_default(),
        &o.load_policy(),
    )?
    .with_punctual_units(o.punctual_units)
    .with_environment(o.environment()?);
    seconds.load = t.elapsed().as_secs_f64();

    let camera = camera_or_framing(&scene, &o.scene, o.width, o.height);
    let (width, height) = camera.resolution(o.width, o.height);
    check_resolution(width, height)?;

    let prepared = PreparedScene::new_with(scene, choice.selector, choice.far_sin);
    seconds.bvh_build = prepared.bvh_seconds;
    seconds.light_build = prepared.light_seconds;
    seconds.selector_build = prepared.selector_seconds;
    warn_skipped_primitives(&prepared.scene.stats, &o.scene);
    if prepared.lights.is_empty() {
        eprintln!(
            "note: {} has no lights: only black will be rendered",
            o.scene.display()
        );
    }
    let estimator = prepared
        .estimator(choice.strategy, choice.k, choice.n)
        .with_candidates(choice.m);
    let opts = RenderOptions {
        width,
        height,
        spp,
        seed: o.seed,
        sampler: choice.sampler,
        first_sample: 0,
        clamp: o.clamp,
    };
    let (t, cpu) = (Instant::now(), process_cpu_seconds());
    let (film, stats) = render(&estimator, &camera, &opts);
    seconds.render = t.elapsed().as_secs_f64();
    seconds.render_cpu = cpu_seconds_between(cpu, process_cpu_seconds());

    let t = Instant::now();
    let mean = RgbImage {
        width: width as usize,
        height: height as usize,
        pixels: film.mean_rgb(),
    };
    let variance = args.variance.then(|| RgbImage {
        width: width as usize,
        height: height as usize,
        pixels: film.variance_of_mean_rgb(),
    });
    write_exr(&args.output, &mean, variance.as_ref())?;
    if let Some(png) = &args.png {
        write_png_preview(png, &mean, args.exposure)?;
    }
    seconds.write = t.elapsed().as_secs_f64();
    seconds.process_cpu = process_cpu_seconds();

    let rays_total = stats.rays.total_rays();
    Ok(RenderSummary {
        scene: o.scene.clone(),
        output: args.output.clone(),
        width,
        height,
        spp,
        k: choice.k,
        n: choice.n,
        m: choice.m,
        selector: choice.selector,
        far_sin: (choice.selector == SelectorKind::Bvh).then_some(choice.far_sin),
        strategy: choice.strategy,
        sampler: choice.sampler,
        seed: o.seed,
        clamp: o.clamp,
        biased: o.clamp.is_some(),
        threads: rayon::current_num_threads(),
        triangles: prepared.scene.triangles.len(),
        lights: prepared.lights.len(),
        environment: prepared.scene.environment.as_ref().and_then(|image| {
            Some(EnvironmentSummary {
                file: o.env.clone()?,
                width: image.width(),
                height: image.height(),
                scale: o.env_scale,
                rotate_degrees: o.env_rotate,
            })
        }),
        degenerate_triangles: prepared.scene.stats.degenerate_triangles,
        total_power: prepared.lights.total_power(),
        selector_bytes: prepared.selector.as_ref().map_or(0, |s| s.bytes()),
        rays_total,
        rays_per_second: rays_total as f64 / seconds.render,
        camera_samples_per_second: stats.camera_samples as f64 / seconds.render,
        cpu_us_per_camera_sample: seconds
            .render_cpu
            .map(|cpu| 1e6 * cpu / stats.camera_samples.max(1) as f64),
        image_mean: film.image_mean(),
        seconds,
        stats,
    })
}

fn print_summary(s: &RenderSummary) {
    let mega = |x: f64| x / 1e6;
    println!(
        "scene     {}: {} triangles ({} degenerate skipped), {} lights, total power {:.4e} W",
        s.scene.display(),
        s.triangles,
        s.degenerate_triangles,
        s.lights,
        s.total_power
    );
    let far = s
        .far_sin
        .map_or(String::new(), |f| format!(" (far lanes below sin {f})"));
    println!(
        "image     {}x{}, {} spp, K x N = {} x {}, M = {}, selector {:?}{far}, strategy {:?}, sampler {:?}, seed {}, {} threads",
        s.width, s.height, s.spp, s.k, s.n, s.m, s.selector, s.strategy, s.sampler, s.seed, s.threads
    );
    if let Some(e) = &s.environment {
        println!(
            "sky       {} ({}x{}), scale {}, turned {}° about +Y",
            e.file.display(),
            e.width,
            e.height,
            e.scale,
            e.rotate_degrees
        );
    }
    if let Some(c) = s.clamp {
        println!("clamp     each sample clamped to {c} per channel (biased)");
    }
    let t = &s.seconds;
    println!(
        "seconds   load {:.3}  bvh build {:.3}  light build {:.3} (selector {:.3})  render {:.3}  \
         write {:.3}",
        t.load, t.bvh_build, t.light_build, t.selector_build, t.render, t.write
    );
    let r = &s.stats.rays;
    println!(
        "rays      {:.3} M (camera {:.3} M, shadow {:.3} M, bounce {:.3} M), {:.3} M rays/s",
        mega(s.rays_total as f64),
        mega(r.camera_rays as f64),
        mega(r.shadow_rays as f64),
        mega(r.bounce_rays as f64),
        mega(s.rays_per_second)
    );
    println!(
        "samples   {:.3} M camera samples, {:.3} M camera samples/s; image mean {:.6}",
        mega(s.stats.camera_samples as f64),
        mega(s.camera_samples_per_second),
        s.image_mean
    );
    if let (Some(cpu), Some(per_sample)) = (t.render_cpu, s.cpu_us_per_camera_sample) {
        let process = t
            .process_cpu
            .map_or(String::new(), |p| format!("; the whole process {p:.3} s"));
        println!(
            "cpu       render {cpu:.3} s on {} threads, {per_sample:.3} µs per camera \
             sample{process}",
            s.threads
        );
    }
    if r.spherical_samples + r.area_samples > 0 {
        println!(
            "triangle  {} solid-angle samples, {} area samples",
            r.spherical_samples, r.area_samples
        );
    }
    if s.selector_bytes > 0 {
        println!(
            "selection {} bytes ({:.1} B per light)",
            s.selector_bytes,
            s.selector_bytes as f64 / s.lights.max(1) as f64
        );
    }
    println!(
        "nan/inf   {} NaN, {} Inf samples (left out of the image)",
        s.stats.nan_samples, s.stats.inf_samples
    );
    println!(
        "fireflies {} samples above {}× their pixel's mean; largest sample luminance {:.4e}",
        s.stats.fireflies,
        crate::integrator::FIREFLY_FACTOR,
        s.stats.max_sample_luminance
    );
    println!("wrote     {}", s.output.display());
}

/// Says on stderr which primitives were left out for having no area (points, lines), so that
/// missing geometry is never silent.
pub fn warn_skipped_primitives(stats: &crate::scene::LoadStats, scene: &std::path::Path) {
    if stats.skipped_primitives == 0 {
        return;
    }
    let more = stats.skipped_primitives - stats.skipped_primitive_names.len();
    let more = if more > 0 {
        format!(" and {more} more")
    } else {
        String::new()
    };
    eprintln!(
        "warning: {} has {} primitive(s) without area, not rendered: {}{more}",
        scene.display(),
        stats.skipped_primitives,
        stats.skipped_primitive_names.join(", ")
    );
}
