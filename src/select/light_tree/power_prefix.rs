//! The choice inside a lane the walk does not descend (a far cluster, see `lanes`): a light of the
//! lane's id range [first, end) with probability ∝ its power, read from prefix sums
//! S_i = Φ_0 + … + Φ_(i−1) over the lights in leaf order (f64): light l ∈ [first, end) is taken
//! with probability (S_(l+1) − S_l) / (S_end − S_first), counting measure over light ids, which
//! `pmf` returns bit for bit. Every light of the tree has Φ > 0; where a light's interval
//! S_(l+1) − S_l rounds to 0 (its Φ below the f64 rounding of the sum before it: powers over more
//! than ~15 decades in one scene) the prefix is not built and the walk always descends, so that no
//! light is ever given probability 0.

/// Prefix sums of the tree's lights' powers in leaf order (`sums[i]` = Σ Φ_j for j < i).
#[derive(Clone, Debug, Default)]
pub(super) struct PowerPrefix {
    sums: Vec<f64>,
}

impl PowerPrefix {
    /// The prefix over `phi` (each > 0), or `None` where some light's interval rounds to 0 or
    /// there is no light.
    pub(super) fn new(phi: &[f32]) -> Option<PowerPrefix> {
        if phi.is_empty() {
            return None;
        }
        // On huge pages: a far lane's choice searches them.
        let mut sums = crate::alloc::on_huge_pages(|| Vec::with_capacity(phi.len() + 1));
        let mut sum = 0.0f64;
        sums.push(sum);
        for &p in phi {
            let next = sum + f64::from(p);
            if next <= sum {
                return None;
            }
            sum = next;
            sums.push(sum);
        }
        Some(PowerPrefix { sums })
    }

    /// The light l ∈ [first, end) whose interval [S_l, S_(l+1)) holds S_first + u·(S_end −
    /// S_first) (the last light where rounding puts it at S_end), and its probability. `first` <
    /// `end` ≤ the number of lights, u ∈ [0, 1).
    #[inline(always)]
    pub(super) fn choose(&self, first: usize, end: usize, u: f64) -> (usize, f64) {
        let (lo, hi) = (self.sums[first], self.sums[end]);
        let target = u.mul_add(hi - lo, lo);
        // The lights whose interval ends at or before the target precede the chosen one.
        let below = self.sums[first + 1..end].partition_point(|&s| s <= target);
        let light = first + below;
        (light, self.pmf(first, end, light))
    }

    /// The probability that [`choose`](Self::choose) over [first, end) returns `light` (in that
    /// range).
    #[inline(always)]
    pub(super) fn pmf(&self, first: usize, end: usize, light: usize) -> f64 {
        (self.sums[light + 1] - self.sums[light]) / (self.sums[end] - self.sums[first])
    }

    /// Heap bytes held.
    pub(super) fn bytes(&self) -> usize {
        self.sums.capacity() * std::mem::size_of::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_range_is_chosen_in_proportion_to_power_and_pmf_agrees() {
        let phi = [0.5f32, 3.0, 1e-3, 7.25, 2.0, 0.125, 40.0, 1.0];
        let prefix = PowerPrefix::new(&phi).unwrap();
        let (first, end) = (1, 7);
        let total: f64 = phi[first..end].iter().map(|&p| f64::from(p)).sum();
        let m = 1 << 20;
        let mut counts = [0usize; 8];
        for i in 0..m {
            let u = (i as f64 + 0.5) / m as f64;
            let (light, p) = prefix.choose(first, end, u);
            assert!((first..end).contains(&light));
            assert_eq!(p.to_bits(), prefix.pmf(first, end, light).to_bits());
            counts[light] += 1;
        }
        for l in first..end {
            let expected = f64::from(phi[l]) / total;
            assert!((prefix.pmf(first, end, l) - expected).abs() < 1e-12 * expected.max(1e-3));
            // Stratified u: each light's count is its share of the m points, within one point.
            let share = counts[l] as f64 / m as f64;
            assert!(
                (share - expected).abs() <= 1.5 / m as f64,
                "light {l}: {share} vs {expected}"
            );
        }
        assert_eq!(
            prefix.choose(first, end, 1.0 - f64::EPSILON / 2.0).0,
            end - 1
        );
    }

    #[test]
    fn powers_too_far_apart_for_f64_sums_give_no_prefix() {
        assert!(PowerPrefix::new(&[1.0, 1e30, 1e-20]).is_none());
        assert!(PowerPrefix::new(&[1e-20, 1.0, 1e30]).is_some());
        assert!(PowerPrefix::new(&[]).is_none());
    }
}
