//! Cutting a large scene's triangles into parts for the BVH build (`build.rs`): binned
//! surface-area-heuristic splits over the triangles' box centres (Wald, "On fast Construction of
//! SAH-based Bounding Volume Hierarchies", 2007), as a top-down builder makes its top levels.
//! A cut minimises A(left)·N(left) + A(right)·N(right) over 32 bins per axis, A the surface area
//! of a side's box and N its triangle count.

use glam::{UVec3, Vec3, Vec3A};
use rayon::prelude::*;

/// Bins per axis.
const BINS: usize = 32;
/// Items per rayon task when binning.
const PARALLEL_MIN_LEN: usize = 1 << 14;

/// A triangle's bounding box and its id in the scene.
#[derive(Clone, Copy, Debug)]
pub(super) struct Item {
    pub(super) lo: Vec3,
    pub(super) hi: Vec3,
    pub(super) id: u32,
}

impl Item {
    fn centre(&self) -> Vec3A {
        (Vec3A::from(self.lo) + Vec3A::from(self.hi)) * 0.5
    }
}

/// The box of a group's item centres: the range the bins divide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Centres {
    lo: Vec3A,
    hi: Vec3A,
}

impl Centres {
    const EMPTY: Centres = Centres {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    fn add(self, other: Centres) -> Centres {
        Centres {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// The centres' box of `items` (in parallel).
    pub(super) fn of(items: &[Item]) -> Centres {
        items
            .par_iter()
            .with_min_len(PARALLEL_MIN_LEN)
            .fold(
                || Centres::EMPTY,
                |b, item| {
                    let c = item.centre();
                    b.add(Centres { lo: c, hi: c })
                },
            )
            .reduce(|| Centres::EMPTY, Centres::add)
    }
}

/// The boxes of some items, of their centres, and how many they are.
#[derive(Clone, Copy)]
struct Bin {
    lo: Vec3A,
    hi: Vec3A,
    centres: Centres,
    count: usize,
}

impl Bin {
    const EMPTY: Bin = Bin {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        centres: Centres::EMPTY,
        count: 0,
    };

    fn add(self, other: Bin) -> Bin {
        Bin {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            centres: self.centres.add(other.centres),
            count: self.count + other.count,
        }
    }

    /// Surface area × count (0 for an empty bin).
    fn cost(&self) -> f64 {
        if self.count == 0 {
            return 0.0;
        }
        let d = (self.hi - self.lo).as_dvec3();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x) * self.count as f64
    }
}

/// Reorders `items` (at least two, their centres' box `centres`) into two non-empty halves by
/// the cheapest binned SAH split, or by the median along the widest axis where every centre
/// falls in one bin; returns the length of the first half and the centres' boxes of the two
/// halves. The same items in the same order always give the same cut.
pub(super) fn sah_cut(items: &mut [Item], centres: Centres) -> (usize, Centres, Centres) {
    let Centres { lo, hi } = centres;
    let active = [0, 1, 2].map(|axis| hi[axis] > lo[axis]);
    // An item's bin on every axis at once (those of inactive axes unused).
    let bins_of = |item: &Item| {
        let t = (item.centre() - lo) / (hi - lo) * BINS as f32;
        t.as_uvec3().min(UVec3::splat(BINS as u32 - 1))
    };
    // Every axis binned in one pass; chunks binned in parallel and their bins merged (min, max
    // and counts: the same bins in any order).
    let bins = items
        .par_chunks(PARALLEL_MIN_LEN)
        .map(|chunk| {
            let mut bins = [[Bin::EMPTY; BINS]; 3];
            for item in chunk {
                let c = item.centre();
                let one = Bin {
                    lo: item.lo.into(),
                    hi: item.hi.into(),
                    centres: Centres { lo: c, hi: c },
                    count: 1,
                };
                let k = bins_of(item);
                for axis in (0..3).filter(|&axis| active[axis]) {
                    let bin = &mut bins[axis][k[axis] as usize];
                    *bin = bin.add(one);
                }
            }
            bins
        })
        .reduce(
            || [[Bin::EMPTY; BINS]; 3],
            |mut a, b| {
                for (x, y) in a.iter_mut().flatten().zip(b.iter().flatten()) {
                    *x = x.add(*y);
                }
                a
            },
        );
    let mut best: Option<(f64, usize, usize, Centres, Centres)> = None;
    for (axis, bins) in bins.iter().enumerate().filter(|(axis, _)| active[*axis]) {
        // right[k]: bins k.. together.
        let mut right = [Bin::EMPTY; BINS];
        let mut sum = Bin::EMPTY;
        for k in (1..BINS).rev() {
            sum = sum.add(bins[k]);
            right[k] = sum;
        }
        let mut left = Bin::EMPTY;
        for k in 1..BINS {
            left = left.add(bins[k - 1]);
            if left.count == 0 || right[k].count == 0 {
                continue;
            }
            let cost = left.cost() + right[k].cost();
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, k, left.centres, right[k].centres));
            }
        }
    }
    match best {
        Some((_, axis, k, left, right)) => {
            let mid = partition(items, |item| (bins_of(item)[axis] as usize) < k);
            (mid, left, right)
        }
        None => {
            let mid = median_cut(items, (hi - lo).max_position());
            (mid, Centres::of(&items[..mid]), Centres::of(&items[mid..]))
        }
    }
}

/// Moves the items for which `first` holds to the front; returns how many there are.
fn partition(items: &mut [Item], first: impl Fn(&Item) -> bool) -> usize {
    let mut front = 0;
    for k in 0..items.len() {
        if first(&items[k]) {
            items.swap(front, k);
            front += 1;
        }
    }
    front
}

/// The median cut along `axis` (ties broken by id).
fn median_cut(items: &mut [Item], axis: usize) -> usize {
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| {
        a.centre()[axis]
            .total_cmp(&b.centre()[axis])
            .then(a.id.cmp(&b.id))
    });
    mid
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(x: f32, size: f32, id: u32) -> Item {
        Item {
            lo: Vec3::new(x, 0.0, 0.0),
            hi: Vec3::new(x + size, size, size),
            id,
        }
    }

    #[test]
    fn the_cut_falls_in_the_gap_between_two_clusters() {
        // 300 small boxes near x = 0..1 and 100 near x = 10..11: the cheapest cut separates them
        // (a median cut would split the larger cluster).
        let mut items: Vec<Item> = (0..400)
            .map(|i| {
                let x = if i % 4 == 0 { 10.0 } else { 0.0 } + (i as f32 * 0.618).fract();
                item(x, 0.01, i)
            })
            .collect();
        let centres = Centres::of(&items);
        let (mid, left, right) = sah_cut(&mut items, centres);
        assert_eq!(mid, 300);
        assert_eq!(left, Centres::of(&items[..mid]));
        assert_eq!(right, Centres::of(&items[mid..]));
        assert!(items[..mid].iter().all(|it| it.lo.x < 5.0));
        assert!(items[mid..].iter().all(|it| it.lo.x > 5.0));
    }

    #[test]
    fn boxes_with_one_centre_are_cut_in_half() {
        let mut items: Vec<Item> = (0..9).map(|i| item(1.0, 1.0, 8 - i)).collect();
        let centres = Centres::of(&items);
        let (mid, left, right) = sah_cut(&mut items, centres);
        assert_eq!(mid, 4);
        assert_eq!(left, Centres::of(&items[..mid]));
        assert_eq!(right, Centres::of(&items[mid..]));
        let mut ids: Vec<u32> = items.iter().map(|it| it.id).collect();
        ids.sort();
        assert_eq!(ids, (0..9).collect::<Vec<_>>());
    }
}
