//! The lit-surface mask against a scene whose pixel coverage is known by construction: a
//! camera at the origin looking down −Z with a 90° field of view over 16 × 16 pixels maps the
//! plane z = −1 onto the image with pixel column x covering [−1 + x/8, −1 + (x+1)/8] and row y
//! covering [1 − (y+1)/8, 1 − y/8]. On that plane a double-sided emitter covers pixels
//! x, y ∈ 4..8 exactly, a second one covers the left half of pixel (10, 11), and a diffuse
//! wall at z = −2 fills every column from x = 2 on (columns 0 and 1 see the empty background).

use std::path::Path;

use glam::{Mat4, Vec3};
use manylights::image::read_exr_layers;
use manylights::measure::mask::{lit_mask, primary_surface_fractions};
use manylights::measure::reference::{
    read_reference, render_reference, write_reference, ReferenceOptions, DEFAULT_ESTIMATOR,
};
use manylights::measure::SceneSetup;
use manylights::scene::{Camera, Material, Scene, Triangle};

const SIZE: u32 = 16;

/// Two triangles covering [x0, x1] × [y0, y1] at depth z, facing +Z.
fn quad(x0: f32, x1: f32, y0: f32, y1: f32, z: f32, material: u32) -> [Triangle; 2] {
    let p = |x, y| Vec3::new(x, y, z);
    [
        Triangle::flat([p(x0, y0), p(x1, y0), p(x1, y1)], material),
        Triangle::flat([p(x0, y0), p(x1, y1), p(x0, y1)], material),
    ]
}

fn setup() -> SceneSetup {
    let mut triangles = Vec::new();
    triangles.extend(quad(-1.5, 10.0, -10.0, 10.0, -2.0, 0));
    triangles.extend(quad(-0.5, 0.0, 0.0, 0.5, -1.0, 1));
    triangles.extend(quad(0.25, 0.3125, -0.5, -0.375, -1.0, 1));
    let materials = vec![
        Material::lambert(Vec3::splat(0.5)),
        Material::emitter(Vec3::splat(4.0), true),
    ];
    let camera =
        Camera::from_world_matrix("c".into(), &Mat4::IDENTITY, 90f32.to_radians(), None).unwrap();
    let scene = Scene::new(triangles, materials, Some(camera.clone())).unwrap();
    SceneSetup {
        path: "constructed".into(),
        hash: 0,
        scene,
        camera,
        camera_choice: None,
        width: SIZE,
        height: SIZE,
    }
}

/// The fraction each pixel must have: 0 on the background columns and under the full emitter,
/// 1/2 at (10, 11), 1 elsewhere.
fn expected(x: usize, y: usize) -> f64 {
    if x < 2 || ((4..8).contains(&x) && (4..8).contains(&y)) {
        0.0
    } else if (x, y) == (10, 11) {
        0.5
    } else {
        1.0
    }
}

#[test]
fn primary_visibility_pass_gives_the_exact_fractions() {
    let fractions = primary_surface_fractions(&setup(), 8);
    for (i, &f) in fractions.iter().enumerate() {
        let (x, y) = (i % SIZE as usize, i / SIZE as usize);
        // The 8 × 8 cell centres split exactly: 32 of 64 rays in the half-covered pixel.
        assert_eq!(f as f64, expected(x, y), "pixel ({x}, {y})");
    }
    let lit = lit_mask(&fractions).iter().filter(|&&l| l).count();
    assert_eq!(lit, 256 - 32 - 16 - 1);
}

#[test]
fn reference_surface_channel_matches_the_coverage_and_survives_its_file() {
    let setup = setup();
    let spp = 256;
    let options = ReferenceOptions {
        width: SIZE,
        height: SIZE,
        camera: None,
        estimator: DEFAULT_ESTIMATOR,
        seed: 7,
        spp: Some(spp),
        time: None,
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ref.exr");
    let reference = render_reference(&setup, &options, &path, |_, _| {});
    let surface = reference
        .surface
        .clone()
        .expect("references carry the channel");
    for (i, &f) in surface.iter().enumerate() {
        let (x, y) = (i % SIZE as usize, i / SIZE as usize);
        let want = expected(x, y);
        if want == 0.5 {
            // Jittered samples: binomial, sd sqrt(1/4 / spp); allow 5σ.
            let sigma = (0.25 / spp as f64).sqrt();
            assert!((f as f64 - 0.5).abs() <= 5.0 * sigma, "half pixel: {f}");
        } else {
            assert_eq!(f as f64, want, "pixel ({x}, {y})");
        }
    }
    write_reference(&reference).unwrap();
    assert_eq!(
        read_reference(&path).unwrap().surface,
        Some(surface.clone())
    );
    assert_eq!(
        read_exr_layers(Path::new(&path)).unwrap().surface,
        Some(surface)
    );
}
