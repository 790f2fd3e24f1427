//! `warp::cosine_hemisphere` for eight points at once in AVX2 lanes, the same operations in the
//! same order (the concentric map's two cases chosen per lane by a mask, its zero point kept),
//! so each lane gives the scalar warp's bits.

use std::arch::x86_64::*;
use std::f32::consts::PI;

use super::warp::{COS_STEPS, SIN_STEPS};

/// Eight directions, coordinate by coordinate.
pub struct Directions {
    pub x: [f32; 8],
    pub y: [f32; 8],
    pub z: [f32; 8],
}

/// Cosine-weighted directions on the hemisphere z > 0 of the points (u0[i], u1[i]).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub unsafe fn cosine_hemisphere(u0: &[f32; 8], u1: &[f32; 8]) -> Directions {
    let splat = _mm256_set1_ps;
    let (one, zero) = (splat(1.0), _mm256_setzero_ps());
    let a = _mm256_sub_ps(_mm256_mul_ps(splat(2.0), _mm256_loadu_ps(u0.as_ptr())), one);
    let b = _mm256_sub_ps(_mm256_mul_ps(splat(2.0), _mm256_loadu_ps(u1.as_ptr())), one);
    // |a| > |b|: φ = π/4 · b/a, (x, y) = a·(cos φ, sin φ); else φ = π/4 · a/b,
    // (x, y) = b·(sin φ, cos φ).
    let abs = |v| _mm256_andnot_ps(splat(-0.0), v);
    let wide = _mm256_cmp_ps::<_CMP_GT_OQ>(abs(a), abs(b));
    let (num, den) = (_mm256_blendv_ps(a, b, wide), _mm256_blendv_ps(b, a, wide));
    let phi = _mm256_mul_ps(splat(0.25 * PI), _mm256_div_ps(num, den));
    let (cos, sin) = cos_sin_within_quarter(phi);
    let x = _mm256_blendv_ps(_mm256_mul_ps(den, sin), _mm256_mul_ps(den, cos), wide);
    let y = _mm256_blendv_ps(_mm256_mul_ps(den, cos), _mm256_mul_ps(den, sin), wide);
    // The centre maps to the centre.
    let centre = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_EQ_OQ>(a, zero),
        _mm256_cmp_ps::<_CMP_EQ_OQ>(b, zero),
    );
    let (x, y) = (
        _mm256_blendv_ps(x, zero, centre),
        _mm256_blendv_ps(y, zero, centre),
    );
    let rest = _mm256_sub_ps(_mm256_sub_ps(one, _mm256_mul_ps(x, x)), _mm256_mul_ps(y, y));
    // f32::max(v, 0) gives 0 for NaN, as maxps does with 0 as its second operand; v is never
    // −0 (x − x is +0), so the two agree on signed zeros too.
    let z = _mm256_sqrt_ps(_mm256_max_ps(rest, zero));
    let mut out = Directions {
        x: [0.0; 8],
        y: [0.0; 8],
        z: [0.0; 8],
    };
    _mm256_storeu_ps(out.x.as_mut_ptr(), x);
    _mm256_storeu_ps(out.y.as_mut_ptr(), y);
    _mm256_storeu_ps(out.z.as_mut_ptr(), z);
    out
}

/// `warp::cos_sin_within_quarter` in each lane, by its Horner steps (`COS_STEPS`, `SIN_STEPS`).
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn cos_sin_within_quarter(phi: __m256) -> (__m256, __m256) {
    let splat = _mm256_set1_ps;
    let one = splat(1.0);
    let x2 = _mm256_mul_ps(phi, phi);
    // 1 − x²·c·rest, over the steps innermost first.
    let horner = |steps: [f32; 4]| {
        steps.iter().rev().fold(one, |rest, &c| {
            _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, splat(c)), rest))
        })
    };
    (horner(COS_STEPS), _mm256_mul_ps(phi, horner(SIN_STEPS)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng::mix64;
    use crate::sampling::warp;

    #[test]
    fn eight_lanes_give_the_scalar_warp_bit_for_bit() {
        if !crate::cpu::has_avx2_fma() {
            return;
        }
        // The centre, the diagonals (|a| = |b|), the edges, and random points on the 2^-24 grid
        // that the samplers produce.
        let grid = |k: u64| (k & 0xff_ffff) as f32 / 16_777_216.0;
        let special = [0.0, 0.5, 0.25, 0.75, 1.0 - 1.0 / 16_777_216.0];
        let mut points: Vec<[f32; 2]> = special
            .iter()
            .flat_map(|&a| special.iter().map(move |&b| [a, b]))
            .collect();
        let mut state = 7u64;
        for _ in 0..400_000 {
            state = mix64(state);
            let (x, y) = (grid(state), grid(state >> 24));
            points.push([x, y]);
            points.push([x, x]);
            points.push([x, 1.0 - x]);
        }
        for chunk in points.chunks(8) {
            let lane = |i: usize, c: usize| chunk[i.min(chunk.len() - 1)][c];
            let (u0, u1) = (
                std::array::from_fn(|i| lane(i, 0)),
                std::array::from_fn(|i| lane(i, 1)),
            );
            // SAFETY: the CPU has AVX2 (checked above).
            let d = unsafe { cosine_hemisphere(&u0, &u1) };
            for i in 0..chunk.len() {
                let want = warp::cosine_hemisphere([u0[i], u1[i]]);
                let got = [d.x[i], d.y[i], d.z[i]].map(f32::to_bits);
                assert_eq!(
                    got,
                    want.to_array().map(f32::to_bits),
                    "u {:?}",
                    [u0[i], u1[i]]
                );
            }
        }
    }
}
