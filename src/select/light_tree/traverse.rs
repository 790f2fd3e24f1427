//! The light tree: [`LightBvh::sample`] walks from the root choosing a child
//! with probability ∝ importance, down to a light or to a far lane, inside which it chooses a
//! light ∝ power (`power_prefix`); [`LightBvh::pmf`] descends towards a light id
//! multiplying the same per-node probabilities, so pmf(l) equals the
//! probability that `sample` returns l (a product of child probabilities along
//! the path, times the power share in a far lane; counting measure over light ids).

use glam::Vec3;
use rayon::prelude::*;

use super::*;
use crate::cpu::has_avx2_fma;

/// How many nodes from the root on are kept decoded ([`LightBvh::top`]).
const DECODED_TOP: usize = 1 + LANES;

/// A chosen light and its probability, or `None`.
type Choice = Option<(usize, f64)>;

/// One node's lane importances I_k in f64 and their running sums S_k = I_0 + … + I_k, added
/// in lane order (S_7 = Σ I): the sum and the choice ([`choose_lane`]) share the additions; and
/// the mask of its far lanes ([`LaneValues`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Importances {
    pub(super) lanes: [f64; LANES],
    sums: [f64; LANES],
    pub(super) far: u8,
}

impl Importances {
    /// Σ I.
    #[inline(always)]
    pub(super) fn total(&self) -> f64 {
        self.sums[LANES - 1]
    }
}

/// The root's importances at one receiver, from [`LightBvh::root`].
#[derive(Clone, Copy, Debug)]
pub struct RootImportances(Importances);

/// A light bounding volume hierarchy over emitters' [`LightBounds`].
#[derive(Clone, Debug)]
pub struct LightBvh {
    pub(super) nodes: Vec<WideNode>,
    /// The first [`DECODED_TOP`] nodes decoded (the root and, as a rule, its children, which
    /// every choice visits), so a walk does not decode them again.
    pub(super) top: Vec<Decoded>,
    /// The distance and direction terms of the root's lanes and its children's near their
    /// lights ([`NearTables`]).
    pub(super) near: NearTables,
    /// Each light's power Φ, by id (one entry a light): a pair lane ([`WideNode::pairs`])
    /// chooses between its two lights in proportion to it.
    pub(super) phi: Vec<f32>,
    /// Whether the CPU has AVX2, FMA and POPCNT (`sample` and `pmf` then run a copy
    /// compiled for them).
    pub(super) avx2: bool,
    /// The lights' power prefix sums, which choose inside a far lane; `None` (the walk then
    /// always descends) where the powers span too many decades for them or no lane is far.
    pub(super) prefix: Option<PowerPrefix>,
    /// The sine of the half-angle below which a lane's bounding sphere makes it far
    /// ([`DEFAULT_FAR_SIN`]; 0: none is, and the walk always descends).
    pub(super) far_sin: f32,
}

/// A light tree half built ([`LightBvh::binary`]): the binary build tree, its
/// grid, the included lights in leaf order and their power points.
pub struct BinaryTree {
    nodes: Vec<Node>,
    grid: Grid,
    order: Vec<u32>,
    points: Vec<PowerPoint>,
}

impl BinaryTree {
    /// The included light indices in leaf order: light `order[k]` becomes light
    /// k of the tree (see [`LightBvh::build`]).
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The traversed tree: the binary tree collapsed into wide nodes.
    pub fn collapse(&self) -> LightBvh {
        let (nodes, reach) = collapse(&self.nodes, &self.grid, &self.points);
        let avx2 = has_avx2_fma();
        // On huge pages: a pair lane reads its two lights' powers.
        let phi: Vec<f32> =
            crate::alloc::on_huge_pages(|| self.points.iter().map(|p| p.phi).collect());
        LightBvh {
            near: NearTables::build(&nodes, &reach, &self.points, avx2),
            top: nodes.iter().take(DECODED_TOP).map(Decoded::of).collect(),
            prefix: PowerPrefix::new(&phi),
            phi,
            nodes,
            avx2,
            far_sin: DEFAULT_FAR_SIN,
        }
    }
}

impl LightBvh {
    /// The tree with far lanes below `far_sin` ([`DEFAULT_FAR_SIN`]; 0 or less: none, and the
    /// power prefix is dropped). Sampling and `pmf` both read it, so the pmf stays exact.
    pub fn with_far_sin(mut self, far_sin: f32) -> LightBvh {
        self.far_sin = far_sin.max(0.0);
        if self.far_sin == 0.0 {
            self.prefix = None;
        }
        self
    }

    /// Builds over `bounds` (index i = light i). Lights with phi == 0 (or
    /// negative, or any non-finite field) are left out, as are indices from
    /// 2³¹ on. Returns the tree and `order`, the included light indices in leaf
    /// order: the caller reorders its lights so that light `order[k]` becomes
    /// light k, the id used by [`sample`](Self::sample) and [`pmf`](Self::pmf).
    pub fn build(bounds: &[LightBounds]) -> (LightBvh, Vec<u32>) {
        let binary = LightBvh::binary(bounds.len(), |i| bounds[i]);
        (binary.collapse(), binary.order)
    }

    /// The first half of [`build`](Self::build) over `count` lights whose bounds
    /// `bounds_of(i)` gives, asked once per light (in parallel): the binary tree
    /// and the lights' leaf order, which the caller may apply to its lights while
    /// [`BinaryTree::collapse`] makes the traversed tree.
    pub fn binary(count: usize, bounds_of: impl Fn(usize) -> LightBounds + Sync) -> BinaryTree {
        let (nodes, grid, order, points) = binary_tree(count, bounds_of);
        BinaryTree {
            nodes,
            grid,
            order,
            points,
        }
    }

    /// Whether some light in the tree may reach the upper hemisphere of a
    /// receiver at (p, n) (some root lane has positive importance; a specular lobe
    /// never makes a lane 0).
    pub fn can_reach(&self, p: Vec3, n: Vec3) -> bool {
        self.root(p, n).is_some()
    }

    /// [`root_with`](Self::root_with) for a receiver without a specular lobe.
    pub fn root(&self, p: Vec3, n: Vec3) -> Option<RootImportances> {
        self.root_with(p, n, Lobe::NONE)
    }

    /// [`sample_with`](Self::sample_with) for a receiver without a specular lobe.
    pub fn sample(&self, p: Vec3, n: Vec3, u: f64) -> Option<(usize, f64)> {
        self.sample_with(p, n, Lobe::NONE, u)
    }

    /// [`pmf_with`](Self::pmf_with) for a receiver without a specular lobe.
    pub fn pmf(&self, p: Vec3, n: Vec3, light: usize) -> f64 {
        self.pmf_with(p, n, Lobe::NONE, light)
    }

    /// The root's lane importances at (p, n, lobe), or `None` where no light in the
    /// tree can reach the receiver. Here as in `sample` and `pmf`, `n` is the receiver's unit
    /// normal (to a few ulps: the zero test's margin, `REJECT_ANGLE`, counts on it) or zero for
    /// none. A caller that must know this before it
    /// chooses passes the answer on to [`sample_below_with`](Self::sample_below_with),
    /// which then does not evaluate the root again.
    pub fn root_with(&self, p: Vec3, n: Vec3, lobe: Lobe) -> Option<RootImportances> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is true only when the CPU reported AVX2, FMA and POPCNT.
            return unsafe { self.root_avx2(p, n, lobe) };
        }
        self.root_portable(p, n, lobe)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt")]
    unsafe fn root_avx2(&self, p: Vec3, n: Vec3, lobe: Lobe) -> Option<RootImportances> {
        self.root_portable(p, n, lobe)
    }

    #[inline(always)]
    fn root_portable(&self, p: Vec3, n: Vec3, lobe: Lobe) -> Option<RootImportances> {
        if !is_finite(p, n) {
            return None;
        }
        self.importances(0, p, n, lobe).map(RootImportances)
    }

    /// [`sample`](Self::sample) from the root `root` evaluated at the same (p, n, lobe).
    pub fn sample_below_with(
        &self,
        root: &RootImportances,
        p: Vec3,
        n: Vec3,
        lobe: Lobe,
        u: f64,
    ) -> Option<(usize, f64)> {
        self.sample_from(p, n, lobe, u, Some(root.0))
    }

    /// Chooses a light (its id in leaf order) with probability proportional
    /// to importance at each level, from `u` ∈ [0, 1): at a wide node, lane k
    /// is taken when u·Σ I falls in its part [I_<k, I_<k + I_k), and u is
    /// rescaled to [0, 1) within that part. Returns the light and its
    /// probability (the product of the chosen lanes' I_k / Σ I), or `None` when the
    /// tree is empty, (p, n) is not finite, a node is reached whose lanes all
    /// have importance 0, or the probability underflows to 0.
    #[inline]
    pub fn sample_with(&self, p: Vec3, n: Vec3, lobe: Lobe, u: f64) -> Option<(usize, f64)> {
        self.sample_from(p, n, lobe, u, None)
    }

    /// [`sample`](Self::sample), the root's importances given or not.
    #[inline]
    fn sample_from(
        &self,
        p: Vec3,
        n: Vec3,
        lobe: Lobe,
        u: f64,
        root: Option<Importances>,
    ) -> Choice {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is true only when the CPU reported AVX2, FMA and POPCNT.
            return unsafe { self.walk_avx2(p, n, lobe, u, root) };
        }
        self.walk(p, n, lobe, u, root)
    }

    /// [`sample`](Self::sample) compiled for AVX2: the lanes in one register.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt")]
    unsafe fn walk_avx2(
        &self,
        p: Vec3,
        n: Vec3,
        lobe: Lobe,
        u: f64,
        root: Option<Importances>,
    ) -> Choice {
        self.walk(p, n, lobe, u, root)
    }

    /// The walk of `sample`; `root`, when given, stands for the root's importances.
    #[inline(always)]
    fn walk(&self, p: Vec3, n: Vec3, lobe: Lobe, u: f64, root: Option<Importances>) -> Choice {
        if !is_finite(p, n) {
            return None;
        }
        let mut u = if u >= 0.0 {
            u.min(LARGEST_BELOW_ONE)
        } else {
            0.0
        };
        let mut node = self.nodes.first()?;
        let mut pmf = 1.0;
        let mut lanes = match root {
            Some(root) => root,
            None => self.importances(0, p, n, lobe)?,
        };
        // One past the last light id of the node's range.
        let mut end = self.len();
        loop {
            let total = lanes.total();
            let target = u * total;
            let (lane, below, importance) = choose_lane(&lanes, target);
            pmf *= importance / total;
            let child = node.child(lane);
            let lane_end = node.lane_end(lane, end);
            if let Some((prefix, range)) = self.far_lane(node, &lanes, lane, child, lane_end) {
                let u = ((target - below) / importance).clamp(0.0, LARGEST_BELOW_ONE);
                let (light, share) = prefix.choose(range.start, range.end, u);
                pmf *= share;
                return (pmf > 0.0).then_some((light, pmf));
            }
            end = lane_end;
            if child & LIGHT_LANE != 0 {
                let mut light = (child & !LIGHT_LANE) as usize;
                if node.pairs & (1 << lane) != 0 {
                    // The first light when u, rescaled to the lane, is below Φ_a / (Φ_a + Φ_b):
                    // compared without dividing.
                    let (a, b) = self.pair_powers(light);
                    let second = (target - below) * (a + b) >= a * importance;
                    pmf *= self.pair_share(light, second);
                    light += usize::from(second);
                }
                return (pmf > 0.0).then_some((light, pmf));
            }
            // Rescaled only where another choice follows.
            u = ((target - below) / importance).clamp(0.0, LARGEST_BELOW_ONE);
            // The node is looked up once: `below_root`'s own lookup of it is the same check.
            let index = child as usize;
            node = self.nodes.get(index)?;
            lanes = self.below_root(index, p, n, lobe)?;
        }
    }

    /// The probability that [`sample`](Self::sample) returns `light` at
    /// (`p`, `n`), bit-identical to the value it returns with it: descends
    /// towards the lane whose id range holds `light`, multiplying the same
    /// per-node probabilities. 0 for ids ≥ [`len`](Self::len).
    pub fn pmf_with(&self, p: Vec3, n: Vec3, lobe: Lobe, light: usize) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is true only when the CPU reported AVX2, FMA and POPCNT.
            return unsafe { self.pmf_avx2(p, n, lobe, light) };
        }
        self.pmf_portable(p, n, lobe, light)
    }

    /// [`pmf`](Self::pmf) compiled for AVX2 (the same arithmetic: the lanes' fused
    /// multiply-adds are explicit and correctly rounded in both copies, and nothing else is
    /// contracted, so both give the same bits).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt")]
    unsafe fn pmf_avx2(&self, p: Vec3, n: Vec3, lobe: Lobe, light: usize) -> f64 {
        self.pmf_portable(p, n, lobe, light)
    }

    #[inline(always)]
    fn pmf_portable(&self, p: Vec3, n: Vec3, lobe: Lobe, light: usize) -> f64 {
        if light >= self.len() || !is_finite(p, n) {
            return 0.0;
        }
        let light = light as u32;
        let mut index = 0;
        let mut end = self.len();
        let mut pmf = 1.0;
        let Some(mut lanes) = self.importances(0, p, n, lobe) else {
            return 0.0;
        };
        loop {
            let (importances, total) = (&lanes.lanes, lanes.total());
            let node = &self.nodes[index];
            let Some(lane) = node.lane_of(light) else {
                return 0.0;
            };
            pmf *= importances[lane] / total;
            if pmf == 0.0 {
                return 0.0;
            }
            let child = node.child(lane);
            let lane_end = node.lane_end(lane, end);
            if let Some((prefix, range)) = self.far_lane(node, &lanes, lane, child, lane_end) {
                return pmf * prefix.pmf(range.start, range.end, light as usize);
            }
            end = lane_end;
            if child & LIGHT_LANE != 0 {
                let first = child & !LIGHT_LANE;
                if node.pairs & (1 << lane) == 0 {
                    return if light == first { pmf } else { 0.0 };
                }
                return match light - first {
                    k @ (0 | 1) => pmf * self.pair_share(first as usize, k == 1),
                    _ => 0.0,
                };
            }
            index = child as usize;
            let Some(below) = self.below_root(index, p, n, lobe) else {
                return 0.0;
            };
            lanes = below;
        }
    }

    /// The power prefix and the id range of lane `lane` of `node` (its child `child`, its range
    /// ending at `lane_end`) where the walk stops there and chooses ∝ power: a far interior lane
    /// ([`LaneValues`]) of a tree with a power prefix. One test for `sample` and `pmf`.
    #[inline(always)]
    fn far_lane(
        &self,
        node: &WideNode,
        lanes: &Importances,
        lane: usize,
        child: u32,
        lane_end: usize,
    ) -> Option<(&PowerPrefix, std::ops::Range<usize>)> {
        let prefix = self.prefix.as_ref()?;
        let far = lanes.far & (1 << lane) != 0 && child & LIGHT_LANE == 0;
        far.then(|| (prefix, node.first[lane] as usize..lane_end))
    }

    /// The powers Φ_a, Φ_b (each > 0) of a pair lane's lights a = `first` and b = `first + 1`.
    #[inline(always)]
    fn pair_powers(&self, first: usize) -> (f64, f64) {
        (f64::from(self.phi[first]), f64::from(self.phi[first + 1]))
    }

    /// The probability with which a pair lane chooses its light a = `first` (Φ_a / (Φ_a + Φ_b))
    /// or, if `second`, b = `first + 1` (Φ_b / (Φ_a + Φ_b)): one expression for `sample` and
    /// `pmf`, so both give the same bits.
    #[inline(always)]
    fn pair_share(&self, first: usize, second: bool) -> f64 {
        let (a, b) = self.pair_powers(first);
        (if second { b } else { a }) / (a + b)
    }

    /// Number of lights in the tree.
    pub fn len(&self) -> usize {
        self.phi.len()
    }

    /// Whether the tree holds no light.
    pub fn is_empty(&self) -> bool {
        self.phi.is_empty()
    }

    /// Number of (8-wide) nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Heap bytes held by the tree.
    pub fn bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<WideNode>()
            + self.top.capacity() * std::mem::size_of::<Decoded>()
            + self.phi.capacity() * std::mem::size_of::<f32>()
            + self.near.bytes()
            + self.prefix.as_ref().map_or(0, PowerPrefix::bytes)
    }

    /// The lanes' importances I_k at wide node `index` in f64, and their running sums (lane k is
    /// chosen with probability I_k / Σ I); `None` when the sum is 0 or the node does not exist.
    /// (p, n, lobe) must be finite (see [`is_finite`]).
    #[inline(always)]
    pub(super) fn importances(
        &self,
        index: usize,
        p: Vec3,
        n: Vec3,
        lobe: Lobe,
    ) -> Option<Importances> {
        let near = self.near.at(index, p, n);
        self.lane_importances(index, p, n, lobe, near)
    }

    /// [`importances`](Self::importances) at a node other than the root. With and without table
    /// terms each case has its own copy of the lanes: one copy for both (`importances` itself)
    /// lost the lanes' SIMD form (town, bvh + mis: 1.7 → 2.7 µs per camera sample).
    #[inline(always)]
    fn below_root(&self, index: usize, p: Vec3, n: Vec3, lobe: Lobe) -> Option<Importances> {
        if let Some(near) = self.near.at(index, p, n) {
            return self.lane_importances(index, p, n, lobe, Some(near));
        }
        self.lane_importances(index, p, n, lobe, None)
    }

    /// The importances of node `index`'s lanes, with its table terms `near` if given.
    #[inline(always)]
    fn lane_importances(
        &self,
        index: usize,
        p: Vec3,
        n: Vec3,
        lobe: Lobe,
        near: Option<NearTerms>,
    ) -> Option<Importances> {
        let node = self.nodes.get(index)?;
        // The table's presence is matched here, so that each arm is compiled for it: with the
        // table, the lanes' distance terms are never computed.
        let LaneValues { importance, far } = match (self.top.get(index), near) {
            (Some(decoded), Some(near)) => {
                decoded_importances(decoded, p, n, &lobe, Some(near), self.far_sin)
            }
            (Some(decoded), None) => decoded_importances(decoded, p, n, &lobe, None, self.far_sin),
            (None, near) => importances(node, p, n, &lobe, near, self.far_sin),
        };
        let importances = importance.map(f64::from);
        let mut sums = [0.0; LANES];
        // From −0.0, the additive identity (so the first sum is no addition at all).
        let mut sum = -0.0;
        for (s, &importance) in sums.iter_mut().zip(&importances) {
            sum += importance;
            *s = sum;
        }
        (sum > 0.0).then_some(Importances {
            lanes: importances,
            sums,
            far,
        })
    }
}

/// Whether a receiver can be evaluated: the importance assumes finite p and n.
#[inline(always)]
fn is_finite(p: Vec3, n: Vec3) -> bool {
    p.is_finite() && n.is_finite()
}

/// The lane whose part of [0, Σ I) holds `target` (lane k's part is [S_k−1, S_k), S_k the
/// running sum, S_−1 = 0), the sum S_k−1 of the parts below it and I_k (returned rather than
/// indexed, so the lanes stay in registers). The first k with `target` < S_k has I_k > 0: an
/// empty lane repeats the sum before it, which `target` (≥ 0) was not below. Rounding that
/// leaves `target` at or past Σ I gives the last lane of positive importance. Branches rather
/// than a branch-free mask of S_k > `target`: the CPU goes on down the predicted lane while the
/// sums are still being added (the mask made `sample` 10% slower, thread CPU time on 50,000
/// random lights).
#[inline(always)]
fn choose_lane(lanes: &Importances, target: f64) -> (usize, f64, f64) {
    let below = |k: usize| if k == 0 { 0.0 } else { lanes.sums[k - 1] };
    for (lane, &sum) in lanes.sums.iter().enumerate() {
        if target < sum {
            return (lane, below(lane), lanes.lanes[lane]);
        }
    }
    for lane in (0..LANES).rev() {
        if lanes.lanes[lane] > 0.0 {
            return (lane, below(lane), lanes.lanes[lane]);
        }
    }
    unreachable!("Σ I > 0")
}

/// The binary build tree over `count` lights (depth-first, root at 0), its grid, the included
/// lights' indices in leaf order (see [`LightBvh::build`]) and their power points in that order.
pub(super) fn binary_tree(
    count: usize,
    bounds_of: impl Fn(usize) -> LightBounds + Sync,
) -> (Vec<Node>, Grid, Vec<u32>, Vec<PowerPoint>) {
    let mut prims: Vec<Prim> = (0..count)
        .into_par_iter()
        .map(|i| Prim::new(i, &bounds_of(i)).unwrap_or(Prim::LEFT_OUT))
        .collect();
    // Retained only when some light is left out: the scan alone is a serial pass over them.
    if prims.par_iter().any(|p| p.phi <= 0.0) {
        prims.retain(|p| p.phi > 0.0);
    }
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
    let order = prims.par_iter().map(Prim::id).collect();
    let points = prims
        .par_iter()
        .map(|p| PowerPoint {
            position: p.centroid().into(),
            phi: p.phi,
        })
        .collect();
    (nodes, grid, order, points)
}
