//! Moving a ray's origin off the surface it starts on.
//!
//! A ray origin on a surface moves off it along the unit normal `n` (toward the side the ray
//! leaves from), by a few ULPs of the position's magnitude, so the ray cannot hit the surface it
//! starts on (Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
//! Ray Tracing Gems, 2019): 256 ULPs per component, and for components below 1/32 (where ULPs
//! vanish) a fixed-point step of 2^-16 · s, with s = 32·max|p_i| clamped to [2^-10, 1]. Their
//! s = 1 (an absolute 1.5e-5 m) is a sixth of a 1e-4 m scene and lets rays start behind nearby
//! walls; s scales it with the point's own magnitude, down to 1.5e-8 m, still 128 ULPs of the
//! 1e-3 m guard (`NODE_CULL_GUARD`) the ray is started behind. Works for 1e-4 m and 1e6 m scenes
//! alike. Every shading point and every sampled light point takes it, so on x86-64 the three
//! components go through SSE2 lanes together, with the same operations as the one-by-one form.

use glam::Vec3;

/// Components of |p| below this take the fixed-point step.
const ORIGIN: f32 = 1.0 / 32.0;
/// The fixed-point step at s = 1.
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
/// The least s.
const MIN_SCALE: f32 = 1.0 / 1024.0;
/// ULPs per unit of the normal's component.
const INT_SCALE: f32 = 256.0;

/// The fixed-point step 2^-16 · s for the point `p` (see the module header).
#[inline(always)]
fn fixed_step(p: Vec3) -> f32 {
    FLOAT_SCALE * (p.abs().max_element() / ORIGIN).clamp(MIN_SCALE, 1.0)
}

/// `p` moved off its surface along the unit normal `n` (see the module header), the three
/// components at once in SSE2 lanes: the same bits as `offset_one_by_one` for every `p` and every
/// `n` whose components are NaN or have |256 n_i| < 2³¹ (every unit normal).
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    let step = fixed_step(p);
    // SAFETY: SSE2 is part of x86-64; the lanes are plain values.
    unsafe {
        let pv = _mm_set_ps(0.0, p.z, p.y, p.x);
        let nv = _mm_set_ps(0.0, n.z, n.y, n.x);
        // (256 n_i) as i32, truncated; a NaN lane gives 0, as `as` does.
        let scaled = _mm_mul_ps(_mm_set1_ps(INT_SCALE), nv);
        let scaled = _mm_and_ps(scaled, _mm_cmpord_ps(scaled, scaled));
        let offset = _mm_cvttps_epi32(scaled);
        // −offset where p_i < 0 (two's complement: (o ^ −1) − (−1) = −o), added to p_i's bits.
        let negative = _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps()));
        let offset = _mm_sub_epi32(_mm_xor_si128(offset, negative), negative);
        let nudged = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), offset));
        // Components below 1/32 in magnitude take p_i + step · n_i instead.
        let small = _mm_cmplt_ps(_mm_andnot_ps(_mm_set1_ps(-0.0), pv), _mm_set1_ps(ORIGIN));
        let stepped = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(step), nv));
        let moved = _mm_or_ps(_mm_and_ps(small, stepped), _mm_andnot_ps(small, nudged));
        let mut out = [0.0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), moved);
        Vec3::new(out[0], out[1], out[2])
    }
}

/// `offset_one_by_one` off x86-64.
#[cfg(not(target_arch = "x86_64"))]
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_one_by_one(p, n)
}

/// `p` moved off its surface along the unit normal `n`, component by component (see the module
/// header).
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline]
fn offset_one_by_one(p: Vec3, n: Vec3) -> Vec3 {
    let offset_int = (INT_SCALE * n).as_ivec3();
    let nudge = |x: f32, o: i32| {
        let o = if x < 0.0 { o.wrapping_neg() } else { o };
        f32::from_bits((x.to_bits() as i32).wrapping_add(o) as u32)
    };
    let step = fixed_step(p);
    let pick = |x: f32, o: i32, nx: f32| {
        if x.abs() < ORIGIN {
            x + step * nx
        } else {
            nudge(x, o)
        }
    };
    Vec3::new(
        pick(p.x, offset_int.x, n.x),
        pick(p.y, offset_int.y, n.y),
        pick(p.z, offset_int.z, n.z),
    )
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::sampling::rng::PixelRng;

    /// The SSE2 form gives the one-by-one form's bits: 400,000 random points (magnitudes from
    /// 1e-9 to 1e7, either sign, with zeros, −0.0, denormals, components at ±1/32 and next to it,
    /// infinities and NaN) against random unit normals, the axes with signed zeros, and a normal
    /// with a NaN component.
    #[test]
    fn the_lanes_give_the_bits_of_the_one_by_one_form() {
        let mut rng = PixelRng::new(11, 12);
        let specials = [
            0.0f32,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(7),
            ORIGIN,
            -ORIGIN,
            ORIGIN.next_down(),
            -ORIGIN.next_up(),
            f32::INFINITY,
            f32::NAN,
            1.0,
        ];
        let component = |rng: &mut PixelRng| {
            let [a, b] = rng.next_2d();
            if a < 0.1 {
                specials[(b * specials.len() as f32) as usize % specials.len()]
            } else {
                let magnitude = 10f32.powf(-9.0 + 16.0 * b);
                if a < 0.55 {
                    magnitude
                } else {
                    -magnitude
                }
            }
        };
        let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        for i in 0..400_000 {
            let p = Vec3::new(
                component(&mut rng),
                component(&mut rng),
                component(&mut rng),
            );
            let n = if i % 4 == 0 {
                axes[i / 4 % axes.len()]
            } else if i % 101 == 1 {
                Vec3::new(f32::NAN, 0.6, -0.8)
            } else {
                let [u, v] = rng.next_2d();
                let [w, _] = rng.next_2d();
                Vec3::new(2.0 * u - 1.0, 2.0 * v - 1.0, 2.0 * w - 1.0).normalize_or(Vec3::Z)
            };
            let (lanes, one) = (offset_ray_origin(p, n), offset_one_by_one(p, n));
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            assert_eq!(bits(lanes), bits(one), "p {p:?}, n {n:?}");
        }
    }
}
