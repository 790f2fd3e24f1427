//! Bench reports: an aligned text table, CSV, Markdown and JSON of the rows, each file written
//! atomically.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use super::bench::BenchRow;
use crate::image::write_atomically;

/// Column headers and one row's cells, shared by the table, CSV and Markdown.
const HEADERS: [&str; 18] = [
    "config",
    "spp",
    "seconds",
    "s min",
    "s max",
    "Mrays",
    "MSE",
    "MSE 95% lo",
    "MSE 95% hi",
    "relMSE",
    "variance",
    "eff 1/(relMSE s)",
    "eff 1/(var s)",
    "MSE ratio",
    "eff ratio",
    "fireflies",
    "max sample",
    "biased",
];

fn cells(r: &BenchRow) -> [String; 18] {
    let e = |x: f64| format!("{x:.3e}");
    let opt = |x: Option<f64>| x.map_or("-".into(), e);
    let (lo, hi) = r
        .mse_interval
        .map_or(("-".into(), "-".into()), |[a, b]| (e(a), e(b)));
    [
        super::bench::estimator_label(&r.estimator()),
        r.spp.to_string(),
        short(r.seconds),
        short(r.seconds_min),
        short(r.seconds_max),
        short(r.rays as f64 / 1e6),
        e(r.mse),
        lo,
        hi,
        e(r.relmse),
        opt(r.variance),
        e(r.efficiency),
        opt(r.efficiency_variance),
        format!("{:.3}", r.mse_ratio),
        format!("{:.3}", r.efficiency_ratio),
        r.fireflies.to_string(),
        e(r.max_sample_luminance),
        if r.biased { "yes" } else { "no" }.into(),
    ]
}

/// Three decimals from 0.1 up, else three significant digits in scientific notation.
fn short(x: f64) -> String {
    if x >= 0.1 || x == 0.0 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// The rows as a right-aligned text table (config left-aligned).
pub fn table(rows: &[BenchRow]) -> String {
    let all: Vec<[String; 18]> = rows.iter().map(cells).collect();
    let widths: Vec<usize> = (0..HEADERS.len())
        .map(|c| {
            all.iter()
                .map(|r| r[c].chars().count())
                .chain([HEADERS[c].len()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    let mut line = |cols: Vec<&str>| {
        for (c, text) in cols.iter().enumerate() {
            let sep = if c == 0 { "" } else { "  " };
            if c == 0 {
                let _ = write!(out, "{sep}{text:<w$}", w = widths[c]);
            } else {
                let _ = write!(out, "{sep}{text:>w$}", w = widths[c]);
            }
        }
        out.push('\n');
    };
    line(HEADERS.to_vec());
    for r in &all {
        line(r.iter().map(String::as_str).collect());
    }
    out
}

/// The rows as CSV (RFC 4180; no cell needs quoting).
pub fn csv(rows: &[BenchRow]) -> String {
    let mut out = HEADERS.join(",") + "\n";
    for r in rows {
        out += &cells(r).join(",");
        out.push('\n');
    }
    out
}

/// The rows as a GitHub Markdown table.
pub fn markdown(rows: &[BenchRow]) -> String {
    let mut out = format!("| {} |\n", HEADERS.join(" | "));
    out += &format!("|{}\n", "---|".repeat(HEADERS.len()));
    for r in rows {
        out += &format!("| {} |\n", cells(r).join(" | "));
    }
    out
}

/// Writes `text` to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    write_atomically(path, |w| {
        w.write_all(text.as_bytes())?;
        Ok(())
    })
}

/// Writes any serialisable value as pretty JSON, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)?;
        Ok(())
    })
}
