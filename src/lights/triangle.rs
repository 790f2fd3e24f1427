//! An emissive triangle, sampled uniformly by area (pdf 1/A) or in solid angle (pdf 1/Ω).

use glam::Vec3;

use super::emits_toward;
use super::spherical_triangle::SphericalTriangle;
use crate::color::luminance;
use crate::sampling::warp;

/// Solid-angle sampling is used above this Ω (sr) where the receiver is at least
/// [`EVEN_DISTANCE_BALLS`] ball radii from the triangle; below it, area sampling, which costs far
/// less and, over a triangle that small (a cone of about 3° half-angle) whose points lie within a
/// factor 1.5 of each other's distance, varies little in 1/r² and the cosines. pbrt-v4's
/// threshold, 3e-4 sr ([`MIN_SPHERICAL_SOLID_ANGLE_UNEVEN`]), is where area sampling becomes the
/// better conditioned; from there to 1e-2 sr solid-angle sampling bought almost nothing on the
/// city and the town. bvh + mis on the 50k `gen city` (render --spp 8 --width 64 --height 48
/// --sampler independent --threads 1, valgrind --tool=callgrind, inside tiles::render), with
/// this threshold for every receiver: 3e-4 → 3e-3 → 1e-2 → 3e-2 sr, 147.5 → 142.2 → 139.9 →
/// 139.3 M instructions; one camera sample's lit-surface MSE (`bench --spp 1 --repeat 100`,
/// 320×240, against one 1024-spp reference), seed 1000: city 2.6255 → 2.6264 → 2.6310 →
/// 2.6460, town 5.4119 → 5.4156 → 5.4254 → 5.4357; seed 2000 at 3e-4 → 1e-2: city 2.4980 →
/// 2.5021, town 5.4101 → 5.4258. So 5% less work for 0.2–0.3% more error. With the uneven
/// views kept at 3e-4 sr (the rule as it stands): 140.9 M instructions, city 2.6296, town
/// 5.4253 (seed 1000).
pub const MIN_SPHERICAL_SOLID_ANGLE: f32 = 1e-2;
/// The threshold where the receiver is nearer than [`EVEN_DISTANCE_BALLS`] ball radii: there the
/// triangle's distances from it may differ by more than a factor 1.5 (a sliver seen from near
/// one end, a large triangle seen at a slant from close to its plane), 1/r² varies over it, and
/// solid-angle sampling pays from pbrt-v4's 3e-4 sr on.
pub const MIN_SPHERICAL_SOLID_ANGLE_UNEVEN: f32 = 3e-4;
/// A receiver at least this many radii R from the centre c of the ball about the triangle's
/// vertex mean (radius to its farthest vertex) sees every point of it at a distance within
/// [|p − c| − R, |p − c| + R], a ratio of at most (5 + 1)/(5 − 1) = 1.5.
pub const EVEN_DISTANCE_BALLS: f32 = 5.0;
/// From this Ω (sr) on, the receiver sits just above the triangle's interior, where Arvo's map
/// loses precision and area sampling's density r²/(A·cosθ') spans many decades (pbrt-v4 falls
/// back to area sampling here). We split the triangle at the receiver's foot instead (see
/// `SolidAngleView::Split`), so solid-angle sampling stays uniform up to Ω = 2π.
pub const MAX_SPHERICAL_SOLID_ANGLE: f32 = 6.22;

/// The area-sampling threshold for a receiver at squared distance `d2` from the centre of a
/// triangle's ball of squared radius `r2` (`TriangleLight::area_threshold`).
#[inline]
fn threshold_at(d2: f32, r2: f32) -> f32 {
    if d2 >= EVEN_DISTANCE_BALLS * EVEN_DISTANCE_BALLS * r2 {
        MIN_SPHERICAL_SOLID_ANGLE
    } else {
        MIN_SPHERICAL_SOLID_ANGLE_UNEVEN
    }
}

/// The triangle seen from a receiver, for uniform solid-angle sampling. A short-lived stack
/// value (boxing the large variant would allocate per sample).
#[allow(clippy::large_enum_variant)]
enum SolidAngleView {
    /// Ω within the thresholds: Arvo's map over the whole triangle.
    Whole(SphericalTriangle),
    /// Ω ≥ MAX_SPHERICAL_SOLID_ANGLE: the triangle cut at the receiver's foot f (its projection
    /// on the plane, inside the triangle since Ω > π) into (f, v1, v2), (f, v2, v0), (f, v0, v1),
    /// each subtending less than π. Choosing part i with probability Ω_i/ΣΩ and a direction
    /// uniform within it is uniform over the whole: p(ω) = 1/ΣΩ_j.
    Split {
        parts: [Option<SphericalTriangle>; 3],
        /// Ω_i in f64 (0 for a degenerate part), and their sum.
        omega: [f64; 3],
        total: f64,
    },
}

impl SolidAngleView {
    /// p(ω) = 1/Ω (1/ΣΩ_i when split), per steradian.
    fn pdf(&self) -> f32 {
        match self {
            SolidAngleView::Whole(view) => view.pdf(),
            SolidAngleView::Split { total, .. } => (1.0 / total) as f32,
        }
    }

    fn sample(&self, u: [f32; 2]) -> Option<super::spherical_triangle::SphericalSample> {
        match self {
            SolidAngleView::Whole(view) => view.sample(u),
            SolidAngleView::Split {
                parts,
                omega,
                total,
            } => {
                // Choose part i by u0 ∝ Ω_i (the last non-empty part if rounding runs past
                // the end), then reuse u0's position within its interval.
                let target = f64::from(u[0]) * total;
                let (mut chosen, mut start) = (None, 0.0);
                for (i, &w) in omega.iter().enumerate() {
                    if w > 0.0 {
                        chosen = Some((i, start));
                        if target < start + w {
                            break;
                        }
                    }
                    start += w;
                }
                let (i, start) = chosen?;
                let u0 = ((target - start) / omega[i]) as f32;
                let mut s = parts[i].as_ref()?.sample([u0, u[1]])?;
                s.pdf = self.pdf();
                Some(s)
            }
        }
    }
}

/// How points on a triangle light are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// Uniform by area: p(x') = 1/A in area measure.
    Area,
    /// Uniform in the solid angle seen from the receiver (Arvo 1995): p(ω) = 1/Ω, with area
    /// sampling below the triangle's `area_threshold` at the receiver.
    SolidAngle,
}

/// A point x' on a triangle light drawn for receiver p, with the pieces of its weight:
/// the integrand's geometry is cosθ_x · `jacobian` and its density `p_x`, in the measure drawn —
/// area (jacobian = cosθ'/r², p_x = 1/A) or solid angle (jacobian = 1, p_x = 1/Ω).
/// Its density in solid angle, for MIS, is p_x / jacobian.
#[derive(Clone, Copy, Debug)]
pub struct TriangleSample {
    pub point: Vec3,
    /// Unit direction from the receiver to `point`.
    pub wi: Vec3,
    pub jacobian: f32,
    pub p_x: f32,
    /// Whether the solid-angle sampler was used (false: area).
    pub spherical: bool,
}

/// An emissive triangle: p(b1, b2) = p0 + b1·e1 + b2·e2.
#[derive(Clone, Debug)]
pub struct TriangleLight {
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    /// Unit normal of the front face.
    pub normal: Vec3,
    pub area: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻²; for a textured emitter its mean over the triangle (the
    /// radiance at a point is the scene's `emission_at`).
    pub radiance: Vec3,
    pub two_sided: bool,
    /// Whether the emission varies over the triangle (an emissive texture).
    pub textured: bool,
    /// The scene triangle this light is.
    pub triangle: u32,
}

impl TriangleLight {
    /// Emitted power used for selection: Φ = π·A·luminance(L), doubled when two-sided (f64).
    pub fn power(&self) -> f64 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        std::f64::consts::PI * self.area as f64 * luminance(self.radiance) as f64 * sides
    }

    pub fn vertices(&self) -> [Vec3; 3] {
        [self.p0, self.p0 + self.e1, self.p0 + self.e2]
    }

    /// The solid-angle view of this triangle from p, when that technique applies there
    /// (Ω above its `area_threshold`; split at the foot from MAX_SPHERICAL_SOLID_ANGLE on).
    /// The cheap test that rules most distant triangles out is inlined into the caller; the
    /// set-up is not.
    #[inline(always)]
    fn spherical_at(&self, p: Vec3, technique: Technique) -> Option<SolidAngleView> {
        if technique != Technique::SolidAngle || self.solid_angle_surely_small(p) {
            return None;
        }
        self.spherical_view(p)
    }

    /// `spherical_at` past its cheap test: Arvo's set-up, whole or split.
    #[inline(never)]
    fn spherical_view(&self, p: Vec3) -> Option<SolidAngleView> {
        let threshold = self.area_threshold(p);
        if self.solid_angle_small_by_plane(p, threshold) {
            return None;
        }
        let view = SphericalTriangle::new(p, self.vertices())?;
        let omega = view.solid_angle();
        if omega <= threshold {
            return None;
        }
        if omega < MAX_SPHERICAL_SOLID_ANGLE {
            return Some(SolidAngleView::Whole(view));
        }
        let foot = p - self.normal * self.normal.dot(p - self.p0);
        let [v0, v1, v2] = self.vertices();
        let parts = [[foot, v1, v2], [foot, v2, v0], [foot, v0, v1]]
            .map(|tri| SphericalTriangle::new(p, tri));
        let omega = parts
            .each_ref()
            .map(|part| part.as_ref().map_or(0.0, |t| f64::from(t.solid_angle())));
        let total: f64 = omega.iter().sum();
        (total > 0.0).then_some(SolidAngleView::Split {
            parts,
            omega,
            total,
        })
    }

    /// The ball about the vertices' mean c whose radius R reaches the farthest vertex: (c, R²).
    #[inline]
    fn ball(&self) -> (Vec3, f32) {
        let c = self.p0 + (self.e1 + self.e2) * (1.0 / 3.0);
        let to_p0 = self.p0 - c;
        let r2 = to_p0
            .length_squared()
            .max((to_p0 + self.e1).length_squared())
            .max((to_p0 + self.e2).length_squared());
        (c, r2)
    }

    /// The Ω up to which the triangle is area-sampled from p: [`MIN_SPHERICAL_SOLID_ANGLE`] where
    /// |p − c|² ≥ ([`EVEN_DISTANCE_BALLS`]·R)² (its `ball`), else
    /// [`MIN_SPHERICAL_SOLID_ANGLE_UNEVEN`] (also for a NaN distance).
    #[inline]
    fn area_threshold(&self, p: Vec3) -> f32 {
        let (c, r2) = self.ball();
        threshold_at((p - c).length_squared(), r2)
    }

    /// Whether Ω from p is surely at most its `area_threshold`, without computing Ω: the
    /// triangle lies in its `ball` (c, R), so Ω is at most the cone's 2π(1 − cos α) ≤ 2π·sin²α =
    /// 2π·R²/|p − c|². A 1% margin covers rounding, so this never says yes where the exact Ω
    /// (f64) exceeds the threshold: it only spares distant triangles the spherical set-up.
    #[inline]
    fn solid_angle_surely_small(&self, p: Vec3) -> bool {
        let (c, r2) = self.ball();
        let d2 = (p - c).length_squared();
        std::f32::consts::TAU * r2 < 0.99 * threshold_at(d2, r2) * d2
    }

    /// Whether Ω from p is surely at most `threshold` by a bound that also counts
    /// how obliquely the plane is seen: each point x of the triangle subtends dω = h/|p − x|³ dA,
    /// h the distance from p to the plane, so Ω ≤ A·h / r³ where r = |p − c| − R ≤ |p − x| (the
    /// ball about the vertices' mean c whose radius R reaches the farthest vertex holds the
    /// triangle). A·h is half the triple product |(v0 − p)·((v1 − v0) × (v2 − v0))|. From the
    /// same vertices as the exact Ω; r is lowered by, and the triple product raised by, more
    /// than their f32 rounding can reach (a few ulps of |p − c| + R and of |v0 − p|·|v1 − v0|·
    /// |v2 − v0| ≤ (|p − c| + R)·4R²), and the 1% margin of `solid_angle_surely_small` stays,
    /// so it never says yes where the exact Ω exceeds the threshold. It spares the set-up where
    /// the receiver sees a nearby triangle's plane at a slant, which the ball bound cannot tell.
    fn solid_angle_small_by_plane(&self, p: Vec3, threshold: f32) -> bool {
        let [v0, v1, v2] = self.vertices();
        let (c, r2) = self.ball();
        let (distance, radius) = ((p - c).length(), r2.sqrt());
        let reach = distance + radius;
        let nearest = distance - radius - 1e-6 * reach;
        let triple = (v0 - p).dot((v1 - v0).cross(v2 - v0)).abs() + 4e-6 * reach * r2;
        // False where the ball reaches p (or a value is not finite).
        nearest > 0.0 && 0.5 * triple < 0.99 * threshold * (nearest * nearest * nearest)
    }

    /// Whether no point of this light can send light to a receiver at p with geometric normal
    /// `ng` (facing the side the receiver looks from): p lies behind a one-sided emitter
    /// (n·(p − p0) < 0, the same sign for every x' on the plane), or the whole triangle lies
    /// below the receiver's tangent plane (ng·(v − p) < 0 at every vertex). Every sample the
    /// light could give such a receiver carries zero, so a caller may skip drawing them.
    #[inline]
    pub fn cannot_reach(&self, p: Vec3, ng: Vec3) -> bool {
        let to_receiver = p - self.p0;
        if !self.two_sided && self.normal.dot(to_receiver) < 0.0 {
            return true;
        }
        let below = |v: Vec3| ng.dot(v - p) < 0.0;
        below(self.p0) && below(self.p0 + self.e1) && below(self.p0 + self.e2)
    }

    /// The unit normal on the side of the triangle that faces unit direction `w` (leaving the
    /// light toward a receiver): the side a shadow ray's far end is lifted off.
    #[inline]
    pub fn side_toward(&self, w: Vec3) -> Vec3 {
        if self.normal.dot(w) > 0.0 {
            self.normal
        } else {
            -self.normal
        }
    }

    /// Draws a point for receiver p; None when the sample carries no light (edge-on).
    #[inline(always)]
    pub fn sample(&self, p: Vec3, technique: Technique, u: [f32; 2]) -> Option<TriangleSample> {
        if let Some(view) = self.spherical_at(p, technique) {
            // A degenerate spherical sample is dropped rather than redrawn by area, so that
            // pdf_solid_angle always describes the technique that was used.
            return view.sample(u).map(|s| TriangleSample {
                point: s.point,
                wi: s.direction,
                jacobian: 1.0,
                p_x: s.pdf,
                spherical: true,
            });
        }
        let point = self.sample_area(u);
        let d = point - p;
        let dist2 = d.length_squared();
        let wi = d / dist2.sqrt();
        let cos_light = self.normal.dot(wi).abs();
        (dist2 > 0.0 && cos_light > 0.0).then(|| TriangleSample {
            point,
            wi,
            jacobian: cos_light / dist2,
            p_x: 1.0 / self.area,
            spherical: false,
        })
    }

    /// The solid-angle density with which `sample` (same technique) produces the direction from
    /// p toward `point` on this triangle: 1/Ω, or r²/(A·cosθ') where area sampling applies.
    pub fn pdf_solid_angle(&self, p: Vec3, technique: Technique, point: Vec3) -> f32 {
        if let Some(view) = self.spherical_at(p, technique) {
            return view.pdf();
        }
        let d = point - p;
        let dist2 = d.length_squared();
        let cos_light = self.normal.dot(d).abs() / dist2.sqrt();
        if cos_light > 0.0 {
            dist2 / (self.area * cos_light)
        } else {
            0.0
        }
    }

    /// A point uniform over the triangle: pdf 1/A in area measure.
    #[inline]
    pub fn sample_area(&self, u: [f32; 2]) -> Vec3 {
        let (b1, b2) = warp::uniform_triangle(u);
        self.p0 + b1 * self.e1 + b2 * self.e2
    }

    /// Barycentrics (b1, b2) of a point x on the triangle's plane, x = p0 + b1·e1 + b2·e2:
    /// b1 = ((x − p0) × e2)·n / ((e1 × e2)·n), b2 = (e1 × (x − p0))·n / ((e1 × e2)·n).
    #[inline]
    pub fn barycentrics(&self, x: Vec3) -> (f32, f32) {
        let d = x - self.p0;
        let inv = 1.0 / self.e1.cross(self.e2).dot(self.normal);
        (
            d.cross(self.e2).dot(self.normal) * inv,
            self.e1.cross(d).dot(self.normal) * inv,
        )
    }

    /// Radiance leaving the light toward unit direction `w` (the mean radiance when textured).
    #[inline]
    pub fn emitted(&self, w: Vec3) -> Vec3 {
        if emits_toward(self.normal, self.two_sided, w) {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The untextured light of radiance 1 over the triangle p0, p0 + e1, p0 + e2 (front face
    /// along e1 × e2; none of them degenerate).
    fn white_light(p0: Vec3, e1: Vec3, e2: Vec3, two_sided: bool) -> TriangleLight {
        TriangleLight {
            p0,
            e1,
            e2,
            normal: e1.cross(e2).normalize(),
            area: 0.5 * e1.cross(e2).length(),
            radiance: Vec3::ONE,
            two_sided,
            textured: false,
            triangle: 0,
        }
    }

    #[test]
    fn power_is_pi_area_luminance_doubled_when_two_sided() {
        let mut l = TriangleLight {
            p0: Vec3::ZERO,
            e1: Vec3::X * 2.0,
            e2: Vec3::Y,
            normal: Vec3::Z,
            area: 1.0,
            radiance: Vec3::new(1.0, 1.0, 1.0),
            two_sided: false,
            textured: false,
            triangle: 0,
        };
        assert!((l.power() - std::f64::consts::PI).abs() < 1e-6);
        l.two_sided = true;
        assert!((l.power() - 2.0 * std::f64::consts::PI).abs() < 1e-6);
        assert_eq!(l.emitted(-Vec3::Z), l.radiance);
        l.two_sided = false;
        assert_eq!(l.emitted(-Vec3::Z), Vec3::ZERO);
        assert_eq!(l.emitted(Vec3::Z), l.radiance);
    }

    #[test]
    fn the_solid_angle_shortcuts_only_skip_triangles_below_the_threshold() {
        use rand_core::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
        let mut u = move || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        let (mut skipped, mut near_threshold) = (0, 0);
        let (mut by_plane, mut plane_near_threshold) = (0, 0);
        for _ in 0..200_000 {
            // Slivers and fat triangles, seen from 1 to 1000 sizes away.
            let size = 0.01 + u();
            let p0 = Vec3::new(u(), u(), u()) * 4.0;
            let e1 = (Vec3::new(u(), u(), u()) - 0.5) * size;
            let e2 = (Vec3::new(u(), u(), u()) - 0.5) * size * u();
            if e1.cross(e2).try_normalize().is_none() {
                continue;
            }
            let light = white_light(p0, e1, e2, true);
            let dir = (Vec3::new(u(), u(), u()) - 0.5).normalize_or(Vec3::X);
            let p = p0 + dir * size * 10f32.powf(3.0 * u());
            let Some(view) = SphericalTriangle::new(p, light.vertices()) else {
                continue;
            };
            let omega = view.solid_angle();
            let threshold = light.area_threshold(p);
            if light.solid_angle_surely_small(p) {
                skipped += 1;
                assert!(omega <= threshold, "Ω {omega} from {p}");
            }
            if light.solid_angle_small_by_plane(p, threshold) {
                by_plane += 1;
                assert!(omega <= threshold, "Ω {omega} from {p} (plane)");
                plane_near_threshold += (omega > 0.5 * threshold) as u32;
            }
            near_threshold += (omega > 0.5 * threshold && omega <= threshold) as u32;
        }
        // The bounds are exercised, the plane bound skips more than the ball bound, and cases
        // within a factor of two below the threshold are met and skipped (here: 138,822
        // skipped by the ball bound, 185,005 by the plane bound; 6,708 cases near the
        // threshold, 1,496 of them skipped by the plane bound).
        assert!(
            skipped > 20_000
                && by_plane > skipped + skipped / 5
                && near_threshold > 1000
                && plane_near_threshold > 1000,
            "{skipped} {by_plane} {near_threshold} {plane_near_threshold}"
        );
    }

    /// The area-sampling threshold follows how evenly the receiver sees the triangle: a 1 m
    /// sliver 1 mm wide seen from 0.1 m above a point 0.05 m beyond one end (distances
    /// 0.11–1.06 m, Ω ≈ 6e-3 sr) is solid-angle sampled, though its Ω is below
    /// `MIN_SPHERICAL_SOLID_ANGLE`; the same sliver seen broadside from 5 m (Ω ≈ 2e-5 sr) and a
    /// fat triangle 20 radii away with Ω between the two thresholds (≈ 3e-3 sr) are area-sampled.
    #[test]
    fn uneven_views_keep_solid_angle_sampling_down_to_the_lower_threshold() {
        let light = |v: [Vec3; 3]| white_light(v[0], v[1] - v[0], v[2] - v[0], true);
        let omega = |l: &TriangleLight, p: Vec3| {
            SphericalTriangle::new(p, l.vertices())
                .unwrap()
                .solid_angle()
        };
        let sliver = light([
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.001, 0.0),
        ]);
        let near_end = Vec3::new(-0.05, 0.0005, 0.1);
        let w = omega(&sliver, near_end);
        assert!(
            MIN_SPHERICAL_SOLID_ANGLE_UNEVEN < w && w < MIN_SPHERICAL_SOLID_ANGLE,
            "{w}"
        );
        assert!(sliver
            .spherical_at(near_end, Technique::SolidAngle)
            .is_some());
        let broadside = Vec3::new(0.5, 0.0, 5.0);
        assert!(omega(&sliver, broadside) < MIN_SPHERICAL_SOLID_ANGLE_UNEVEN);
        assert!(sliver
            .spherical_at(broadside, Technique::SolidAngle)
            .is_none());
        // Ball radius 0.58; seen from 12 m.
        let fat = light([
            Vec3::new(-0.5, -0.29, 0.0),
            Vec3::new(0.5, -0.29, 0.0),
            Vec3::new(0.0, 0.58, 0.0),
        ]);
        let far = Vec3::new(0.0, 0.0, 12.0);
        let w = omega(&fat, far);
        assert!(
            MIN_SPHERICAL_SOLID_ANGLE_UNEVEN < w && w < MIN_SPHERICAL_SOLID_ANGLE,
            "{w}"
        );
        assert!(fat.spherical_at(far, Technique::SolidAngle).is_none());
    }

    #[test]
    fn barycentrics_invert_the_parametrisation() {
        let l = TriangleLight {
            p0: Vec3::new(1.0, -2.0, 0.5),
            e1: Vec3::new(2.0, 0.5, -1.0),
            e2: Vec3::new(-0.5, 1.5, 2.0),
            normal: Vec3::new(2.0, 0.5, -1.0)
                .cross(Vec3::new(-0.5, 1.5, 2.0))
                .normalize(),
            area: 0.0,
            radiance: Vec3::ONE,
            two_sided: false,
            textured: true,
            triangle: 0,
        };
        for (b1, b2) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.2, 0.7), (0.45, 0.1)] {
            let (c1, c2) = l.barycentrics(l.p0 + b1 * l.e1 + b2 * l.e2);
            assert!(
                (c1 - b1).abs() < 1e-5 && (c2 - b2).abs() < 1e-5,
                "{b1},{b2}: {c1},{c2}"
            );
        }
    }

    /// A large triangle just above receivers facing it (Ω from 6.1 sr to 2π − 1e-5 sr): the
    /// solid-angle sampler (split at the foot from 6.22 sr on) estimates the projected solid
    /// angle ∫cosθ dω = mean(cosθ / p(ω)) within 5σ of Lambert's formula, and its density
    /// agrees with `pdf_solid_angle` for every sample.
    #[test]
    fn near_hemisphere_solid_angle_sampling_matches_lambert() {
        use crate::sampling::rng::PixelRng;
        let (a, b, c) = (
            Vec3::new(-3.0, -2.0, 0.0),
            Vec3::new(4.0, -1.5, 0.0),
            Vec3::new(0.5, 3.5, 0.0),
        );
        // Winding so that the front face looks down at the receivers below it.
        let light = white_light(a, c - a, b - a, false);
        assert!(light.normal.z < 0.0);
        let mut rng = PixelRng::new(3, 4);
        for (h, foot) in [
            (0.05, Vec3::new(0.3, 0.2, 0.0)),
            (1e-3, Vec3::new(0.3, 0.2, 0.0)),
            (1e-5, Vec3::new(-1.0, -1.0, 0.0)),
            (1e-5, Vec3::new(3.0, -1.4, 0.0)),
        ] {
            let p = foot - Vec3::Z * h;
            let omega = SphericalTriangle::new(p, light.vertices())
                .unwrap()
                .solid_angle();
            let expected =
                crate::lights::polygon::projected_solid_angle(p, Vec3::Z, light.vertices());
            // The first case is sampled whole, the others split at the foot.
            assert_eq!(
                omega >= MAX_SPHERICAL_SOLID_ANGLE,
                h < 0.01,
                "h {h}: Ω {omega}"
            );
            let n = 20_000;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let s = light
                    .sample(p, Technique::SolidAngle, rng.next_2d())
                    .unwrap();
                assert!(s.spherical);
                let pdf = light.pdf_solid_angle(p, Technique::SolidAngle, s.point);
                assert!((pdf - s.p_x).abs() <= 1e-6 * pdf, "{pdf} vs {}", s.p_x);
                let v = f64::from(s.wi.z.max(0.0)) / f64::from(s.p_x);
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            assert!(
                (mean - expected).abs() <= 5.0 * sigma + 1e-6 * expected,
                "h {h}, Ω {omega}: {mean} ± {sigma} vs Lambert {expected}"
            );
        }
    }
}
