use glam::Vec3;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::ploc::PlocBuilder;
use obvhs::triangle::Triangle as BvhTriangle;
use obvhs::BvhBuildParams;

use super::super::tests::uniforms;
use super::*;

/// obvhs's binary tree over `tris` with its medium preset, optionally followed by reinsertion
/// (which moves nodes away from the builder's layout).
fn binary(tris: &[BvhTriangle], reinsert: bool) -> Bvh2 {
    let params = BvhBuildParams::medium_build();
    let boxes: Vec<Aabb> = tris.iter().map(BvhTriangle::aabb).collect();
    let mut bvh2 = Bvh2::default();
    PlocBuilder::default().build_with_bvh(
        &mut bvh2,
        params.ploc_search_distance,
        &boxes,
        (0..boxes.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    if reinsert {
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    }
    bvh2
}

fn triangle(a: Vec3, b: Vec3, c: Vec3) -> BvhTriangle {
    BvhTriangle {
        v0: a.into(),
        v1: b.into(),
        v2: c.into(),
    }
}

/// `count` random triangles of about `size` in the cube [0, 10]³.
fn soup(seed: u64, count: usize, size: f32) -> Vec<BvhTriangle> {
    let mut u = uniforms(seed);
    let mut point = move || Vec3::new(u(), u(), u());
    (0..count)
        .map(|_| {
            let c = point() * 10.0;
            let mut corner = || c + (point() - Vec3::splat(0.5)) * size;
            triangle(corner(), corner(), corner())
        })
        .collect()
}

/// Equal triangles side by side on a plane (z = 0): equal costs everywhere, boxes of no depth.
fn flat_grid(side: usize) -> Vec<BvhTriangle> {
    (0..side * side)
        .map(|i| {
            let o = Vec3::new((i % side) as f32, (i / side) as f32, 0.0);
            triangle(o, o + Vec3::X, o + Vec3::Y)
        })
        .collect()
}

#[test]
fn collapses_to_the_same_tree_as_obvhs() {
    let mut scenes = vec![
        ("one", soup(1, 1, 0.5)),
        ("two", soup(2, 2, 0.5)),
        ("three", soup(3, 3, 0.5)),
        ("seven", soup(4, 7, 0.5)),
        ("200 large", soup(5, 200, 4.0)),
        ("3000 small", soup(6, 3000, 0.2)),
        ("flat grid", flat_grid(40)),
    ];
    // The same triangle many times over: every node's box and cost alike.
    scenes.push(("stacked", vec![soup(7, 1, 1.0)[0]; 50]));
    let mut collapser = Collapser::default();
    let mut compared = 0;
    // Interior nodes whose children lie before them (reinsertion moves some there): the
    // bottom-up scan evaluates those on demand, and the test must reach that case.
    let mut children_before = 0;
    for (name, tris) in &scenes {
        for reinsert in [false, true] {
            let bvh2 = binary(tris, reinsert);
            children_before += (bvh2.nodes.iter().enumerate())
                .filter(|(i, n)| !n.is_leaf() && (n.first_index as usize) < *i)
                .count();
            for leaf_max in 1..=3 {
                for ordered in [false, true] {
                    let theirs = bvh2_to_cwbvh(&bvh2, leaf_max, ordered, false);
                    let ours = collapser.collapse(&bvh2, leaf_max, ordered);
                    assert!(
                        ours.nodes == theirs.nodes,
                        "{name}, reinsert {reinsert}, leaf_max {leaf_max}, ordered {ordered}: \
                         {} nodes against {}",
                        ours.nodes.len(),
                        theirs.nodes.len()
                    );
                    assert_eq!(ours.primitive_indices, theirs.primitive_indices, "{name}");
                    assert_eq!(ours.total_aabb, theirs.total_aabb, "{name}");
                    compared += ours.nodes.len();
                }
            }
        }
    }
    assert!(compared > 10_000, "{compared} nodes compared");
    assert!(children_before > 0);
}

#[test]
fn wider_leaves_make_fewer_nodes() {
    // The programme must take what leaf_max allows: with leaves of up to three triangles a
    // tree of random small triangles needs fewer wide nodes than with one.
    let bvh2 = binary(&soup(8, 5000, 0.1), true);
    let mut collapser = Collapser::default();
    let counts: Vec<usize> = (1..=3)
        .map(|leaf_max| collapser.collapse(&bvh2, leaf_max, false).nodes.len())
        .collect();
    assert!(counts[0] > counts[1] && counts[1] > counts[2], "{counts:?}");
}
