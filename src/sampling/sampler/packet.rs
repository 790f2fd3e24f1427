//! A packet's numbers for K·N > 1, drawn together. Where each camera sample has several light
//! slots or points (K·N from 2 to `MAX_SLOTS`) and the CPU has AVX2, the independent and Sobol
//! numbers of a packet's camera samples (up to eight, one a lane) are made slot by slot in AVX2
//! lanes when the packet is formed, for every light choice, light point and BSDF slot, bit for
//! bit the numbers each sample would make alone, and kept in the tile's [`PacketNumbers`]; each
//! `CameraSample` then reads its own lane there. (K = N = 1 keeps its numbers in the sample
//! itself: `drawn`, which shares the lane helpers here.)

use glam::Vec3;

use super::*;

/// The lanes of a draw: one camera sample each.
pub(super) const LANES: usize = 8;

/// The most K·N slots a packet's numbers hold (renders with more make theirs one at a time); a
/// power of two, so a slot index masked by `MAX_SLOTS − 1` needs no bounds check.
const MAX_SLOTS: usize = 16;
const _: () = assert!(MAX_SLOTS.is_power_of_two() && LANES.is_power_of_two());

/// A packet's numbers lane by lane (lane i: the packet's camera sample i), for every slot;
/// written over by each packet of a tile.
#[derive(Debug)]
pub struct PacketNumbers {
    /// K and N of the render.
    k: usize,
    n: usize,
    jitter: [[f32; 2]; LANES],
    /// Light slot k's choice at [k][lane].
    light_choice: [[f64; LANES]; MAX_SLOTS],
    /// Point n on light slot k at [k·N + n][lane].
    light_point: [[[f32; 2]; LANES]; MAX_SLOTS],
    /// BSDF slot j's numbers at [j][lane].
    bsdf: [[BsdfSlot; LANES]; MAX_SLOTS],
}

/// One BSDF slot's numbers: the lobe's, the direction's, and the direction warped to the
/// cosine-weighted hemisphere.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BsdfSlot {
    pub(super) lobe: f32,
    pub(super) direction: [f32; 2],
    pub(super) cosine_direction: Vec3,
}

/// A camera sample's place in its packet's numbers.
#[derive(Clone, Copy, Debug)]
pub(super) struct Lane<'a> {
    numbers: &'a PacketNumbers,
    lane: usize,
}

impl Lane<'_> {
    #[inline(always)]
    pub(super) fn jitter(&self) -> [f32; 2] {
        self.numbers.jitter[self.lane()]
    }

    #[inline(always)]
    pub(super) fn light_choice(&self, k: u32) -> f64 {
        debug_assert!((k as usize) < self.numbers.k);
        self.numbers.light_choice[slot(k as usize)][self.lane()]
    }

    #[inline(always)]
    pub(super) fn light_point(&self, k: u32, n: u32) -> [f32; 2] {
        debug_assert!((k as usize) < self.numbers.k && (n as usize) < self.numbers.n);
        let at = slot(k as usize * self.numbers.n + n as usize);
        self.numbers.light_point[at][self.lane()]
    }

    #[inline(always)]
    pub(super) fn bsdf(&self, j: u32) -> BsdfSlot {
        debug_assert!((j as usize) < self.numbers.k * self.numbers.n);
        self.numbers.bsdf[slot(j as usize)][self.lane()]
    }

    /// The lane, masked as `slot` masks a slot (it is below `LANES`).
    #[inline(always)]
    fn lane(&self) -> usize {
        self.lane & (LANES - 1)
    }
}

/// A slot index as the arrays hold it: callers ask for slots below K·N ≤ `MAX_SLOTS` (checked in
/// debug builds), which the mask leaves as they are, so the arrays' bounds need no check.
#[inline(always)]
fn slot(index: usize) -> usize {
    index & (MAX_SLOTS - 1)
}

impl PacketNumbers {
    /// Storage for the packets of a render with `sampler`'s K and N.
    pub fn new(sampler: &Sampler) -> PacketNumbers {
        PacketNumbers {
            k: sampler.k as usize,
            n: sampler.n as usize,
            jitter: [[0.0; 2]; LANES],
            light_choice: [[0.0; LANES]; MAX_SLOTS],
            light_point: [[[0.0; 2]; LANES]; MAX_SLOTS],
            bsdf: [[BsdfSlot::default(); LANES]; MAX_SLOTS],
        }
    }
}

/// Draws the numbers of `samples` (at most `LANES`, all of a render with K·N > 1 whose sampler
/// is `sm`, the one `numbers` was made for) into `numbers` and points each sample at its lane,
/// where the module header says; else leaves them to be made one at a time (`draw_together`
/// checks what the two draws share).
///
/// # Safety
/// The CPU must support AVX2.
pub(super) unsafe fn draw_slots<'a>(
    samples: &mut [CameraSample<'a>],
    numbers: &'a mut PacketNumbers,
    sm: &Sampler,
) {
    let (k, n) = (sm.k as usize, sm.n as usize);
    debug_assert_eq!(
        (k, n),
        (numbers.k, numbers.n),
        "numbers made for this render"
    );
    if (k, n) != (numbers.k, numbers.n) || k * n > MAX_SLOTS {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    // SAFETY: the caller's.
    let drawn = unsafe {
        match sm.kind {
            SamplerKind::Sobol => lanes::draw_sobol(samples, numbers),
            SamplerKind::Independent => {
                lanes::draw_independent(samples, numbers);
                true
            }
            _ => false,
        }
    };
    #[cfg(not(target_arch = "x86_64"))]
    let drawn = false;
    if drawn {
        let numbers: &'a PacketNumbers = numbers;
        for (lane, cs) in samples.iter_mut().enumerate() {
            cs.source = Source::Packet(Lane { numbers, lane });
        }
    }
}

/// The lane helpers of the draws, here and in `drawn`.
#[cfg(target_arch = "x86_64")]
pub(super) mod lanes {
    use std::arch::x86_64::{__m256i, _mm256_add_epi32, _mm256_mullo_epi32, _mm256_set1_epi32};

    use super::super::hash_avx2::hashes;
    use super::super::independent::halves;
    use super::super::sobol::{GroupSeeds, SeedLanes};
    use super::super::sobol_avx2::{bits, load, sample_1d, sample_2d, sample_3d, units};
    use super::*;
    use crate::sampling::warp_avx2::cosine_hemisphere;

    /// Eight BSDF slots from their lobe numbers and direction numbers (x and y, lane by lane),
    /// with the directions' cosine-hemisphere warps.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in super::super) unsafe fn bsdf_lanes(
        lobe: &[f32; LANES],
        x: &[f32; LANES],
        y: &[f32; LANES],
    ) -> [BsdfSlot; LANES] {
        let cosine = cosine_hemisphere(x, y);
        std::array::from_fn(|lane| BsdfSlot {
            lobe: lobe[lane],
            direction: [x[lane], y[lane]],
            cosine_direction: Vec3::new(cosine.x[lane], cosine.y[lane], cosine.z[lane]),
        })
    }

    /// Each lane's pair of 24-bit fractions from its 64-bit hash (`independent::halves`), as two
    /// lanes of x and of y.
    #[inline(always)]
    pub(in super::super) fn unit_pairs(hashes: &[u64; LANES]) -> ([f32; LANES], [f32; LANES]) {
        let (mut x, mut y) = ([0.0; LANES], [0.0; LANES]);
        for lane in 0..LANES {
            [x[lane], y[lane]] = halves(hashes[lane]).map(to_f32);
        }
        (x, y)
    }

    /// Each lane's 2D point in [0, 1)² from the two coordinates' reversed bits (`units`).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(in super::super) unsafe fn point_pairs(x: __m256i, y: __m256i) -> [[f32; 2]; LANES] {
        let (x, y) = (units(x), units(y));
        std::array::from_fn(|lane| [x[lane], y[lane]])
    }

    /// The low 32 bits of each lane's index (the Sobol lanes' indices, below 2^32: `sobol_fits`).
    #[inline(always)]
    pub(in super::super) fn low_words(index: &[u64; LANES]) -> [u32; LANES] {
        let mut words = [0; LANES];
        for lane in 0..LANES {
            words[lane] = index[lane] as u32;
        }
        words
    }

    /// Lane i's camera sample: sample i, spare lanes repeating the last one.
    #[inline(always)]
    fn in_lane<'s, 'a>(samples: &'s [CameraSample<'a>], lane: usize) -> &'s CameraSample<'a> {
        &samples[lane.min(samples.len() - 1)]
    }

    /// Each lane's absolute index of point `slot` of a group with `per_sample` points per
    /// camera sample (`PixelSampler::absolute`).
    #[inline(always)]
    pub(in super::super) fn indices(
        samples: &[CameraSample],
        per_sample: usize,
        slot: usize,
    ) -> [u64; LANES] {
        std::array::from_fn(|lane| {
            let cs = in_lane(samples, lane);
            cs.pixel.absolute(per_sample as u64, cs.s, slot as u64)
        })
    }

    /// Each lane's seed of dimension `dim`.
    #[inline(always)]
    pub(in super::super) fn seeds(samples: &[CameraSample], dim: u64) -> [u64; LANES] {
        std::array::from_fn(|lane| in_lane(samples, lane).pixel.seeds[dim as usize])
    }

    /// Whether every index of the camera samples `camera` (their indices S) with `per_sample`
    /// points each, up to S·per_sample + per_sample − 1, lies below 2^32, as the Sobol lanes
    /// need.
    #[inline(always)]
    pub(in super::super) fn sobol_fits(camera: &[u64; LANES], per_sample: usize) -> bool {
        let end = |s: u64| (s + 1).checked_mul(per_sample as u64);
        camera
            .iter()
            .all(|&s| end(s).is_some_and(|end| end <= 1 << 32))
    }

    /// `draw_slots` for the independent sampler: the numbers `get_1d`, `get_2d` and
    /// `light_choice` make, from the same hashes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn draw_independent(samples: &[CameraSample], numbers: &mut PacketNumbers) {
        let (k, kn) = (numbers.k, numbers.k * numbers.n);
        let unit_pair = |h: u64| halves(h).map(to_f32);
        let seed = |dim| seeds(samples, dim);
        let [jitter] = hashes(indices(samples, 1, 0), &[seed(PIXEL)]);
        numbers.jitter = jitter.map(unit_pair);
        let choice_seed = [seed(LIGHT_CHOICE)];
        for slot in 0..k {
            let [choice] = hashes(indices(samples, k, slot), &choice_seed);
            numbers.light_choice[slot] = choice.map(unit_53);
        }
        // The light points and the BSDF slots share their indices S·K·N + slot.
        let dims = [seed(LIGHT_POINT), seed(BSDF_LOBE), seed(BSDF_DIRECTION)];
        for slot in 0..kn {
            let [point, lobe, direction] = hashes(indices(samples, kn, slot), &dims);
            numbers.light_point[slot] = point.map(unit_pair);
            let lobe = lobe.map(|h| to_f32(halves(h)[0]));
            let (x, y) = unit_pairs(&direction);
            numbers.bsdf[slot] = bsdf_lanes(&lobe, &x, &y);
        }
    }

    /// The seed lanes of Sobol groups `dims`: lanes of one pixel share its seeds, made once.
    pub(in super::super) fn group_seeds<const G: usize>(
        samples: &[CameraSample],
        dims: [u64; G],
    ) -> [SeedLanes; G] {
        let mut lanes = [SeedLanes::default(); G];
        let mut made: Option<(&PixelSampler, [GroupSeeds; G])> = None;
        for lane in 0..LANES {
            let cs = in_lane(samples, lane);
            let groups = match made {
                Some((pixel, groups)) if std::ptr::eq(pixel, cs.pixel) => groups,
                _ => dims.map(|dim| GroupSeeds::of(cs.pixel.seeds[dim as usize])),
            };
            made = Some((cs.pixel, groups));
            for (seeds, group) in lanes.iter_mut().zip(&groups) {
                seeds.set(lane, group);
            }
        }
        lanes
    }

    /// `draw_slots` for Sobol points: `sample_2d` and `sample_3d` in every lane. False (and
    /// nothing drawn) where some index would be 2^32 or more.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn draw_sobol(samples: &[CameraSample], numbers: &mut PacketNumbers) -> bool {
        let (k, n) = (numbers.k, numbers.n);
        let kn = k * n;
        // Each lane's camera sample S; a group's index is S·per_sample + slot, the largest
        // S·K·N + K·N − 1.
        let camera = indices(samples, 1, 0);
        if !sobol_fits(&camera, kn) {
            return false;
        }
        let s = load(low_words(&camera));
        let at = |per_sample: usize, slot: usize| {
            let times = _mm256_mullo_epi32(s, _mm256_set1_epi32(per_sample as i32));
            _mm256_add_epi32(times, _mm256_set1_epi32(slot as i32))
        };
        // LIGHT_CHOICE's seeds are read only where N > 1 (made for every pixel all the same).
        let [pixel, light, bsdf, choice_group] =
            group_seeds(samples, [PIXEL, LIGHT_POINT, BSDF_DIRECTION, LIGHT_CHOICE]);
        let [jx, jy] = sample_2d(at(1, 0), &pixel);
        numbers.jitter = point_pairs(jx, jy);
        // N = 1: a light's choice is the third coordinate of the point on it; else dimension
        // 2's own one-dimensional point.
        let choice_seed = seeds(samples, if n > 1 { LIGHT_CHOICE } else { LIGHT_POINT });
        for slot in 0..k {
            let choice = if n > 1 {
                bits(sample_1d(at(k, slot), &choice_group))
            } else {
                let [x, y, z] = sample_3d(at(k, slot), &light);
                numbers.light_point[slot] = point_pairs(x, y);
                bits(z)
            };
            numbers.light_choice[slot] = std::array::from_fn(|lane| {
                let index = camera[lane] * k as u64 + slot as u64;
                with_hashed_bits(choice[lane], choice_seed[lane], index)
            });
        }
        if n > 1 {
            for slot in 0..kn {
                let [x, y] = sample_2d(at(kn, slot), &light);
                numbers.light_point[slot] = point_pairs(x, y);
            }
        }
        for j in 0..kn {
            let [x, y, z] = sample_3d(at(kn, j), &bsdf);
            let (x, y) = (units(x), units(y));
            numbers.bsdf[j] = bsdf_lanes(&units(z), &x, &y);
        }
        true
    }
}
