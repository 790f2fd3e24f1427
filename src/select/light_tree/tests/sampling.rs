//! Sampling and pmf: frequencies match the pmf, every contributing light keeps a positive
//! probability (grazing receivers included), nothing behind the tangent plane, exact pmf in deep
//! trees.

use super::*;

#[test]
fn sampled_frequencies_match_pmf() {
    let mut rng = Rand::new(1);
    let (mut points, mut with_dead_ends, mut dead_mass) = (0, 0, 0.0f64);
    // Receivers inside the grid of a table below the root's, whose terms the walk then reads.
    let mut in_child_tables = 0;
    for &count in &[1, 2, 3, 100, 5000] {
        for seed in 0..3 {
            let mut scene_rng = Rand::new(100 * count as u64 + seed);
            let scene = random_scene(&mut scene_rng, count);
            let (bvh, order) = LightBvh::build(&scene.bounds);
            assert_eq!((bvh.len(), order.len()), (count, count));
            // Every light in one lane (a pair lane holds two), every node but the root in one
            // lane.
            let lanes = |leaf: bool| {
                let is = |node: &WideNode, k: usize| {
                    node.first[k] != EMPTY_LANE && (node.child(k) & LIGHT_LANE != 0) == leaf
                };
                let held = |node: &WideNode, k: usize| 1 + usize::from(node.pairs >> k & 1);
                bvh.nodes
                    .iter()
                    .map(|node| {
                        (0..LANES)
                            .filter(|&k| is(node, k))
                            .map(|k| if leaf { held(node, k) } else { 1 })
                            .sum::<usize>()
                    })
                    .sum::<usize>()
            };
            assert_eq!((lanes(true), lanes(false) + 1), (count, bvh.node_count()));
            for (p, n) in receivers(&mut rng, &scene, 6) {
                let dead = check_frequencies(&bvh, p, n, 10_000, &mut rng);
                points += 1;
                in_child_tables +=
                    usize::from((1..=LANES).any(|index| bvh.near.at(index, p, n).is_some()));
                with_dead_ends += usize::from(dead > 0.0);
                dead_mass = dead_mass.max(dead);
            }
        }
    }
    println!(
        "{with_dead_ends} of {points} shading points can reach a node whose children all \
         have importance 0 (largest probability {dead_mass:.3}); {in_child_tables} lie in a \
         child's table"
    );
    assert!(
        in_child_tables >= 6,
        "{in_child_tables} receivers in a child's table"
    );
}

#[test]
fn contributing_lights_have_positive_pmf() {
    let mut rng = Rand::new(2);
    let mut checked = 0;
    for &count in &[1, 2, 3, 100, 5000] {
        for seed in 0..4 {
            let mut scene_rng = Rand::new(7 + 1000 * count as u64 + seed);
            let scene = random_scene(&mut scene_rng, count);
            let (bvh, order) = LightBvh::build(&scene.bounds);
            for (p, n) in receivers(&mut rng, &scene, 120) {
                for node in &bvh.nodes {
                    let lanes =
                        importances(node, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN).importance;
                    assert!(lanes.iter().all(|i| i.is_finite() && *i >= 0.0));
                }
                for (light, &original) in order.iter().enumerate() {
                    let original = original as usize;
                    if scene.emitters[original].contributes(p, n, &mut rng) {
                        checked += 1;
                        assert!(
                            bvh.pmf(p, n, light) > 0.0,
                            "light {original} at p {p} n {n}"
                        );
                    }
                }
            }
        }
    }
    println!("{checked} contributing (receiver, light) pairs checked");
}

#[test]
fn lights_close_to_grazing_receivers_are_kept() {
    // A unit triangle in z = 0 facing +z; receivers on its plane, 1e-6
    // above it, and with tangent planes just touching it.
    let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let tri = Emitter::Triangle {
        v,
        two_sided: false,
    };
    let b = tri.bounds(1.0);
    let mut rng = Rand::new(3);
    let cases = [
        (Vec3::new(3.0, 0.2, 1e-6), Vec3::X * -1.0),
        (Vec3::new(0.2, 0.2, 1e-6), Vec3::new(0.0, 0.0, -1.0)),
        (
            Vec3::new(0.2, 0.2, 1e-6),
            Vec3::new(1.0, 0.0, 1e-6).normalize(),
        ),
        (
            Vec3::new(-2.0, 0.5, 1.0),
            Vec3::new(1.0, 0.0, 2.0 + 1e-5).normalize(),
        ),
        (
            Vec3::new(2.0, 2.0, 1e-6),
            Vec3::new(-1.0, -1.0, 0.0).normalize(),
        ),
    ];
    let (bvh, _) = LightBvh::build(&[b]);
    for (p, n) in cases {
        if tri.contributes(p, n, &mut rng) {
            assert!(importance(&b, p, n) > 0.0, "p {p} n {n}");
            assert!(bvh.pmf(p, n, 0) > 0.0, "p {p} n {n}");
        }
    }
    // On the emitter's plane p is on neither side: no light, but finite.
    let on_plane = importance(&b, Vec3::new(3.0, 0.5, 0.0), Vec3::X * -1.0);
    assert!(on_plane.is_finite() && on_plane >= 0.0);
}

#[test]
fn nodes_behind_the_tangent_plane_get_zero() {
    let b = LightBounds {
        lo: Vec3::new(-0.5, -0.5, -2.5),
        hi: Vec3::new(0.5, 0.5, -2.0),
        phi: 1e30,
        w: Vec3::Z,
        cos_theta_o: -1.0,
        cos_theta_e: 0.0,
        two_sided: true,
    };
    assert_eq!(importance(&b, Vec3::ZERO, Vec3::Z), 0.0);
    assert!(importance(&b, Vec3::ZERO, -Vec3::Z) > 0.0);
    assert!(importance(&b, Vec3::ZERO, Vec3::ZERO) > 0.0);
    // A tree whose lights all lie below the plane z = 0.
    let mut rng = Rand::new(4);
    let mut scene = random_scene(&mut rng, 300);
    for b in &mut scene.bounds {
        let shift = Vec3::new(0.0, 0.0, -2.0);
        b.lo += shift;
        b.hi += shift;
    }
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let (p, n) = (Vec3::new(0.0, 0.0, 0.5), Vec3::Z);
    for node in &bvh.nodes {
        assert_eq!(
            importances(node, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN).importance,
            [0.0; LANES]
        );
    }
    assert_eq!(bvh.sample(p, n, 0.5), None);
    assert!((0..bvh.len()).all(|l| bvh.pmf(p, n, l) == 0.0));
    // An emitter facing away from p.
    let away = LightBounds {
        w: Vec3::Z,
        cos_theta_o: 1.0,
        two_sided: false,
        lo: Vec3::new(-0.5, -0.5, 1.0),
        hi: Vec3::new(0.5, 0.5, 1.0),
        ..b
    };
    assert_eq!(importance(&away, Vec3::ZERO, Vec3::Z), 0.0);
    let facing_both_ways = LightBounds {
        two_sided: true,
        ..away
    };
    assert!(importance(&facing_both_ways, Vec3::ZERO, Vec3::Z) > 0.0);
}

#[test]
fn deep_trees_keep_exact_pmf() {
    let mut rng = Rand::new(8);
    // A chain of lights at geometrically shrinking distances and sizes,
    // each holding most of the power of what remains: the cost peels one
    // light per level.
    let chain = 85;
    let chain_light = |i: i32| {
        let x = 0.9f32.powi(i);
        LightBounds {
            lo: Vec3::new(x, 0.0, 0.0),
            hi: Vec3::new(1.01 * x, 0.01 * x, 0.01 * x),
            phi: (3e38 * 0.12f64.powi(i)) as f32,
            w: Vec3::Z,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
            two_sided: false,
        }
    };
    let lights: Vec<LightBounds> = (0..chain).map(chain_light).collect();
    let (bvh, _) = LightBvh::build(&lights);
    let depth = max_depth(&bvh);
    println!("chain: {} lights, depth {depth}", bvh.len());
    assert!(depth > chain as usize / LANES, "depth {depth}");
    let mut deepest_sampled = 0;
    for _ in 0..300 {
        // Just above a chain light, or anywhere near the chain.
        let x = 0.9f32.powi(rng.below(chain as usize) as i32);
        let p = match rng.below(2) {
            0 => Vec3::new(x * 1.005, x * 0.005, x * 0.01),
            _ => Vec3::new(rng.range(0.0, 2.0), 0.0, rng.range(0.1, 1.0)) * x,
        };
        let n = (rng.unit() - 2.0 * Vec3::Z).normalize_or_zero();
        for _ in 0..100 {
            if let Some((light, pmf)) = bvh.sample(p, n, rng.f64()) {
                assert_eq!(pmf.to_bits(), bvh.pmf(p, n, light).to_bits());
                deepest_sampled = deepest_sampled.max(leaf_depth(&bvh, light));
            }
        }
        let total: f64 = (0..bvh.len()).map(|l| bvh.pmf(p, n, l)).sum();
        if bvh.can_reach(p, n) {
            assert!((total + dead_end_mass(&bvh, p, n, Lobe::NONE) - 1.0).abs() < 1e-6);
        }
    }
    println!("deepest sampled leaf: {deepest_sampled}");
    assert!(deepest_sampled > chain as usize / LANES);
    let x = 0.9f32.powi(70);
    let (p, n) = (Vec3::new(x * 1.005, x * 0.005, x * 0.01), -Vec3::Z);
    check_frequencies(&bvh, p, n, 10_000, &mut rng);

    // The chain ending in a cluster of 100,000 lights shrunk to 1e-32:
    // split after split peels a light or two off a large set.
    let mut scene = random_scene(&mut rng, 100_000);
    for b in &mut scene.bounds {
        (b.lo, b.hi) = (b.lo * 1e-32, b.hi * 1e-32);
        (b.w, b.cos_theta_o, b.two_sided) = (Vec3::Z, 1.0, false);
    }
    scene.bounds.extend((0..chain).map(chain_light));
    let (bvh, _) = LightBvh::build(&scene.bounds);
    println!(
        "chain and cluster: {} lights, depth {}",
        bvh.len(),
        max_depth(&bvh)
    );
    for _ in 0..100 {
        let p = Vec3::new(rng.range(0.0, 1.0), 0.0, rng.range(0.0, 0.1)) * 1e-3;
        let n = (rng.unit() - 2.0 * Vec3::Z).normalize_or_zero();
        for _ in 0..100 {
            if let Some((light, pmf)) = bvh.sample(p, n, rng.f64()) {
                assert_eq!(pmf.to_bits(), bvh.pmf(p, n, light).to_bits());
            }
        }
    }
}

/// Depth (in wide nodes) of the lane holding `light`, found by id ranges.
fn leaf_depth(bvh: &LightBvh, light: usize) -> usize {
    let (mut index, mut depth) = (0, 1);
    loop {
        let node = &bvh.nodes[index];
        let lane = node.lane_of(light as u32).expect("light in the tree");
        if node.child(lane) & LIGHT_LANE != 0 {
            return depth;
        }
        (index, depth) = (node.child(lane) as usize, depth + 1);
    }
}

#[test]
fn a_root_evaluated_first_gives_the_same_choices() {
    let mut rng = Rand::new(12);
    let scene = random_scene(&mut rng, 300);
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let (mut reached, mut unreached) = (0, 0);
    for (p, n) in receivers(&mut rng, &scene, 400) {
        let Some(root) = bvh.root(p, n) else {
            // Where the root says no light reaches, the tree gives nothing either.
            assert!(bvh.sample(p, n, rng.f64()).is_none(), "p {p} n {n}");
            assert!((0..bvh.len()).all(|l| bvh.pmf(p, n, l) == 0.0));
            unreached += 1;
            continue;
        };
        reached += 1;
        for _ in 0..8 {
            let u = rng.f64();
            let below = bvh.sample_below_with(&root, p, n, Lobe::NONE, u);
            assert_eq!(below, bvh.sample(p, n, u), "p {p} n {n} u {u}");
            if let Some((light, pmf)) = below {
                assert_eq!(pmf.to_bits(), bvh.pmf(p, n, light).to_bits());
            }
        }
    }
    assert!(
        reached > 200 && unreached > 0,
        "{reached} reached, {unreached} not"
    );
}
