//! The importance of a wide node's eight children at a receiver, computed in
//! SIMD lanes without trigonometry: pbrt-v4's `LightBounds::Importance`, with
//! each child's box seen as its bounding sphere, sharpened where it only
//! weighs (Cycles' light tree clamps the distance the same way).
//!
//! For a child with sphere (c, r), power centre c_Φ (its lights' box centres
//! weighted by power) and spread σ about it (their Φ-weighted RMS distance from
//! c_Φ), power Φ, normal cone (w, θo) and spread θe, at receiver p with unit
//! normal n, d = |p − c|, and a sphere half-angle θ:
//!   θp(θ) = max(0, θw − θo − θ), θw = ∠(w, p − c) (folded to ≤ 90° when
//!   two-sided); θr(θ) = max(0, ∠(n, c − p) − θ);
//!   importance = Φ · E · R / max(|p − c_Φ|² − 1.5·σ², 0.05·r², 0.5·σ²),
//!   E = max(cos θp(θs), β·cos θp(θb)), R = max(cos θr(θs), β·cos θr(θb)),
//! with θb = asin(r/d) the whole sphere's half-angle, θs = asin(r/(4d)) that of
//! a sphere a quarter as wide (the angles the emitters mostly subtend: a light
//! behind the receiver's horizon by more than that gets less weight) and β =
//! `CONSERVATIVE_SHARE` (0.1): no lane falls below that share of pbrt's bound.
//! Inside the whole sphere (d ≤ r), where pbrt's cosines are 1, the floor is
//! `INSIDE_FLOOR` (¼) instead of β·cos; inside the quarter sphere the sharp
//! cosines are 1 too. The zero test is pbrt's, on the whole sphere: 0 when
//! θp(θb) ≥ θe or θr(θb) ≥ 90° (never inside), so a child that can reach p's
//! upper hemisphere always gets a positive importance. Angles are combined
//! through their (cos, sin) pairs; the zero test's angles get a margin of
//! `REJECT_ANGLE`, so f32 rounding never rejects a child that can reach the
//! receiver. Positive results lie in [f32::MIN_POSITIVE, f32::MAX]; unused
//! lanes give 0. Chosen by measuring the choice against the oracle (`cargo
//! bench --bench selection_quality`, W²-weighted χ²: on the 50k city 6.7 with
//! pbrt's bound, 1.4 sharpened, 1.6 with the inside floor, which brings the
//! mean χ² from 3.3 to 2.1 and the median from 2.8 to 1.9). The distance from
//! the power centre rather than the sphere's (the angles stay the sphere's, which
//! bounds them): W²-weighted / mean / median χ² at lit-surface points, town 1.51 /
//! 1.60 / 1.10 → 0.98 / 1.25 / 0.97, 50k city 1.95 / 1.72 / 1.58 → 1.41 / 1.60 /
//! 1.52; an exact Σ Φ_i / d_i² over each lane's lights in place of the distance
//! term would give town 0.77 and city 0.60 (a throwaway test), the leaves' choice
//! made exactly instead of by the lanes 1.48 and 1.56: the loss is in the
//! clusters' distance. Hence the spread: the mean of 1/|p − x|² over lights
//! spread about c_Φ exceeds 1/|p − c_Φ|² (for a shell of radius σ it is
//! ≈ 1/(d² − σ²/3)), most for a receiver near or inside the cluster, where the
//! lights it sees best are the near ones. The weight 1.5 (and the floors:
//! 0.05·r² for d² from (r/2)², an inside floor of ¼ from ½) were chosen by the
//! error they leave where it matters, visibility included (a throwaway variant of
//! `selection_quality` summing Σ V_l q_l² / p_l − (Σ V_l q_l)² over the points,
//! V_l one shadow ray to light l's centroid, against the oracle's): that excess
//! over the oracle's fell from 4.2× to 3.0× on the town and from 10.5× to 7.0×
//! on the 50k city; one camera sample's lit-surface MSE (bvh + mis, `bench --spp
//! 1 --seed 1000`, 100 / 200 repeats) from 7.33 to 7.05 on the town (7.36 to
//! 7.03 with seed 2000) and from 8.50 to 7.96 on the city (relMSE 4.43 → 4.10,
//! 8.31 → 6.47); W²-weighted / mean / median χ² at lit-surface points: town
//! 0.91 / 1.25 / 1.05, city 0.86 / 1.35 / 1.16. At the root, whose lanes hold thousands of
//! lights, Φ / d² is replaced by the lane's Σ Φ_i / d_i² from a table (`near_field`), where
//! the receiver lies inside it: W²-weighted / mean / median χ² town 0.722 / 0.953 / 0.698,
//! city 0.887 / 1.272 / 1.136; one camera sample's lit-surface MSE (as above) town 7.05 →
//! 5.72 (seed 2000: 7.03 → 5.77), city 7.96 → 8.28 (seeds 1000–4000: mean 8.34 → 7.54).
//! The table also splits each lane's sum by direction, and at a receiver its estimate of
//! Σ Φ_i · max(0, n·ω_i) / d_i², raised to at least the table's floor (½ at the root) of the
//! lane's T · E · R, stands for T · E · R: a facade then tells the lights in front of it from
//! those behind it. W²-weighted / mean / median χ² town 0.722 / 0.953 / 0.698 → 0.673 / 0.893 /
//! 0.628, city 0.887 / 1.272 / 1.136 → 0.843 / 1.152 / 1.000; the shadowed variance over the
//! oracle's town 2.96 → 2.83, city 9.76 → 9.56; one camera sample's lit-surface MSE town 5.725 →
//! 5.410 (seed 2000: 5.758 → 5.408), city (mean over seeds 1000–8000) 7.58 → 7.59. The floor
//! was chosen among 0.1, 0.2, 0.3, 0.5 and 0.7 by those MSEs on a first, f32 version of the
//! table (town at seed 1000: 5.55, 5.61, 5.54, 5.31, 5.28; at 0.7 the city's mean rose to 8.05,
//! at 0.5 it was 7.51); weighting each light's term by its emitter's cosine as well made the
//! town worse (6.40 with a floor of 0.1, 5.40 with 0.5).
//! The root's children, whose lanes still hold hundreds of lights, read tables of their own
//! (512 points each, the estimate's floor ¼; `near_field`'s `CHILD_TABLE`). One camera sample's
//! lit-surface MSE − Var[ref] (`bench --spp 1 --repeat 100 --width 320`): town 6.51 → 5.85
//! (seeds 1000, 2000; with the root's floor of ½ it was 5.95, and at that floor 128, 256, 1024,
//! 2048 and 4096 points gave 6.50, 6.29, 6.08, 6.00 and 5.94), the peers' Lambert copy of the
//! 50k city 1.162 → 1.121 (seeds 1000–4000), the 50k city 2.431 → 2.409 (seeds 1000–8000);
//! W²-weighted / mean / median χ² town 0.656 / 0.875 / 0.624 → 0.586 / 0.800 / 0.591, city
//! 0.799 / 1.148 / 0.998 → 0.778 / 1.092 / 1.007. The cities' lit relMSE rose by 2.2% and
//! 2.3%, the town's fell by 9%: finer tables, at the root as well, lowered the cities' MSE and
//! raised their relMSE every time, as more of the choices go to the lights that matter most.
//! Reading the tables only for lanes wider than three cells (the others keeping their own
//! Φ / d²) made the town worse than no child tables (7.07), and a quarter of the own term as a
//! floor under the table's value left both scenes worse than the tables alone.
//! At a glossy receiver every lane's value is multiplied by its specular lobe factor
//! 1 + g / (1 + λ·(1 − cos θm))² ([`Lobe`]; θm the angle from the mirror direction less θb),
//! which is ≥ 1 and finite, so the lanes that get 0 are the same. One camera sample's lit-surface
//! MSE (bvh + mis, `bench --spp 1 --repeat 100`, mean over seeds 1000–8000) on the 50k city, whose
//! dark glass (roughness 0.1) mirrors the lamps, 7.51 → 3.05 (relMSE 7.06 → 6.80); on the town,
//! whose lit surfaces are all rougher than the factor is used for, unchanged.

use glam::Vec3;

use super::*;

/// Radius of the sphere whose half-angle θs sharpens the cosines, over r.
const SHARP_RADIUS: f32 = 0.25;
/// The least share of pbrt's conservative cosine a weighted cosine keeps.
const CONSERVATIVE_SHARE: f32 = 0.1;
/// (d/r)² below which the distance is clamped: d ≥ 0.22·r.
const MIN_DISTANCE_SQ: f32 = 0.05;
/// The least weighted cosine inside the bounding sphere (where pbrt's is 1).
const INSIDE_FLOOR: f32 = 0.25;
/// k in the distance term's d² = |p − c_Φ|² − k·σ².
const SPREAD_WEIGHT: f32 = 1.5;
/// The least d² in units of σ².
const SPREAD_FLOOR: f32 = 0.5;
/// A lane is far ([`LaneValues::far`]) where its whole sphere subtends less than a sine of a
/// half-angle, the tree's `far_sin` (by default this one: θb < 17.5°; 0: no lane is far)…
pub const DEFAULT_FAR_SIN: f32 = 0.3;
/// …and its normal cone is narrower than this cosine of θo (θo < 90°).
const FAR_COS: f32 = 0.0;

/// A glossy receiver's specular lobe for the lanes' lobe factor
/// 1 + g / (1 + λ·(1 − cos θm))², θm = max(0, ∠(r, c − p) − θb): r the mirror direction of
/// the view direction about the shading normal, λ = 1/(2α²) (GGX's D at normal incidence as a
/// function of the angle from r, relative to its peak), g the specular lobe's peak over the
/// diffuse one (f_s·cos / f_d·cos at r). The factor is ≥ 1: it never lowers a lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    pub r: Vec3,
    pub sharpness: f32,
    pub gain: f32,
}

impl Lobe {
    /// No specular lobe: the factor is 1 exactly.
    pub const NONE: Lobe = Lobe {
        r: Vec3::ZERO,
        sharpness: 0.0,
        gain: 0.0,
    };

    /// The lobe of a receiver with unit shading normal `n` seen from unit direction `wo`, whose
    /// BRDF has GGX roughness α and specular and diffuse albedo estimates `w_s`, `w_d`
    /// (`Brdf::lobe_weights`), where α ≤ `MAX_LOBE_ALPHA` (else `NONE`): r the mirror direction
    /// of ωo, λ = 1/(2α²) and g = w_s / (4α²·max(n·ωo, 0.1)·w_d), the peak of f_s·cos
    /// (F·D(n)/(4 n·ωo), D(n) = 1/(πα²)) over that of f_d·cos (w_d/π), at most `MAX_LOBE_GAIN`
    /// (a metal, w_d = 0, gets it).
    pub fn of_receiver(alpha: f32, w_s: f32, w_d: f32, n: Vec3, wo: Vec3) -> Lobe {
        /// Rougher lobes (roughness above 0.5) are left to the diffuse importance: on the town,
        /// whose lit surfaces are all rougher, it raised one camera sample's lit-surface MSE by 2%.
        const MAX_LOBE_ALPHA: f32 = 0.25;
        /// The largest gain: the diffuse share keeps at least 1/(1 + g) of a lane's weight.
        const MAX_LOBE_GAIN: f32 = 300.0;
        if !(alpha <= MAX_LOBE_ALPHA && w_s > 0.0) {
            return Lobe::NONE;
        }
        let cos_o = n.dot(wo);
        let a2 = alpha * alpha;
        let gain = w_s / (4.0 * a2 * cos_o.max(0.1) * w_d);
        Lobe {
            r: 2.0 * cos_o * n - wo,
            sharpness: 0.5 / a2,
            gain: if gain < MAX_LOBE_GAIN {
                gain
            } else {
                MAX_LOBE_GAIN
            },
        }
    }
}

/// The larger of a and b (b when either is NaN), as one SIMD max.
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// √(1 − c²) for c ∈ [−1, 1] (0 outside, and for NaN): the sine of an angle from its cosine or
/// the reverse, as `cost::sin_of` but with 1 − c² from one fused multiply-add (rounded once).
#[inline(always)]
fn cofunction(c: f32) -> f32 {
    let square = (-c).mul_add(c, 1.0);
    if square > 0.0 {
        square.sqrt()
    } else {
        0.0
    }
}

/// √(d² − a²)/d from d² and 1/d, for |a| ≤ d (0 beyond): the sine of the angle whose cosine is
/// a/d, or the cosine of the one whose sine is. Its square root waits only for d², as 1/d's does,
/// instead of for 1/d (`cofunction` of a/d).
#[inline(always)]
fn leg(dist_sq: f32, a: f32, inv_dist: f32) -> f32 {
    let square = (-a).mul_add(a, dist_sq);
    if square > 0.0 {
        square.sqrt() * inv_dist
    } else {
        0.0
    }
}

/// a · b with fused multiply-adds (correctly rounded on every CPU, so the bits do not depend
/// on which copy of the walk runs).
#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// (cos, sin) of max(0, α − β) from those of α and β, α, β ∈ [0, π].
#[inline(always)]
fn minus(cos_a: f32, sin_a: f32, cos_b: f32, sin_b: f32) -> (f32, f32) {
    if cos_a >= cos_b {
        (1.0, 0.0)
    } else {
        (
            cos_a.mul_add(cos_b, sin_a * sin_b),
            max(sin_a.mul_add(cos_b, -(cos_a * sin_b)), 0.0),
        )
    }
}

/// (cos, sin) of min(π, α + β) from those of α and β, α, β ∈ [0, π]: (−1, 0) once α + β ≥ π
/// (cos α + cos β ≤ 0). `cost::cos_sum` in pair form, taking sin α as given (the lanes have
/// it already) instead of computing it again.
#[inline(always)]
fn plus(cos_a: f32, sin_a: f32, cos_b: f32, sin_b: f32) -> (f32, f32) {
    if cos_a + cos_b <= 0.0 {
        (-1.0, 0.0)
    } else {
        (
            cos_a.mul_add(cos_b, -(sin_a * sin_b)),
            sin_a.mul_add(cos_b, cos_a * sin_b),
        )
    }
}

/// One weighted cosine (E or R in the module header): `cos_sharp` over the quarter sphere
/// (1 inside it), at least β·`cos_whole` (pbrt's, over the whole sphere) outside the whole
/// sphere and `INSIDE_FLOOR` inside it, and at least `COS_FLOOR`.
#[inline(always)]
fn weighted(cos_sharp: f32, cos_whole: f32, outside_sharp: bool, outside: bool) -> f32 {
    let sharp = if outside_sharp { cos_sharp } else { 1.0 };
    let floor = if outside {
        CONSERVATIVE_SHARE * cos_whole
    } else {
        INSIDE_FLOOR
    };
    max(max(sharp, floor), COS_FLOOR)
}

/// A node's lanes at a receiver: each lane's importance, and the mask of its far lanes (bit k
/// for lane k), which the walk does not descend: their lights are chosen in proportion to power
/// (`power_prefix`). A lane is far where its bounding sphere subtends a half-angle θb with
/// sin θb < `far_sin` (the tree's, [`DEFAULT_FAR_SIN`] unless `--far-sin` says otherwise) and
/// its normal cone has cos θo > `FAR_COS`, at a receiver without a specular lobe (a glossy one
/// mirrors single lights of a cluster). One camera sample's lit-surface MSE (`bench --spp 1
/// --repeat 100 --width 320 --seed 1000`, bvh + mis) against a walk that always descends, sin
/// θb below 0.2, 0.3 and 0.5 (cos θo above 0.5, 0, 0): peers' Lambert copy of the 50k city
/// +0.4, +1.3, +1.9% (relMSE +0.8, +3.1, +5.3%); town +0.4, +1.0, +2.8%; the 50k city (50
/// repeats) +0.1, +0.5, +0.8%. Without the glossy exception sin θb < 0.1 and cos θo >
/// 0.9 already raised the 50k city's by 8%. At 0.3 the render's CPU per camera sample fell 7.4%
/// on the Lambert copy, 4.2% on the 50k city, 4.0% on the town and 3.4% on the 1M city (`render
/// --spp 16 --width 320 --sampler independent`, bvh + mis, medians of 5 alternating rounds).
#[derive(Clone, Copy, Debug)]
pub(super) struct LaneValues {
    pub(super) importance: [f32; LANES],
    pub(super) far: u8,
}

/// The importance of each lane of `node` at receiver `p` with unit normal `n`
/// (`Vec3::ZERO`: no receiver term). `p` and `n` must be finite (the callers
/// check). The node's codes are first decoded into f32 arrays, field by field; then
/// written lane by lane over those arrays, which the compiler turns into SIMD
/// across the eight lanes (8-wide where the caller enables AVX).
/// `near`, when given, holds each lane's Σ Φ_i / d_i² at p (its node's table, [`NearTables`]),
/// which then stands for its Φ / d².
#[inline(always)]
pub(super) fn importances(
    node: &WideNode,
    p: Vec3,
    n: Vec3,
    lobe: &Lobe,
    near: Option<NearTerms>,
    far_sin: f32,
) -> LaneValues {
    // Each lane decoded where its importance is computed: the decoded bounds never go through
    // memory.
    lane_importances::<false>(|k| LaneBounds::decode(node, k), p, n, lobe, near, far_sin)
}

/// [`importances`] of a node already decoded (the same bits).
#[inline(always)]
pub(super) fn decoded_importances(
    lanes: &Decoded,
    p: Vec3,
    n: Vec3,
    lobe: &Lobe,
    near: Option<NearTerms>,
    far_sin: f32,
) -> LaneValues {
    let bounds = |k| lanes.lane(k);
    if lanes.full_cones {
        lane_importances::<true>(bounds, p, n, lobe, near, far_sin)
    } else {
        lane_importances::<false>(bounds, p, n, lobe, near, far_sin)
    }
}

/// The eight lanes' importances from their bounds `bounds(k)`; `FULL_CONES`: every lane in use
/// has a normal cone of the whole sphere ([`Decoded::full_cones`]).
#[inline(always)]
fn lane_importances<const FULL_CONES: bool>(
    bounds: impl Fn(usize) -> LaneBounds,
    p: Vec3,
    n: Vec3,
    lobe: &Lobe,
    near: Option<NearTerms>,
    far_sin: f32,
) -> LaneValues {
    // A flag for the node and a plain array, not an Option per lane: the lanes then stay one
    // SIMD computation (an Option per lane made criterion's `sample` 980 ns against 315).
    let use_near = near.is_some();
    let NearTerms {
        plain,
        directed,
        directed_floor,
    } = near.unwrap_or(NearTerms {
        plain: [0.0; LANES],
        directed: [0.0; LANES],
        directed_floor: 0.0,
    });
    let near = (&plain, &directed, directed_floor);
    let bounds = &bounds;
    // The lobe factor is 1 exactly without a gain: a receiver without a lobe skips it. Each case
    // is compiled on its own, so that no choice between them is left in the lanes.
    match (lobe.gain > 0.0, n != Vec3::ZERO) {
        (true, true) => {
            lanes::<true, true, FULL_CONES>(bounds, p, n, lobe, use_near, near, far_sin)
        }
        (true, false) => {
            lanes::<true, false, FULL_CONES>(bounds, p, n, lobe, use_near, near, far_sin)
        }
        (false, true) => {
            lanes::<false, true, FULL_CONES>(bounds, p, n, lobe, use_near, near, far_sin)
        }
        (false, false) => {
            lanes::<false, false, FULL_CONES>(bounds, p, n, lobe, use_near, near, far_sin)
        }
    }
}

/// [`lane_importances`] for a receiver with a specular lobe or not (`GLOSSY`), with a normal or
/// not (`RECEIVER`), with whole-sphere cones or not (`FULL_CONES`).
#[inline(always)]
fn lanes<const GLOSSY: bool, const RECEIVER: bool, const FULL_CONES: bool>(
    bounds: &impl Fn(usize) -> LaneBounds,
    p: Vec3,
    n: Vec3,
    lobe: &Lobe,
    use_near: bool,
    (plain, directed, directed_floor): (&[f32; LANES], &[f32; LANES], f32),
    far_sin: f32,
) -> LaneValues {
    let mut importance = [0.0; LANES];
    let mut far = [false; LANES];
    for k in 0..LANES {
        let near = (plain[k], directed[k], directed_floor);
        (importance[k], far[k]) =
            lane::<GLOSSY, RECEIVER, FULL_CONES>(&bounds(k), p, n, lobe, use_near, near, far_sin);
    }
    let far = far
        .iter()
        .enumerate()
        .fold(0, |mask, (k, &far)| mask | u8::from(far) << k);
    LaneValues { importance, far }
}

/// A wide node's lane bounds in f32, one array per field: each lane's bounding sphere (centre,
/// radius), power centre, cone axis (length within 1.5e-5 of 1, 2.7e-6 on average), cos θo,
/// cos θe, signed Φ and σ², and whether every cone is the whole sphere.
#[derive(Clone, Debug)]
pub(super) struct Decoded {
    pub(super) centre: [[f32; LANES]; 3],
    pub(super) power_centre: [[f32; LANES]; 3],
    pub(super) radius: [f32; LANES],
    pub(super) axis: [[f32; LANES]; 3],
    pub(super) cos_o: [f32; LANES],
    pub(super) cos_e: [f32; LANES],
    pub(super) signed_phi: [f32; LANES],
    pub(super) spread_sq: [f32; LANES],
    /// Every lane in use (Φ ≠ 0) has cos θo = −1: its lights face every way, so E = 1 and the
    /// emitter rejects nothing at any receiver, and `lane` skips that arithmetic. The same bits
    /// need cos θw ≥ −1 in f32 too, which holds for a two-sided lane (folded to ≥ 0) and for the
    /// exact axis (0, 0, ≤ 1) a whole-sphere cone is coded with, not for the axis of a cone
    /// widened to π (up to 1.5e-5 longer than 1), wherever |p − c|² is a normal f32. As a rule
    /// the root's lanes, each over a block of a city or a town (callgrind, bvh + mis on the
    /// Lambert 50k city: 103 instructions a camera sample).
    pub(super) full_cones: bool,
}

impl Decoded {
    /// The bounds coded in `node` ([`WideNode`] says how).
    #[inline(always)]
    pub(super) fn of(node: &WideNode) -> Decoded {
        let mut d = Decoded {
            centre: [[0.0; LANES]; 3],
            power_centre: [[0.0; LANES]; 3],
            radius: [0.0; LANES],
            axis: [[0.0; LANES]; 3],
            cos_o: [0.0; LANES],
            cos_e: [0.0; LANES],
            signed_phi: [0.0; LANES],
            spread_sq: [0.0; LANES],
            full_cones: false,
        };
        for k in 0..LANES {
            let b = LaneBounds::decode(node, k);
            for a in 0..3 {
                d.centre[a][k] = b.centre[a];
                d.power_centre[a][k] = b.power_centre[a];
                d.axis[a][k] = b.axis[a];
            }
            d.radius[k] = b.radius;
            d.cos_o[k] = b.cos_o;
            d.cos_e[k] = b.cos_e;
            d.signed_phi[k] = b.signed_phi;
            d.spread_sq[k] = b.spread_sq;
        }
        d.full_cones = (0..LANES).all(|k| {
            let exact_axis =
                d.axis[0][k] == 0.0 && d.axis[1][k] == 0.0 && d.axis[2][k].abs() <= 1.0;
            let whole = d.cos_o[k] == -1.0 && (d.signed_phi[k] < 0.0 || exact_axis);
            d.signed_phi[k] == 0.0 || whole
        });
        d
    }

    /// Lane k's bounds.
    #[inline(always)]
    fn lane(&self, k: usize) -> LaneBounds {
        LaneBounds {
            centre: [self.centre[0][k], self.centre[1][k], self.centre[2][k]],
            power_centre: [
                self.power_centre[0][k],
                self.power_centre[1][k],
                self.power_centre[2][k],
            ],
            radius: self.radius[k],
            axis: [self.axis[0][k], self.axis[1][k], self.axis[2][k]],
            cos_o: self.cos_o[k],
            cos_e: self.cos_e[k],
            signed_phi: self.signed_phi[k],
            spread_sq: self.spread_sq[k],
        }
    }
}

/// One lane's bounds in f32 (the fields of [`Decoded`] at one lane).
#[derive(Clone, Copy, Debug)]
struct LaneBounds {
    centre: [f32; 3],
    power_centre: [f32; 3],
    radius: f32,
    axis: [f32; 3],
    cos_o: f32,
    cos_e: f32,
    signed_phi: f32,
    spread_sq: f32,
}

impl LaneBounds {
    /// Lane k's bounds as coded in `node` ([`WideNode`] says how).
    #[inline(always)]
    fn decode(node: &WideNode, k: usize) -> LaneBounds {
        // Written out axis by axis, not with `map`: a closure left out of line would lose the
        // caller's AVX2.
        let centre_of = |a: usize| node.origin[a] + f32::from(node.centre[a][k]) * node.step[a];
        let centre = [centre_of(0), centre_of(1), centre_of(2)];
        let radius = f32::from(node.radius[k]) * node.radius_step;
        let offset_step = radius * (1.0 / OFFSET_MAX);
        // Lane k's nibble is bits 4k .. 4k + 3 of the four bytes read as one little-endian word.
        let code = (u32::from_le_bytes(node.spread) >> (4 * k)) & 0xF;
        let spread = code as f32 * (radius * (1.0 / SPREAD_MAX));
        LaneBounds {
            centre,
            power_centre: [
                centre[0] + f32::from(node.power_centre[0][k]) * offset_step,
                centre[1] + f32::from(node.power_centre[1][k]) * offset_step,
                centre[2] + f32::from(node.power_centre[2][k]) * offset_step,
            ],
            radius,
            axis: [
                f32::from(node.axis[0][k]) * AXIS_STEP,
                f32::from(node.axis[1][k]) * AXIS_STEP,
                f32::from(node.axis[2][k]) * AXIS_STEP,
            ],
            cos_o: decode_cos(u32::from(node.cos_o[k])),
            cos_e: decode_cos(u32::from(node.cos_e[k])),
            signed_phi: decode_phi(node.phi[k]),
            spread_sq: spread * spread,
        }
    }
}

/// One lane's importance and whether it is far ([`LaneValues`]).
#[inline(always)]
fn lane<const GLOSSY: bool, const RECEIVER: bool, const FULL_CONES: bool>(
    node: &LaneBounds,
    p: Vec3,
    n: Vec3,
    lobe: &Lobe,
    use_near: bool,
    (near, directed, directed_floor): (f32, f32, f32),
    far_sin: f32,
) -> (f32, bool) {
    let to_p = [
        p.x - node.centre[0],
        p.y - node.centre[1],
        p.z - node.centre[2],
    ];
    let dist_sq = dot(to_p, to_p);
    let radius = node.radius;
    let radius_sq = radius * radius;
    let inv_dist = 1.0 / dist_sq.sqrt();
    let sin_b = radius * inv_dist;
    // θb = 90° wherever sin θb rounds to 1, as its clamp says (d² may still exceed r² by an ulp).
    let cos_b = if sin_b < 1.0 {
        leg(dist_sq, radius, inv_dist)
    } else {
        0.0
    };
    let sin_b = if sin_b < 1.0 { sin_b } else { 1.0 };
    let sin_s = SHARP_RADIUS * radius * inv_dist;
    let sin_s = if sin_s < 1.0 { sin_s } else { 1.0 };
    let cos_s = leg(dist_sq, SHARP_RADIUS * radius, inv_dist);

    // θw − θo − θ as θw − (θo + θ): the sums wait only for the distance, so the chain from
    // the cone axis's cosine to the importance is one subtraction of angles long. Both dot
    // products are taken with p − c and then scaled by 1/d, so they wait for the square root
    // only at the end; each sine or cosine made from another is a `leg`, whose root runs beside
    // 1/d's (render CPU 0.980 / 0.973 on the Lambert 50k city / town, the same MSE).
    let signed_phi = node.signed_phi;
    let phi = signed_phi.abs();
    let cos_o = node.cos_o;
    let outside = dist_sq > radius_sq;
    let outside_sharp = dist_sq > SHARP_RADIUS * SHARP_RADIUS * radius_sq;
    // With θo = π both sums θo + θ reach π, so θp = 0 at the whole and the quarter sphere: both
    // cosines are 1, E is 1 and the emitter rejects nothing (θe is coded widened by
    // `REJECT_ANGLE`, so cos θe < 1), whatever the receiver.
    let (emitted, emitter_rejects) = if FULL_CONES {
        (1.0, false)
    } else {
        let axis = node.axis;
        let along = dot(axis, to_p);
        let along = if signed_phi < 0.0 { along.abs() } else { along };
        let cos_w = along * inv_dist;
        let sin_w = leg(dist_sq, along, inv_dist);
        let sin_o = cofunction(cos_o);
        let (cos_ob, sin_ob) = plus(cos_o, sin_o, cos_b, sin_b);
        let (cos_os, sin_os) = plus(cos_o, sin_o, cos_s, sin_s);
        let (cos_p, _) = minus(cos_w, sin_w, cos_ob, sin_ob);
        let (cos_p_sharp, _) = minus(cos_w, sin_w, cos_os, sin_os);
        (
            weighted(cos_p_sharp, cos_p, outside_sharp, outside),
            cos_p <= node.cos_e, // θe coded widened by `REJECT_ANGLE`
        )
    };

    // Without a receiver cos θi is taken as 1: then θr = 0, so the receiver rejects nothing and
    // R is 1 exactly (cos θb, cos θs ≤ 1).
    let (cos_i, sin_i) = if RECEIVER {
        let along = -dot(to_p, n.to_array());
        (along * inv_dist, leg(dist_sq, along, inv_dist))
    } else {
        (1.0, 0.0)
    };
    let (cos_r, _) = minus(cos_i, sin_i, cos_b, sin_b);
    let receiver_rejects = cos_r <= -REJECT_ANGLE;
    let (cos_r_sharp, _) = minus(cos_i, sin_i, cos_s, sin_s);
    let received = weighted(cos_r_sharp, cos_r, outside_sharp, outside);

    let reject = (outside & (emitter_rejects | receiver_rejects)) | (phi <= 0.0);
    let factor = emitted * received;
    let to_power = [
        p.x - node.power_centre[0],
        p.y - node.power_centre[1],
        p.z - node.power_centre[2],
    ];
    let power_dist_sq = dot(to_power, to_power);
    let spread_sq = node.spread_sq;
    let d_sq = max(
        max(
            (-SPREAD_WEIGHT).mul_add(spread_sq, power_dist_sq),
            MIN_DISTANCE_SQ * radius_sq,
        ),
        max(SPREAD_FLOOR * spread_sq, f32::MIN_POSITIVE),
    );
    let value = match (use_near, RECEIVER) {
        (true, true) => max(directed, directed_floor * near * factor),
        (true, false) => near * factor,
        (false, _) => phi / d_sq * factor,
    };
    // The lobe factor (`Lobe`); a NaN cosine (p at the centre) gives t = 1.
    let value = if GLOSSY {
        let r = lobe.r;
        let along = -dot(to_p, r.to_array());
        let (cos_m, sin_m) = (along * inv_dist, leg(dist_sq, along, inv_dist));
        let (cos_g, _) = minus(cos_m, sin_m, cos_b, sin_b);
        let t = max(lobe.sharpness.mul_add(1.0 - cos_g, 1.0), 1.0);
        value * (1.0 + lobe.gain / (t * t))
    } else {
        value
    };
    let value = if value < f32::MAX { value } else { f32::MAX };
    let value = max(value, f32::MIN_POSITIVE);
    let far = !GLOSSY & (sin_b < far_sin) & (cos_o > FAR_COS);
    (if reject { 0.0 } else { value }, far)
}
