//! Compact coding of node bounds. Build-tree nodes: box corners as 16-bit codes on
//! a grid spanning the root box (rounded outwards), cosines as 15-bit codes
//! (rounded down), the cone axis as a 2×16-bit octahedral code with θo widened by
//! its coding error. Wide-node lanes: the cone axis as three 16-bit components
//! (`encode_axis`), the sphere's radius as a 16-bit multiple of a node step
//! (`radius_step`, `encode_radius`, rounded up). Every rounding enlarges the
//! bound, so a node never loses a reachable light.

use glam::{DVec3, Vec3, Vec3A};
use std::cell::Cell;
use std::thread::LocalKey;

use super::*;

/// Grid on which node boxes are stored: coordinate k of code q decodes to
/// `origin[k] + q · step[k]`, q = 0 ..= 65535, and code 65535 reaches at least
/// the root box's upper corner.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub(super) origin: Vec3A,
    pub(super) step: Vec3A,
    /// 1/step (0 along axes without extent), for first guesses only.
    pub(super) inv_step: Vec3A,
}

/// `origin + q · step`, coordinate by coordinate: how a grid code decodes ([`Grid::decode`],
/// and a wide node's lane centres on the grid its `origin` and `step` keep).
pub(super) fn decode_on_grid(origin: Vec3A, step: Vec3A, q: [u16; 3]) -> Vec3 {
    let q = Vec3A::new(f32::from(q[0]), f32::from(q[1]), f32::from(q[2]));
    (origin + q * step).into()
}

impl Grid {
    pub(super) fn new(lo: Vec3, hi: Vec3) -> Grid {
        let step = |k: usize| {
            let mut s = ((f64::from(hi[k]) - f64::from(lo[k])) / f64::from(BOX_MAX)) as f32;
            while lo[k] + BOX_MAX as f32 * s < hi[k] {
                s = s.next_up();
            }
            s
        };
        let step = Vec3A::new(step(0), step(1), step(2));
        Grid {
            origin: lo.into(),
            step,
            inv_step: Vec3A::select(step.cmpgt(Vec3A::ZERO), step.recip(), Vec3A::ZERO)
                .min(Vec3A::splat(f32::MAX)),
        }
    }

    pub(super) fn decode(&self, q: [u16; 3]) -> Vec3 {
        decode_on_grid(self.origin, self.step, q)
    }

    /// Codes whose decoding is ≤ `x` (`up` false) or ≥ `x` (`up` true): a
    /// first guess rounded down (up), then stepped until the decoding
    /// arithmetic itself confirms the rounding direction.
    pub(super) fn encode(&self, x: Vec3, up: bool) -> [u16; 3] {
        let x = Vec3A::from(x);
        let top = Vec3A::splat(BOX_MAX as f32);
        let guess = ((x - self.origin) * self.inv_step).clamp(Vec3A::ZERO, top);
        let mut q = if up { guess.ceil() } else { guess.floor() };
        loop {
            let at = self.origin + q * self.step;
            let (wrong, next) = if up {
                (at.cmplt(x) & q.cmplt(top), q + 1.0)
            } else {
                (at.cmpgt(x) & q.cmpgt(Vec3A::ZERO), q - 1.0)
            };
            if !wrong.any() {
                // SAFETY: q is a whole number in [0, 65535] (the guess is clamped there, a NaN
                // to 0 by `_mm_max_ps`, and a step never leaves it): it fits a u32.
                return [q.x, q.y, q.z].map(|c| unsafe { c.to_int_unchecked::<u32>() } as u16);
            }
            q = Vec3A::select(wrong, next, q);
        }
    }
}

/// (cos, sin) of the angle in [0, π] whose cosine is `c` (clamped to [−1, 1]).
pub(super) fn cos_sin(c: f64) -> (f64, f64) {
    let c = c.clamp(-1.0, 1.0);
    (c, ((1.0 - c) * (1.0 + c)).max(0.0).sqrt())
}

/// acos(min(|w'|, 1/|w'|)) as a (cos, sin) pair, for a coded axis w' of length `length`: the
/// most by which the lanes' cos ∠(w', d) for a unit d, computed as w'·d, can overstate or
/// understate the angle, which the coding adds to θo.
pub(super) fn stretch(length: f64) -> (f64, f64) {
    cos_sin(length.min(1.0 / length))
}

/// cos(min(π, θ + `angle`)) for cos θ = `cos`: a cone widened by `angle` radians.
pub(super) fn widened(cos: f32, angle: f32) -> f64 {
    let angle = f64::from(angle);
    angle_sum(cos_sin(f64::from(cos)), (angle.cos(), angle.sin())).0
}

/// 15-bit cosine code → cosine in [−1, 1].
pub(super) fn decode_cos(q: u32) -> f32 {
    q as f32 * (2.0 / COS_MAX as f32) - 1.0
}

/// A 15-bit code whose cosine is ≤ `c` (a wider or equal angle): `c` rounded
/// down to the grid, then checked with the decoding arithmetic.
pub(super) fn encode_cos(c: f64) -> u32 {
    let q = ((c + 1.0) * 0.5 * f64::from(COS_MAX)).clamp(0.0, f64::from(COS_MAX)) as u32;
    let fits = |q: u32| q == 0 || f64::from(decode_cos(q)) <= c;
    // The first guess nearly always fits. Checked on its own before the search, which the
    // compiler would otherwise turn into a 16-code SIMD scan with a slow reduction.
    if fits(q) {
        return q;
    }
    (0..q).rev().find(|&q| fits(q)).unwrap_or(0)
}

/// Octahedral code of a unit vector: 16 bits for each of the two coordinates
/// of its projection onto |x| + |y| + |z| = 1, the lower half folded over.
pub(super) fn encode_octahedral(v: Vec3) -> u32 {
    let v = v / (v.x.abs() + v.y.abs() + v.z.abs());
    let (x, y) = if v.z < 0.0 {
        (
            (1.0 - v.y.abs()) * v.x.signum(),
            (1.0 - v.x.abs()) * v.y.signum(),
        )
    } else {
        (v.x, v.y)
    };
    let code = |t: f32| ((t.clamp(-1.0, 1.0) * 0.5 + 0.5) * BOX_MAX as f32 + 0.5) as u32;
    code(x) | code(y) << 16
}

/// Unit vector of an octahedral code.
#[inline(always)]
pub(super) fn decode_octahedral(code: u32) -> Vec3 {
    let coord = |q: u32| (q & BOX_MAX) as f32 * (2.0 / BOX_MAX as f32) - 1.0;
    let (x, y) = (coord(code), coord(code >> 16));
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum())
    } else {
        (x, y)
    };
    Vec3::new(x, y, z).normalize()
}

/// The last cone an encoder coded on this thread, by the bits of (w, cos θo), and its codes.
type Last<V> = Cell<Option<([u32; 4], V)>>;

thread_local! {
    static LAST_CONE: Last<(u32, u32)> = const { Cell::new(None) };
    static LAST_AXIS: Last<([i16; 3], u32)> = const { Cell::new(None) };
}

/// `code()`, the codes of the cone (w, cos θo), unless `last` holds them already (the same bits
/// coded last on this thread). Neighbouring nodes mostly share their cone (a facade's lights one
/// normal, a parent its children's cone when one holds the other): in the 1M-light city 95% of
/// [`encode_cone`]'s calls repeat the thread's previous one. The codes are a function of the bits
/// alone, so they do not depend on what was coded before.
fn remembered<V: Copy + 'static>(
    last: &'static LocalKey<Last<V>>,
    (w, cos_o): (Vec3, f32),
    code: impl FnOnce() -> V,
) -> V {
    let key = [w.x, w.y, w.z, cos_o].map(f32::to_bits);
    last.with(|last| match last.get() {
        Some((seen, codes)) if seen == key => codes,
        _ => {
            let codes = code();
            last.set(Some((key, codes)));
            codes
        }
    })
}

/// Quantised normal cone: the axis' octahedral code and the 15-bit cos θo of
/// a cone about the decoded axis that holds the original cone (θo widened by
/// the angle between the two axes).
pub(super) fn encode_cone(w: Vec3, cos_o: f32) -> (u32, u32) {
    remembered(&LAST_CONE, (w, cos_o), || code_cone(w, cos_o))
}

/// [`encode_cone`], computed.
fn code_cone(w: Vec3, cos_o: f32) -> (u32, u32) {
    if is_whole_sphere((w, cos_o)) {
        return (encode_octahedral(Vec3::Z), 0);
    }
    let code = encode_octahedral(w);
    let (a, b) = (w.as_dvec3().normalize(), decode_octahedral(code).as_dvec3());
    let error = (a.dot(b), a.cross(b).length());
    let theta = angle_sum(cos_sin(f64::from(cos_o)), error);
    let slack = (1.0 - 0.5 * ANGLE_SLACK * ANGLE_SLACK, ANGLE_SLACK);
    (code, encode_cos(angle_sum(theta, slack).0))
}

/// The cone (w, cos θo) for a wide node's lane: w as three codes of [`AXIS_STEP`] and the
/// [`encode_cos`] code of a θo widened by the angle between w and the decoded axis w', and by
/// its [`stretch`]. Of the eight codes next to w's (each
/// component rounded down or up), the one with |w'| nearest to 1 is kept, so the lanes'
/// cosines are barely scaled.
pub(super) fn encode_axis(w: Vec3, cos_o: f32) -> ([i16; 3], u32) {
    remembered(&LAST_AXIS, (w, cos_o), || code_axis(w, cos_o))
}

/// [`encode_axis`], computed.
fn code_axis(w: Vec3, cos_o: f32) -> ([i16; 3], u32) {
    if is_whole_sphere((w, cos_o)) {
        return ([0, 0, i16::MAX], 0);
    }
    let w = w.as_dvec3().normalize();
    let scale = f64::from(i16::MAX);
    let whole = i64::from(i16::MAX).pow(2);
    // Floors through integer conversion: `f64::floor` is a library call on x86-64 without
    // SSE4.1.
    let below = |x: f64| x as i64 - i64::from((x as i64) as f64 > x);
    let floors = w.to_array().map(|c| below(c * scale));
    let mut best = ([0i16; 3], i64::MAX);
    for up in 0..8 {
        let code = [0, 1, 2].map(|a| {
            let c = floors[a] + (up >> a & 1);
            c.clamp(-i64::from(i16::MAX), i64::from(i16::MAX)) as i16
        });
        // |length² − 1| in code units, exact in integers.
        let off = (code.iter().map(|&c| i64::from(c).pow(2)).sum::<i64>() - whole).abs();
        if off < best.1 {
            best = (code, off);
        }
    }
    let code = best.0;
    let decoded = DVec3::from_array(code.map(|c| f64::from(f32::from(c) * AXIS_STEP)));
    let length = decoded.length();
    let turn = (w.dot(decoded) / length, w.cross(decoded).length() / length);
    let theta = angle_sum(angle_sum(cos_sin(f64::from(cos_o)), turn), stretch(length));
    let slack = (1.0 - 0.5 * ANGLE_SLACK * ANGLE_SLACK, ANGLE_SLACK);
    (code, encode_cos(angle_sum(theta, slack).0))
}

/// Largest radius code: below 65535, so a radius rounded up one more step still fits.
const RADIUS_MAX: f64 = 65000.0;

/// The radius step of a node whose lanes need radii `radii` (f64, ≥ 0).
pub(super) fn radius_step(radii: impl Iterator<Item = f64>) -> f32 {
    let largest = radii.fold(0.0, f64::max);
    if largest > 0.0 {
        ((largest / RADIUS_MAX) as f32).max(f32::MIN_POSITIVE)
    } else {
        0.0
    }
}

/// A radius code whose decoding (code · `step`) is at least `radius`.
pub(super) fn encode_radius(radius: f64, step: f32) -> u16 {
    if radius <= 0.0 {
        return 0;
    }
    let mut q = (radius / f64::from(step)).ceil();
    while f64::from(q as f32 * step) < radius {
        q += 1.0;
    }
    q as u16
}

/// (cos, sin) of α + β from those of α, β ∈ [0, π]; (−1, 0) once α + β ≥ π.
pub(super) fn angle_sum((cos_a, sin_a): (f64, f64), (cos_b, sin_b): (f64, f64)) -> (f64, f64) {
    if cos_a + cos_b <= 0.0 {
        return (-1.0, 0.0);
    }
    (cos_a * cos_b - sin_a * sin_b, sin_a * cos_b + cos_a * sin_b)
}

/// Φ as a bfloat16 code (the upper half of its f32 bits, rounded to nearest, never to 0 or ∞;
/// 0.4% at most off), its sign bit set for a two-sided lane. `phi` must be finite and > 0.
pub(super) fn encode_phi(phi: f32, two_sided: bool) -> u16 {
    let bits = phi.to_bits();
    let rounded = (bits + 0x7FFF + ((bits >> 16) & 1)) >> 16;
    let code = rounded.clamp(1, 0x7F7F) as u16;
    if two_sided {
        code | 0x8000
    } else {
        code
    }
}

/// The signed Φ of an [`encode_phi`] code (negative: two-sided; 0 for code 0).
#[inline(always)]
pub(super) fn decode_phi(code: u16) -> f32 {
    f32::from_bits(u32::from(code) << 16)
}

/// Largest power-centre offset code: an offset of one radius.
pub(super) const OFFSET_MAX: f32 = 127.0;

/// `offset` (a point's place relative to a sphere's centre) in units of `radius` / 127, each
/// component rounded to nearest and clamped to one radius; zeros for a radius of 0.
pub(super) fn encode_offset(offset: DVec3, radius: f32) -> [i8; 3] {
    if radius <= 0.0 {
        return [0; 3];
    }
    let scaled = offset / f64::from(radius) * f64::from(OFFSET_MAX);
    scaled
        .to_array()
        .map(|x| round_to_nearest(x).clamp(-f64::from(OFFSET_MAX), f64::from(OFFSET_MAX)) as i8)
}

/// Largest spread code (four bits): a spread of one radius.
pub(super) const SPREAD_MAX: f32 = 15.0;

/// A lane's spread `sigma` in steps of `radius` / 15, rounded to nearest, clamped to one radius
/// (which it never exceeds: the power centre minimises the Φ-weighted mean square distance, and
/// from the sphere's centre every box centre is within one radius); 0 for a radius of 0.
pub(super) fn encode_spread(sigma: f64, radius: f32) -> u8 {
    if radius <= 0.0 {
        return 0;
    }
    round_to_nearest(sigma / f64::from(radius) * f64::from(SPREAD_MAX))
        .clamp(0.0, f64::from(SPREAD_MAX)) as u8
}

/// `x.round()` (to the nearest whole number, halves away from zero) for the codes above, from a
/// truncation by conversion to i64 and the remainder, where `f64::round` is a library call on
/// CPUs without SSE4.1 (x86-64's baseline; at 1M lights the collapse took 1,896 M instructions
/// with it and 1,790 M without, valgrind --tool=callgrind).
/// Equal to `x.round()` for |x| < 2⁶³ but for the sign of a zero; beyond, and for ±∞, the
/// conversion saturates to ±2⁶³ and NaN gives 0, which the callers' clamps code as they code
/// `x.round()`.
#[inline(always)]
pub(super) fn round_to_nearest(x: f64) -> f64 {
    let whole = x as i64 as f64;
    // Exact: x and its whole part share their leading bits.
    let rest = x - whole;
    if rest >= 0.5 {
        whole + 1.0
    } else if rest <= -0.5 {
        whole - 1.0
    } else {
        whole
    }
}
