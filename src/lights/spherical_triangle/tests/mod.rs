//! Tests of the spherical triangle: shared fixtures here, the solid angle in `solid_angle`,
//! sampling (support, unbiasedness, uniformity, stratification, hostile input) in `sampling`.

use super::*;
use crate::lights::triangle::MIN_SPHERICAL_SOLID_ANGLE;
use rand_core::Rng;
use rand_pcg::Pcg32;
use std::f64::consts::PI;

pub(super) fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 / 16_777_216.0
}

pub(super) fn uv(rng: &mut Pcg32) -> [f32; 2] {
    [uniform(rng), uniform(rng)]
}

pub(super) fn dv(x: Vec3) -> DVec3 {
    x.as_dvec3()
}

/// Planar barycentrics of `x` (assumed in the plane) with respect to `v`, in f64.
pub(super) fn planar_barycentrics(x: Vec3, v: [Vec3; 3]) -> [f64; 3] {
    let (a, b, c, x) = (dv(v[0]), dv(v[1]), dv(v[2]), dv(x));
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    let l1 = (x - a).cross(c - a).dot(n) / nn;
    let l2 = (b - a).cross(x - a).dot(n) / nn;
    [1.0 - l1 - l2, l1, l2]
}

/// Vector integral ∫_Δ ω dω over the spherical triangle, from Lambert's polygon formula:
/// ½ Σ Θ_i Γ_i with Θ_i the arc length of edge i and Γ_i its unit great-circle normal,
/// oriented so that Γ_i points into the triangle. Projected solid angle on n is `n·` this.
pub(super) fn lambert_vector(p: Vec3, v: [Vec3; 3]) -> DVec3 {
    let d = v.map(|x| (dv(x) - dv(p)).normalize());
    let orient = d[0].dot(d[1].cross(d[2])).signum();
    let mut sum = DVec3::ZERO;
    for i in 0..3 {
        let (a, b) = (d[i], d[(i + 1) % 3]);
        let cross = a.cross(b);
        let theta = cross.length().atan2(a.dot(b));
        sum += theta * cross.normalize();
    }
    0.5 * orient * sum
}

/// Triangle with vertices on the axes at distance r; from the origin it covers an octant.
pub(super) fn octant(r: f32) -> [Vec3; 3] {
    [Vec3::X * r, Vec3::Y * r, Vec3::Z * r]
}

/// Equilateral-ish triangle of circumradius `radius` in the plane z = 0 around `centre`.
pub(super) fn flat_triangle(centre: Vec3, radius: f32) -> [Vec3; 3] {
    [0.0f32, 2.0, 4.0].map(|k| {
        let phi = k * std::f32::consts::FRAC_PI_3 + 0.3;
        centre + radius * Vec3::new(phi.cos(), phi.sin(), 0.0)
    })
}

/// Point `foot + h·dir` where Ω of `tri` reaches `target`, by bisection on `h`.
pub(super) fn at_solid_angle(tri: [Vec3; 3], foot: Vec3, dir: Vec3, target: f32) -> Vec3 {
    let (mut lo, mut hi) = (1e-6f32, 1e6f32);
    for _ in 0..200 {
        let mid = (lo * hi).sqrt();
        if solid_angle(foot + dir * mid, tri) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    foot + dir * lo
}

/// Point above the centroid of `tri` (in z = 0) where Ω reaches `target`.
pub(super) fn height_for_solid_angle(tri: [Vec3; 3], target: f32) -> Vec3 {
    at_solid_angle(tri, (tri[0] + tri[1] + tri[2]) / 3.0, Vec3::Z, target)
}

pub(super) struct Case {
    pub(super) name: &'static str,
    pub(super) p: Vec3,
    pub(super) v: [Vec3; 3],
}

pub(super) fn cases() -> Vec<Case> {
    let big = flat_triangle(Vec3::ZERO, 1.0);
    let sliver = [
        Vec3::new(-1.0, 0.0, 0.0),
        Vec3::new(1.0, 0.02, 0.0),
        Vec3::new(0.9, -0.01, 0.0),
    ];
    vec![
        Case {
            name: "octant",
            p: Vec3::ZERO,
            v: octant(2.0),
        },
        Case {
            name: "near",
            p: Vec3::new(0.1, 0.2, 0.15),
            v: [
                Vec3::new(-0.5, -0.4, 0.0),
                Vec3::new(0.7, -0.2, 0.1),
                Vec3::new(0.0, 0.8, -0.05),
            ],
        },
        Case {
            name: "far",
            p: Vec3::new(3.0, -40.0, 25.0),
            v: [
                Vec3::new(-0.5, -0.4, 0.0),
                Vec3::new(0.7, -0.2, 0.1),
                Vec3::new(0.0, 0.8, -0.05),
            ],
        },
        Case {
            name: "large ~2 sr",
            p: height_for_solid_angle(big, 2.0),
            v: big,
        },
        Case {
            name: "small ~1e-3 sr",
            p: height_for_solid_angle(big, 1e-3),
            v: big,
        },
        Case {
            name: "obtuse",
            p: Vec3::new(0.3, 0.5, 0.6),
            v: [
                Vec3::new(-1.5, 0.0, 0.0),
                Vec3::new(1.5, 0.0, 0.0),
                Vec3::new(0.2, 0.25, 0.0),
            ],
        },
        Case {
            name: "sliver, sharp at v0",
            p: Vec3::new(0.2, 0.3, 0.4),
            v: [
                Vec3::new(-1.0, 0.0, 0.0),
                Vec3::new(1.0, 0.01, 0.0),
                Vec3::new(1.0, -0.01, 0.0),
            ],
        },
        Case {
            name: "sliver, sharp at v1",
            p: Vec3::new(0.2, 0.3, 0.4),
            v: [
                Vec3::new(1.0, 0.01, 0.0),
                Vec3::new(-1.0, 0.0, 0.0),
                Vec3::new(1.0, -0.01, 0.0),
            ],
        },
        Case {
            name: "sliver, flat at v0",
            p: Vec3::new(-0.3, 0.2, 0.5),
            v: [
                Vec3::new(0.0, 0.005, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(-1.0, 0.0, 0.0),
            ],
        },
        Case {
            name: "small, 3e-4 sr",
            p: height_for_solid_angle(big, 3e-4),
            v: big,
        },
        Case {
            name: "threshold MIN_SPHERICAL_SOLID_ANGLE",
            p: height_for_solid_angle(big, MIN_SPHERICAL_SOLID_ANGLE),
            v: big,
        },
        Case {
            name: "threshold 6.2 sr",
            p: height_for_solid_angle(big, 6.2),
            v: big,
        },
        Case {
            name: "small, 3e-4 sr, oblique sliver",
            p: at_solid_angle(
                sliver,
                Vec3::ZERO,
                Vec3::new(0.3, -0.5, 0.2).normalize(),
                3e-4,
            ),
            v: sliver,
        },
        Case {
            name: "threshold 6.2 sr, off-centre",
            p: at_solid_angle(big, 0.8 * big[1] + 0.1 * big[2], Vec3::Z, 6.2),
            v: big,
        },
        Case {
            name: "edge-on, p beside the plane",
            p: Vec3::new(2.0, 0.1, 0.02),
            v: big,
        },
    ]
}

mod sampling;
mod solid_angle;
