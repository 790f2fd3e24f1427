//! Ray queries over the scene's triangles with obvhs's compressed 8-wide BVH (CWBVH):
//! closest hit for camera and hemisphere rays, any hit for shadow rays.

use glam::Vec3;
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, CwBvh};
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle as BvhTriangle;
use obvhs::BvhBuildParams;

use crate::scene::Scene;

/// A ray–triangle intersection: the scene triangle, the distance, and the barycentric weights
/// (b1, b2) of its vertices 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub triangle: u32,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

pub struct Accel {
    bvh: CwBvh,
    /// Triangles in BVH leaf order, so that a leaf's primitive id indexes them directly.
    triangles: Vec<BvhTriangle>,
}

impl Accel {
    pub fn build(scene: &Scene) -> Accel {
        let tris: Vec<BvhTriangle> = scene
            .triangles
            .iter()
            .map(|t| BvhTriangle {
                v0: t.positions[0].into(),
                v1: t.positions[1].into(),
                v2: t.positions[2].into(),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        Accel { bvh, triangles }
    }

    /// Bytes held by the BVH nodes, index map and reordered triangles.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.bvh.nodes.as_slice())
            + std::mem::size_of_val(self.bvh.primitive_indices.as_slice())
            + std::mem::size_of_val(self.triangles.as_slice())
    }

    /// The nearest intersection with t in [0, tmax) along a unit direction.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let ray = guarded_ray(origin, dir, tmax);
        let mut hit = RayHit::none();
        if !self
            .bvh
            .ray_traverse(ray, &mut hit, |r, id| self.triangles[id].intersect(r))
        {
            return None;
        }
        let id = hit.primitive_id as usize;
        let (b1, b2) = barycentrics(&self.triangles[id], origin, dir);
        let t = hit.t - NODE_CULL_GUARD;
        Some(Hit {
            triangle: self.bvh.primitive_indices[id],
            t,
            b1,
            b2,
        })
    }

    /// Whether the segment from surface point `a` (unit normal `na` on the segment's side) to
    /// surface point `b` (unit normal `nb` on the segment's side) is blocked. Both ends are moved
    /// off their surfaces, so neither the receiver nor the emitter occludes itself.
    #[inline]
    pub fn segment_occluded(&self, a: Vec3, na: Vec3, b: Vec3, nb: Vec3) -> bool {
        let from = offset_ray_origin(a, na);
        let to = offset_ray_origin(b, nb);
        let d = to - from;
        let len = d.length();
        len > 0.0 && self.occluded(from, d / len, len)
    }

    /// Whether anything lies on the segment origin + t·dir, t ∈ [0, tmax).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let ray = guarded_ray(origin, dir, tmax);
        !self
            .bvh
            .ray_traverse_miss(ray, |r, id| self.triangles[id].intersect(r))
    }
}

/// obvhs's node test clamps a child box's entry distance to a fixed 1e-4 (ignoring
/// `ray.tmin`), so a box the ray leaves within 1e-4 of its origin is culled: a wall 5e-5 m
/// from a shading point near a corner would not block its shadow rays. Every ray therefore
/// starts this far behind its true origin, with the triangle test's tmin set to the same
/// distance, so nothing before the true origin is hit and nothing after it is culled.
const NODE_CULL_GUARD: f32 = 1e-3;

/// The obvhs ray for the segment origin + t·dir, t ∈ [0, tmax), shifted back by the guard.
///
/// Direction components of −0.0 become +0.0: obvhs picks a child order from `dir < 0.0` (false
/// for −0.0) but inverts −0.0 to a large negative number, and the two disagree, so an
/// axis-aligned ray such as −Z would miss every box.
#[inline]
fn guarded_ray(origin: Vec3, dir: Vec3, tmax: f32) -> Ray {
    let dir = dir + Vec3::ZERO;
    let start = origin - NODE_CULL_GUARD * dir;
    Ray::new(
        start.into(),
        dir.into(),
        NODE_CULL_GUARD,
        tmax + NODE_CULL_GUARD,
    )
}

/// Barycentric weights (b1, b2) of vertices 1 and 2 where the line origin + t·dir meets the
/// triangle's plane (Möller–Trumbore with the unnormalised normal; obvhs's
/// `compute_barycentric` divides by the normalised one, which scales the result by 2·area).
#[inline]
fn barycentrics(tri: &BvhTriangle, origin: Vec3, dir: Vec3) -> (f32, f32) {
    let (v0, v1, v2) = (Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2));
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let q = dir.cross(e2);
    let inv_det = 1.0 / e1.dot(q);
    let s = origin - v0;
    let b1 = s.dot(q) * inv_det;
    let b2 = dir.dot(s.cross(e1)) * inv_det;
    (b1, b2)
}

/// Moves a ray origin on a surface off it along the unit normal `n` (toward the side the ray
/// leaves from), by a few ULPs of the position's magnitude, so the ray cannot hit the surface it
/// starts on (Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
/// Ray Tracing Gems, 2019): 256 ULPs per component, and for components below 1/32 (where ULPs
/// vanish) a fixed-point step of 2^-16 · s, with s = 32·max|p_i| clamped to [2^-10, 1]. Their s = 1
/// (an absolute 1.5e-5 m) is a sixth of a 1e-4 m scene and lets rays start behind nearby walls;
/// s scales it with the point's own magnitude, down to 1.5e-8 m, still 128 ULPs of the 1e-3 m
/// guard (`NODE_CULL_GUARD`) the ray is started behind. Works for 1e-4 m and 1e6 m scenes alike.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const MIN_SCALE: f32 = 1.0 / 1024.0;
    const INT_SCALE: f32 = 256.0;
    let offset_int = (INT_SCALE * n).as_ivec3();
    let nudge = |x: f32, o: i32| {
        let o = if x < 0.0 { -o } else { o };
        f32::from_bits((x.to_bits() as i32).wrapping_add(o) as u32)
    };
    let p_int = Vec3::new(
        nudge(p.x, offset_int.x),
        nudge(p.y, offset_int.y),
        nudge(p.z, offset_int.z),
    );
    let step = FLOAT_SCALE * (p.abs().max_element() / ORIGIN).clamp(MIN_SCALE, 1.0);
    let pick = |x: f32, xi: f32, nx: f32| {
        if x.abs() < ORIGIN {
            x + step * nx
        } else {
            xi
        }
    };
    Vec3::new(
        pick(p.x, p_int.x, n.x),
        pick(p.y, p_int.y, n.y),
        pick(p.z, p_int.z, n.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Triangle};

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
}
