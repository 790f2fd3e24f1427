//! The root's distance term from a table: for each root lane k, the sum
//!     T_k(x) = Σ_{i in lane k} Φ_i / max(|x − x_i|², ε)
//! over its lights (x_i a light's box centre, ε = ¼ of a grid cell's largest side squared), on a
//! grid of 4096 points with near-cubic cells over the lights' box, read at a receiver by
//! trilinear interpolation, in place of the lane's Φ / d² (`lanes`). The root's lanes hold
//! thousands of lights each, tens of metres across: one distance cannot tell a receiver beside
//! one of its lamps from one in the middle of nowhere, and that is where most of the tree's
//! excess error over the oracle sat (facade receivers 1–3 m from lamps and neon had p/q of
//! 0.26–0.5 at the root on the town).
//!
//! The sums are built from the tree itself (Barnes–Hut): a lane counts as its power at its power
//! centre c where the grid point lies more than [`OPEN`] times R from c (R bounds its lights'
//! distance from c: [`Reach`], kept by the collapse) or [`OPEN`] radii from its sphere's centre,
//! or where R is small against a cell ([`SMALL`]); otherwise it is opened. R is over the light
//! centres that the sums are over, while the sphere holds whole triangles: with the sphere alone,
//! the table of 1M random triangles in a cube (sizes up to 0.3 of its half-side: a few large
//! ones widen every sphere around them) took 4.5 s beside 0.8 s of tree; now 0.3 s. Receivers
//! outside the grid keep the lane's own term. Any positive value keeps the choice unbiased:
//! `sample` and `pmf` read the same table.

use glam::Vec3;
use rayon::prelude::*;

use super::*;

/// Grid points in all (the table's 128 KB), spread over the axes so that cells are near cubes.
const POINTS: usize = 4096;
/// The grid's margin around the lights, as a share of their box's size.
const MARGIN: f32 = 0.05;
/// A lane is summed as one point when its power centre is more than this many times R away (each
/// light's 1/d² is then within a factor (4/3)² of the centre's) or its sphere's centre more than
/// this many radii (within (5/3)²).
const OPEN: f32 = 4.0;
/// A lane is also summed as one point when R is at most this share of a cell's largest side (half
/// the floor's radius √ε): within √ε − R of the grid point every light's term is floored and the
/// point's is exact; farther out its lights lie at d ± R and their terms are within a factor 2.25
/// of the point's (the worst case: d = √ε).
const SMALL: f32 = 0.25;

/// The table over the root's lanes (see the module header).
#[derive(Clone, Debug)]
pub(super) struct NearField {
    /// Grid point (i, j, k) lies at `lo` + `cell` · (i, j, k), i < `dims[0]` and so on.
    pub(super) lo: Vec3,
    pub(super) cell: Vec3,
    pub(super) dims: [usize; 3],
    /// Point (i, j, k) at i + dims[0]·(j + dims[1]·k): the eight lanes' sums.
    pub(super) points: Vec<[f32; LANES]>,
}

impl NearField {
    /// The table of `nodes`' root (`reach`: their lanes' [`Reach`]), on a grid over the box of
    /// the lights' `points` widened on each side by [`MARGIN`] of its size along that axis (of
    /// its largest side along an axis without extent); `None` for an empty tree or lights all
    /// at one point.
    pub(super) fn build(
        nodes: &[WideNode],
        reach: &[Reach],
        points: &[PowerPoint],
    ) -> Option<NearField> {
        if nodes.is_empty() {
            return None;
        }
        let (lo, hi) = points.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), p| (lo.min(p.position), hi.max(p.position)),
        );
        // An axis along which the lights do not spread (a ceiling of panels) gets the margin of
        // the largest side, so that the grid is a slab rather than nothing.
        let extent = hi - lo;
        let margin = Vec3::select(
            extent.cmpgt(Vec3::ZERO),
            extent,
            Vec3::splat(extent.max_element()),
        ) * MARGIN;
        let (lo, hi) = (lo - margin, hi + margin);
        let size = hi - lo;
        if !(size.min_element() > 0.0 && size.is_finite()) {
            return None;
        }
        let dims = dims(size);
        let cell = size / Vec3::from_array(dims.map(|d| (d - 1) as f32));
        let floor = floor(cell);
        let small = SMALL * cell.max_element();
        let sums = LaneSums {
            nodes,
            reach,
            floor,
            small,
        };
        let points = (0..dims.iter().product())
            .into_par_iter()
            .map(|i| {
                let at = [
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                ];
                let x = lo + cell * Vec3::from_array(at.map(|a| a as f32));
                sums.node_sums(0, x)
            })
            .collect();
        Some(NearField {
            lo,
            cell,
            dims,
            points,
        })
    }

    /// The root lanes' sums at `p`, interpolated; `None` outside the grid.
    #[inline(always)]
    pub(super) fn at(&self, p: Vec3) -> Option<[f32; LANES]> {
        let t = (p - self.lo) / self.cell;
        let last = Vec3::from_array(self.dims.map(|d| (d - 1) as f32));
        if !(t.min_element() >= 0.0 && t.cmple(last).all()) {
            return None;
        }
        let base = t.floor().min(last - 1.0);
        let f = t - base;
        let [i, j, k] = base.to_array().map(|b| b as usize);
        let mut out = [0.0f32; LANES];
        for corner in 0..8 {
            let (dx, dy, dz) = (corner & 1, (corner >> 1) & 1, corner >> 2);
            let w = |d: usize, f: f32| if d == 1 { f } else { 1.0 - f };
            let weight = w(dx, f.x) * w(dy, f.y) * w(dz, f.z);
            let [nx, ny, _] = self.dims;
            let point = &self.points[(i + dx) + nx * ((j + dy) + ny * (k + dz))];
            for (out, &value) in out.iter_mut().zip(point) {
                *out += weight * value;
            }
        }
        Some(out)
    }

    /// Heap bytes held.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.points.as_slice())
    }
}

/// Grid points along each axis of a box of `size`: at least 2, at most [`POINTS`] in all, added
/// one at a time along the axis of the longest cell.
fn dims(size: Vec3) -> [usize; 3] {
    let mut dims = [2usize; 3];
    loop {
        let cell = |a: usize| size[a] / (dims[a] - 1) as f32;
        let axis = (0..3)
            .max_by(|&a, &b| cell(a).total_cmp(&cell(b)))
            .unwrap_or(0);
        let more = dims.iter().product::<usize>() / dims[axis] * (dims[axis] + 1);
        if more > POINTS {
            return dims;
        }
        dims[axis] += 1;
    }
}

/// ε of the module header for grid cells of sides `cell`.
pub(super) fn floor(cell: Vec3) -> f32 {
    0.25 * cell.max_element() * cell.max_element()
}

/// Lane `k`'s centre in `field` (a decoded node's centres or power centres).
fn centre(field: &[[f32; LANES]; 3], k: usize) -> Vec3 {
    Vec3::new(field[0][k], field[1][k], field[2][k])
}

/// What [`LaneSums::node_sums`] reads: the tree, each lane's R ([`Reach`]), ε and the R up to
/// which a lane is summed whole.
struct LaneSums<'a> {
    nodes: &'a [WideNode],
    reach: &'a [Reach],
    floor: f32,
    small: f32,
}

impl LaneSums<'_> {
    /// Σ Φ_i / max(|x − x_i|², ε) over the lights of each lane of node `index`, lanes far from
    /// x or small taken whole at their power centre. The tests and whole terms of the eight
    /// lanes are computed together (array by array, so they vectorise); only the lanes to open
    /// recurse, and each sums its child's lanes in lane order.
    fn node_sums(&self, index: usize, x: Vec3) -> [f32; LANES] {
        let wide = &self.nodes[index];
        let node = Decoded::of(wide);
        let reach = &self.reach[index];
        let mut sums = [0.0; LANES];
        let mut open = [false; LANES];
        for k in 0..LANES {
            let power_centre = centre(&node.power_centre, k);
            let far = (x.distance(centre(&node.centre, k)) > OPEN * node.radius[k])
                | (reach[k] <= self.small)
                | (x.distance(power_centre) > OPEN * reach[k]);
            let phi = node.signed_phi[k].abs();
            sums[k] = phi / x.distance_squared(power_centre).max(self.floor);
            open[k] = !far & (phi != 0.0) & (wide.interior & (1 << k) != 0);
        }
        for k in 0..LANES {
            if open[k] {
                let child = wide.child(k) as usize;
                sums[k] = self.node_sums(child, x).iter().sum();
            }
        }
        sums
    }
}
