//! Light BVH: chooses one emitter among very many with probability roughly
//! proportional to its contribution at a shading point, after Conty Estevez &
//! Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree
//! Splitting" (the same scheme as pbrt-v4's BVH light sampler).
//!
//! Each node bounds a set of emitters by a box, their total power Φ, a cone of
//! normals (axis w, half-angle θo) and the spread θe of emission beyond those
//! normals. [`LightBounds::importance`] turns these into an upper bound on what
//! the set can send to a receiver; [`LightBvh::sample`] walks down from the
//! root choosing a child with probability proportional to its importance, and
//! [`LightBvh::pmf`] recomputes the probability of any given light.
//!
//! What is stored, and why:
//! - Nodes are 32 bytes (two per cache line), in depth-first order: the left
//!   child of node i is i + 1 and the node keeps the index of its right child.
//! - The box is kept as 16-bit coordinates on a grid spanning the root's box,
//!   the cone axis as a 2×16-bit octahedral code, cos θo and cos θe as 15-bit
//!   numbers, plus a two-sided and a leaf bit, Φ as an f32 and the radius of
//!   a sphere holding the decoded box (so `importance` need not recompute it).
//!   Every rounding makes the bound larger (box rounded outwards, cosines
//!   rounded down, θo widened by the axis' coding error), so quantisation can
//!   cost efficiency but never gives 0 to a node that holds a light able to
//!   reach the receiver.
//! - The lights are renumbered into leaf order, so a subtree covers a
//!   contiguous range of light ids: a leaf keeps its light's id, and the first
//!   id of a right child's range is its parent's plus half the index distance
//!   between them. `pmf` then finds a light by descending towards its id,
//!   multiplying the very same per-node probabilities that `sample` does, at
//!   any depth and without per-light bit trails or parent links.
//!
//! The build is top-down with a binned cost over all three axes (Φ times the
//! orientation measure M_Ω times the surface area, scaled by how thin the node
//! is along the split axis), running subtrees in parallel with rayon.

use glam::{DVec3, Vec3, Vec3A};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Absolute tolerance on the cosines compared in `importance`, larger than the
/// f32 rounding of those cosines: a node is only rejected with this margin.
const COS_SLACK: f32 = 2e-6;
/// Angle (radians) added to every cone that is merged or quantised here, larger
/// than the rounding of the f64 computation and of the f32 axis it yields.
const ANGLE_SLACK: f64 = 1e-6;
/// Buckets per axis in the binned build.
const BUCKETS: usize = 12;
/// Subtrees with at least this many lights are built in parallel.
const PARALLEL_MIN: usize = 4096;
/// Nodes with at least this many lights are binned in parallel.
const PARALLEL_BINNING_MIN: usize = 1 << 16;
/// The largest f64 below 1.
const LARGEST_BELOW_ONE: f64 = 1.0 - f64::EPSILON / 2.0;
/// Largest 16-bit box coordinate.
const BOX_MAX: u32 = u16::MAX as u32;
/// Largest 15-bit cosine code.
const COS_MAX: u32 = (1 << 15) - 1;
const TWO_SIDED_BIT: u32 = 1 << 30;
const LEAF_BIT: u32 = 1 << 31;

/// Bounds of one emitter or a group: what the importance function needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Lower corner of the axis-aligned box of the emitter(s).
    pub lo: Vec3,
    /// Upper corner of the axis-aligned box of the emitter(s).
    pub hi: Vec3,
    /// Emitted power Φ ≥ 0 (already including ×2 for two-sided emitters).
    pub phi: f32,
    /// Unit axis of the normal cone.
    pub w: Vec3,
    /// cos θo, θo the normal cone's half-angle (1 for a flat one-sided
    /// triangle, −1 for a point light).
    pub cos_theta_o: f32,
    /// cos θe, θe the emission spread beyond θo (0 for area emitters: 90°).
    pub cos_theta_e: f32,
    /// Whether the emitter(s) also emit on the side opposite to their normal.
    pub two_sided: bool,
}

impl LightBounds {
    /// Bounds of both: box union, Φ summed, the smallest cone holding both
    /// normal cones (pbrt's `DirectionCone` union), the larger θe, and two-sided
    /// if either is.
    pub fn union(&self, other: &LightBounds) -> LightBounds {
        let (w, cos_theta_o) = cone_union((self.w, self.cos_theta_o), (other.w, other.cos_theta_o));
        LightBounds {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            phi: (self.phi + other.phi).min(f32::MAX),
            w,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(other.cos_theta_e),
            two_sided: self.two_sided || other.two_sided,
        }
    }

    /// Conservative bound on Φ·cos θ'/d² times the receiver's cosine, at a
    /// receiver point `p` with unit normal `n` (`Vec3::ZERO`: no receiver term).
    ///
    /// With c the box centre, θb the half-angle of the cone from p around the
    /// box's bounding sphere (π when p is inside it):
    /// - emitter: θw = ∠(w, p − c) (|cos| when two-sided), θx = max(0, θw − θo),
    ///   θp = max(0, θx − θb); 0 if cos θp ≤ cos θe, else the factor cos θp;
    /// - receiver: θi = ∠(n, c − p); factor cos(max(0, θi − θb)), 0 when that
    ///   angle reaches 90° (the whole sphere behind the tangent plane);
    /// - d² = max(|p − c|², (|hi − lo|/2)²).
    ///
    /// Cosines near a threshold are given a margin of `COS_SLACK` so that f32
    /// rounding never rejects a node that can reach p's upper hemisphere. The
    /// result is finite and ≥ 0 (clamped to f32::MAX), and positive results
    /// are at least f32::MIN_POSITIVE.
    #[inline(always)]
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        self.importance_with_radius(p, n, bounding_radius)
    }

    /// [`importance`](Self::importance) with the bounding sphere's radius
    /// given by `radius(centre, half_diagonal_sq)`: [`bounding_radius`] or a
    /// value precomputed by it.
    #[inline(always)]
    fn importance_with_radius(
        &self,
        p: Vec3,
        n: Vec3,
        radius: impl FnOnce(Vec3, f32) -> f32,
    ) -> f32 {
        let (centre, half_diagonal_sq) = self.centre_and_half_diagonal_sq();
        let valid = self.phi > 0.0 && centre.is_finite() && p.is_finite() && n.is_finite();
        if !valid {
            return 0.0;
        }
        let radius = radius(centre, half_diagonal_sq);
        let to_p = p - centre;
        let dist_sq = to_p.length_squared();
        let sphere = Subtended::new(to_p, dist_sq, radius);
        let emitted = self.emitter_factor(sphere);
        if emitted == 0.0 {
            return 0.0;
        }
        let received = receiver_factor(n, sphere);
        let inv_d_sq = dist_sq.max(half_diagonal_sq).max(f32::MIN_POSITIVE).recip();
        let value = f64::from(self.phi) * f64::from(emitted * received) * f64::from(inv_d_sq);
        if value > 0.0 {
            (value.min(f64::from(f32::MAX)) as f32).max(f32::MIN_POSITIVE)
        } else {
            0.0
        }
    }

    /// The box's centre and its half diagonal squared.
    #[inline(always)]
    fn centre_and_half_diagonal_sq(&self) -> (Vec3, f32) {
        let centre = (self.lo + self.hi) * 0.5;
        (centre, ((self.hi - self.lo) * 0.5).length_squared())
    }

    /// cos θp, or 0 when θp ≥ θe (with slack) so no emitter faces p.
    #[inline(always)]
    fn emitter_factor(&self, sphere: Option<Subtended>) -> f32 {
        let Some(s) = sphere else {
            return 1.0; // p inside the sphere: θb = π, θp = 0
        };
        let x = if self.cos_theta_o <= -1.0 || self.w == Vec3::ZERO {
            (1.0, 0.0)
        } else {
            let cos_w = self.w.dot(s.dir);
            let cos_w = if self.two_sided { cos_w.abs() } else { cos_w };
            let sin_w = self.w.cross(s.dir).length();
            angle_minus((cos_w, sin_w), (self.cos_theta_o, sin_of(self.cos_theta_o)))
        };
        let (cos_p, _) = angle_minus(x, (s.cos_b, s.sin_b));
        if cos_p <= self.cos_theta_e - COS_SLACK {
            0.0
        } else {
            cos_p.max(COS_SLACK)
        }
    }
}

/// Receiver factor cos(max(0, θi − θb)), or 0 when that angle is ≥ 90° (with
/// slack): the node's bounding sphere lies wholly behind the tangent plane.
#[inline(always)]
fn receiver_factor(n: Vec3, sphere: Option<Subtended>) -> f32 {
    let Some(s) = sphere else { return 1.0 };
    if n == Vec3::ZERO {
        return 1.0;
    }
    let to_centre = -s.dir;
    let (cos_i, sin_i) = (n.dot(to_centre), n.cross(to_centre).length());
    let (cos, _) = angle_minus((cos_i, sin_i), (s.cos_b, s.sin_b));
    if cos <= -COS_SLACK {
        0.0
    } else {
        cos.max(COS_SLACK)
    }
}

/// The cone of directions from the receiver that holds a node's bounding
/// sphere: `dir` is the unit vector from the sphere's centre to p, and
/// (`cos_b`, `sin_b`) its half-angle θb, sin θb = r/|p − c|.
#[derive(Clone, Copy, Debug)]
struct Subtended {
    dir: Vec3,
    cos_b: f32,
    sin_b: f32,
}

impl Subtended {
    /// `None` when p is inside the sphere (θb = π).
    #[inline(always)]
    fn new(to_p: Vec3, dist_sq: f32, radius: f32) -> Option<Subtended> {
        (dist_sq > radius * radius).then(|| {
            let dist = dist_sq.sqrt();
            let inv_dist = dist.recip();
            Subtended {
                dir: to_p * inv_dist,
                cos_b: ((dist - radius) * (dist + radius)).sqrt() * inv_dist,
                sin_b: radius * inv_dist,
            }
        })
    }
}

/// Radius of a sphere about the f32 centre that surely holds the box: the half
/// diagonal enlarged for the rounding of the centre and of the half diagonal.
fn bounding_radius(centre: Vec3, half_diagonal_sq: f32) -> f32 {
    let eps = f32::EPSILON;
    half_diagonal_sq.sqrt() * (1.0 + 8.0 * eps) + 4.0 * eps * centre.abs().max_element()
}

/// (cos, sin) of max(0, α − β) from those of α, β ∈ [0, π].
fn angle_minus((cos_a, sin_a): (f32, f32), (cos_b, sin_b): (f32, f32)) -> (f32, f32) {
    if cos_a >= cos_b {
        return (1.0, 0.0);
    }
    (
        cos_a * cos_b + sin_a * sin_b,
        (sin_a * cos_b - cos_a * sin_b).max(0.0),
    )
}

/// sin θ from cos θ for θ ∈ [0, π], written (1 − c)(1 + c) to stay accurate
/// near c = ±1.
fn sin_of(cos: f32) -> f32 {
    ((1.0 - cos) * (1.0 + cos)).max(0.0).sqrt()
}

/// cos(α + β) from cos α, cos β and sin β, α, β ∈ [0, π]; −1 once α + β ≥ π.
fn cos_sum(cos_a: f32, cos_b: f32, sin_b: f32) -> f32 {
    if cos_a + cos_b <= 0.0 {
        return -1.0;
    }
    (cos_a * cos_b - sin_of(cos_a) * sin_b).max(-1.0)
}

/// Angle between two vectors, accurate at small and large angles.
fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The largest f32 not above `c` (so a cone never narrows), at least −1.
fn cos_down(c: f64) -> f32 {
    let f = c as f32;
    let f = if f64::from(f) > c { f.next_down() } else { f };
    f.max(-1.0)
}

/// Whether the cone holds every direction (or has no usable axis).
fn is_whole_sphere((w, cos): (Vec3, f32)) -> bool {
    cos <= -1.0 || w.length_squared() == 0.0 || !w.is_finite()
}

/// Smallest cone holding two cones (w, cos θ), following pbrt-v4's
/// `DirectionCone` union: if one holds the other it is the result; otherwise
/// the half-angle is (θa + θd + θb)/2, θd = ∠(wa, wb), and the axis is wa
/// turned towards wb by that minus θa. Computed in f64, widened by
/// `ANGLE_SLACK` and with the cosine rounded down.
fn cone_union(a: (Vec3, f32), b: (Vec3, f32)) -> (Vec3, f32) {
    if is_whole_sphere(a) || is_whole_sphere(b) {
        return (a.0, -1.0);
    }
    let (wa, wb) = (a.0.as_dvec3().normalize(), b.0.as_dvec3().normalize());
    let theta_a = f64::from(a.1).clamp(-1.0, 1.0).acos();
    let theta_b = f64::from(b.1).clamp(-1.0, 1.0).acos();
    let theta_d = angle_between(wa, wb);
    if (theta_d + theta_b).min(PI) <= theta_a {
        return a;
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return b;
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    let spread = theta_o + ANGLE_SLACK;
    let Some(pivot) = wa.cross(wb).try_normalize() else {
        return (a.0, -1.0);
    };
    if spread >= PI {
        return (a.0, -1.0);
    }
    let (sin_r, cos_r) = (theta_o - theta_a).sin_cos();
    let w = wa * cos_r + pivot.cross(wa) * sin_r;
    (w.as_vec3().normalize(), cos_down(spread.cos()))
}

/// Grid on which node boxes are stored: coordinate k of code q decodes to
/// `origin[k] + q · step[k]`, q = 0 ..= 65535, and code 65535 reaches at least
/// the root box's upper corner.
#[derive(Clone, Copy, Debug)]
struct Grid {
    origin: Vec3A,
    step: Vec3A,
    /// 1/step (0 along axes without extent), for first guesses only.
    inv_step: Vec3A,
}

impl Grid {
    fn new(lo: Vec3, hi: Vec3) -> Grid {
        let step = |k: usize| {
            let mut s = ((f64::from(hi[k]) - f64::from(lo[k])) / f64::from(BOX_MAX)) as f32;
            while lo[k] + BOX_MAX as f32 * s < hi[k] {
                s = s.next_up();
            }
            s
        };
        let step = Vec3A::new(step(0), step(1), step(2));
        Grid {
            origin: lo.into(),
            step,
            inv_step: Vec3A::select(step.cmpgt(Vec3A::ZERO), step.recip(), Vec3A::ZERO)
                .min(Vec3A::splat(f32::MAX)),
        }
    }

    fn decode(&self, q: [u16; 3]) -> Vec3 {
        let q = Vec3A::new(f32::from(q[0]), f32::from(q[1]), f32::from(q[2]));
        (self.origin + q * self.step).into()
    }

    /// Codes whose decoding is ≤ `x` (`up` false) or ≥ `x` (`up` true): a
    /// first guess rounded down (up), then stepped until the decoding
    /// arithmetic itself confirms the rounding direction.
    fn encode(&self, x: Vec3, up: bool) -> [u16; 3] {
        let x = Vec3A::from(x);
        let top = Vec3A::splat(BOX_MAX as f32);
        let guess = ((x - self.origin) * self.inv_step).clamp(Vec3A::ZERO, top);
        let mut q = if up { guess.ceil() } else { guess.floor() };
        loop {
            let at = self.origin + q * self.step;
            let (wrong, next) = if up {
                (at.cmplt(x) & q.cmplt(top), q + 1.0)
            } else {
                (at.cmpgt(x) & q.cmpgt(Vec3A::ZERO), q - 1.0)
            };
            if !wrong.any() {
                let q = q.as_uvec3();
                return [q.x, q.y, q.z].map(|c| c as u16);
            }
            q = Vec3A::select(wrong, next, q);
        }
    }
}

/// 15-bit cosine code → cosine in [−1, 1].
fn decode_cos(q: u32) -> f32 {
    q as f32 * (2.0 / COS_MAX as f32) - 1.0
}

/// A 15-bit code whose cosine is ≤ `c` (a wider or equal angle): `c` rounded
/// down to the grid, then checked with the decoding arithmetic.
fn encode_cos(c: f64) -> u32 {
    let mut q = ((c + 1.0) * 0.5 * f64::from(COS_MAX)).clamp(0.0, f64::from(COS_MAX)) as u32;
    while q > 0 && f64::from(decode_cos(q)) > c {
        q -= 1;
    }
    q
}

/// Octahedral code of a unit vector: 16 bits for each of the two coordinates
/// of its projection onto |x| + |y| + |z| = 1, the lower half folded over.
fn encode_octahedral(v: Vec3) -> u32 {
    let v = v / (v.x.abs() + v.y.abs() + v.z.abs());
    let (x, y) = if v.z < 0.0 {
        (
            (1.0 - v.y.abs()) * v.x.signum(),
            (1.0 - v.x.abs()) * v.y.signum(),
        )
    } else {
        (v.x, v.y)
    };
    let code = |t: f32| ((t.clamp(-1.0, 1.0) * 0.5 + 0.5) * BOX_MAX as f32 + 0.5) as u32;
    code(x) | code(y) << 16
}

/// Unit vector of an octahedral code.
#[inline(always)]
fn decode_octahedral(code: u32) -> Vec3 {
    let coord = |q: u32| (q & BOX_MAX) as f32 * (2.0 / BOX_MAX as f32) - 1.0;
    let (x, y) = (coord(code), coord(code >> 16));
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum())
    } else {
        (x, y)
    };
    Vec3::new(x, y, z).normalize()
}

/// Quantised normal cone: the axis' octahedral code and the 15-bit cos θo of
/// a cone about the decoded axis that holds the original cone (θo widened by
/// the angle between the two axes).
fn encode_cone(w: Vec3, cos_o: f32) -> (u32, u32) {
    if is_whole_sphere((w, cos_o)) {
        return (encode_octahedral(Vec3::Z), 0);
    }
    let code = encode_octahedral(w);
    let (a, b) = (w.as_dvec3().normalize(), decode_octahedral(code).as_dvec3());
    let error = (a.dot(b), a.cross(b).length());
    let cos_o = f64::from(cos_o).clamp(-1.0, 1.0);
    let theta = angle_sum((cos_o, ((1.0 - cos_o) * (1.0 + cos_o)).sqrt()), error);
    let slack = (1.0 - 0.5 * ANGLE_SLACK * ANGLE_SLACK, ANGLE_SLACK);
    (code, encode_cos(angle_sum(theta, slack).0))
}

/// (cos, sin) of α + β from those of α, β ∈ [0, π]; (−1, 0) once α + β ≥ π.
fn angle_sum((cos_a, sin_a): (f64, f64), (cos_b, sin_b): (f64, f64)) -> (f64, f64) {
    if cos_a + cos_b <= 0.0 {
        return (-1.0, 0.0);
    }
    (cos_a * cos_b - sin_a * sin_b, sin_a * cos_b + cos_a * sin_b)
}

/// A compact tree node: 32 bytes, decoded on the fly.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
struct Node {
    /// Box corners on the tree's [`Grid`].
    lo: [u16; 3],
    hi: [u16; 3],
    /// Octahedral code of the cone axis.
    axis: u32,
    phi: f32,
    /// Bits 0–14 cos θo, 15–29 cos θe, 30 two-sided, 31 leaf.
    cones: u32,
    /// Right child (interior node) or the light id (leaf). The first light id
    /// of a right child's range is its parent's plus half the distance from
    /// parent to right child (the left subtree's 2k − 1 nodes hold k lights).
    link: u32,
    /// [`bounding_radius`] of the decoded box, precomputed for `importance`.
    radius: f32,
}

impl Node {
    /// A node with its place in the tree only; bounds come later.
    fn topology(link: u32, leaf: bool) -> Node {
        Node {
            link,
            cones: if leaf { LEAF_BIT } else { 0 },
            ..Node::default()
        }
    }

    /// `self`'s topology with the quantised `bounds`.
    fn with_bounds(self, b: &LightBounds, grid: &Grid) -> Node {
        let (axis, cos_o) = encode_cone(b.w, b.cos_theta_o);
        let cos_e = encode_cos(f64::from(b.cos_theta_e));
        let two_sided = if b.two_sided { TWO_SIDED_BIT } else { 0 };
        let node = Node {
            lo: grid.encode(b.lo, false),
            hi: grid.encode(b.hi, true),
            axis,
            phi: b.phi,
            cones: cos_o | cos_e << 15 | two_sided | (self.cones & LEAF_BIT),
            ..self
        };
        let (centre, half_diagonal_sq) = node.bounds(grid).centre_and_half_diagonal_sq();
        Node {
            radius: bounding_radius(centre, half_diagonal_sq),
            ..node
        }
    }

    fn is_leaf(&self) -> bool {
        self.cones & LEAF_BIT != 0
    }

    #[inline(always)]
    fn bounds(&self, grid: &Grid) -> LightBounds {
        LightBounds {
            lo: grid.decode(self.lo),
            hi: grid.decode(self.hi),
            phi: self.phi,
            w: decode_octahedral(self.axis),
            cos_theta_o: decode_cos(self.cones & COS_MAX),
            cos_theta_e: decode_cos((self.cones >> 15) & COS_MAX),
            two_sided: self.cones & TWO_SIDED_BIT != 0,
        }
    }

    #[inline(always)]
    fn importance(&self, grid: &Grid, p: Vec3, n: Vec3) -> f32 {
        self.bounds(grid)
            .importance_with_radius(p, n, |_, _| self.radius)
    }

    /// First light id of the right child's range, `first` being this
    /// interior node's, at `index`.
    fn right_first(&self, index: usize, first: usize) -> usize {
        first + (self.link as usize - index) / 2
    }
}

/// Probabilities (left, right) of the two children from their importances,
/// in f64 (a child of importance 0 gets exactly 0, its sibling exactly 1);
/// `None` when both are 0.
fn split_probabilities(left: f32, right: f32) -> Option<(f64, f64)> {
    let (l, r) = (f64::from(left), f64::from(right));
    let total = l + r;
    (total > 0.0).then(|| (l / total, r / total))
}

/// A light bounding volume hierarchy over emitters' [`LightBounds`].
#[derive(Clone, Debug)]
pub struct LightBvh {
    nodes: Vec<Node>,
    grid: Grid,
}

impl LightBvh {
    /// Builds over `bounds` (index i = light i). Lights with phi == 0 (or
    /// negative, or any non-finite field) are left out, as are indices from
    /// 2³¹ on. Returns the tree and `order`, the included light indices in leaf
    /// order: the caller reorders its lights so that light `order[k]` becomes
    /// light k, the id used by [`sample`](Self::sample) and [`pmf`](Self::pmf).
    pub fn build(bounds: &[LightBounds]) -> (LightBvh, Vec<u32>) {
        let mut prims: Vec<Prim> = bounds
            .par_iter()
            .enumerate()
            .map(|(i, b)| Prim::new(i, b).unwrap_or(Prim::LEFT_OUT))
            .collect();
        prims.retain(|p| p.phi > 0.0);
        let (boxes, centroids) = prims
            .par_iter()
            .map(|p| (p.aabb(), Aabb::point(p.centroid())))
            .reduce(
                || (Aabb::EMPTY, Aabb::EMPTY),
                |a, b| (a.0.merge(&b.0), a.1.merge(&b.1)),
            );
        let grid = Grid::new(boxes.lo.into(), boxes.hi.into());
        let mut nodes: Vec<Node> = (1..2 * prims.len())
            .into_par_iter()
            .map(|_| Node::default())
            .collect();
        if !prims.is_empty() {
            let tree = Subtree {
                prims: &mut prims,
                nodes: &mut nodes,
                base: 0,
                first: 0,
            };
            tree.build(&grid, centroids);
        }
        let order = prims.iter().map(|p| p.id).collect();
        (LightBvh { nodes, grid }, order)
    }

    /// The root's importance at (p, n): 0 when no light in the tree can reach p's upper
    /// hemisphere.
    pub fn root_importance(&self, p: Vec3, n: Vec3) -> f32 {
        self.nodes
            .first()
            .map_or(0.0, |root| root.importance(&self.grid, p, n))
    }

    /// Chooses a light (its id in leaf order) with probability proportional
    /// to importance at each level, from `u` ∈ [0, 1): at a node, the left
    /// child is taken when u < I_l/(I_l + I_r), and u is rescaled to [0, 1)
    /// within the chosen part. Returns the light and its probability, or
    /// `None` when the tree is empty, the root's importance is 0, a node is
    /// reached whose children both have importance 0, or the probability
    /// underflows to 0.
    pub fn sample(&self, p: Vec3, n: Vec3, u: f64) -> Option<(usize, f64)> {
        if self.nodes.first()?.importance(&self.grid, p, n) == 0.0 {
            return None;
        }
        let mut u = if u >= 0.0 {
            u.min(LARGEST_BELOW_ONE)
        } else {
            0.0
        };
        let mut index = 0;
        let mut pmf = 1.0;
        loop {
            let node = self.nodes.get(index)?;
            if node.is_leaf() {
                return (pmf > 0.0).then_some((node.link as usize, pmf));
            }
            let (p_left, p_right) = self.child_probabilities(index, p, n)?;
            if u < p_left {
                pmf *= p_left;
                u = (u / p_left).min(LARGEST_BELOW_ONE);
                index += 1;
            } else {
                pmf *= p_right;
                u = ((u - p_left) / p_right).min(LARGEST_BELOW_ONE);
                index = node.link as usize;
            }
        }
    }

    /// The probability that [`sample`](Self::sample) returns `light` at
    /// (`p`, `n`), bit-identical to the value it returns with it: descends
    /// towards the child whose id range holds `light`, multiplying the same
    /// per-node probabilities. 0 for ids ≥ [`len`](Self::len).
    pub fn pmf(&self, p: Vec3, n: Vec3, light: usize) -> f64 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        if light >= self.len() || root.importance(&self.grid, p, n) == 0.0 {
            return 0.0;
        }
        let (mut index, mut first) = (0, 0);
        let mut pmf = 1.0;
        loop {
            let Some(node) = self.nodes.get(index) else {
                return 0.0;
            };
            if node.is_leaf() {
                return pmf;
            }
            let Some((p_left, p_right)) = self.child_probabilities(index, p, n) else {
                return 0.0;
            };
            let right_first = node.right_first(index, first);
            let (probability, next) = if light >= right_first {
                (p_right, node.link as usize)
            } else {
                (p_left, index + 1)
            };
            if probability == 0.0 {
                return 0.0;
            }
            pmf *= probability;
            if light >= right_first {
                first = right_first;
            }
            index = next;
        }
    }

    /// Number of lights in the tree.
    pub fn len(&self) -> usize {
        self.nodes.len().div_ceil(2)
    }

    /// Whether the tree holds no light.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Number of nodes (2·len − 1).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Heap bytes held by the tree.
    pub fn bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
    }

    /// Child probabilities at interior node `index` (see [`split_probabilities`]).
    fn child_probabilities(&self, index: usize, p: Vec3, n: Vec3) -> Option<(f64, f64)> {
        let right = self.nodes.get(index)?.link as usize;
        let left = self.nodes.get(index + 1)?.importance(&self.grid, p, n);
        let right = self.nodes.get(right)?.importance(&self.grid, p, n);
        split_probabilities(left, right)
    }
}

/// A light as the build sees it: sanitised bounds plus its original index.
#[derive(Clone, Copy, Debug)]
struct Prim {
    lo: Vec3,
    hi: Vec3,
    w: Vec3,
    phi: f32,
    cos_o: f32,
    cos_e: f32,
    id: u32,
    two_sided: bool,
}

impl Prim {
    /// Stands for a light left out until it is removed (Φ = 0).
    const LEFT_OUT: Prim = Prim {
        lo: Vec3::ZERO,
        hi: Vec3::ZERO,
        w: Vec3::ZERO,
        phi: 0.0,
        cos_o: -1.0,
        cos_e: 0.0,
        id: 0,
        two_sided: false,
    };

    /// `None` for lights left out: Φ not > 0, a non-finite field, or i ≥ 2³¹.
    /// Otherwise the box is reordered, w normalised (a zero w means every
    /// direction) and the cosines clamped to [−1, 1].
    fn new(i: usize, b: &LightBounds) -> Option<Prim> {
        let id = u32::try_from(i).ok().filter(|&id| id < 1 << 31)?;
        let finite = b.lo.is_finite()
            && b.hi.is_finite()
            && b.w.is_finite()
            && b.phi.is_finite()
            && b.cos_theta_o.is_finite()
            && b.cos_theta_e.is_finite();
        if !(finite && b.phi > 0.0) {
            return None;
        }
        let w = b.w.normalize_or_zero();
        let cos_o = if w == Vec3::ZERO {
            -1.0
        } else {
            b.cos_theta_o.clamp(-1.0, 1.0)
        };
        Some(Prim {
            lo: b.lo.min(b.hi),
            hi: b.lo.max(b.hi),
            w,
            phi: b.phi,
            cos_o,
            cos_e: b.cos_theta_e.clamp(-1.0, 1.0),
            id,
            two_sided: b.two_sided,
        })
    }

    fn centroid(&self) -> Vec3A {
        (Vec3A::from(self.lo) + Vec3A::from(self.hi)) * 0.5
    }

    fn aabb(&self) -> Aabb {
        Aabb {
            lo: self.lo.into(),
            hi: self.hi.into(),
        }
    }

    fn bounds(&self) -> LightBounds {
        LightBounds {
            lo: self.lo,
            hi: self.hi,
            phi: self.phi,
            w: self.w,
            cos_theta_o: self.cos_o,
            cos_theta_e: self.cos_e,
            two_sided: self.two_sided,
        }
    }
}

/// Axis-aligned box used by the build.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: Vec3A,
    hi: Vec3A,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    fn point(p: Vec3A) -> Aabb {
        Aabb { lo: p, hi: p }
    }

    fn merge(&self, other: &Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    fn grow(&mut self, other: &Aabb) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }

    fn extent(&self) -> Vec3A {
        (self.hi - self.lo).max(Vec3A::ZERO)
    }

    /// Surface area with every edge lengthened by `pad`, so that flat or
    /// collinear sets still compare by size.
    fn padded_area(&self, pad: f32) -> f64 {
        let e = (self.extent() + pad).as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// A set of lights as the split cost sees it: box, summed Φ (f64), count,
/// the box holding their unit axes, and their widest θo and θe. Merging is
/// component-wise, so runs of buckets or lights are cheap to accumulate.
#[derive(Clone, Copy, Debug)]
struct Side {
    bounds: Aabb,
    axes: Aabb,
    phi: f64,
    count: u32,
    cos_o: f32,
    cos_e: f32,
}

impl Side {
    const EMPTY: Side = Side {
        bounds: Aabb::EMPTY,
        axes: Aabb::EMPTY,
        phi: 0.0,
        count: 0,
        cos_o: 1.0,
        cos_e: 1.0,
    };

    fn of(p: &Prim) -> Side {
        Side {
            bounds: p.aabb(),
            axes: Aabb::point(p.w.into()),
            phi: f64::from(p.phi),
            count: 1,
            cos_o: p.cos_o,
            cos_e: p.cos_e,
        }
    }

    /// Adds `other`'s lights, in place.
    fn add(&mut self, other: &Side) {
        self.bounds.grow(&other.bounds);
        self.axes.grow(&other.axes);
        self.phi += other.phi;
        self.count += other.count;
        self.cos_o = self.cos_o.min(other.cos_o);
        self.cos_e = self.cos_e.min(other.cos_e);
    }

    /// cos θo of a cone holding every light's normal cone: about the
    /// direction a of the axis box's centre, the smallest a·w over the box
    /// bounds the axes' angle from a, and the widest θo is added to it.
    fn cos_half_angle(&self) -> f32 {
        if self.count == 1 {
            return self.cos_o;
        }
        let a = self.axes.lo + self.axes.hi;
        let length = a.length();
        if !length.is_normal() {
            return -1.0;
        }
        let nearest =
            ((a * self.axes.lo).min(a * self.axes.hi).element_sum() / length).clamp(-1.0, 1.0);
        if self.cos_o >= 1.0 {
            nearest
        } else {
            cos_sum(nearest, self.cos_o, sin_of(self.cos_o))
        }
    }

    /// pbrt-v4's split cost of one side without the axis factor:
    /// Φ · M_Ω(θo, θe) · surface area.
    fn cost(&self, pad: f32) -> f64 {
        let m_omega = orientation_measure(self.cos_half_angle(), self.cos_e);
        self.phi * m_omega * self.bounds.padded_area(pad)
    }
}

/// M_Ω(θo, θe): the integral of the clamped emission bound over the sphere,
/// 2π(1 − cos θo) + π/2·(2θw sin θo − cos(θo − 2θw) − 2θo sin θo + cos θo)
/// with θw = min(θo + θe, π); in f32 with an approximate arccosine (it only
/// ranks splits), written without branches on the cone's width.
fn orientation_measure(cos_o: f32, cos_e: f32) -> f64 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (co, so) = (cos_o, sin_of(cos_o));
    let (ce, se) = (cos_e, sin_of(cos_e));
    let theta_o = approx_acos(co);
    let theta_e = if ce == 0.0 {
        FRAC_PI_2
    } else {
        approx_acos(ce)
    };
    // θw − θo, and cos(θo − 2θw) = cos(θo + 2θe) unless θw = π.
    let spread = theta_e.min(PI - theta_o);
    let wraps = theta_o + theta_e >= PI;
    let cos_o_2e = co * (2.0 * ce * ce - 1.0) - so * (2.0 * se * ce);
    let cos_o_2w = if wraps { co } else { cos_o_2e };
    f64::from(2.0 * PI * (1.0 - co) + FRAC_PI_2 * (2.0 * spread * so - cos_o_2w + co))
}

/// arccos within 7e-5 (Abramowitz & Stegun 4.4.45).
fn approx_acos(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let t =
        (1.0 - a).sqrt() * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261 - 0.018_729_3 * a)));
    if x < 0.0 {
        std::f32::consts::PI - t
    } else {
        t
    }
}

/// Most items [`cheapest_cut`] handles: buckets, or lights of a small node.
const MAX_CUT_ITEMS: usize = 16;
/// Nodes with at most this many lights try every cut of their lights sorted
/// along each axis instead of binning.
const SMALL_NODE: usize = MAX_CUT_ITEMS;

/// The cheapest cut of a sequence of `n` ≤ [`MAX_CUT_ITEMS`] sets (empty ones
/// allowed) into two non-empty runs, as (Σ side costs, length of the first
/// run); every distinct cut is tried.
fn cheapest_cut(n: usize, item: impl Fn(usize) -> Side, pad: f32) -> Option<(f64, usize)> {
    let mut suffix_cost = [f64::INFINITY; MAX_CUT_ITEMS];
    let mut suffix = Side::EMPTY;
    for k in (1..n).rev() {
        suffix.add(&item(k));
        if suffix.count > 0 {
            suffix_cost[k] = suffix.cost(pad);
        }
    }
    let mut prefix = Side::EMPTY;
    let mut best: Option<(f64, usize)> = None;
    for k in 0..n - 1 {
        let next = item(k);
        if next.count == 0 {
            continue;
        }
        prefix.add(&next);
        let cost = prefix.cost(pad) + suffix_cost[k + 1];
        if cost.is_finite() && best.is_none_or(|b| cost < b.0) {
            best = Some((cost, k + 1));
        }
    }
    best
}

/// Lights binned by centroid along one axis: their [`Side`] and centroid box.
#[derive(Clone, Copy, Debug)]
struct Bin {
    side: Side,
    centroids: Aabb,
}

impl Bin {
    const EMPTY: Bin = Bin {
        side: Side::EMPTY,
        centroids: Aabb::EMPTY,
    };

    /// Adds `other`'s lights, in place.
    fn add(&mut self, other: &Bin) {
        self.side.add(&other.side);
        self.centroids.grow(&other.centroids);
    }
}

/// Maps centroids to buckets along the axes where their box has extent.
#[derive(Clone, Copy, Debug)]
struct Binner {
    lo: Vec3A,
    scale: Vec3A,
    active: [bool; 3],
}

impl Binner {
    fn new(centroids: &Aabb) -> Binner {
        let extent = centroids.extent();
        let scale =
            |k: usize| (BUCKETS as f64 / f64::from(extent[k])).min(f64::from(f32::MAX)) as f32;
        Binner {
            lo: centroids.lo,
            scale: Vec3A::new(scale(0), scale(1), scale(2)),
            active: [0, 1, 2].map(|k| extent[k] > 0.0),
        }
    }

    /// Bucket of a centroid along each axis.
    fn buckets(&self, centroid: Vec3A) -> [usize; 3] {
        let b = ((centroid - self.lo) * self.scale).as_uvec3();
        [b.x, b.y, b.z].map(|b| (b as usize).min(BUCKETS - 1))
    }

    /// Whether a light's bucket along `axis` is below `cut`; the same
    /// arithmetic as [`buckets`](Self::buckets), for one axis.
    fn below(&self, p: &Prim, axis: usize, cut: usize) -> bool {
        let centroid = (p.lo[axis] + p.hi[axis]) * 0.5;
        let b = ((centroid - self.lo[axis]) * self.scale[axis]) as u32;
        (b as usize).min(BUCKETS - 1) < cut
    }

    /// Bins the lights along every active axis, in one pass (halves of
    /// large sets binned in parallel).
    fn bin(&self, prims: &[Prim]) -> [[Bin; BUCKETS]; 3] {
        if prims.len() >= PARALLEL_BINNING_MIN {
            let (a, b) = prims.split_at(prims.len() / 2);
            let (mut bins, other) = rayon::join(|| self.bin(a), || self.bin(b));
            for (bin, more) in bins.iter_mut().flatten().zip(other.iter().flatten()) {
                bin.add(more);
            }
            return bins;
        }
        let mut bins = [[Bin::EMPTY; BUCKETS]; 3];
        for p in prims {
            let (c, side) = (p.centroid(), Side::of(p));
            let buckets = self.buckets(c);
            for (axis, row) in bins.iter_mut().enumerate() {
                if self.active[axis] {
                    let bin = &mut row[buckets[axis]];
                    bin.side.add(&side);
                    bin.centroids.grow(&Aabb::point(c));
                }
            }
        }
        bins
    }
}

/// A chosen split: lights `..mid` go left; the children's centroid boxes.
#[derive(Clone, Copy, Debug)]
struct Split {
    mid: usize,
    left: Aabb,
    right: Aabb,
}

/// Splits `prims` (≥ 2), reordering them so the left part comes first: by
/// the binned cost, or by trying every cut for small nodes; a median split
/// when the centroids cannot be separated.
fn choose_split(prims: &mut [Prim], centroids: Aabb) -> Split {
    let median = Split {
        mid: prims.len() / 2,
        left: centroids,
        right: centroids,
    };
    let split = match prims.len() {
        0..=2 => None,
        3..=SMALL_NODE => small_split(prims, centroids),
        _ => binned_split(prims, centroids),
    };
    split.unwrap_or(median)
}

/// The split axis' weight Kr = (largest extent)/(extent along the axis), and
/// the padding for [`Aabb::padded_area`], from the node's box.
fn axis_weights(node: &Aabb) -> ([f64; 3], f32) {
    let extent = node.extent();
    let largest = extent.max_element();
    (
        [0, 1, 2].map(|k| f64::from(largest / extent[k])),
        1e-3 * largest,
    )
}

/// Binned split: 12 buckets along each axis, every boundary tried.
fn binned_split(prims: &mut [Prim], centroids: Aabb) -> Option<Split> {
    let binner = Binner::new(&centroids);
    let bins = binner.bin(prims);
    let row = bins.iter().zip(binner.active).find(|(_, a)| *a)?.0;
    let node = row
        .iter()
        .fold(Aabb::EMPTY, |b, bin| b.merge(&bin.side.bounds));
    let (kr, pad) = axis_weights(&node);
    let mut best: Option<(f64, usize, usize)> = None;
    for (axis, row) in bins
        .iter()
        .enumerate()
        .filter(|(axis, _)| binner.active[*axis])
    {
        if let Some((cost, cut)) = cheapest_cut(BUCKETS, |k| row[k].side, pad) {
            let cost = kr[axis] * cost;
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, cut));
            }
        }
    }
    let (_, axis, cut) = best?;
    let union = |bins: &[Bin]| {
        bins.iter()
            .fold(Aabb::EMPTY, |b, bin| b.merge(&bin.centroids))
    };
    let mid = partition(prims, |p| binner.below(p, axis, cut));
    let split = Split {
        mid,
        left: union(&bins[axis][..cut]),
        right: union(&bins[axis][cut..]),
    };
    (0 < mid && mid < prims.len()).then_some(split)
}

/// Split of a small node: the lights sorted by centroid along each axis, every
/// cut tried.
fn small_split(prims: &mut [Prim], centroids: Aabb) -> Option<Split> {
    let n = prims.len();
    let sides: [Side; SMALL_NODE] =
        std::array::from_fn(|k| prims.get(k).map_or(Side::EMPTY, Side::of));
    let keys: [Vec3A; SMALL_NODE] =
        std::array::from_fn(|k| sides[k].bounds.lo + sides[k].bounds.hi);
    let node = sides.iter().fold(Aabb::EMPTY, |b, s| b.merge(&s.bounds));
    let (kr, pad) = axis_weights(&node);
    let active = centroids.extent().cmpgt(Vec3A::ZERO);
    let mut best: Option<(f64, [u8; SMALL_NODE], usize)> = None;
    for axis in (0..3).filter(|&k| active.test(k)) {
        let order = sorted_along(&keys[..n], axis);
        if let Some((cost, cut)) = cheapest_cut(n, |k| sides[usize::from(order[k])], pad) {
            let cost = kr[axis] * cost;
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, order, cut));
            }
        }
    }
    let (_, order, mid) = best?;
    let sorted: [Prim; SMALL_NODE] = std::array::from_fn(|k| prims[usize::from(order[k])]);
    prims.copy_from_slice(&sorted[..n]);
    Some(Split {
        mid,
        left: centroids,
        right: centroids,
    })
}

/// Positions 0..keys.len() (at most [`SMALL_NODE`]) sorted by `keys[·][axis]`,
/// ties kept in order; unused entries are 0.
fn sorted_along(keys: &[Vec3A], axis: usize) -> [u8; SMALL_NODE] {
    let key = |i: u8| keys[usize::from(i)][axis];
    let mut order = [0u8; SMALL_NODE];
    for i in 1..keys.len().min(SMALL_NODE) as u8 {
        let mut j = usize::from(i);
        while j > 0 && key(i).total_cmp(&key(order[j - 1])).is_lt() {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = i;
    }
    order
}

/// Moves the lights for which `goes_left` holds to the front (swapping
/// misplaced pairs from both ends); returns how many.
fn partition(prims: &mut [Prim], goes_left: impl Fn(&Prim) -> bool) -> usize {
    let (mut i, mut j) = (0, prims.len());
    loop {
        while i < j && goes_left(&prims[i]) {
            i += 1;
        }
        while i < j && !goes_left(&prims[j - 1]) {
            j -= 1;
        }
        if i + 1 >= j {
            return i;
        }
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// A subtree under construction: its lights, and its nodes, which are those of
/// indices `base ..` in the tree (a subtree of n lights has 2n − 1 nodes);
/// its lights get ids `first ..`.
struct Subtree<'a> {
    prims: &'a mut [Prim],
    nodes: &'a mut [Node],
    base: u32,
    first: u32,
}

/// Pending work of the serial build: lights `start..end` under local node `node`.
struct Task {
    start: usize,
    end: usize,
    node: usize,
    centroids: Aabb,
}

impl<'a> Subtree<'a> {
    /// Builds the subtree and returns its root's full-precision bounds. Large
    /// subtrees split here: two large halves are built in parallel; when one
    /// half is small it is built at once and the loop goes on with the other,
    /// so lopsided chains of splits do not recurse.
    fn build(self, grid: &Grid, centroids: Aabb) -> LightBounds {
        let (mut tree, mut centroids) = (self, centroids);
        // (node, its topology, bounds of the half built, whether that is the left)
        let mut pending = Vec::new();
        let mut bounds = loop {
            if tree.prims.len() < PARALLEL_MIN {
                break tree.build_serial(grid, centroids);
            }
            let split = choose_split(tree.prims, centroids);
            let (root, left, right) = tree.split(split.mid);
            let topology = Node::topology(right.base, false);
            if left.prims.len() < PARALLEL_MIN {
                pending.push((root, topology, left.build_serial(grid, split.left), true));
                (tree, centroids) = (right, split.right);
            } else if right.prims.len() < PARALLEL_MIN {
                pending.push((root, topology, right.build_serial(grid, split.right), false));
                (tree, centroids) = (left, split.left);
            } else {
                let (l, r) = rayon::join(
                    || left.build(grid, split.left),
                    || right.build(grid, split.right),
                );
                let bounds = l.union(&r);
                *root = topology.with_bounds(&bounds, grid);
                break bounds;
            }
        };
        for (root, topology, built, built_is_left) in pending.into_iter().rev() {
            bounds = if built_is_left {
                built.union(&bounds)
            } else {
                bounds.union(&built)
            };
            *root = topology.with_bounds(&bounds, grid);
        }
        bounds
    }

    /// The root node and the two child subtrees when lights `..mid` go left.
    fn split(self, mid: usize) -> (&'a mut Node, Subtree<'a>, Subtree<'a>) {
        let (root, rest) = self.nodes.split_at_mut(1);
        let (left_nodes, right_nodes) = rest.split_at_mut(2 * mid - 1);
        let (left_prims, right_prims) = self.prims.split_at_mut(mid);
        let left = Subtree {
            prims: left_prims,
            nodes: left_nodes,
            base: self.base + 1,
            first: self.first,
        };
        let right = Subtree {
            prims: right_prims,
            nodes: right_nodes,
            base: self.base + 2 * mid as u32,
            first: self.first + mid as u32,
        };
        (&mut root[0], left, right)
    }

    /// Builds top-down with an explicit stack (any depth), then computes and
    /// quantises the bounds bottom-up.
    fn build_serial(self, grid: &Grid, centroids: Aabb) -> LightBounds {
        let Subtree {
            prims,
            nodes,
            base,
            first,
        } = self;
        let mut stack = vec![Task {
            start: 0,
            end: prims.len(),
            node: 0,
            centroids,
        }];
        while let Some(task) = stack.pop() {
            let light = first + task.start as u32;
            if task.end - task.start == 1 {
                nodes[task.node] = Node::topology(light, true);
                continue;
            }
            let split = choose_split(&mut prims[task.start..task.end], task.centroids);
            let right = task.node + 2 * split.mid;
            nodes[task.node] = Node::topology(base + right as u32, false);
            stack.push(Task {
                start: task.start + split.mid,
                end: task.end,
                node: right,
                centroids: split.right,
            });
            stack.push(Task {
                start: task.start,
                end: task.start + split.mid,
                node: task.node + 1,
                centroids: split.left,
            });
        }
        // In reverse depth-first order a node comes right after its left
        // subtree, which comes right after its right subtree: the children's
        // bounds are the top two entries of a stack.
        let mut done: Vec<LightBounds> = Vec::new();
        for node in nodes.iter_mut().rev() {
            let bounds = if node.is_leaf() {
                prims[(node.link - first) as usize].bounds()
            } else {
                let n = done.len();
                let bounds = done[n - 1].union(&done[n - 2]);
                done.truncate(n - 2);
                bounds
            };
            *node = node.with_bounds(&bounds, grid);
            done.push(bounds);
        }
        done[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::Rng as _;
    use rand_pcg::Pcg32;
    use std::time::Instant;

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

    fn max_depth(bvh: &LightBvh) -> usize {
        let mut deepest = 0;
        let mut stack = vec![(0usize, 0usize)];
        while let Some((i, depth)) = stack.pop() {
            let Some(node) = bvh.nodes.get(i) else {
                continue;
            };
            deepest = deepest.max(depth);
            if !node.is_leaf() {
                stack.push((i + 1, depth + 1));
                stack.push((node.link as usize, depth + 1));
            }
        }
        deepest
    }

    /// Probability that `sample` stops at a node whose children both have
    /// importance 0 (it then returns `None`).
    fn dead_end_mass(bvh: &LightBvh, p: Vec3, n: Vec3) -> f64 {
        let mut mass = 0.0;
        let mut stack = vec![(0usize, 1.0f64)];
        while let Some((i, weight)) = stack.pop() {
            if bvh.nodes[i].is_leaf() {
                continue;
            }
            match bvh.child_probabilities(i, p, n) {
                None => mass += weight,
                Some((l, r)) => {
                    if l > 0.0 {
                        stack.push((i + 1, weight * l));
                    }
                    if r > 0.0 {
                        stack.push((bvh.nodes[i].link as usize, weight * r));
                    }
                }
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
        if bvh.root_importance(p, n) > 0.0 {
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
    fn node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<Node>(), 32);
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
                assert_eq!(bvh.node_count(), 2 * count - 1);
                for (p, n) in receivers(&mut rng, &scene, 6) {
                    let dead = check_frequencies(&bvh, p, n, 10_000, &mut rng);
                    points += 1;
                    with_dead_ends += usize::from(dead > 0.0);
                    dead_mass = dead_mass.max(dead);
                }
            }
        }
        println!(
            "{with_dead_ends} of {points} shading points can reach a node whose children both \
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
                        let i = node.importance(&bvh.grid, p, n);
                        assert!(i.is_finite() && i >= 0.0);
                    }
                    for (light, &original) in order.iter().enumerate() {
                        let original = original as usize;
                        if scene.emitters[original].contributes(p, n, &mut rng) {
                            checked += 1;
                            assert!(scene.bounds[original].importance(p, n) > 0.0);
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
                assert!(b.importance(p, n) > 0.0, "p {p} n {n}");
                assert!(bvh.pmf(p, n, 0) > 0.0, "p {p} n {n}");
            }
        }
        // On the emitter's plane p is on neither side: no light, but finite.
        let on_plane = b.importance(Vec3::new(3.0, 0.5, 0.0), Vec3::X * -1.0);
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
        assert_eq!(b.importance(Vec3::ZERO, Vec3::Z), 0.0);
        assert!(b.importance(Vec3::ZERO, -Vec3::Z) > 0.0);
        assert!(b.importance(Vec3::ZERO, Vec3::ZERO) > 0.0);
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
            assert_eq!(node.importance(&bvh.grid, p, n), 0.0);
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
        assert_eq!(away.importance(Vec3::ZERO, Vec3::Z), 0.0);
        assert!(
            LightBounds {
                two_sided: true,
                ..away
            }
            .importance(Vec3::ZERO, Vec3::Z)
                > 0.0
        );
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
                let i = b.importance(p, n);
                assert!(i.is_finite() && i > 0.0, "{p} {n}: {i}");
            }
        }
        assert_eq!(point.importance(Vec3::NAN, Vec3::Z), 0.0);
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
        assert!(depth > 64);
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
            if bvh.root_importance(p, n) > 0.0 {
                assert!((total + dead_end_mass(&bvh, p, n) - 1.0).abs() < 1e-6);
            }
        }
        println!("deepest sampled leaf: {deepest_sampled}");
        assert!(deepest_sampled > 64);
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

    /// Depth of the leaf of `light`, found by its id range.
    fn leaf_depth(bvh: &LightBvh, light: usize) -> usize {
        let (mut index, mut first, mut depth) = (0, 0, 0);
        while !bvh.nodes[index].is_leaf() {
            let right_first = bvh.nodes[index].right_first(index, first);
            (index, first) = if light >= right_first {
                (bvh.nodes[index].link as usize, right_first)
            } else {
                (index + 1, first)
            };
            depth += 1;
        }
        depth
    }

    #[test]
    fn build_time_and_size() {
        for count in [50_000, 1_000_000] {
            let mut rng = Rand::new(9);
            let scene = random_scene(&mut rng, count);
            let start = Instant::now();
            let (bvh, _) = LightBvh::build(&scene.bounds);
            let seconds = start.elapsed().as_secs_f64();
            println!(
                "{count} lights: build {seconds:.3} s (beside the other tests), depth {}, {} nodes, \
                 {:.1} bytes/light",
                max_depth(&bvh),
                bvh.node_count(),
                bvh.bytes() as f64 / bvh.len() as f64
            );
        }
    }
}
