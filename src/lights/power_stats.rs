//! How emitted power is spread over the lights: what decides whether power-proportional
//! selection helps (a few lights holding most of the power) or not (equal lights).

use super::{Light, Lights};

/// Summary of the lights' powers Φ (f64).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PowerStats {
    pub count: usize,
    pub zero: usize,
    pub min_positive: f64,
    pub median: f64,
    pub max: f64,
    pub total: f64,
    /// Share of the total power held by the brightest 1% of lights (at least one light).
    pub top_percent_share: f64,
    /// (decade d, count of lights with 10^d ≤ Φ < 10^(d+1)), ascending, positive powers only.
    pub decades: Vec<(i32, usize)>,
    pub one_sided: usize,
    pub two_sided: usize,
}

impl PowerStats {
    /// None when there are no lights.
    pub fn of(lights: &Lights) -> Option<PowerStats> {
        let mut powers = lights.powers();
        if powers.is_empty() {
            return None;
        }
        powers.sort_by(|a, b| a.total_cmp(b));
        let count = powers.len();
        let total: f64 = powers.iter().sum();
        let top = count.div_ceil(100);
        let top_sum: f64 = powers[count - top..].iter().sum();
        let positive: Vec<f64> = powers.iter().copied().filter(|&p| p > 0.0).collect();
        let mut decades: Vec<(i32, usize)> = Vec::new();
        for p in &positive {
            let d = p.log10().floor() as i32;
            match decades.last_mut() {
                Some((last, n)) if *last == d => *n += 1,
                _ => decades.push((d, 1)),
            }
        }
        let two_sided = lights
            .lights
            .iter()
            .filter(|l| matches!(l, Light::Triangle(t) if t.two_sided))
            .count();
        Some(PowerStats {
            count,
            zero: count - positive.len(),
            min_positive: positive.first().copied().unwrap_or(0.0),
            median: powers[count / 2],
            max: powers[count - 1],
            total,
            top_percent_share: if total > 0.0 { top_sum / total } else { 0.0 },
            decades,
            one_sided: lights.triangle_count() - two_sided,
            two_sided,
        })
    }

    /// A text histogram over decades of Φ, one line per decade, bars scaled to `width`.
    pub fn histogram(&self, width: usize) -> String {
        let most = self
            .decades
            .iter()
            .map(|&(_, n)| n)
            .max()
            .unwrap_or(1)
            .max(1);
        self.decades
            .iter()
            .map(|&(d, n)| {
                let bar = "#".repeat(((n * width).div_ceil(most)).max(1));
                format!("  [1e{d:+03}, 1e{:+03}) W {n:>9} {bar}\n", d + 1)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::TriangleLight;
    use glam::Vec3;

    fn light(radiance: f32, two_sided: bool) -> Light {
        // Area 1/π … chosen so that Φ = π·A·L = L (one-sided).
        Light::Triangle(TriangleLight {
            p0: Vec3::ZERO,
            e1: Vec3::X,
            e2: Vec3::Y,
            normal: Vec3::Z,
            area: 1.0 / std::f32::consts::PI,
            radiance: Vec3::splat(radiance),
            two_sided,
            textured: false,
            triangle: 0,
        })
    }

    #[test]
    fn summary_by_hand() {
        let mut lights = Lights::default();
        // Φ = 2, 2, 20, 200 (two-sided: 2·100), 0 and 2000: away from decade boundaries, where
        // f32 rounding of π·(1/π) could tip a light into the decade below.
        for (l, two) in [
            (2.0, false),
            (2.0, false),
            (20.0, false),
            (100.0, true),
            (0.0, false),
            (2000.0, false),
        ] {
            lights.lights.push(light(l, two));
        }
        let s = PowerStats::of(&lights).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-4 * b.abs().max(1e-9);
        assert_eq!((s.count, s.zero, s.one_sided, s.two_sided), (6, 1, 5, 1));
        assert!(close(s.total, 2224.0) && close(s.max, 2000.0) && close(s.min_positive, 2.0));
        // Sorted: 0, 2, 2, 20, 200, 2000 → element 3 is the median.
        assert!(close(s.median, 20.0));
        // Top 1% of 6 lights rounds up to one light: 2000 / 2224.
        assert!(close(s.top_percent_share, 2000.0 / 2224.0));
        let decades: Vec<i32> = s.decades.iter().map(|d| d.0).collect();
        assert_eq!(decades, vec![0, 1, 2, 3]);
        assert_eq!(s.decades[0].1, 2);
        assert_eq!(s.histogram(10).lines().count(), 4);
    }
}
