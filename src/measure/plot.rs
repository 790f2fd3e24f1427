//! Pictures of a bench: relMSE against seconds (log-log SVG, one line per configuration over
//! its spp values) and false-colour PNGs of the per-pixel relative squared error
//! (x − r)² / (r² + 1e-2), averaged over channels.

use anyhow::anyhow;
use plotters::prelude::*;

use super::bench::{estimator_label, BenchRow};
use super::metrics::REL_MSE_EPSILON;
use crate::image::{write_atomically, write_rgb8, RgbImage};

/// Writes the relMSE-versus-seconds plot of `rows` as SVG, atomically.
pub fn plot_relmse_vs_seconds(
    path: &std::path::Path,
    rows: &[BenchRow],
    title: &str,
) -> anyhow::Result<()> {
    let usable: Vec<&BenchRow> = rows
        .iter()
        .filter(|r| r.relmse > 0.0 && r.seconds > 0.0 && r.relmse.is_finite())
        .collect();
    if usable.is_empty() {
        anyhow::bail!("nothing to plot: no configuration has a positive relMSE and time");
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for r in &usable {
        x0 = x0.min(r.seconds);
        x1 = x1.max(r.seconds);
        y0 = y0.min(r.relmse);
        y1 = y1.max(r.relmse);
    }
    // Half a decade of margin on each side, so single points are not on the frame.
    let pad = 10f64.powf(0.25);
    let (x0, x1, y0, y1) = (x0 / pad, x1 * pad, y0 / pad, y1 * pad);

    let mut configs = Vec::new();
    for r in &usable {
        let label = estimator_label(&r.estimator());
        if !configs.contains(&label) {
            configs.push(label);
        }
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| anyhow!("plot: {e}");
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("render time (seconds)")
            .y_desc("relMSE")
            .x_label_formatter(&|v| format!("{v:.1e}"))
            .y_label_formatter(&|v| format!("{v:.1e}"))
            .draw()
            .map_err(|e| err(&e))?;
        for (i, label) in configs.iter().enumerate() {
            let colour = Palette99::pick(i).to_rgba();
            let mut points: Vec<(f64, f64)> = usable
                .iter()
                .filter(|r| estimator_label(&r.estimator()) == *label)
                .map(|r| (r.seconds, r.relmse))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    write_atomically(path, |w| {
        use std::io::Write;
        w.write_all(svg.as_bytes())?;
        Ok(())
    })
}

/// Per-pixel relative squared error, averaged over channels.
pub fn relative_error(image: &RgbImage, reference: &RgbImage) -> Vec<f64> {
    image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(x, r)| {
            (0..3)
                .map(|c| {
                    let (x, r) = (x[c] as f64, r[c] as f64);
                    (x - r).powi(2) / (r * r + REL_MSE_EPSILON)
                })
                .sum::<f64>()
                / 3.0
        })
        .collect()
}

/// Decades of relative error the false colours span: 1e-4 (dark blue) to 1e1 (yellow-white).
const LOG_RANGE: (f64, f64) = (-4.0, 1.0);

/// A perceptually ordered ramp (dark blue → purple → orange → pale yellow) at t ∈ [0, 1].
pub fn false_colour(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.25],
        [0.35, 0.05, 0.55],
        [0.8, 0.2, 0.35],
        [1.0, 0.6, 0.1],
        [1.0, 1.0, 0.75],
    ];
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    let s = t * (STOPS.len() - 1) as f64;
    let i = (s as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    [0, 1, 2].map(|c| ((STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f) * 255.0).round() as u8)
}

/// Writes a false-colour PNG of the per-pixel relative error of `image` against `reference`,
/// log-scaled over [`LOG_RANGE`]; NaN shows as the top colour.
pub fn write_error_image(
    path: &std::path::Path,
    image: &RgbImage,
    reference: &RgbImage,
) -> anyhow::Result<()> {
    let (lo, hi) = LOG_RANGE;
    let bytes: Vec<u8> = relative_error(image, reference)
        .iter()
        .flat_map(|&e| false_colour((e.max(1e-300).log10() - lo) / (hi - lo)))
        .collect();
    let (w, h) = (image.width as u32, image.height as u32);
    write_rgb8(path, w, h, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_ends_and_relative_error_by_hand() {
        assert_eq!(false_colour(0.0), [0, 0, 64]);
        assert_eq!(false_colour(1.0), [255, 255, 191]);
        assert_eq!(false_colour(f64::NAN), false_colour(1.0));
        let img = |p: [f32; 3]| RgbImage {
            width: 1,
            height: 1,
            pixels: vec![p],
        };
        let e = relative_error(&img([1.5, 0.0, 0.1]), &img([1.0, 0.0, 0.0]));
        let want = (0.25 / 1.01 + 0.0 + 0.01 / 0.01) / 3.0;
        assert!((e[0] - want).abs() < 1e-7);
    }
}
