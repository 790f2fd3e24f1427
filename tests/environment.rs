//! The environment light through the whole renderer: under a constant sky of radiance L an
//! unoccluded upward-facing Lambertian plane of albedo ρ receives E = π·L and reflects ρ·L,
//! whichever way the directions are drawn (hemisphere-uniform, hemisphere-cosine, BSDF, light
//! sampling of the map through every selector, MIS). A second light — an emissive triangle
//! under the plane that cannot reach its upper side — makes each selector split its probability
//! between the sky and a light that contributes nothing, so p_l(env) must be right too.
//! Under a sun-and-sky map the plane's irradiance is the exact texel sum
//! E = Σ_ij L_ij ∫_texel cosθ dω = Σ_ij L_ij · (π/W)·(sin²θ_{j+1} − sin²θ_j) over the upper rows.

use std::sync::Arc;

use glam::{DVec3, Mat4, Vec3};
use manylights::gen::sky;
use manylights::image::RgbImage;
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::scene::{Camera, EnvironmentImage, Material, Scene, Triangle};
use manylights::select::SelectorKind;

const RHO: f32 = 0.6;
const SKY: [f32; 3] = [0.5, 1.0, 2.0];
const SIZE: u32 = 12;

const HEMISPHERE_AND_BSDF: [Strategy; 3] = [
    Strategy::HemisphereUniform,
    Strategy::HemisphereCosine,
    Strategy::Bsdf,
];

const SELECTORS: [SelectorKind; 4] = [
    SelectorKind::Uniform,
    SelectorKind::Power,
    SelectorKind::Bvh,
    SelectorKind::Oracle,
];

/// A 4 m plane at y = 0 facing +Y, a camera 2 m above looking straight down (it sees only the
/// plane), an emissive triangle facing down 0.5 m below the plane, and the sky `env`.
fn scene(env: EnvironmentImage) -> Scene {
    let materials = vec![
        Material::lambert(Vec3::splat(RHO)),
        Material::emitter(Vec3::splat(50.0), false),
    ];
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let (a, b, c, d) = (
        p(-2.0, 0.0, -2.0),
        p(-2.0, 0.0, 2.0),
        p(2.0, 0.0, 2.0),
        p(2.0, 0.0, -2.0),
    );
    let triangles = vec![
        Triangle::flat([a, b, c], 0),
        Triangle::flat([a, c, d], 0),
        // Clockwise seen from above: faces −Y, away from the plane.
        Triangle::flat([p(0.0, -0.5, 0.0), p(0.5, -0.5, 0.0), p(0.0, -0.5, 0.5)], 1),
    ];
    assert!(triangles[0].geometric_normal().y > 0.99);
    assert!(triangles[2].geometric_normal().y < -0.99);
    let look_down = Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let camera = Camera::from_world_matrix("down".into(), &look_down, 0.6, None).unwrap();
    Scene::new(triangles, materials, Some(camera))
        .unwrap()
        .with_environment(Some(Arc::new(env)))
}

/// Renders at 64 spp and checks the image mean of each channel against `expected` within 5σ
/// (σ from the pixels' variances; estimators with zero variance must then hit it to float
/// precision).
fn check(env: EnvironmentImage, expected: DVec3, selector: SelectorKind, strategy: Strategy) {
    let prepared = PreparedScene::new(scene(env), selector);
    assert_eq!(prepared.lights.len(), 2);
    let estimator = prepared.estimator(strategy, 1, 1);
    let camera = prepared.scene.camera.clone().unwrap();
    let opts = RenderOptions::new(SIZE, SIZE, 64, 3);
    let (film, stats) = render(&estimator, &camera, &opts);
    assert_eq!(stats.nan_samples + stats.inf_samples, 0);
    let pixels = film.pixels.len() as f64;
    let mean: DVec3 = film.pixels.iter().map(|p| p.mean).sum::<DVec3>() / pixels;
    let var: DVec3 = film
        .pixels
        .iter()
        .map(|p| p.variance_of_mean())
        .sum::<DVec3>()
        / (pixels * pixels);
    for c in 0..3 {
        let sigma = var[c].sqrt();
        assert!(
            (mean[c] - expected[c]).abs() < 5.0 * sigma + 1e-5 * expected[c],
            "{selector:?} {strategy:?}: channel {c} = {} ± {sigma}, expected {}",
            mean[c],
            expected[c]
        );
    }
}

/// A constant 8×4 sky of radiance SKY, turned by 33° (which changes nothing), and the plane's
/// exitant radiance under it, ρ·L.
fn constant_sky() -> (EnvironmentImage, DVec3) {
    let sky = RgbImage {
        width: 8,
        height: 4,
        pixels: vec![SKY; 32],
    };
    let map = EnvironmentImage::from_rgb(&sky, 1.0, 33.0).unwrap();
    (map, (Vec3::from_array(SKY) * RHO).as_dvec3())
}

/// The 32×16 sun-and-sky map turned by 70°, and ρ/π·E of an upward plane under it, E summed
/// over the upper 8 rows' texels (each row's ∫cosθ dω = (π/W)·(sin²θ_{j+1} − sin²θ_j)).
fn sun_and_sky() -> (EnvironmentImage, DVec3) {
    let (w, h) = (32, 16);
    let image = sky::sun_and_sky(w, h);
    let sin2 = |j: usize| (std::f64::consts::PI * j as f64 / h as f64).sin().powi(2);
    let mut irradiance = DVec3::ZERO;
    for j in 0..h / 2 {
        let projected = std::f64::consts::PI / w as f64 * (sin2(j + 1) - sin2(j));
        for i in 0..w {
            irradiance += DVec3::from_array(image.pixels[j * w + i].map(f64::from)) * projected;
        }
    }
    let map = EnvironmentImage::from_rgb(&image, 1.0, 70.0).unwrap();
    (map, irradiance * RHO as f64 / std::f64::consts::PI)
}

#[test]
fn hemisphere_and_bsdf_sampling_see_a_constant_sky() {
    for strategy in HEMISPHERE_AND_BSDF {
        let (map, expected) = constant_sky();
        check(map, expected, SelectorKind::Power, strategy);
    }
}

#[test]
fn light_sampling_of_the_map_gives_e_equal_pi_l_with_every_selector() {
    for selector in SELECTORS {
        for strategy in [
            Strategy::LightArea,
            Strategy::LightSolidAngle,
            Strategy::Mis,
        ] {
            let (map, expected) = constant_sky();
            check(map, expected, selector, strategy);
        }
    }
}

#[test]
fn every_strategy_gets_the_exact_irradiance_under_a_sun_and_sky() {
    for strategy in HEMISPHERE_AND_BSDF {
        let (map, expected) = sun_and_sky();
        check(map, expected, SelectorKind::Power, strategy);
    }
    for selector in SELECTORS {
        for strategy in [Strategy::LightArea, Strategy::Mis] {
            let (map, expected) = sun_and_sky();
            check(map, expected, selector, strategy);
        }
    }
}

mod cli {
    use std::path::Path;
    use std::process::Command;

    use manylights::cli::{EXIT_BAD_INPUT, EXIT_USAGE};
    use manylights::image::{write_exr, RgbImage};

    fn repo(path: &str) -> String {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(path)
            .to_string_lossy()
            .into_owned()
    }

    /// Renders the Cornell box at 8 px with `extra` options: (exit code, stderr, wrote output).
    fn render(dir: &Path, extra: &[&str]) -> (i32, String, bool) {
        let out = dir.join("out.exr");
        let o = Command::new(env!("CARGO_BIN_EXE_manylights"))
            .args(["render", &repo("scenes/cornell.glb"), "-o"])
            .arg(&out)
            .args(["--width", "8", "--spp", "1"])
            .args(extra)
            .output()
            .expect("binary runs");
        (
            o.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&o.stderr).into_owned(),
            out.exists(),
        )
    }

    fn assert_bad_input(dir: &Path, env: &Path, must_mention: &str) {
        let (code, stderr, wrote) = render(dir, &["--env", env.to_str().unwrap()]);
        assert_eq!(code, EXIT_BAD_INPUT, "{stderr}");
        let name = env.file_name().unwrap().to_str().unwrap();
        assert!(stderr.contains(name), "should name {name}: {stderr}");
        assert!(
            stderr.contains(must_mention),
            "should say {must_mention:?}: {stderr}"
        );
        assert!(!stderr.contains("panicked") && !wrote, "{stderr}");
    }

    #[test]
    fn bad_environment_maps_are_refused_with_exit_3_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        assert_bad_input(dir.path(), &dir.path().join("missing.exr"), "cannot read");
        let text = dir.path().join("text.exr");
        std::fs::write(&text, b"not an image").unwrap();
        assert_bad_input(dir.path(), &text, "OpenEXR");
        let image = |pixels: Vec<[f32; 3]>| RgbImage {
            width: 2,
            height: 2,
            pixels,
        };
        let nan = dir.path().join("nan.exr");
        write_exr(
            &nan,
            &image(vec![[1.0; 3], [1.0; 3], [0.0, f32::NAN, 0.0], [1.0; 3]]),
            None,
        )
        .unwrap();
        assert_bad_input(dir.path(), &nan, "texel (0, 1)");
        let negative = dir.path().join("negative.exr");
        write_exr(
            &negative,
            &image(vec![[1.0; 3], [-2.0, 0.0, 0.0], [1.0; 3], [1.0; 3]]),
            None,
        )
        .unwrap();
        assert_bad_input(dir.path(), &negative, "non-negative");
    }

    #[test]
    fn env_options_without_a_map_are_usage_errors() {
        let dir = tempfile::tempdir().unwrap();
        let (code, stderr, _) = render(dir.path(), &["--env-scale", "2"]);
        assert_eq!(code, EXIT_USAGE, "{stderr}");
        let (code, stderr, _) = render(
            dir.path(),
            &["--env", &repo("scenes/sky.exr"), "--env-scale", "-1"],
        );
        assert_eq!(code, EXIT_USAGE, "{stderr}");
    }

    #[test]
    fn the_shipped_sky_is_what_gen_writes_and_lights_the_scene() {
        let dir = tempfile::tempdir().unwrap();
        let sky = dir.path().join("sky.exr");
        let o = Command::new(env!("CARGO_BIN_EXE_manylights"))
            .args(["gen", "sky", "-o"])
            .arg(&sky)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(std::fs::read(&sky).unwrap() == std::fs::read(repo("scenes/sky.exr")).unwrap());
        // The Cornell box is open toward +Z: the sky adds light, and counts as one more light.
        let json = dir.path().join("summary.json");
        let (code, stderr, wrote) = render(
            dir.path(),
            &[
                "--env",
                sky.to_str().unwrap(),
                "--env-rotate",
                "-90",
                "--json",
                json.to_str().unwrap(),
            ],
        );
        assert!(code == 0 && wrote, "{stderr}");
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(summary["lights"], 3);
        assert_eq!(summary["environment"]["width"], 256);
        assert_eq!(summary["environment"]["rotate_degrees"], -90.0);
    }
}

#[test]
fn reference_caches_tell_skies_apart() {
    use manylights::measure::SceneSetup;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let load = || SceneSetup::load(&path, None, 8, None).unwrap();
    let sky = |scale: f32, rotate: f32| {
        let (map, _) = sun_and_sky();
        let image = RgbImage {
            width: map.width(),
            height: map.height(),
            pixels: map.texels().iter().map(|t| t.to_array()).collect(),
        };
        Some(Arc::new(
            EnvironmentImage::from_rgb(&image, scale, rotate).unwrap(),
        ))
    };
    let plain = load().hash;
    let hashes = [
        load().with_environment(None).hash,
        load().with_environment(sky(1.0, 0.0)).hash,
        load().with_environment(sky(2.0, 0.0)).hash,
        load().with_environment(sky(1.0, 10.0)).hash,
    ];
    assert_eq!(hashes[0], plain);
    for i in 1..4 {
        assert_ne!(hashes[i], plain);
        for j in i + 1..4 {
            assert_ne!(hashes[i], hashes[j], "maps {i} and {j}");
        }
    }
    assert_eq!(load().with_environment(sky(2.0, 0.0)).hash, hashes[2]);
}
