//! The distance and direction terms of the root's lanes, and of its children's, from tables: for
//! each lane k of such a node, the sum
//!     T_k(x) = Σ_{i in lane k} Φ_i / max(|x − x_i|², ε)
//! over its lights (x_i a light's box centre, ε = ¼ of a grid cell's largest side squared), and
//! the same sum split by direction, D_k,±a(x) = Σ_i Φ_i · max(0, ±ω_i,a) / max(|x − x_i|², ε)
//! (ω_i the unit vector from x toward x_i, a one of the three axes), on a grid with near-cubic
//! cells over the node's lights' box: 4096 points for the root, 512 for each of its children.
//! At a receiver p with unit normal n, T_k(p) is read by trilinear interpolation and the lane's
//! receiver-weighted sum Σ Φ_i · max(0, n·ω_i) / d_i² is estimated as T_k(p) · Σ_a n_a² ·
//! s_k,sign(n_a)·a, s = D / T at the grid point nearest p (an "ambient cube": exact for a normal
//! along an axis, as most surfaces of the town and the city are; otherwise a smooth stand-in, 1/√3
//! of the truth for a light straight along a diagonal normal, and above 0 for a light just below
//! the horizon of such a normal). That estimate, raised to at least its table's share of T_k
//! ([`TableKind`]) times the lane's weighted cosines, stands for the lane's Φ / d² times its
//! cosines (`lanes`). The root's lanes hold thousands of lights each, tens of metres across: one
//! distance cannot tell a receiver beside one of its lamps from one in the middle of nowhere, and
//! that is where most of the tree's excess error over the oracle sat (facade receivers 1–3 m from
//! lamps and neon had p/q of 0.26–0.5 at the root on the town); nor can the lane's bounding sphere
//! tell a facade facing its lights from one facing away. A point holds T as bfloat16 (0.4% at most
//! off) and each D as its share of T in 4 bits (D ≤ T; the share within 1/30): 40 bytes a point,
//! 160 KiB for the root's table and 20 KiB for each child's, 320 KiB in all, 0.32 bytes per light
//! at 1M lights (the children's tables and what they gave: `lanes`). Trilinear shares cost eight
//! points' decoding and gave 5.33 against 5.41 on the town (one camera sample's lit-surface MSE,
//! `lanes`), the city alike.
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

/// A table's size and how far its receiver-weighted estimate is trusted.
#[derive(Clone, Copy, Debug)]
pub(super) struct TableKind {
    /// Grid points in all, spread over the axes so that cells are near cubes.
    pub(super) points: usize,
    /// The least share of a lane's T · E · R (its table's plain sum times its weighted cosines)
    /// that the table's receiver-weighted estimate is raised to (`lanes`).
    pub(super) directed_floor: f32,
}

/// The root's table: 160 KiB.
pub(super) const ROOT_TABLE: TableKind = TableKind {
    points: 4096,
    directed_floor: 0.5,
};
/// Each table of a child of the root: 20 KiB. A child's lights fill about an eighth of the root's
/// box, so its cells are about the size of the root's. Its lanes are smaller clusters, whose
/// lights lie more to one side of a receiver: its estimate of what faces the receiver is trusted
/// further (one camera sample's lit-surface MSE − Var[ref] with a floor of ¾, ½, ¼, ⅛ and 1/20:
/// town at seed 1000 6.05, 5.96, 5.86, 5.78, 5.75; the Lambert 50k city at seeds 1000 / 2000
/// 1.180 / 1.188, 1.132 / 1.144, 1.114 / 1.124, 1.133 / 1.142, 1.190 / 1.204).
const CHILD_TABLE: TableKind = TableKind {
    points: 512,
    directed_floor: 0.25,
};
/// The code of a direction sum equal to T (four bits).
const SHARE_MAX: f32 = 15.0;
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

/// The tables of the root (node 0) and of the root's children, by node index.
#[derive(Clone, Debug, Default)]
pub(super) struct NearTables {
    /// Entry i: node i's table, if it has one; at most 1 + [`LANES`] entries.
    tables: Vec<Option<NearField>>,
}

impl NearTables {
    /// The tables of the root of `nodes` (`reach`: their lanes' [`Reach`]) and of its children,
    /// each over its own lights' `points` (in leaf order, so a node's are one run); see
    /// [`NearField::build`].
    pub(super) fn build(
        nodes: &[WideNode],
        reach: &[Reach],
        points: &[PowerPoint],
        avx2: bool,
    ) -> NearTables {
        let Some(root) = nodes.first() else {
            return NearTables::default();
        };
        let mut tables = vec![NearField::build(nodes, reach, points, 0, ROOT_TABLE, avx2)];
        let ends = lane_ends(root, points.len());
        for k in (0..LANES).filter(|&k| root.interior & (1 << k) != 0) {
            let child = root.child(k) as usize;
            let lights = &points[root.first[k] as usize..ends[k]];
            if tables.len() <= child {
                tables.resize_with(child + 1, || None);
            }
            tables[child] = NearField::build(nodes, reach, lights, child, CHILD_TABLE, avx2);
        }
        NearTables { tables }
    }

    /// The terms of node `index`'s lanes at a receiver at `p` with unit normal `n`: `None` for
    /// a node without a table or a receiver outside its grid.
    #[inline(always)]
    pub(super) fn at(&self, index: usize, p: Vec3, n: Vec3) -> Option<NearTerms> {
        self.tables.get(index)?.as_ref()?.at(p, n)
    }

    /// Node `index`'s table.
    #[cfg(test)]
    pub(super) fn of(&self, index: usize) -> Option<&NearField> {
        self.tables.get(index)?.as_ref()
    }

    /// Heap bytes held.
    pub(super) fn bytes(&self) -> usize {
        self.tables.iter().flatten().map(NearField::bytes).sum()
    }
}

/// The end (one past the last light id) of each lane's range in `node`, whose range ends at
/// `end`: the next used lane's first id, or `end` for the last (unused lanes: `end`).
pub(super) fn lane_ends(node: &WideNode, end: usize) -> [usize; LANES] {
    std::array::from_fn(|k| node.lane_end(k, end))
}

/// The table over one node's lanes (see the module header).
#[derive(Clone, Debug)]
pub(super) struct NearField {
    /// Grid point (i, j, k) lies at `lo` + `cell` · (i, j, k), i < `dims[0]` and so on.
    pub(super) lo: Vec3,
    pub(super) cell: Vec3,
    pub(super) dims: [usize; 3],
    /// dims − 1 per axis, in f32: the largest grid coordinate.
    last: Vec3,
    /// Point (i, j, k) at i + dims[0]·(j + dims[1]·k): the eight lanes' T as bfloat16 codes.
    plain: Vec<[u16; LANES]>,
    /// The same point's D / T in units of 1/15, four bits a lane ([`share_shift`]; `[2a]` for
    /// +a, `[2a + 1]` for −a).
    shares: Vec<[u32; 6]>,
    /// [`TableKind::directed_floor`].
    directed_floor: f32,
}

/// T and D (see the module header) of the eight lanes at one grid point, in f32 as they are added
/// up; `toward[2a]` for +a, `toward[2a + 1]` for −a.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    plain: [f32; LANES],
    toward: [[f32; LANES]; 6],
}

impl Sums {
    /// T as bfloat16 codes.
    fn plain_codes(&self) -> [u16; LANES] {
        self.plain.map(encode_sum)
    }

    /// D / T in units of 1/15 (0 where T is 0), four bits a lane.
    fn share_codes(&self) -> [u32; 6] {
        self.toward.map(|d| {
            (0..LANES).fold(0, |word, k| {
                let t = self.plain[k];
                let share = if t > 0.0 { d[k] / t } else { 0.0 };
                let code = (share * SHARE_MAX).round().clamp(0.0, SHARE_MAX) as u32;
                word | code << share_shift(k)
            })
        })
    }
}

/// A table read at a receiver with unit normal n: each of its node's lanes' T, its estimate
/// T · Σ_a n_a² · s_sign(n_a)·a of the receiver-weighted sum (see the module header), and the
/// table's [`TableKind::directed_floor`].
#[derive(Clone, Copy, Debug)]
pub(super) struct NearTerms {
    pub(super) plain: [f32; LANES],
    pub(super) directed: [f32; LANES],
    pub(super) directed_floor: f32,
}

impl NearField {
    /// The table of node `node` of `nodes` (`reach`: their lanes' [`Reach`]), of `kind`, on a
    /// grid of at most `kind.points` points over the box of its lights' `points` widened on each
    /// side by [`MARGIN`] of its size along that axis (of its largest side along an axis without
    /// extent); `None` for a node that does not exist, no lights, or lights all at one point.
    /// `avx2` (true only where the CPU has AVX2 and FMA) sums with the copy compiled for them,
    /// which gives the same table.
    pub(super) fn build(
        nodes: &[WideNode],
        reach: &[Reach],
        points: &[PowerPoint],
        node: usize,
        kind: TableKind,
        avx2: bool,
    ) -> Option<NearField> {
        if node >= nodes.len() || points.is_empty() {
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
        let dims = dims(size, kind.points);
        let cell = size / Vec3::from_array(dims.map(|d| (d - 1) as f32));
        let floor = floor(cell);
        let small = SMALL * cell.max_element();
        let sums = LaneSums {
            nodes,
            reach,
            floor,
            small,
            node,
        };
        let (plain, shares) = (0..dims.iter().product())
            .into_par_iter()
            .map(|i| {
                let at = [
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                ];
                let x = lo + cell * Vec3::from_array(at.map(|a| a as f32));
                let sums = sums.at(x, avx2);
                (sums.plain_codes(), sums.share_codes())
            })
            .unzip();
        Some(NearField {
            lo,
            cell,
            last: Vec3::from_array(dims.map(|d| (d - 1) as f32)),
            dims,
            plain,
            shares,
            directed_floor: kind.directed_floor,
        })
    }

    /// The terms of the table's node's lanes at `p` for a receiver with unit normal `n`,
    /// interpolated; `None` outside the grid.
    #[inline(always)]
    pub(super) fn at(&self, p: Vec3, n: Vec3) -> Option<NearTerms> {
        let t = (p - self.lo) / self.cell;
        if !(t.min_element() >= 0.0 && t.cmple(self.last).all()) {
            return None;
        }
        let base = t.floor().min(self.last - 1.0);
        let f = t - base;
        // SAFETY: 0 ≤ base ≤ dims − 2 (checked above, which a NaN fails): each component is a
        // whole number below 2³², so each conversion is exact.
        let (i, j, k) = unsafe {
            (
                base.x.to_int_unchecked::<u32>() as usize,
                base.y.to_int_unchecked::<u32>() as usize,
                base.z.to_int_unchecked::<u32>() as usize,
            )
        };
        let (row, slab) = (self.dims[0], self.dims[0] * self.dims[1]);
        let first = i + row * j + slab * k;
        // The cell's eight points, checked once (as one comparison, not eight bounds checks):
        // corner c = (c & 1, c >> 1 & 1, c >> 2) lies at `first + offsets[c]`, the farthest at
        // `first + slab + row + 1`.
        let last = first + slab + row + 1;
        if last >= self.plain.len() || last >= self.shares.len() {
            return None;
        }
        let offsets = [
            0,
            1,
            row,
            row + 1,
            slab,
            slab + 1,
            slab + row,
            slab + row + 1,
        ];
        let (wx, wy, wz) = ([1.0 - f.x, f.x], [1.0 - f.y, f.y], [1.0 - f.z, f.z]);
        // The direction sums facing n along each axis, and the weights n_a² of their terms.
        let facing = [
            usize::from(n.x < 0.0),
            2 + usize::from(n.y < 0.0),
            4 + usize::from(n.z < 0.0),
        ];
        let along = [n.x * n.x, n.y * n.y, n.z * n.z];
        // Plain loops rather than array constructors and `map`: a closure the compiler leaves out
        // of line loses the caller's FMA and calls the library's fused multiply-add.
        let mut plain = [0.0f32; LANES];
        for (c, offset) in offsets.into_iter().enumerate() {
            let weight = wx[c & 1] * wy[(c >> 1) & 1] * wz[c >> 2];
            // SAFETY: first + offset ≤ last, which is in bounds (checked above).
            let codes = unsafe { self.plain.get_unchecked(first + offset) };
            for l in 0..LANES {
                plain[l] = weight.mul_add(decode_sum(codes[l]), plain[l]);
            }
        }
        // The shares of the grid point nearest p.
        let nearest = usize::from(f.x >= 0.5)
            + row * usize::from(f.y >= 0.5)
            + slab * usize::from(f.z >= 0.5);
        // SAFETY: first + nearest ≤ last, which is in bounds (checked above).
        let nearest = unsafe { self.shares.get_unchecked(first + nearest) };
        let (x, y, z) = (
            share_codes(nearest[facing[0]]),
            share_codes(nearest[facing[1]]),
            share_codes(nearest[facing[2]]),
        );
        let mut directed = [0.0f32; LANES];
        for l in 0..LANES {
            directed[l] =
                plain[l] * along[2].mul_add(z[l], along[1].mul_add(y[l], along[0] * x[l]));
        }
        Some(NearTerms {
            plain,
            directed,
            directed_floor: self.directed_floor,
        })
    }

    /// The eight lanes' T at grid point `point` (as in [`NearField::at`]'s indexing).
    #[cfg(test)]
    pub(super) fn plain(&self, point: usize) -> [f32; LANES] {
        self.plain[point].map(decode_sum)
    }

    /// The eight lanes' D / T at grid point `point` for direction `d` (2a for +a, 2a + 1 for −a).
    #[cfg(test)]
    pub(super) fn share(&self, point: usize, d: usize) -> [f32; LANES] {
        share_codes(self.shares[point][d])
    }

    /// Heap bytes held.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.plain.as_slice()) + std::mem::size_of_val(self.shares.as_slice())
    }
}

/// Grid points along each axis of a box of `size`: at least 2, at most `points_max` in all, added
/// one at a time along the axis of the longest cell.
fn dims(size: Vec3, points_max: usize) -> [usize; 3] {
    let mut dims = [2usize; 3];
    loop {
        let cell = |a: usize| size[a] / (dims[a] - 1) as f32;
        let axis = (0..3)
            .max_by(|&a, &b| cell(a).total_cmp(&cell(b)))
            .unwrap_or(0);
        let more = dims.iter().product::<usize>() / dims[axis] * (dims[axis] + 1);
        if more > points_max {
            return dims;
        }
        dims[axis] += 1;
    }
}

/// ε of the module header for grid cells of sides `cell`.
pub(super) fn floor(cell: Vec3) -> f32 {
    0.25 * cell.max_element() * cell.max_element()
}

/// T and D at x before they are coded (see the module header) over the lanes of the root of
/// `nodes` and their `reach`, for a table of grid cells `cell`, summed by the portable copy or,
/// with `avx2`, the AVX2 one.
#[cfg(test)]
pub(super) fn sums_at(
    nodes: &[WideNode],
    reach: &[Reach],
    cell: Vec3,
    x: Vec3,
    avx2: bool,
) -> ([f32; LANES], [[f32; LANES]; 6]) {
    let sums = LaneSums {
        nodes,
        reach,
        floor: floor(cell),
        small: SMALL * cell.max_element(),
        node: 0,
    };
    let sums = sums.at(x, avx2);
    (sums.plain, sums.toward)
}

/// What [`LaneSums::node_sums`] reads: the tree, each lane's R ([`Reach`]), ε, the R up to
/// which a lane is summed whole, and the node whose lanes are summed.
struct LaneSums<'a> {
    nodes: &'a [WideNode],
    reach: &'a [Reach],
    floor: f32,
    small: f32,
    node: usize,
}

impl LaneSums<'_> {
    /// T and D (see the module header) at grid point x, from the node down; with `avx2` (which
    /// only a CPU with AVX2 and FMA may ask for) by the copy compiled for it, the same bits.
    fn at(&self, x: Vec3, avx2: bool) -> Sums {
        let mut sums = Sums::default();
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: the caller asks for AVX2 only where the CPU reported AVX2 and FMA.
            unsafe { self.node_sums_avx2(self.node, x, &mut sums) };
            return sums;
        }
        let _ = avx2;
        self.node_sums(self.node, x, &mut sums);
        sums
    }

    /// [`node_sums_with`](Self::node_sums_with) recursing into itself.
    fn node_sums(&self, index: usize, x: Vec3, sums: &mut Sums) {
        self.node_sums_with(index, x, sums, |child, sums| self.node_sums(child, x, sums));
    }

    /// [`node_sums`](Self::node_sums) compiled for AVX2: the eight lanes in one register. The
    /// same operations lane by lane (nothing is contracted into fused multiply-adds), so the
    /// same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn node_sums_avx2(&self, index: usize, x: Vec3, sums: &mut Sums) {
        self.node_sums_with(index, x, sums, |child, sums| {
            // SAFETY: reached only from `node_sums_avx2`, which the CPU can run.
            unsafe { self.node_sums_avx2(child, x, sums) }
        });
    }

    /// Writes into `sums` T and D (see the module header) over the lights of each lane of node
    /// `index` at x, lanes far from x or small taken whole at their power centre. The tests and
    /// whole terms of the eight lanes are computed together (array by array, so they
    /// vectorise); only the lanes to open recurse (`child_sums` of their node), and each sums
    /// its child's lanes in lane order.
    #[inline(always)]
    fn node_sums_with(
        &self,
        index: usize,
        x: Vec3,
        sums: &mut Sums,
        child_sums: impl Fn(usize, &mut Sums),
    ) {
        let wide = &self.nodes[index];
        let node = Decoded::of(wide);
        let reach = &self.reach[index];
        // x − c and x − c_Φ, axis by axis (their squares are those of c − x and c_Φ − x), in
        // plain loops: an array `map` left a copy of the arrays behind.
        let (mut dc, mut dp) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3]);
        for a in 0..3 {
            for k in 0..LANES {
                dc[a][k] = x[a] - node.centre[a][k];
                dp[a][k] = x[a] - node.power_centre[a][k];
            }
        }
        let mut open = [false; LANES];
        let mut inverse = [0.0f32; LANES];
        for k in 0..LANES {
            // |x − c|² as glam's `distance_squared` adds it, x then y then z.
            let centre_sq = dc[0][k] * dc[0][k] + dc[1][k] * dc[1][k] + dc[2][k] * dc[2][k];
            let power_sq = dp[0][k] * dp[0][k] + dp[1][k] * dp[1][k] + dp[2][k] * dp[2][k];
            let power_distance = power_sq.sqrt();
            let far = (centre_sq.sqrt() > OPEN * node.radius[k])
                | (reach[k] <= self.small)
                | (power_distance > OPEN * reach[k]);
            let phi = node.signed_phi[k].abs();
            sums.plain[k] = phi / power_sq.max(self.floor);
            open[k] = !far & (phi != 0.0) & (wide.interior & (1 << k) != 0);
            // 1 / |x − c_Φ| (0 for a power centre at x: its term counts in T only).
            let recip = 1.0 / power_distance;
            inverse[k] = if recip.is_finite() && recip > 0.0 {
                recip
            } else {
                0.0
            };
        }
        // ω, the unit vector from x to the power centre: −(x − c_Φ) / |x − c_Φ|.
        for (a, from) in dp.iter().enumerate() {
            for k in 0..LANES {
                let omega = -from[k] * inverse[k];
                sums.toward[2 * a][k] = sums.plain[k] * omega.max(0.0);
                sums.toward[2 * a + 1][k] = sums.plain[k] * (-omega).max(0.0);
            }
        }
        for k in 0..LANES {
            if open[k] {
                let mut child = Sums::default();
                child_sums(wide.child(k) as usize, &mut child);
                sums.plain[k] = child.plain.iter().sum();
                for (toward, child) in sums.toward.iter_mut().zip(&child.toward) {
                    toward[k] = child.iter().sum();
                }
            }
        }
    }
}

/// A sum ≥ 0 as a bfloat16 code (the upper half of its f32 bits, rounded to nearest; finite sums
/// stay finite).
fn encode_sum(sum: f32) -> u16 {
    let bits = sum.to_bits();
    let rounded = (bits + 0x7FFF + ((bits >> 16) & 1)) >> 16;
    rounded.min(0x7F7F) as u16
}

/// The sum of an [`encode_sum`] code.
#[inline(always)]
fn decode_sum(code: u16) -> f32 {
    f32::from_bits(u32::from(code) << 16)
}

/// The eight lanes' shares in a word of four-bit codes ([`share_shift`]), in units of 1/15.
#[inline(always)]
fn share_codes(word: u32) -> [f32; LANES] {
    // One shift per lane by a constant: a single SIMD shift where the caller has AVX2.
    let mut shares = [0.0; LANES];
    for (k, share) in shares.iter_mut().enumerate() {
        *share = ((word >> share_shift(k)) & 0xF) as f32 * (1.0 / SHARE_MAX);
    }
    shares
}

/// Where lane k's four-bit share code sits in its word: lanes 0–3 in the low nibbles of bytes
/// 0–3, lanes 4–7 in their high nibbles (`share_codes` reads lane k by one shift of the word).
#[inline(always)]
const fn share_shift(k: usize) -> usize {
    8 * (k % 4) + 4 * (k / 4)
}
