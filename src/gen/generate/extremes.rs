//! `extremes`: the numerically hard cases in one scene, each in its own
//! 1 m box open toward +z, so that no box sees another's lights (their
//! openings are coplanar, and a ray leaving one never turns back): a light
//! 1e-4 m above a surface, a light of area 1e-10 m² and radiance 1e8, an
//! emitter standing perpendicular on its receiver, a one-sided emitter facing
//! away beside a two-sided one, a light of radiance 1e-8, an emitter lying in
//! its receiver's plane, and, outside the boxes, a 2 km square light 10 km
//! away (below every box floor's horizon) lighting a plate that faces it.
//!
//! Receivers are Lambertian (albedo [`RECEIVER_ALBEDO`], no specular lobe),
//! so a probe point x reflects ρ/π · Σ E_l(x), every E_l given by Lambert's
//! polygon formula over the lights inside the probe's region ([`PROBES`]).

use glam::Vec3;

use super::super::gltf_write::{GltfBuilder, GltfMaterial, NodeTransform};
use super::{add_camera_with_aspect, add_object, QuadMesh};

/// Albedo of every receiver (box floors and the far light's plate).
pub const RECEIVER_ALBEDO: f32 = 0.8;

/// A point whose reflected radiance has a closed form.
#[derive(Clone, Copy, Debug)]
pub struct Probe {
    pub name: &'static str,
    /// The point, on a receiver.
    pub point: [f32; 3],
    /// The receiver's normal there (its lit side).
    pub normal: [f32; 3],
    /// A point from which the straight segment to `point` crosses nothing.
    pub approach: [f32; 3],
    /// Corners of the box holding every light that reaches `point` (by centroid).
    pub region: ([f32; 3], [f32; 3]),
}

/// Box k is centred at x = 2k: floor y = 0, ceiling y = 1, back z = −0.5, open at z = 0.5.
const fn box_x(k: usize) -> f32 {
    2.0 * k as f32
}

/// The light-holding region of box k.
const fn box_region(k: usize) -> ([f32; 3], [f32; 3]) {
    let x = box_x(k);
    ([x - 0.5, -0.01, -0.5], [x + 0.5, 1.0, 0.5])
}

const TINY: usize = 0;
const NEAR: usize = 1;
const GRAZING: usize = 2;
const SIDES: usize = 3;
const DIM: usize = 4;
const IN_PLANE: usize = 5;
const BOXES: usize = 6;
/// Height of the near light above its floor, metres.
pub const NEAR_GAP: f32 = 1e-4;
/// Area of the tiny light, m².
pub const TINY_AREA: f32 = 1e-10;
/// x of the plate facing the far light.
const PLATE_X: f32 = 12.0;

/// A probe on box k's floor at (x offset, z).
const fn floor_probe(name: &'static str, k: usize, dx: f32, approach_height: f32) -> Probe {
    let x = box_x(k) + dx;
    Probe {
        name,
        point: [x, 0.0, 0.0],
        normal: [0.0, 1.0, 0.0],
        approach: [x, approach_height, 0.0],
        region: box_region(k),
    }
}

/// The probes, one or more per case.
pub const PROBES: [Probe; 11] = [
    floor_probe("under the 1e-10 m² light of radiance 1e8", TINY, 0.0, 0.05),
    // Entered through the gap: from 5 cm aside at half the gap's height.
    Probe {
        name: "1e-4 m under a 0.6 m light (≈ full hemisphere)",
        point: [box_x(NEAR), 0.0, 0.0],
        normal: [0.0, 1.0, 0.0],
        approach: [box_x(NEAR), 0.5 * NEAR_GAP, 0.05],
        region: box_region(NEAR),
    },
    floor_probe(
        "0.3 m from an emitter perpendicular to the floor",
        GRAZING,
        0.0,
        0.05,
    ),
    floor_probe(
        "1 cm from an emitter perpendicular to the floor",
        GRAZING,
        0.29,
        0.05,
    ),
    floor_probe(
        "behind a one-sided perpendicular emitter",
        GRAZING,
        0.4,
        0.05,
    ),
    floor_probe("under a one-sided emitter facing away", SIDES, -0.25, 0.05),
    floor_probe("under a two-sided emitter", SIDES, 0.25, 0.05),
    floor_probe("under a light of radiance 1e-8", DIM, -0.25, 0.05),
    floor_probe(
        "in the plane of an emitter, under a ceiling light",
        IN_PLANE,
        -0.25,
        0.05,
    ),
    floor_probe(
        "5 cm from an emitter in the floor's plane",
        IN_PLANE,
        0.05,
        0.05,
    ),
    Probe {
        name: "facing a 2 km light 10 km away",
        point: [PLATE_X, 0.5, 0.6],
        normal: [0.0, 0.0, 1.0],
        approach: [PLATE_X, 0.5, 0.65],
        region: ([-1e5, -1e5, 1e3], [1e5, 1e5, 1e5]),
    },
];

/// Builds the scene: `BOXES` open boxes in a row along +x, the far light's
/// plate beside them, and a camera in front looking into the openings.
pub fn extremes() -> GltfBuilder {
    let mut b = GltfBuilder::new();
    let lambert = |name: &str, albedo: f32| GltfMaterial {
        name: name.into(),
        base_color: [albedo; 3],
        specular: 0.0,
        ..GltfMaterial::default()
    };
    let receiver = b.add_material(lambert("receiver", RECEIVER_ALBEDO));
    let wall = b.add_material(lambert("wall", 0.4));

    let mut floors = QuadMesh::default();
    let mut walls = QuadMesh::default();
    for k in 0..BOXES {
        let x = box_x(k);
        // Every quad reaches 2 cm past the seams it shares (never past the opening),
        // so no ray slips between two walls.
        let floor_end = if k == IN_PLANE { x + 0.1 } else { x + 0.52 };
        floors.quad(
            Vec3::new(0.5 * (x - 0.52 + floor_end), 0.0, -0.01),
            Vec3::Z * 0.51,
            Vec3::X * 0.5 * (floor_end - x + 0.52),
        );
        walls.quad(Vec3::new(x, 1.0, -0.01), Vec3::X * 0.52, Vec3::Z * 0.51); // ceiling, faces −y
        walls.quad(Vec3::new(x, 0.5, -0.5), Vec3::X * 0.52, Vec3::Y * 0.52); // back, faces +z
        walls.quad(
            Vec3::new(x - 0.5, 0.5, -0.01),
            Vec3::Y * 0.52,
            Vec3::Z * 0.51,
        ); // faces +x
        walls.quad(
            Vec3::new(x + 0.5, 0.5, -0.01),
            Vec3::Z * 0.51,
            Vec3::Y * 0.52,
        ); // faces −x
    }
    floors.quad(Vec3::new(PLATE_X, 0.5, 0.6), Vec3::X * 0.5, Vec3::Y * 0.5); // faces +z
    add_object(
        &mut b,
        "receivers",
        &floors,
        receiver,
        NodeTransform::Identity,
    );
    add_object(&mut b, "walls", &walls, wall, NodeTransform::Identity);

    let mut emitter = |name: &str, radiance: f32, two_sided: bool, mesh: QuadMesh| {
        let m = b.add_material(GltfMaterial {
            name: name.into(),
            base_color: [0.0; 3],
            specular: 0.0,
            emissive: [1.0; 3],
            emissive_strength: radiance,
            double_sided: two_sided,
            ..GltfMaterial::default()
        });
        add_object(&mut b, name, &mesh, m, NodeTransform::Identity);
    };
    let down = |centre: Vec3, hx: f32, hz: f32| {
        let mut q = QuadMesh::default();
        q.quad(centre, Vec3::X * hx, Vec3::Z * hz);
        q
    };
    let up = |centre: Vec3, hx: f32, hz: f32| {
        let mut q = QuadMesh::default();
        q.quad(centre, Vec3::Z * hz, Vec3::X * hx);
        q
    };

    // A right triangle with legs √(2A), at the origin's box, facing down.
    let leg = (2.0 * TINY_AREA).sqrt();
    let mut tiny = QuadMesh::default();
    let y = 0.2;
    tiny.triangle([
        Vec3::new(0.0, y, 0.0),
        Vec3::new(leg, y, 0.0),
        Vec3::new(0.0, y, leg),
    ]);
    emitter("tiny light (1e-10 m², radiance 1e8)", 1e8, false, tiny);

    let near = down(Vec3::new(box_x(NEAR), NEAR_GAP, 0.0), 0.3, 0.3);
    emitter("light 1e-4 m above the floor", 1.0, false, near);

    let mut standing = QuadMesh::default();
    standing.quad(
        Vec3::new(box_x(GRAZING) + 0.3, 0.2, 0.0),
        Vec3::Z * 0.3,
        Vec3::Y * 0.2,
    ); // faces −x
    emitter("emitter perpendicular to the floor", 10.0, false, standing);

    let sides = box_x(SIDES);
    let away = up(Vec3::new(sides - 0.25, 0.5, 0.0), 0.2, 0.2);
    emitter("one-sided emitter facing up", 5.0, false, away);
    let both = up(Vec3::new(sides + 0.25, 0.5, 0.0), 0.2, 0.2);
    emitter("two-sided emitter", 5.0, true, both);

    let dim = down(Vec3::new(box_x(DIM) - 0.25, 0.9, 0.0), 0.15, 0.15);
    emitter("light of radiance 1e-8", 1e-8, false, dim);

    let plane = box_x(IN_PLANE);
    let tile = up(Vec3::new(plane + 0.31, 0.0, -0.01), 0.21, 0.51);
    emitter("emitter in the floor's plane", 2.0, false, tile);
    let ceiling = down(Vec3::new(plane - 0.25, 0.999, 0.0), 0.1, 0.1);
    emitter(
        "ceiling light over the in-plane emitter",
        3.0,
        false,
        ceiling,
    );

    let mut far = QuadMesh::default();
    far.quad(
        Vec3::new(box_x(BOXES / 2), -1500.0, 1e4),
        Vec3::Y * 1000.0,
        Vec3::X * 1000.0,
    ); // faces −z
    emitter("huge far light", 100.0, false, far);

    // 9 m in front of the openings, wide enough for the row of boxes and the plate.
    let centre = 0.5 * PLATE_X;
    add_camera_with_aspect(&mut b, [centre, 0.5, 9.0], [centre, 0.5, 0.0], 24.0, 3.5);
    b
}
