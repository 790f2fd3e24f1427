//! Unit tests of the light tree: bounds and coding never shrink, pmf equals the
//! sampling frequency, every reachable light keeps pmf > 0, build invariants.

use super::*;
use glam::{DVec3, Vec3};
use rand_core::Rng as _;
use rand_pcg::Pcg32;

/// Seeded random numbers for the tests.
struct Rand(Pcg32);

impl Rand {
    fn new(seed: u64) -> Rand {
        Rand(Pcg32::new(seed, 0xda3e_39cb_94b9_5bdb))
    }
    fn f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 / 16_777_216.0
    }
    fn f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / 9_007_199_254_740_992.0
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.f64() * n as f64) as usize).min(n - 1)
    }
    fn point(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn unit(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

#[derive(Clone, Copy, Debug)]
enum Emitter {
    Triangle { v: [Vec3; 3], two_sided: bool },
    Point(Vec3),
}

impl Emitter {
    fn bounds(&self, power: f32) -> LightBounds {
        match *self {
            Emitter::Triangle { v, two_sided } => {
                let normal = (v[1] - v[0]).as_dvec3().cross((v[2] - v[0]).as_dvec3());
                let sides = if two_sided { 2.0 } else { 1.0 };
                LightBounds {
                    lo: v[0].min(v[1]).min(v[2]),
                    hi: v[0].max(v[1]).max(v[2]),
                    phi: (0.5 * normal.length()) as f32 * power * std::f32::consts::PI * sides,
                    w: normal.normalize().as_vec3(),
                    cos_theta_o: 1.0,
                    cos_theta_e: 0.0,
                    two_sided,
                }
            }
            Emitter::Point(x) => LightBounds {
                lo: x,
                hi: x,
                phi: power * 4.0 * std::f32::consts::PI,
                w: Vec3::Z,
                cos_theta_o: -1.0,
                cos_theta_e: 0.0,
                two_sided: false,
            },
        }
    }

    /// A point of the emitter from two random numbers.
    fn point_at(&self, a: f32, b: f32) -> Vec3 {
        match *self {
            Emitter::Triangle { v, .. } => {
                let (a, b) = if a + b > 1.0 {
                    (1.0 - a, 1.0 - b)
                } else {
                    (a, b)
                };
                v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b
            }
            Emitter::Point(x) => x,
        }
    }

    /// Brute force, in f64: does some test point of the emitter lie strictly
    /// above p's tangent plane while p is on its emitting side?
    fn contributes(&self, p: Vec3, n: Vec3, rng: &mut Rand) -> bool {
        let (pd, nd) = (p.as_dvec3(), n.as_dvec3());
        let above = |x: DVec3| nd == DVec3::ZERO || (x - pd).dot(nd) > 0.0;
        match *self {
            Emitter::Point(x) => above(x.as_dvec3()),
            Emitter::Triangle { v, two_sided } => {
                let v = v.map(Vec3::as_dvec3);
                let side = (pd - v[0]).dot((v[1] - v[0]).cross(v[2] - v[0]));
                let emits = if two_sided { side != 0.0 } else { side > 0.0 };
                let mut points = vec![
                    v[0],
                    v[1],
                    v[2],
                    (v[0] + v[1]) * 0.5,
                    (v[1] + v[2]) * 0.5,
                    (v[2] + v[0]) * 0.5,
                    (v[0] + v[1] + v[2]) / 3.0,
                ];
                for _ in 0..64 {
                    let (a, b) = (rng.f64(), rng.f64());
                    let (a, b) = if a + b > 1.0 {
                        (1.0 - a, 1.0 - b)
                    } else {
                        (a, b)
                    };
                    points.push(v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b);
                }
                emits && points.into_iter().any(above)
            }
        }
    }
}

struct Scene {
    emitters: Vec<Emitter>,
    bounds: Vec<LightBounds>,
}

/// Triangles in [−1, 1]³ with sizes over three decades, random
/// orientations, a quarter two-sided, one in ten a point light, powers
/// over six decades.
fn random_scene(rng: &mut Rand, count: usize) -> Scene {
    let mut emitters = Vec::with_capacity(count);
    let mut bounds = Vec::with_capacity(count);
    while emitters.len() < count {
        let power = 10f32.powf(rng.range(-3.0, 3.0));
        let centre = rng.point(-1.0, 1.0);
        let emitter = if rng.f32() < 0.1 {
            Emitter::Point(centre)
        } else {
            let size = 10f32.powf(rng.range(-3.0, -0.5));
            let v = [0; 3].map(|_| centre + rng.point(-size, size));
            let normal = (v[1] - v[0]).as_dvec3().cross((v[2] - v[0]).as_dvec3());
            if normal.length() < 1e-12 {
                continue;
            }
            Emitter::Triangle {
                v,
                two_sided: rng.f32() < 0.25,
            }
        };
        bounds.push(emitter.bounds(power));
        emitters.push(emitter);
    }
    Scene { emitters, bounds }
}

/// Receivers (p, n): random; 1e-6 from an emitter; on an emitter's
/// plane; grazing an emitter point; at an emitter's box centre; with no
/// normal.
fn receivers(rng: &mut Rand, scene: &Scene, count: usize) -> Vec<(Vec3, Vec3)> {
    let mut out = Vec::with_capacity(count);
    for i in 0..count {
        let e = scene.emitters[rng.below(scene.emitters.len())];
        let on = e.point_at(rng.f32(), rng.f32());
        let n = rng.unit();
        let receiver = match i % 6 {
            0 => (rng.point(-1.5, 1.5), n),
            1 => (on + rng.unit() * 1e-6, n),
            2 => match e {
                Emitter::Triangle { v, .. } => {
                    let (a, b) = (rng.range(-1.0, 2.0), rng.range(-1.0, 2.0));
                    (v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b, n)
                }
                Emitter::Point(x) => (x + Vec3::X * 1e-6, n),
            },
            3 => {
                let p = rng.point(-1.5, 1.5);
                let to = (on - p).normalize_or_zero();
                let tangent = to.cross(rng.unit()).normalize_or_zero();
                let tilt = rng.range(-1e-4, 1e-4);
                (p, (tangent + to * tilt).normalize_or_zero())
            }
            4 => {
                let b = e.bounds(1.0);
                ((b.lo + b.hi) * 0.5, n)
            }
            _ => (rng.point(-1.5, 1.5), Vec3::ZERO),
        };
        out.push(receiver);
    }
    out
}

/// The importance of one light's bounds at (p, n), as the tree sees it: the
/// root lane of a tree holding only that light.
fn importance(b: &LightBounds, p: Vec3, n: Vec3) -> f32 {
    let (bvh, _) = LightBvh::build(&[*b]);
    bvh.nodes
        .first()
        .map_or(0.0, |root| importances(root, p, n)[0])
}

/// Interior lanes: (lane, child node index) of wide node `i`.
fn interior_lanes(bvh: &LightBvh, i: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
    let node = &bvh.nodes[i];
    (0..LANES)
        .filter(|&k| node.first[k] != EMPTY_LANE && node.child[k] & LIGHT_LANE == 0)
        .map(|k| (k, node.child[k] as usize))
}

/// Number of wide nodes on the longest root-to-leaf path.
fn max_depth(bvh: &LightBvh) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, depth)) = stack.pop() {
        if i >= bvh.nodes.len() {
            continue;
        }
        deepest = deepest.max(depth);
        stack.extend(interior_lanes(bvh, i).map(|(_, child)| (child, depth + 1)));
    }
    deepest
}

/// Probability that `sample` stops at a node whose lanes all have
/// importance 0 (it then returns `None`).
fn dead_end_mass(bvh: &LightBvh, p: Vec3, n: Vec3) -> f64 {
    let mut mass = 0.0;
    let mut stack = vec![(0usize, 1.0f64)];
    while let Some((i, weight)) = stack.pop() {
        match bvh.importances(i, p, n) {
            None => mass += weight,
            Some((importances, total)) => stack.extend(
                interior_lanes(bvh, i)
                    .filter(|&(k, _)| importances[k] > 0.0)
                    .map(|(k, child)| (child, weight * importances[k] / total)),
            ),
        }
    }
    mass
}

/// Checks, at (p, n), with `m` stratified samples: returned pmf == `pmf`
/// bit for bit; hit frequency matches pmf for well-sampled lights; Σ pmf
/// plus the dead-end mass is 1. Returns the dead-end mass.
fn check_frequencies(bvh: &LightBvh, p: Vec3, n: Vec3, m: usize, rng: &mut Rand) -> f64 {
    let mut weight = vec![0.0f64; bvh.len()];
    let mut misses = 0usize;
    for i in 0..m {
        let u = (i as f64 + rng.f64()) / m as f64;
        match bvh.sample(p, n, u) {
            Some((light, pmf)) => {
                assert!(light < bvh.len());
                assert_eq!(
                    pmf.to_bits(),
                    bvh.pmf(p, n, light).to_bits(),
                    "light {light}"
                );
                weight[light] += 1.0 / (pmf * m as f64);
            }
            None => misses += 1,
        }
    }
    let mut total = 0.0;
    for (light, w) in weight.iter().enumerate() {
        let pmf = bvh.pmf(p, n, light);
        total += pmf;
        if pmf * m as f64 >= 1000.0 {
            assert!(
                (0.98..=1.02).contains(w),
                "light {light}: Σ 1/(pmf·M) = {w}"
            );
        }
    }
    let dead = dead_end_mass(bvh, p, n);
    if bvh.can_reach(p, n) {
        assert!(
            (total + dead - 1.0).abs() < 1e-6,
            "Σ pmf {total} + dead ends {dead}"
        );
        if dead == 0.0 {
            assert!((total - 1.0).abs() < 1e-6, "Σ pmf {total}");
        }
        let miss_rate = misses as f64 / m as f64;
        assert!(
            (miss_rate - dead).abs() < 0.01,
            "misses {miss_rate} vs {dead}"
        );
    } else {
        assert_eq!((total, misses), (0.0, m));
    }
    dead
}

#[test]
fn nodes_are_32_and_384_bytes() {
    assert_eq!(std::mem::size_of::<Node>(), 32);
    assert_eq!(std::mem::size_of::<WideNode>(), 384);
}

#[test]
fn sampled_frequencies_match_pmf() {
    let mut rng = Rand::new(1);
    let (mut points, mut with_dead_ends, mut dead_mass) = (0, 0, 0.0f64);
    for &count in &[1, 2, 3, 100, 5000] {
        for seed in 0..3 {
            let mut scene_rng = Rand::new(100 * count as u64 + seed);
            let scene = random_scene(&mut scene_rng, count);
            let (bvh, order) = LightBvh::build(&scene.bounds);
            assert_eq!((bvh.len(), order.len()), (count, count));
            // Every light in one lane, every node but the root in one lane.
            let lanes = |leaf: bool| {
                let is = |node: &WideNode, k: usize| {
                    node.first[k] != EMPTY_LANE && (node.child[k] & LIGHT_LANE != 0) == leaf
                };
                bvh.nodes
                    .iter()
                    .map(|node| (0..LANES).filter(|&k| is(node, k)).count())
                    .sum::<usize>()
            };
            assert_eq!((lanes(true), lanes(false) + 1), (count, bvh.node_count()));
            for (p, n) in receivers(&mut rng, &scene, 6) {
                let dead = check_frequencies(&bvh, p, n, 10_000, &mut rng);
                points += 1;
                with_dead_ends += usize::from(dead > 0.0);
                dead_mass = dead_mass.max(dead);
            }
        }
    }
    println!(
        "{with_dead_ends} of {points} shading points can reach a node whose children all \
         have importance 0 (largest probability {dead_mass:.3})"
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
                    let lanes = importances(node, p, n);
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
        assert_eq!(importances(node, p, n), [0.0; LANES]);
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
            assert!((total + dead_end_mass(&bvh, p, n) - 1.0).abs() < 1e-6);
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
        if node.child[lane] & LIGHT_LANE != 0 {
            return depth;
        }
        (index, depth) = (node.child[lane] as usize, depth + 1);
    }
}

/// The importance bound written with angles (acos, asin) in f64, for
/// comparison with the lanes' (cos, sin) arithmetic; `None` near a threshold.
fn importance_with_angles(b: &LightBounds, radius: f32, p: Vec3, n: Vec3) -> Option<f64> {
    let centre = ((b.lo + b.hi) * 0.5).as_dvec3();
    let (p, n) = (p.as_dvec3(), n.as_dvec3());
    let (r, d) = (f64::from(radius), p.distance(centre));
    if (d - r).abs() < 1e-3 * r.max(1e-3) {
        return None;
    }
    let mut emitted = 1.0;
    let mut received = 1.0;
    if d > r {
        let theta_b = (r / d).asin();
        let theta_w = angle_between(b.w.as_dvec3(), p - centre);
        let theta_w = if b.two_sided {
            theta_w.min(std::f64::consts::PI - theta_w)
        } else {
            theta_w
        };
        let theta_o = f64::from(b.cos_theta_o).clamp(-1.0, 1.0).acos();
        let theta_e = f64::from(b.cos_theta_e).clamp(-1.0, 1.0).acos();
        let theta_p = (theta_w - theta_o).max(0.0) - theta_b;
        let theta_p = theta_p.max(0.0);
        if (theta_p - theta_e).abs() < 1e-3 {
            return None;
        }
        emitted = if theta_p < theta_e {
            theta_p.cos()
        } else {
            0.0
        };
        if n != DVec3::ZERO {
            let theta_r = (angle_between(n, centre - p) - theta_b).max(0.0);
            if (theta_r - std::f64::consts::FRAC_PI_2).abs() < 1e-3 {
                return None;
            }
            received = theta_r.cos().max(0.0);
        }
    }
    let d_sq = (d * d).max(r * r);
    Some(f64::from(b.phi) * emitted * received / d_sq)
}

#[test]
fn lane_importance_matches_the_bound_written_with_angles() {
    let mut rng = Rand::new(10);
    let scene = random_scene(&mut rng, 2000);
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let mut compared = 0;
    for (p, n) in receivers(&mut rng, &scene, 300) {
        for node in &bvh.nodes {
            let lanes = importances(node, p, n);
            for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
                let phi = node.signed_phi[k];
                let c = Vec3::new(node.centre[0][k], node.centre[1][k], node.centre[2][k]);
                let w = Vec3::new(node.axis[0][k], node.axis[1][k], node.axis[2][k]);
                let b = LightBounds {
                    lo: c,
                    hi: c,
                    phi: phi.abs(),
                    w,
                    cos_theta_o: node.cos_o[k],
                    cos_theta_e: node.cos_e[k],
                    two_sided: phi < 0.0,
                };
                let Some(expected) = importance_with_angles(&b, node.radius[k], p, n) else {
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
