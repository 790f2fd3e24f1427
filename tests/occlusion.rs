//! Shadow rays: no light leaks into a closed box from emitters pressed against its outside, and
//! a surface never shadows itself (no acne), even at grazing angles and extreme scales.

use crate::shapes;
use shapes::{closed_box, quad};

use glam::{Mat4, Vec3};
use manylights::accel::Accel;
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::scene::{Camera, Material, Scene};
use manylights::select::SelectorKind;

fn render_scene(scene: &Scene, strategy: Strategy, spp: u32) -> manylights::film::Film {
    let prepared = PreparedScene::new(scene.clone(), SelectorKind::Power);
    let estimator = prepared.estimator(strategy, 2, 2);
    let opts = RenderOptions::new(24, 24, spp, 3);
    render(&estimator, scene.camera.as_ref().unwrap(), &opts).0
}

/// A camera node matrix at `eye` whose local −Z looks at `target`, +Y up.
fn camera_to_world(eye: Vec3, target: Vec3) -> Mat4 {
    let forward = (target - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        (-forward).extend(0.0),
        eye.extend(1.0),
    )
}

#[test]
fn no_light_leaks_into_a_closed_box() {
    let mut tris = closed_box(Vec3::ZERO, Vec3::ONE, 0);
    // A big two-sided emitter lying 1e-4 m above the lid and another 1e-4 m outside a wall.
    let lid = 1.0 + 1e-4;
    tris.extend(quad(
        Vec3::new(-0.5, lid, -0.5),
        Vec3::new(-0.5, lid, 1.5),
        Vec3::new(1.5, lid, 1.5),
        Vec3::new(1.5, lid, -0.5),
        1,
    ));
    let wall = 1.0 + 1e-4;
    tris.extend(quad(
        Vec3::new(wall, 0.0, 0.0),
        Vec3::new(wall, 1.0, 0.0),
        Vec3::new(wall, 1.0, 1.0),
        Vec3::new(wall, 0.0, 1.0),
        1,
    ));
    let materials = vec![
        Material::lambert(Vec3::splat(0.8)),
        Material::emitter(Vec3::splat(1e3), true),
    ];
    // Camera inside the box looking at a corner of the floor and walls.
    let world = camera_to_world(Vec3::new(0.2, 0.8, 0.9), Vec3::new(0.9, 0.1, 0.1));
    let camera = Camera::from_world_matrix("inside".into(), &world, 1.4, None).unwrap();
    let scene = Scene::new(tris, materials, Some(camera)).unwrap();
    for strategy in [Strategy::LightArea, Strategy::HemisphereCosine] {
        let film = render_scene(&scene, strategy, 64);
        let max = film
            .pixels
            .iter()
            .map(|p| p.mean.max_element())
            .fold(0.0, f64::max);
        assert_eq!(
            max, 0.0,
            "{strategy:?}: light leaked into the box (max pixel {max})"
        );
    }
}

#[test]
fn grazing_and_tiny_segments_do_not_self_occlude() {
    // Receiver points on a plane and light points above it at elevations down to 0.01°, at
    // scales from 1e-2 m to 1e6 m: the plane must never block its own shadow rays (acne), and a
    // segment crossing the plane must be blocked. The end-point offsets move a segment's
    // crossing by about offset / tan(elevation), so that check starts at 1° elevation. (Below
    // 1e-2 m the offset near the origin, an absolute 2^-16 m, becomes a sizeable part of the
    // scene: a known limit of the offset method.)
    let mut rng = manylights::sampling::rng::PixelRng::new(9, 9);
    for scale in [1e-2f32, 1.0, 1e3, 1e6] {
        let offset = Vec3::new(0.37, -1.3, 0.11) * scale;
        let tris = quad(
            Vec3::new(-1.0, -1.0, 0.0) * scale + offset,
            Vec3::new(1.0, -1.0, 0.0) * scale + offset,
            Vec3::new(1.0, 1.0, 0.0) * scale + offset,
            Vec3::new(-1.0, 1.0, 0.0) * scale + offset,
            0,
        )
        .to_vec();
        let scene = Scene::new(tris, vec![Material::default()], None).unwrap();
        let accel = Accel::build(&scene);
        for i in 0..5000 {
            let [u, v] = rng.next_2d();
            let a = Vec3::new(2.0 * u - 1.0, 2.0 * v - 1.0, 0.0) * 0.9 * scale + offset;
            let elevation = (1e-2f32 + 90.0 * rng.next_f32().powi(3)).to_radians();
            let azimuth = 6.2831855 * rng.next_f32();
            let dir = Vec3::new(
                elevation.cos() * azimuth.cos(),
                elevation.cos() * azimuth.sin(),
                elevation.sin(),
            );
            let b = a + dir * (0.05 + 3.0 * rng.next_f32()) * scale;
            // The light faces the receiver.
            let nb = -dir;
            assert!(
                !accel.segment_occluded(a, Vec3::Z, b, nb),
                "scale {scale}, pair {i}: elevation {}° blocked by the receiver's own plane",
                elevation.to_degrees()
            );
            let below = a - dir * scale;
            assert!(
                elevation < 1f32.to_radians() || accel.segment_occluded(below, -Vec3::Z, b, nb),
                "scale {scale}, pair {i}: a segment through the plane at {a} passes (elevation {}°)",
                elevation.to_degrees()
            );
        }
    }
}
