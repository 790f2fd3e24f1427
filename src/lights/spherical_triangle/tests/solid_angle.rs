//! The solid angle Ω: known values, invariances, degenerate cases, pdf = 1/Ω.

use super::*;

#[test]
fn solid_angle_of_octant_is_pi_over_2() {
    for r in [1e-3, 0.5, 1.0, 7.0, 1e4] {
        let omega = solid_angle(Vec3::ZERO, octant(r));
        assert!(
            (f64::from(omega) - PI / 2.0).abs() < 1e-6,
            "r = {r}: {omega}"
        );
    }
}

#[test]
fn solid_angle_of_small_far_triangle_matches_area_cos_over_d2() {
    let v = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.02, 0.0, 0.0),
        Vec3::new(0.005, 0.03, 0.0),
    ];
    let centroid = (dv(v[0]) + dv(v[1]) + dv(v[2])) / 3.0;
    let area = 0.5 * (dv(v[1]) - dv(v[0])).cross(dv(v[2]) - dv(v[0])).length();
    for (dir, d) in [
        (DVec3::Z, 5.0),
        (DVec3::new(0.3, -0.4, 0.8).normalize(), 10.0),
        (DVec3::new(-0.9, 0.1, 0.2).normalize(), 3.0),
    ] {
        let p = (centroid + d * dir).as_vec3();
        let to_p = dv(p) - centroid;
        let expected = area * to_p.normalize().z.abs() / to_p.length_squared();
        let omega = f64::from(solid_angle(p, v));
        assert!(
            (omega / expected - 1.0).abs() < 1e-3,
            "{omega} vs {expected}"
        );
    }
}

#[test]
fn solid_angle_ignores_vertex_order_and_orientation() {
    for case in cases() {
        let [a, b, c] = case.v;
        let reference = solid_angle(case.p, case.v);
        for perm in [
            [a, b, c],
            [b, c, a],
            [c, a, b],
            [a, c, b],
            [c, b, a],
            [b, a, c],
        ] {
            let omega = solid_angle(case.p, perm);
            assert!(
                (omega - reference).abs() <= 1e-6 * reference,
                "{}: {omega} vs {reference}",
                case.name
            );
        }
        // Reflecting p through the plane flips the orientation as seen from p.
        let n = (dv(b) - dv(a)).cross(dv(c) - dv(a)).normalize();
        let mirrored = dv(case.p) - 2.0 * (dv(case.p) - dv(a)).dot(n) * n;
        let omega = solid_angle(mirrored.as_vec3(), case.v);
        assert!(
            (omega - reference).abs() <= 1e-4 * reference,
            "{} mirrored: {omega} vs {reference}",
            case.name
        );
    }
}

#[test]
fn solid_angle_is_zero_in_plane_or_degenerate() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    for p in [
        Vec3::new(0.2, 0.2, 0.0),
        Vec3::new(3.0, -1.0, 0.0),
        Vec3::ZERO,
        Vec3::new(0.5, 0.0, 0.0),
    ] {
        assert_eq!(solid_angle(p, tri), 0.0, "{p}");
        assert_eq!(spherical_pdf(p, tri), 0.0);
        assert!(sample_spherical_triangle(p, tri, [0.5, 0.5]).is_none());
    }
    let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
    let point = [Vec3::ONE; 3];
    for v in [line, point] {
        assert_eq!(solid_angle(Vec3::Z, v), 0.0);
        assert!(sample_spherical_triangle(Vec3::Z, v, [0.5, 0.5]).is_none());
    }
    // A tilted plane: p is only in it up to f32 rounding.
    let tilted = [
        Vec3::new(0.1, 0.2, 0.3),
        Vec3::new(1.3, -0.7, 0.9),
        Vec3::new(-0.4, 1.1, 2.0),
    ];
    let p = tilted[0] + 0.3 * (tilted[1] - tilted[0]) + 0.25 * (tilted[2] - tilted[0]);
    let outside = tilted[0] + 1.5 * (tilted[1] - tilted[0]) + 0.25 * (tilted[2] - tilted[0]);
    assert!(solid_angle(outside, tilted) < 1e-5);
    let omega = solid_angle(p, tilted);
    println!("p in a tilted plane (up to f32 rounding): Ω = {omega:e}");
    assert!(
        !(1e-5..=2.0 * std::f32::consts::PI - 1e-4).contains(&omega),
        "{omega}"
    );
}

#[test]
fn pdf_is_reciprocal_of_solid_angle() {
    let mut rng = Pcg32::new(11, 3);
    for case in cases() {
        let omega = solid_angle(case.p, case.v);
        let pdf = spherical_pdf(case.p, case.v);
        assert_eq!(pdf, 1.0 / omega, "{}", case.name);
        for _ in 0..100 {
            let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng)).unwrap();
            assert_eq!(s.pdf, pdf, "{}", case.name);
        }
    }
}
