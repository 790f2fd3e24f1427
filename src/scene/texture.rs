//! A texture: linear RGB texels (decoded from sRGB once, at load) filtered bilinearly, and the
//! exact mean of that filtered texture over a triangle's uv footprint.
//!
//! Texel (i, j) has its centre at uv ((i + ½)/W, (j + ½)/H), with v = 0 the image's first row
//! (glTF's convention). In texel-centre coordinates x = u·W − ½, y = v·H − ½ the bilinear
//! interpolant is, on each unit cell [i, i+1]×[j, j+1], the polynomial
//!     f(s, t) = t₀₀(1−s)(1−t) + t₁₀·s(1−t) + t₀₁(1−s)·t + t₁₁·s·t,   (s, t) = (x − i, y − j),
//! whose corner texels are wrapped by the sampler's mode. glTF's minification and magnification
//! filters are ignored: every lookup is bilinear on the full-resolution image (no mipmaps).
//!
//! A texture reference may carry KHR_texture_transform: the mesh's uv is mapped by the affine
//!     uv' = offset + R(θ)·(scale ⊙ uv),   R(θ) = [[cos θ, sin θ], [−sin θ, cos θ]]
//! before the lookup (θ turns the uvs counter-clockwise, i.e. the image clockwise, in glTF's
//! v-down image space). An affine map takes a triangle's uv footprint to a triangle, so the
//! footprint mean is the same integral over the mapped triangle.

use glam::{DVec2, DVec3, Vec2, Vec3};

/// glTF sampler wrap mode, for one texture axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    #[default]
    Repeat,
    ClampToEdge,
    MirroredRepeat,
}

impl Wrap {
    /// The texel index that integer index `i` reads on an axis of `n` texels.
    #[inline]
    fn texel_index(self, i: i64, n: i64) -> usize {
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        };
        k as usize
    }

    /// `u` moved by whole periods (or clamped) into a bounded range with the same lookup, so
    /// that `u · n` keeps its precision and fits an integer.
    #[inline]
    fn reduce(self, u: f32) -> f32 {
        match self {
            Wrap::Repeat => u - u.floor(),
            Wrap::ClampToEdge => u.clamp(0.0, 1.0),
            Wrap::MirroredRepeat => u - 2.0 * (0.5 * u).floor(),
        }
    }

    /// The shift, a whole number of periods, that moves `u_min` next to the origin (zero for
    /// clamping, whose lookups are not periodic).
    fn period_shift(self, u_min: f64) -> f64 {
        match self {
            Wrap::Repeat => u_min.floor(),
            Wrap::ClampToEdge => 0.0,
            Wrap::MirroredRepeat => 2.0 * (0.5 * u_min).floor(),
        }
    }
}

/// Footprints whose bounding box covers more texel cells than this are not integrated cell by
/// cell: their mean is taken as the image mean (exact for a footprint of whole periods of a
/// repeating texture, an approximation otherwise). The footprint mean only sets an emitter's
/// power for light selection (the estimator reads the texture at each point), so the
/// approximation costs efficiency, never correctness; the cap bounds the work per triangle (a
/// 13 kB fuzzed GLB whose 511 emissive triangles had large uv footprints took 0.60 s to load
/// with a cap of 2^24 cells).
const MAX_FOOTPRINT_CELLS: f64 = (1u64 << 18) as f64;

/// A footprint mean is never below this fraction of the brightest texel (per channel) whose
/// bilinear support meets the footprint, so that a triangle that can emit never gets zero power.
pub const FOOTPRINT_FLOOR: f64 = 1e-6;

/// KHR_texture_transform's affine map of texture coordinates: uv' = u·x_axis + v·y_axis + offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub x_axis: Vec2,
    pub y_axis: Vec2,
    pub offset: Vec2,
}

impl UvTransform {
    /// offset + R(rotation)·(scale ⊙ uv), glTF's translation × rotation × scale.
    pub fn from_offset_rotation_scale(offset: Vec2, rotation: f32, scale: Vec2) -> UvTransform {
        let (sin, cos) = rotation.sin_cos();
        UvTransform {
            x_axis: scale.x * Vec2::new(cos, -sin),
            y_axis: scale.y * Vec2::new(sin, cos),
            offset,
        }
    }

    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        uv.x * self.x_axis + uv.y * self.y_axis + self.offset
    }

    pub fn is_finite(&self) -> bool {
        self.x_axis.is_finite() && self.y_axis.is_finite() && self.offset.is_finite()
    }
}

/// An image of linear RGB texels with its sampler's wrap modes (u, v), and the transform its
/// material reference applies to mesh uvs (None: the identity).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at v = 0.
    pub texels: Vec<Vec3>,
    pub wrap: [Wrap; 2],
    pub transform: Option<UvTransform>,
}

/// A convex polygon of at most 7 vertices: a triangle clipped by four axis-aligned half-planes.
#[derive(Clone, Copy)]
struct Polygon {
    v: [DVec2; 8],
    n: usize,
}

impl Polygon {
    fn triangle(q: [DVec2; 3]) -> Polygon {
        let mut v = [DVec2::ZERO; 8];
        v[..3].copy_from_slice(&q);
        Polygon { v, n: 3 }
    }

    /// The part where `sign · (p[axis] − value) ≥ 0` (Sutherland–Hodgman, one plane).
    fn clip(&self, axis: usize, value: f64, sign: f64) -> Polygon {
        let mut out = Polygon {
            v: [DVec2::ZERO; 8],
            n: 0,
        };
        let dist = |p: DVec2| sign * (p[axis] - value);
        for k in 0..self.n {
            let (a, b) = (self.v[k], self.v[(k + 1) % self.n]);
            let (da, db) = (dist(a), dist(b));
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let mut p = a + (b - a) * (da / (da - db));
                p[axis] = value;
                out.push(p);
            }
        }
        out
    }

    fn push(&mut self, p: DVec2) {
        if self.n < self.v.len() {
            self.v[self.n] = p;
            self.n += 1;
        }
    }

    fn x_range(&self) -> (f64, f64) {
        self.v[..self.n]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.x), hi.max(p.x))
            })
    }

    /// ∫ of the four bilinear weights ((1−s)(1−t), s(1−t), (1−s)t, st) over the polygon, with
    /// (s, t) = p − origin: a triangle fan, each triangle by the edge-midpoint rule, which is
    /// exact for polynomials of degree 2.
    fn bilinear_weight_integrals(&self, origin: DVec2) -> [f64; 4] {
        let mut w = [0.0; 4];
        let a = self.v[0] - origin;
        for k in 1..self.n.saturating_sub(1) {
            let (b, c) = (self.v[k] - origin, self.v[k + 1] - origin);
            let area = 0.5 * (b - a).perp_dot(c - a);
            for m in [0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)] {
                let (s, t) = (m.x, m.y);
                let third = area / 3.0;
                w[0] += third * (1.0 - s) * (1.0 - t);
                w[1] += third * s * (1.0 - t);
                w[2] += third * (1.0 - s) * t;
                w[3] += third * s * t;
            }
        }
        w
    }
}

impl Texture {
    /// A texture of `width × height` texels (row-major); None when the count does not match or
    /// a dimension is zero.
    pub fn new(width: u32, height: u32, texels: Vec<Vec3>, wrap: [Wrap; 2]) -> Option<Texture> {
        let count = (width as usize).checked_mul(height as usize)?;
        (count > 0 && texels.len() == count).then_some(Texture {
            width,
            height,
            texels,
            wrap,
            transform: None,
        })
    }

    /// The same texture read through `transform` (None: the identity).
    pub fn with_transform(mut self, transform: Option<UvTransform>) -> Texture {
        self.transform = transform;
        self
    }

    /// The texture at a mesh texture coordinate: the transform, then the bilinear lookup.
    #[inline]
    pub fn at(&self, uv: Vec2) -> Vec3 {
        match &self.transform {
            None => self.sample_bilinear(uv),
            Some(t) => self.sample_bilinear(t.apply(uv)),
        }
    }

    /// The mean of [`Texture::at`] over a triangle whose vertices have mesh uvs `uv`: the
    /// filtered texture's mean over the transformed footprint.
    pub fn footprint_mean(&self, uv: [Vec2; 3]) -> Vec3 {
        match &self.transform {
            None => self.average_over_uv_triangle(uv),
            Some(t) => self.average_over_uv_triangle(uv.map(|p| t.apply(p))),
        }
    }

    /// The texel that integer texel coordinates (i, j) read under the wrap modes.
    #[inline]
    fn texel(&self, i: i64, j: i64) -> Vec3 {
        let x = self.wrap[0].texel_index(i, self.width as i64);
        let y = self.wrap[1].texel_index(j, self.height as i64);
        self.texels[y * self.width as usize + x]
    }

    /// The bilinearly filtered texture at `uv` (a non-finite coordinate reads as 0).
    #[inline]
    pub fn sample_bilinear(&self, uv: Vec2) -> Vec3 {
        let uv = Vec2::select(uv.is_finite_mask(), uv, Vec2::ZERO);
        let x = self.wrap[0].reduce(uv.x) * self.width as f32 - 0.5;
        let y = self.wrap[1].reduce(uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (s, t) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let top = self.texel(i, j) * (1.0 - s) + self.texel(i + 1, j) * s;
        let bottom = self.texel(i, j + 1) * (1.0 - s) + self.texel(i + 1, j + 1) * s;
        top * (1.0 - t) + bottom * t
    }

    /// Mean of the texels (f64 sum), and their per-channel maximum.
    pub fn mean_and_max(&self) -> (Vec3, Vec3) {
        let (sum, max) = self
            .texels
            .iter()
            .fold((DVec3::ZERO, Vec3::ZERO), |(s, m), t| {
                (s + t.as_dvec3(), m.max(*t))
            });
        ((sum / self.texels.len() as f64).as_vec3(), max)
    }

    /// The mean of the bilinearly filtered texture over the uv triangle, i.e. the mean of
    /// `sample_bilinear(uv(b))` over barycentrics b uniform on the triangle, floored per channel
    /// at [`FOOTPRINT_FLOOR`] × the brightest texel whose support the footprint reaches.
    ///
    /// Method: the triangle (in f64 texel-centre coordinates) is clipped against every cell of
    /// the interpolant it overlaps, and the bilinear polynomial integrated exactly over each
    /// piece; cells entirely inside the triangle take the mean of their four corners. The error
    /// is f64 rounding (relative ≈ 1e-12 for footprints of a few cells or more). A footprint of
    /// (nearly) zero uv area is averaged by 64×64 stratified barycentric points instead, and one
    /// spanning more than 2^18 cells takes the image mean.
    pub fn average_over_uv_triangle(&self, uv: [Vec2; 3]) -> Vec3 {
        if uv.iter().any(|p| !p.is_finite()) {
            return self.sample_bilinear(Vec2::ZERO);
        }
        let size = DVec2::new(self.width as f64, self.height as f64);
        let lo = uv[0].min(uv[1]).min(uv[2]).as_dvec2();
        let shift = DVec2::new(
            self.wrap[0].period_shift(lo.x),
            self.wrap[1].period_shift(lo.y),
        );
        let q = uv.map(|p| (p.as_dvec2() - shift) * size - 0.5);
        let (lo, hi) = (q[0].min(q[1]).min(q[2]), q[0].max(q[1]).max(q[2]));
        let cells = (hi.x.floor() - lo.x.floor() + 2.0) * (hi.y.floor() - lo.y.floor() + 2.0);
        if cells > MAX_FOOTPRINT_CELLS {
            return self.mean_and_max().0;
        }
        let twice_area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
        let longest = (q[1] - q[0])
            .length_squared()
            .max((q[2] - q[1]).length_squared())
            .max((q[0] - q[2]).length_squared());
        let (mean, max) = if twice_area.abs() > 1e-9 * longest && twice_area.abs() > 1e-12 {
            let q = if twice_area < 0.0 {
                [q[0], q[2], q[1]]
            } else {
                q
            };
            let (integral, max) = self.integrate_triangle(q);
            (integral / (0.5 * twice_area.abs()), max)
        } else {
            (self.stratified_mean(uv), self.max_in_box(lo, hi))
        };
        mean.max(max * FOOTPRINT_FLOOR).as_vec3()
    }

    /// ∫ of the interpolant over a counter-clockwise triangle in texel-centre coordinates
    /// (texel² units), and the per-channel maximum of the corner texels of every cell it meets.
    fn integrate_triangle(&self, q: [DVec2; 3]) -> (DVec3, DVec3) {
        let inside = |p: DVec2| (0..3).all(|k| (q[(k + 1) % 3] - q[k]).perp_dot(p - q[k]) >= 0.0);
        let y_lo = q[0].y.min(q[1].y).min(q[2].y).floor() as i64;
        let y_hi = q[0].y.max(q[1].y).max(q[2].y).ceil() as i64;
        let triangle = Polygon::triangle(q);
        let (mut integral, mut max) = (DVec3::ZERO, DVec3::ZERO);
        for j in y_lo..y_hi {
            let strip = triangle
                .clip(1, j as f64, 1.0)
                .clip(1, (j + 1) as f64, -1.0);
            if strip.n < 3 {
                continue;
            }
            let (x_lo, x_hi) = strip.x_range();
            for i in x_lo.floor() as i64..x_hi.ceil() as i64 {
                let corners = [
                    self.texel(i, j),
                    self.texel(i + 1, j),
                    self.texel(i, j + 1),
                    self.texel(i + 1, j + 1),
                ]
                .map(Vec3::as_dvec3);
                let origin = DVec2::new(i as f64, j as f64);
                let whole = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                    .iter()
                    .all(|&(dx, dy)| inside(origin + DVec2::new(dx, dy)));
                let weights = if whole {
                    [0.25; 4]
                } else {
                    let piece = strip.clip(0, i as f64, 1.0).clip(0, (i + 1) as f64, -1.0);
                    if piece.n < 3 {
                        continue;
                    }
                    piece.bilinear_weight_integrals(origin)
                };
                if weights.iter().sum::<f64>() <= 0.0 {
                    continue;
                }
                for (w, t) in weights.iter().zip(corners) {
                    integral += *w * t;
                    max = max.max(t);
                }
            }
        }
        (integral, max)
    }

    /// Mean of the interpolant at 64×64 stratified barycentric points (cell midpoints of the
    /// unit square mapped by the square-root warp), for footprints of no area.
    fn stratified_mean(&self, uv: [Vec2; 3]) -> DVec3 {
        const N: usize = 64;
        let mut sum = DVec3::ZERO;
        for a in 0..N {
            for b in 0..N {
                let u = [(a as f32 + 0.5) / N as f32, (b as f32 + 0.5) / N as f32];
                let s = u[0].sqrt();
                let (b1, b2) = (s * (1.0 - u[1]), s * u[1]);
                let p = uv[0] + b1 * (uv[1] - uv[0]) + b2 * (uv[2] - uv[0]);
                sum += self.sample_bilinear(p).as_dvec3();
            }
        }
        sum / (N * N) as f64
    }

    /// Per-channel maximum of the texels whose bilinear support meets the box [lo, hi] (in
    /// texel-centre coordinates).
    fn max_in_box(&self, lo: DVec2, hi: DVec2) -> DVec3 {
        let mut max = Vec3::ZERO;
        for j in lo.y.floor() as i64..=hi.y.ceil() as i64 {
            for i in lo.x.floor() as i64..=hi.x.ceil() as i64 {
                max = max.max(self.texel(i, j));
            }
        }
        max.as_dvec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(width: u32, height: u32, values: &[f32], wrap: [Wrap; 2]) -> Texture {
        let texels = values.iter().map(|&v| Vec3::splat(v)).collect();
        Texture::new(width, height, texels, wrap).unwrap()
    }

    #[test]
    fn bilinear_matches_hand_computed_values() {
        // 2×2: a b / c d with a = (1, 0, 0), b = (0, 1, 0), c = (0, 0, 1), d = (1, 1, 1).
        let (a, b, c, d) = (Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE);
        let t = Texture::new(2, 2, vec![a, b, c, d], [Wrap::ClampToEdge; 2]).unwrap();
        let close = |x: Vec3, y: Vec3| (x - y).abs().max_element() < 1e-6;
        assert!(close(t.sample_bilinear(Vec2::new(0.25, 0.25)), a));
        assert!(close(t.sample_bilinear(Vec2::new(0.75, 0.75)), d));
        assert!(close(
            t.sample_bilinear(Vec2::new(0.5, 0.5)),
            (a + b + c + d) / 4.0
        ));
        // x = 0.375·2 − ½ = 0.25 between a and b; y = 0.625·2 − ½ = 0.75 toward the second row.
        let expected = 0.25 * (0.75 * a + 0.25 * b) + 0.75 * (0.75 * c + 0.25 * d);
        assert!(close(t.sample_bilinear(Vec2::new(0.375, 0.625)), expected));
        // Clamped beyond the outer texel centres; a non-finite uv reads as (0, 0).
        assert!(close(t.sample_bilinear(Vec2::new(-3.0, 0.25)), a));
        assert!(close(t.sample_bilinear(Vec2::new(f32::NAN, 0.0)), a));
    }

    #[test]
    fn wrap_modes_follow_the_gl_definitions() {
        // One row 0 1 2 3: texel k has its centre at u = (k + ½)/4.
        let at = |wrap: Wrap, u: f32| {
            grey(4, 1, &[0.0, 1.0, 2.0, 3.0], [wrap, Wrap::ClampToEdge])
                .sample_bilinear(Vec2::new(u, 0.5))
                .x
        };
        let cases = [
            // u = 0 lies halfway between texel 0 and its left neighbour.
            (Wrap::Repeat, 0.0, 1.5),
            (Wrap::Repeat, 1.125, 0.0),
            (Wrap::Repeat, -0.125, 3.0),
            (Wrap::Repeat, -3.875, 0.0),
            (Wrap::Repeat, 0.0625, 0.75),
            (Wrap::ClampToEdge, 0.0, 0.0),
            (Wrap::ClampToEdge, 7.0, 3.0),
            (Wrap::ClampToEdge, 0.25, 0.5),
            // Mirrored: u ∈ [1, 2) reads 2 − u.
            (Wrap::MirroredRepeat, 0.0, 0.0),
            (Wrap::MirroredRepeat, 1.125, 3.0),
            (Wrap::MirroredRepeat, 1.625, at(Wrap::MirroredRepeat, 0.375)),
            (Wrap::MirroredRepeat, -0.125, 0.0),
            (Wrap::MirroredRepeat, 2.375, at(Wrap::MirroredRepeat, 0.375)),
        ];
        for (wrap, u, expected) in cases {
            let got = at(wrap, u);
            assert!(
                (got - expected).abs() < 1e-5,
                "{wrap:?} u = {u}: {got} vs {expected}"
            );
        }
    }

    /// A triangle inside one cell: the interpolant is a quadratic there, so the edge-midpoint
    /// rule applied to `sample_bilinear` is its exact mean.
    #[test]
    fn one_cell_average_is_the_midpoint_rule() {
        let t = grey(3, 2, &[0.1, 0.9, 0.3, 0.7, 0.2, 0.5], [Wrap::Repeat; 2]);
        // Cell [0, 1]×[0, 1] in texel-centre coordinates: u ∈ [1/6, 1/2], v ∈ [1/4, 3/4].
        let uv = [
            Vec2::new(0.2, 0.3),
            Vec2::new(0.45, 0.35),
            Vec2::new(0.3, 0.7),
        ];
        let mid = |a: Vec2, b: Vec2| t.sample_bilinear(0.5 * (a + b)).x as f64;
        let expected = (mid(uv[0], uv[1]) + mid(uv[1], uv[2]) + mid(uv[2], uv[0])) / 3.0;
        let got = t.average_over_uv_triangle(uv).x as f64;
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
        // Clockwise order gives the same mean.
        let got = t.average_over_uv_triangle([uv[0], uv[2], uv[1]]).x as f64;
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
    }

    /// The mean over a triangle equals the mean of its four midpoint-subdivision children (equal
    /// areas), whose clipping against the cells is entirely different.
    #[test]
    fn averages_are_additive_under_subdivision() {
        let values: Vec<f32> = (0..35).map(|k| ((k * 37 % 11) as f32) / 10.0).collect();
        for wrap in [Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat] {
            let t = grey(7, 5, &values, [wrap, wrap]);
            let uv = [
                Vec2::new(-0.43, 0.12),
                Vec2::new(1.61, -0.27),
                Vec2::new(0.37, 1.88),
            ];
            let m = [
                0.5 * (uv[0] + uv[1]),
                0.5 * (uv[1] + uv[2]),
                0.5 * (uv[2] + uv[0]),
            ];
            let children = [
                [uv[0], m[0], m[2]],
                [m[0], uv[1], m[1]],
                [m[2], m[1], uv[2]],
                [m[0], m[1], m[2]],
            ];
            let whole = t.average_over_uv_triangle(uv).x as f64;
            let parts: f64 = children
                .iter()
                .map(|c| t.average_over_uv_triangle(*c).x as f64 / 4.0)
                .sum();
            assert!((whole - parts).abs() < 1e-5, "{wrap:?}: {whole} vs {parts}");
        }
    }

    #[test]
    fn a_footprint_reaching_a_bright_texel_has_positive_mean_and_one_that_does_not_has_zero() {
        // 8×8 black with texel (6, 6) bright; its bilinear support is x, y ∈ (5, 7) in
        // texel-centre coordinates, i.e. u, v ∈ (5.5/8, 7.5/8).
        let mut values = vec![0.0; 64];
        values[6 * 8 + 6] = 1000.0;
        let t = grey(8, 8, &values, [Wrap::ClampToEdge; 2]);
        let far = [
            Vec2::new(0.0, 0.0),
            Vec2::new(0.5, 0.0),
            Vec2::new(0.0, 0.5),
        ];
        assert_eq!(t.average_over_uv_triangle(far), Vec3::ZERO);
        // A sliver reaching 1e-4 texels into the support: exact mean ≈ 1e-13 of the texel, so
        // the floor (1e-6 × 1000) applies.
        let edge = 5.5 / 8.0 + 1e-4 / 8.0;
        let sliver = [
            Vec2::new(0.0, 0.7),
            Vec2::new(edge, 0.7),
            Vec2::new(0.0, 0.71),
        ];
        let mean = t.average_over_uv_triangle(sliver).x as f64;
        assert!(
            (mean - 1000.0 * FOOTPRINT_FLOOR).abs() < 1e-9,
            "sliver mean {mean}"
        );
        // A zero-area footprint through the bright texel's centre: its mean along the segment.
        let line = [
            Vec2::new(0.0, 6.5 / 8.0),
            Vec2::new(1.0, 6.5 / 8.0),
            Vec2::new(0.5, 6.5 / 8.0),
        ];
        assert!(t.average_over_uv_triangle(line).x > 0.0);
    }
}
