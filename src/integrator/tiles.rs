//! The parallel render loop: rayon over 16×16 tiles. Each pixel's numbers are pure functions
//! of (seed, pixel index, dimension, sample index) (see `sampling::sampler`), so the image is
//! bit-identical for any thread count.

use glam::Vec3;
use rayon::prelude::*;

use super::estimator::{Estimator, SampleCounts};
use crate::accel::PACKET;
use crate::color::luminance;
use crate::film::{classify, Film, PixelStats, SampleClass};
use crate::sampling::sampler::{
    draw_together, CameraSample, PacketNumbers, PixelSampler, Sampler, SamplerKind,
};
use crate::scene::{Camera, CameraRays};

const TILE: u32 = 16;

#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Camera samples per pixel, each box-filtered (uniform jitter inside the pixel).
    pub spp: u32,
    pub seed: u64,
    /// Where each camera sample's numbers come from.
    pub sampler: SamplerKind,
    /// Index of this render's first camera sample in each pixel's sequence: a progressive pass
    /// starts where the previous ones ended (0 for a render of its own).
    pub first_sample: u64,
    /// Per-channel upper bound on each finite camera sample's radiance (biased when set).
    pub clamp: Option<f32>,
}

impl RenderOptions {
    /// A `width` × `height` render of `spp` independent samples per pixel from `seed`, starting
    /// at each pixel's first sample, unclamped: change the other fields with struct update syntax.
    pub fn new(width: u32, height: u32, spp: u32, seed: u64) -> RenderOptions {
        RenderOptions {
            width,
            height,
            spp,
            seed,
            sampler: SamplerKind::Independent,
            first_sample: 0,
            clamp: None,
        }
    }
}

/// A camera sample is a firefly when its luminance exceeds this multiple of its pixel's mean
/// luminance over the render.
pub const FIREFLY_FACTOR: f64 = 100.0;

/// What a render did, summed over all pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RenderStats {
    pub camera_samples: u64,
    pub rays: SampleCounts,
    /// Samples with a NaN component, left out of the image.
    pub nan_samples: u64,
    /// Samples with an infinite component, left out of the image.
    pub inf_samples: u64,
    /// Finite camera samples whose luminance exceeds `FIREFLY_FACTOR` × their pixel's mean
    /// luminance (before `--clamp`).
    pub fireflies: u64,
    /// The largest luminance of one finite camera sample (before `--clamp`): the largest
    /// estimator weight f·Le·G / (K·N·p_l·p(x')) the render met, in luminance.
    pub max_sample_luminance: f64,
}

impl RenderStats {
    pub fn add(&mut self, o: &RenderStats) {
        self.camera_samples += o.camera_samples;
        self.rays.add(&o.rays);
        self.nan_samples += o.nan_samples;
        self.inf_samples += o.inf_samples;
        self.fireflies += o.fireflies;
        self.max_sample_luminance = self.max_sample_luminance.max(o.max_sample_luminance);
    }
}

/// Renders the image on the current rayon pool.
pub fn render(estimator: &Estimator, camera: &Camera, opts: &RenderOptions) -> (Film, RenderStats) {
    let (w, h) = (opts.width, opts.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
        .collect();
    let sampler = Sampler::new(
        opts.sampler,
        opts.seed,
        opts.first_sample,
        opts.spp,
        estimator.k,
        estimator.n,
    );
    let camera = camera.rays(w, h);
    let rendered: Vec<(Vec<PixelStats>, RenderStats)> = tiles
        .par_iter()
        .map(|&(tx, ty)| render_tile(estimator, &camera, opts, &sampler, tx, ty))
        .collect();

    // On huge pages: the tiles' rows land far apart, and a process that renders again (`bench`,
    // progressive passes) maps the film anew each time, where small pages would take a fault per
    // 4 KiB (the town's 128×128 frame in `cargo bench --bench render`: 2.4 → 2.6 ms without).
    let mut film = Film {
        width: w,
        height: h,
        pixels: crate::alloc::on_huge_pages(|| vec![PixelStats::default(); (w * h) as usize]),
    };
    let mut stats = RenderStats::default();
    for (&(tx, ty), (pixels, tile_stats)) in tiles.iter().zip(&rendered) {
        stats.add(tile_stats);
        let mut it = pixels.iter();
        for y in ty * TILE..((ty + 1) * TILE).min(h) {
            for x in tx * TILE..((tx + 1) * TILE).min(w) {
                film.pixels[(y * w + x) as usize] = *it.next().expect("tile holds its pixels");
            }
        }
    }
    (film, stats)
}

fn render_tile(
    estimator: &Estimator,
    camera: &CameraRays,
    opts: &RenderOptions,
    sampler: &Sampler,
    tx: u32,
    ty: u32,
) -> (Vec<PixelStats>, RenderStats) {
    let (w, h) = (opts.width, opts.height);
    let mut tile = TileSums {
        pixels: Vec::with_capacity((TILE * TILE) as usize),
        pixel: PixelStats::default(),
        luminances: Vec::with_capacity(opts.spp as usize),
        stats: RenderStats::default(),
    };
    let pixels: Vec<(u32, u32)> = (ty * TILE..((ty + 1) * TILE).min(h))
        .flat_map(|y| (tx * TILE..((tx + 1) * TILE).min(w)).map(move |x| (x, y)))
        .collect();
    let pixel_sampler = |(x, y): (u32, u32)| sampler.pixel(y as u64 * w as u64 + x as u64);
    // Every packet's numbers, drawn into the same storage where K·N > 1.
    let mut numbers = PacketNumbers::new(sampler);
    let spp = opts.spp as usize;
    if spp >= PACKET {
        // A pixel's camera rays go through the BVH PACKET at a time.
        for &(x, y) in &pixels {
            let pixel_sampler = pixel_sampler((x, y));
            for first in (0..opts.spp).step_by(PACKET) {
                let count = (opts.spp - first).min(PACKET as u32) as usize;
                // Slots past the pixel's last sample are never traced nor read.
                let mut samples = [pixel_sampler.camera_sample(first); PACKET];
                for (i, cs) in samples.iter_mut().enumerate().take(count) {
                    *cs = pixel_sampler.camera_sample(first + i as u32);
                }
                draw_together(&mut samples[..count], &mut numbers);
                let mut rays = [(Vec3::ZERO, Vec3::ZERO); PACKET];
                for (cs, ray) in samples.iter().zip(&mut rays).take(count) {
                    let [jx, jy] = cs.pixel_jitter();
                    *ray = camera.ray(x as f32 + jx, y as f32 + jy);
                }
                tile.shade(estimator, opts, samples, &rays, count, 0);
            }
            tile.end_pixel();
        }
    } else if let Some(group) = PACKET.checked_div(spp) {
        // Fewer samples than a packet holds: the samples of PACKET / spp neighbouring pixels,
        // pixel after pixel, share one walk.
        // The run's pixels' sequences, written over the previous run's in place (entries past
        // the run's last pixel are never read).
        let mut samplers: [PixelSampler; PACKET] = [sampler.pixel(0); PACKET];
        for run in pixels.chunks(group) {
            let count = run.len() * spp;
            for (slot, &pixel) in samplers.iter_mut().zip(run) {
                *slot = pixel_sampler(pixel);
            }
            // Slot i is sample i % spp of the run's pixel i / spp; slots past the run's last
            // sample are never traced nor read.
            let mut samples = [samplers[0].camera_sample(0); PACKET];
            for (i, cs) in samples.iter_mut().enumerate().take(count) {
                *cs = samplers[i / spp].camera_sample((i % spp) as u32);
            }
            draw_together(&mut samples[..count], &mut numbers);
            let mut rays = [(Vec3::ZERO, Vec3::ZERO); PACKET];
            for (i, (cs, ray)) in samples.iter().zip(&mut rays).take(count).enumerate() {
                let (x, y) = run[i / spp];
                let [jx, jy] = cs.pixel_jitter();
                *ray = camera.ray(x as f32 + jx, y as f32 + jy);
            }
            let last_of_pixel = (1..=run.len()).fold(0, |mask, p| mask | 1 << (p * spp - 1));
            tile.shade(estimator, opts, samples, &rays, count, last_of_pixel);
        }
    } else {
        tile.pixels.resize(pixels.len(), PixelStats::default());
    }
    (tile.pixels, tile.stats)
}

/// A tile's finished pixels, the pixel being sampled, and what the render did.
struct TileSums {
    pixels: Vec<PixelStats>,
    pixel: PixelStats,
    /// The current pixel's sample luminances, for counting fireflies once its mean is known.
    luminances: Vec<f32>,
    stats: RenderStats,
}

impl TileSums {
    /// Traces the camera rays of slots 0..count in one packet, then shades and adds each sample
    /// in slot order, so every pixel's sums are the same as one ray at a time. A slot whose bit
    /// is set in `last_of_pixel` ends its pixel.
    #[inline(always)]
    fn shade(
        &mut self,
        estimator: &Estimator,
        opts: &RenderOptions,
        samples: [CameraSample; PACKET],
        rays: &[(Vec3, Vec3); PACKET],
        count: usize,
        last_of_pixel: u32,
    ) {
        // The light choices' cache misses overlap the camera rays' traversal: their first bins
        // are asked for before it, read after it.
        let starts = estimator.prefetch_light_bins(&samples[..count]);
        let mut hits = [None; PACKET];
        estimator
            .accel
            .closest_hits(&rays[..count], &mut hits[..count]);
        let mut first_lights = [None; PACKET];
        if let Some(starts) = &starts {
            estimator.prefetch_lights(&samples[..count], starts, &mut first_lights[..count]);
        }
        estimator.prefetch_hits(&hits[..count]);
        for i in 0..count {
            let stats = &mut self.stats;
            let surface_hits = stats.rays.surface_hits;
            let l = estimator.radiance_from(
                hits[i],
                rays[i].1,
                &samples[i],
                first_lights[i],
                &mut stats.rays,
            );
            stats.camera_samples += 1;
            match classify(l) {
                SampleClass::Finite => {
                    self.luminances.push(luminance(l));
                    let l = opts.clamp.map_or(l, |c| l.min(Vec3::splat(c)));
                    self.pixel.add(l.as_dvec3());
                    self.pixel.surface += stats.rays.surface_hits - surface_hits;
                }
                SampleClass::Nan => stats.nan_samples += 1,
                SampleClass::Infinite => stats.inf_samples += 1,
            }
            if last_of_pixel & 1 << i != 0 {
                self.end_pixel();
            }
        }
    }

    /// Closes the current pixel: counts its fireflies and keeps its statistics.
    fn end_pixel(&mut self) {
        count_fireflies(&self.luminances, &mut self.stats);
        self.luminances.clear();
        self.pixels.push(std::mem::take(&mut self.pixel));
    }
}

/// Adds one pixel's fireflies (luminance > FIREFLY_FACTOR × the pixel's mean, f64) and its
/// largest sample luminance to `stats`.
fn count_fireflies(luminances: &[f32], stats: &mut RenderStats) {
    if luminances.is_empty() {
        return;
    }
    let mean = luminances.iter().map(|&l| l as f64).sum::<f64>() / luminances.len() as f64;
    let threshold = FIREFLY_FACTOR * mean;
    for &l in luminances {
        let l = l as f64;
        stats.max_sample_luminance = stats.max_sample_luminance.max(l);
        if mean > 0.0 && l > threshold {
            stats.fireflies += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::{PreparedScene, Strategy};
    use crate::scene::{load_gltf, CameraChoice};
    use crate::select::SelectorKind;

    /// Rays traced in packets (a pixel's eight at a time, or several pixels' when spp < 8),
    /// with their light choices prefetched (power selector) and their independent or Sobol
    /// numbers drawn together, give every pixel exactly the sums of tracing and shading its
    /// samples one at a time, each making its own numbers.
    #[test]
    fn packets_give_the_pixels_of_one_ray_at_a_time() {
        for kind in [SelectorKind::Bvh, SelectorKind::Power] {
            for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
                packets_match_single_rays(kind, sampler);
            }
        }
    }

    fn packets_match_single_rays(kind: SelectorKind, sampler: SamplerKind) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
        let scene = load_gltf(&path, &CameraChoice::default()).unwrap();
        let camera = scene.camera.clone().unwrap();
        let prepared = PreparedScene::new(scene, kind);
        let estimator = prepared.estimator(Strategy::Mis, 1, 1);
        for spp in [1, 3, 8, 11] {
            let opts = RenderOptions {
                sampler,
                ..RenderOptions::new(19, 13, spp, 5)
            };
            let (film, stats) = render(&estimator, &camera, &opts);
            let sampler = Sampler::new(opts.sampler, opts.seed, 0, spp, 1, 1);
            let mut counts = SampleCounts::default();
            for y in 0..opts.height {
                for x in 0..opts.width {
                    let pixel_sampler = sampler.pixel((y * opts.width + x) as u64);
                    let mut pixel = PixelStats::default();
                    for s in 0..spp {
                        let cs = pixel_sampler.camera_sample(s);
                        let [jx, jy] = cs.pixel_jitter();
                        let (o, d) = camera.ray(x as f32 + jx, y as f32 + jy, 19, 13);
                        let before = counts.surface_hits;
                        let l = estimator.radiance(o, d, &cs, &mut counts);
                        pixel.add(l.as_dvec3());
                        pixel.surface += counts.surface_hits - before;
                    }
                    assert_eq!(
                        film.pixels[(y * opts.width + x) as usize],
                        pixel,
                        "spp {spp}, {sampler:?}"
                    );
                }
            }
            assert_eq!(stats.rays, counts, "spp {spp}, {sampler:?}");
        }
    }
}
