//! Top-down tree construction: subtrees of the depth-first node array are
//! built in parallel (rayon) when large, serially with an explicit stack when
//! small; each node gets its quantised bounds once its children are known.

use super::*;

/// A subtree under construction: its lights, and its nodes, which are those of
/// indices `base ..` in the tree (a subtree of n lights has 2n − 1 nodes);
/// its lights get ids `first ..`.
pub(super) struct Subtree<'a> {
    pub(super) prims: &'a mut [Prim],
    pub(super) nodes: &'a mut [Node],
    pub(super) base: u32,
    pub(super) first: u32,
}

/// Pending work of the serial build: lights `start..end` under local node `node`.
pub(super) struct Task {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) node: usize,
    pub(super) centroids: Aabb,
}

impl<'a> Subtree<'a> {
    /// Builds the subtree and returns its root's full-precision bounds. Large
    /// subtrees split here: two large halves are built in parallel; when one
    /// half is small it is built at once and the loop goes on with the other,
    /// so lopsided chains of splits do not recurse.
    pub(super) fn build(self, grid: &Grid, centroids: Aabb) -> LightBounds {
        let (mut tree, mut centroids) = (self, centroids);
        // (node, its topology, bounds of the half built, whether that is the left)
        let mut pending = Vec::new();
        let mut inputs = CostInputs::new();
        let mut bounds = loop {
            if tree.prims.len() < PARALLEL_MIN {
                break tree.build_serial(grid, centroids);
            }
            let split = choose_split(tree.prims, centroids, &mut inputs);
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
    pub(super) fn split(self, mid: usize) -> (&'a mut Node, Subtree<'a>, Subtree<'a>) {
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
    pub(super) fn build_serial(self, grid: &Grid, centroids: Aabb) -> LightBounds {
        let Subtree {
            prims,
            nodes,
            base,
            first,
        } = self;
        let mut inputs = CostInputs::new();
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
            let split = choose_split(
                &mut prims[task.start..task.end],
                task.centroids,
                &mut inputs,
            );
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
