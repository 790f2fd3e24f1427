//! Whole-program behaviour of the measuring commands (reference, bench, converge) on the small
//! Cornell box: their files parse with the documented fields, references are cached and reused,
//! and converge fails on a deliberately biased configuration.

use crate::run;
use run::manylights;

use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A copy of scenes/cornell.glb in a fresh folder, so its reference cache lands there.
fn cornell_copy(dir: &Path) -> PathBuf {
    let scene = dir.join("cornell.glb");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb"),
        &scene,
    )
    .unwrap();
    scene
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn reference_writes_exr_and_sidecar_and_refuses_clamp() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let out = dir.path().join("ref.exr");
    let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let run = manylights(&["reference", s, "-o", o, "--width", "16", "--spp", "20"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let meta = json(&dir.path().join("ref.exr.json"));
    assert_eq!(meta["spp"], 20);
    assert_eq!(meta["passes"], 3, "passes of 8, 8 and 4 spp");
    assert_eq!(meta["options"]["estimator"]["selector"], "bvh");
    assert_eq!(meta["options"]["estimator"]["strategy"], "mis");
    assert_eq!(meta["scene_hash"].as_str().unwrap().len(), 16);
    assert!(meta["seconds"].as_f64().unwrap() >= 0.0);
    let rel = meta["relmse_estimate"].as_f64().unwrap();
    assert!(rel.is_finite() && rel > 0.0);

    let refused = manylights(&["reference", s, "-o", o, "--clamp", "1"]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(stderr(&refused).contains("unbiased"));
}

#[test]
fn bench_reports_every_configuration_and_reuses_its_cached_reference() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let files = ["b.json", "b.csv", "b.md"].map(|f| dir.path().join(f));
    let [j, c, m] = files.each_ref().map(|p| p.to_str().unwrap());
    let (svg, errors) = (dir.path().join("p.svg"), dir.path().join("errors"));
    std::fs::create_dir(&errors).unwrap();
    let args = [
        "bench",
        scene.to_str().unwrap(),
        "--width",
        "16",
        "--selectors",
        "uniform,power",
        "--strategies",
        "light-area,mis",
        "--kn",
        "1x1,4x1",
        "--spp",
        "2,4",
        "--repeat",
        "2",
        "--reference-spp",
        "64",
        "--json",
        j,
        "--csv",
        c,
        "--markdown",
        m,
        "--plot",
        svg.to_str().unwrap(),
        "--error-images",
        errors.to_str().unwrap(),
    ];
    let first = manylights(&args);
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(
        stderr(&first).contains("rendering one"),
        "{}",
        stderr(&first)
    );

    let rows = json(&files[0]);
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2 * 2 * 2 * 2);
    for row in rows {
        for field in ["selector", "strategy", "k", "n", "spp", "biased"] {
            assert!(!row[field].is_null(), "{field} missing in {row}");
        }
        for field in [
            "seconds",
            "cpu_seconds",
            "rays",
            "mse",
            "relmse",
            "variance",
            "efficiency",
        ] {
            let v = row[field].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v >= 0.0, "{field} = {v} in {row}");
        }
        assert_eq!(row["biased"], false);
        let [lo, hi] = [0, 1].map(|i| row["mse_interval"][i].as_f64().unwrap());
        assert!(lo <= row["mse"].as_f64().unwrap() && row["mse"].as_f64().unwrap() <= hi);
    }
    // CPU-time efficiency: 1 / (relMSE × CPU seconds), and its ratio to the baseline row's at
    // the same spp (the row whose wall-time ratio is 1).
    let f = |row: &serde_json::Value, field: &str| row[field].as_f64().unwrap();
    for row in rows {
        let expected = 1.0 / (f(row, "relmse") * f(row, "cpu_seconds"));
        let got = f(row, "efficiency_cpu");
        assert!(
            (got / expected - 1.0).abs() < 1e-12,
            "{got} vs {expected} in {row}"
        );
        let baseline = rows
            .iter()
            .find(|b| b["spp"] == row["spp"] && f(b, "efficiency_ratio") == 1.0)
            .expect("a baseline row at each spp");
        let ratio = f(row, "efficiency_cpu_ratio");
        let expected = got / f(baseline, "efficiency_cpu");
        assert!(
            (ratio / expected - 1.0).abs() < 1e-12,
            "{ratio} vs {expected} in {row}"
        );
    }
    assert!(rows
        .iter()
        .any(|r| r["selector"] == "uniform" && r["k"] == 4 && r["spp"] == 4));
    let csv = std::fs::read_to_string(&files[1]).unwrap();
    assert_eq!(csv.lines().count(), 1 + rows.len());
    let md = std::fs::read_to_string(&files[2]).unwrap();
    assert_eq!(md.lines().count(), 2 + rows.len());
    let table = String::from_utf8_lossy(&first.stdout);
    assert!(table.contains("power:mis:4x1"), "{table}");
    // Each selector's one-off build: reported with every row that uses it (one build for all of
    // them, so the same figures), on its own line after the table, and in the CSV.
    for selector in ["uniform", "power"] {
        let mine: Vec<_> = rows.iter().filter(|r| r["selector"] == selector).collect();
        for field in ["selector_build_seconds", "selector_build_cpu_seconds"] {
            let v = f(mine[0], field);
            assert!(v.is_finite() && v >= 0.0, "{field} = {v} in {}", mine[0]);
            assert!(mine.iter().all(|r| r[field] == mine[0][field]), "{field}");
        }
    }
    let builds = table
        .lines()
        .find(|l| l.starts_with("selector builds"))
        .unwrap_or_else(|| panic!("no selector builds line in {table}"));
    assert!(
        builds.contains("uniform ") && builds.contains("power "),
        "{builds}"
    );
    assert!(csv.lines().next().unwrap().contains("selector build cpu s"));

    let plot = std::fs::read_to_string(&svg).unwrap();
    for text in [
        "<svg",
        "relMSE",
        "render time (seconds)",
        "uniform:mis:4x1",
        "power:light-area:1x1",
    ] {
        assert!(plot.contains(text), "plot lacks {text}");
    }
    assert_eq!(std::fs::read_dir(&errors).unwrap().count(), rows.len());
    assert!(errors.join("power_mis_4x1_4.png").exists());

    let second = manylights(&args);
    assert!(second.status.success(), "{}", stderr(&second));
    assert!(
        stderr(&second).contains("reusing the cached reference"),
        "{}",
        stderr(&second)
    );
}

/// `bench` of the Cornell box at 8 × 8 against a 16-spp reference, with `extra` options and
/// `--json`: its output and the JSON rows.
fn small_bench(extra: &[&str]) -> (Output, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let j = dir.path().join("b.json");
    let (scene, j_arg) = (scene.to_str().unwrap(), j.to_str().unwrap());
    let head = ["bench", scene, "--width", "8", "--reference-spp", "16"];
    let args = [&head[..], extra, &["--json", j_arg]].concat();
    let o = manylights(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = json(&j);
    (o, rows)
}

#[test]
fn a_cpu_time_budget_spends_at_least_that_much_cpu_time() {
    let budget = 0.2;
    let (o, rows) = small_bench(&[
        "--time-budget",
        &budget.to_string(),
        "--budget-clock",
        "cpu",
        "--repeat",
        "2",
    ]);
    assert!(
        stderr(&o).contains("equal CPU time 0.2 s each"),
        "{}",
        stderr(&o)
    );
    for row in rows.as_array().unwrap() {
        assert_eq!(row["budget_clock"], "cpu", "{row}");
        assert_eq!(row["time_budget"].as_f64(), Some(budget), "{row}");
        // The renders' CPU time is read around the passes, whose clock starts inside.
        let cpu = row["cpu_seconds"].as_f64().unwrap();
        assert!(
            cpu >= budget,
            "{cpu} CPU seconds for a budget of {budget} in {row}"
        );
    }
}

#[test]
fn clamped_bench_rows_are_marked_biased() {
    let (_, rows) = small_bench(&["--spp", "2", "--repeat", "1", "--clamp", "0.5"]);
    assert_eq!(rows[0]["biased"], true);
}

#[test]
fn converge_exits_0_when_unbiased_and_4_when_clamped() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let j = dir.path().join("c.json");
    let converge = |extra: &[&str]| {
        let mut args = vec![
            "converge",
            scene.to_str().unwrap(),
            "--width",
            "32",
            "--seeds",
            "16",
            "--json",
            j.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        manylights(&args)
    };
    let good = converge(&[]);
    assert_eq!(
        good.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&good.stdout)
    );
    let report = json(&j);
    let slope = report["slope"].as_f64().unwrap();
    assert!((slope + 1.0).abs() <= 0.15, "{slope}");
    assert!(report["slope_interval"][0].as_f64().unwrap() < slope);
    assert_eq!(report["passed"], true);

    let bad = converge(&["--clamp", "0.5"]);
    assert_eq!(
        bad.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&bad.stdout)
    );
    assert!(stderr(&bad).contains("reusing the cached reference"));
    assert!(String::from_utf8_lossy(&bad.stdout).contains("unbiased  FAIL"));
    let report = json(&j);
    assert_eq!(report["passed"], false);
    assert_eq!(report["biased"], true);
}

#[test]
fn bench_refuses_an_unknown_baseline_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let o = manylights(&[
        "bench",
        scene.to_str().unwrap(),
        "--baseline",
        "power:mis:2x2",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("power:light-area:1x1"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("cornell.glb.ref").exists());
}

#[test]
fn bench_sweeps_samplers_and_converge_records_its_sampler() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let (s, b, c) = (
        scene.to_str().unwrap(),
        dir.path().join("b.json"),
        dir.path().join("c.json"),
    );
    let o = manylights(&[
        "bench",
        s,
        "--width",
        "8",
        "--spp",
        "4,16",
        "--repeat",
        "2",
        "--reference-spp",
        "64",
        "--samplers",
        "independent,sobol",
        "--baseline",
        "power:light-area:1x1:sobol",
        "--json",
        b.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = json(&b);
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for (row, (sampler, spp)) in rows.iter().zip([
        ("independent", 4),
        ("independent", 16),
        ("sobol", 4),
        ("sobol", 16),
    ]) {
        assert_eq!(row["sampler"], sampler, "{row}");
        assert_eq!(row["spp"], spp, "{row}");
        assert_eq!(
            row["baseline"],
            format!("power:light-area:1x1:sobol:{spp}"),
            "{row}"
        );
    }
    assert_eq!(rows[3]["mse_ratio"], 1.0);
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("power:light-area:1x1:sobol "), "{table}");

    let o = manylights(&[
        "converge",
        s,
        "--width",
        "16",
        "--seeds",
        "8",
        "--sampler",
        "sobol",
        "--json",
        c.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("Sobol sampler"), "{stdout}");
    let report = json(&c);
    assert_eq!(report["estimator"]["sampler"], "sobol");
    assert_eq!(report["passed"], true);

    let o = manylights(&["converge", s, "--sampler", "sobol,halton"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn external_row_reproduces_diff_and_every_report_has_lit_and_corrected_figures() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    let path = |f: &str| dir.path().join(f).to_str().unwrap().to_owned();
    let s = scene.to_str().unwrap();
    let reference = manylights(&[
        "reference",
        s,
        "--width",
        "24",
        "--spp",
        "64",
        "-o",
        &path("ref.exr"),
    ]);
    assert!(reference.status.success(), "{}", stderr(&reference));
    let render = manylights(&[
        "render",
        s,
        "--width",
        "24",
        "--spp",
        "4",
        "--selector",
        "power",
        "--strategy",
        "light-area",
        "-o",
        &path("mine.exr"),
    ]);
    assert!(render.status.success(), "{}", stderr(&render));
    let diff = manylights(&[
        "diff",
        &path("mine.exr"),
        &path("ref.exr"),
        "--json",
        &path("d.json"),
    ]);
    assert!(diff.status.success(), "{}", stderr(&diff));
    let diff_out = String::from_utf8_lossy(&diff.stdout);
    assert!(
        diff_out.contains("lit mse") && diff_out.contains("mse-var[ref]"),
        "{diff_out}"
    );
    let bench = manylights(&[
        "bench",
        s,
        "--width",
        "24",
        "--selector",
        "power",
        "--strategy",
        "light-area",
        "--spp",
        "1,4",
        "--repeat",
        "2",
        "--reference",
        &path("ref.exr"),
        "--external",
        &format!("mine={}:0.25:4", path("mine.exr")),
        "--target-relmse",
        "1e-3",
        "--json",
        &path("b.json"),
        "--csv",
        &path("b.csv"),
        "--plot",
        &path("b.svg"),
    ]);
    assert!(bench.status.success(), "{}", stderr(&bench));
    let rows = json(&dir.path().join("b.json"));
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    let external = &rows[2];
    assert_eq!(external["external"], true);
    assert_eq!(external["name"], "mine");
    assert_eq!(external["seconds"], 0.25);
    assert_eq!(external["spp"], 4);
    let diff_json = json(&dir.path().join("d.json"));
    // Same image, same reference, same code path: the figures are equal, not just close.
    assert_eq!(external["errors"], diff_json["errors"]);
    for key in ["mse", "relmse", "max_abs", "psnr"] {
        assert_eq!(external[key], diff_json[key], "{key}");
    }
    for row in rows {
        let lit = &row["errors"]["lit"];
        assert!(lit["pixels"].as_u64().unwrap() > 0, "{row}");
        let all = &row["errors"]["all"];
        let corrected = all["mse_corrected"].as_f64().unwrap();
        let ref_var = all["reference_variance"].as_f64().unwrap();
        assert!(
            (all["mse"].as_f64().unwrap() - ref_var - corrected).abs()
                <= 1e-9 * corrected.abs().max(1e-12) + 1e-12
        );
    }
    let csv = std::fs::read_to_string(dir.path().join("b.csv")).unwrap();
    assert!(csv.lines().next().unwrap().contains("lit MSE-Var[ref]"));
    assert!(csv.lines().last().unwrap().starts_with("external:mine,4,"));
    let plot = std::fs::read_to_string(dir.path().join("b.svg")).unwrap();
    assert!(plot.contains("lit-surface pixels") && plot.contains("external:mine"));
    let out = String::from_utf8_lossy(&bench.stdout);
    assert!(
        out.contains("external:mine") && out.contains("time to reach relMSE"),
        "{out}"
    );
    assert!(out.contains("95% interval"), "{out}");
}

#[test]
fn external_spec_errors_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_copy(dir.path());
    for bad in ["noequals.exr", "x=image.png", "x=a.exr:fast", "x=a.exr:1:0"] {
        let o = manylights(&["bench", scene.to_str().unwrap(), "--external", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
    }
}

#[test]
fn far_sine_is_a_usage_error_without_the_light_tree() {
    let dir = tempfile::tempdir().unwrap();
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let out = dir.path().join("o.exr");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            cornell.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        manylights(&args)
    };
    let o = render(&["--selector", "power", "--far-sin", "0.5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--far-sin applies to --selector bvh"));
    let o = render(&["--far-sin", "1.5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("from 0 to 1"));
    assert!(!out.exists());
}

#[test]
fn bench_sweeps_the_far_sine_for_the_light_tree_only() {
    let (o, rows) = small_bench(&[
        "--spp",
        "2",
        "--repeat",
        "1",
        "--selectors",
        "power,bvh",
        "--strategies",
        "mis",
        "--far-sin",
        "0,0.3,0.6",
    ]);
    let got: Vec<(String, f64)> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["selector"].as_str().unwrap().to_owned(),
                r["far_sin"].as_f64().unwrap(),
            )
        })
        .collect();
    let want = [("power", 0.3), ("bvh", 0.0), ("bvh", 0.3), ("bvh", 0.6)];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for ((s, f), (ws, wf)) in got.iter().zip(want) {
        assert!(s == ws && (f - wf).abs() < 1e-6, "{got:?}");
    }
    // The default keeps the label it had; the others name their sine.
    let table = String::from_utf8_lossy(&o.stdout);
    for label in ["bvh:mis:1x1:far0 ", "bvh:mis:1x1 ", "bvh:mis:1x1:far0.6 "] {
        assert!(table.contains(label), "{label:?} missing from {table}");
    }
}
