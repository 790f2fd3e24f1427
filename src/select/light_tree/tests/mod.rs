//! Unit tests of the light tree: bounds and coding never shrink, pmf equals the
//! sampling frequency, every reachable light keeps pmf > 0, build invariants.

use super::*;
use glam::{DVec3, Vec3};
use rand_core::Rng as _;
use rand_pcg::Pcg32;

/// Seeded random numbers for the tests.
pub(super) struct Rand(Pcg32);

impl Rand {
    pub(super) fn new(seed: u64) -> Rand {
        Rand(Pcg32::new(seed, 0xda3e_39cb_94b9_5bdb))
    }
    pub(super) fn f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 / 16_777_216.0
    }
    pub(super) fn f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / 9_007_199_254_740_992.0
    }
    pub(super) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    /// −1 or 1.
    pub(super) fn sign(&mut self) -> f64 {
        if self.0.next_u32() & 1 == 0 {
            -1.0
        } else {
            1.0
        }
    }
    pub(super) fn below(&mut self, n: usize) -> usize {
        ((self.f64() * n as f64) as usize).min(n - 1)
    }
    pub(super) fn point(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    pub(super) fn unit(&mut self) -> Vec3 {
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
    pub(super) fn bounds(&self, power: f32) -> LightBounds {
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
    pub(super) fn point_at(&self, a: f32, b: f32) -> Vec3 {
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
    pub(super) fn contributes(&self, p: Vec3, n: Vec3, rng: &mut Rand) -> bool {
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

pub(super) struct Scene {
    emitters: Vec<Emitter>,
    bounds: Vec<LightBounds>,
}

/// Triangles in [−1, 1]³ with sizes over three decades, random
/// orientations, a quarter two-sided, one in ten a point light, powers
/// over six decades.
pub(super) fn random_scene(rng: &mut Rand, count: usize) -> Scene {
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

/// A random glossy lobe at a receiver with normal `n`: the mirror direction of a random `wo`
/// above it, sharpness over five decades and gain over six.
pub(super) fn random_lobe(rng: &mut Rand, n: Vec3) -> Lobe {
    let wo = (rng.unit() + n).normalize_or(n);
    Lobe {
        r: 2.0 * n.dot(wo) * n - wo,
        sharpness: 10f32.powf(rng.range(-1.0, 4.0)),
        gain: 10f32.powf(rng.range(-2.0, 4.0)),
    }
}

/// Receivers (p, n): random; 1e-6 from an emitter; on an emitter's
/// plane; grazing an emitter point; at an emitter's box centre; with no
/// normal.
pub(super) fn receivers(rng: &mut Rand, scene: &Scene, count: usize) -> Vec<(Vec3, Vec3)> {
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
pub(super) fn importance(b: &LightBounds, p: Vec3, n: Vec3) -> f32 {
    let (bvh, _) = LightBvh::build(&[*b]);
    bvh.nodes.first().map_or(0.0, |root| {
        importances(root, p, n, &Lobe::NONE, None, DEFAULT_FAR_SIN).importance[0]
    })
}

/// Interior lanes: (lane, child node index) of wide node `i`.
pub(super) fn interior_lanes(
    bvh: &LightBvh,
    i: usize,
) -> impl Iterator<Item = (usize, usize)> + '_ {
    let node = &bvh.nodes[i];
    (0..LANES)
        .filter(|&k| node.first[k] != EMPTY_LANE && node.child(k) & LIGHT_LANE == 0)
        .map(|k| (k, node.child(k) as usize))
}

/// Number of wide nodes on the longest root-to-leaf path.
pub(super) fn max_depth(bvh: &LightBvh) -> usize {
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
pub(super) fn dead_end_mass(bvh: &LightBvh, p: Vec3, n: Vec3, lobe: Lobe) -> f64 {
    let mut mass = 0.0;
    let mut stack = vec![(0usize, 1.0f64)];
    while let Some((i, weight)) = stack.pop() {
        match bvh.importances(i, p, n, lobe) {
            None => mass += weight,
            // A far lane is not descended: it chooses among all its lights ([`PowerPrefix`]).
            Some(lanes) => stack.extend(
                interior_lanes(bvh, i)
                    .filter(|&(k, _)| lanes.lanes[k] > 0.0)
                    .filter(|&(k, _)| bvh.prefix.is_none() || lanes.far & (1 << k) == 0)
                    .map(|(k, child)| (child, weight * lanes.lanes[k] / lanes.total())),
            ),
        }
    }
    mass
}

/// Checks, at (p, n), with `m` stratified samples: returned pmf == `pmf`
/// bit for bit; hit frequency matches pmf for well-sampled lights; Σ pmf
/// plus the dead-end mass is 1. Returns the dead-end mass.
pub(super) fn check_frequencies(bvh: &LightBvh, p: Vec3, n: Vec3, m: usize, rng: &mut Rand) -> f64 {
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
    let dead = dead_end_mass(bvh, p, n, Lobe::NONE);
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

mod bounds;
mod collapse;
mod far;
mod lobe;
mod near_field;
mod pairs;
mod sampling;
mod thresholds;
