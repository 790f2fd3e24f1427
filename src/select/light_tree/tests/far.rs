//! Far lanes: a distant cluster of lights facing the receiver is not descended, and its lights
//! are chosen in exact proportion to their power, with `sample` and `pmf` agreeing bit for bit.

use super::*;

/// A flat triangle light's bounds: a square of side `size` at `centre`, facing −y.
fn facing_down(centre: Vec3, size: f32, phi: f32) -> LightBounds {
    LightBounds {
        lo: centre - Vec3::new(size, 0.0, size) * 0.5,
        hi: centre + Vec3::new(size, 0.0, size) * 0.5,
        phi,
        w: Vec3::NEG_Y,
        cos_theta_o: 1.0,
        cos_theta_e: 0.0,
        two_sided: false,
    }
}

/// 60 lights over a receiver at the origin, and a cluster of 40 a hundred metres away (their
/// indices in `bounds`).
fn near_and_far_lights(rng: &mut Rand) -> (Vec<LightBounds>, std::ops::Range<usize>) {
    let mut bounds: Vec<LightBounds> = (0..60)
        .map(|_| {
            let c = Vec3::new(
                rng.range(-5.0, 5.0),
                rng.range(3.0, 6.0),
                rng.range(-5.0, 5.0),
            );
            facing_down(c, 0.3, rng.range(0.5, 2.0))
        })
        .collect();
    let cluster = bounds.len()..bounds.len() + 40;
    bounds.extend((0..40).map(|_| {
        let c = Vec3::new(100.0 + rng.range(-1.0, 1.0), 10.0, rng.range(-1.0, 1.0));
        facing_down(c, 0.1, 10f32.powf(rng.range(-1.0, 1.0)))
    }));
    (bounds, cluster)
}

#[test]
fn a_far_cluster_is_chosen_in_proportion_to_power() {
    let mut rng = Rand::new(31);
    let (bounds, cluster) = near_and_far_lights(&mut rng);
    let (bvh, order) = LightBvh::build(&bounds);
    let descending = LightBvh {
        prefix: None,
        ..bvh.clone()
    };
    let (p, n) = (Vec3::ZERO, Vec3::Y);
    let phi = |l: usize| f64::from(bounds[order[l] as usize].phi);
    // The root's far interior lanes: lane k is taken with probability I_k / Σ I, and then each of
    // its lights with its share of the lane's power.
    let root = &bvh.nodes[0];
    let lanes = bvh.importances(0, p, n, Lobe::NONE).unwrap();
    let (mut checked, mut differs) = (0, 0);
    for (k, _) in interior_lanes(&bvh, 0).filter(|&(k, _)| lanes.far & (1 << k) != 0) {
        let range = root.first[k] as usize..root.lane_end(k, bvh.len());
        let power: f64 = range.clone().map(phi).sum();
        let lane = lanes.lanes[k] / lanes.total();
        for l in range {
            assert!(cluster.contains(&(order[l] as usize)), "light {l} is near");
            let expected = lane * phi(l) / power;
            let got = bvh.pmf(p, n, l);
            assert!(
                (got - expected).abs() <= 1e-12 * expected,
                "light {l}: {got} vs {expected}"
            );
            // A walk down to the lights weighs each by its own bounds instead.
            let walked = descending.pmf(p, n, l);
            differs += usize::from((walked - expected).abs() > 1e-9 * expected);
            checked += 1;
        }
    }
    assert!(
        checked >= 30 && differs > checked / 2,
        "{checked} checked, {differs} differ"
    );
    check_frequencies(&bvh, p, n, 200_000, &mut rng);
}

/// The far-lane sine is a knob of the walk: at 0 no lane is far and every light's pmf is, bit for
/// bit, that of a tree without the power prefix (which always descends); a wider sine makes a
/// superset of the root's lanes far, and sampling still matches its pmf.
#[test]
fn the_far_sine_sets_which_lanes_end_the_walk() {
    let mut rng = Rand::new(32);
    let (bounds, _) = near_and_far_lights(&mut rng);
    let (bvh, _) = LightBvh::build(&bounds);
    let (p, n) = (Vec3::ZERO, Vec3::Y);
    let descending = LightBvh {
        prefix: None,
        ..bvh.clone()
    };
    let never = bvh.clone().with_far_sin(0.0);
    assert!(never.prefix.is_none());
    assert_eq!(never.importances(0, p, n, Lobe::NONE).unwrap().far, 0);
    for l in 0..bvh.len() {
        assert_eq!(
            never.pmf(p, n, l).to_bits(),
            descending.pmf(p, n, l).to_bits(),
            "light {l}"
        );
    }
    let default_far = bvh.importances(0, p, n, Lobe::NONE).unwrap().far;
    let wide = bvh.clone().with_far_sin(0.95);
    let wide_far = wide.importances(0, p, n, Lobe::NONE).unwrap().far;
    assert_ne!(default_far, 0, "the cluster's lane is far at the default");
    assert_eq!(wide_far & default_far, default_far);
    assert_ne!(wide_far, default_far, "a wider sine makes more lanes far");
    check_frequencies(&wide, p, n, 200_000, &mut rng);
}
