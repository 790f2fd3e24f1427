//! Lambert's polygon formula for expected values, written here apart from the crate's own
//! (`lights::polygon`) so that a test never checks the renderer against the renderer.
//!
//! The projected solid angle of a polygon above the tangent plane at x (unit normal n), with u_i
//! the unit directions from x to its vertices (the polygon first cut at that plane):
//!     Ω⊥ = ½ |Σ_i Θ_i (n · Γ_i)|,  Θ_i = ∠(u_i, u_{i+1}),  Γ_i = (u_i × u_{i+1}) / |u_i × u_{i+1}|
//! (Lambert 1760; Arvo, "Analytic Methods for Simulated Light Transport", 1995). Irradiance from
//! a constant radiance L is L·Ω⊥.

use glam::DVec3;

/// Projected solid angle of `polygon` (any winding) seen from x with unit normal n, counting only
/// its part above the tangent plane.
pub fn projected_solid_angle(x: DVec3, n: DVec3, polygon: &[DVec3]) -> f64 {
    // The part of the polygon with n·(v − x) ≥ 0: walk the edges, keep the vertices on that side
    // and the points where an edge crosses the plane.
    let height = |v: DVec3| n.dot(v - x);
    let mut above = Vec::with_capacity(polygon.len() + 2);
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        let (ha, hb) = (height(a), height(b));
        if ha >= 0.0 {
            above.push(a);
        }
        if (ha < 0.0 && hb > 0.0) || (ha > 0.0 && hb < 0.0) {
            above.push(a + (b - a) * (ha / (ha - hb)));
        }
    }
    if above.len() < 3 {
        return 0.0;
    }
    let u: Vec<DVec3> = above.iter().map(|&v| (v - x).normalize_or_zero()).collect();
    let mut sum = 0.0;
    for i in 0..u.len() {
        let (a, b) = (u[i], u[(i + 1) % u.len()]);
        let cross = a.cross(b);
        let length = cross.length();
        if length > 0.0 {
            let theta = length.atan2(a.dot(b));
            sum += theta * n.dot(cross) / length;
        }
    }
    0.5 * sum.abs()
}

/// Irradiance at x (unit normal n) from `polygon` emitting radiance L toward x.
pub fn irradiance(x: DVec3, n: DVec3, polygon: &[DVec3], radiance: f64) -> f64 {
    radiance * projected_solid_angle(x, n, polygon)
}
