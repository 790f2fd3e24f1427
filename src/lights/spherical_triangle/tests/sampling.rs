//! Arvo sampling: points on the triangle and the ray, unbiasedness against Lambert's formula,
//! uniformity in solid angle (χ²), stratification kept, hostile input.

use super::*;

/// Largest barycentric violation and distance from the ray, and |1 − |direction||.
fn check_samples(case: &Case, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg32::new(seed, 7);
    let mut worst_bary = 0.0f64;
    let mut worst_ray = 0.0f64;
    let scale = case
        .v
        .iter()
        .map(|x| (dv(*x) - dv(case.p)).length())
        .fold(0.0, f64::max);
    for _ in 0..n {
        let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng))
            .unwrap_or_else(|| panic!("{}: no sample", case.name));
        assert!(s.direction.is_finite() && s.point.is_finite());
        assert!(
            (f64::from(s.direction.length()) - 1.0).abs() < 1e-6,
            "{}: |direction| = {}",
            case.name,
            s.direction.length()
        );
        let l = planar_barycentrics(s.point, case.v);
        worst_bary = worst_bary.max(-l[0]).max(-l[1]).max(-l[2]);
        worst_bary = worst_bary.max(l[0] + l[1] + l[2] - 1.0);
        let off = dv(s.point) - dv(case.p);
        let miss = off.cross(dv(s.direction)).length() / scale;
        worst_ray = worst_ray.max(miss);
        assert!(off.dot(dv(s.direction)) > 0.0, "{}: behind p", case.name);
    }
    (worst_bary, worst_ray)
}

#[test]
fn samples_lie_inside_the_triangle_and_on_the_ray() {
    for (k, case) in cases().iter().enumerate() {
        let (bary, ray) = check_samples(case, 20_000, 100 + k as u64);
        println!(
            "{:32} max barycentric violation {bary:.2e}, ray miss {ray:.2e}",
            case.name
        );
        assert!(bary <= 1e-5, "{}: barycentric violation {bary}", case.name);
        assert!(ray <= 1e-6, "{}: off the ray by {ray}", case.name);
    }
}

#[test]
fn extreme_u_give_vertices_and_edges() {
    for case in cases() {
        let omega = solid_angle(case.p, case.v);
        for u in [
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0],
            [0.5, 1.0],
            [1.0, 0.5],
        ] {
            let s = sample_spherical_triangle(case.p, case.v, u).unwrap();
            let l = planar_barycentrics(s.point, case.v);
            let tol = 1e-4;
            // u1 = 0 is the vertex B = v1; u0 = 0 collapses C' onto A; u0 = 1 puts C' at C.
            if u[1] == 0.0 {
                assert!(l[1] > 1.0 - tol, "{} {u:?}: {l:?}", case.name);
            } else if u[0] == 0.0 {
                assert!(l[2] < tol, "{} {u:?}: {l:?}", case.name);
            } else if u[0] == 1.0 && u[1] == 1.0 {
                assert!(l[2] > 1.0 - tol, "{} {u:?}: {l:?}", case.name);
            } else if u[0] == 1.0 {
                assert!(l[0] < tol, "{} {u:?}: {l:?}", case.name);
            } else {
                // u1 = 1: on the arc AC, cutting off a fraction u0 of Ω.
                assert!(l[1] < tol, "{} {u:?}: {l:?}", case.name);
                let fraction = solid_angle(case.p, [case.v[0], case.v[1], s.point]) / omega;
                assert!((fraction - u[0]).abs() < 1e-4, "{}: {fraction}", case.name);
            }
        }
    }
}

/// Mean of `ω/pdf` against the Lambert vector; returns the worst |error|/σ over the axes
/// (and along the plane normal) and the largest relative error of the cos-weighted integral.
fn unbiasedness(case: &Case, n: usize, seed: u64) -> (f64, f64) {
    let normal = {
        let [a, b, c] = case.v.map(dv);
        let n = (b - a).cross(c - a).normalize();
        if n.dot(dv(case.p) - a) >= 0.0 {
            n
        } else {
            -n
        }
    };
    let axes = [DVec3::X, DVec3::Y, DVec3::Z, normal];
    let reference = lambert_vector(case.p, case.v);
    let mut rng = Pcg32::new(seed, 5);
    let mut sum = [0.0f64; 4];
    let mut sum_sq = [0.0f64; 4];
    for _ in 0..n {
        let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng)).unwrap();
        let w = dv(s.direction);
        for (k, axis) in axes.iter().enumerate() {
            let f = w.dot(*axis) / f64::from(s.pdf);
            sum[k] += f;
            sum_sq[k] += f * f;
        }
    }
    let nf = n as f64;
    let mut worst_sigma = 0.0f64;
    let mut cos_rel = 0.0;
    for (k, axis) in axes.iter().enumerate() {
        let mean = sum[k] / nf;
        let var = (sum_sq[k] / nf - mean * mean).max(0.0) * nf / (nf - 1.0);
        let expected = reference.dot(*axis);
        // Floor of f32 rounding of the direction so near-constant integrands do not give σ = 0.
        let sigma = (var / nf).sqrt() + 1e-7 * expected.abs();
        worst_sigma = worst_sigma.max((mean - expected).abs() / sigma);
        if k == 3 {
            cos_rel = (mean / expected - 1.0).abs();
        }
    }
    (worst_sigma, cos_rel)
}

#[test]
fn estimator_is_unbiased_against_lamberts_formula() {
    for (k, case) in cases().iter().enumerate() {
        let omega = solid_angle(case.p, case.v);
        let (sigmas, cos_rel) = unbiasedness(case, 200_000, 1000 + k as u64);
        println!(
            "{:32} Ω = {omega:.4e}: worst deviation {sigmas:.2} σ, cos-weighted rel. error {cos_rel:.2e}",
            case.name
        );
        assert!(sigmas < 5.0, "{}: {sigmas} σ", case.name);
    }
}

#[test]
fn lamberts_formula_matches_octant() {
    // Projected solid angle of the octant on each axis is a quarter disc: π/4.
    let l = lambert_vector(Vec3::ZERO, octant(3.0));
    assert!((l - DVec3::splat(PI / 4.0)).length() < 1e-12, "{l}");
}

/// Barycentric corners `(λ1, λ2)` of the 4^levels cells of repeated midpoint subdivision.
fn subdivide(levels: u32) -> Vec<[[f64; 2]; 3]> {
    let mut cells = vec![[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]];
    for _ in 0..levels {
        cells = cells
            .iter()
            .flat_map(|&[a, b, c]| {
                let mid = |x: [f64; 2], y: [f64; 2]| [0.5 * (x[0] + y[0]), 0.5 * (x[1] + y[1])];
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [bc, ca, ab]]
            })
            .collect();
    }
    cells
}

/// Smallest local barycentric of the point `x = (λ1, λ2)` in `cell` (≥ 0 inside).
fn inside_margin(cell: &[[f64; 2]; 3], x: [f64; 2]) -> f64 {
    let [a, b, c] = *cell;
    let (e1, e2, r) = (
        [b[0] - a[0], b[1] - a[1]],
        [c[0] - a[0], c[1] - a[1]],
        [x[0] - a[0], x[1] - a[1]],
    );
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    let s = (r[0] * e2[1] - r[1] * e2[0]) / det;
    let t = (e1[0] * r[1] - e1[1] * r[0]) / det;
    s.min(t).min(1.0 - s - t)
}

#[test]
fn chi_square_against_uniform_solid_angle() {
    const SAMPLES: usize = 200_000;
    let cells = subdivide(3);
    assert_eq!(cells.len(), 64);
    let all = cases();
    for name in ["near", "obtuse", "large ~2 sr", "threshold 6.2 sr"] {
        let case = all.iter().find(|c| c.name == name).unwrap();
        let [v0, v1, v2] = case.v.map(dv);
        let at = |x: [f64; 2]| (v0 + x[0] * (v1 - v0) + x[1] * (v2 - v0)).as_vec3();
        let omega = f64::from(solid_angle(case.p, case.v));
        let expected: Vec<f64> = cells
            .iter()
            .map(|cell| f64::from(solid_angle(case.p, cell.map(at))) / omega)
            .collect();
        let total: f64 = expected.iter().sum();
        assert!((total - 1.0).abs() < 1e-4, "{name}: cells sum to {total}");
        let mut counts = vec![0usize; cells.len()];
        let mut rng = Pcg32::new(4242, 9);
        for _ in 0..SAMPLES {
            let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng)).unwrap();
            let l = planar_barycentrics(s.point, case.v);
            let x = [l[1], l[2]];
            let best = (0..cells.len())
                .max_by(|&i, &j| {
                    inside_margin(&cells[i], x).total_cmp(&inside_margin(&cells[j], x))
                })
                .unwrap();
            counts[best] += 1;
        }
        let n = SAMPLES as f64;
        let chi2: f64 = counts
            .iter()
            .zip(&expected)
            .map(|(&o, &p)| (o as f64 - n * p).powi(2) / (n * p))
            .sum();
        let dof = (cells.len() - 1) as f64;
        let bound = dof + 5.0 * (2.0 * dof).sqrt();
        let min_expected = expected.iter().fold(f64::INFINITY, |m, &p| m.min(n * p));
        println!(
            "{name:24} χ² = {chi2:.1} (dof {dof}, bound {bound:.1}), smallest expected count {min_expected:.0}"
        );
        assert!(chi2 < bound, "{name}: χ² = {chi2} ≥ {bound}");
    }
}

#[test]
fn stratification_is_preserved() {
    for case in cases() {
        let mut worst = 0.0f32;
        let omega = solid_angle(case.p, case.v);
        let b = (dv(case.v[1]) - dv(case.p)).normalize();
        for u1 in [0.25f32, 0.5, 0.9] {
            let mut previous = -1.0f32;
            for k in 0..=64 {
                let u0 = k as f32 / 64.0;
                let s = sample_spherical_triangle(case.p, case.v, [u0, u1]).unwrap();
                // C' is where the line from v1 through the point meets the edge v0 v2.
                let l = planar_barycentrics(s.point, case.v);
                let w0 = l[0] / (l[0] + l[2]);
                let [v0, v2] = [case.v[0], case.v[2]].map(dv);
                let c_prime = (v0 + (1.0 - w0) * (v2 - v0)).as_vec3();
                let fraction = solid_angle(case.p, [case.v[0], case.v[1], c_prime]) / omega;
                assert!(
                    (fraction - u0).abs() < 1e-4,
                    "{} u = ({u0}, {u1}): fraction {fraction}",
                    case.name
                );
                worst = worst.max((fraction - u0).abs());
                assert!(fraction >= previous - 1e-6, "{}: not monotone", case.name);
                previous = fraction;
                // Along B C', u1 is the fraction of 1 − cos of the arc length.
                let cp = (dv(c_prime) - dv(case.p)).normalize();
                let w = (dv(s.point) - dv(case.p)).normalize();
                let arc = 0.5 * (cp - b).length_squared();
                if arc > 1e-9 {
                    let along = 0.5 * (w - b).length_squared() / arc;
                    assert!(
                        (along - f64::from(u1)).abs() < 1e-4,
                        "{} u = ({u0}, {u1}): along {along}",
                        case.name
                    );
                }
            }
        }
        println!("{:36} max |fraction − u0| = {worst:.2e}", case.name);
    }
}

/// Barycentric violation of Arvo's direction before clamping, i.e. the accuracy of the
/// spherical trigonometry itself (the public result is clamped into the triangle).
#[test]
fn raw_arvo_directions_fall_inside() {
    for (k, case) in cases().iter().enumerate() {
        let view = SphericalTriangle::new(case.p, case.v).unwrap();
        let [d0, d1, d2] = view.offset;
        let mut rng = Pcg32::new(500 + k as u64, 3);
        let mut worst = 0.0f64;
        for _ in 0..50_000 {
            // A quarter of the samples sit on the edges u1 = 1 (arc AC) or u0 = 1 (arc BC).
            let mut u = uv(&mut rng).map(f64::from);
            match rng.next_u32() % 8 {
                0 => u[1] = 1.0,
                1 => u[0] = 1.0,
                _ => {}
            }
            let w = view.arvo_direction(u).unwrap();
            let x = [d1.cross(d2), d2.cross(d0), d0.cross(d1)].map(|m| w.dot(m) / view.triple);
            let sum = x[0] + x[1] + x[2];
            worst = x.iter().fold(worst, |m, &x_i| m.max(-x_i / sum));
        }
        println!("{:36} raw barycentric violation {worst:.2e}", case.name);
        assert!(worst < 1e-6, "{}: {worst}", case.name);
    }
}

#[test]
fn grazing_and_tiny_configurations_stay_inside() {
    let big = flat_triangle(Vec3::ZERO, 1.0);
    let feet = [
        Vec3::ZERO,
        0.98 * big[0],
        0.5 * (big[1] + big[2]),
        1.5 * big[2],
    ];
    let mut rng = Pcg32::new(77, 2);
    let mut some = 0;
    for foot in feet {
        for h in [1e-2f32, 1e-4, 1e-6, -1e-6, 1e3, 1e5] {
            let case = Case {
                name: "grazing or tiny",
                p: foot + Vec3::Z * h,
                v: big,
            };
            for _ in 0..2000 {
                let Some(s) = sample_spherical_triangle(case.p, case.v, uv(&mut rng)) else {
                    continue;
                };
                some += 1;
                let l = planar_barycentrics(s.point, case.v);
                assert!(l.iter().all(|&x| x >= -1e-5), "{foot} {h}: {l:?}");
                assert!((s.direction.length() - 1.0).abs() < 1e-6);
            }
        }
    }
    assert!(some > 40_000, "{some}");
}

#[test]
fn never_nan_on_hostile_input() {
    let mut rng = Pcg32::new(99, 1);
    let specials = [
        0.0,
        -0.0,
        1e-30,
        -1e-30,
        1e30,
        -1e30,
        1.0,
        f32::MAX,
        f32::MIN_POSITIVE,
        f32::NAN,
        f32::INFINITY,
    ];
    let pick = |rng: &mut Pcg32| -> f32 {
        let r = rng.next_u32();
        if r.is_multiple_of(4) {
            specials[(r as usize / 4) % specials.len()]
        } else {
            let e = (r % 13) as i32 - 6;
            (uniform(rng) * 2.0 - 1.0) * 10f32.powi(e)
        }
    };
    let mut produced = 0;
    for _ in 0..200_000 {
        let vec = |rng: &mut Pcg32| Vec3::new(pick(rng), pick(rng), pick(rng));
        let p = vec(&mut rng);
        let mut v = [vec(&mut rng), vec(&mut rng), vec(&mut rng)];
        // Sometimes make the triangle collinear or doubled, or put p on a vertex.
        match rng.next_u32() % 8 {
            0 => v[2] = v[0] + 0.5 * (v[1] - v[0]),
            1 => v[1] = p,
            2 => v[2] = v[0],
            _ => {}
        }
        let u = [
            [uniform(&mut rng), uniform(&mut rng)],
            [0.0, 0.0],
            [1.0, 1.0],
            [f32::NAN, 0.5],
        ][(rng.next_u32() % 4) as usize];
        let omega = solid_angle(p, v);
        let pdf = spherical_pdf(p, v);
        assert!(omega.is_finite() && omega >= 0.0);
        assert!(omega <= 2.0 * std::f32::consts::PI + 1e-5);
        assert!(pdf.is_finite() && pdf >= 0.0);
        if let Some(s) = sample_spherical_triangle(p, v, u) {
            assert!(s.direction.is_finite() && s.point.is_finite(), "{p} {v:?}");
            assert!(s.pdf > 0.0 && s.pdf == pdf);
            produced += 1;
        }
    }
    assert!(produced > 10_000, "{produced}");
}
