//! Bad reference EXRs (NaN, infinite, negative, wrong size, truncated) refused by diff, bench and
//! converge.

use super::*;

/// An 8×8 EXR whose pixel (3, 2) has `value` in G (mean) or in variance.G.
fn poisoned_exr(dir: &Path, name: &str, value: f32, in_variance: bool) -> PathBuf {
    let mut mean = RgbImage {
        width: 8,
        height: 8,
        pixels: vec![[0.5; 3]; 64],
    };
    let mut variance = RgbImage {
        pixels: vec![[1e-3; 3]; 64],
        ..mean.clone()
    };
    let target = if in_variance {
        &mut variance
    } else {
        &mut mean
    };
    target.pixels[2 * 8 + 3][1] = value;
    let path = dir.join(name);
    write_exr(&path, &mean, Some(&variance)).unwrap();
    path
}

#[test]
fn diff_bench_and_converge_refuse_bad_reference_exrs_with_exit_3() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    let out = dir.path().join("out");
    fs::create_dir_all(&inputs).unwrap();
    fs::create_dir_all(&out).unwrap();
    let scene = inputs.join("cornell.glb");
    fs::write(&scene, cornell_bytes()).unwrap();
    let good = render_small(&inputs, "good.exr", "8");
    let wide = render_small(&inputs, "wide.exr", "12");
    let text = inputs.join("text.exr");
    fs::write(&text, "{\"not\": \"an image\"}").unwrap();
    let truncated = inputs.join("truncated.exr");
    let bytes = fs::read(&good).unwrap();
    fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let nan = poisoned_exr(&inputs, "nan.exr", f32::NAN, false);
    let inf = poisoned_exr(&inputs, "inf.exr", f32::INFINITY, false);
    let negative_variance = poisoned_exr(&inputs, "negvar.exr", -1.0, true);
    let bad_sidecar = inputs.join("sidecar.exr");
    fs::copy(&good, &bad_sidecar).unwrap();
    fs::write(inputs.join("sidecar.exr.json"), "{ truncated").unwrap();
    let missing = inputs.join("missing.exr");

    let mean_cases: Vec<(&PathBuf, Vec<&str>)> = vec![
        (&wide, vec!["wide.exr", "12x12", "8x8"]),
        (&text, vec!["text.exr", "not a valid OpenEXR file"]),
        (&truncated, vec!["truncated.exr", "truncated or corrupt"]),
        (
            &nan,
            vec![
                "nan.exr",
                "mean pixel (3, 2) channel G is NaN, expected a finite value",
            ],
        ),
        (&inf, vec!["inf.exr", "mean pixel (3, 2) channel G is inf"]),
        (&missing, vec!["missing.exr", "cannot read", "No such file"]),
    ];
    let diff_image = s(&out.join("d.exr"));
    for (bad, mentions) in &mean_cases {
        // diff: the bad file as the reference, and as the image measured.
        for pair in [[&good, *bad], [*bad, &good]] {
            let args = ["diff", &s(pair[0]), &s(pair[1]), "--image", &diff_image];
            assert_refused(&args, EXIT_BAD_INPUT, mentions, dir.path());
        }
    }
    let reference_only: Vec<(&PathBuf, Vec<&str>)> = vec![
        (
            &negative_variance,
            vec![
                "negvar.exr",
                "variance pixel (3, 2) channel G is -1, expected a finite value ≥ 0",
            ],
        ),
        (
            &bad_sidecar,
            vec!["sidecar.exr.json", "not a reference sidecar"],
        ),
    ];
    let [b_json, b_svg, c_json] = ["b.json", "b.svg", "c.json"].map(|f| s(&out.join(f)));
    for (bad, mentions) in mean_cases.iter().chain(&reference_only) {
        let (scene, bad) = (s(&scene), s(bad));
        let common = ["--width", "8", "--reference", &bad, "--seed", "1"];
        let bench = [
            &["bench", &scene, "--spp", "1", "--repeat", "1"][..],
            &common,
            &["--json", &b_json, "--plot", &b_svg],
        ]
        .concat();
        assert_refused(&bench, EXIT_BAD_INPUT, mentions, dir.path());
        let converge = [
            &["converge", &scene, "--spp", "1,2", "--seeds", "1"][..],
            &common,
            &["--json", &c_json],
        ]
        .concat();
        assert_refused(&converge, EXIT_BAD_INPUT, mentions, dir.path());
    }
    // The inputs are fine: diff succeeds on them, so the refusals above are about the bad files.
    let run = manylights(&["diff", &s(&good), &s(&good), "--image", &diff_image]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains("mse      0.000000e0"), "{}", run.stdout);
}
