//! A packet's numbers drawn together (here K = N = 1; more slots: `packet`). Where each camera
//! sample has one light slot with one point (K = N = 1) and the CPU has AVX2, the numbers of a packet's camera samples (up to
//! eight) are made in AVX2 lanes when the packet is formed, bit for bit the numbers each would
//! make alone, and each `CameraSample` then hands out its own: Sobol points from `sobol_avx2`
//! (the 21 low bits appended to the light choice still hashed one sample at a time),
//! independent numbers from `hash_avx2` (each sample's index mixed once for all its dimensions
//! instead of once per dimension), and the BSDF direction's cosine-hemisphere warp from
//! `warp_avx2`.

use glam::Vec3;

use super::*;

use super::packet::{draw_slots, LANES};

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
    pub(super) bsdf_lobe: f32,
    pub(super) bsdf_direction: [f32; 2],
    /// `bsdf_direction` warped to the cosine-weighted hemisphere.
    pub(super) bsdf_cosine: Vec3,
}

/// Draws the numbers of `samples` together where the module header says (K·N > 1: into
/// `numbers`, see `packet`), else leaves them to be made one at a time, as they are for more
/// than eight samples, for the other sequences and for Sobol points at indices from 2^32 on.
pub fn draw_together<'a>(samples: &mut [CameraSample<'a>], numbers: &'a mut PacketNumbers) {
    let Some(last) = samples.last() else {
        return;
    };
    let sm = &last.pixel.sampler;
    if sm.k * sm.n > 1 {
        draw_slots(samples, numbers);
        return;
    }
    if samples.len() > LANES || !sm.avx2 {
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
    use super::super::sobol::{GroupSeeds, SeedLanes};
    use super::super::sobol_avx2::{bits, load, sample_2d, sample_3d, units};
    use super::*;
    use crate::sampling::warp_avx2::{cosine_hemisphere, Directions};

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
        // Spare lanes repeat the last sample.
        let lane = |i: usize| &samples[i.min(samples.len() - 1)];
        let index: [u64; LANES] = std::array::from_fn(|i| lane(i).pixel.absolute(1, lane(i).s, 0));
        let seeds =
            INDEPENDENT_DIMS.map(|dim| std::array::from_fn(|i| lane(i).pixel.seeds[dim as usize]));
        let [jitter, choice, point, lobe, direction] = hashes(index, &seeds);
        let unit_pair = |h: u64| halves(h).map(to_f32);
        let direction = direction.map(unit_pair);
        let cosine = cosine_hemisphere(&direction.map(|d| d[0]), &direction.map(|d| d[1]));
        for (i, cs) in samples.iter_mut().enumerate() {
            cs.source = Source::Drawn(Drawn {
                jitter: unit_pair(jitter[i]),
                light_choice: unit_53(choice[i]),
                light_point: unit_pair(point[i]),
                bsdf_lobe: to_f32(halves(lobe[i])[0]),
                bsdf_direction: direction[i],
                bsdf_cosine: lane_of(&cosine, i),
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
        let mut index = [0u32; LANES];
        let mut seeds = [SeedLanes::default(); 3];
        // Lanes of one pixel share its seeds, made once; spare lanes repeat the last sample.
        let mut pixel_seeds: Option<(&PixelSampler, [GroupSeeds; 3])> = None;
        for (lane, slot) in index.iter_mut().enumerate() {
            let cs = &samples[lane.min(samples.len() - 1)];
            let Ok(absolute) = u32::try_from(cs.pixel.absolute(1, cs.s, 0)) else {
                return;
            };
            *slot = absolute;
            let groups = match pixel_seeds {
                Some((pixel, groups)) if std::ptr::eq(pixel, cs.pixel) => groups,
                _ => {
                    let groups =
                        SOBOL_GROUPS.map(|dim| GroupSeeds::of(cs.pixel.seeds[dim as usize]));
                    pixel_seeds = Some((cs.pixel, groups));
                    groups
                }
            };
            for (lanes, group) in seeds.iter_mut().zip(&groups) {
                lanes.set(lane, group);
            }
        }
        let all = load(index);
        let [jx, jy] = sample_2d(all, &seeds[0]);
        let [lx, ly, lz] = sample_3d(all, &seeds[1]);
        let [bx, by, bz] = sample_3d(all, &seeds[2]);
        let (jitter, point) = ([units(jx), units(jy)], [units(lx), units(ly)]);
        let (lobe, direction) = (units(bz), [units(bx), units(by)]);
        let choice = bits(lz);
        let cosine = cosine_hemisphere(&direction[0], &direction[1]);
        for (lane, cs) in samples.iter_mut().enumerate() {
            let seed = cs.pixel.seeds[LIGHT_POINT as usize];
            cs.source = Source::Drawn(Drawn {
                jitter: jitter.map(|c| c[lane]),
                light_choice: with_hashed_bits(choice[lane], seed, u64::from(index[lane])),
                light_point: point.map(|c| c[lane]),
                bsdf_lobe: lobe[lane],
                bsdf_direction: direction.map(|c| c[lane]),
                bsdf_cosine: lane_of(&cosine, lane),
            });
        }
    }

    fn lane_of(d: &Directions, lane: usize) -> Vec3 {
        Vec3::new(d.x[lane], d.y[lane], d.z[lane])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a drawn camera sample hands out, for every light slot, point and BSDF slot,
    /// has the bits the same sample makes alone: K × N of 1 × 1 (`drawn`), 2 × 1, 1 × 3, 2 × 2
    /// and 16 × 1 (`packet`), packets of one to eight samples of one pixel or of several, at the
    /// start of a render, further on, and near index 2^32, where Sobol packets whose indices
    /// reach it are left undrawn.
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
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            for kn in [(1, 1), (2, 1), (1, 3), (2, 2), (16, 1)] {
                for first in [0u64, 5, (1 << 28) - 3, (1 << 32) - 3] {
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
                            let per_sample = u64::from(kn.0 * kn.1);
                            let last_index =
                                |i: usize| (first + u64::from(slot(i).1) + 1) * per_sample - 1;
                            let beyond = (0..count).any(|i| last_index(i) >> 32 != 0);
                            let undrawn = kind == SamplerKind::Sobol && beyond;
                            let case =
                                format!("{kind:?} {kn:?}, first {first}, {count}/{per_pixel}");
                            for (i, cs) in samples.iter().enumerate() {
                                let drawn = match cs.source {
                                    Source::Alone => false,
                                    Source::Drawn(_) => kn == (1, 1),
                                    Source::Packet(_) => kn != (1, 1),
                                };
                                assert_eq!(drawn, !undrawn, "{case}");
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
