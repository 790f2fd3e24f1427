//! A packet's numbers drawn together. Where each camera sample has one light slot with one
//! point (K = N = 1) and the CPU has AVX2, the numbers of a packet's camera samples (up to
//! eight) are made in AVX2 lanes when the packet is formed, bit for bit the numbers each would
//! make alone; each `CameraSample` then hands out its own. Sobol points come from `sobol_avx2`;
//! independent numbers from `hash_avx2`, which also mixes each sample's index once for all its
//! dimensions instead of once per dimension.

use super::sobol::{GroupSeeds, SeedLanes};
use super::*;

/// The lanes of a draw.
const LANES: usize = 8;

/// One camera sample's numbers, drawn ahead (see the module header).
#[derive(Clone, Copy, Debug)]
pub(super) struct Drawn {
    pub(super) jitter: [f32; 2],
    pub(super) light_choice: f64,
    pub(super) light_point: [f32; 2],
    pub(super) bsdf_lobe: f32,
    pub(super) bsdf_direction: [f32; 2],
    /// `bsdf_direction` warped to the cosine-weighted hemisphere.
    pub(super) bsdf_cosine: glam::Vec3,
}

/// Draws the numbers of `samples` together where the module header says, else leaves them to
/// be made one at a time, as they are made for more than eight samples, for the other sequences
/// or for Sobol points at indices from 2^32 on.
pub fn draw_together(samples: &mut [CameraSample]) {
    let Some(last) = samples.last() else {
        return;
    };
    let sm = &last.pixel.sampler;
    if samples.len() > LANES || !(sm.k == 1 && sm.n == 1 && sm.avx2) {
        return;
    }
    match sm.kind {
        SamplerKind::Sobol => draw_sobol(samples),
        SamplerKind::Independent => draw_independent(samples),
        _ => {}
    }
}

/// The dimensions an independent camera sample reads (one hash each): the pixel jitter, the
/// light choice, the light point, the BSDF lobe and the BSDF direction.
const INDEPENDENT: [u64; 5] = [PIXEL, LIGHT_CHOICE, LIGHT_POINT, BSDF_LOBE, BSDF_DIRECTION];

/// `draw_together` for the independent sampler: the numbers `get_1d`, `get_2d` and
/// `light_choice` make from the same hashes.
fn draw_independent(samples: &mut [CameraSample]) {
    // Spare lanes repeat the last sample.
    let lane = |i: usize| &samples[i.min(samples.len() - 1)];
    let index: [u64; LANES] = std::array::from_fn(|i| lane(i).pixel.absolute(1, lane(i).s, 0));
    let seeds = INDEPENDENT.map(|dim| std::array::from_fn(|i| lane(i).pixel.seeds[dim as usize]));
    let [jitter, choice, point, lobe, direction] = independent_hashes(index, &seeds);
    let two = |h: u64| [to_f32((h >> 32) as u32), to_f32(h as u32)];
    let direction = direction.map(two);
    let cosine = cosine_lanes(&direction.map(|d| d[0]), &direction.map(|d| d[1]));
    for (i, cs) in samples.iter_mut().enumerate() {
        cs.drawn = Some(Drawn {
            jitter: two(jitter[i]),
            light_choice: (choice[i] >> 11) as f64 * TO_UNIT_53,
            light_point: two(point[i]),
            bsdf_lobe: to_f32((lobe[i] >> 32) as u32),
            bsdf_direction: direction[i],
            bsdf_cosine: cosine[i],
        });
    }
}

#[cfg(target_arch = "x86_64")]
fn independent_hashes(index: [u64; LANES], seeds: &[[u64; LANES]; 5]) -> [[u64; LANES]; 5] {
    // SAFETY: `draw_together` draws only where the sampler's `avx2` is true, which it is only
    // when the CPU reported AVX2.
    unsafe { super::hash_avx2::hashes(index, seeds) }
}

#[cfg(not(target_arch = "x86_64"))]
fn independent_hashes(_: [u64; LANES], _: &[[u64; LANES]; 5]) -> [[u64; LANES]; 5] {
    unreachable!("no AVX2 off x86-64")
}

/// `draw_together` for Sobol points.
fn draw_sobol(samples: &mut [CameraSample]) {
    let mut index = [0u32; LANES];
    let mut seeds = [SeedLanes::default(); 3];
    // Lanes of one pixel share its seeds, made once; spare lanes repeat the last sample.
    let mut made: Option<(&PixelSampler, [GroupSeeds; 3])> = None;
    for (lane, slot) in index.iter_mut().enumerate() {
        let cs = &samples[lane.min(samples.len() - 1)];
        let Ok(absolute) = u32::try_from(cs.pixel.absolute(1, cs.s, 0)) else {
            return;
        };
        *slot = absolute;
        let groups = match made {
            Some((pixel, groups)) if std::ptr::eq(pixel, cs.pixel) => groups,
            _ => {
                let groups = GROUPS.map(|dim| GroupSeeds::of(cs.pixel.seeds[dim as usize]));
                made = Some((cs.pixel, groups));
                groups
            }
        };
        for (lanes, group) in seeds.iter_mut().zip(&groups) {
            lanes.set(lane, group);
        }
    }
    // SAFETY: `draw_together` draws only where the sampler's `avx2` is true, which it is only
    // when the CPU reported AVX2.
    let drawn = unsafe { draw(index, &seeds) };
    let cosine = cosine_lanes(&drawn.units[4], &drawn.units[5]);
    for (lane, cs) in samples.iter_mut().enumerate() {
        let seed = cs.pixel.seeds[LIGHT_POINT as usize];
        let at = |c: &[f32; LANES]| c[lane];
        cs.drawn = Some(Drawn {
            jitter: [at(&drawn.units[0]), at(&drawn.units[1])],
            light_choice: with_hashed_bits(drawn.choice[lane], seed, u64::from(index[lane])),
            light_point: [at(&drawn.units[2]), at(&drawn.units[3])],
            bsdf_lobe: at(&drawn.units[6]),
            bsdf_direction: [at(&drawn.units[4]), at(&drawn.units[5])],
            bsdf_cosine: cosine[lane],
        });
    }
}

/// The dimension groups a camera sample draws from: the pixel jitter, the light's point (and
/// its choice, the third coordinate) and the BSDF's direction (and lobe, the third).
const GROUPS: [u64; 3] = [PIXEL, LIGHT_POINT, BSDF_DIRECTION];

/// A packet's numbers in lanes: the light choice's 32 sequence bits, and as f32 in [0, 1) the
/// pixel jitter's two coordinates, the light point's two and the BSDF group's three.
struct Lanes {
    choice: [u32; LANES],
    units: [[f32; LANES]; 7],
}

/// The numbers of the points at `index` in the groups seeded `seeds` (`GROUPS`' order).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn draw(index: [u32; LANES], seeds: &[SeedLanes; 3]) -> Lanes {
    use super::sobol_avx2::{bits, load, sample_2d, sample_3d, units};
    use std::arch::x86_64::*;
    let index = load(index);
    let [jx, jy] = sample_2d(index, &seeds[0]);
    let [lx, ly, lz] = sample_3d(index, &seeds[1]);
    let [bx, by, bz] = sample_3d(index, &seeds[2]);
    let mut out = Lanes {
        choice: [0; LANES],
        units: [[0.0; LANES]; 7],
    };
    _mm256_storeu_si256(out.choice.as_mut_ptr().cast(), bits(lz));
    for (row, c) in out.units.iter_mut().zip([jx, jy, lx, ly, bx, by, bz]) {
        _mm256_storeu_ps(row.as_mut_ptr(), units(c));
    }
    out
}

#[cfg(not(target_arch = "x86_64"))]
unsafe fn draw(_: [u32; LANES], _: &[SeedLanes; 3]) -> Lanes {
    unreachable!("no AVX2 off x86-64")
}

/// The lanes' BSDF direction numbers (u0, u1) warped to the cosine-weighted hemisphere.
#[cfg(target_arch = "x86_64")]
fn cosine_lanes(u0: &[f32; LANES], u1: &[f32; LANES]) -> [glam::Vec3; LANES] {
    // SAFETY: `draw_together` draws only where the sampler's `avx2` is true, which it is only
    // when the CPU reported AVX2.
    let d = unsafe { crate::sampling::warp_avx2::cosine_hemisphere(u0, u1) };
    std::array::from_fn(|i| glam::Vec3::new(d.x[i], d.y[i], d.z[i]))
}

#[cfg(not(target_arch = "x86_64"))]
fn cosine_lanes(_: &[f32; LANES], _: &[f32; LANES]) -> [glam::Vec3; LANES] {
    unreachable!("no AVX2 off x86-64")
}
