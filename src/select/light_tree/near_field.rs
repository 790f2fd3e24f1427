//! The root's distance term from a table: for each root lane k, the sum
//!     T_k(x) = Σ_{i in lane k} Φ_i / max(|x − x_i|², ε)
//! over its lights (x_i a light's box centre, ε = ¼ of a grid cell's largest side squared), on a
//! grid of 4096 points with near-cubic cells over the lights' box, read at a receiver by trilinear interpolation, in place
//! of the lane's Φ / d² (`lanes`). The root's lanes hold thousands of lights each, tens of metres
//! across: one distance cannot tell a receiver beside one of its lamps from one in the middle of
//! nowhere, and that is where most of the tree's excess error over the oracle sat (facade
//! receivers 1–3 m from lamps and neon had p/q of 0.26–0.5 at the root on the town). The sums
//! are built from the tree itself (Barnes–Hut): a lane whose sphere is far from the grid point
//! (distance > [`OPEN`] radii) counts as its power at its power centre, a nearer one is opened.
//! Receivers outside the grid keep the lane's own term. Any positive value keeps the choice
//! unbiased: `sample` and `pmf` read the same table.

use glam::Vec3;
use rayon::prelude::*;

use super::*;

/// Grid points in all (the table's 128 KB), spread over the axes so that cells are near cubes.
const POINTS: usize = 4096;
/// The grid's margin around the lights, as a share of their box's size.
const MARGIN: f32 = 0.05;
/// A lane is summed as one point when its sphere's centre is more than this many radii away.
const OPEN: f32 = 4.0;

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
    /// The table of `nodes`' root, on a grid over the box of the lights' `points` widened on
    /// each side by [`MARGIN`] of its size along that axis (of its largest side along an axis
    /// without extent); `None` for an empty tree or lights all at one point.
    pub(super) fn build(nodes: &[WideNode], points: &[PowerPoint]) -> Option<NearField> {
        let root = Decoded::of(nodes.first()?);
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
        let points = (0..dims.iter().product())
            .into_par_iter()
            .map(|i| {
                let at = [
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                ];
                let x = lo + cell * Vec3::from_array(at.map(|a| a as f32));
                std::array::from_fn(|k| lane_sum(nodes, &root, 0, k, x, floor))
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

/// Σ Φ_i / max(|x − x_i|², `floor`) over the lights of lane `k` of node `index` (decoded as
/// `node`), far lanes taken whole at their power centre.
fn lane_sum(
    nodes: &[WideNode],
    node: &Decoded,
    index: usize,
    k: usize,
    x: Vec3,
    floor: f32,
) -> f32 {
    let phi = node.signed_phi[k].abs();
    if phi == 0.0 {
        return 0.0;
    }
    let far = x.distance(centre(&node.centre, k)) > OPEN * node.radius[k];
    let child = nodes[index].child(k);
    if far || child & LIGHT_LANE != 0 {
        return phi / x.distance_squared(centre(&node.power_centre, k)).max(floor);
    }
    let below = Decoded::of(&nodes[child as usize]);
    (0..LANES)
        .map(|j| lane_sum(nodes, &below, child as usize, j, x, floor))
        .sum()
}
