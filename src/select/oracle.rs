//! The oracle selector (measurement only, O(L) per shading point): p_l ∝ the light's exact
//! unshadowed contribution to a diffuse receiver at (p, n), in luminance:
//!     triangle: luminance(L) · Ω⊥ (Lambert's polygon formula, clipped to the receiver's upper
//!               hemisphere; zero behind a one-sided emitter),
//!     point/spot: luminance(I · falloff) · max(0, n·ω) / r²,   directional: luminance(E) · max(0, n·ω),
//!     environment: ∫ luminance(L)·max(0, n·ω) dω from a table accurate to a few percent
//!               (lights::environment::sky_irradiance), floored at 1e-4·∫ luminance(L) dω so that a sky the
//!               table rounds to 0 is never ruled out.
//! It ignores visibility and the BRDF's shape: the bound any visibility-blind selector can approach.

use std::cell::RefCell;

use super::ShadingContext;
use crate::color::luminance;
use crate::lights::{polygon::projected_solid_angle, Light, Lights};

/// The oracle's weight of one light at a shading point (f64).
pub fn weight(light: &Light, ctx: &ShadingContext) -> f64 {
    match light {
        Light::Triangle(t) => {
            if !t.two_sided && t.normal.dot(ctx.p - t.p0) <= 0.0 {
                return 0.0;
            }
            let v = [t.p0, t.p0 + t.e1, t.p0 + t.e2];
            luminance(t.radiance) as f64 * projected_solid_angle(ctx.p, ctx.n, v)
        }
        Light::Environment(e) => e
            .map
            .irradiance(ctx.n)
            .max(1e-4 * e.map.luminance_integral()),
        Light::Point(_) | Light::Directional(_) => match light.sample_delta(ctx.p) {
            Some(s) => luminance(s.li) as f64 * ctx.n.dot(s.wi).max(0.0) as f64,
            None => 0.0,
        },
    }
}

thread_local! {
    /// Running sums of the weights, reused across calls so that sampling does not allocate.
    static CUMULATIVE: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// Chooses a light ∝ its weight: (light, weight / total), or None when every weight is 0.
pub fn sample(lights: &Lights, ctx: &ShadingContext, u: f64) -> Option<(usize, f64)> {
    CUMULATIVE.with(|cell| {
        let mut cum = cell.borrow_mut();
        cum.clear();
        let mut total = 0.0;
        for light in &lights.lights {
            total += weight(light, ctx);
            cum.push(total);
        }
        if total <= 0.0 || !total.is_finite() {
            return None;
        }
        // The first light whose running sum exceeds u·total has a positive weight.
        let target = u * total;
        let i = cum.partition_point(|&c| c <= target).min(cum.len() - 1);
        let i = (0..=i)
            .rev()
            .find(|&j| weight(&lights.lights[j], ctx) > 0.0)
            .unwrap_or(i);
        Some((i, weight(&lights.lights[i], ctx) / total))
    })
}

/// The probability that `sample` returns `light`: its weight over the sum of all weights.
pub fn pmf(lights: &Lights, ctx: &ShadingContext, light: usize) -> f64 {
    let total: f64 = lights.lights.iter().map(|l| weight(l, ctx)).sum();
    if total <= 0.0 || !total.is_finite() {
        return 0.0;
    }
    weight(&lights.lights[light], ctx) / total
}
