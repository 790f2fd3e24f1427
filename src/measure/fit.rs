//! Least-squares line fits for convergence rates. For points (xᵢ, yᵢ), i = 1…n:
//!     slope b = Sxy / Sxx, intercept a = ȳ − b·x̄,
//!     se(b) = sqrt( Σ rᵢ² / (n − 2) / Sxx ),   95% interval b ± t₀.₉₇₅,ₙ₋₂ · se(b),
//! with rᵢ the residuals. Fitted in log-log space, b is the convergence rate: MSE ∝ spp^b,
//! b = −1 for independent samples.

use serde::Serialize;

/// A fitted line y = intercept + slope·x.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LineFit {
    pub slope: f64,
    pub intercept: f64,
    /// Standard error of the slope (infinite with two points: no residual degrees of freedom).
    pub slope_se: f64,
    /// 95% confidence interval of the slope.
    pub slope_interval: [f64; 2],
    pub points: usize,
    /// Residual standard deviation s = sqrt(RSS / (n − 2)) (infinite with two points).
    pub residual_sd: f64,
    /// Mean of the x values and Sxx = Σ (x − x̄)².
    pub x_mean: f64,
    pub sxx: f64,
}

/// Least-squares fit; None with fewer than two distinct x or a non-finite value.
pub fn fit_line(xs: &[f64], ys: &[f64]) -> Option<LineFit> {
    let n = xs.len();
    if n != ys.len() || n < 2 || xs.iter().chain(ys).any(|v| !v.is_finite()) {
        return None;
    }
    let nf = n as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / nf, ys.iter().sum::<f64>() / nf);
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let residual_sd = if n > 2 {
        let rss: f64 = xs
            .iter()
            .zip(ys)
            .map(|(x, y)| (y - intercept - slope * x).powi(2))
            .sum();
        (rss / (nf - 2.0)).sqrt()
    } else {
        f64::INFINITY
    };
    let slope_se = residual_sd / sxx.sqrt();
    let half = if n > 2 {
        t_975(n - 2) * slope_se
    } else {
        f64::INFINITY
    };
    Some(LineFit {
        slope,
        intercept,
        slope_se,
        slope_interval: [slope - half, slope + half],
        points: n,
        residual_sd,
        x_mean: mx,
        sxx,
    })
}

/// Fit of ln y against ln x; None when a value is not positive.
pub fn fit_loglog(xs: &[f64], ys: &[f64]) -> Option<LineFit> {
    if xs.iter().chain(ys).any(|&v| v <= 0.0) {
        return None;
    }
    let lx: Vec<f64> = xs.iter().map(|x| x.ln()).collect();
    let ly: Vec<f64> = ys.iter().map(|y| y.ln()).collect();
    fit_line(&lx, &ly)
}

/// The 0.975 quantile of Student's t with `df` ≥ 1 degrees of freedom: a table to 30, then the
/// Cornish–Fisher expansion z + (z³ + z)/(4ν) + (5z⁵ + 16z³ + 3z)/(96ν²) (error < 1e-3).
pub fn t_975(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => TABLE[df - 1],
        _ => {
            let z: f64 = 1.959_964;
            let v = df as f64;
            z + (z.powi(3) + z) / (4.0 * v)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * v * v)
        }
    }
}

/// Farthest the target spp may lie beyond the largest measured spp for a point estimate.
pub const EXTRAPOLATION_FACTOR: f64 = 100.0;

/// Widest ratio (upper / lower end) of the spp interval for a point estimate: one decade.
pub const MAX_INTERVAL_RATIO: f64 = 10.0;

/// One measured configuration at one spp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetPoint {
    pub spp: f64,
    pub relmse: f64,
    /// 95% interval of the relMSE across repeats, when there are several.
    pub relmse_interval: Option<[f64; 2]>,
    pub seconds: f64,
}

/// What reaching a target relMSE costs one configuration, as an interval.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TargetCost {
    /// The rate used: fitted (three or more spp values and a slope interval below 0) or −1.
    pub slope: f64,
    /// The fitted slope's 95% interval (None with fewer than three spp values).
    pub slope_interval: Option<[f64; 2]>,
    /// Whether slope −1 was assumed because the data cannot tell the rate.
    pub assumed_slope: bool,
    /// 95% interval of the spp and seconds needed (NaN when unknown: one render).
    pub spp_interval: [f64; 2],
    pub seconds_interval: [f64; 2],
    /// The point estimates, None when refused.
    pub spp: Option<f64>,
    pub seconds: Option<f64>,
    /// Why no point estimate is given.
    pub refused: Option<String>,
}

/// Extrapolates a configuration's measurements to `target` relMSE along relMSE = c·spp^b,
/// seconds = spp × (Σ seconds / Σ spp).
///
/// With three or more distinct spp and a fitted slope whose 95% interval lies below 0, b is
/// fitted in log-log space and the interval of x* = ln spp* = (ln target − a)/b is
/// x* ± t₀.₉₇₅,ₙ₋₂ · s·sqrt(1/n + (x* − x̄)²/Sxx) / |b| (the line's own standard error at x*,
/// delta method). Otherwise b = −1 is assumed (independent samples) and c is estimated from
/// each point's relMSE·spp: mean ± t₀.₉₇₅,ₙ₋₁·sd/√n over points, or a single point's interval
/// across repeats. The point estimate is refused (the interval is still given) when the
/// configuration is flagged heavy-tailed, the interval spans more than [`MAX_INTERVAL_RATIO`],
/// or the target lies beyond [`EXTRAPOLATION_FACTOR`] × the largest measured spp. None when
/// the relMSE does not fall with spp (fitted slope ≥ 0) or data are missing.
pub fn cost_to_target(
    points: &[TargetPoint],
    target: f64,
    heavy_tail: Option<&str>,
) -> Option<TargetCost> {
    let first = points.first()?;
    let valid = target > 0.0 && points.iter().all(|p| p.relmse > 0.0 && p.spp > 0.0);
    if !valid {
        return None;
    }
    let total_spp: f64 = points.iter().map(|p| p.spp).sum();
    let seconds_per_spp = points.iter().map(|p| p.seconds).sum::<f64>() / total_spp;
    let max_spp = points.iter().map(|p| p.spp).fold(0.0, f64::max);
    let mut distinct: Vec<f64> = points.iter().map(|p| p.spp).collect();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let xs: Vec<f64> = points.iter().map(|p| p.spp.ln()).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.relmse.ln()).collect();
    let fit = (distinct.len() >= 2).then(|| fit_line(&xs, &ys)).flatten();
    if fit.is_some_and(|f| f.slope.is_nan() || f.slope >= 0.0) {
        return None;
    }
    let fit = fit.filter(|_| distinct.len() >= 3);
    let ln_target = target.ln();
    let (slope, assumed, x, x_interval) = match fit.filter(|f| f.slope_interval[1] < 0.0) {
        Some(f) => {
            let x = (ln_target - f.intercept) / f.slope;
            let se =
                f.residual_sd * (1.0 / f.points as f64 + (x - f.x_mean).powi(2) / f.sxx).sqrt();
            let half = t_975(f.points - 2) * se / f.slope.abs();
            (f.slope, false, x, [x - half, x + half])
        }
        None => {
            // relMSE·spp = c: ln spp* = ln c − ln target.
            let lc: Vec<f64> = points.iter().map(|p| p.relmse.ln() + p.spp.ln()).collect();
            let n = lc.len() as f64;
            let mean = lc.iter().sum::<f64>() / n;
            let interval = if lc.len() >= 2 {
                let sd = (lc.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                let half = t_975(lc.len() - 1) * sd / n.sqrt();
                [mean - half, mean + half]
            } else {
                match first.relmse_interval {
                    Some([lo, hi]) if lo > 0.0 => {
                        [lo.ln() + first.spp.ln(), hi.ln() + first.spp.ln()]
                    }
                    Some(_) => [f64::NEG_INFINITY, f64::INFINITY],
                    None => [f64::NAN, f64::NAN],
                }
            };
            (
                -1.0,
                true,
                mean - ln_target,
                interval.map(|c| c - ln_target),
            )
        }
    };
    let spp = x.exp();
    let spp_interval = x_interval.map(f64::exp);
    let refused = if let Some(why) = heavy_tail {
        Some(format!("heavy-tailed ({why})"))
    } else if spp_interval.iter().any(|v| v.is_nan()) {
        Some("one render: no interval (use --repeat 2 or more, or several --spp)".into())
    } else if spp_interval[1] > MAX_INTERVAL_RATIO * spp_interval[0] {
        Some(format!(
            "the interval spans {:.1} decades (more than one)",
            (spp_interval[1] / spp_interval[0]).log10()
        ))
    } else if spp > EXTRAPOLATION_FACTOR * max_spp {
        Some(format!(
            "beyond {EXTRAPOLATION_FACTOR}× the largest measured spp ({max_spp})"
        ))
    } else {
        None
    };
    let point = refused.is_none();
    Some(TargetCost {
        slope,
        slope_interval: fit.map(|f| f.slope_interval),
        assumed_slope: assumed,
        spp_interval,
        seconds_interval: spp_interval.map(|s| s * seconds_per_spp),
        spp: point.then_some(spp),
        seconds: point.then_some(spp * seconds_per_spp),
        refused,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_free_power_law_gives_its_slope_and_a_zero_width_interval() {
        let spp = [4.0, 8.0, 16.0, 32.0, 64.0];
        let mse: Vec<f64> = spp.iter().map(|s: &f64| 3.0 * s.powf(-1.25)).collect();
        let f = fit_loglog(&spp, &mse).unwrap();
        assert!((f.slope + 1.25).abs() < 1e-12);
        assert!((f.intercept - 3.0f64.ln()).abs() < 1e-12);
        assert!(f.slope_interval[1] - f.slope_interval[0] < 1e-9);
    }

    #[test]
    fn interval_matches_hand_computed_residuals() {
        // y = 1 + 2x with residuals +1, −1, −1, +1 at x = 0…3: the slope stays 2 (the residuals
        // are orthogonal to x − x̄), Sxx = 5, RSS = 4, se = sqrt(4/2/5), t(2) = 4.303.
        let xs = [0.0, 1.0, 2.0, 3.0];
        let ys = [2.0, 2.0, 4.0, 8.0];
        let f = fit_line(&xs, &ys).unwrap();
        assert!((f.slope - 2.0).abs() < 1e-12);
        assert!((f.intercept - 1.0).abs() < 1e-12);
        let se = (4.0f64 / 2.0 / 5.0).sqrt();
        assert!((f.slope_se - se).abs() < 1e-12);
        assert!((f.slope_interval[1] - (2.0 + 4.303 * se)).abs() < 1e-9);
        assert!(fit_line(&[1.0, 1.0], &[2.0, 3.0]).is_none());
        assert!(fit_line(&[1.0, 2.0], &[2.0, 3.0])
            .unwrap()
            .slope_se
            .is_infinite());
    }

    #[test]
    fn t_quantiles_join_the_table_smoothly() {
        assert_eq!(t_975(10), 2.228);
        assert!((t_975(31) - 2.040).abs() < 1e-3);
        assert!((t_975(60) - 2.000).abs() < 1e-3);
        assert!((t_975(1000) - 1.962).abs() < 1e-3);
    }

    fn point(spp: f64, relmse: f64, seconds: f64) -> TargetPoint {
        TargetPoint {
            spp,
            relmse,
            relmse_interval: None,
            seconds,
        }
    }

    #[test]
    fn cost_to_target_follows_the_rate() {
        // relMSE = 1/spp, 0.1 s per spp: 0.01 needs 100 spp, 10 s.
        let exact: Vec<TargetPoint> = [1.0, 4.0, 16.0]
            .iter()
            .map(|&s| point(s, 1.0 / s, 0.1 * s))
            .collect();
        let c = cost_to_target(&exact, 0.01, None).unwrap();
        assert!((c.slope + 1.0).abs() < 1e-12 && !c.assumed_slope);
        assert!((c.seconds.unwrap() - 10.0).abs() < 1e-6);
        assert!((c.spp_interval[1] - c.spp_interval[0]).abs() < 1e-6);
        // One point with an interval across repeats: slope −1 assumed, interval scaled by spp.
        let one = TargetPoint {
            relmse_interval: Some([0.2, 0.3]),
            ..point(4.0, 0.25, 0.4)
        };
        let c = cost_to_target(&[one], 0.01, None).unwrap();
        assert!(c.assumed_slope && (c.spp.unwrap() - 100.0).abs() < 1e-9);
        assert!(
            (c.spp_interval[0] - 80.0).abs() < 1e-9 && (c.spp_interval[1] - 120.0).abs() < 1e-9
        );
        // Without repeats there is no interval and no point estimate.
        let c = cost_to_target(&[point(4.0, 0.25, 0.4)], 0.01, None).unwrap();
        assert!(c.spp.is_none() && c.refused.unwrap().contains("one render"));
        // Beyond 100× the measured spp: refused, interval still given.
        let c = cost_to_target(&exact, 1e-5, None).unwrap();
        assert!(c.spp.is_none() && c.refused.unwrap().contains("beyond"));
        assert!((c.spp_interval[0] - 1e5).abs() < 1e-3);
        // Heavy tails refuse the point estimate; a flat or rising curve never reaches.
        let c = cost_to_target(&exact, 0.01, Some("MSE rises")).unwrap();
        assert!(c.refused.unwrap().contains("MSE rises"));
        assert!(
            cost_to_target(&[point(1.0, 0.5, 0.1), point(4.0, 0.5, 0.4)], 0.01, None).is_none()
        );
    }

    #[test]
    fn extrapolation_interval_covers_the_true_cost_on_noisy_series() {
        // relMSE = 2·spp^−0.8 · exp(ε), ε ~ N(0, 0.1²) per point, 5 spp levels; the 95% interval
        // of the spp reaching 1e-3 should contain the truth in about 95% of 400 series.
        let truth = (2.0f64 / 1e-3).powf(1.0 / 0.8);
        let mut rng = crate::sampling::rng::PixelRng::new(7, 0);
        let mut covered = 0;
        let trials = 400;
        for _ in 0..trials {
            let points: Vec<TargetPoint> = [4.0, 8.0, 16.0, 32.0, 64.0]
                .iter()
                .map(|&s: &f64| {
                    let e = 0.1 * normal(&mut rng);
                    point(s, 2.0 * s.powf(-0.8) * e.exp(), s)
                })
                .collect();
            let c = cost_to_target(&points, 1e-3, None).unwrap();
            if c.spp_interval[0] <= truth && truth <= c.spp_interval[1] {
                covered += 1;
            }
        }
        assert!(
            covered as f64 >= 0.9 * trials as f64,
            "covered {covered} of {trials}"
        );
    }

    #[test]
    fn slope_interval_covers_the_true_slope_in_most_fits() {
        // 200 fits of 6 noisy points on a line of slope −1.3: the 95% interval must cover it
        // in at least 90% of them (binomial sd ≈ 1.5%).
        let mut rng = crate::sampling::rng::PixelRng::new(11, 0);
        let xs: Vec<f64> = (0..6).map(|i| i as f64).collect();
        let covered = (0..200)
            .filter(|_| {
                let ys: Vec<f64> = xs
                    .iter()
                    .map(|x| 0.5 - 1.3 * x + 0.2 * normal(&mut rng))
                    .collect();
                let f = fit_line(&xs, &ys).unwrap();
                f.slope_interval[0] <= -1.3 && -1.3 <= f.slope_interval[1]
            })
            .count();
        assert!(covered >= 180, "covered {covered} of 200");
    }

    /// A standard normal deviate (Box–Muller).
    fn normal(rng: &mut crate::sampling::rng::PixelRng) -> f64 {
        let u1 = (1.0 - rng.next_f64()).max(1e-300);
        let u2 = rng.next_f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}
