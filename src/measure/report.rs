//! Bench reports: an aligned text table (the main columns), CSV and Markdown (every column) and
//! JSON of the rows, external ones included, each file written atomically. Columns: errors over
//! all pixels and over lit-surface pixels (`lit …`), raw and minus the reference's variance
//! (`…-Var[ref]`, see `errors`), with 95% intervals.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use super::bench::ReportRow;
use crate::image::write_atomically;

/// Column headers and one row's cells, shared by the table, CSV and Markdown; the table
/// shows only the columns marked for it.
const HEADERS: [(&str, bool); 36] = [
    ("config", true),
    ("spp", true),
    ("seconds", true),
    ("s min", false),
    ("s max", false),
    ("cpu s", true),
    ("selector build s", false),
    ("selector build cpu s", false),
    ("Mrays", false),
    ("MSE", true),
    ("MSE 95% lo", false),
    ("MSE 95% hi", false),
    ("relMSE", true),
    ("MSE-Var[ref]", true),
    ("MSE-Var 95% lo", false),
    ("MSE-Var 95% hi", false),
    ("relMSE-Var[ref]", false),
    ("lit px", false),
    ("lit MSE", true),
    ("lit MSE 95% lo", false),
    ("lit MSE 95% hi", false),
    ("lit relMSE", true),
    ("lit MSE-Var[ref]", true),
    ("lit relMSE-Var[ref]", false),
    ("variance", false),
    ("eff 1/(relMSE s)", true),
    ("eff 1/(var s)", false),
    ("eff 1/(relMSE cpu s)", false),
    ("MSE ratio", true),
    ("eff ratio", true),
    ("cpu eff ratio", true),
    ("fireflies", false),
    ("max sample", false),
    ("heavy tail", true),
    ("biased", false),
    ("external", false),
];

fn cells(row: &ReportRow) -> [String; 36] {
    let e = |x: f64| format!("{x:.3e}");
    let opt = |x: Option<f64>| x.map_or("-".into(), e);
    let ends = |i: Option<[f64; 2]>| i.map_or(("-".into(), "-".into()), |[a, b]| (e(a), e(b)));
    let yes = |b: bool| if b { "yes" } else { "no" }.to_string();
    let errors = row.errors();
    let all = &errors.all;
    let lit = errors.lit.as_ref();
    let (lo, hi) = ends(all.mse_interval);
    let (clo, chi) = ends(all.mse_corrected_interval);
    let (llo, lhi) = ends(lit.and_then(|l| l.mse_interval));
    let errors_cells = [
        e(all.mse),
        lo,
        hi,
        e(all.relmse),
        opt(all.mse_corrected),
        clo,
        chi,
        opt(all.relmse_corrected),
        lit.map_or("-".into(), |l| l.pixels.to_string()),
        opt(lit.map(|l| l.mse)),
        llo,
        lhi,
        opt(lit.map(|l| l.relmse)),
        opt(lit.and_then(|l| l.mse_corrected)),
        opt(lit.and_then(|l| l.relmse_corrected)),
    ];
    let [a, b, c, d, f, g, h, i, j, k, l, m, n, o, p] = errors_cells;
    match row {
        ReportRow::Bench(r) => [
            row.label(),
            r.spp.to_string(),
            short(r.seconds),
            short(r.seconds_min),
            short(r.seconds_max),
            r.cpu_seconds.map_or("-".into(), short),
            short(r.selector_build_seconds),
            r.selector_build_cpu_seconds.map_or("-".into(), short),
            short(r.rays as f64 / 1e6),
            a,
            b,
            c,
            d,
            f,
            g,
            h,
            i,
            j,
            k,
            l,
            m,
            n,
            o,
            p,
            opt(r.variance),
            e(r.efficiency),
            opt(r.efficiency_variance),
            opt(r.efficiency_cpu),
            format!("{:.3}", r.mse_ratio),
            format!("{:.3}", r.efficiency_ratio),
            r.efficiency_cpu_ratio
                .map_or("-".into(), |x| format!("{x:.3}")),
            r.fireflies.to_string(),
            e(r.max_sample_luminance),
            yes(r.heavy_tail.is_some()),
            yes(r.biased),
            "no".into(),
        ],
        ReportRow::External(x) => [
            row.label(),
            x.spp.map_or("-".into(), |s| s.to_string()),
            x.seconds.map_or("-".into(), short),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            a,
            b,
            c,
            d,
            f,
            g,
            h,
            i,
            j,
            k,
            l,
            m,
            n,
            o,
            p,
            "-".into(),
            opt(x.efficiency),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            yes(x.heavy_tail.is_some()),
            "-".into(),
            "yes".into(),
        ],
    }
}

/// Three decimals from 0.1 up, else three significant digits in scientific notation.
pub fn short(x: f64) -> String {
    if x >= 0.1 || x == 0.0 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// The rows as a right-aligned text table (config left-aligned) of the columns marked for it.
pub fn table(rows: &[ReportRow]) -> String {
    let shown: Vec<usize> = (0..HEADERS.len()).filter(|&c| HEADERS[c].1).collect();
    let all: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            let cells = cells(r);
            shown.iter().map(|&c| cells[c].clone()).collect()
        })
        .collect();
    let headers: Vec<&str> = shown.iter().map(|&c| HEADERS[c].0).collect();
    let widths: Vec<usize> = (0..headers.len())
        .map(|c| {
            all.iter()
                .map(|r| r[c].chars().count())
                .chain([headers[c].chars().count()])
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
    line(headers);
    for r in &all {
        line(r.iter().map(String::as_str).collect());
    }
    out
}

/// The rows as CSV (RFC 4180; no cell needs quoting).
pub fn csv(rows: &[ReportRow]) -> String {
    let mut out = header_names().join(",") + "\n";
    for r in rows {
        out += &cells(r).join(",");
        out.push('\n');
    }
    out
}

/// The rows as a GitHub Markdown table.
pub fn markdown(rows: &[ReportRow]) -> String {
    let mut out = format!("| {} |\n", header_names().join(" | "));
    out += &format!("|{}\n", "---|".repeat(HEADERS.len()));
    for r in rows {
        out += &format!("| {} |\n", cells(r).join(" | "));
    }
    out
}

fn header_names() -> Vec<&'static str> {
    HEADERS.iter().map(|h| h.0).collect()
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
