//! Choosing where to split a node in the build: the binned cost over three axes
//! (Φ × orientation measure M_Ω × box area, scaled by thinness along the axis,
//! Conty Estevez & Kulla 2018 SAOH), exhaustive cuts for small nodes, and the
//! in-place partition of the lights.

use glam::{Vec3, Vec3A, Vec4};

use super::*;

/// A light as the build sees it: sanitised bounds plus its original index.
/// Laid out so that (lo, cos θo), (hi, Φ) and (w, cos θe) are each 16
/// consecutive bytes, which the binning loads as one SIMD register; 52 bytes
/// in all (the index and the two-sided flag share a word), which each level's
/// partition moves.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct Prim {
    pub(super) lo: Vec3,
    pub(super) cos_o: f32,
    pub(super) hi: Vec3,
    pub(super) phi: f32,
    pub(super) w: Vec3,
    pub(super) cos_e: f32,
    /// The original index (< 2³¹), with [`TWO_SIDED_PRIM`] set for two-sided lights.
    id_and_sides: u32,
}

/// Set in [`Prim`]'s packed index for two-sided lights.
const TWO_SIDED_PRIM: u32 = 1 << 31;

impl Prim {
    /// Stands for a light left out until it is removed (Φ = 0).
    pub(super) const LEFT_OUT: Prim = Prim {
        lo: Vec3::ZERO,
        hi: Vec3::ZERO,
        w: Vec3::ZERO,
        phi: 0.0,
        cos_o: -1.0,
        cos_e: 0.0,
        id_and_sides: 0,
    };

    /// `None` for lights left out: Φ not > 0, a non-finite field, or i ≥ 2³¹.
    /// Otherwise the box is reordered, w normalised (a zero w means every
    /// direction) and the cosines clamped to [−1, 1].
    pub(super) fn new(i: usize, b: &LightBounds) -> Option<Prim> {
        let id = u32::try_from(i).ok().filter(|&id| id < 1 << 31)?;
        let finite = b.lo.is_finite()
            && b.hi.is_finite()
            && b.w.is_finite()
            && b.phi.is_finite()
            && b.cos_theta_o.is_finite()
            && b.cos_theta_e.is_finite();
        if !(finite && b.phi > 0.0) {
            return None;
        }
        let w = b.w.normalize_or_zero();
        let cos_o = if w == Vec3::ZERO {
            -1.0
        } else {
            b.cos_theta_o.clamp(-1.0, 1.0)
        };
        Some(Prim {
            lo: b.lo.min(b.hi),
            hi: b.lo.max(b.hi),
            w,
            phi: b.phi,
            cos_o,
            cos_e: b.cos_theta_e.clamp(-1.0, 1.0),
            id_and_sides: id | if b.two_sided { TWO_SIDED_PRIM } else { 0 },
        })
    }

    /// The light's original index.
    pub(super) fn id(&self) -> u32 {
        self.id_and_sides & !TWO_SIDED_PRIM
    }

    pub(super) fn centroid(&self) -> Vec3A {
        (Vec3A::from(self.lo) + Vec3A::from(self.hi)) * 0.5
    }

    pub(super) fn aabb(&self) -> Aabb {
        Aabb {
            lo: self.lo.into(),
            hi: self.hi.into(),
        }
    }

    pub(super) fn bounds(&self) -> LightBounds {
        LightBounds {
            lo: self.lo,
            hi: self.hi,
            phi: self.phi,
            w: self.w,
            cos_theta_o: self.cos_o,
            cos_theta_e: self.cos_e,
            two_sided: self.id_and_sides & TWO_SIDED_PRIM != 0,
        }
    }
}

/// Axis-aligned box used by the build.
#[derive(Clone, Copy, Debug)]
pub(super) struct Aabb {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
}

impl Aabb {
    pub(super) const EMPTY: Aabb = Aabb {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    pub(super) fn point(p: Vec3A) -> Aabb {
        Aabb { lo: p, hi: p }
    }

    pub(super) fn merge(&self, other: &Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    pub(super) fn grow(&mut self, other: &Aabb) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }

    pub(super) fn extent(&self) -> Vec3A {
        (self.hi - self.lo).max(Vec3A::ZERO)
    }

    /// Surface area with every edge lengthened by `pad`, so that flat or
    /// collinear sets still compare by size.
    pub(super) fn padded_area(&self, pad: f32) -> f64 {
        let e = (self.extent() + pad).as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// A set of lights as the split cost sees it: box, summed Φ (f64), count,
/// the box holding their unit axes, and their widest θo and θe, as four SIMD
/// lanes each, cos θo and cos θe in the fourth lane of the lower corners
/// (both keep their smallest). Merging is component-wise, so runs of buckets
/// or lights are cheap to accumulate: adding a light is four min/max, a sum
/// and a count.
#[derive(Clone, Copy, Debug)]
pub(super) struct Side {
    /// The box's lower corner; the smallest cos θo.
    lo: Vec4,
    /// The box's upper corner; the fourth lane (the largest Φ) is unused.
    hi: Vec4,
    /// The lower corner of the box holding the unit axes; the smallest cos θe.
    axes_lo: Vec4,
    /// The upper corner of that box; the fourth lane (the largest cos θe) is unused.
    axes_hi: Vec4,
    pub(super) phi: f64,
    pub(super) count: u32,
}

impl Side {
    pub(super) const EMPTY: Side = Side {
        lo: Vec4::INFINITY,
        hi: Vec4::NEG_INFINITY,
        axes_lo: Vec4::INFINITY,
        axes_hi: Vec4::NEG_INFINITY,
        phi: 0.0,
        count: 0,
    };

    pub(super) fn of(p: &Prim) -> Side {
        let mut side = Side::EMPTY;
        side.push(p);
        side
    }

    /// Adds one light, in place.
    #[inline(always)]
    pub(super) fn push(&mut self, p: &Prim) {
        let w = Vec4::new(p.w.x, p.w.y, p.w.z, p.cos_e);
        self.lo = self.lo.min(Vec4::new(p.lo.x, p.lo.y, p.lo.z, p.cos_o));
        self.hi = self.hi.max(Vec4::new(p.hi.x, p.hi.y, p.hi.z, p.phi));
        self.axes_lo = self.axes_lo.min(w);
        self.axes_hi = self.axes_hi.max(w);
        self.phi += f64::from(p.phi);
        self.count += 1;
    }

    /// Adds `other`'s lights, in place.
    #[inline(always)]
    pub(super) fn add(&mut self, other: &Side) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
        self.axes_lo = self.axes_lo.min(other.axes_lo);
        self.axes_hi = self.axes_hi.max(other.axes_hi);
        self.phi += other.phi;
        self.count += other.count;
    }

    /// The lights' box.
    pub(super) fn bounds(&self) -> Aabb {
        Aabb {
            lo: Vec3A::from_vec4(self.lo),
            hi: Vec3A::from_vec4(self.hi),
        }
    }

    /// Writes what this set's cost needs into entry `i` of `inputs`, Φ · area
    /// scaled by `scale`.
    #[inline(always)]
    fn cost_inputs(&self, inputs: &mut CostInputs, i: usize, pad: f32, scale: f64) {
        let (a_sq, a_min) = if self.count == 1 {
            (1.0, 1.0)
        } else {
            let (lo, hi) = (
                Vec3A::from_vec4(self.axes_lo),
                Vec3A::from_vec4(self.axes_hi),
            );
            let a = lo + hi;
            (a.length_squared(), (a * lo).min(a * hi).element_sum())
        };
        inputs.phi_area[i] = (self.phi * self.bounds().padded_area(pad) * scale) as f32;
        inputs.a_sq[i] = a_sq;
        inputs.a_min[i] = a_min;
        inputs.cos_o[i] = self.lo.w;
        inputs.cos_e[i] = self.axes_lo.w;
    }
}

/// Most items [`cheapest_cut`] handles: buckets, or lights of a small node.
pub(super) const MAX_CUT_ITEMS: usize = 16;
/// Nodes with at most this many lights try every cut of their lights sorted
/// along one axis instead of binning.
pub(super) const SMALL_NODE: usize = MAX_CUT_ITEMS;
/// Nodes with at most this many lights are cut in the middle of that order:
/// their subtrees are flattened into one wide node, where the split rarely
/// shows.
pub(super) const TINY_NODE: usize = 4;

/// The cheapest cut of a sequence of `n` ≤ [`MAX_CUT_ITEMS`] sets (empty ones
/// allowed) into two non-empty runs, as (Σ side costs, length of the first
/// run); every distinct cut is tried. `scale` is 1/(Φ · padded area) of the
/// whole sequence. `inputs` is room for the sides' cost inputs: what it holds
/// before is never read for a cut that is tried (the entries of cuts not tried
/// are left as they were, and their costs ignored), so one serves every node
/// of a build.
pub(super) fn cheapest_cut(
    n: usize,
    item: impl Fn(usize) -> Side,
    pad: f32,
    scale: f64,
    inputs: &mut CostInputs,
) -> Option<(f32, usize)> {
    // Entry k: the first k + 1 items; entry n − 2 + k: items k.. .
    let mut cuts = [false; MAX_CUT_ITEMS];
    let mut suffix = Side::EMPTY;
    for k in (1..n).rev() {
        suffix.add(&item(k));
        if suffix.count > 0 {
            suffix.cost_inputs(inputs, n - 2 + k, pad, scale);
            cuts[k - 1] = true;
        }
    }
    let mut prefix = Side::EMPTY;
    for (k, cut) in cuts.iter_mut().enumerate().take(n - 1) {
        let next = item(k);
        prefix.add(&next);
        *cut &= next.count > 0;
        if *cut {
            prefix.cost_inputs(inputs, k, pad, scale);
        }
    }
    let costs = inputs.costs(2 * (n - 1));
    let mut best: Option<(f32, usize)> = None;
    for k in (0..n - 1).filter(|&k| cuts[k]) {
        let cost = costs[k] + costs[n - 1 + k];
        if cost.is_finite() && best.is_none_or(|b| cost < b.0) {
            best = Some((cost, k + 1));
        }
    }
    best
}

/// Maps centroids to buckets along the axes where their box has extent.
#[derive(Clone, Copy, Debug)]
pub(super) struct Binner {
    pub(super) lo: Vec3A,
    pub(super) scale: Vec3A,
    pub(super) active: [bool; 3],
}

impl Binner {
    pub(super) fn new(centroids: &Aabb) -> Binner {
        let extent = centroids.extent();
        let scale =
            |k: usize| (BUCKETS as f64 / f64::from(extent[k])).min(f64::from(f32::MAX)) as f32;
        Binner {
            lo: centroids.lo,
            scale: Vec3A::new(scale(0), scale(1), scale(2)),
            active: [0, 1, 2].map(|k| extent[k] > 0.0),
        }
    }

    /// Bucket of a centroid along each axis: the offset x ≥ 0 truncated, at most
    /// `BUCKETS` − 1 (a NaN x, from an overflowing centroid, in bucket 0). x is clamped to
    /// [0, `BUCKETS` − 1] in SIMD lanes before it is truncated (`_mm_max_ps` gives its second
    /// operand, 0, for a NaN), which gives the same bucket as truncating and then clamping but
    /// needs no saturating conversions.
    #[inline(always)]
    pub(super) fn buckets(&self, centroid: Vec3A) -> [usize; 3] {
        let x = ((centroid - self.lo) * self.scale)
            .max(Vec3A::ZERO)
            .min(Vec3A::splat((BUCKETS - 1) as f32));
        // SAFETY: every lane is in [0, BUCKETS − 1], not NaN: it fits a u32.
        [x.x, x.y, x.z].map(|x| unsafe { x.to_int_unchecked::<u32>() } as usize)
    }

    /// Whether a centroid's bucket along `axis` is below `cut` (1 ..= `BUCKETS` − 1), from the
    /// offset x that [`buckets`](Self::buckets) truncates, by the same arithmetic. x ≥ 0 (the
    /// box starts at the smallest centroid), so ⌊x⌋ < cut exactly when x < cut, and no
    /// conversion is needed; a NaN x (an overflowing centroid) truncates to bucket 0.
    /// Along axis `A`, so that the axis is not chosen again for every light.
    #[inline(always)]
    pub(super) fn below<const A: usize>(&self, centroid: Vec3A, cut: usize) -> bool {
        let x = (centroid[A] - self.lo[A]) * self.scale[A];
        x < cut as f32 || x.is_nan()
    }

    /// Bins every `step`-th light (from the first) along every axis, in one pass, into `even`
    /// (empty bins). Alternate lights of those go to a second set of bins, merged at the end,
    /// so that a run of lights in one bucket is not a chain of updates each waiting for the one
    /// before. The bins are filled in place: returned, they were copied (2,880 bytes a node).
    pub(super) fn bin(&self, prims: &[Prim], step: usize, even: &mut [[Side; BUCKETS]; 3]) {
        let mut odd = [[Side::EMPTY; BUCKETS]; 3];
        let mut at = 0;
        while at + step < prims.len() {
            self.add(even, &prims[at]);
            self.add(&mut odd, &prims[at + step]);
            at += 2 * step;
        }
        if at < prims.len() {
            self.add(even, &prims[at]);
        }
        for (bin, more) in even.iter_mut().flatten().zip(odd.iter().flatten()) {
            bin.add(more);
        }
    }

    /// Adds one light to its bucket along every axis, active or not: an inactive axis' row is
    /// never read, and pushing into it costs less than testing for it.
    #[inline(always)]
    fn add(&self, bins: &mut [[Side; BUCKETS]; 3], p: &Prim) {
        let buckets = self.buckets(p.centroid());
        for (row, bucket) in bins.iter_mut().zip(buckets) {
            row[bucket].push(p);
        }
    }
}

/// A chosen split: lights `..mid` go left; the children's centroid boxes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Split {
    pub(super) mid: usize,
    pub(super) left: Aabb,
    pub(super) right: Aabb,
}

/// Splits `prims` (≥ 2), reordering them so the left part comes first: by
/// the binned cost, by trying every cut along one axis for small nodes, in
/// the middle of that order for tiny ones; a median split when the centroids
/// cannot be separated. `inputs` is [`cheapest_cut`]'s room.
pub(super) fn choose_split(prims: &mut [Prim], centroids: Aabb, inputs: &mut CostInputs) -> Split {
    let median = Split {
        mid: prims.len() / 2,
        left: centroids,
        right: centroids,
    };
    let split = match prims.len() {
        0..=2 => None,
        3..=SMALL_NODE => small_split(prims, centroids, inputs),
        _ => binned_split(prims, centroids, inputs),
    };
    split.unwrap_or(median)
}

/// The split axis' weight Kr = (largest extent)/(extent along the axis), the
/// padding for [`Aabb::padded_area`] and the `scale` of [`cheapest_cut`], from
/// the node's lights.
pub(super) fn axis_weights(node: &Side) -> ([f64; 3], f32, f64) {
    let bounds = node.bounds();
    let extent = bounds.extent();
    let largest = extent.max_element();
    let pad = 1e-3 * largest;
    (
        [0, 1, 2].map(|k| f64::from(largest / extent[k])),
        pad,
        1.0 / (node.phi * bounds.padded_area(pad)),
    )
}

/// The stride of the sample a node of `n` lights is binned from: 1 below [`SAMPLED_MIN`],
/// else ⌊n / m⌋ for a sample of m = [`SAMPLED_MIN`] / 2 lights, or m = [`BINNED_SAMPLE`] from
/// n = 2·[`BINNED_SAMPLE`] on.
pub(super) fn sample_step(n: usize) -> usize {
    if n < SAMPLED_MIN {
        1
    } else if n < 2 * BINNED_SAMPLE {
        n / (SAMPLED_MIN / 2)
    } else {
        n / BINNED_SAMPLE
    }
}

/// Binned split: 12 buckets along each axis, every boundary tried. A node of n ≥
/// [`SAMPLED_MIN`] lights is binned from every [`sample_step`]-th light only (all are
/// partitioned).
pub(super) fn binned_split(
    prims: &mut [Prim],
    centroids: Aabb,
    inputs: &mut CostInputs,
) -> Option<Split> {
    let binner = Binner::new(&centroids);
    let mut bins = [[Side::EMPTY; BUCKETS]; 3];
    binner.bin(prims, sample_step(prims.len()), &mut bins);
    let row = bins.iter().zip(binner.active).find(|(_, a)| *a)?.0;
    let mut node = Side::EMPTY;
    row.iter().for_each(|bin| node.add(bin));
    let (kr, pad, scale) = axis_weights(&node);
    let mut best: Option<(f64, usize, usize)> = None;
    for (axis, row) in bins
        .iter()
        .enumerate()
        .filter(|(axis, _)| binner.active[*axis])
    {
        if let Some((cost, cut)) = cheapest_cut(BUCKETS, |k| row[k], pad, scale, inputs) {
            let cost = kr[axis] * f64::from(cost);
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, cut));
            }
        }
    }
    let (_, axis, cut) = best?;
    let (mid, left, right) = match axis {
        0 => partition(prims, |c| binner.below::<0>(c, cut)),
        1 => partition(prims, |c| binner.below::<1>(c, cut)),
        _ => partition(prims, |c| binner.below::<2>(c, cut)),
    };
    let split = Split { mid, left, right };
    (0 < mid && mid < prims.len()).then_some(split)
}

/// Split of a small node: its lights sorted by centroid along the axis where
/// the centroids spread most, then every cut tried, or the middle one for
/// [`TINY_NODE`]s (trying all three axes cost three times as much and left
/// `cargo bench --bench selection_quality`'s bvh χ² within 0.3%). The lights
/// are reordered only once a cut is found.
pub(super) fn small_split(
    prims: &mut [Prim],
    centroids: Aabb,
    inputs: &mut CostInputs,
) -> Option<Split> {
    let n = prims.len();
    let keys: [Vec3A; SMALL_NODE] = std::array::from_fn(|k| {
        prims
            .get(k)
            .map_or(Vec3A::ZERO, |p| Vec3A::from(p.lo) + Vec3A::from(p.hi))
    });
    let spread = keys[..n]
        .iter()
        .fold(Aabb::EMPTY, |b, &k| b.merge(&Aabb::point(k)))
        .extent();
    if spread.max_element() <= 0.0 {
        return None;
    }
    let order = sorted_along(&keys[..n], spread.max_position());
    let mid = if n <= TINY_NODE {
        n / 2
    } else {
        // Summed in the lights' order, as every node's Φ is.
        let mut node = Side::EMPTY;
        prims.iter().for_each(|p| node.push(p));
        let (_, pad, scale) = axis_weights(&node);
        let item = |k: usize| Side::of(&prims[usize::from(order[k])]);
        cheapest_cut(n, item, pad, scale, inputs)?.1
    };
    permute(prims, &order);
    Some(Split {
        mid,
        left: centroids,
        right: centroids,
    })
}

/// Puts light `order[k]` at position k, k < `prims.len()` (≤ [`SMALL_NODE`]), `order` being
/// a permutation of those positions: cycle by cycle, each light moved once and one per cycle
/// held aside (no copy of the whole node).
fn permute(prims: &mut [Prim], order: &[u8; SMALL_NODE]) {
    let mut placed = 0u32;
    for start in 0..prims.len() {
        if placed & 1 << start != 0 {
            continue;
        }
        let held = prims[start];
        let mut k = start;
        loop {
            placed |= 1 << k;
            let from = usize::from(order[k]);
            if from == start {
                prims[k] = held;
                break;
            }
            prims[k] = prims[from];
            k = from;
        }
    }
}

/// Positions 0..keys.len() (at most [`SMALL_NODE`]) sorted by `keys[·][axis]`,
/// ties kept in order; unused entries are 0.
pub(super) fn sorted_along(keys: &[Vec3A], axis: usize) -> [u8; SMALL_NODE] {
    let along: [f32; SMALL_NODE] =
        std::array::from_fn(|k| keys.get(k).map_or(0.0, |key| key[axis]));
    let key = |i: u8| along[usize::from(i)];
    let mut order = [0u8; SMALL_NODE];
    for i in 1..keys.len().min(SMALL_NODE) as u8 {
        let mut j = usize::from(i);
        while j > 0 && key(i).total_cmp(&key(order[j - 1])).is_lt() {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = i;
    }
    order
}

/// Moves the lights whose centroid `goes_left` to the front (swapping
/// misplaced pairs from both ends); returns how many, and the boxes of the
/// centroids that went left and right (each light is tested once).
pub(super) fn partition(
    prims: &mut [Prim],
    goes_left: impl Fn(Vec3A) -> bool,
) -> (usize, Aabb, Aabb) {
    let (mut left, mut right) = (Aabb::EMPTY, Aabb::EMPTY);
    let mut sorts_left = |p: &Prim| {
        let c = p.centroid();
        let is_left = goes_left(c);
        if is_left {
            left.grow(&Aabb::point(c));
        } else {
            right.grow(&Aabb::point(c));
        }
        is_left
    };
    let (mut i, mut j) = (0, prims.len());
    loop {
        while i < j && sorts_left(&prims[i]) {
            i += 1;
        }
        while i < j && !sorts_left(&prims[j - 1]) {
            j -= 1;
        }
        if i + 1 >= j {
            return (i, left, right);
        }
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}
