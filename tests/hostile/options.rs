//! Malformed option values: usage errors, refused before any work.

use super::*;

#[test]
fn malformed_option_values_are_usage_errors_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let scene = root.join("cornell.glb");
    fs::write(&scene, cornell_bytes()).unwrap();
    let scene = s(&scene);
    let out = |f: &str| s(&root.join(f));
    let (r_exr, j) = (out("r.exr"), out("x.json"));
    let with = |head: &[&str], extra: &[&str]| -> Vec<String> {
        [head, extra]
            .concat()
            .into_iter()
            .map(String::from)
            .collect()
    };
    let render = |extra: &[&str]| with(&["render", &scene, "-o", &r_exr, "--spp", "1"], extra);
    let bench = |extra: &[&str]| with(&["bench", &scene, "--json", &j], extra);
    let converge = |extra: &[&str]| with(&["converge", &scene, "--json", &j], extra);
    let reference = |extra: &[&str]| with(&["reference", &scene, "-o", &r_exr], extra);
    let huge = ["--width", "16384", "--height", "16384"];
    let cases: Vec<(Vec<String>, i32, Vec<&str>)> = vec![
        (
            bench(&["--kn", "0x1"]),
            EXIT_USAGE,
            vec!["--kn", "0x1", "1..=4096"],
        ),
        (
            bench(&["--kn", "4"]),
            EXIT_USAGE,
            vec!["--kn", "expected KxN"],
        ),
        (
            bench(&["--kn", "1x5000"]),
            EXIT_USAGE,
            vec!["--kn", "1x5000"],
        ),
        (
            bench(&["--kn", "1x1", "--k", "2"]),
            EXIT_USAGE,
            vec!["--kn or --k/--n"],
        ),
        (
            bench(&["--spp", "0"]),
            EXIT_USAGE,
            vec!["--spp", "0 is not in 1..="],
        ),
        (bench(&["--spp", "1,,2"]), EXIT_USAGE, vec!["--spp"]),
        (bench(&["--repeat", "0"]), EXIT_USAGE, vec!["--repeat"]),
        (
            bench(&["--time-budget", "0"]),
            EXIT_USAGE,
            vec!["--time-budget must be a positive number"],
        ),
        (
            bench(&["--time-budget", "inf"]),
            EXIT_USAGE,
            vec!["--time-budget"],
        ),
        (
            bench(&["--budget-clock", "cpu"]),
            EXIT_USAGE,
            vec!["--budget-clock", "--time-budget"],
        ),
        (
            bench(&["--time-budget", "1", "--budget-clock", "sundial"]),
            EXIT_USAGE,
            vec!["--budget-clock", "sundial"],
        ),
        (
            bench(&["--target-relmse", "NaN"]),
            EXIT_USAGE,
            vec!["--target-relmse"],
        ),
        (
            bench(&["--baseline", "oracle:bsdf:9x9"]),
            EXIT_USAGE,
            vec!["--baseline oracle:bsdf:9x9 is not among"],
        ),
        (
            bench(&["--selectors", "psychic"]),
            EXIT_USAGE,
            vec!["--selector", "psychic"],
        ),
        (bench(&["--threads", "0"]), EXIT_USAGE, vec!["--threads"]),
        (
            bench(&["--clamp=-1"]),
            EXIT_USAGE,
            vec!["--clamp", "positive finite"],
        ),
        (
            bench(&["--width", "0"]),
            EXIT_USAGE,
            vec!["--width", "0 is not in 1..=16384"],
        ),
        (
            bench(&["--width", "1000000000"]),
            EXIT_USAGE,
            vec!["--width", "1000000000"],
        ),
        (
            bench(&huge),
            EXIT_USAGE,
            vec!["--width 16384 --height 16384", "268435456 pixels"],
        ),
        (
            converge(&["--spp", "8"]),
            EXIT_USAGE,
            vec!["two distinct --spp"],
        ),
        (
            converge(&["--spp", "8,8"]),
            EXIT_USAGE,
            vec!["two distinct --spp"],
        ),
        (converge(&["--seeds", "0"]), EXIT_USAGE, vec!["--seeds"]),
        (
            converge(&["--tolerance=-1"]),
            EXIT_USAGE,
            vec!["--tolerance"],
        ),
        (
            converge(&["--tolerance", "nan"]),
            EXIT_USAGE,
            vec!["--tolerance"],
        ),
        (
            converge(&["--reference-spp", "0"]),
            EXIT_USAGE,
            vec!["--reference-spp"],
        ),
        (
            converge(&["--selector", "bvh,power"]),
            EXIT_USAGE,
            vec!["--selector takes one value"],
        ),
        (converge(&huge), EXIT_USAGE, vec!["268435456 pixels"]),
        (
            reference(&["--time", "0"]),
            EXIT_USAGE,
            vec!["--time", "positive number of seconds"],
        ),
        (reference(&["--time", "nan"]), EXIT_USAGE, vec!["--time"]),
        (
            reference(&["--time", "1", "--spp", "4"]),
            EXIT_USAGE,
            vec!["--time", "--spp"],
        ),
        (
            reference(&["--spp", "4,8"]),
            EXIT_USAGE,
            vec!["--spp takes one value"],
        ),
        (
            reference(&["--clamp", "1"]),
            EXIT_USAGE,
            vec!["--clamp is not allowed"],
        ),
        (reference(&huge), EXIT_USAGE, vec!["268435456 pixels"]),
        (render(&["--k", "0"]), EXIT_USAGE, vec!["--k"]),
        (render(&["--n", "5000"]), EXIT_USAGE, vec!["--n"]),
        (
            render(&["--exposure", "nan"]),
            EXIT_USAGE,
            vec!["--exposure", "finite"],
        ),
        (
            render(&["--strategy", "mis,bsdf"]),
            EXIT_USAGE,
            vec!["--strategy takes one value"],
        ),
        (render(&["--height", "0"]), EXIT_USAGE, vec!["--height"]),
        (render(&huge), EXIT_USAGE, vec!["268435456 pixels"]),
        // Refused for its size before the scene's memory is estimated: the same usage error
        // on a machine with little memory as on one with much.
        (
            render(&[&huge[..], &["--max-memory", "64M"]].concat()),
            EXIT_USAGE,
            vec!["268435456 pixels"],
        ),
        (
            bench(&[&huge[..], &["--max-memory", "64M"]].concat()),
            EXIT_USAGE,
            vec!["268435456 pixels"],
        ),
        (
            render(&["--camera", "99"]),
            EXIT_BAD_INPUT,
            vec!["cornell.glb", "camera", "--camera 99"],
        ),
        (
            with(&["info", &scene, "--camera", "nobody"], &[]),
            EXIT_BAD_INPUT,
            vec!["--camera 'nobody'"],
        ),
        (
            with(
                &["gen", "cornell", "-o", &out("g.glb"), "--lights", "1"],
                &[],
            ),
            EXIT_USAGE,
            vec!["--lights"],
        ),
        (
            with(&["gen", "attic", "-o", &out("g.glb")], &[]),
            EXIT_USAGE,
            vec!["attic"],
        ),
        (with(&["diff", &r_exr], &[]), EXIT_USAGE, vec!["REFERENCE"]),
        (with(&["render", &scene], &[]), EXIT_USAGE, vec!["--output"]),
        (with(&["teleport"], &[]), EXIT_USAGE, vec!["teleport"]),
    ];
    for (args, code, mentions) in &cases {
        assert_refused(args, *code, mentions, root);
    }
}
