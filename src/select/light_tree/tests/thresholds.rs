//! The zero test at its thresholds: a lane may be rejected only where the bound, written with
//! exact angles in f64 from what the lane's decoded fields promise of its lights, rejects it;
//! and it must be rejected once that bound is well beyond its threshold, so that the margin
//! (`REJECT_ANGLE`) stays a small angle. Receivers are placed just inside each lane's reach for
//! its receiver and emitter tests (by angles from 1e-9 to 1e-2 radians) and well outside it, at
//! distances from barely outside the bounding sphere to ten radii, where the lanes' sines and
//! cosines lose the most to f32 rounding, and on the sphere.

use super::*;

/// Rotates unit `v` by `angle` towards the unit direction `toward` (perpendicular to `v`).
fn turned(v: DVec3, toward: DVec3, angle: f64) -> DVec3 {
    v * angle.cos() + toward * angle.sin()
}

/// A unit vector perpendicular to unit `v`.
fn perpendicular(v: DVec3, rng: &mut Rand) -> DVec3 {
    loop {
        let t = rng.unit().as_dvec3();
        let t = t - v * t.dot(v);
        if t.length() > 1e-3 {
            return t.normalize();
        }
    }
}

/// One lane's decoded fields in f64: its sphere, its unit axis, θo and θe as coded, whether
/// it is two-sided, and the widenings the coding added to θo (`stretch`, for the coded axis's
/// length) and θe (`REJECT_ANGLE`) for the lanes' own use, which are not the lights'.
struct Exact {
    centre: DVec3,
    radius: f64,
    axis: DVec3,
    theta_o: f64,
    theta_e: f64,
    two_sided: bool,
    stretch: f64,
    margin_e: f64,
}

impl Exact {
    fn of(decoded: &Decoded, k: usize) -> Exact {
        let at = |field: &[[f32; LANES]; 3]| DVec3::from_array(field.map(|f| f64::from(f[k])));
        let axis = at(&decoded.axis);
        // The coding widened θo by the axis's `stretch` for the lanes' use of the unscaled
        // axis w' (`encode_axis`): that much of θo is theirs, not the lights'.
        let stretch = stretch(axis.length()).0.acos();
        let theta_o = f64::from(decoded.cos_o[k]).clamp(-1.0, 1.0).acos();
        let theta_e = f64::from(decoded.cos_e[k]).clamp(-1.0, 1.0).acos();
        let whole = |theta: f64| theta >= std::f64::consts::PI;
        Exact {
            centre: at(&decoded.centre),
            radius: f64::from(decoded.radius[k]),
            axis: axis.normalize(),
            theta_o,
            theta_e,
            two_sided: decoded.signed_phi[k] < 0.0,
            stretch: if whole(theta_o) { 0.0 } else { stretch },
            margin_e: if whole(theta_e) {
                0.0
            } else {
                f64::from(REJECT_ANGLE)
            },
        }
    }

    /// By how much in angle the bound over the lane's lights (θo and θe less the coding's
    /// widenings) lets them reach a receiver at `p` (f32, as the lanes see it) with normal `n`
    /// (zero: no receiver test): positive where they may, +∞ inside.
    fn margin(&self, p: Vec3, n: Vec3) -> f64 {
        self.margin_with(p, n, self.stretch, self.margin_e)
    }

    /// [`margin`](Self::margin) of the bound as coded, θo and θe widened.
    fn coded_margin(&self, p: Vec3, n: Vec3) -> f64 {
        self.margin_with(p, n, 0.0, 0.0)
    }

    fn margin_with(&self, p: Vec3, n: Vec3, less_o: f64, less_e: f64) -> f64 {
        let to_p = p.as_dvec3() - self.centre;
        let d = to_p.length();
        // The lane's lights lie within r/(1 + 4ε) of its centre (`bounding_radius` enlarges the
        // box's half diagonal by 8ε, less its own rounding, and the codes round r up): nothing
        // is rejected there. Beyond, the lanes' sphere of radius r is a safe bound.
        if d <= self.radius / (1.0 + 4.0 * f64::from(f32::EPSILON)) {
            return f64::INFINITY;
        }
        let theta_b = (self.radius / d).min(1.0).asin();
        let theta_w = angle_between(self.axis, to_p);
        let theta_w = if self.two_sided {
            theta_w.min(std::f64::consts::PI - theta_w)
        } else {
            theta_w
        };
        let emitter = (self.theta_e - less_e) - (theta_w - (self.theta_o - less_o) - theta_b);
        let receiver = if n == Vec3::ZERO {
            f64::INFINITY
        } else {
            std::f64::consts::FRAC_PI_2 - (angle_between(n.as_dvec3(), -to_p) - theta_b)
        };
        emitter.min(receiver)
    }
}

#[test]
fn lanes_are_rejected_where_the_exact_bound_rejects_them_and_only_there() {
    let mut rng = Rand::new(40);
    let mut scene = random_scene(&mut rng, 3000);
    // Narrow emission and spot lights' (θe = 1e-3, as the `bvh` selector gives them) as well as
    // the scene's Lambertian θe = 90°, and flat lights facing along an axis (city facades),
    // whose axis codes have length 1 and whose θo gets no widening.
    for (i, b) in scene.bounds.iter_mut().enumerate() {
        match i % 4 {
            0 => b.cos_theta_e = rng.range(0.0, 0.99),
            1 => {
                let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
                b.w = axes[rng.below(6)];
                b.cos_theta_o = 1.0;
            }
            2 => b.cos_theta_e = 1e-3f32.cos(),
            _ => {}
        }
    }
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let (mut reached, mut wrongly_rejected, mut worst) = (0, 0, 0.0f64);
    let (mut beyond, mut wrongly_kept) = (0, 0);
    for node in &bvh.nodes {
        let decoded = Decoded::of(node);
        for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
            let lane = Exact::of(&decoded, k);
            if lane.radius == 0.0 {
                continue;
            }
            for _ in 0..40 {
                let d = lane.radius * (1.0 + 10f64.powf(f64::from(rng.range(-9.0, 1.0))));
                let theta_b = (lane.radius / d).asin();
                // Just inside the reach, or well outside it.
                let offset = if rng.f32() < 0.75 {
                    -(10f64.powf(f64::from(rng.range(-9.0, -2.0))))
                } else {
                    10f64.powf(f64::from(rng.range(-1.7, -1.0)))
                };
                // The receiver test: the sphere's far edge just above p's horizon, or below it.
                let u = rng.unit().as_dvec3();
                let to_c = -u;
                let n = turned(
                    to_c,
                    perpendicular(to_c, &mut rng),
                    std::f64::consts::FRAC_PI_2 + theta_b + offset,
                );
                let receiver = ((lane.centre + u * d).as_vec3(), n.as_vec3());
                // The emitter test, with no receiver term: p just inside the widest emission,
                // or outside it.
                let theta_w =
                    lane.theta_o - lane.stretch + theta_b + lane.theta_e - lane.margin_e + offset;
                let emitter = (theta_w < std::f64::consts::PI).then(|| {
                    let dir = turned(lane.axis, perpendicular(lane.axis, &mut rng), theta_w);
                    ((lane.centre + dir * d).as_vec3(), Vec3::ZERO)
                });
                // On the sphere, just inside or outside it, facing anywhere.
                let shell = 1.0 + 10f64.powf(f64::from(rng.range(-9.0, -6.0))) * rng.sign();
                let normal = if rng.f32() < 0.5 {
                    Vec3::ZERO
                } else {
                    rng.unit()
                };
                let on_sphere = (
                    (lane.centre + rng.unit().as_dvec3() * lane.radius * shell).as_vec3(),
                    normal,
                );
                for (p, n) in [receiver, on_sphere].into_iter().chain(emitter) {
                    let margin = lane.margin(p, n);
                    let value =
                        importances(node, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN).importance[k];
                    if margin > 0.0 {
                        reached += 1;
                        if value <= 0.0 {
                            wrongly_rejected += 1;
                            worst = worst.max(margin);
                        }
                    } else if lane.coded_margin(p, n) < -(0.01 + lane.stretch)
                        && (p.as_dvec3() - lane.centre).length() > lane.radius * (1.0 + 1e-5)
                    {
                        // Clearly outside the sphere and beyond the coded bound by far more than
                        // f32's error (and the coded axis's length): the lane must go.
                        beyond += 1;
                        wrongly_kept += usize::from(value > 0.0);
                    }
                }
            }
        }
    }
    println!(
        "{reached} receivers within reach, {wrongly_rejected} rejected (largest margin \
         {worst:e} rad); {beyond} well beyond, {wrongly_kept} kept"
    );
    assert!(reached > 10_000 && beyond > 1000, "{reached} {beyond}");
    assert_eq!(wrongly_rejected, 0, "largest margin {worst:e} rad");
    assert_eq!(wrongly_kept, 0);
}
