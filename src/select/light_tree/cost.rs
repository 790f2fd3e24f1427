//! The split cost's orientation term for a batch of sides, in SIMD lanes: four (SSE, any
//! x86-64) or eight (AVX2, chosen at run time). Both widths do the same IEEE operations per lane
//! (no fused multiply-adds: the compiler never contracts them), so the costs, and the tree, do
//! not depend on the CPU.

use glam::{BVec4A, Vec4};
use std::ops::{Add, Div, Mul, Sub};

use super::*;

/// Sides whose costs [`CostInputs::costs`] evaluates together: the prefix and
/// suffix runs of one axis' cuts.
pub(super) const BATCH: usize = 2 * MAX_CUT_ITEMS;

/// What the costs of up to [`BATCH`] sides need, one array per field so that
/// they are evaluated in SIMD lanes.
#[derive(Clone, Copy, Debug)]
pub(super) struct CostInputs {
    /// Φ · padded surface area, scaled (to at most 1 in a node).
    pub(super) phi_area: [f32; BATCH],
    /// |a|², a being the sum of the corners of the box holding the unit axes
    /// (1 for a single light).
    pub(super) a_sq: [f32; BATCH],
    /// The smallest a·w over that box, Σ min(a·lo, a·hi) (1 for a single light).
    pub(super) a_min: [f32; BATCH],
    /// Widest θo and θe, as cosines.
    pub(super) cos_o: [f32; BATCH],
    pub(super) cos_e: [f32; BATCH],
    /// Whether [`costs`](Self::costs) runs its AVX2 copy: the CPU was asked once, when these
    /// inputs were made for a build.
    pub(super) avx2: bool,
}

impl CostInputs {
    /// Inputs of no side, for a build on this CPU.
    pub(super) fn new() -> CostInputs {
        CostInputs {
            phi_area: [0.0; BATCH],
            a_sq: [0.0; BATCH],
            a_min: [0.0; BATCH],
            cos_o: [1.0; BATCH],
            cos_e: [1.0; BATCH],
            avx2: crate::cpu::has_avx2_fma(),
        }
    }

    /// pbrt-v4's split cost of sides `..n` without the axis factor,
    /// Φ · M_Ω(θo, θe) · surface area (scaled), θo being that of a cone
    /// holding every light's normal cone: about the direction a, the smallest
    /// a·w/|a| bounds the axes' angle from a, and the widest θo is added to
    /// it. Entries from `n` up to the next multiple of 8 are unspecified (they
    /// come from whatever the inputs hold there).
    pub(super) fn costs(&self, n: usize) -> [f32; BATCH] {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU reported AVX2 and FMA.
            return unsafe { self.costs_avx2(n) };
        }
        self.costs_in::<Vec4>(n)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn costs_avx2(&self, n: usize) -> [f32; BATCH] {
        self.costs_in::<avx::F8>(n)
    }

    /// [`costs`](Self::costs), `L::WIDTH` sides at a time.
    #[inline(always)]
    fn costs_in<L: Lanes>(&self, n: usize) -> [f32; BATCH] {
        let mut costs = [0.0; BATCH];
        for i in (0..n).step_by(L::WIDTH) {
            let lanes = |field: &[f32; BATCH]| L::load(&field[i..i + L::WIDTH]);
            let (a_sq, cos_o) = (lanes(&self.a_sq), lanes(&self.cos_o));
            let nearest = L::select(
                a_sq.cmpgt(L::splat(0.0)),
                (lanes(&self.a_min) / a_sq.sqrt())
                    .max(L::splat(-1.0))
                    .min(L::splat(1.0)),
                L::splat(-1.0),
            );
            // cos(θ + θo), θ the axes' angle from a.
            let cos_half = cos_sum(nearest, cos_o, sin_of(cos_o));
            let cost = lanes(&self.phi_area) * orientation_measure(cos_half, lanes(&self.cos_e));
            cost.store(&mut costs[i..i + L::WIDTH]);
        }
        costs
    }
}

/// f32 SIMD lanes with the operations of SSE's `_ps` instructions (their NaN and signed-zero
/// rules: `min`/`max` give the second operand when either is NaN or both are equal; the
/// comparisons are ordered, false for a NaN).
pub(super) trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// A lane mask (all ones or all zeros per lane).
    type Mask: Copy;
    const WIDTH: usize;
    fn splat(x: f32) -> Self;
    /// The first `WIDTH` values of `from`.
    fn load(from: &[f32]) -> Self;
    fn store(self, to: &mut [f32]);
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn min(self, other: Self) -> Self;
    fn max(self, other: Self) -> Self;
    fn cmpeq(self, other: Self) -> Self::Mask;
    fn cmplt(self, other: Self) -> Self::Mask;
    fn cmple(self, other: Self) -> Self::Mask;
    fn cmpgt(self, other: Self) -> Self::Mask;
    fn cmpge(self, other: Self) -> Self::Mask;
    fn select(mask: Self::Mask, if_true: Self, if_false: Self) -> Self;
}

impl Lanes for Vec4 {
    type Mask = BVec4A;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec4::splat(x)
    }
    #[inline(always)]
    fn load(from: &[f32]) -> Self {
        Vec4::from_slice(from)
    }
    #[inline(always)]
    fn store(self, to: &mut [f32]) {
        self.write_to_slice(to);
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Vec4::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        Vec4::min(self, other)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        Vec4::max(self, other)
    }
    #[inline(always)]
    fn cmpeq(self, other: Self) -> BVec4A {
        self.cmpeq(other)
    }
    #[inline(always)]
    fn cmplt(self, other: Self) -> BVec4A {
        self.cmplt(other)
    }
    #[inline(always)]
    fn cmple(self, other: Self) -> BVec4A {
        self.cmple(other)
    }
    #[inline(always)]
    fn cmpgt(self, other: Self) -> BVec4A {
        self.cmpgt(other)
    }
    #[inline(always)]
    fn cmpge(self, other: Self) -> BVec4A {
        self.cmpge(other)
    }
    #[inline(always)]
    fn select(mask: BVec4A, if_true: Self, if_false: Self) -> Self {
        Vec4::select(mask, if_true, if_false)
    }
}

/// Eight lanes in one AVX register, used only by code compiled for AVX2.
#[cfg(target_arch = "x86_64")]
mod avx {
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Sub};

    use super::Lanes;

    #[derive(Clone, Copy, Debug)]
    pub(super) struct F8(__m256);

    // SAFETY (every `unsafe` block below): an F8 exists only inside functions compiled with
    // AVX2 enabled (`CostInputs::costs_avx2`, called once the CPU reported it), into which
    // these always-inlined operations are inlined; loads and stores are of `WIDTH` values of
    // slices checked to hold them.
    macro_rules! binary {
        ($op:ident, $fn:ident, $intrinsic:ident) => {
            impl $op for F8 {
                type Output = F8;
                #[inline(always)]
                fn $fn(self, other: F8) -> F8 {
                    F8(unsafe { $intrinsic(self.0, other.0) })
                }
            }
        };
    }
    binary!(Add, add, _mm256_add_ps);
    binary!(Sub, sub, _mm256_sub_ps);
    binary!(Mul, mul, _mm256_mul_ps);
    binary!(Div, div, _mm256_div_ps);

    impl Lanes for F8 {
        type Mask = F8;
        const WIDTH: usize = 8;
        #[inline(always)]
        fn splat(x: f32) -> F8 {
            F8(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn load(from: &[f32]) -> F8 {
            let from = &from[..8];
            F8(unsafe { _mm256_loadu_ps(from.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, to: &mut [f32]) {
            let to = &mut to[..8];
            unsafe { _mm256_storeu_ps(to.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn sqrt(self) -> F8 {
            F8(unsafe { _mm256_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn abs(self) -> F8 {
            F8(unsafe { _mm256_and_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX))) })
        }
        #[inline(always)]
        fn min(self, other: F8) -> F8 {
            F8(unsafe { _mm256_min_ps(self.0, other.0) })
        }
        #[inline(always)]
        fn max(self, other: F8) -> F8 {
            F8(unsafe { _mm256_max_ps(self.0, other.0) })
        }
        #[inline(always)]
        fn cmpeq(self, other: F8) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, other.0) })
        }
        #[inline(always)]
        fn cmplt(self, other: F8) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_LT_OS>(self.0, other.0) })
        }
        #[inline(always)]
        fn cmple(self, other: F8) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_LE_OS>(self.0, other.0) })
        }
        #[inline(always)]
        fn cmpgt(self, other: F8) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_GT_OS>(self.0, other.0) })
        }
        #[inline(always)]
        fn cmpge(self, other: F8) -> F8 {
            F8(unsafe { _mm256_cmp_ps::<_CMP_GE_OS>(self.0, other.0) })
        }
        #[inline(always)]
        fn select(mask: F8, if_true: F8, if_false: F8) -> F8 {
            F8(unsafe { _mm256_blendv_ps(if_false.0, if_true.0, mask.0) })
        }
    }
}

/// sin θ from cos θ for θ ∈ [0, π], lane by lane, written (1 − c)(1 + c) to stay accurate
/// near c = ±1 (0 for |c| ≥ 1 or NaN).
#[inline(always)]
pub(super) fn sin_of<L: Lanes>(cos: L) -> L {
    let sin_sq = (L::splat(1.0) - cos) * (L::splat(1.0) + cos);
    L::select(sin_sq.cmpgt(L::splat(0.0)), sin_sq.sqrt(), L::splat(0.0))
}

/// cos(α + β) from cos α, cos β and sin β, α, β ∈ [0, π], lane by lane; −1 once α + β ≥ π
/// (cos α + cos β ≤ 0), and at least −1 (also for a NaN: `max` gives its second operand).
#[inline(always)]
pub(super) fn cos_sum<L: Lanes>(cos_a: L, cos_b: L, sin_b: L) -> L {
    let sum = (cos_a * cos_b - sin_of(cos_a) * sin_b).max(L::splat(-1.0));
    L::select((cos_a + cos_b).cmple(L::splat(0.0)), L::splat(-1.0), sum)
}

/// M_Ω(θo, θe) lane by lane: the integral of the clamped emission bound over
/// the sphere, 2π(1 − cos θo) + π/2·(2θw sin θo − cos(θo − 2θw) − 2θo sin θo +
/// cos θo) with θw = min(θo + θe, π); in f32 with an approximate arccosine (it
/// only ranks splits).
#[inline(always)]
pub(super) fn orientation_measure<L: Lanes>(co: L, ce: L) -> L {
    use std::f32::consts::{FRAC_PI_2, PI};
    let splat = L::splat;
    let (so, se) = (sin_of(co), sin_of(ce));
    let theta_o = approx_acos(co);
    let theta_e = L::select(ce.cmpeq(splat(0.0)), splat(FRAC_PI_2), approx_acos(ce));
    // θw − θo, and cos(θo − 2θw) = cos(θo + 2θe) unless θw = π.
    let spread = theta_e.min(splat(PI) - theta_o);
    let wraps = (theta_o + theta_e).cmpge(splat(PI));
    let cos_o_2e = co * (splat(2.0) * ce * ce - splat(1.0)) - so * (splat(2.0) * se * ce);
    let cos_o_2w = L::select(wraps, co, cos_o_2e);
    splat(2.0 * PI) * (splat(1.0) - co)
        + splat(FRAC_PI_2) * (splat(2.0) * spread * so - cos_o_2w + co)
}

/// arccos within 7e-5 (Abramowitz & Stegun 4.4.45), lane by lane.
#[inline(always)]
pub(super) fn approx_acos<L: Lanes>(x: L) -> L {
    let splat = L::splat;
    let a = x.abs().min(splat(1.0));
    let poly = splat(1.570_728_8)
        + a * (splat(-0.212_114_4) + a * (splat(0.074_261) - splat(0.018_729_3) * a));
    let t = (splat(1.0) - a).sqrt() * poly;
    L::select(x.cmplt(splat(0.0)), splat(std::f32::consts::PI) - t, t)
}
