//! Sample sequences: where every number a camera sample consumes comes from.
//!
//! A number is a pure function of (seed, pixel, dimension, sample index): no state is carried
//! from one sample to the next, so the image is the same for any thread count and a render can
//! continue the sequence of an earlier one (progressive passes). Each pixel's sequences are
//! scrambled or permuted with seeds hashed from (seed, pixel, dimension), so pixels are
//! decorrelated; every point is uniform on [0,1)^d, so every sampler is unbiased.
//!
//! # Dimension layout
//!
//! For camera sample s < spp of a render whose first camera sample is F (S = F + s), light slot
//! k < K, point n < N on that light, and BSDF slot j < K·N:
//!
//! | dims | consumed by                               | index            | points per render |
//! |------|-------------------------------------------|------------------|-------------------|
//! | 0, 1 | pixel jitter                              | S                | spp               |
//! | 2    | light choice (53 bits)                    | S·K + k          | spp·K             |
//! | 3, 4 | point on the chosen light                 | (S·K + k)·N + n  | spp·K·N           |
//! | 5    | BSDF lobe                                 | S·K·N + j        | spp·K·N           |
//! | 6, 7 | BSDF or hemisphere direction              | S·K·N + j        | spp·K·N           |
//!
//! So the K×N samples of one camera sample are distinct points of one well-distributed set per
//! dimension group. Sobol reads the lobe (dim 5) as the third coordinate of the direction's
//! point, and with N = 1 the light choice (dim 2) as the third coordinate of the point on the
//! light: a discrete choice and the continuous sample it leads to then share one 3D point, so
//! their interaction is integrated at the quasi-Monte Carlo rate too (padding them apart
//! leaves an MSE ∝ 1/spp term). An environment light chosen as one of the K lights takes its direction
//! from dims 3, 4 like a point on any other light.
//!
//! Sequences (independent, halton, sobol) index by the absolute S, so a progressive pass that
//! starts at F = the samples already rendered continues the same sequence. Stratified and LHS
//! stratify each render's own points (index s·… relative to the render, over the count in the
//! last column), with permutations seeded by F as well: every pass is its own stratified set.
//!
//! Where the sampler is independent or Sobol, on a CPU with AVX2, a packet's camera samples have
//! their numbers drawn together in AVX2 lanes (`drawn` where K = N = 1, `packet` for up to 16
//! slots), the same bits as one at a time.
//!
//! The 32-bit sequences give 24-bit f32 coordinates; the light choice, which may pick among
//! millions of lights, appends 21 hashed random bits to the sequence's 32 to fill an f64
//! mantissa, so the choice stays exactly uniform.

mod drawn;
mod halton;
#[cfg(target_arch = "x86_64")]
mod hash_avx2;
mod independent;
mod lhs;
mod packet;
mod scramble;
mod sobol;
#[cfg(target_arch = "x86_64")]
mod sobol_avx2;
mod stratified;

pub use drawn::draw_together;
use drawn::Drawn;
use packet::Lane;
pub use packet::PacketNumbers;

use scramble::{hash, subseed};
use sobol::Reversed;

/// The dimension layout (see the module doc): the first dimension of each group.
const PIXEL: u64 = 0;
const LIGHT_CHOICE: u64 = 2;
const LIGHT_POINT: u64 = 3;
const BSDF_LOBE: u64 = 5;
const BSDF_DIRECTION: u64 = 6;
/// Dimensions in the layout (0 ..= 7).
const DIMENSIONS: usize = 8;

/// Where a camera sample's numbers come from.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum SamplerKind {
    /// Independent uniform numbers (plain Monte Carlo: MSE ∝ 1/spp).
    #[default]
    Independent,
    /// Jittered strata: each point in its own interval (1D) or grid cell (2D) of the render's
    /// points.
    Stratified,
    /// Latin hypercube (N-rooks): each coordinate stratified on its own.
    Lhs,
    /// Owen-scrambled Halton: a prime base per dimension.
    Halton,
    /// Owen-scrambled Sobol, padded 2D/3D groups with shuffled indices (Burley 2020).
    Sobol,
}

/// A render's sampler: the kind, the seed and the counts its stratification needs.
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    kind: SamplerKind,
    seed: u64,
    first_sample: u64,
    spp: u64,
    k: u64,
    n: u64,
    /// Whether the CPU has AVX2 and FMA (`has_avx2_fma`; a packet's numbers are then drawn
    /// together: `drawn`, `packet`).
    avx2: bool,
}

impl Sampler {
    /// Camera samples `first_sample .. first_sample + spp` of every pixel, each with K lights of
    /// N points (or K·N BSDF or hemisphere directions).
    pub fn new(kind: SamplerKind, seed: u64, first_sample: u64, spp: u32, k: u32, n: u32) -> Self {
        Sampler {
            kind,
            seed,
            first_sample,
            spp: spp as u64,
            k: k as u64,
            n: n as u64,
            avx2: crate::cpu::has_avx2_fma(),
        }
    }

    /// The sequences of pixel `pixel` (row-major index).
    pub fn pixel(&self, pixel: u64) -> PixelSampler {
        let key = hash(self.seed, pixel);
        let key = match self.kind {
            SamplerKind::Stratified | SamplerKind::Lhs => hash(key, !self.first_sample),
            _ => key,
        };
        PixelSampler {
            sampler: *self,
            seeds: std::array::from_fn(|dim| subseed(key, dim as u64)),
        }
    }
}

/// One pixel's sequences.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    sampler: Sampler,
    /// Each dimension's scrambling seed, derived once per pixel from its key.
    seeds: [u64; DIMENSIONS],
}

/// Point `slot` of camera sample s in a dimension group with `per_sample` points per camera
/// sample: its seed, index within the render (`local` of `count`) and absolute index.
struct Point {
    dim: u64,
    seed: u64,
    local: u64,
    count: u64,
    absolute: u64,
}

impl PixelSampler {
    /// Camera sample `s` (0 ≤ s < spp) of this render.
    #[inline]
    pub fn camera_sample(&self, s: u32) -> CameraSample<'_> {
        debug_assert!((s as u64) < self.sampler.spp);
        CameraSample {
            pixel: self,
            s: s as u64,
            source: Source::Alone,
        }
    }

    #[inline]
    fn point(&self, dim: u64, per_sample: u64, s: u64, slot: u64) -> Point {
        debug_assert!(slot < per_sample);
        let sm = &self.sampler;
        Point {
            dim,
            seed: self.seeds[dim as usize],
            local: s * per_sample + slot,
            count: sm.spp * per_sample,
            absolute: self.absolute(per_sample, s, slot),
        }
    }

    /// The absolute index of point `slot` of camera sample s in a group with `per_sample`
    /// points per camera sample (`Point::absolute`), for the independent and Sobol samplers,
    /// which need nothing else of the point.
    #[inline(always)]
    fn absolute(&self, per_sample: u64, s: u64, slot: u64) -> u64 {
        (self.sampler.first_sample + s) * per_sample + slot
    }

    /// One coordinate of point `slot` of camera sample s in dimension `dim` (see `point`), as a
    /// fraction of 2^32. The independent sampler's one hash is inlined into every caller, from
    /// the index and seed alone; the sequences stay out of line with the whole `Point`, built
    /// only on their branch, so the hot path carries no call and no stores.
    #[inline(always)]
    fn get_1d(&self, dim: u64, per_sample: u64, s: u64, slot: u64) -> u32 {
        if self.sampler.kind == SamplerKind::Independent {
            let index = self.absolute(per_sample, s, slot);
            return independent::sample_1d(index, self.seeds[dim as usize]);
        }
        self.get_1d_sequence(&self.point(dim, per_sample, s, slot))
    }

    #[inline(never)]
    fn get_1d_sequence(&self, p: &Point) -> u32 {
        match self.sampler.kind {
            SamplerKind::Independent => independent::sample_1d(p.absolute, p.seed),
            SamplerKind::Stratified | SamplerKind::Lhs => {
                stratified::sample_1d(p.local, p.count, p.seed)
            }
            SamplerKind::Halton => {
                halton::sample(p.absolute, halton::PRIMES[p.dim as usize], p.seed)
            }
            SamplerKind::Sobol => sobol::sample_1d(p.absolute, p.seed).bits(),
        }
    }

    /// Two coordinates (dims `dim`, `dim + 1`) in [0, 1) (`to_f32` of their 32-bit fractions):
    /// inlined for the independent and Sobol samplers, the other sequences through
    /// `get_2d_sequence`.
    #[inline(always)]
    fn get_2d(&self, dim: u64, per_sample: u64, s: u64, slot: u64) -> [f32; 2] {
        let index = self.absolute(per_sample, s, slot);
        match self.sampler.kind {
            SamplerKind::Independent => {
                independent::sample_2d(index, self.seeds[dim as usize]).map(to_f32)
            }
            SamplerKind::Sobol => {
                sobol::sample_2d(index, self.seeds[dim as usize]).map(Reversed::unit)
            }
            _ => self
                .get_2d_sequence(&self.point(dim, per_sample, s, slot))
                .map(to_f32),
        }
    }

    /// `get_2d` out of line, for any sampler (`get_2d` itself takes the independent and Sobol
    /// samplers).
    #[inline(never)]
    fn get_2d_sequence(&self, p: &Point) -> [u32; 2] {
        match self.sampler.kind {
            SamplerKind::Independent => independent::sample_2d(p.absolute, p.seed),
            SamplerKind::Stratified => stratified::sample_2d(p.local, p.count, p.seed),
            SamplerKind::Lhs => lhs::sample_2d(p.local, p.count, p.seed),
            SamplerKind::Halton => {
                let base = |d: u64| halton::PRIMES[d as usize];
                [
                    halton::sample(p.absolute, base(p.dim), p.seed),
                    halton::sample(p.absolute, base(p.dim + 1), self.seeds[p.dim as usize + 1]),
                ]
            }
            SamplerKind::Sobol => sobol::sample_2d(p.absolute, p.seed).map(Reversed::bits),
        }
    }
}

/// BSDF slot j's numbers ([`CameraSample::bsdf_numbers`]).
#[derive(Clone, Copy, Debug)]
pub struct BsdfNumbers {
    /// Chooses the lobe.
    pub lobe: f32,
    /// Places the direction within the lobe.
    pub direction: [f32; 2],
    /// `direction` warped to the cosine-weighted hemisphere, where the packet's numbers were
    /// drawn together.
    drawn_cosine: Option<glam::Vec3>,
}

impl BsdfNumbers {
    /// `direction` warped to the cosine-weighted hemisphere (`warp::cosine_hemisphere`).
    #[inline]
    pub fn cosine_direction(&self) -> glam::Vec3 {
        self.drawn_cosine
            .unwrap_or_else(|| crate::sampling::warp::cosine_hemisphere(self.direction))
    }
}

/// The numbers of one camera sample, by use (see the layout in the module doc).
#[derive(Clone, Copy)]
pub struct CameraSample<'a> {
    pixel: &'a PixelSampler,
    s: u64,
    /// Where its numbers come from.
    source: Source<'a>,
}

/// Where a camera sample's numbers come from ([`draw_together`]).
#[derive(Clone, Copy)]
enum Source<'a> {
    /// Made one at a time, as they are asked for.
    Alone,
    /// Drawn with its packet's, K = N = 1: all of them kept here.
    Drawn(Drawn),
    /// Drawn with its packet's, K·N > 1: its lane of the packet's numbers.
    Packet(Lane<'a>),
}

/// 2^-53: a 53-bit integer times this is a fraction in [0, 1).
const TO_UNIT_53: f64 = 1.0 / 9_007_199_254_740_992.0;

/// A fraction of 2^32 as an f32 in [0, 1) with 24 bits (never 1.0).
#[inline]
fn to_f32(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A fraction in [0, 1) with the 53 high bits of a 64-bit hash (the independent sampler's light
/// choice).
#[inline(always)]
fn unit_53(h: u64) -> f64 {
    (h >> 11) as f64 * TO_UNIT_53
}

/// A sequence's 32-bit coordinate `high` of point `index` (group seed `seed`) extended to a
/// fraction in [0, 1) with 53 bits: 21 low bits hashed from the seed and index.
#[inline(always)]
fn with_hashed_bits(high: u32, seed: u64, index: u64) -> f64 {
    let low = hash(seed ^ 0xa076_1d64_78bd_642f, index) >> 43;
    ((u64::from(high) << 21) | low) as f64 * TO_UNIT_53
}

impl CameraSample<'_> {
    /// The point inside the pixel, in [0,1)².
    #[inline]
    pub fn pixel_jitter(&self) -> [f32; 2] {
        match &self.source {
            Source::Drawn(d) => return d.jitter,
            Source::Packet(lane) => return lane.jitter(),
            Source::Alone => {}
        }
        self.pixel.get_2d(PIXEL, 1, self.s, 0)
    }

    /// The number that chooses light slot k's light, in [0, 1) with 53 bits.
    #[inline(always)]
    pub fn light_choice(&self, k: u32) -> f64 {
        if let (Source::Drawn(d), 0) = (&self.source, k) {
            return d.light_choice;
        }
        if let Source::Packet(lane) = &self.source {
            return lane.light_choice(k);
        }
        let sm = &self.pixel.sampler;
        if sm.kind == SamplerKind::Independent {
            let index = self.pixel.absolute(sm.k, self.s, k as u64);
            let seed = self.pixel.seeds[LIGHT_CHOICE as usize];
            return unit_53(hash(seed, index));
        }
        if sm.kind == SamplerKind::Sobol && sm.n == 1 {
            // The third coordinate of the point on the light (see the module doc), built from
            // the index and seed alone, as `get_2d` does.
            let index = self.pixel.absolute(sm.k, self.s, k as u64);
            let seed = self.pixel.seeds[LIGHT_POINT as usize];
            return with_hashed_bits(sobol::third(index, seed).bits(), seed, index);
        }
        self.sequence_light_choice(k)
    }

    /// `light_choice` for the other sequences: dimension 2's 32 bits and 21 hashed ones.
    #[inline(never)]
    fn sequence_light_choice(&self, k: u32) -> f64 {
        let sm = &self.pixel.sampler;
        let p = self.pixel.point(LIGHT_CHOICE, sm.k, self.s, k as u64);
        with_hashed_bits(self.pixel.get_1d_sequence(&p), p.seed, p.absolute)
    }

    /// The 2D number that places point n on light slot k's light.
    #[inline]
    pub fn light_point(&self, k: u32, n: u32) -> [f32; 2] {
        if let (Source::Drawn(d), 0, 0) = (&self.source, k, n) {
            return d.light_point;
        }
        if let Source::Packet(lane) = &self.source {
            return lane.light_point(k, n);
        }
        let sm = &self.pixel.sampler;
        let slot = k as u64 * sm.n + n as u64;
        let per_sample = sm.k * sm.n;
        self.pixel.get_2d(LIGHT_POINT, per_sample, self.s, slot)
    }

    /// The number that chooses BSDF slot j's lobe.
    #[inline]
    pub fn bsdf_lobe(&self, j: u32) -> f32 {
        if let (Source::Drawn(d), 0) = (&self.source, j) {
            return d.bsdf.lobe;
        }
        if let Source::Packet(lane) = &self.source {
            return lane.bsdf(j).lobe;
        }
        let sm = &self.pixel.sampler;
        if sm.kind == SamplerKind::Sobol {
            let p = self
                .pixel
                .point(BSDF_DIRECTION, sm.k * sm.n, self.s, j as u64);
            return sobol::third(p.absolute, p.seed).unit();
        }
        to_f32(self.pixel.get_1d(BSDF_LOBE, sm.k * sm.n, self.s, j as u64))
    }

    /// [`bsdf_lobe`](Self::bsdf_lobe) and [`bsdf_direction`](Self::bsdf_direction) of slot j
    /// together (the same numbers; Sobol's one 3D point is then shuffled once), with the
    /// direction's cosine-hemisphere warp where the packet made it.
    #[inline]
    pub fn bsdf_numbers(&self, j: u32) -> BsdfNumbers {
        if let (Source::Drawn(d), 0) = (&self.source, j) {
            return BsdfNumbers {
                lobe: d.bsdf.lobe,
                direction: d.bsdf.direction,
                drawn_cosine: Some(d.bsdf.cosine_direction),
            };
        }
        if let Source::Packet(lane) = &self.source {
            let b = lane.bsdf(j);
            return BsdfNumbers {
                lobe: b.lobe,
                direction: b.direction,
                drawn_cosine: Some(b.cosine_direction),
            };
        }
        let sm = &self.pixel.sampler;
        let (lobe, direction) = if sm.kind == SamplerKind::Sobol {
            let index = self.pixel.absolute(sm.k * sm.n, self.s, j as u64);
            let seed = self.pixel.seeds[BSDF_DIRECTION as usize];
            let [x, y, lobe] = sobol::sample_3d(index, seed).map(Reversed::unit);
            (lobe, [x, y])
        } else {
            (self.bsdf_lobe(j), self.bsdf_direction(j))
        };
        BsdfNumbers {
            lobe,
            direction,
            drawn_cosine: None,
        }
    }

    /// [`bsdf_direction`](Self::bsdf_direction) warped to the cosine-weighted hemisphere
    /// (`warp::cosine_hemisphere`), made with the packet's numbers where they were drawn
    /// together.
    #[inline]
    pub fn bsdf_cosine_direction(&self, j: u32) -> glam::Vec3 {
        if let (Source::Drawn(d), 0) = (&self.source, j) {
            return d.bsdf.cosine_direction;
        }
        if let Source::Packet(lane) = &self.source {
            return lane.bsdf(j).cosine_direction;
        }
        crate::sampling::warp::cosine_hemisphere(self.bsdf_direction(j))
    }

    /// The 2D number that gives BSDF (or hemisphere) slot j's direction.
    #[inline]
    pub fn bsdf_direction(&self, j: u32) -> [f32; 2] {
        if let (Source::Drawn(d), 0) = (&self.source, j) {
            return d.bsdf.direction;
        }
        if let Source::Packet(lane) = &self.source {
            return lane.bsdf(j).direction;
        }
        let sm = &self.pixel.sampler;
        self.pixel
            .get_2d(BSDF_DIRECTION, sm.k * sm.n, self.s, j as u64)
    }
}

#[cfg(test)]
mod tests;
