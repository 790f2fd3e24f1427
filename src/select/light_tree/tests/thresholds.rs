//! The zero test at its thresholds: a lane may be rejected only where the bound, written with
//! exact angles in f64 from the lane's decoded fields, rejects it. Receivers are placed just
//! inside the reach of each lane's receiver and emitter tests (by angles from 1e-9 to 1e-2
//! radians), at distances from barely outside the bounding sphere to ten radii, where the
//! lanes' sines and cosines lose the most to f32 rounding.

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

/// One lane's decoded bounds in f64: centre, radius, unit axis, θo, θe, two-sided, Φ.
struct Exact {
    centre: DVec3,
    radius: f64,
    axis: DVec3,
    theta_o: f64,
    theta_e: f64,
    two_sided: bool,
}

impl Exact {
    fn of(decoded: &Decoded, k: usize) -> Exact {
        let at = |field: &[[f32; LANES]; 3]| DVec3::from_array(field.map(|f| f64::from(f[k])));
        let axis = at(&decoded.axis);
        // The coding widened θo by acos(min(|w'|, 1/|w'|)) for the lanes' use of the unscaled
        // axis w' (`encode_axis`): that much of θo is theirs, not the lights'.
        let stretch = axis.length().min(1.0 / axis.length()).acos();
        let theta_o = f64::from(decoded.cos_o[k]).clamp(-1.0, 1.0).acos();
        Exact {
            centre: at(&decoded.centre),
            radius: f64::from(decoded.radius[k]),
            axis: axis.normalize(),
            theta_o: if theta_o < std::f64::consts::PI {
                theta_o - stretch
            } else {
                theta_o
            },
            theta_e: f64::from(decoded.cos_e[k]).clamp(-1.0, 1.0).acos(),
            two_sided: decoded.signed_phi[k] < 0.0,
        }
    }

    /// Whether the bound lets the lane reach a receiver at `p` (f32, as the lanes see it) with
    /// normal `n` (zero: no receiver test), by how much in angle (positive: reaches).
    fn margin(&self, p: Vec3, n: Vec3) -> f64 {
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
        let emitter = self.theta_e - (theta_w - self.theta_o - theta_b);
        let receiver = if n == Vec3::ZERO {
            f64::INFINITY
        } else {
            std::f64::consts::FRAC_PI_2 - (angle_between(n.as_dvec3(), -to_p) - theta_b)
        };
        emitter.min(receiver)
    }
}

#[test]
fn lanes_are_rejected_only_where_the_exact_bound_rejects_them() {
    let mut rng = Rand::new(40);
    let mut scene = random_scene(&mut rng, 3000);
    // Narrow emission as well as the scene's Lambertian θe = 90°, and flat lights facing along
    // an axis (city facades), whose axis codes have length 1 and whose θo gets no widening.
    for (i, b) in scene.bounds.iter_mut().enumerate() {
        match i % 3 {
            0 => b.cos_theta_e = rng.range(0.0, 0.99),
            1 => {
                let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
                b.w = axes[rng.below(6)];
                b.cos_theta_o = 1.0;
            }
            _ => {}
        }
    }
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let (mut probed, mut wrong, mut worst) = (0, 0, 0.0f64);
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
                let inside = 10f64.powf(f64::from(rng.range(-9.0, -2.0)));
                // The receiver test: the sphere's far edge just above p's horizon.
                let u = rng.unit().as_dvec3();
                let to_c = -u;
                let n = turned(
                    to_c,
                    perpendicular(to_c, &mut rng),
                    std::f64::consts::FRAC_PI_2 + theta_b - inside,
                );
                let receiver = ((lane.centre + u * d).as_vec3(), n.as_vec3());
                // The emitter test: p just inside the widest emission, with no receiver term.
                let theta_w = lane.theta_o + theta_b + lane.theta_e - inside;
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
                    if margin <= 0.0 {
                        continue;
                    }
                    probed += 1;
                    let value =
                        importances(node, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN).importance[k];
                    if value <= 0.0 {
                        wrong += 1;
                        worst = worst.max(margin);
                    }
                }
            }
        }
    }
    println!("{probed} receivers within reach, {wrong} rejected (largest margin {worst:e} rad)");
    assert!(probed > 10_000, "{probed}");
    assert_eq!(wrong, 0, "largest margin {worst:e} rad");
}
