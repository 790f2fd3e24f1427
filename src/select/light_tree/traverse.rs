//! The light tree: [`LightBvh::sample`] walks from the root choosing a child
//! with probability ∝ importance; [`LightBvh::pmf`] descends towards a light id
//! multiplying the same per-node probabilities, so pmf(l) equals the
//! probability that `sample` returns l (a product of child probabilities along
//! the root-to-leaf path, counting measure over light ids).

use glam::Vec3;
use rayon::prelude::*;

use super::*;

/// A light bounding volume hierarchy over emitters' [`LightBounds`].
#[derive(Clone, Debug)]
pub struct LightBvh {
    pub(super) nodes: Vec<Node>,
    pub(super) grid: Grid,
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
    pub(super) fn child_probabilities(&self, index: usize, p: Vec3, n: Vec3) -> Option<(f64, f64)> {
        let right = self.nodes.get(index)?.link as usize;
        let left = self.nodes.get(index + 1)?.importance(&self.grid, p, n);
        let right = self.nodes.get(right)?.importance(&self.grid, p, n);
        split_probabilities(left, right)
    }
}
