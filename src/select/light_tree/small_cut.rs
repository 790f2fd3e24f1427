//! The lanes of a wide node over a small subtree (at most [`SMALL_SUBTREE`] lights): the cut with
//! the fewest wide nodes below it in all, after Ylitie, Karras & Laine 2017, who collapse a binary
//! BVH into wide nodes by a cost over cuts the same way (here the cost is the node count alone).
//! Opening by priority alone leaves small subtrees of two or three lights as lanes, each then a
//! wide node of two or three lanes out of eight; near the leaves, where that happens, the count
//! decides. Measured (bytes: the 1M city render's selection line; χ²: `cargo bench --bench
//! selection_quality`): up to 16 lights, 76.7 → 63.8 B per light, mean χ² town 2.03 → 2.03, city
//! 1.69 → 1.72 (one point's χ² 6.9 → 30 moves the city's W²-weighted χ² 1.27 → 1.91; one sample's
//! lit MSE moves < 1%); up to 32 lights 52.7 B, town's mean χ² 2.19.

use super::*;

/// Subtrees of at most this many lights are cut by the node count.
pub(super) const SMALL_SUBTREE: usize = 16;

/// How a binary node of a small subtree is best collapsed: `nodes` wide nodes below it in all
/// when it is opened into at most eight lanes (0 for a leaf), `lanes` the fewest lanes that
/// reach that count (1 for a leaf). Kept as one lane instead, an interior node costs one wide
/// node more (its own); opened into fewer than `lanes` lanes it costs at least as much as
/// kept whole.
/// So the two numbers describe every choice: kept (1 lane) or opened (`lanes` lanes).
/// `opened` records which of an interior node's children that cut opens.
#[derive(Clone, Copy, Debug, Default)]
struct Fewest {
    nodes: u32,
    lanes: u8,
    opened: [bool; 2],
}

/// [`Fewest`] of every binary node of one small subtree (depth-first: node `root + i` at i).
/// An entry depends on its node's subtree only, so the table of a subtree serves the smaller
/// subtrees inside it as well: the wide nodes below a small subtree's root reuse its table.
/// One table is refilled in place from subtree to subtree (returned by value, each was copied).
pub(super) struct Table {
    root: usize,
    /// Its binary nodes: `root .. root + len`.
    len: usize,
    fewest: [Fewest; 2 * SMALL_SUBTREE - 1],
}

impl Table {
    /// A table that covers no subtree.
    pub(super) fn empty() -> Table {
        Table {
            root: usize::MAX,
            len: 0,
            fewest: [Fewest::default(); 2 * SMALL_SUBTREE - 1],
        }
    }

    /// Makes this the table of `root`'s subtree: children before parents, from the subtree's
    /// last node back to its root.
    fn fill(&mut self, binary: &[Node], root: Lane) {
        (self.root, self.len) = (root.index, 2 * root.count - 1);
        for i in (0..2 * root.count - 1).rev() {
            let index = root.index + i;
            self.fewest[i] = if is_unit(binary, index) {
                Fewest {
                    nodes: 0,
                    lanes: 1,
                    opened: [false; 2],
                }
            } else {
                let (nodes, lanes, opened) = self.best_split(binary, index);
                Fewest {
                    nodes,
                    lanes,
                    opened,
                }
            };
        }
    }

    /// Whether the subtree of `lane` is within this table's.
    fn covers(&self, lane: Lane) -> bool {
        self.root <= lane.index && lane.index + 2 * lane.count - 1 <= self.root + self.len
    }

    fn get(&self, index: usize) -> Fewest {
        self.fewest[index - self.root]
    }

    /// (nodes, lanes) of keeping binary node `index` as one lane.
    fn kept(&self, binary: &[Node], index: usize) -> (u32, u8) {
        let f = self.get(index);
        if is_unit(binary, index) {
            (f.nodes, f.lanes)
        } else {
            (f.nodes + 1, 1)
        }
    }

    /// How interior node `index`'s two children take part in its cut: (wide nodes, lanes,
    /// [left opened, right opened]) with the fewest nodes within eight lanes, then the fewest
    /// lanes; between equal choices the child of larger [`opening_priority`] is opened.
    fn best_split(&self, binary: &[Node], index: usize) -> (u32, u8, [bool; 2]) {
        let (left, right) = (index + 1, binary[index].link as usize);
        let option = |child: usize, opened: bool| {
            let f = self.get(child);
            if opened {
                (f.nodes, f.lanes)
            } else {
                self.kept(binary, child)
            }
        };
        let first = usize::from(opening_priority(&binary[right]) > opening_priority(&binary[left]));
        // The order (nodes, lanes, first child kept) as one integer: nodes from bit 16, lanes
        // (< 256) from bit 1, the flag in bit 0.
        let mut best = (u64::MAX, [false; 2]);
        for opened in [[true, true], [true, false], [false, true], [false, false]] {
            let (ln, ll) = option(left, opened[0]);
            let (rn, rl) = option(right, opened[1]);
            let (nodes, lanes) = (ln + rn, ll + rl);
            let key = u64::from(nodes) << 16 | u64::from(lanes) << 1 | u64::from(!opened[first]);
            if usize::from(lanes) <= LANES && key < best.0 {
                best = (key, opened);
            }
        }
        ((best.0 >> 16) as u32, (best.0 >> 1) as u8, best.1)
    }

    /// Appends to `lanes` (from `used` on) the cut [`best_split`](Self::best_split) chose for
    /// interior lane `lane` (kept in the table), left to right.
    fn cut(
        &self,
        binary: &[Node],
        lane: Lane,
        lanes: &mut [Option<Lane>; LANES],
        used: &mut usize,
    ) {
        let (left, right) = halves(binary, lane);
        let opened = self.get(lane.index).opened;
        for (half, opened) in [(left, opened[0]), (right, opened[1])] {
            if opened && !is_unit(binary, half.index) {
                self.cut(binary, half, lanes, used);
            } else {
                lanes[*used] = Some(half);
                *used += 1;
            }
        }
    }
}

/// How many wide nodes the subtree of interior binary node `start` (at most [`SMALL_SUBTREE`]
/// lights) makes when collapsed by [`small_cut`], its own included: its cut's count, which the
/// cuts below reach (each is the fewest for its own subtree, the table's subproblem; the lanes
/// opened afterwards add none). `table` is refilled with `start`'s.
pub(super) fn small_count(binary: &[Node], start: Lane, table: &mut Table) -> usize {
    table.fill(binary, start);
    table.get(start.index).nodes as usize + 1
}

/// The lanes of the wide node rooted at interior binary node `start` (at most
/// [`SMALL_SUBTREE`] lights): the cut with the fewest wide nodes in all, in light-id order;
/// lanes left over then open, largest [`opening_priority`] first, the interior lanes whose two
/// children as lanes add no wide node. `table` holds the table last made, which is reused when
/// it covers `start` and refilled with `start`'s otherwise.
pub(super) fn small_cut(binary: &[Node], start: Lane, table: &mut Table) -> OpenLanes {
    if !table.covers(start) {
        table.fill(binary, start);
    }
    let mut lanes = [None; LANES];
    let mut used = 0;
    table.cut(binary, start, &mut lanes, &mut used);
    let free = |lane: &Lane| {
        let (left, right) = halves(binary, *lane);
        let split = table.kept(binary, left.index).0 + table.kept(binary, right.index).0;
        split <= table.kept(binary, lane.index).0
    };
    open_more(binary, lanes, used, free)
}
