//! Node layout and bounds: sizes, degenerate input, quantised bounds that hold their lights,
//! cone unions, the lane importance against the same bound written with angles, decoded and
//! coded nodes bit for bit, AVX2 and portable copies bit for bit.

use super::*;

#[test]
fn nodes_are_32_and_256_bytes() {
    assert_eq!(std::mem::size_of::<Node>(), 32);
    assert_eq!(std::mem::size_of::<WideNode>(), 256);
}

#[test]
fn degenerate_inputs_stay_finite() {
    let point = LightBounds {
        lo: Vec3::ONE,
        hi: Vec3::ONE,
        phi: 1e30,
        w: Vec3::ZERO,
        cos_theta_o: 1.0,
        cos_theta_e: 0.0,
        two_sided: false,
    };
    let tiny = Vec3::splat(1e-6);
    let probes = [
        (Vec3::ONE, Vec3::Z),
        (Vec3::ONE, Vec3::ZERO),
        (Vec3::ONE + tiny, -Vec3::Z),
        (Vec3::ONE + Vec3::X * 1e7, Vec3::ZERO),
        (Vec3::ZERO, Vec3::ZERO),
    ];
    for (p, n) in probes {
        for b in [
            point,
            LightBounds {
                hi: Vec3::ONE + tiny,
                ..point
            },
        ] {
            let i = importance(&b, p, n);
            assert!(i.is_finite() && i > 0.0, "{p} {n}: {i}");
        }
    }
    let (single, _) = LightBvh::build(&[point]);
    assert_eq!(single.sample(Vec3::NAN, Vec3::Z, 0.5), None);
    assert_eq!(single.pmf(Vec3::NAN, Vec3::Z, 0), 0.0);
    // Excluded lights: zero or non-finite power or bounds.
    let bad = [
        LightBounds { phi: 0.0, ..point },
        LightBounds {
            phi: f32::NAN,
            ..point
        },
        LightBounds {
            lo: Vec3::NAN,
            ..point
        },
        LightBounds {
            phi: f32::INFINITY,
            ..point
        },
    ];
    let mut lights = bad.to_vec();
    lights.push(point);
    let (bvh, order) = LightBvh::build(&lights);
    assert_eq!(order, vec![4]);
    assert_eq!(bvh.sample(Vec3::ZERO, Vec3::ZERO, 0.3), Some((0, 1.0)));
    assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::ZERO, 1), 0.0);
    let (empty, order) = LightBvh::build(&bad);
    assert!(empty.is_empty() && order.is_empty() && empty.bytes() == 0);
    assert_eq!(empty.sample(Vec3::ZERO, Vec3::Z, 0.5), None);
    assert_eq!(empty.pmf(Vec3::ZERO, Vec3::Z, 0), 0.0);
    // Many lights at one point: median splits.
    let (same, _) = LightBvh::build(&vec![point; 1000]);
    let mut rng = Rand::new(5);
    check_frequencies(&same, Vec3::ZERO, Vec3::ONE.normalize(), 10_000, &mut rng);
}

#[test]
fn quantised_nodes_hold_their_bounds() {
    let mut rng = Rand::new(6);
    let grid = Grid::new(Vec3::splat(-10.0), Vec3::splat(10.0));
    for _ in 0..20_000 {
        let (a, b) = (rng.point(-10.0, 10.0), rng.point(-10.0, 10.0));
        let bounds = LightBounds {
            lo: a.min(b),
            hi: a.max(b),
            phi: 1.0,
            w: rng.unit(),
            cos_theta_o: rng.range(-1.0, 1.0).max(rng.range(-1.0, 1.0)),
            cos_theta_e: rng.range(0.0, 1.0),
            two_sided: rng.f32() < 0.5,
        };
        let q = Node::default().with_bounds(&bounds, &grid).bounds(&grid);
        assert!(q.lo.cmple(bounds.lo).all() && q.hi.cmpge(bounds.hi).all());
        assert!(q.cos_theta_e <= bounds.cos_theta_e);
        assert_eq!(q.two_sided, bounds.two_sided);
        let theta = |c: f32| f64::from(c).acos();
        let drift = angle_between(q.w.as_dvec3(), bounds.w.as_dvec3());
        if q.cos_theta_o > -1.0 {
            assert!(drift + theta(bounds.cos_theta_o) <= theta(q.cos_theta_o));
        }
        assert!(drift < 1e-4, "octahedral error {drift}");
    }
}

#[test]
fn cone_union_holds_both_cones() {
    let mut rng = Rand::new(7);
    for _ in 0..20_000 {
        let a = (rng.unit(), rng.range(-1.0, 1.0).max(rng.range(0.5, 1.0)));
        let b = (rng.unit(), rng.range(0.0, 1.0).max(rng.range(0.9, 1.0)));
        let (w, cos) = cone_union(a, b);
        let theta = |c: f32| f64::from(c).acos();
        for (axis, c) in [a, b] {
            let need = angle_between(w.as_dvec3(), axis.as_dvec3()) + theta(c);
            assert!(cos <= -1.0 || need <= theta(cos), "{need} > {}", theta(cos));
        }
    }
}

/// The importance written with angles (acos, asin) in f64 from the formula in
/// `lanes`' header, for comparison with the lanes' (cos, sin) arithmetic, the
/// distance term measured from `power_centre` and shortened by `spread_sq` (σ²); `None` near a
/// threshold.
fn importance_with_angles(
    b: &LightBounds,
    radius: f32,
    power_centre: Vec3,
    spread_sq: f32,
    p: Vec3,
    n: Vec3,
) -> Option<f64> {
    use std::f64::consts::FRAC_PI_2;
    let centre = ((b.lo + b.hi) * 0.5).as_dvec3();
    let (p, n) = (p.as_dvec3(), n.as_dvec3());
    let (r, d) = (f64::from(radius), p.distance(centre));
    if (d - r).abs() < 1e-3 * r.max(1e-3) || (d - 0.25 * r).abs() < 1e-3 * r.max(1e-3) {
        return None;
    }
    let (share, inside_floor) = (0.1, 0.25);
    // The lanes read the coded cone axis w' as it is (|w'| within 1.5e-5 of 1, θo
    // widened for that): cos θw = w'·d for the unit direction d from the centre to p.
    let cos_w = b.w.as_dvec3().dot((p - centre).normalize());
    let theta_w = cos_w.clamp(-1.0, 1.0).acos();
    let theta_w = if b.two_sided {
        theta_w.min(std::f64::consts::PI - theta_w)
    } else {
        theta_w
    };
    let theta_o = f64::from(b.cos_theta_o).clamp(-1.0, 1.0).acos();
    let theta_e = f64::from(b.cos_theta_e).clamp(-1.0, 1.0).acos();
    let theta_i = angle_between(n, centre - p);
    // The cosine of θx − θ for the sphere of radius `radius` (1 inside it).
    let cosine = |theta_x: f64, radius: f64| {
        if d <= radius {
            1.0
        } else {
            (theta_x - (radius / d).asin()).max(0.0).cos()
        }
    };
    let theta_x = (theta_w - theta_o).max(0.0);
    let mut emitted = cosine(theta_x, 0.25 * r);
    let mut received = cosine(theta_i, 0.25 * r);
    if d > r {
        let theta_b = (r / d).asin();
        let theta_p = (theta_x - theta_b).max(0.0);
        let theta_r = (theta_i - theta_b).max(0.0);
        let near = |a: f64, b: f64| (a - b).abs() < 1e-3;
        if near(theta_p, theta_e) || (n != DVec3::ZERO && near(theta_r, FRAC_PI_2)) {
            return None;
        }
        if theta_p >= theta_e || (n != DVec3::ZERO && theta_r >= FRAC_PI_2) {
            return Some(0.0);
        }
        emitted = emitted.max(share * theta_p.cos());
        received = received.max(share * theta_r.cos());
    } else {
        emitted = emitted.max(inside_floor);
        received = received.max(inside_floor);
    }
    emitted = emitted.max(f64::from(COS_FLOOR));
    received = if n == DVec3::ZERO {
        1.0
    } else {
        received.max(f64::from(COS_FLOOR))
    };
    let spread_sq = f64::from(spread_sq);
    let d_sq = (p.distance_squared(power_centre.as_dvec3()) - 1.5 * spread_sq)
        .max(0.05 * r * r)
        .max(0.5 * spread_sq);
    Some(f64::from(b.phi) * emitted * received / d_sq)
}

/// The walk reads the top nodes from their decoded copy and the others from their codes, one
/// lane at a time: both must give the same bits, with and without a receiver, a lobe or the
/// root's table terms. A decoded node whose lanes all face every way skips the emitter's cone
/// (`Decoded::full_cones`), which the codes' path never does: the same bits there too.
#[test]
fn kept_decoded_nodes_give_the_same_importances_as_their_codes() {
    let mut rng = Rand::new(12);
    let scene = random_scene(&mut rng, 3000);
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let full = bvh
        .nodes
        .iter()
        .filter(|n| Decoded::of(n).full_cones)
        .count();
    assert!(
        full > 0 && full < bvh.nodes.len(),
        "{full} of {}",
        bvh.nodes.len()
    );
    let (mut compared, mut with_table) = (0, 0);
    for (p, n) in receivers(&mut rng, &scene, 60) {
        let glossy = random_lobe(&mut rng, n);
        let near = bvh.near.at(0, p, n);
        with_table += usize::from(near.is_some());
        for node in &bvh.nodes {
            let decoded = Decoded::of(node);
            for (lobe, receiver, terms) in [
                (Lobe::NONE, n, None),
                (Lobe::NONE, Vec3::ZERO, None),
                (glossy, n, None),
                (Lobe::NONE, n, near),
                (glossy, n, near),
            ] {
                let coded = importances(node, p, receiver, &lobe, terms, DEFAULT_FAR_SIN);
                let kept =
                    decoded_importances(&decoded, p, receiver, &lobe, terms, DEFAULT_FAR_SIN);
                assert_eq!(
                    (coded.importance.map(f32::to_bits), coded.far),
                    (kept.importance.map(f32::to_bits), kept.far),
                    "p {p} n {n}"
                );
                compared += 1;
            }
        }
    }
    assert!(
        compared > 1000 && with_table > 10,
        "{compared} {with_table}"
    );
}

/// A whole-sphere cone (cos θo code 0) whose axis is coded slightly longer than 1 (a cone
/// widened to π keeps its own axis) gives cos θw < −1 just behind it, where the emitter term
/// of the codes' path exceeds 1: such a lane must not take the whole-sphere shortcut. The exact
/// axis (0, 0, 1) must, with the same bits all around the lane.
#[test]
fn only_exact_whole_sphere_cones_skip_the_emitter_term() {
    let lane = |axis: [i16; 3]| {
        let mut node = WideNode::empty();
        node.origin = [0.0; 3];
        node.step = [0.01; 3];
        node.radius_step = 0.01;
        for (a, &code) in axis.iter().enumerate() {
            node.centre[a][0] = 100;
            node.axis[a][0] = code;
        }
        node.radius[0] = 100;
        node.cos_o[0] = 0;
        node.cos_e[0] = encode_cos(0.0) as u16;
        node.phi[0] = encode_phi(1.0, false);
        node
    };
    let exact = lane([0, 0, i16::MAX]);
    let long = lane([300, 300, i16::MAX]);
    assert!(Decoded::of(&exact).full_cones);
    assert!(!Decoded::of(&long).full_cones);
    let mut rng = Rand::new(31);
    for node in [exact, long] {
        let decoded = Decoded::of(&node);
        let w = Vec3::from_array(std::array::from_fn(|a| decoded.axis[a][0]));
        let centre = Vec3::ONE;
        // Just behind the axis (cos θw at its most negative), then all around.
        let mut receivers = vec![(centre - 5.0 * w.normalize(), w.normalize())];
        receivers.extend((0..200).map(|_| {
            let p = centre + 6.0 * rng.unit();
            (p, (centre - p).normalize())
        }));
        for (p, n) in receivers {
            let coded = importances(&node, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN);
            let kept = decoded_importances(&decoded, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN);
            assert_eq!(
                (coded.importance.map(f32::to_bits), coded.far),
                (kept.importance.map(f32::to_bits), kept.far),
                "p {p} axis {w}"
            );
        }
    }
}

#[test]
fn lane_importance_matches_the_bound_written_with_angles() {
    let mut rng = Rand::new(10);
    let scene = random_scene(&mut rng, 2000);
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let mut compared = 0;
    for (p, n) in receivers(&mut rng, &scene, 300) {
        for node in &bvh.nodes {
            let lanes = importances(node, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN).importance;
            let decoded = Decoded::of(node);
            for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
                let phi = decoded.signed_phi[k];
                let at = |field: &[[f32; LANES]; 3]| Vec3::from_array(field.map(|f| f[k]));
                let power_centre = at(&decoded.power_centre);
                let (c, w) = (at(&decoded.centre), at(&decoded.axis));
                let b = LightBounds {
                    lo: c,
                    hi: c,
                    phi: phi.abs(),
                    w,
                    cos_theta_o: decoded.cos_o[k],
                    cos_theta_e: decoded.cos_e[k],
                    two_sided: phi < 0.0,
                };
                let radius = decoded.radius[k];
                let Some(expected) =
                    importance_with_angles(&b, radius, power_centre, decoded.spread_sq[k], p, n)
                else {
                    continue;
                };
                let got = f64::from(lanes[k]);
                let tolerance = 1e-3 * expected + f64::from(f32::MIN_POSITIVE);
                assert!(
                    (got - expected).abs() <= tolerance || (expected == 0.0 && got > 0.0),
                    "lane {k} at p {p} n {n}: {got} vs {expected}"
                );
                compared += usize::from(expected > 0.0);
            }
        }
    }
    println!("{compared} positive lane importances compared");
    assert!(compared > 1000);
}

#[test]
fn avx2_and_portable_copies_agree_bit_for_bit() {
    let mut rng = Rand::new(11);
    let scene = random_scene(&mut rng, 3000);
    let (fast, _) = LightBvh::build(&scene.bounds);
    let portable = LightBvh {
        avx2: false,
        ..fast.clone()
    };
    println!("AVX2 copy in use: {}", fast.avx2);
    for (p, n) in receivers(&mut rng, &scene, 600) {
        let u = rng.f64();
        let (a, b) = (fast.sample(p, n, u), portable.sample(p, n, u));
        assert_eq!(
            a.map(|(l, q)| (l, q.to_bits())),
            b.map(|(l, q)| (l, q.to_bits()))
        );
        let light = rng.below(fast.len());
        assert_eq!(
            fast.pmf(p, n, light).to_bits(),
            portable.pmf(p, n, light).to_bits()
        );
    }
}

/// `bounds` with every box scaled by `scale` about the origin, then moved by `offset` along
/// each axis (cones and power unchanged).
fn scaled(bounds: &[LightBounds], scale: f32, offset: f32) -> Vec<LightBounds> {
    bounds
        .iter()
        .map(|b| LightBounds {
            lo: b.lo * scale + Vec3::splat(offset),
            hi: b.hi * scale + Vec3::splat(offset),
            ..*b
        })
        .collect()
}

#[test]
fn wide_lanes_hold_their_lights() {
    let mut rng = Rand::new(12);
    let mut checked = 0;
    let mut singles = 0;
    for (scale, offset) in [(1e-4, 0.0), (1.0, 0.0), (1e6, 0.0), (1.0, 1e6), (1e-4, 1e3)] {
        let scene = random_scene(&mut rng, 3000);
        let mut lights = scaled(&scene.bounds, scale, offset);
        for (i, b) in lights.iter_mut().enumerate() {
            b.cos_theta_e = [0.0, 1e-3f32.cos(), 0.5, -0.9][i % 4];
        }
        let (bvh, order) = LightBvh::build(&lights);
        for (id, &original) in order.iter().enumerate() {
            let light = &lights[original as usize];
            let mut index = 0;
            loop {
                let node = &bvh.nodes[index];
                let k = node.lane_of(id as u32).expect("a lane holds every light");
                let lanes = Decoded::of(node);
                // The lane's sphere holds the light's box (f64 distances to its corners), with a
                // margin of 4ε, which the zero test counts on (`REJECT_ANGLE`).
                let centre = DVec3::from_array(lanes.centre.map(|c| f64::from(c[k])));
                let within = f64::from(lanes.radius[k]) / (1.0 + 4.0 * f64::from(f32::EPSILON));
                for corner in 0..8 {
                    let pick =
                        |a: usize, lo: f32, hi: f32| if corner >> a & 1 == 0 { lo } else { hi };
                    let c = DVec3::new(
                        f64::from(pick(0, light.lo.x, light.hi.x)),
                        f64::from(pick(1, light.lo.y, light.hi.y)),
                        f64::from(pick(2, light.lo.z, light.hi.z)),
                    );
                    assert!(c.distance(centre) <= within, "light {id} box");
                }
                // Its cone holds the light's, read as the lanes read it (w' as it is: the
                // angle from cos = w'·d, at most acos(min(|w'|, 1/|w'|)) off ∠(w', d)).
                let axis = DVec3::from_array(lanes.axis.map(|a| f64::from(a[k])));
                if lanes.cos_o[k] > -1.0 {
                    let need = angle_between(axis, light.w.as_dvec3())
                        + f64::from(light.cos_theta_o).acos()
                        + stretch(axis.length()).0.acos();
                    assert!(need <= f64::from(lanes.cos_o[k]).acos(), "light {id} cone");
                }
                // θe widened by the zero test's margin.
                assert!(f64::from(lanes.cos_e[k]) <= widened(light.cos_theta_e, REJECT_ANGLE));
                // Φ is rounded to nearest in bfloat16 (8 significant bits).
                assert!(lanes.signed_phi[k].abs() >= light.phi * (1.0 - 1.0 / 256.0));
                assert!(!light.two_sided || lanes.signed_phi[k] < 0.0);
                checked += 1;
                let child = node.child(k);
                if child & LIGHT_LANE != 0 {
                    // The lane's light, or for a pair lane its first light or the next.
                    let (first, pair) = (child & !LIGHT_LANE, u32::from(node.pairs >> k & 1));
                    assert!((first..=first + pair).contains(&(id as u32)), "light {id}");
                    if pair == 0 {
                        // A single light's lane: θe widened by the margin, no more.
                        let binary = decode_cos(encode_cos(f64::from(light.cos_theta_e)));
                        let expected = decode_cos(encode_cos(widened(binary, REJECT_ANGLE)));
                        assert_eq!(lanes.cos_e[k], expected, "light {id} θe");
                        singles += 1;
                    }
                    break;
                }
                index = child as usize;
            }
        }
    }
    println!("{checked} lanes checked, {singles} single lights' θe");
}

#[test]
fn lanes_know_their_power_centre_spread_and_power() {
    let mut rng = Rand::new(13);
    let mut checked = 0;
    for (scale, offset) in [(1e-4, 0.0), (1.0, 0.0), (1e6, 0.0), (1.0, 1e6)] {
        let scene = random_scene(&mut rng, 3000);
        let lights = scaled(&scene.bounds, scale, offset);
        let (bvh, order) = LightBvh::build(&lights);
        // (box centre, Φ) of every light of every lane, gathered light by light along its path.
        let mut members: std::collections::HashMap<(usize, usize), Vec<(DVec3, f64)>> =
            Default::default();
        for (id, &original) in order.iter().enumerate() {
            let light = &lights[original as usize];
            let centre = (light.lo.min(light.hi) + light.lo.max(light.hi)).as_dvec3() * 0.5;
            let phi = f64::from(light.phi);
            let mut index = 0;
            loop {
                let node = &bvh.nodes[index];
                let k = node.lane_of(id as u32).expect("a lane holds every light");
                members.entry((index, k)).or_default().push((centre, phi));
                let child = node.child(k);
                if child & LIGHT_LANE != 0 {
                    break;
                }
                index = child as usize;
            }
        }
        for (&(index, k), lane) in &members {
            let lanes = Decoded::of(&bvh.nodes[index]);
            let phi: f64 = lane.iter().map(|&(_, w)| w).sum();
            let expected = lane.iter().map(|&(x, w)| x * w).sum::<DVec3>() / phi;
            let got = DVec3::from_array(lanes.power_centre.map(|c| f64::from(c[k])));
            // Offsets are coded in steps of r/127 (half a step off at most), then decoded in f32.
            let r = f64::from(lanes.radius[k]);
            let slack = r / 254.0 + 1e-6 * (expected.abs().max_element() + r);
            assert!(
                (got - expected).abs().max_element() <= slack,
                "node {index} lane {k}: power centre {got} vs {expected} (r {r})"
            );
            // The spread, in two passes about the centre: coded in steps of r/15 (half a step
            // off at most), decoded in f32 (1e-4 relative), from f32 box centres (1e-6 of the
            // coordinates far from the origin).
            let spread = (lane
                .iter()
                .map(|&(x, w)| (x - expected).length_squared() * w)
                .sum::<f64>()
                / phi)
                .sqrt();
            let coded_spread = f64::from(lanes.spread_sq[k]).sqrt();
            assert!(
                (coded_spread - spread).abs()
                    <= r / 30.0 * (1.0 + 1e-4) + 1e-6 * (expected.abs().max_element() + r),
                "node {index} lane {k}: spread {coded_spread} vs {spread} (r {r})"
            );
            let coded = f64::from(lanes.signed_phi[k].abs());
            assert!(
                (coded - phi).abs() <= phi / 256.0,
                "node {index} lane {k}: Φ {coded} vs {phi}"
            );
            checked += 1;
        }
    }
    println!("{checked} lanes checked");
    assert!(checked > 1000);
}

#[test]
fn codes_round_to_nearest_as_the_library_does() {
    let mut rng = Rand::new(31);
    let mut values = vec![
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.5,
        -1.5,
        2.5,
        -2.5,
        0.49999999999999994,
        -0.49999999999999994,
        126.5,
        -127.5,
        4503599627370495.5,
        4503599627370497.0,
        -9.2e18,
        f64::MIN_POSITIVE,
    ];
    for _ in 0..100_000 {
        let x = (rng.f64() - 0.5) * 400.0;
        values.extend([x, x.floor() + 0.5, x.ceil() - 0.5, x.floor()]);
    }
    for x in values {
        let rounded = round_to_nearest(x);
        assert!(rounded == x.round(), "{x}: {rounded} against {}", x.round());
    }
    // Beyond the conversion's range and for non-finite x the codes are the library's.
    for x in [1e30, -1e30, f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
        let code = |r: f64| r.clamp(-127.0, 127.0) as i8;
        assert_eq!(code(round_to_nearest(x)), code(x.round()), "{x}");
    }
}

#[test]
fn split_costs_are_the_same_in_four_and_eight_lanes() {
    if !crate::cpu::has_avx2_fma() {
        println!("no AVX2 here: only one copy of the costs to compare");
        return;
    }
    let mut rng = Rand::new(37);
    // Cosines at and near the ends of their range, beside random ones.
    let cosines = [-1.0, -0.999_999, 0.0, 1e-7, 0.5, 0.999_999, 1.0];
    for round in 0..2_000 {
        let mut inputs = CostInputs::new();
        for i in 0..BATCH {
            let pick = |rng: &mut Rand| {
                if round % 4 == 0 {
                    cosines[(rng.f64() * cosines.len() as f64) as usize % cosines.len()]
                } else {
                    rng.f32() * 2.0 - 1.0
                }
            };
            inputs.phi_area[i] = rng.f32();
            inputs.a_sq[i] = if round % 7 == 0 { 0.0 } else { rng.f32() * 9.0 };
            inputs.a_min[i] = rng.f32() * 6.0 - 3.0;
            inputs.cos_o[i] = pick(&mut rng);
            inputs.cos_e[i] = pick(&mut rng);
            if round % 4 == 1 {
                // The cone's nearest axis exactly opposite θo: cos θ + cos θo = 0.
                inputs.a_sq[i] = 4.0;
                inputs.a_min[i] = -2.0 * inputs.cos_o[i];
            }
        }
        let eight = inputs.costs(BATCH);
        inputs.avx2 = false;
        let four = inputs.costs(BATCH);
        assert_eq!(
            eight.map(f32::to_bits),
            four.map(f32::to_bits),
            "{inputs:?}"
        );
    }
}
