//! The 8-wide tree that is traversed: each [`WideNode`] holds up to eight
//! children ("lanes") laid out field by field, so one node's importances are
//! computed together in SIMD lanes ([`super::lanes`]) and a choice descends
//! about three binary levels at once.
//!
//! [`collapse`] turns the binary build tree into wide nodes: starting from a
//! binary node it repeatedly opens the interior lane of largest r·Φ² (bounding
//! radius times squared power), replacing it in place by its two children,
//! until eight lanes are filled or only leaves remain; subtrees of at most 16
//! lights are cut with the fewest wide nodes instead ([`super::small_cut`]).
//! A node of two lights that its bounds cannot tell apart ([`is_pair`]: the
//! triangles of a quad) counts as a leaf: one lane, whose light is chosen in
//! proportion to power. Lanes keep light-id order, so each lane covers a
//! contiguous id range starting at `first`, and `pmf` can find the lane
//! holding a light without parent links. The nodes of a node's interior lanes
//! are consecutive, so one index per node finds them all.

use glam::{DVec3, Vec3, Vec3A};
use rayon::prelude::*;

use super::*;

/// Whether binary node `index` is one lane that is never opened: a leaf, or a pair ([`is_pair`]).
pub(super) fn is_unit(binary: &[Node], index: usize) -> bool {
    binary[index].is_leaf() || is_pair(binary, index)
}

/// Whether binary node `index` holds two lights that its bounds cannot tell apart: two leaves
/// (the two triangles of a quad, as a rule) whose union's bounding sphere is at most
/// [`PAIR_RADIUS`] times the larger of theirs and whose normals lie within a cone of cosine at
/// least [`PAIR_COS`]. Two lights with the same box and cone have importances in the ratio of
/// their powers, so such a pair is one lane whose light is then chosen in proportion to power
/// ([`WideNode::pairs`]).
pub(super) fn is_pair(binary: &[Node], index: usize) -> bool {
    let node = &binary[index];
    !node.is_leaf()
        && node.link as usize == index + 2
        && binary[index + 1].is_leaf()
        && binary[index + 2].is_leaf()
        && node.radius <= PAIR_RADIUS * binary[index + 1].radius.max(binary[index + 2].radius)
        && decode_cos(node.cones & COS_MAX) >= PAIR_COS
}

/// See [`is_pair`].
const PAIR_RADIUS: f32 = 1.25;
/// See [`is_pair`]: cos 3°.
const PAIR_COS: f32 = 0.998_63;

/// Children per wide node.
pub(super) const LANES: usize = 8;
/// Set in `child` when the lane is a single light (the other bits its id).
pub(super) const LIGHT_LANE: u32 = 1 << 31;
/// `first` of an unused lane: larger than every light id.
pub(super) const EMPTY_LANE: u32 = u32::MAX;

/// Up to eight children's bounds, one array per field (structure of arrays), coded compactly: 256
/// bytes, four cache lines, aligned to a cache line. Each child's bounding sphere has its centre on
/// a grid over the node's centres (16 bits an axis) and its radius as a 16-bit multiple of
/// `radius_step`, both rounded so the sphere still holds the child's box; the cone axis as three
/// 16-bit fractions of 1 (of the eight codes around it, the one of length nearest 1:
/// [`encode_axis`]), θo widened by the coding error; θe widened by the zero test's margin
/// (`REJECT_ANGLE`); cosines as [`encode_cos`] codes rounded down (every rounding enlarges the
/// bound).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub(super) struct WideNode {
    /// Centre codes: centre = `origin` + code · `step`, axis by axis.
    pub(super) centre: [[u16; LANES]; 3],
    /// Radius codes: radius = code · `radius_step`.
    pub(super) radius: [u16; LANES],
    /// Normal cone axis w: component = code · [`AXIS_STEP`].
    pub(super) axis: [[i16; LANES]; 3],
    /// cos θo of the normal cone ([`decode_cos`] code).
    pub(super) cos_o: [u16; LANES],
    /// cos θe of the emission spread ([`decode_cos`] code).
    pub(super) cos_e: [u16; LANES],
    /// Power Φ ([`encode_phi`] code: bfloat16, negative for two-sided children); 0 in unused lanes.
    pub(super) phi: [u16; LANES],
    /// The lane's power centre (its lights' box centres weighted by Φ) relative to its sphere:
    /// centre + code · radius / [`OFFSET_MAX`], axis by axis.
    pub(super) power_centre: [[i8; LANES]; 3],
    /// The spread σ of the lane's lights (RMS distance of their box centres from the power
    /// centre) in steps of radius / [`SPREAD_MAX`], four bits a lane: lane k in byte k / 2,
    /// low nibble for even k.
    pub(super) spread: [u8; LANES / 2],
    /// First light id of the lane's range ([`EMPTY_LANE`] if unused); a single light's id.
    pub(super) first: [u32; LANES],
    pub(super) origin: [f32; 3],
    pub(super) step: [f32; 3],
    pub(super) radius_step: f32,
    /// Index of the first child node; the interior lanes' nodes follow it in lane order.
    pub(super) children: u32,
    /// Bit k set: lane k holds a subtree (its node is a child), else a single light, a pair or
    /// nothing.
    pub(super) interior: u8,
    /// Bit k set: lane k holds two lights, `first[k]` and the next, of which one is chosen in
    /// proportion to its power Φ (the pmf's factor Φ_i / (Φ_a + Φ_b)). A lane is a pair where
    /// the build made a node of two lights that its bounds cannot tell apart ([`is_pair`]: the
    /// two triangles of a quad, as a rule). The render's `selection` line (`render SCENE --spp 1
    /// --width 64 --height 48 --selector bvh`), B per light with the 4 B of Φ, 6188a3f → d12379d
    /// (which added the pairs): 1M city 64.0 → 39.6, 50k city 67.7 → 43.0, town 75.6 → 53.4.
    pub(super) pairs: u8,
}

/// One unit of an axis component code.
pub(super) const AXIS_STEP: f32 = 1.0 / i16::MAX as f32;

impl WideNode {
    /// A node with every lane unused (Φ = 0: importance 0).
    pub(super) fn empty() -> WideNode {
        WideNode {
            centre: [[0; LANES]; 3],
            radius: [0; LANES],
            axis: [[0; LANES], [0; LANES], [i16::MAX; LANES]],
            cos_o: [COS_MAX as u16; LANES],
            cos_e: [COS_MAX as u16; LANES],
            phi: [0; LANES],
            power_centre: [[0; LANES]; 3],
            spread: [0; LANES / 2],
            first: [EMPTY_LANE; LANES],
            origin: [0.0; 3],
            step: [0.0; 3],
            radius_step: 0.0,
            children: 0,
            interior: 0,
            pairs: 0,
        }
    }

    /// The child of lane `k`: the index of its node, or `LIGHT_LANE | light id`.
    #[inline(always)]
    pub(super) fn child(&self, k: usize) -> u32 {
        let bit = 1u8 << k;
        if self.interior & bit != 0 {
            self.children + (self.interior & (bit - 1)).count_ones()
        } else {
            LIGHT_LANE | self.first[k]
        }
    }

    /// One past the last light id of lane `k`'s range, the node's range ending at `end`: the next
    /// used lane's first id, or `end` after the last used lane.
    #[inline(always)]
    pub(super) fn lane_end(&self, k: usize, end: usize) -> usize {
        self.first[k + 1..]
            .iter()
            .find(|&&first| first != EMPTY_LANE)
            .map_or(end, |&next| next as usize)
    }

    /// The node of `lanes` (binary nodes with their ranges), interior lanes' nodes numbered from
    /// `children` on; the fields that depend on the lanes' [`Moments`] are left to
    /// [`finish`](Self::finish), which needs the children's.
    fn new(binary: &[Node], grid: &Grid, lanes: &[Lane], children: u32) -> WideNode {
        let mut node = WideNode::empty();
        let mut bounds = [(binary[0].bounds(grid), Vec3::ZERO, 0.0); LANES];
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for (lane, bounds) in lanes.iter().zip(&mut bounds) {
            let b = &binary[lane.index];
            let decoded = b.bounds(grid);
            let centre = decoded.centre_and_half_diagonal_sq().0;
            (lo, hi) = (lo.min(centre), hi.max(centre));
            *bounds = (decoded, centre, b.radius);
        }
        let centres = Grid::new(lo, hi);
        let mut codes = [([0u16; 3], 0.0f64); LANES];
        for (&(_, c, r), code) in bounds.iter().zip(&mut codes).take(lanes.len()) {
            let q = centres.encode(c, false);
            let moved = centres.decode(q).as_dvec3().distance(c.as_dvec3());
            *code = (q, f64::from(r) + moved);
        }
        let radius_step = radius_step(codes.iter().map(|&(_, r)| r));
        (node.origin, node.step) = (centres.origin.into(), centres.step.into());
        node.radius_step = radius_step;
        node.children = children;
        for (k, ((lane, (b, _, _)), (centre, radius))) in
            lanes.iter().zip(&bounds).zip(&codes).enumerate()
        {
            for (field, &code) in node.centre.iter_mut().zip(centre) {
                field[k] = code;
            }
            node.radius[k] = encode_radius(*radius, radius_step);
            let (axis, cos_o) = encode_axis(b.w, b.cos_theta_o);
            for (field, code) in node.axis.iter_mut().zip(axis) {
                field[k] = code;
            }
            node.cos_o[k] = cos_o as u16;
            node.cos_e[k] = encode_cos(widened(b.cos_theta_e, REJECT_ANGLE)) as u16;
            node.phi[k] = encode_phi(b.phi, b.two_sided);
            node.first[k] = lane.first as u32;
            if !is_unit(binary, lane.index) {
                node.interior |= 1 << k;
            } else if is_pair(binary, lane.index) {
                debug_assert_eq!(binary[lane.index + 1].link as usize, lane.first);
                node.pairs |= 1 << k;
            } else {
                debug_assert_eq!(binary[lane.index].link as usize, lane.first);
            }
        }
        node
    }

    /// Sets each used lane's power centre and spread from its [`Moments`]: a single light's
    /// from `points` (the lights' power points in leaf order), an interior lane's from
    /// `child_moments` of its node (the total of that node's lanes, which are finished
    /// first). Returns the lanes' [`Reach`] and the node's moments, its lanes' merged in
    /// lane order.
    fn finish(
        &mut self,
        points: &[PowerPoint],
        child_moments: impl Fn(u32) -> Moments,
    ) -> (Reach, Moments) {
        let mut reach = [0.0; LANES];
        let mut total: Option<Moments> = None;
        let used = self
            .first
            .iter()
            .take_while(|&&first| first != EMPTY_LANE)
            .count();
        for (k, lane_reach) in reach.iter_mut().enumerate().take(used) {
            let child = self.child(k);
            let moments = if child & LIGHT_LANE != 0 {
                let first = (child & !LIGHT_LANE) as usize;
                let moments = Moments::of(&points[first]);
                if self.pairs & (1 << k) != 0 {
                    moments.merge(&Moments::of(&points[first + 1]))
                } else {
                    moments
                }
            } else {
                child_moments(child)
            };
            *lane_reach = self.set_moments(k, &moments);
            total = Some(total.map_or(moments, |t| t.merge(&moments)));
        }
        (reach, total.expect("a wide node has a lane"))
    }

    /// Codes lane `k`'s power centre c and spread σ relative to its coded sphere; returns the
    /// lane's reach: the distance from the coded c to the farthest corner of the box of its
    /// lights' centres.
    fn set_moments(&mut self, k: usize, moments: &Moments) -> f32 {
        let code = [self.centre[0][k], self.centre[1][k], self.centre[2][k]];
        let sphere_centre = decode_on_grid(self.origin.into(), self.step.into(), code).as_dvec3();
        let coded_radius = f32::from(self.radius[k]) * self.radius_step;
        let offset = encode_offset(moments.centre - sphere_centre, coded_radius);
        let coded_offset =
            DVec3::from_array(offset.map(f64::from)) * f64::from(coded_radius / OFFSET_MAX);
        // The box relative to the sphere's centre: rounding x − o is monotonic in x, so the
        // f32 box moved once is the box of the points' f64 offsets, exactly.
        let (lo, hi) = (
            moments.lo.as_dvec3() - sphere_centre,
            moments.hi.as_dvec3() - sphere_centre,
        );
        for (field, code) in self.power_centre.iter_mut().zip(offset) {
            field[k] = code;
        }
        self.spread[k / 2] |= encode_spread(moments.spread(), coded_radius) << (4 * (k % 2));
        (lo - coded_offset)
            .abs()
            .max((hi - coded_offset).abs())
            .length() as f32
    }

    /// The lane whose id range holds `light`: the last used lane starting at or before it,
    /// found by counting the used lanes that do (lanes are in id order), eight compares at once.
    #[inline(always)]
    pub(super) fn lane_of(&self, light: u32) -> Option<usize> {
        let mut at_or_before = 0;
        for &first in &self.first {
            at_or_before += usize::from((first != EMPTY_LANE) & (first <= light));
        }
        at_or_before.checked_sub(1)
    }
}

/// A binary node as a candidate lane: its index, the first id of its range and how many
/// lights the range holds.
#[derive(Clone, Copy, Debug)]
pub(super) struct Lane {
    pub(super) index: usize,
    pub(super) first: usize,
    pub(super) count: usize,
}

/// For each lane of a wide node, a bound R on the distance of its lights' box centres from its
/// coded power centre (that of the farthest corner of the centres' box), which the near-field
/// tables ([`super::near_field`]) read; 0 in unused lanes.
pub(super) type Reach = [f32; LANES];

/// Below lanes of fewer lights the subtrees are collapsed by one rayon task each.
const PARALLEL_COLLAPSE_MIN: usize = 1 << 14;

/// The wide tree of the binary depth-first tree `binary` (root at 0): wide node 0 is the root,
/// and the nodes of a node's interior lanes are consecutive, after it. The top is collapsed
/// first, down to lanes of fewer than [`PARALLEL_COLLAPSE_MIN`] lights, whose nodes get their
/// places there; the subtrees below those lanes are counted, given their ranges of the list,
/// and collapsed into them in parallel. Each node's power centres and spreads are set once its
/// children's are, from their [`Moments`] (its own lights are never summed again): within each
/// subtree, then over the top in reverse order (a node's children come after it). Also returns
/// each node's [`Reach`], in the same order.
pub(super) fn collapse(
    binary: &[Node],
    grid: &Grid,
    points: &[PowerPoint],
) -> (Vec<WideNode>, Vec<Reach>) {
    if binary.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let root = Lane {
        index: 0,
        first: 0,
        count: binary.len().div_ceil(2),
    };
    // (lane, index of its node) of each subtree left for later.
    let mut deferred = Vec::new();
    let mut wide = vec![WideNode::empty()];
    let mut reach = vec![[0.0; LANES]];
    let mut pending = vec![(root, 0)];
    let mut tables = Table::empty();
    while let Some((start, at)) = pending.pop() {
        let lanes = open(binary, start, &mut tables);
        let children = wide.len() as u32;
        for &lane in interior(binary, &lanes) {
            let child = (lane, wide.len());
            wide.push(WideNode::empty());
            reach.push([0.0; LANES]);
            if lane.count < PARALLEL_COLLAPSE_MIN {
                deferred.push(child);
            } else {
                pending.push(child);
            }
        }
        wide[at] = WideNode::new(binary, grid, &lanes, children);
    }
    // The nodes below each deferred lane's own.
    let counts: Vec<usize> = deferred
        .par_iter()
        .map(|&(lane, _)| count_wide(binary, lane) - 1)
        .collect();
    // Sized once: the nodes are over-aligned, so growing or shrinking the list would copy it
    // (the system allocator's realloc does not keep a 64-byte alignment).
    let (top, below): (usize, usize) = (wide.len(), counts.iter().sum());
    // Filled in parallel: 64 MB at 1M lights, which took about 20 ms on one core.
    // On huge pages: every choice reads a few nodes at random.
    crate::alloc::on_huge_pages(|| wide.reserve_exact(below));
    wide.par_extend(rayon::iter::repeat_n(WideNode::empty(), below));
    reach.par_extend(rayon::iter::repeat_n([0.0; LANES], below));
    let mut blocks = Vec::with_capacity(deferred.len());
    let (mut rest, mut rest_reach) = (&mut wide[top..], &mut reach[top..]);
    let mut base = top;
    for (&(lane, at), &count) in deferred.iter().zip(&counts) {
        let (block, after) = rest.split_at_mut(count);
        let (block_reach, after_reach) = rest_reach.split_at_mut(count);
        blocks.push((lane, at, (block, block_reach), base as u32));
        (rest, rest_reach) = (after, after_reach);
        base += count;
    }
    let roots: Vec<(usize, (WideNode, Reach, Moments))> = blocks
        .into_par_iter()
        .map(|(lane, at, block, base)| {
            let node = collapse_block(binary, grid, points, lane, block, base);
            (at, node)
        })
        .collect();
    let mut moments: Vec<Option<Moments>> = vec![None; top];
    for (at, (node, node_reach, node_moments)) in roots {
        (wide[at], reach[at], moments[at]) = (node, node_reach, Some(node_moments));
    }
    for at in (0..top).rev() {
        if moments[at].is_none() {
            let (node_reach, node_moments) = wide[at].finish(points, |child| {
                moments[child as usize].expect("a child comes after its node")
            });
            (reach[at], moments[at]) = (node_reach, Some(node_moments));
        }
    }
    (wide, reach)
}

/// A light's box centre and power Φ > 0: what a lane's power centre averages.
#[derive(Clone, Copy, Debug)]
pub(super) struct PowerPoint {
    pub(super) position: Vec3,
    pub(super) phi: f32,
}

/// The power moments of a set of lights' power points: ΣΦ, the power centre c = Σ Φ_i x_i / ΣΦ,
/// the Φ-weighted squared spread M₂ = Σ Φ_i |x_i − c|², and the points' box. Merged bottom-up
/// (Chan, Golub & LeVeque's pairwise update: c = c_a + (c_b − c_a)·Φ_b/Φ, M₂ = M₂a + M₂b +
/// |c_b − c_a|²·Φ_a Φ_b/Φ), so a lane's moments come from its children's, not from a pass over
/// its lights at every level, and M₂ never cancels as E|x|² − |c|² would.
#[derive(Clone, Copy, Debug)]
pub(super) struct Moments {
    phi: f64,
    centre: DVec3,
    m2: f64,
    lo: Vec3A,
    hi: Vec3A,
}

impl Moments {
    /// One light's: its point, with M₂ = 0.
    fn of(p: &PowerPoint) -> Moments {
        Moments {
            phi: f64::from(p.phi),
            centre: p.position.as_dvec3(),
            m2: 0.0,
            lo: p.position.into(),
            hi: p.position.into(),
        }
    }

    /// The moments of both sets together.
    fn merge(&self, other: &Moments) -> Moments {
        let phi = self.phi + other.phi;
        let d = other.centre - self.centre;
        Moments {
            phi,
            centre: self.centre + d * (other.phi / phi),
            m2: self.m2 + other.m2 + d.length_squared() * (self.phi * other.phi / phi),
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// The spread σ = (M₂ / ΣΦ)^½, the RMS distance of the points from c.
    fn spread(&self) -> f64 {
        (self.m2 / self.phi).max(0.0).sqrt()
    }
}

/// The interior lanes among `lanes`, in lane order.
fn interior<'a>(binary: &'a [Node], lanes: &'a [Lane]) -> impl Iterator<Item = &'a Lane> + 'a {
    lanes.iter().filter(|lane| !is_unit(binary, lane.index))
}

/// Collapses the subtree of interior lane `start`: returns its node, [`Reach`] and
/// [`Moments`] and writes the nodes below it and their reach into `block` (exactly their
/// number, from [`count_wide`]), whose first node has index `base` in the whole list.
fn collapse_block(
    binary: &[Node],
    grid: &Grid,
    points: &[PowerPoint],
    start: Lane,
    (block, block_reach): (&mut [WideNode], &mut [Reach]),
    base: u32,
) -> (WideNode, Reach, Moments) {
    let mut used = 0;
    let mut root = WideNode::empty();
    let mut pending = vec![(start, None)];
    // The pending lanes are taken depth first, so the wide nodes of a small subtree come one
    // after the other and share its table.
    let mut tables = Table::empty();
    while let Some((start, at)) = pending.pop() {
        let lanes = open(binary, start, &mut tables);
        let children = base + used as u32;
        for &lane in interior(binary, &lanes) {
            pending.push((lane, Some(used)));
            used += 1;
        }
        let node = WideNode::new(binary, grid, &lanes, children);
        match at {
            Some(at) => block[at] = node,
            None => root = node,
        }
    }
    debug_assert_eq!(used, block.len());
    // Children come after their node: in reverse order each node's children are finished.
    let mut moments = vec![None; block.len()];
    let child_moments = |moments: &[Option<Moments>], child: u32| -> Moments {
        moments[(child - base) as usize].expect("a child comes after its node")
    };
    for at in (0..block.len()).rev() {
        let (node_reach, node_moments) = block[at].finish(points, |c| child_moments(&moments, c));
        (block_reach[at], moments[at]) = (node_reach, Some(node_moments));
    }
    let (root_reach, root_moments) = root.finish(points, |c| child_moments(&moments, c));
    (root, root_reach, root_moments)
}

/// How many wide nodes the subtree of lane `start` makes: one for its root and one per
/// interior lane below.
pub(super) fn count_wide(binary: &[Node], start: Lane) -> usize {
    let mut count = 1;
    let mut pending = vec![start];
    let mut tables = Table::empty();
    while let Some(start) = pending.pop() {
        for &lane in interior(binary, &open(binary, start, &mut tables)) {
            if lane.count <= SMALL_SUBTREE {
                count += small_count(binary, lane, &mut tables);
            } else {
                count += 1;
                pending.push(lane);
            }
        }
    }
    count
}

/// The lanes of the wide node rooted at binary node `start`: `start` itself if it is a leaf;
/// for subtrees of at most [`SMALL_SUBTREE`] lights the cut with the fewest wide nodes
/// ([`small_cut`]); else its children, with the interior lane of largest
/// [`opening_priority`] opened while fewer than eight lanes are used. `tables` is
/// [`small_cut`]'s cache.
fn open(binary: &[Node], start: Lane, tables: &mut Table) -> OpenLanes {
    if start.count <= SMALL_SUBTREE && !is_unit(binary, start.index) {
        return small_cut(binary, start, tables);
    }
    let mut lanes = [None; LANES];
    lanes[0] = Some(start);
    open_more(binary, lanes, 1, |_| true)
}

/// `lanes` (the first `used` set) with, while fewer than eight are used, the interior lane of
/// largest [`opening_priority`] among those `may_open` allows replaced by its two children.
pub(super) fn open_more(
    binary: &[Node],
    mut lanes: [Option<Lane>; LANES],
    mut used: usize,
    may_open: impl Fn(&Lane) -> bool,
) -> OpenLanes {
    while used < LANES {
        let widest = lanes[..used]
            .iter()
            .enumerate()
            .filter_map(|(k, lane)| lane.map(|l| (k, l)))
            .filter(|(_, l)| !is_unit(binary, l.index) && may_open(l))
            .max_by(|a, b| {
                opening_priority(&binary[a.1.index])
                    .total_cmp(&opening_priority(&binary[b.1.index]))
            });
        let Some((k, lane)) = widest else { break };
        let (left, right) = halves(binary, lane);
        lanes.copy_within(k + 1..used, k + 2);
        lanes[k] = Some(left);
        lanes[k + 1] = Some(right);
        used += 1;
    }
    let mut open = OpenLanes {
        lanes: [lanes[0].expect("a wide node has a lane"); LANES],
        used,
    };
    for (to, from) in open.lanes.iter_mut().zip(lanes.into_iter().flatten()) {
        *to = from;
    }
    open
}

/// The two children of interior lane `lane` as lanes.
pub(super) fn halves(binary: &[Node], lane: Lane) -> (Lane, Lane) {
    let node = &binary[lane.index];
    let left = Lane {
        index: lane.index + 1,
        first: lane.first,
        count: (node.link as usize - lane.index) / 2,
    };
    let right = Lane {
        index: node.link as usize,
        first: node.right_first(lane.index, lane.first),
        count: lane.count - left.count,
    };
    (left, right)
}

/// Which interior lane a wide node opens first: the one of largest r·Φ², its bounding radius (how
/// loosely its importance is known) times the square of its power (a choice's variance weighs
/// squared contributions). Measured against opening by radius alone (`cargo bench --bench
/// selection_quality`, W²-weighted / mean / median χ² against the oracle, at bbac328, before the
/// small-subtree cut): town 15.7 / 2.81 / 1.18 → 13.6 / 2.03 / 1.11, 50k city 1.56 / 2.07 / 1.86 →
/// 1.27 / 1.69 / 1.61; r·Φ gave 16.0 / 2.26 / 1.10 and 1.46 / 1.72 / 1.47.
pub(super) fn opening_priority(node: &Node) -> f64 {
    f64::from(node.radius) * f64::from(node.phi).powi(2)
}

/// The lanes of one wide node, in light-id order: the first `used` of `lanes`.
pub(super) struct OpenLanes {
    lanes: [Lane; LANES],
    used: usize,
}

impl std::ops::Deref for OpenLanes {
    type Target = [Lane];

    fn deref(&self) -> &[Lane] {
        &self.lanes[..self.used]
    }
}
