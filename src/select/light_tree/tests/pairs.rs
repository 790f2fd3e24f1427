//! Pair lanes: two lights that their bounds cannot tell apart (the triangles of a quad) share a
//! lane, which chooses between them in proportion to power; lights apart never do.

use super::*;

/// A facade of `side`² quads in the plane z = 0, facing +z, each split along its diagonal into
/// two triangles (lights 2q and 2q + 1, whose boxes and normals are the same) of powers over
/// three decades.
fn facade(rng: &mut Rand, side: usize) -> Vec<LightBounds> {
    let mut lights = Vec::with_capacity(2 * side * side);
    for (i, j) in (0..side).flat_map(|i| (0..side).map(move |j| (i, j))) {
        let corner = |di: usize, dj: usize| {
            Vec3::new((i + di) as f32 * 0.5, (j + dj) as f32 * 0.5, 0.0) - 0.25 * side as f32
        };
        let (a, b, c, d) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
        for v in [[a, b, c], [a, c, d]] {
            let power = 10f32.powf(rng.range(-1.5, 1.5));
            lights.push(
                Emitter::Triangle {
                    v,
                    two_sided: false,
                }
                .bounds(power),
            );
        }
    }
    lights
}

#[test]
fn a_quads_triangles_share_a_lane_chosen_by_power() {
    let mut rng = Rand::new(41);
    let mut checked = 0;
    // One quad alone (the root's only lane is the pair), and a facade of 1,600.
    for side in [1, 40] {
        let lights = facade(&mut rng, side);
        let (bvh, order) = LightBvh::build(&lights);
        let pairs: Vec<u32> = bvh
            .nodes
            .iter()
            .flat_map(|node| {
                (0..LANES)
                    .filter(move |&k| node.pairs >> k & 1 != 0)
                    .map(move |k| node.first[k])
            })
            .collect();
        // Every quad is a pair, of its own two triangles.
        assert_eq!(pairs.len(), lights.len() / 2);
        for &first in &pairs {
            let (a, b) = (order[first as usize], order[first as usize + 1]);
            assert_eq!(a / 2, b / 2, "lights {a} and {b} are not one quad's");
        }
        for _ in 0..40 {
            let across = rng.point(-12.0, 12.0) * Vec3::new(1.0, 1.0, 0.0);
            let p = across + Vec3::Z * rng.range(0.05, 4.0);
            let n = (rng.unit() - Vec3::Z * 1.5).normalize();
            check_frequencies(&bvh, p, n, 20_000, &mut rng);
            for &first in &pairs {
                let (first, second) = (first as usize, first as usize + 1);
                let (p_first, p_second) = (bvh.pmf(p, n, first), bvh.pmf(p, n, second));
                if p_first > 0.0 {
                    let phi = |id: usize| f64::from(lights[order[id] as usize].phi);
                    let ratio = p_second / p_first / (phi(second) / phi(first));
                    assert!((ratio - 1.0).abs() < 1e-12, "pair {first}: {ratio}");
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 10_000, "{checked}");
}

#[test]
fn lights_apart_keep_lanes_of_their_own() {
    // Two copies of one triangle 10 m apart: no pair, so a receiver right under one of them
    // gives it nearly all the probability.
    let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let lights = [0.0, 10.0].map(|x| {
        Emitter::Triangle {
            v: v.map(|p| p + Vec3::X * x),
            two_sided: false,
        }
        .bounds(1.0)
    });
    let (bvh, order) = LightBvh::build(&lights);
    assert!(bvh.nodes.iter().all(|node| node.pairs == 0));
    let near = order
        .iter()
        .position(|&o| o == 0)
        .expect("light 0 is in the tree");
    let pmf = bvh.pmf(Vec3::new(0.3, 0.3, 0.5), -Vec3::Z, near);
    assert!(pmf > 0.95, "{pmf}");
}
