//! Collapsing obvhs's binary tree (one triangle per leaf) into its compressed 8-wide layout
//! (CWBVH), node for node what `obvhs::cwbvh::bvh2_to_cwbvh` makes, in less time and memory.
//!
//! The collapse is the dynamic programme of Ylitie, Karras & Laine 2017 (§3.1): bottom up, each
//! binary node n gets the least SAH cost C(n, i) of standing for its subtree as at most i + 1
//! children of a wide node (i = 0: one child, a leaf of ≤ `leaf_max` triangles at cost
//! 0.3·count·A(n) or an interior node at A(n) plus its best 8-way split; i ≥ 1: the cheaper of
//! C(n, i − 1) and the best C(left, k) + C(right, i − 1 − k)), A being the half surface area.
//! Top down, each wide node then takes the children the choices name. obvhs walks the tree
//! depth first twice, waiting on one node's load after another, with a 56-byte table per binary
//! node allocated per tree; here the bottom-up pass reads the nodes in memory order, the top-down
//! pass asks for the nodes it will visit before it needs them, and the costs (32 bytes a node)
//! and choices (7) live in buffers kept from tree to tree. Ties, sums and comparisons are taken
//! in obvhs's order, so that the trees are the same (`tests`).

use glam::{UVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::{node::CwBvhNode, CwBvh};

use crate::sampling::prefetch::prefetch;

/// A leaf triangle's SAH cost relative to a node's (obvhs's constant).
const PRIM_COST: f32 = 0.3;
/// Slots of the programme: slot i stands for at most i + 1 children.
const SLOTS: usize = 7;
/// Children of a wide node.
const WIDTH: usize = 8;
/// No child in a slot of the gathered list.
const EMPTY: u32 = u32::MAX;

/// What slot i of a binary node chose, in a byte: how it is represented (bits 6–7) and, when it
/// is spread over several children, over how many slots of its left (bits 0–2) and right
/// (bits 3–5) child.
#[derive(Clone, Copy, Default)]
struct Choice(u8);

impl Choice {
    const LEAF: u8 = 0;
    const INTERIOR: u8 = 1;
    const SPREAD: u8 = 2;

    fn new(kind: u8, left: usize, right: usize) -> Choice {
        Choice(kind << 6 | (right as u8) << 3 | left as u8)
    }
    fn kind(self) -> u8 {
        self.0 >> 6
    }
    fn left(self) -> usize {
        usize::from(self.0 & 7)
    }
    fn right(self) -> usize {
        usize::from(self.0 >> 3 & 7)
    }
}

/// A wide node's quantisation grid: from its box's lower corner, a power-of-two step per axis
/// no smaller than 1/255 of the box (obvhs's rule); child boxes are rounded outwards onto it.
pub(super) struct NodeGrid {
    origin: Vec3A,
    inv_step: Vec3A,
    exponents: [u8; 3],
}

impl NodeGrid {
    pub(super) fn new(node_box: &Aabb) -> NodeGrid {
        let origin = node_box.min;
        let step = ((node_box.max - origin).max(Vec3A::splat(1e-20)) * (1.0 / 255.0))
            .log2()
            .ceil()
            .exp2();
        // A power of two's bits are its biased exponent alone.
        let exponents = UVec3::new(step.x.to_bits(), step.y.to_bits(), step.z.to_bits()) >> 23u32;
        NodeGrid {
            origin,
            inv_step: 1.0 / step,
            exponents: [exponents.x as u8, exponents.y as u8, exponents.z as u8],
        }
    }

    /// A node with this grid and nothing in its slots.
    pub(super) fn empty_node(&self) -> CwBvhNode {
        CwBvhNode {
            p: self.origin.into(),
            e: self.exponents,
            ..CwBvhNode::default()
        }
    }

    /// Writes `child`'s box into `slot` of `node`, rounded outwards (lower corner down, upper up).
    pub(super) fn set_box(&self, node: &mut CwBvhNode, slot: usize, child: &Aabb) {
        let lo = ((child.min - self.origin) * self.inv_step)
            .floor()
            .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
        let hi = ((child.max - self.origin) * self.inv_step)
            .ceil()
            .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
        node.child_min_x[slot] = lo.x as u8;
        node.child_min_y[slot] = lo.y as u8;
        node.child_min_z[slot] = lo.z as u8;
        node.child_max_x[slot] = hi.x as u8;
        node.child_max_y[slot] = hi.y as u8;
        node.child_max_z[slot] = hi.z as u8;
    }
}

/// The collapse's working memory, kept from one tree to the next.
#[derive(Default)]
pub(super) struct Collapser {
    /// Per binary node, the choice of each slot.
    choices: Vec<[Choice; SLOTS]>,
    /// Per binary node, its subtree's costs.
    subtrees: Vec<Subtree>,
}

impl Collapser {
    /// The CWBVH of `bvh2` (leaves of one primitive each) with at most `leaf_max` (1–3)
    /// triangles per leaf; with `ordered`, each node's children placed in the octant slots
    /// obvhs's walk expects. Primitive indices are `bvh2`'s.
    pub(super) fn collapse(&mut self, bvh2: &Bvh2, leaf_max: u32, ordered: bool) -> CwBvh {
        if bvh2.nodes.is_empty() {
            return CwBvh::default();
        }
        self.choices.clear();
        self.choices
            .resize(bvh2.nodes.len(), [Choice::default(); SLOTS]);
        self.subtrees.clear();
        self.subtrees.resize(bvh2.nodes.len(), Subtree::default());
        choose(bvh2, &mut self.choices, &mut self.subtrees, leaf_max);
        let mut out = Emitter {
            bvh2,
            choices: &self.choices,
            ordered,
            nodes: vec![CwBvhNode::default()],
            // Every hit reads its triangle's id here: on huge pages.
            primitive_indices: crate::alloc::on_huge_pages(|| {
                Vec::with_capacity(bvh2.primitive_indices.len())
            }),
        };
        out.emit(0, 0);
        CwBvh {
            nodes: out.nodes,
            primitive_indices: out.primitive_indices,
            total_aabb: *bvh2.nodes[0].aabb(),
            exact_node_aabbs: None,
            uses_spatial_splits: bvh2.uses_spatial_splits,
        }
    }
}

/// A binary subtree's costs per slot and its triangle count.
#[derive(Clone, Copy, Default)]
struct Subtree {
    cost: [f32; SLOTS],
    count: u32,
}

/// How far ahead (in nodes) the bottom-up scan asks for the children it will read.
const LOOKAHEAD: usize = 16;

/// The bottom-up pass: every binary node's [`Subtree`] and choices. Nodes are taken from the
/// last index down, which reads the tree in memory order: obvhs's builder places children after
/// their parent, so their values are ready when the parent is reached, and the few nodes that
/// reinsertion moved below their parent are evaluated on demand (`evaluate`). Every read of a
/// child then depends on the loop alone, not on the previous read, so the misses overlap (a
/// depth-first walk waits on each node in turn).
fn choose(bvh2: &Bvh2, choices: &mut [[Choice; SLOTS]], subtrees: &mut [Subtree], leaf_max: u32) {
    let nodes = &bvh2.nodes;
    for i in (0..nodes.len()).rev() {
        if let Some(ahead) = i.checked_sub(LOOKAHEAD).map(|k| &nodes[k]) {
            if !ahead.is_leaf() {
                prefetch(&subtrees[ahead.first_index as usize]);
            }
        }
        subtrees[i] = evaluate(bvh2, choices, subtrees, i, i, leaf_max);
    }
}

/// Binary node `node`'s [`Subtree`], recording its choices; the values of nodes above index
/// `scanned` are read as the scan left them, the others evaluated here first.
fn evaluate(
    bvh2: &Bvh2,
    choices: &mut [[Choice; SLOTS]],
    subtrees: &mut [Subtree],
    node: usize,
    scanned: usize,
    leaf_max: u32,
) -> Subtree {
    let n = &bvh2.nodes[node];
    let area = n.aabb().half_area();
    if n.is_leaf() {
        debug_assert_eq!(n.prim_count, 1, "the binary tree has a triangle per leaf");
        choices[node] = [Choice::new(Choice::LEAF, 0, 0); SLOTS];
        return Subtree {
            cost: [area * n.prim_count as f32 * PRIM_COST; SLOTS],
            count: n.prim_count,
        };
    }
    let first = n.first_index as usize;
    let mut halves = [Subtree::default(); 2];
    for (half, child) in halves.iter_mut().zip(first..) {
        if child <= scanned {
            subtrees[child] = evaluate(bvh2, choices, subtrees, child, scanned, leaf_max);
        }
        *half = subtrees[child];
    }
    let [Subtree { cost: left, .. }, Subtree { cost: right, .. }] = halves;
    let count = halves[0].count + halves[1].count;
    let mut cost = [0.0; SLOTS];
    let mut chosen = [Choice::default(); SLOTS];

    // Slot 0: a leaf, or an interior node whose ≤ 8 children split 7 slots between the halves.
    let leaf = if count <= leaf_max {
        count as f32 * area * PRIM_COST
    } else {
        f32::INFINITY
    };
    let (mut spread, mut best) = (f32::INFINITY, 0);
    for k in 0..SLOTS {
        let c = left[k] + right[SLOTS - 1 - k];
        if c < spread {
            (spread, best) = (c, k);
        }
    }
    let interior = spread + area;
    let kind = if leaf < interior {
        Choice::LEAF
    } else {
        Choice::INTERIOR
    };
    cost[0] = if leaf < interior { leaf } else { interior };
    chosen[0] = Choice::new(kind, best, SLOTS - 1 - best);

    // Slot i ≥ 1: slot i − 1's choice, or the halves spread over i + 1 slots together.
    for i in 1..SLOTS {
        (cost[i], chosen[i]) = (cost[i - 1], chosen[i - 1]);
        for k in 0..i {
            let c = left[k] + right[i - 1 - k];
            if c < cost[i] {
                (cost[i], chosen[i]) = (c, Choice::new(Choice::SPREAD, k, i - 1 - k));
            }
        }
    }
    choices[node] = chosen;
    Subtree { cost, count }
}

/// The top-down pass: writes wide nodes and leaf primitive lists in obvhs's order.
struct Emitter<'a> {
    bvh2: &'a Bvh2,
    choices: &'a [[Choice; SLOTS]],
    ordered: bool,
    nodes: Vec<CwBvhNode>,
    primitive_indices: Vec<u32>,
}

impl Emitter<'_> {
    /// Writes the wide node at index `at` for the binary node `node` (an interior choice), then
    /// its interior children's nodes, depth first.
    fn emit(&mut self, at: usize, node: usize) {
        let node_box = *self.bvh2.nodes[node].aabb();
        let grid = NodeGrid::new(&node_box);
        let mut children = [EMPTY; WIDTH];
        let mut count = 0;
        self.gather(node, 0, &mut children, &mut count);
        // The children's nodes and, once those are in, their own children are asked for ahead
        // of use: the leaves' triangles and the interior children's wide nodes come later.
        for &child in &children[..count] {
            prefetch(&self.bvh2.nodes[child as usize]);
        }
        for &child in &children[..count] {
            let n = &self.bvh2.nodes[child as usize];
            if !n.is_leaf() {
                let first = n.first_index as usize;
                prefetch(&self.bvh2.nodes[first]);
                prefetch(&self.bvh2.nodes[first + 1]);
                prefetch(&self.choices[first]);
                prefetch(&self.choices[first + 1]);
            }
        }
        if self.ordered {
            order_by_octant(self.bvh2, &node_box, &mut children, count);
        }
        let mut wide = grid.empty_node();
        wide.primitive_base_idx = self.primitive_indices.len() as u32;
        wide.child_base_idx = self.nodes.len() as u32;
        let mut interior = 0;
        let mut triangles = 0;
        for (slot, &child) in children.iter().enumerate() {
            if child == EMPTY {
                continue;
            }
            grid.set_box(&mut wide, slot, self.bvh2.nodes[child as usize].aabb());
            if self.choices[child as usize][0].kind() == Choice::LEAF {
                let before = self.primitive_indices.len();
                self.push_triangles(child as usize);
                let n = (self.primitive_indices.len() - before) as u8;
                debug_assert!((1..=3).contains(&n));
                // The count in unary in the top three bits, the first triangle's offset below.
                wide.child_meta[slot] = triangles | ((1 << n) - 1) << 5;
                triangles += n;
            } else {
                wide.imask |= 1 << slot;
                wide.child_meta[slot] = 0b0010_0000 | (24 + slot as u8);
                interior += 1;
            }
        }
        self.nodes
            .resize(self.nodes.len() + interior, CwBvhNode::default());
        self.nodes[at] = wide;
        let mut next = wide.child_base_idx as usize;
        for (slot, &child) in children.iter().enumerate() {
            if wide.imask & (1 << slot) != 0 {
                self.emit(next, child as usize);
                next += 1;
            }
        }
    }

    /// Appends the children that slot `slot` of `node` stands for: a child spread over several
    /// slots gives its own children in its place.
    fn gather(&self, node: usize, slot: usize, children: &mut [u32; WIDTH], count: &mut usize) {
        let n = &self.bvh2.nodes[node];
        if n.is_leaf() {
            children[*count] = node as u32;
            *count += 1;
            return;
        }
        let choice = self.choices[node][slot];
        let first = n.first_index as usize;
        for (child, child_slot) in [(first, choice.left()), (first + 1, choice.right())] {
            if self.choices[child][child_slot].kind() == Choice::SPREAD {
                self.gather(child, child_slot, children, count);
            } else {
                children[*count] = child as u32;
                *count += 1;
            }
        }
    }

    /// Appends the triangles under `node`, left to right.
    fn push_triangles(&mut self, node: usize) {
        let n = &self.bvh2.nodes[node];
        if n.is_leaf() {
            let first = n.first_index as usize;
            let last = first + n.prim_count as usize;
            self.primitive_indices
                .extend_from_slice(&self.bvh2.primitive_indices[first..last]);
        } else {
            self.push_triangles(n.first_index as usize);
            self.push_triangles(n.first_index as usize + 1);
        }
    }
}

/// Moves the first `count` children into their [`octant_slots`].
fn order_by_octant(bvh2: &Bvh2, node_box: &Aabb, children: &mut [u32; WIDTH], count: usize) {
    let mut centres = [Vec3A::ZERO; WIDTH];
    for (centre, &child) in centres.iter_mut().zip(&children[..count]) {
        *centre = bvh2.nodes[child as usize].aabb().center();
    }
    let slot_of = octant_slots(node_box.center(), &centres[..count]);
    let given = std::mem::replace(children, [EMPTY; WIDTH]);
    for c in 0..count {
        children[slot_of[c]] = given[c];
    }
}

/// A slot for each of (at most eight) children with box centres `centres` in a node centred at
/// `centre`, so that children lying towards a slot's octant get that slot (obvhs's convention,
/// from which its walk derives the visiting order): slot s points to −x, −y, −z where its bits
/// 4, 2, 1 are set, and the pairs (child, free slot) are taken greedily by the smallest
/// (child centre − node centre)·direction, ties to the first child, then the first slot.
pub(super) fn octant_slots(centre: Vec3A, centres: &[Vec3A]) -> [usize; WIDTH] {
    let sign = |s: usize, bit: usize| if s & bit != 0 { -1.0 } else { 1.0 };
    let mut cost = [[0.0f32; WIDTH]; WIDTH];
    for (row, &c) in cost.iter_mut().zip(centres) {
        let v = c - centre;
        for (s, slot_cost) in row.iter_mut().enumerate() {
            *slot_cost = Vec3A::new(sign(s, 4), sign(s, 2), sign(s, 1)).dot(v);
        }
    }
    let mut slot_of = [usize::MAX; WIDTH];
    let mut taken = [false; WIDTH];
    loop {
        let mut best = (f32::MAX, usize::MAX, usize::MAX);
        for c in (0..centres.len()).filter(|&c| slot_of[c] == usize::MAX) {
            for s in (0..WIDTH).filter(|&s| !taken[s]) {
                if cost[c][s] < best.0 {
                    best = (cost[c][s], c, s);
                }
            }
        }
        let (_, c, s) = best;
        if c == usize::MAX {
            return slot_of;
        }
        slot_of[c] = s;
        taken[s] = true;
    }
}

#[cfg(test)]
mod tests;
