//! Pictures of a bench: relMSE against seconds (log-log SVG, one line per configuration over
//! its spp values, error bars of the 95% interval across repeats, a panel for all pixels and
//! one for lit-surface pixels) and false-colour PNGs of the per-pixel relative squared error
//! (x − r)² / (r² + 1e-2), averaged over channels.

use anyhow::anyhow;
use plotters::prelude::*;

use super::bench::ReportRow;
use super::errors::RegionErrors;
use super::metrics::REL_MSE_EPSILON;
use crate::image::{write_atomically, write_rgb8, RgbImage};

/// One point of a plot: seconds, relMSE and its 95% interval across repeats.
type PlotPoint = (f64, f64, Option<[f64; 2]>);

/// Writes the relMSE-versus-seconds plot of `rows` as SVG, atomically: one panel over all
/// pixels and, when the rows have lit-surface figures, a second over lit-surface pixels; each
/// point with its 95% interval across repeats as an error bar. External rows (with seconds)
/// are drawn as unconnected squares.
pub fn plot_relmse_vs_seconds(
    path: &std::path::Path,
    rows: &[ReportRow],
    title: &str,
) -> anyhow::Result<()> {
    let panels: Vec<(&str, Series)> = [
        (
            "relMSE, all pixels",
            series(rows, |r| Some(&r.errors().all)),
        ),
        (
            "relMSE, lit-surface pixels",
            series(rows, |r| r.errors().lit.as_ref()),
        ),
    ]
    .into_iter()
    .filter(|(_, s)| !s.is_empty())
    .collect();
    if panels.is_empty() {
        anyhow::bail!("nothing to plot: no configuration has a positive relMSE and time");
    }
    let mut svg = String::new();
    {
        let width = 900 * panels.len() as u32;
        let root = SVGBackend::with_string(&mut svg, (width, 600)).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| anyhow!("plot: {e}");
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let root = root
            .titled(title, ("sans-serif", 22))
            .map_err(|e| err(&e))?;
        let areas = root.split_evenly((1, panels.len()));
        for (area, (y_desc, lines)) in areas.iter().zip(&panels) {
            draw_panel(area, y_desc, lines).map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    write_atomically(path, |w| {
        use std::io::Write;
        w.write_all(svg.as_bytes())?;
        Ok(())
    })
}

/// Labelled lines of points (label, external, points sorted by seconds).
type Series = Vec<(String, bool, Vec<PlotPoint>)>;

fn series<'a>(
    rows: &'a [ReportRow<'a>],
    region: fn(&'a ReportRow<'a>) -> Option<&'a RegionErrors>,
) -> Series {
    let mut out: Series = Vec::new();
    for r in rows {
        let (Some(seconds), Some(e)) = (r.seconds(), region(r)) else {
            continue;
        };
        if !(e.relmse > 0.0 && e.relmse.is_finite() && seconds > 0.0) {
            continue;
        }
        let label = r.label();
        let point = (seconds, e.relmse, e.relmse_interval);
        match out.iter_mut().find(|s| s.0 == label) {
            Some(s) => s.2.push(point),
            None => out.push((label, matches!(r, ReportRow::External(_)), vec![point])),
        }
    }
    for s in &mut out {
        s.2.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    out
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    y_desc: &str,
    lines: &Series,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for &(x, y, interval) in lines.iter().flat_map(|l| &l.2) {
        let [lo, hi] = interval.filter(|i| i[0] > 0.0).unwrap_or([y, y]);
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(lo);
        y1 = y1.max(hi);
    }
    // Half a decade of margin on each side, so single points are not on the frame.
    let pad = 10f64.powf(0.25);
    let (x0, x1, y0, y1) = (x0 / pad, x1 * pad, y0 / pad, y1 * pad);
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("render time (seconds)")
        .y_desc(y_desc)
        .x_label_formatter(&|v| format!("{v:.1e}"))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .draw()?;
    for (i, (label, external, points)) in lines.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let xy: Vec<(f64, f64)> = points.iter().map(|p| (p.0, p.1)).collect();
        if *external {
            chart
                .draw_series(xy.iter().map(|&(x, y)| {
                    EmptyElement::at((x, y)) + Rectangle::new([(-5, -5), (5, 5)], colour.filled())
                }))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], colour.filled())
                });
        } else {
            chart
                .draw_series(LineSeries::new(xy.clone(), colour.stroke_width(2)))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart.draw_series(xy.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
        }
        chart.draw_series(points.iter().filter_map(|&(x, _, interval)| {
            let [lo, hi] = interval?;
            Some(PathElement::new(
                vec![(x, lo.max(y0)), (x, hi.min(y1))],
                colour.stroke_width(1),
            ))
        }))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
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
/// log-scaled over `LOG_RANGE`; NaN shows as the top colour.
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
