//! Seeded random streams outside the render loop: `derive_seed` for the sub-renders of a run
//! (passes, repeats), and `PixelRng`, a PCG32 stream hashed from (seed, index) that tests and
//! benchmarks draw from. Renders take their numbers from `sampling::sampler`.

use rand_core::Rng;
use rand_pcg::Pcg32;

/// SplitMix64's finaliser: a bijective 64-bit mix (Steele, Lea & Flood 2014).
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(MIX64_MULTIPLIERS[0]);
    z = (z ^ (z >> 27)).wrapping_mul(MIX64_MULTIPLIERS[1]);
    z ^ (z >> 31)
}

/// The two multipliers of [`mix64`].
pub(crate) const MIX64_MULTIPLIERS: [u64; 2] = [0xbf58_476d_1ce4_e5b9, 0x94d0_49bb_1331_11eb];

/// The seed of sub-render `index` (a pass, a repeat) of a run with base seed `seed`: distinct
/// for distinct indices, so the sub-renders draw independent streams.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    mix64(seed ^ mix64(index.wrapping_add(0x243f_6a88_85a3_08d3)))
}

/// A PCG32 stream whose state and increment are hashed from (seed, index).
pub struct PixelRng(Pcg32);

impl PixelRng {
    pub fn new(seed: u64, pixel: u64) -> Self {
        let key = mix64(seed.wrapping_add(mix64(pixel ^ 0x9e37_79b9_7f4a_7c15)));
        PixelRng(Pcg32::new(key, mix64(key ^ 0x6a09_e667_f3bc_c909)))
    }

    /// Uniform in [0, 1) with 24 random bits (never returns 1.0).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in [0, 1) with 53 random bits, for choices among millions of lights.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    #[inline]
    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_depend_on_seed_and_pixel_and_stay_in_unit_interval() {
        let first = |seed, pixel| PixelRng::new(seed, pixel).0.next_u64();
        assert_ne!(first(0, 0), first(0, 1));
        assert_ne!(first(0, 0), first(1, 0));
        assert_eq!(first(5, 9), first(5, 9));
        let mut rng = PixelRng::new(1, 2);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| rng.next_f32() as f64).sum::<f64>() / n as f64;
        // Uniform [0,1): σ of the mean = sqrt(1/12 / n).
        assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt());
        assert!((0..n).all(|_| (0.0..1.0).contains(&rng.next_f64())));
    }
}
