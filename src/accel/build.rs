//! Building the geometry BVH with obvhs: PLOC (parallel locally-ordered clustering, Meister &
//! Bittner 2018), reinsertion, then conversion to the compressed 8-wide layout (CWBVH, Ylitie,
//! Karras & Laine 2017) by our own collapse (`collapse.rs`), which makes obvhs's tree node for
//! node.
//!
//! Large scenes are built in parts: the triangles are cut by binned-SAH splits (`cut.rs`) until
//! every group has at most `part_max` triangles; each part gets its own CWBVH, two parts at a
//! time, and the parts are joined under CWBVH nodes of our own whose child boxes are quantised
//! the way obvhs quantises them (rounded outwards on the node's power-of-two grid). Only two
//! parts' builder temporaries are alive at once, which bounds peak memory (1M city: 751 → 421
//! MB) and the build takes both cores (1.6–2.3 → 0.8 s); rays cost what they cost in one tree
//! built whole (`cargo bench --bench rays`, city1m: −9 to +5%; median cuts lost 13–27%).
//! The part size and the parts built at once are the memory model's (`crate::scene::memory`);
//! below 4M elements obvhs's parallel radix sorts are stable or single-threaded, so a part's
//! tree never depends on the number of threads.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::{node::CwBvhNode, CwBvh};
use obvhs::ploc::PlocBuilder;
use obvhs::triangle::Triangle as BvhTriangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

use crate::scene::memory::BVH_PARTS_AT_ONCE;
use crate::scene::Scene;

use super::collapse::{octant_slots, Collapser, NodeGrid};
use super::cut::{sah_cut, Centres, Item};
use super::gathered_positions;

/// Up to this many triangles the BVH is built with obvhs's most thorough preset (pre-splitting,
/// reinsertion over all nodes); larger scenes use the medium preset, whose build time stays near
/// linear. Town (12k triangles): 73 ms against 15 ms to build, rays/s +13 to +35% with the new
/// triangle test (`cargo bench --bench rays`, thread CPU time); on the 50k city (97k triangles)
/// the thorough build took 513 ms against 159 ms for a gain within the noise, so it stops here.
const THOROUGH_BUILD_MAX_TRIANGLES: usize = 1 << 15;

/// Most triangles in a CWBVH leaf (obvhs allows 1 to 3; its presets ask for 3), for the walk
/// the tree is built for (`ordered`: obvhs's). Our AVX2 walk tests all the leaf triangles of a
/// node in one pass per eight: three (fewer, shallower nodes) against two, `cargo bench --bench
/// rays -- 'town|city50k'`, one run each: town camera / shadow / bounce / packets +3.4 / +5.2 /
/// +3.2 / +7.2% rays/s, 50k city +2.3 / −0.1 / +7.5 / −0.1%. obvhs's walk tests them one at a
/// time: there two gave 9–14% more rays/s than three, with the images unchanged; one was slower
/// on the city (−3 to −8%) and the Cornell box (−20%).
fn leaf_max(ordered: bool) -> u32 {
    if ordered {
        2
    } else {
        3
    }
}

/// Children of a CWBVH node.
const WIDTH: usize = 8;

/// The CWBVH over `scene`'s triangles (see the module header). With `ordered`, the children of
/// the parts' nodes are placed in obvhs's octant slots, the order its walk visits them in; the
/// AVX2 walk sorts the children it hits by entry distance itself and skips that step (on the
/// 1M-emitter city the render's `bvh build` line fell from 0.861 to 0.777 s, medians of seven
/// alternating pairs).
pub(super) fn build_bvh(scene: &Scene, part_max: usize, ordered: bool) -> CwBvh {
    let count = scene.triangles.len();
    if count <= THOROUGH_BUILD_MAX_TRIANGLES {
        let tris: Vec<BvhTriangle> = scene
            .triangles
            .iter()
            .map(|t| bvh_triangle(t.positions))
            .collect();
        return build_cwbvh_from_tris(
            &tris,
            BvhBuildParams {
                max_prims_per_leaf: leaf_max(ordered),
                ..BvhBuildParams::very_slow_build()
            },
            &mut std::time::Duration::default(),
        );
    }
    let mut items: Vec<Item> = scene
        .triangles
        .par_iter()
        .enumerate()
        .map(|(id, t)| {
            let [a, b, c] = t.positions;
            Item {
                lo: a.min(b).min(c),
                hi: a.max(b).max(c),
                id: id as u32,
            }
        })
        .collect();
    let centres = Centres::of(&items);
    let plan = Plan::cut(&mut items, centres, 0, part_max.max(1));
    let ids: Vec<u32> = items.par_iter().map(|c| c.id).collect();
    drop(items);
    match plan.build(scene, &ids, ordered) {
        Built::Part(bvh) => bvh,
        joined => Joiner::join(joined),
    }
}

fn bvh_triangle(p: [Vec3; 3]) -> BvhTriangle {
    BvhTriangle {
        v0: p[0].into(),
        v1: p[1].into(),
        v2: p[2].into(),
    }
}

/// What a worker keeps from one part's build to the next: obvhs's builder, its binary tree, its
/// reinsertion pass and the parts' boxes keep their allocations (sized for the largest part so
/// far), as obvhs intends them to be reused, so that each part writes into memory already
/// faulted in rather than fresh pages.
#[derive(Default)]
struct PartBuilder {
    ploc: PlocBuilder,
    bvh2: Bvh2,
    reinsertion: ReinsertionOptimizer,
    collapser: Collapser,
    boxes: Vec<Aabb>,
}

impl PartBuilder {
    /// obvhs's medium preset over the triangles `ids` (primitive indices are the scene's ids),
    /// the children in octant order when `ordered`.
    fn build(&mut self, scene: &Scene, ids: &[u32], ordered: bool) -> CwBvh {
        let params = BvhBuildParams::medium_build();
        self.boxes.clear();
        self.boxes
            .extend((0..ids.len()).map(|k| bvh_triangle(gathered_positions(scene, ids, k)).aabb()));
        self.ploc.build_with_bvh(
            &mut self.bvh2,
            params.ploc_search_distance,
            &self.boxes,
            (0..ids.len() as u32).collect(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        self.reinsertion
            .run(&mut self.bvh2, params.reinsertion_batch_ratio, None);
        let mut bvh = self
            .collapser
            .collapse(&self.bvh2, leaf_max(ordered), ordered);
        // obvhs's leaves index its primitive list by position: the part's own 0..len.
        for p in &mut bvh.primitive_indices {
            *p = ids[*p as usize];
        }
        bvh
    }
}

/// How the triangles are cut: a part is a range of the reordered ids; a join has two to eight
/// children.
enum Plan {
    Part(Range<usize>),
    Join(Vec<Plan>),
}

impl Plan {
    /// The plan for `items` (which start at `offset` in the full list), reordering them so
    /// that every part is a contiguous range: a join's children are made by cutting the largest
    /// group above `part_max` in two until there are eight or none is above.
    fn cut(items: &mut [Item], centres: Centres, offset: usize, part_max: usize) -> Plan {
        if items.len() <= part_max {
            return Plan::Part(offset..offset + items.len());
        }
        let mut groups = vec![(offset, items, centres)];
        while groups.len() < WIDTH {
            let (largest, _) = groups
                .iter()
                .enumerate()
                .max_by_key(|(k, (_, g, _))| (g.len(), std::cmp::Reverse(*k)))
                .expect("at least one group");
            if groups[largest].1.len() <= part_max {
                break;
            }
            let (start, group, centres) = groups.remove(largest);
            let (mid, left_centres, right_centres) = sah_cut(group, centres);
            let (left, right) = group.split_at_mut(mid);
            groups.insert(largest, (start + mid, right, right_centres));
            groups.insert(largest, (start, left, left_centres));
        }
        Plan::Join(
            groups
                .into_par_iter()
                .map(|(start, group, centres)| Plan::cut(group, centres, start, part_max))
                .collect(),
        )
    }

    /// Builds the parts, [`BVH_PARTS_AT_ONCE`] at a time in parallel, so that no more of their
    /// builders' memory is alive at once, whatever the number of threads: that many workers each
    /// take the next part until none is left (inside a part obvhs uses every thread).
    fn build(&self, scene: &Scene, ids: &[u32], ordered: bool) -> Built {
        let mut ranges = Vec::new();
        self.for_each_part(&mut |range| ranges.push(range));
        let parts: Vec<OnceLock<CwBvh>> = ranges.iter().map(|_| OnceLock::new()).collect();
        let next = AtomicUsize::new(0);
        rayon::scope(|scope| {
            for _ in 0..BVH_PARTS_AT_ONCE {
                scope.spawn(|_| {
                    let mut builder = PartBuilder::default();
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        let Some(range) = ranges.get(k) else { break };
                        let built = builder.build(scene, &ids[range.clone()], ordered);
                        assert!(parts[k].set(built).is_ok(), "each part is built once");
                    }
                });
            }
        });
        let mut parts = parts
            .into_iter()
            .map(|part| part.into_inner().expect("every part is built"));
        self.attach(&mut parts)
    }

    /// Calls `f` with every part's range, in order.
    fn for_each_part(&self, f: &mut impl FnMut(Range<usize>)) {
        match self {
            Plan::Part(range) => f(range.clone()),
            Plan::Join(children) => children.iter().for_each(|c| c.for_each_part(f)),
        }
    }

    /// The plan with its parts, given in order.
    fn attach(&self, parts: &mut impl Iterator<Item = CwBvh>) -> Built {
        match self {
            Plan::Part(_) => Built::Part(parts.next().expect("a tree per part")),
            Plan::Join(children) => Built::Join(children.iter().map(|c| c.attach(parts)).collect()),
        }
    }
}

/// A plan with its parts built.
enum Built {
    Part(CwBvh),
    Join(Vec<Built>),
}

impl Built {
    /// Nodes and primitive slots of the joined tree.
    fn sizes(&self) -> (usize, usize) {
        match self {
            Built::Part(bvh) => (bvh.nodes.len(), bvh.primitive_indices.len()),
            Built::Join(children) => children
                .iter()
                .map(Built::sizes)
                .fold((1, 0), |(nodes, prims), (n, p)| (nodes + n, prims + p)),
        }
    }

    fn bounds(&self) -> Aabb {
        match self {
            Built::Part(bvh) => bvh.total_aabb,
            Built::Join(children) => children
                .iter()
                .fold(Aabb::empty(), |a, c| a.union(&c.bounds())),
        }
    }
}

/// Joins built parts into one CWBVH: a join becomes a node of ours whose children are the
/// joined subtrees' roots; a part's nodes are copied with their child and primitive offsets
/// moved to where they now lie.
struct Joiner {
    nodes: Vec<CwBvhNode>,
    primitive_indices: Vec<u32>,
}

impl Joiner {
    fn join(built: Built) -> CwBvh {
        let (nodes, primitives) = built.sizes();
        let mut joiner = Joiner {
            nodes: Vec::with_capacity(nodes),
            // Every hit reads its triangle's id here: on huge pages.
            primitive_indices: crate::alloc::on_huge_pages(|| Vec::with_capacity(primitives)),
        };
        joiner.nodes.push(CwBvhNode::default());
        let total_aabb = joiner.place(built, 0);
        CwBvh {
            nodes: joiner.nodes,
            primitive_indices: joiner.primitive_indices,
            total_aabb,
            exact_node_aabbs: None,
            uses_spatial_splits: false,
        }
    }

    /// Writes `built` with its root node at index `at`; returns its box.
    fn place(&mut self, built: Built, at: usize) -> Aabb {
        let children = match built {
            Built::Part(part) => return self.copy_part(part, at),
            Built::Join(children) => children,
        };
        let boxes: Vec<Aabb> = children.iter().map(Built::bounds).collect();
        let node_box = boxes.iter().fold(Aabb::empty(), |a, b| a.union(b));
        let centres: Vec<Vec3A> = boxes.iter().map(Aabb::center).collect();
        let slots = &octant_slots(node_box.center(), &centres)[..centres.len()];
        // The children's roots lie side by side from `base`, in slot order.
        let base = self.nodes.len();
        self.nodes
            .resize(base + children.len(), CwBvhNode::default());
        self.nodes[at] = join_node(&node_box, &boxes, slots, base as u32);
        for (child, slot) in children.into_iter().zip(slots) {
            let rank = slots.iter().filter(|&s| s < slot).count();
            self.place(child, base + rank);
        }
        node_box
    }

    /// Copies `part` with its root at index `at` and its other nodes appended; returns its box.
    fn copy_part(&mut self, part: CwBvh, at: usize) -> Aabb {
        // The part's node i ≥ 1 lands at index `moved + i`: its own child indices are ≥ 1.
        let moved = self.nodes.len() as u32 - 1;
        let prims = self.primitive_indices.len() as u32;
        let relocate = |node: &CwBvhNode| CwBvhNode {
            child_base_idx: node.child_base_idx + moved,
            primitive_base_idx: node.primitive_base_idx + prims,
            ..*node
        };
        let mut nodes = part.nodes.iter().map(relocate);
        self.nodes[at] = nodes.next().expect("a part has a root");
        self.nodes.extend(nodes);
        self.primitive_indices
            .extend_from_slice(&part.primitive_indices);
        part.total_aabb
    }
}

/// A CWBVH node whose children are all interior nodes, child c in slot `slots[c]` with box
/// `boxes[c]`, the first child's node at `child_base`, the boxes quantised as obvhs quantises
/// them ([`NodeGrid`]).
fn join_node(node_box: &Aabb, boxes: &[Aabb], slots: &[usize], child_base: u32) -> CwBvhNode {
    let grid = NodeGrid::new(node_box);
    let mut node = grid.empty_node();
    node.child_base_idx = child_base;
    for (b, &s) in boxes.iter().zip(slots) {
        grid.set_box(&mut node, s, b);
        node.imask |= 1 << s;
        node.child_meta[s] = 0b0010_0000 | (24 + s as u8);
    }
    node
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::tests::{triangle_soup, tris_centre, uniforms};
    use super::super::Accel;
    use super::*;

    /// 40,000 triangles (above the thorough-build limit) in parts of at most 600: 512 parts
    /// under three levels of joins.
    fn soup() -> Scene {
        triangle_soup(&mut uniforms(5), 40_000, 0.3)
    }

    #[test]
    fn a_tree_joined_from_parts_passes_obvhs_validation() {
        let scene = soup();
        let boxes: Vec<Aabb> = scene
            .triangles
            .iter()
            .map(|t| bvh_triangle(t.positions).aabb())
            .collect();
        // With the parts' children in octant slots (obvhs's walk) and as they come (ours).
        for ordered in [true, false] {
            let bvh = build_bvh(&scene, 600, ordered);
            // Every node reached once, every child box inside its parent's, every primitive
            // once.
            let result = bvh.validate(&boxes, false);
            assert_eq!(result.discovered_primitives.len(), scene.triangles.len());
            assert!(result.max_depth >= 4, "depth {}", result.max_depth);
        }
    }

    #[test]
    fn rays_find_the_same_hits_in_parts_as_in_one_tree() {
        // The soup as made (10 m across at the origin), 10 cm across 1 km away (triangles of
        // 3 mm, about 50 f32 steps there) and 10 km across: the join nodes' quantisation grids
        // span all these scales.
        for (scale, offset) in [(1.0, 0.0), (1e-2, 1e3), (1e3, -2e3)] {
            let mut scene = soup();
            for t in &mut scene.triangles {
                t.positions = t.positions.map(|p| p * scale + Vec3::splat(offset));
            }
            let whole = Accel::build_in_parts(&scene, usize::MAX);
            let mut parts = Accel::build_in_parts(&scene, 600);
            let mut u = uniforms(6);
            let mut hits = 0;
            for _ in 0..4000 {
                let origin =
                    (Vec3::new(u(), u(), u()) * 12.0 - Vec3::ONE) * scale + Vec3::splat(offset);
                // Near a vertex, where a triangle reaches the edge of its boxes.
                let i = (u() * 40_000.0) as usize;
                let vertex = scene.triangles[i].positions[(u() * 3.0) as usize % 3];
                let to = vertex.lerp(tris_centre(&scene, i), 0.02) - origin;
                let (dir, length) = (to.normalize(), to.length());
                let expected = whole.closest_hit(origin, dir, f32::INFINITY);
                let blocked = whole.occluded(origin, dir, length);
                hits += usize::from(expected.is_some());
                for avx2 in [false, crate::accel::has_simd_walk()] {
                    parts.avx2 = avx2;
                    let got = parts.closest_hit(origin, dir, f32::INFINITY);
                    // Two triangles at exactly the same distance (a shared vertex or edge) may
                    // be found in either order.
                    let tie = got.zip(expected).is_some_and(|(a, b)| a.t == b.t);
                    assert!(
                        got == expected || tie,
                        "scale {scale}: {got:?} {expected:?}"
                    );
                    assert_eq!(
                        parts.occluded(origin, dir, length),
                        blocked,
                        "scale {scale}"
                    );
                }
            }
            assert!(hits > 3000, "scale {scale}: {hits} of 4000 rays hit");
        }
    }

    #[test]
    fn the_joined_tree_does_not_depend_on_the_number_of_threads() {
        let scene = soup();
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            (
                pool.install(|| build_bvh(&scene, 600, true)),
                pool.install(|| build_bvh(&scene, 600, false)),
            )
        };
        let (one, three) = (build(1), build(3));
        for (one, three) in [(one.0, three.0), (one.1, three.1)] {
            assert!(one.nodes == three.nodes);
            assert_eq!(one.primitive_indices, three.primitive_indices);
        }
    }
}
