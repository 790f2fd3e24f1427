//! The collapse: a small subtree's wide nodes are as few as any cut into lanes allows, found
//! here by trying every cut.

use super::*;
use crate::select::light_tree::traverse::binary_tree;

#[test]
fn small_subtrees_take_the_fewest_wide_nodes() {
    let mut rng = Rand::new(13);
    let mut checked = 0;
    for count in [20, 300, 3000] {
        let scene = random_scene(&mut rng, count);
        let (binary, _, _, _) = binary_tree(scene.bounds.len(), |i| scene.bounds[i]);
        let lights = lights_below(&binary);
        for (index, &lights) in lights.iter().enumerate() {
            if is_unit(&binary, index) || lights > SMALL_SUBTREE {
                continue;
            }
            let lane = Lane {
                index,
                first: 0,
                count: lights,
            };
            assert_eq!(
                count_wide(&binary, lane),
                fewest_by_enumeration(&binary, index)
            );
            checked += 1;
        }
    }
    println!("{checked} subtrees of at most {SMALL_SUBTREE} lights checked");
    assert!(checked > 1000);
}

/// Lights below each binary node.
fn lights_below(binary: &[Node]) -> Vec<usize> {
    let mut lights = vec![1; binary.len()];
    for index in (0..binary.len()).rev() {
        if !binary[index].is_leaf() {
            lights[index] = lights[index + 1] + lights[binary[index].link as usize];
        }
    }
    lights
}

/// The fewest wide nodes for the subtree of interior node `v`, its own included: one, plus the
/// least over every cut of `v` into at most eight lanes.
fn fewest_by_enumeration(binary: &[Node], v: usize) -> usize {
    1 + opened(binary, v)
        .into_iter()
        .flatten()
        .min()
        .expect("two lanes at least")
}

/// Entry j − 1: the fewest wide nodes below `v`'s own when it is opened into exactly j lanes.
fn opened(binary: &[Node], v: usize) -> [Option<usize>; LANES] {
    let left = as_lanes(binary, v + 1);
    let right = as_lanes(binary, binary[v].link as usize);
    let mut out = [None; LANES];
    for (i, a) in left.iter().enumerate() {
        for (j, b) in right.iter().enumerate() {
            if let (Some(a), Some(b), Some(slot)) = (a, b, out.get_mut(i + j + 1)) {
                *slot = Some(slot.map_or(a + b, |s: usize| s.min(a + b)));
            }
        }
    }
    out
}

/// Entry j − 1: the fewest wide nodes that node `x` as exactly j lanes brings: kept as one lane
/// (none for a light or a pair, its own and those below for a subtree) or opened.
fn as_lanes(binary: &[Node], x: usize) -> [Option<usize>; LANES] {
    if is_unit(binary, x) {
        let mut light = [None; LANES];
        light[0] = Some(0);
        return light;
    }
    let mut lanes = opened(binary, x);
    lanes[0] = Some(fewest_by_enumeration(binary, x));
    lanes
}

#[test]
fn every_wide_node_is_reached_once_from_the_root() {
    // The collapse sizes each subtree's block by counting first (small subtrees by their cut's
    // node count); a miscount would leave unreached nodes or write one subtree over another.
    let mut rng = Rand::new(29);
    for count in [2, 9, 17, 300, 3000, 20_000] {
        let scene = random_scene(&mut rng, count);
        let (binary, grid, _, points) = binary_tree(scene.bounds.len(), |i| scene.bounds[i]);
        let (nodes, _) = collapse(&binary, &grid, &points);
        let mut reached = vec![0u32; nodes.len()];
        let mut pending = vec![0usize];
        while let Some(index) = pending.pop() {
            reached[index] += 1;
            let node = &nodes[index];
            for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
                let child = node.child(k);
                if child & LIGHT_LANE == 0 {
                    pending.push(child as usize);
                }
            }
        }
        assert!(
            reached.iter().all(|&r| r == 1),
            "{count} lights: {} nodes, {} reached once",
            nodes.len(),
            reached.iter().filter(|&&r| r == 1).count()
        );
    }
}
