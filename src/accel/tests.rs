//! Tests of `Accel`: hits against an exhaustive search on both code paths, the AVX2 node test
//! against obvhs's, packets against single rays, and origin offsets at every scale; the
//! random-soup fixtures are shared with `build`'s tests.

use super::*;
use crate::scene::{Material, Triangle};
use glam::Vec3A;

fn quad_scene(z: f32) -> Scene {
    let p = [
        Vec3::new(-1.0, -1.0, z),
        Vec3::new(1.0, -1.0, z),
        Vec3::new(1.0, 1.0, z),
    ];
    let q = [p[0], p[2], Vec3::new(-1.0, 1.0, z)];
    let tris = vec![Triangle::flat(p, 0), Triangle::flat(q, 0)];
    Scene::new(tris, vec![Material::default()], None).unwrap()
}

#[test]
fn barycentrics_reconstruct_the_hit_point() {
    let scene = quad_scene(-2.0);
    let accel = Accel::build(&scene);
    let origin = Vec3::new(0.3, -0.4, 1.0);
    let dir = Vec3::new(0.1, 0.2, -1.0).normalize();
    let hit = accel
        .closest_hit(origin, dir, f32::INFINITY)
        .expect("hits the quad");
    let [p0, p1, p2] = scene.triangles[hit.triangle as usize].positions;
    let from_bary = p0 + hit.b1 * (p1 - p0) + hit.b2 * (p2 - p0);
    assert!((from_bary - (origin + hit.t * dir)).length() < 1e-5);
    assert!(accel.closest_hit(origin, -dir, f32::INFINITY).is_none());
    assert!(accel.occluded(origin, dir, 10.0));
    assert!(!accel.occluded(origin, dir, hit.t * 0.99));
}

/// The occluders a thread remembers (`occluders`) never change an answer, on both code paths:
/// segments from a few origins toward random targets give the walk's answer, and so does each
/// blocked one asked again short of its nearest hit, where the occluder just remembered lies
/// beyond its end (nothing blocks it).
#[test]
fn remembered_occluders_give_the_walks_answers() {
    let mut u = uniforms(5);
    let scene = triangle_soup(&mut u, 400, 1.0);
    let mut accel = Accel::build(&scene);
    for avx2 in [false, has_simd_walk()] {
        accel.avx2 = avx2;
        let mut blocked = 0;
        for _ in 0..20 {
            let origin = Vec3::new(u(), u(), u()) * 12.0 - Vec3::ONE;
            for _ in 0..50 {
                let target = Vec3::new(u(), u(), u()) * 12.0 - Vec3::ONE;
                let (dir, length) = ((target - origin).normalize(), (target - origin).length());
                let full = accel.occluded(origin, dir, length);
                assert_eq!(full, accel.occluded_by_walk(origin, dir, length));
                if full {
                    blocked += 1;
                    let nearest = accel.closest_hit(origin, dir, length).expect("blocked");
                    let short = 0.5 * nearest.t;
                    assert!(
                        !accel.occluded(origin, dir, short),
                        "{origin} {dir} {short}"
                    );
                    assert!(!accel.occluded_by_walk(origin, dir, short));
                }
            }
        }
        assert!(blocked > 100, "only {blocked} of 1000 segments blocked");
    }
}

/// A thread that remembers an occluder of one tree does not answer another tree's query with
/// it: the wall 3 m below the origin blocks a 4 m segment in its own scene only.
#[test]
fn another_tree_is_not_answered_with_remembered_occluders() {
    let mut wall = Accel::build(&quad_scene(-2.0));
    let mut beyond = Accel::build(&quad_scene(-5.0));
    let origin = Vec3::new(0.3, -0.4, 1.0);
    for avx2 in [false, has_simd_walk()] {
        (wall.avx2, beyond.avx2) = (avx2, avx2);
        assert!(wall.occluded(origin, -Vec3::Z, 4.0));
        assert!(!beyond.occluded(origin, -Vec3::Z, 4.0));
        assert!(beyond.occluded(origin, -Vec3::Z, 7.0));
        assert!(wall.occluded(origin, -Vec3::Z, 4.0));
    }
}

/// Closest hit of origin + t·dir over every triangle, computed in f64 by intersecting the
/// plane and taking barycentrics from sub-triangle areas: (triangle, t, b1, b2).
fn brute_force(scene: &Scene, origin: Vec3, dir: Vec3) -> Option<(u32, f64, f64, f64)> {
    let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
    let mut best: Option<(u32, f64, f64, f64)> = None;
    for (i, tri) in scene.triangles.iter().enumerate() {
        let [p0, p1, p2] = tri.positions.map(|p| p.as_dvec3());
        let n = (p1 - p0).cross(p2 - p0);
        let t = n.dot(p0 - o) / n.dot(d);
        if t.is_nan() || t <= 0.0 || best.is_some_and(|b| b.1 <= t) {
            continue;
        }
        let x = o + t * d;
        let area = |a: glam::DVec3, b: glam::DVec3, c: glam::DVec3| (b - a).cross(c - a).dot(n);
        let (b1, b2) = (area(p0, x, p2) / n.dot(n), area(p0, p1, x) / n.dot(n));
        if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
            best = Some((i as u32, t, b1, b2));
        }
    }
    best
}

pub(super) fn tris_centre(scene: &Scene, i: usize) -> Vec3 {
    let [a, b, c] = scene.triangles[i.min(scene.triangles.len() - 1)].positions;
    (a + b + c) / 3.0
}

/// Uniform numbers in [0, 1) from a fixed seed.
pub(super) fn uniforms(seed: u64) -> impl FnMut() -> f32 {
    use rand_core::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    move || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

/// `count` random triangles of about `size` m, centred in the cube [0, 10]³.
pub(super) fn triangle_soup(u: &mut impl FnMut() -> f32, count: usize, size: f32) -> Scene {
    let tris = (0..count)
        .map(|_| {
            let c = Vec3::new(u(), u(), u()) * 10.0;
            let p = [0, 1, 2].map(|_| c + (Vec3::new(u(), u(), u()) - Vec3::splat(0.5)) * size);
            Triangle::flat(p, 0)
        })
        .collect();
    Scene::new(tris, vec![Material::default()], None).unwrap()
}

#[test]
fn closest_hits_match_an_exhaustive_search_on_both_code_paths() {
    let mut u = uniforms(11);
    let scene = triangle_soup(&mut u, 400, 1.0);
    let mut accel = Accel::build(&scene);
    let (mut hits, mut compared) = (0, 0);
    for _ in 0..2000 {
        let origin = Vec3::new(u(), u(), u()) * 12.0 - Vec3::ONE;
        let target = tris_centre(&scene, (u() * 400.0) as usize);
        let dir = (target - origin).normalize();
        let expected = brute_force(&scene, origin, dir);
        accel.avx2 = false;
        let obvhs_walk = accel.closest_hit(origin, dir, f32::INFINITY);
        for avx2 in [false, has_simd_walk()] {
            accel.avx2 = avx2;
            let got = accel.closest_hit(origin, dir, f32::INFINITY);
            // The two walks find the same triangle with the same (t, b1, b2).
            assert_eq!(got, obvhs_walk);
            compared += 1;
            match (got, expected) {
                (None, None) => {}
                (Some(h), Some((i, t, b1, b2))) => {
                    hits += 1;
                    // A ray through a shared point may report either triangle: then the
                    // distances agree.
                    assert!((h.t as f64 - t).abs() < 1e-4 * (1.0 + t), "{h:?} vs t {t}");
                    if h.triangle == i {
                        // Compared as points, with a tolerance growing as 1/cos θ: along a
                        // grazing ray a rounding of the origin moves the hit that much.
                        let [p0, p1, p2] = scene.triangles[i as usize].positions;
                        let at = |w1: f64, w2: f64| {
                            p0.as_dvec3() + w1 * (p1 - p0).as_dvec3() + w2 * (p2 - p0).as_dvec3()
                        };
                        let miss = (at(h.b1 as f64, h.b2 as f64) - at(b1, b2)).length();
                        let cos = scene.triangles[i as usize]
                            .geometric_normal()
                            .dot(dir)
                            .abs() as f64;
                        let tol = 1e-5 * (1.0 + t) / cos;
                        assert!(miss < tol, "{h:?} vs b {b1} {b2}, cos {cos}");
                    }
                }
                // Only a ray grazing an edge may disagree; none of these does.
                (got, expected) => panic!("{origin} {dir}: {got:?} vs {expected:?}"),
            }
            assert_eq!(
                accel.occluded(origin, dir, f32::INFINITY),
                expected.is_some()
            );
        }
    }
    assert!(hits > compared / 2, "only {hits} hits of {compared}");
}

/// The AVX2 node test gives obvhs's own hit mask, for one ray and for the rays of a packet
/// OR-ed, on every node of a BVH, rays in random and axis-aligned directions — except for a
/// child the ray grazes: one that the roundings of a plane distance (of the plane to f32, the
/// difference and the product here; two in obvhs) can put on either side, which `grazes`
/// checks in f64.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx2_node_test_gives_obvhs_masks_but_for_grazed_children() {
    if !has_avx2_fma() {
        return;
    }
    let mut u = uniforms(9);
    let scene = triangle_soup(&mut u, 2000, 0.8);
    let accel = Accel::build(&scene);
    let (mut compared, mut nonzero, mut grazed) = (0, 0, 0);
    for (node, walk_node) in accel.bvh.nodes.iter().zip(&accel.walk_nodes) {
        let planes = &walk_node.planes;
        // Rays toward a random point of the node's box (most hit some child), every third
        // along an axis instead (0 · ∞ in the slab test), with random lengths.
        let extent = Vec3::from(node.compute_extent()) * 255.0;
        let rays: Vec<Ray> = (0..PACKET)
            .map(|k| {
                let origin = Vec3::new(u(), u(), u()) * 12.0 - Vec3::ONE;
                let target = node.p + extent * Vec3::new(u(), u(), u());
                let dir = if k % 3 == 0 {
                    let axis = (u() * 3.0) as usize % 3;
                    Vec3::AXES[axis] * (target - origin)[axis].signum()
                } else {
                    (target - origin).normalize_or(Vec3::X)
                };
                guarded_ray(origin, dir, 40.0 * u())
            })
            .collect();
        let oct_inv4 = accel.bvh.new_traversal(rays[0].direction).oct_inv4;
        let (mut expected_or, mut grazed_here) = (0, 0);
        // SAFETY: the CPU reported AVX2 and FMA above.
        unsafe {
            let mut lanes = std::arch::x86_64::_mm256_setzero_ps();
            for ray in &rays {
                let expected = node.intersect_ray(ray, oct_inv4);
                let node_ray = node_avx2::NodeRay::new(ray);
                let (hit, _) = node_avx2::test_children(planes, &node_ray, ray.tmax);
                let got = node_avx2::traversal_mask(node, oct_inv4, hit);
                for child in 0..8 {
                    let lane = node_avx2::traversal_mask(node, oct_inv4, one_lane(child));
                    if got & lane != expected & lane {
                        assert!(
                            grazes(node, ray, child),
                            "child {child}: {got:b} vs {expected:b}"
                        );
                        grazed_here += 1;
                    }
                }
                expected_or |= expected;
                nonzero += (expected != 0) as usize;
                compared += 1;
                lanes = std::arch::x86_64::_mm256_or_ps(lanes, hit);
            }
            grazed += grazed_here;
            if grazed_here == 0 {
                assert_eq!(
                    node_avx2::traversal_mask(node, oct_inv4, lanes),
                    expected_or
                );
            }
        }
    }
    assert!(
        nonzero > compared / 6,
        "{nonzero} of {compared} rays hit a child"
    );
    assert!(
        grazed * 1000 < compared,
        "{grazed} grazed children in {compared} rays"
    );
}

/// The packet's interval node test (`node_avx2::test_packet`, every child taken as an inner one)
/// keeps every child any of its rays hits (`node_avx2::test_children`, the single-ray test), at
/// an entry no farther than that ray's, and keeps as leaves exactly the children some ray hits:
/// random packets of 2..=8 rays from one origin or from origins spread over 1 mm or 1 m,
/// with random tmax, against random child boxes (some flat, some 1 mm wide); a third of the
/// packets aim at one corner of a box within 1e-6 (grazing it), a fifth run nearly along an
/// axis (other components of 1e-7 or exactly 0). The mixed-sign packets among those take the
/// ray-by-ray fallback (`NodePacket::new` is `None`).
#[cfg(target_arch = "x86_64")]
#[test]
fn the_packet_node_test_keeps_every_child_a_ray_hits() {
    use std::arch::x86_64::{_mm256_loadu_ps, _mm256_movemask_ps, _mm256_storeu_ps};
    if !has_avx2_fma() {
        return;
    }
    let mut u = uniforms(21);
    let mut rand3 = move || Vec3::new(u(), u(), u());
    let (mut tested, mut fallbacks, mut kept, mut extra, mut straddled) = (0, 0, 0, 0, 0);
    for trial in 0..30_000 {
        let mut planes = planes::ChildPlanes([[0.0; 8]; 6]);
        let mut corners = [Vec3::ZERO; 8];
        for (child, corner) in corners.iter_mut().enumerate() {
            let lo = rand3() * 10.0 - Vec3::splat(5.0);
            let size = match child % 4 {
                0 => rand3() * Vec3::new(3.0, 3.0, 0.0),
                1 => rand3() * 1e-3,
                _ => rand3() * 3.0,
            };
            let hi = lo + size;
            let pick = rand3();
            for axis in 0..3 {
                planes.0[2 * axis][child] = lo[axis];
                planes.0[2 * axis + 1][child] = hi[axis];
                corner[axis] = if pick[axis] < 0.5 { lo[axis] } else { hi[axis] };
            }
        }
        let origin = rand3() * 30.0 - Vec3::splat(15.0);
        let spread = [0.0, 1e-3, 1.0][trial % 3];
        let aim = rand3();
        let (target, width) = if trial % 3 == 0 {
            (corners[(aim.x * 8.0) as usize % 8], 1e-6)
        } else {
            (rand3() * 10.0 - Vec3::splat(5.0), 0.3 * aim.y)
        };
        let along = (trial % 5 == 0).then_some((aim.z * 3.0) as usize % 3);
        let size = 2 + trial % 7;
        let rays: Vec<Ray> = (0..size)
            .map(|_| {
                let o = origin + spread * (rand3() - Vec3::splat(0.5));
                let mut dir = target + width * (rand3() - Vec3::splat(0.5)) - o;
                if let Some(axis) = along {
                    let main = dir[axis];
                    let tiny = rand3();
                    dir =
                        (tiny - Vec3::splat(0.5)) * 2e-7 * main.abs() * (tiny.x < 0.8) as u8 as f32;
                    dir[axis] = main;
                }
                let tmax = if aim.y < 0.5 {
                    f32::INFINITY
                } else {
                    40.0 * rand3().x
                };
                guarded_ray(o, dir.normalize_or(Vec3::X), tmax)
            })
            .collect();
        // The rays in lanes, spare lanes repeating the first (as `closest_hits_avx2` has them).
        let lane = |f: &dyn Fn(&Ray) -> f32| {
            let mut v = [f(&rays[0]); PACKET];
            for (x, ray) in v.iter_mut().zip(&rays) {
                *x = f(ray);
            }
            // SAFETY: the CPU reported AVX2 and FMA above.
            unsafe { _mm256_loadu_ps(v.as_ptr()) }
        };
        let axes = |f: fn(&Ray) -> Vec3A| [0, 1, 2].map(|axis| lane(&|ray| f(ray)[axis]));
        let (origin, direction) = (axes(|ray| ray.origin), axes(|ray| ray.direction));
        let inverse = axes(|ray| ray.inv_direction);
        // SAFETY: as above.
        let Some(bounds) = (unsafe { node_avx2::NodePacket::new(origin, direction, inverse) })
        else {
            fallbacks += 1;
            continue;
        };
        tested += 1;
        let tmax = lane(&|ray| ray.tmax);
        let reach = rays.iter().fold(0.0f32, |m, r| m.max(r.tmax));
        let lanes = |(hit, entry)| {
            let mut t = [0.0f32; 8];
            // SAFETY: as above.
            unsafe { _mm256_storeu_ps(t.as_mut_ptr(), entry) };
            (unsafe { _mm256_movemask_ps(hit) }, t)
        };
        // Every child taken as an inner one (the interval test alone), then as a leaf.
        let (packet_hits, packet_entry) =
            lanes(unsafe { node_avx2::test_packet(&planes, &bounds, tmax, reach, 0xff) });
        let (leaf_hits, _) =
            lanes(unsafe { node_avx2::test_packet(&planes, &bounds, tmax, reach, 0) });
        let (mut any, mut all) = (0, 0xff);
        for ray in &rays {
            let node_ray = node_avx2::NodeRay::new(ray);
            let (hits, entry) =
                lanes(unsafe { node_avx2::test_children(&planes, &node_ray, ray.tmax) });
            for child in (0..8).filter(|c| hits >> c & 1 == 1) {
                assert!(
                    packet_hits >> child & 1 == 1,
                    "trial {trial}: child {child} dropped, ray {ray:?}"
                );
                assert!(
                    packet_entry[child] <= entry[child],
                    "trial {trial}: child {child} entry {} beyond {}",
                    packet_entry[child],
                    entry[child]
                );
            }
            (any, all) = (any | hits, all & hits);
        }
        assert_eq!(leaf_hits, any, "trial {trial}: leaves");
        kept += (any as u32).count_ones();
        extra += (packet_hits & !any).count_ones();
        straddled += ((any & !all) as u32).count_ones();
    }
    assert!(
        tested > 15_000 && fallbacks > 3_000,
        "{tested} packets tested, {fallbacks} fell back"
    );
    assert!(
        kept > 5_000 && straddled > 3_000,
        "{kept} children hit, {straddled} hit by some rays only"
    );
    // The bounds are close: the children kept that no ray hits are fewer than half those hit.
    assert!(
        extra * 2 < kept,
        "{extra} children kept but not hit, {kept} hit"
    );
}

/// A hit mask with only lane `child` set.
#[cfg(target_arch = "x86_64")]
fn one_lane(child: usize) -> std::arch::x86_64::__m256 {
    let mut lanes = [0.0f32; 8];
    lanes[child] = f32::from_bits(u32::MAX);
    // SAFETY: an unaligned load of eight f32 (AVX, which the caller checked).
    unsafe { std::arch::x86_64::_mm256_loadu_ps(lanes.as_ptr()) }
}

/// Whether `ray` grazes child `child` of `node`: in f64, from the same f32 scale 2^e / d and
/// offset (p − o) / d per axis, its entry and exit distances (clamped as obvhs clamps them) lie
/// within the rounding error either f32 evaluation (obvhs's t = q·s + o', or the planes'
/// (x − o) · (1/d), whose |x − o| / |d| is at most |q·s| + |o'|) can make, 4 ulps of
/// |q·s| + |o'|.
#[cfg(target_arch = "x86_64")]
fn grazes(node: &CwBvhNode, ray: &Ray, child: usize) -> bool {
    let scale = node.compute_extent() * ray.inv_direction;
    let shift = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    let bounds = [
        (node.child_min_x[child], node.child_max_x[child]),
        (node.child_min_y[child], node.child_max_y[child]),
        (node.child_min_z[child], node.child_max_z[child]),
    ];
    let (mut entry, mut exit, mut error) = (1e-4f64, f64::from(ray.tmax), 0.0f64);
    for (axis, &(lo, hi)) in bounds.iter().enumerate() {
        let (s, o) = (f64::from(scale[axis]), f64::from(shift[axis]));
        let (a, b) = (f64::from(lo) * s + o, f64::from(hi) * s + o);
        entry = entry.max(a.min(b));
        exit = exit.min(a.max(b));
        error = error.max(f64::from(lo.max(hi)) * s.abs() + o.abs());
    }
    (entry - exit).abs() <= 4.0 * f64::from(f32::EPSILON) * error
}

/// Each node's f32 planes hold its children's boxes as obvhs's codes give them,
/// p + 2^e · q (exact in f64), rounded outward: a lower plane at or below it by less than one
/// f32 step, an upper one at or above it; on random soups at three scales.
#[cfg(target_arch = "x86_64")]
#[test]
fn child_planes_round_the_decoded_boxes_outward() {
    let mut u = uniforms(11);
    let (mut rounded, mut exact) = (0, 0);
    for size in [1e-3f32, 0.7, 3e4] {
        let scene = triangle_soup(&mut u, 1500, size);
        let accel = Accel::build(&scene);
        let nodes = &accel.bvh.nodes;
        for (node, walk_node) in nodes.iter().zip(planes::walk_nodes(nodes)) {
            let planes = walk_node.planes;
            let codes = [
                node.child_min_x,
                node.child_max_x,
                node.child_min_y,
                node.child_max_y,
                node.child_min_z,
                node.child_max_z,
            ];
            for (plane, (row, q)) in planes.0.iter().zip(codes).enumerate() {
                let axis = plane / 2;
                let step = f64::from(node.compute_extent()[axis]);
                for (&x, q) in row.iter().zip(q) {
                    let decoded = f64::from(node.p[axis]) + step * f64::from(q);
                    let x64 = f64::from(x);
                    let (inside, beyond) = if plane % 2 == 0 {
                        (x.next_up(), x64 <= decoded)
                    } else {
                        (x.next_down(), x64 >= decoded)
                    };
                    assert!(beyond, "plane {plane}: {x} vs {decoded}");
                    let within = (f64::from(inside) - decoded) * (x64 - decoded) <= 0.0;
                    assert!(within, "plane {plane}: {x} is more than one step out");
                    if x64 == decoded {
                        exact += 1;
                    } else {
                        rounded += 1;
                    }
                }
            }
        }
    }
    assert!(rounded > 0 && exact > 0, "{rounded} rounded, {exact} exact");
}

#[test]
fn packets_find_the_hits_of_single_rays() {
    let mut u = uniforms(5);
    let scene = triangle_soup(&mut u, 3000, 0.6);
    let accel = Accel::build(&scene);
    let mut hits = 0;
    for packet in 0..400 {
        // Half the packets are a pixel's rays (one origin, directions within 0.01 rad), half
        // scatter over the sphere from nearby origins; sizes 1..=PACKET.
        let size = 1 + packet % PACKET;
        let origin = Vec3::new(u(), u(), u()) * 12.0 - Vec3::ONE;
        let axis = (Vec3::splat(5.0) - origin).normalize();
        let rays: Vec<(Vec3, Vec3)> = (0..size)
            .map(|_| {
                let jitter = Vec3::new(u(), u(), u()) - Vec3::splat(0.5);
                if packet % 2 == 0 {
                    (origin, (axis + 0.02 * jitter).normalize())
                } else {
                    (origin + 0.1 * jitter, (jitter + 1e-3 * axis).normalize())
                }
            })
            .collect();
        let mut got = vec![None; size];
        accel.closest_hits(&rays, &mut got);
        for (&(o, d), got) in rays.iter().zip(&got) {
            let alone = accel.closest_hit(o, d, f32::INFINITY);
            assert_eq!(*got, alone, "packet {packet}: ray {o} {d}");
            hits += alone.is_some() as usize;
        }
    }
    assert!(hits > 400, "only {hits} hits");
}

#[test]
fn offset_origins_do_not_self_intersect_at_any_scale() {
    for scale in [1e-4f32, 1.0, 1e3, 1e6] {
        let scene = quad_scene(0.0);
        let tris = scene
            .triangles
            .iter()
            .map(|t| Triangle::flat(t.positions.map(|p| p * scale + Vec3::splat(scale)), 0))
            .collect();
        let scene = Scene::new(tris, vec![Material::default()], None).unwrap();
        let accel = Accel::build(&scene);
        let p = Vec3::new(0.37 * scale + scale, -0.21 * scale + scale, scale);
        let o = offset_ray_origin(p, Vec3::Z);
        assert!(o.z > p.z, "scale {scale}: origin moved off the plane");
        // Grazing directions leaving the surface must not hit it again.
        for dz in [1e-3f32, 1e-2, 0.5] {
            let d = Vec3::new(1.0, 0.3, dz).normalize();
            assert!(
                !accel.occluded(o, d, 10.0 * scale),
                "scale {scale}, dz {dz}"
            );
        }
        // And a ray going back through the surface does hit it (−Z has −0.0 components).
        assert!(accel.occluded(o, -Vec3::Z, scale), "scale {scale}: o {o}");
    }
}
