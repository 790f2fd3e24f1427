//! A packet's numbers drawn together, K = N = 1 (more slots: `packet`). Where each camera sample
//! has one light slot with one point and the CPU has AVX2, the numbers of a packet's camera
//! samples (up to eight) are made in AVX2 lanes when the packet is formed, bit for bit the
//! numbers each would make alone, and each `CameraSample` keeps and hands out its own: Sobol
//! points from `sobol_avx2` (the 21 low bits appended to the light choice still hashed one sample
//! at a time), independent numbers from `hash_avx2` (each sample's index mixed once for all its
//! dimensions instead of once per dimension), and the BSDF direction's cosine-hemisphere warp
//! from `warp_avx2`.

use super::packet::{draw_slots, BsdfSlot, LANES};
use super::*;

const _: () = assert!(
    crate::accel::PACKET <= LANES,
    "a packet's samples fit one draw"
);

/// One camera sample's numbers, drawn ahead (see the module header).
#[derive(Clone, Copy, Debug)]
pub(super) struct Drawn {
    pub(super) jitter: [f32; 2],
    pub(super) light_choice: f64,
    pub(super) light_point: [f32; 2],
    pub(super) bsdf: BsdfSlot,
}

/// Draws the numbers of `samples` together where the module header says (K·N from 2 to 16: into
/// `numbers`, see `packet`), else leaves them to be made one at a time, as they are for more
/// than eight samples, for more than 16 slots, for the other sequences and for Sobol points at
/// indices from 2^32 on.
pub fn draw_together<'a>(samples: &mut [CameraSample<'a>], numbers: &'a mut PacketNumbers) {
    let Some(last) = samples.last() else {
        return;
    };
    let sm = last.pixel.sampler;
    if samples.len() > LANES || !sm.avx2 {
        return;
    }
    if sm.k * sm.n > 1 {
        // SAFETY: the sampler's `avx2` is true only when the CPU reported AVX2 (`has_avx2_fma`).
        unsafe { draw_slots(samples, numbers, &sm) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    // SAFETY: the sampler's `avx2` is true only when the CPU reported AVX2 (`has_avx2_fma`).
    unsafe {
        match sm.kind {
            SamplerKind::Sobol => lanes::draw_sobol(samples),
            SamplerKind::Independent => lanes::draw_independent(samples),
            _ => {}
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod lanes {
    use super::super::hash_avx2::hashes;
    use super::super::independent::halves;
    use super::super::packet::lanes::{
        bsdf_lanes, group_seeds, indices, low_words, point_pairs, seeds, sobol_fits, unit_pairs,
    };
    use super::super::sobol_avx2::{bits, load, sample_2d, sample_3d, units};
    use super::*;

    /// The dimensions an independent camera sample reads, one hash each: the pixel jitter, the
    /// light choice, the light point, the BSDF lobe and the BSDF direction.
    const INDEPENDENT_DIMS: [u64; 5] =
        [PIXEL, LIGHT_CHOICE, LIGHT_POINT, BSDF_LOBE, BSDF_DIRECTION];

    /// The Sobol groups a camera sample draws from: the pixel jitter, the light's point (and its
    /// choice, the third coordinate) and the BSDF's direction (and its lobe, the third).
    const SOBOL_GROUPS: [u64; 3] = [PIXEL, LIGHT_POINT, BSDF_DIRECTION];

    /// `draw_together` for the independent sampler: the numbers `get_1d`, `get_2d` and
    /// `light_choice` make, from the same hashes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn draw_independent(samples: &mut [CameraSample]) {
        let dims = INDEPENDENT_DIMS.map(|dim| seeds(samples, dim));
        let [jitter, choice, point, lobe, direction] = hashes(indices(samples, 1, 0), &dims);
        let unit_pair = |h: u64| halves(h).map(to_f32);
        let (x, y) = unit_pairs(&direction);
        let bsdf = bsdf_lanes(&lobe.map(|h| to_f32(halves(h)[0])), &x, &y);
        for (lane, cs) in samples.iter_mut().enumerate() {
            cs.source = Source::Drawn(Drawn {
                jitter: unit_pair(jitter[lane]),
                light_choice: unit_53(choice[lane]),
                light_point: unit_pair(point[lane]),
                bsdf: bsdf[lane],
            });
        }
    }

    /// `draw_together` for Sobol points: `sample_2d` and `sample_3d` in every lane, where every
    /// index is below 2^32.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn draw_sobol(samples: &mut [CameraSample]) {
        let camera = indices(samples, 1, 0);
        if !sobol_fits(&camera, 1) {
            return;
        }
        let all = load(low_words(&camera));
        let [pixel, light, bsdf] = group_seeds(samples, SOBOL_GROUPS);
        let [jx, jy] = sample_2d(all, &pixel);
        let [lx, ly, lz] = sample_3d(all, &light);
        let [bx, by, bz] = sample_3d(all, &bsdf);
        let (jitter, point) = (point_pairs(jx, jy), point_pairs(lx, ly));
        let choice = bits(lz);
        let bsdf = bsdf_lanes(&units(bz), &units(bx), &units(by));
        for (lane, cs) in samples.iter_mut().enumerate() {
            let seed = cs.pixel.seeds[LIGHT_POINT as usize];
            cs.source = Source::Drawn(Drawn {
                jitter: jitter[lane],
                light_choice: with_hashed_bits(choice[lane], seed, camera[lane]),
                light_point: point[lane],
                bsdf: bsdf[lane],
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a drawn camera sample hands out, for every light slot, point and BSDF slot,
    /// has the bits the same sample makes alone: every sampler, K × N from 1 × 1 (`drawn`) to 16
    /// slots (`packet`) and beyond (17 × 1, made one at a time), packets of one to eight samples
    /// of one pixel or of several, at the start of a render, further on, and about the camera
    /// sample whose indices reach 2^32, from which Sobol packets are left undrawn.
    #[test]
    fn drawn_numbers_are_the_numbers_made_one_at_a_time() {
        if !crate::cpu::has_avx2_fma() {
            return;
        }
        let numbers_of = |cs: &CameraSample, (k, n): (u32, u32)| {
            let mut bits: Vec<u64> = (0..k).map(|slot| cs.light_choice(slot).to_bits()).collect();
            let mut f32s = |xs: &[f32]| bits.extend(xs.iter().map(|x| u64::from(x.to_bits())));
            f32s(&cs.pixel_jitter());
            for slot in 0..k {
                for point in 0..n {
                    f32s(&cs.light_point(slot, point));
                }
            }
            for j in 0..k * n {
                let both = cs.bsdf_numbers(j);
                f32s(&[both.lobe, cs.bsdf_lobe(j)]);
                f32s(&[both.direction, cs.bsdf_direction(j)].concat());
                f32s(&both.cosine_direction().to_array());
                f32s(&cs.bsdf_cosine_direction(j).to_array());
            }
            bits
        };
        let kinds = [
            SamplerKind::Independent,
            SamplerKind::Sobol,
            SamplerKind::Halton,
            SamplerKind::Stratified,
            SamplerKind::Lhs,
        ];
        let layouts = [
            (1, 1),
            (2, 1),
            (1, 3),
            (2, 2),
            (3, 2),
            (4, 4),
            (2, 8),
            (1, 16),
            (17, 1),
        ];
        for kind in kinds {
            for kn in layouts {
                let per_sample = u64::from(kn.0 * kn.1);
                // The first camera sample whose indices reach 2^32, and some before and after it.
                let edge = (1u64 << 32) / per_sample;
                let firsts = [0, 5, edge - 8, edge - 4, edge - 1, (1 << 32) - 3, 1 << 32];
                for first in firsts {
                    let sampler = Sampler::new(kind, 11, first, 8, kn.0, kn.1);
                    let pixels: Vec<PixelSampler> = (0..8).map(|p| sampler.pixel(p)).collect();
                    let mut numbers = PacketNumbers::new(&sampler);
                    for count in 1..=LANES {
                        for per_pixel in [8, 3, 1] {
                            // Slot i: sample i % per_pixel of pixel i / per_pixel.
                            let slot = |i: usize| (&pixels[i / per_pixel], (i % per_pixel) as u32);
                            let mut samples: Vec<CameraSample> = (0..count)
                                .map(|i| slot(i).0.camera_sample(slot(i).1))
                                .collect();
                            draw_together(&mut samples, &mut numbers);
                            // The largest index a sample's numbers read: S·K·N + K·N − 1.
                            let last_index =
                                |i: usize| (first + u64::from(slot(i).1) + 1) * per_sample - 1;
                            let beyond = (0..count).any(|i| last_index(i) >> 32 != 0);
                            let drawable = match kind {
                                SamplerKind::Independent => true,
                                SamplerKind::Sobol => !beyond,
                                _ => false,
                            } && per_sample <= 16;
                            let case =
                                format!("{kind:?} {kn:?}, first {first}, {count}/{per_pixel}");
                            for (i, cs) in samples.iter().enumerate() {
                                let drawn = match cs.source {
                                    Source::Alone => false,
                                    Source::Drawn(_) => kn == (1, 1),
                                    Source::Packet(_) => kn != (1, 1),
                                };
                                assert_eq!(drawn, drawable, "{case}");
                                let alone = slot(i).0.camera_sample(slot(i).1);
                                assert_eq!(
                                    numbers_of(cs, kn),
                                    numbers_of(&alone, kn),
                                    "{case}, slot {i}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
