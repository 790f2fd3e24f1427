//! The committed Blender export `scenes/room.glb` (built by `scenes/blender/room.py` with
//! Blender 5.0.1's glTF exporter, Standard lighting mode) against the values the script set:
//! a 100 W point and a 300 W spot light written as Φ/(4π)·683 cd read back as Φ/(4π) W/sr, a
//! 2 W/m² sun written as 2·683 lx read back as 2 W/m², each emitter's power π·A·luminance(L)
//! (×2 two-sided) from the script's sizes and strengths (the textured one from the 8-bit sRGB
//! texels the script wrote, averaged over whole periods of the pattern), the mirrored duplicate
//! of the Array strip, and the 4:3 camera; a render lit by the sun alone on Lambert surfaces
//! whose noise-free pixels are ρ/π·E·cos θ of the floor or a wall with the script's sun angles;
//! and a punctual-only render that scales by 683 (within 5σ) under radiometric units.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use crate::color;

use glam::{DVec3, Vec3};
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::lights::{Light, Lights};
use manylights::scene::{load_gltf, CameraChoice, PunctualKind, PunctualUnits, Scene};
use manylights::select::SelectorKind;

/// The script's constants (scenes/blender/room.py).
const POINT_W: f64 = 100.0;
const SPOT_W: f64 = 300.0;
const SUN_W_M2: f64 = 2.0;
const STRIP_STRENGTH: f64 = 5.0;
const SIDED_STRENGTH: f64 = 3.0;
const TEXTURE_STRENGTH: f64 = 4.0;

fn room() -> Scene {
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/room.glb");
    load_gltf(&path, &CameraChoice::default()).unwrap()
}

fn lum(c: [f64; 3]) -> f64 {
    color::luminance(DVec3::from_array(c))
}

/// An 8-bit sRGB texel as the exporter writes it (Blender stores byte images in sRGB), linear.
fn texel(v: f64) -> f64 {
    let s = (v * 255.0).round() / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn room_punctual_lights_are_the_watts_the_script_set() {
    let scene = room();
    assert_eq!(scene.punctual_units, PunctualUnits::Photometric);
    assert_eq!(scene.punctual.len(), 3);
    // The file's numbers: Φ/(4π)·683 cd and E·683 lx.
    let mut kinds = [0; 3];
    for light in &scene.punctual {
        assert_eq!(
            light.intensity,
            Vec3::splat(light.intensity.x),
            "white lights"
        );
        let (index, want) = match light.kind {
            PunctualKind::Point => (0, POINT_W / (4.0 * PI) * 683.0),
            PunctualKind::Spot { cos_outer, .. } => {
                let half_angle = 30f32.to_radians();
                assert!((cos_outer - half_angle.cos()).abs() < 1e-5, "{cos_outer}");
                (1, SPOT_W / (4.0 * PI) * 683.0)
            }
            PunctualKind::Directional => (2, SUN_W_M2 * 683.0),
        };
        let got = light.intensity.x as f64;
        assert!(
            (got - want).abs() < 1e-5 * want,
            "{:?}: {got} vs {want}",
            light.kind
        );
        kinds[index] += 1;
    }
    assert_eq!(kinds, [1; 3]);
    // Blender (-1, 0.5, 2), Z up → glTF (x, z, −y).
    let point = scene
        .punctual
        .iter()
        .find(|l| l.kind == PunctualKind::Point);
    assert!((point.unwrap().position - Vec3::new(-1.0, 2.0, -0.5)).length() < 1e-5);

    // Read back as W/sr and W/m² (÷ 683), or unchanged in radiometric mode.
    for (units, scale) in [
        (PunctualUnits::Photometric, 1.0),
        (PunctualUnits::Radiometric, 683.0),
    ] {
        let lights = Lights::from_scene(&scene.clone().with_punctual_units(units));
        for light in &lights.lights {
            let (got, want) = match light {
                Light::Point(p) if p.spot.is_none() => (p.intensity.x, POINT_W / (4.0 * PI)),
                Light::Point(p) => (p.intensity.x, SPOT_W / (4.0 * PI)),
                Light::Directional(d) => (d.irradiance.x, SUN_W_M2),
                _ => continue,
            };
            let want = want * scale;
            let got = got as f64;
            assert!(
                (got - want).abs() < 1e-5 * want,
                "{units:?}: {got} vs {want}"
            );
        }
        let point_power = lights
            .lights
            .iter()
            .find(|l| matches!(l, Light::Point(p) if p.spot.is_none()))
            .unwrap()
            .power();
        let want = POINT_W * scale;
        assert!((point_power - want).abs() < 1e-5 * want, "{point_power} W");
    }
}

#[test]
fn room_emitters_have_the_power_of_the_script_sizes_and_strengths() {
    let scene = room();
    let lights = Lights::from_scene(&scene);
    let triangles: Vec<_> = lights.triangles().collect();
    // Two strips of 8 quads (Array modifier, applied; one mirrored copy), the one- and
    // two-sided squares and the textured panel: 19 quads.
    assert_eq!(triangles.len(), 38);
    assert_eq!(triangles.iter().filter(|t| !t.two_sided).count(), 2);
    let mirrored = triangles
        .iter()
        .filter(|t| (t.p0.y - 2.8).abs() < 1e-4 && t.p0.x < 0.0)
        .count();
    assert_eq!(mirrored, 16, "the mirrored strip lies at x < 0");
    let textured = triangles.iter().filter(|t| t.textured).count();
    assert_eq!(textured, 2);

    let strip = 2.0 * PI * 16.0 * 0.2 * 0.1 * STRIP_STRENGTH * lum([1.0, 0.9, 0.7]);
    let one_sided = PI * 0.4 * 0.4 * SIDED_STRENGTH * lum([0.3, 0.6, 1.0]);
    let two_sided = 2.0 * PI * 0.4 * 0.4 * SIDED_STRENGTH * lum([1.0, 0.4, 0.3]);
    // The 16² checker of 4×4 blocks, scaled ×2 by the Mapping node: the panel's uv footprint
    // covers whole periods, so its mean is the mean of the two colours.
    let on = [1.0, 0.8, 0.5].map(texel);
    let off = [0.05, 0.1, 0.3].map(texel);
    let mean = [0, 1, 2].map(|c| 0.5 * (on[c] + off[c]));
    let panel = 2.0 * PI * 1.0 * 0.6 * TEXTURE_STRENGTH * lum(mean);
    let want = strip + one_sided + two_sided + panel;
    let got: f64 = triangles.iter().map(|t| t.power()).sum();
    assert!(
        (got - want).abs() < 1e-3 * want,
        "emitter power {got} W vs {want} W"
    );
    let panel_got: f64 = triangles
        .iter()
        .filter(|t| t.textured)
        .map(|t| t.power())
        .sum();
    assert!(
        (panel_got - panel).abs() < 1e-3 * panel,
        "{panel_got} vs {panel}"
    );
}

#[test]
fn room_camera_is_the_exported_4_by_3_view() {
    let scene = room();
    let camera = scene.camera.expect("the export includes the camera");
    let aspect = camera.aspect_ratio.expect("the export writes aspectRatio");
    assert!((aspect - 4.0 / 3.0).abs() < 1e-5, "{aspect}");
}

/// Mean of a render's green channel, and its standard error from the per-pixel variances.
fn mean_image(scene: Scene) -> (f64, f64) {
    let camera = scene.camera.clone().unwrap();
    let prepared = PreparedScene::new(scene, SelectorKind::Bvh);
    let estimator = prepared.estimator(Strategy::Mis, 1, 1);
    let opts = RenderOptions::new(32, 24, 16, 7);
    let (film, _) = render(&estimator, &camera, &opts);
    let n = film.pixels.len() as f64;
    let mean = film.pixels.iter().map(|p| p.mean.y).sum::<f64>() / n;
    // Variance of each pixel's mean: m2 / (count − 1) / count.
    let var = film
        .pixels
        .iter()
        .map(|p| p.m2.y / ((p.count - 1) * p.count) as f64)
        .sum::<f64>()
        / (n * n);
    (mean, var.sqrt())
}

/// Rendering the room with its emitters turned off, once per unit system: only the punctual
/// lights remain (delta lights, read exactly), so the radiometric image is 683× the photometric.
#[test]
fn room_punctual_light_scales_by_683_between_unit_systems() {
    let mut dark = room();
    for m in &mut dark.materials {
        m.emission = Vec3::ZERO;
        m.emissive_texture = None;
    }
    let (photometric, se_p) = mean_image(dark.clone());
    let (radiometric, se_r) = mean_image(dark.with_punctual_units(PunctualUnits::Radiometric));
    assert!(photometric > 0.0);
    let want = 683.0 * photometric;
    let tolerance = 5.0 * (se_r * se_r + (683.0 * se_p).powi(2)).sqrt() + 1e-4 * want;
    assert!(
        (radiometric - want).abs() < tolerance,
        "{radiometric} vs 683 × {photometric} ± {tolerance}"
    );
}

/// The room lit by its sun alone, on pure Lambert surfaces (specular 0): a pixel whose samples
/// all agree sees one plane in full sun or nothing lit, so its value is ρ/π·E·cos θ for the floor,
/// the back wall or the left wall, with the sun's direction from the script's Euler angles
/// (40° about X, then 30° about Z, on Blender's −Z; glTF (x, y, z) = Blender (x, z, −y)), or 0.
#[test]
fn room_sunlit_planes_match_lambert_with_the_script_sun() {
    let mut scene = room();
    for m in &mut scene.materials {
        m.emission = Vec3::ZERO;
        m.emissive_texture = None;
        m.specular = 0.0;
        m.metallic = 0.0;
    }
    scene
        .punctual
        .retain(|l| l.kind == PunctualKind::Directional);
    let (a, b) = (40f64.to_radians(), 30f64.to_radians());
    let sun = [-a.sin() * b.sin(), -a.cos(), -a.sin() * b.cos()];
    let lit = |n: [f64; 3]| {
        let cos = -(sun[0] * n[0] + sun[1] * n[1] + sun[2] * n[2]);
        0.6 / PI * SUN_W_M2 * cos
    };
    // Floor (+Y), back wall (+Z, toward the camera), left wall (+X).
    let planes = [
        lit([0.0, 1.0, 0.0]),
        lit([0.0, 0.0, 1.0]),
        lit([1.0, 0.0, 0.0]),
    ];
    let camera = scene.camera.clone().unwrap();
    let prepared = PreparedScene::new(scene, SelectorKind::Power);
    let estimator = prepared.estimator(Strategy::LightArea, 1, 1);
    let opts = RenderOptions::new(64, 48, 8, 3);
    let (film, _) = render(&estimator, &camera, &opts);
    let mut seen = [0usize; 3];
    for p in film
        .pixels
        .iter()
        .filter(|p| p.m2.y == 0.0 && p.mean.y > 0.0)
    {
        let value = p.mean.y;
        let plane = planes.iter().position(|&v| (value - v).abs() < 1e-4 * v);
        let plane = plane.unwrap_or_else(|| panic!("{value} is none of {planes:?}"));
        seen[plane] += 1;
    }
    assert!(seen.iter().all(|&n| n >= 10), "pixels per plane {seen:?}");
}
