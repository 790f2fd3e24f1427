//! The importance of a wide node's eight children at a receiver, computed in
//! SIMD lanes (f32x8) without trigonometry: pbrt-v4's `LightBounds::Importance`
//! bound, with each child's box seen as its bounding sphere.
//!
//! For a child with sphere (c, r), power Φ, normal cone (w, θo) and spread θe,
//! at receiver p with unit normal n, d = |p − c|, θb = asin(r/d):
//!   importance = Φ · cos θp · cos θr / max(d², r²),
//! θp = max(0, θw − θo − θb), θw = ∠(w, p − c) (folded to ≤ 90° when
//! two-sided), 0 when θp ≥ θe; θr = max(0, ∠(n, c − p) − θb), 0 when θr ≥ 90°.
//! Inside the sphere (d ≤ r) both cosines are 1. Angles are combined through
//! their (cos, sin) pairs; cosines near a threshold get a margin of `COS_SLACK`
//! so f32 rounding never rejects a child that can reach p's upper hemisphere.
//! Positive results lie in [f32::MIN_POSITIVE, f32::MAX]; unused lanes give 0.

use ::wide::f32x8;
use glam::Vec3;

use super::*;

type Lanes = f32x8;

const ZERO: Lanes = Lanes::ZERO;
const ONE: Lanes = Lanes::ONE;

#[inline(always)]
fn load(values: &[f32; LANES]) -> Lanes {
    Lanes::from(*values)
}

/// sin θ from cos θ, θ ∈ [0, π], as √((1 − c)(1 + c)) (accurate near ±1).
#[inline(always)]
fn sin_of(cos: Lanes) -> Lanes {
    ((ONE - cos) * (ONE + cos)).max(ZERO).sqrt()
}

/// (cos, sin) of max(0, α − β) from those of α and β, α, β ∈ [0, π].
#[inline(always)]
fn minus(cos_a: Lanes, sin_a: Lanes, cos_b: Lanes, sin_b: Lanes) -> (Lanes, Lanes) {
    let within = cos_a.simd_ge(cos_b);
    let cos = within.select(ONE, cos_a * cos_b + sin_a * sin_b);
    let sin = within.select(ZERO, (sin_a * cos_b - cos_a * sin_b).max(ZERO));
    (cos, sin)
}

/// The importance of each lane of `node` at receiver `p` with unit normal `n`
/// (`Vec3::ZERO`: no receiver term). `p` and `n` must be finite.
#[inline(always)]
pub(super) fn importances(node: &WideNode, p: Vec3, n: Vec3) -> [f32; LANES] {
    let to_p = [0, 1, 2].map(|k| Lanes::splat(p[k]) - load(&node.centre[k]));
    let dist_sq = to_p[0] * to_p[0] + to_p[1] * to_p[1] + to_p[2] * to_p[2];
    let radius = load(&node.radius);
    let radius_sq = radius * radius;
    let outside = dist_sq.simd_gt(radius_sq);
    let inv_dist = ONE / dist_sq.sqrt();
    let dir = to_p.map(|t| t * inv_dist);
    let sin_b = (radius * inv_dist).min(ONE);
    let cos_b = sin_of(sin_b);

    let signed_phi = load(&node.signed_phi);
    let phi = signed_phi.abs();
    let axis = [0, 1, 2].map(|k| load(&node.axis[k]));
    let cos_w = axis[0] * dir[0] + axis[1] * dir[1] + axis[2] * dir[2];
    let cos_w = signed_phi.simd_lt(ZERO).select(cos_w.abs(), cos_w);
    let cos_o = load(&node.cos_o);
    let (cos_x, sin_x) = minus(cos_w, sin_of(cos_w), cos_o, sin_of(cos_o));
    let (cos_p, _) = minus(cos_x, sin_x, cos_b, sin_b);
    let slack = Lanes::splat(COS_SLACK);
    let mut reject = cos_p.simd_le(load(&node.cos_e) - slack);
    let mut factor = cos_p.max(slack);

    if n != Vec3::ZERO {
        let cos_i = -(dir[0] * n.x + dir[1] * n.y + dir[2] * n.z);
        let (cos_r, _) = minus(cos_i, sin_of(cos_i), cos_b, sin_b);
        reject |= cos_r.simd_le(-slack);
        factor *= cos_r.max(slack);
    }
    let reject = (reject & outside) | phi.simd_le(ZERO);
    let factor = outside.select(factor, ONE);
    let d_sq = dist_sq.max(radius_sq).max(Lanes::splat(f32::MIN_POSITIVE));
    let value = (phi * factor / d_sq)
        .min(Lanes::splat(f32::MAX))
        .max(Lanes::splat(f32::MIN_POSITIVE));
    reject.select(ZERO, value).to_array()
}
