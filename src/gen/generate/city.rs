//! `city`: a night city of box buildings on a square street grid, lit by
//! exactly the requested number of emissive triangles: lit windows on all
//! four facades (most of them face a side street or a back yard, hidden from
//! most shading points), street lamps, and two-sided neon strips on the
//! facades. Radiance spans 8 decades: windows log-uniform in 1e-3 … 1e2,
//! neon 1e1 … 1e4, lamps 1e3 … 1e5, bucketed into 4 levels per decade so
//! that a few hundred materials at most serve any light count. The grid
//! grows with the light count until the facades hold twice as many window
//! slots as lit windows; half the unlit slots get dark glass.

use std::collections::BTreeMap;

use glam::Vec3;
use rand_core::SeedableRng;
use rand_pcg::Pcg32;

use super::super::gltf_write::{GltfBuilder, GltfMaterial, NodeTransform};
use super::{add_camera_with_aspect, add_object, below, matte, uniform, weighted, QuadMesh};

/// The largest light count `city` accepts.
pub const CITY_MAX_LIGHTS: usize = 2_000_000;

/// Width of one grid cell (building plot plus half the streets), metres.
const PITCH: f32 = 32.0;
/// Half the street width: no building comes closer to a street line.
const STREET_HALF: f32 = 5.0;
/// Storey height, window column spacing and window half sizes, metres.
const STOREY: f32 = 3.5;
const COLUMN: f32 = 2.0;
const WINDOW_HALF_WIDTH: f32 = 0.6;
const WINDOW_HALF_HEIGHT: f32 = 0.8;
/// Distance of windows and neon in front of their facade.
const WINDOW_OFFSET: f32 = 0.02;
const NEON_OFFSET: f32 = 0.15;
/// Radiance levels per decade, and the decade of level 0 (1e-3).
const LEVELS_PER_DECADE: f32 = 4.0;
const LOWEST_DECADE: f32 = -3.0;

/// An axis-aligned building standing on the ground.
struct Building {
    min: Vec3,
    max: Vec3,
}

/// Where a light goes, with its kind's colours and decades.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Window,
    Lamp,
    Neon,
}

impl Kind {
    /// Emission colours (maximum component 1).
    fn colours(self) -> &'static [[f32; 3]] {
        match self {
            Kind::Window => &[[1.0, 0.85, 0.65], [0.8, 0.9, 1.0], [1.0, 0.6, 0.3]],
            Kind::Lamp => &[[1.0, 0.65, 0.25], [0.85, 0.92, 1.0]],
            Kind::Neon => &[[0.1, 0.9, 1.0], [1.0, 0.15, 0.85], [1.0, 0.1, 0.1]],
        }
    }

    /// The decades (log10 of radiance) its radiance is drawn from.
    fn decades(self) -> (f32, f32) {
        match self {
            Kind::Window => (-3.0, 2.0),
            Kind::Lamp => (3.0, 5.0),
            Kind::Neon => (1.0, 4.0),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kind::Window => "window",
            Kind::Lamp => "lamp",
            Kind::Neon => "neon",
        }
    }
}

/// Emissive geometry grouped by (kind, colour, level): one material and one mesh each.
#[derive(Default)]
struct Groups(BTreeMap<(Kind, usize, usize), QuadMesh>);

impl Groups {
    /// The mesh of a light of `kind` with a random colour and radiance level.
    fn pick(&mut self, rng: &mut Pcg32, kind: Kind) -> &mut QuadMesh {
        let colour = below(rng, kind.colours().len());
        let (lo, hi) = kind.decades();
        let level = ((uniform(rng, lo, hi) - LOWEST_DECADE) * LEVELS_PER_DECADE).round() as usize;
        self.0.entry((kind, colour, level)).or_default()
    }
}

/// A city with exactly `lights` (1 ..= [`CITY_MAX_LIGHTS`]) emissive
/// triangles: 2 % of the quads are lamps, 8 % neon, the rest windows; an odd
/// count ends with one triangular neon pennant. The same `seed` always gives
/// the same city.
pub fn city(lights: usize, seed: u64) -> GltfBuilder {
    assert!(
        (1..=CITY_MAX_LIGHTS).contains(&lights),
        "city lights out of range"
    );
    let quads = lights / 2;
    let lamps = quads * 2 / 100;
    let neon = quads * 8 / 100;
    let windows = quads - lamps - neon;
    let (cells, buildings) = (2..)
        .map(|cells| (cells, city_buildings(seed, cells)))
        .find(|(_, b)| slot_count(b) >= 2 * windows)
        .expect("some grid holds enough windows");
    let half_city = 0.5 * cells as f32 * PITCH;

    let mut rng = Pcg32::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let mut b = GltfBuilder::new();
    let asphalt = b.add_material(matte("asphalt", [0.06; 3]));
    let mut ground = QuadMesh::default();
    ground.quad(Vec3::ZERO, Vec3::Z * half_city, Vec3::X * half_city);
    add_object(&mut b, "ground", &ground, asphalt, NodeTransform::Identity);
    let mut blocks = [
        QuadMesh::default(),
        QuadMesh::default(),
        QuadMesh::default(),
    ];
    for building in &buildings {
        blocks[below(&mut rng, 3)].cuboid(building.min, building.max);
    }
    let shades = blocks.iter().zip([0.25, 0.4, 0.55]).enumerate();
    for (shade, (mesh, grey)) in shades.filter(|(_, (m, _))| !m.positions.is_empty()) {
        let name = format!("buildings {shade}");
        let concrete = b.add_material(matte(&name, [grey; 3]));
        add_object(&mut b, &name, mesh, concrete, NodeTransform::Identity);
    }

    let mut groups = Groups::default();
    let mut dark = QuadMesh::default();
    let mut slots = window_slots(&buildings);
    // A partial Fisher–Yates shuffle: the first `windows` slots are lit, the next ones dark.
    let dark_count = (slots.len() - windows).min(windows);
    for i in 0..windows + dark_count {
        let j = i + below(&mut rng, slots.len() - i);
        slots.swap(i, j);
        let (centre, tangent) = slots[i];
        let mesh = if i < windows {
            groups.pick(&mut rng, Kind::Window)
        } else {
            &mut dark
        };
        mesh.quad(
            centre,
            Vec3::Y * WINDOW_HALF_HEIGHT,
            tangent * WINDOW_HALF_WIDTH,
        );
    }
    let glass = b.add_material(GltfMaterial {
        name: "dark glass".into(),
        base_color: [0.02, 0.03, 0.05],
        roughness: 0.1,
        ..GltfMaterial::default()
    });
    if !dark.positions.is_empty() {
        add_object(
            &mut b,
            "dark windows",
            &dark,
            glass,
            NodeTransform::Identity,
        );
    }

    for _ in 0..lamps {
        let (origin, along, across) = random_street(&mut rng, cells);
        let side = if below(&mut rng, 2) == 0 { -1.0 } else { 1.0 };
        let centre = origin
            + along * uniform(&mut rng, -half_city, half_city)
            + across * side * (STREET_HALF - 1.0)
            + Vec3::Y * uniform(&mut rng, 6.5, 7.5);
        let half = uniform(&mut rng, 0.2, 0.3);
        groups
            .pick(&mut rng, Kind::Lamp)
            .quad(centre, Vec3::X * half, Vec3::Z * half); // faces −y
    }

    let mut left = neon;
    while left > 0 {
        let pieces = (1 + below(&mut rng, 6)).min(left);
        left -= pieces;
        let bld = &buildings[below(&mut rng, buildings.len())];
        let (facade, tangent, width) = random_facade(&mut rng, bld);
        let up = Vec3::Y * uniform(&mut rng, 0.08, 0.2);
        let mut at = facade - tangent * uniform(&mut rng, 0.0, 0.5 * width)
            + Vec3::Y * uniform(&mut rng, 4.0, (bld.max.y - 1.0).max(4.5));
        let mesh = groups.pick(&mut rng, Kind::Neon);
        for _ in 0..pieces {
            let half = uniform(&mut rng, 0.25, 0.75);
            mesh.quad(at + tangent * half, up, tangent * half);
            at += tangent * (2.0 * half + 0.1);
        }
    }
    if lights % 2 == 1 {
        let bld = &buildings[0];
        let (facade, tangent, _) = random_facade(&mut rng, bld);
        let top = facade + Vec3::Y * (bld.max.y - 1.0);
        let mesh = groups.pick(&mut rng, Kind::Neon);
        mesh.triangle([
            top,
            top + tangent * 1.5 - Vec3::Y * 0.5,
            top - Vec3::Y * 1.0,
        ]);
    }

    for (&(kind, colour, level), mesh) in &groups.0 {
        let name = format!("{} {colour} L{level:02}", kind.name());
        let strength = 10f32.powf(LOWEST_DECADE + level as f32 / LEVELS_PER_DECADE);
        let material = b.add_material(GltfMaterial {
            name: name.clone(),
            base_color: [0.1; 3],
            roughness: 0.4,
            emissive: kind.colours()[colour],
            emissive_strength: strength,
            double_sided: kind == Kind::Neon,
            ..GltfMaterial::default()
        });
        let m = b.add_mesh(&name, &mesh.positions, None, Some(&mesh.indices), material);
        b.add_node(&name, Some(m), None, NodeTransform::Identity);
    }

    // Down the street between the two middle columns, from just inside the city.
    let street_x = street_line(cells / 2 - 1, cells);
    let eye = [street_x + 1.5, 3.0, half_city - 4.0];
    let target = [street_x - 0.5, 9.0, -half_city];
    add_camera_with_aspect(&mut b, eye, target, 50.0, 1.5);
    b
}

/// The coordinate of the street line between cells `k` and `k + 1`.
fn street_line(k: usize, cells: usize) -> f32 {
    (k + 1) as f32 * PITCH - 0.5 * cells as f32 * PITCH
}

/// One building per cell of a `cells` × `cells` grid, from its own random
/// stream so that the grid size search and the final city agree.
fn city_buildings(seed: u64, cells: usize) -> Vec<Building> {
    let mut rng = Pcg32::seed_from_u64(seed);
    let half_city = 0.5 * cells as f32 * PITCH;
    let mut out = Vec::with_capacity(cells * cells);
    for i in 0..cells {
        for k in 0..cells {
            let centre = |c: usize| (c as f32 + 0.5) * PITCH - half_city;
            let max_half = 0.5 * PITCH - STREET_HALF;
            let half = Vec3::new(
                uniform(&mut rng, 6.0, max_half),
                0.0,
                uniform(&mut rng, 6.0, max_half),
            );
            let slack = Vec3::splat(max_half) - half;
            let shift = Vec3::new(
                uniform(&mut rng, -1.0, 1.0),
                0.0,
                uniform(&mut rng, -1.0, 1.0),
            ) * slack;
            // Mostly mid-rise, a few towers: heights 10 … 90 m, skewed low.
            let height = 10.0 + 80.0 * uniform(&mut rng, 0.0, 1.0).powi(3);
            let foot = Vec3::new(centre(i), 0.0, centre(k)) + shift;
            out.push(Building {
                min: foot - half,
                max: foot + half + Vec3::Y * height,
            });
        }
    }
    out
}

/// The facades of a building: (outward normal, horizontal tangent with
/// `y × tangent` = normal, width).
fn facades(bld: &Building) -> [(Vec3, Vec3, f32); 4] {
    let half = (bld.max - bld.min) * 0.5;
    [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z].map(|normal| {
        let tangent = normal.cross(Vec3::Y);
        (normal, tangent, 2.0 * tangent.abs().dot(half))
    })
}

/// Window columns on a facade of width `width`, and storeys on a building of height `height`.
fn slot_grid(width: f32, height: f32) -> (usize, usize) {
    let columns = ((width - 1.0) / COLUMN).floor().max(0.0) as usize;
    let storeys = ((height - 2.0) / STOREY).floor().max(0.0) as usize;
    (columns, storeys)
}

/// Number of window slots of all buildings.
fn slot_count(buildings: &[Building]) -> usize {
    let height = |b: &Building| b.max.y - b.min.y;
    buildings
        .iter()
        .flat_map(|b| facades(b).map(|(_, _, w)| slot_grid(w, height(b))))
        .map(|(c, s)| c * s)
        .sum()
}

/// Every window slot: (centre, just off the facade; facade tangent).
fn window_slots(buildings: &[Building]) -> Vec<(Vec3, Vec3)> {
    let mut slots = Vec::with_capacity(slot_count(buildings));
    for bld in buildings {
        let centre = (bld.min + bld.max) * 0.5;
        let half = (bld.max - bld.min) * 0.5;
        for (normal, tangent, width) in facades(bld) {
            let (columns, storeys) = slot_grid(width, bld.max.y - bld.min.y);
            let facade = centre + normal * (normal.abs().dot(half) + WINDOW_OFFSET);
            for s in 0..storeys {
                let y = 2.0 + STOREY * (s as f32 + 0.5);
                for c in 0..columns {
                    let along = (c as f32 - (columns as f32 - 1.0) * 0.5) * COLUMN;
                    slots.push((Vec3::new(facade.x, y, facade.z) + tangent * along, tangent));
                }
            }
        }
    }
    slots
}

/// A random facade of `bld`: (a point on its vertical centre line at ground
/// level, `NEON_OFFSET` out; tangent; width). Weighted by width.
fn random_facade(rng: &mut Pcg32, bld: &Building) -> (Vec3, Vec3, f32) {
    let all = facades(bld);
    let weights = all.map(|(_, _, w)| w.round().max(1.0) as u32);
    let (normal, tangent, width) = all[weighted(rng, &weights)];
    let centre = (bld.min + bld.max) * 0.5;
    let half = (bld.max - bld.min) * 0.5;
    let at = centre + normal * (normal.abs().dot(half) + NEON_OFFSET);
    (Vec3::new(at.x, 0.0, at.z), tangent, width)
}

/// A random street centre line: (a point on it, its direction, the horizontal
/// direction across it).
fn random_street(rng: &mut Pcg32, cells: usize) -> (Vec3, Vec3, Vec3) {
    let offset = street_line(below(rng, cells - 1), cells);
    if below(rng, 2) == 0 {
        (Vec3::X * offset, Vec3::Z, Vec3::X)
    } else {
        (Vec3::Z * offset, Vec3::X, Vec3::Z)
    }
}
