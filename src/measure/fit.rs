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
    let slope_se = if n > 2 {
        let rss: f64 = xs
            .iter()
            .zip(ys)
            .map(|(x, y)| (y - intercept - slope * x).powi(2))
            .sum();
        (rss / (nf - 2.0) / sxx).sqrt()
    } else {
        f64::INFINITY
    };
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

/// What reaching a target relMSE costs one configuration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TargetCost {
    /// The rate used: the fitted log-log slope with ≥ 2 spp values, else −1.
    pub slope: f64,
    pub spp: f64,
    pub seconds: f64,
}

/// Extrapolates (spp, relMSE, seconds) measurements to `target` relMSE: relMSE = c·spp^b with b
/// fitted in log-log space (or b = −1 from a single spp), seconds = spp × (Σ seconds / Σ spp).
/// None when the fitted slope is not negative (more samples would not help) or data are
/// missing.
pub fn cost_to_target(points: &[(f64, f64, f64)], target: f64) -> Option<TargetCost> {
    let first = points.first()?;
    let total_spp: f64 = points.iter().map(|p| p.0).sum();
    let seconds_per_spp = points.iter().map(|p| p.2).sum::<f64>() / total_spp;
    let distinct = points.iter().any(|p| p.0 != first.0);
    let (slope, intercept) = if distinct {
        let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
        let fit = fit_loglog(&xs, &ys)?;
        (fit.slope, fit.intercept)
    } else {
        let mean_rel = points.iter().map(|p| p.1).sum::<f64>() / points.len() as f64;
        if mean_rel.is_nan() || mean_rel <= 0.0 {
            return None;
        }
        (-1.0, mean_rel.ln() + first.0.ln())
    };
    // NaN compares false, so a NaN slope or target is refused too.
    let usable = slope < 0.0 && target > 0.0;
    if !usable {
        return None;
    }
    let spp = ((target.ln() - intercept) / slope).exp();
    Some(TargetCost {
        slope,
        spp,
        seconds: spp * seconds_per_spp,
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

    #[test]
    fn cost_to_target_follows_the_rate() {
        // relMSE = 1/spp, 0.1 s per spp: 0.01 needs 100 spp, 10 s, from one point or several.
        let one = cost_to_target(&[(4.0, 0.25, 0.4)], 0.01).unwrap();
        assert!((one.spp - 100.0).abs() < 1e-9 && (one.seconds - 10.0).abs() < 1e-9);
        let pts = [(1.0, 1.0, 0.1), (4.0, 0.25, 0.4), (16.0, 1.0 / 16.0, 1.6)];
        let many = cost_to_target(&pts, 0.01).unwrap();
        assert!((many.slope + 1.0).abs() < 1e-12);
        assert!((many.seconds - 10.0).abs() < 1e-6);
        // A flat curve (bias floor) never reaches the target.
        assert!(cost_to_target(&[(1.0, 0.5, 0.1), (4.0, 0.5, 0.4)], 0.01).is_none());
    }
}
