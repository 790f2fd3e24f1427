//! The night town of `gen town`: a grid of buildings with lit windows, street lamps and
//! two-sided neon strips, radiances over five decades, for benchmarking light selection.

use glam::{Mat4, Vec3};
use rand_core::SeedableRng;
use rand_pcg::Pcg32;

use super::super::gltf_write::{GltfBuilder, GltfMaterial, NodeTransform};
use super::*;

/// Builds a night town of about `target_lights` emissive triangles (two per
/// quad) spread over lit windows, street lamps and two-sided neon strips,
/// with radiances spanning five decades. The same `seed` always gives the
/// same scene.
pub fn many_lights(seed: u64, target_lights: usize) -> GltfBuilder {
    let mut rng = Pcg32::seed_from_u64(seed);
    let buildings = town_buildings(&mut rng);
    let mut b = GltfBuilder::new();
    add_town_geometry(&mut b, &buildings, &mut rng);

    let quads = target_lights.div_ceil(2);
    let mut lights = LightGroups::default();
    let windows = lights.add_windows(&mut rng, &buildings, quads / 2);
    let lamps = lights.add_lamps(&mut rng, quads * 10 / 100);
    lights.add_neon(&mut rng, quads - windows - lamps);
    lights.add_to(&mut b);

    add_camera(&mut b, [0.8, 8.0, 29.5], [-1.0, 4.0, 0.0], 60.0);
    b
}

/// The town is a `CELLS × CELLS` grid of `PITCH`-metre cells centred on the
/// origin, one building per cell; streets run along the cell borders.
const CELLS: usize = 6;
const PITCH: f32 = 10.0;
const HALF_TOWN: f32 = CELLS as f32 * PITCH * 0.5;
/// Minimum distance from a street's centre line to any building.
const STREET_HALF_WIDTH: f32 = 2.0;
/// Storey height and horizontal window spacing on facades.
const STOREY: f32 = 2.5;
const WINDOW_PITCH: f32 = 0.9;
/// Window offset from its facade, against z-fighting and self-occlusion.
const WINDOW_OFFSET: f32 = 0.01;

/// Number of emission levels.
const LEVELS: usize = 24;

/// The emissive strength of `level`, log-spaced from 1e-2 to 1e3.
fn level_strength(level: usize) -> f32 {
    10f64.powf(-2.0 + 5.0 * level as f64 / (LEVELS - 1) as f64) as f32
}

/// Emission colours (maximum component 1) and their names.
const COLOURS: [(&str, [f32; 3]); 5] = [
    ("warm white", [1.0, 0.85, 0.65]),
    ("cool white", [0.8, 0.9, 1.0]),
    ("orange", [1.0, 0.55, 0.15]),
    ("cyan", [0.1, 0.9, 1.0]),
    ("magenta", [1.0, 0.15, 0.85]),
];
const WARM: usize = 0;
const COOL: usize = 1;
const ORANGE: usize = 2;
const CYAN: usize = 3;
const MAGENTA: usize = 4;

/// Column-major frame of the neon strips: a quarter turn about +y (which maps
/// the street grid onto itself) and a lift of 8 m.
const NEON_FRAME: [f32; 16] = [
    0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 8.0, 0.0, 1.0,
];

/// An axis-aligned building standing on the ground.
struct Building {
    min: Vec3,
    max: Vec3,
}

/// The centre coordinate of cell `i` along either axis.
fn cell_centre(i: usize) -> f32 {
    (i as f32 + 0.5) * PITCH - HALF_TOWN
}

/// The coordinate of the street line between cells `k` and `k + 1`.
fn street_line(k: usize) -> f32 {
    (k + 1) as f32 * PITCH - HALF_TOWN
}

/// One building per cell, taller towards the town centre, always leaving
/// `STREET_HALF_WIDTH` to the surrounding street lines.
fn town_buildings(rng: &mut Pcg32) -> Vec<Building> {
    let mut out = Vec::with_capacity(CELLS * CELLS);
    for i in 0..CELLS {
        for k in 0..CELLS {
            let (cx, cz) = (cell_centre(i), cell_centre(k));
            let half = Vec3::new(uniform(rng, 2.25, 3.0), 0.0, uniform(rng, 2.25, 3.0));
            let slack = Vec3::splat(PITCH * 0.5 - STREET_HALF_WIDTH) - half;
            let shift = Vec3::new(uniform(rng, -1.0, 1.0), 0.0, uniform(rng, -1.0, 1.0)) * slack;
            let centrality = 1.0 - cx.abs().max(cz.abs()) / (HALF_TOWN - PITCH * 0.5);
            let height = 6.0 + uniform(rng, 0.0, 10.0) + 30.0 * centrality * unit(rng);
            let foot = Vec3::new(cx, 0.0, cz) + shift;
            out.push(Building {
                min: foot - half,
                max: foot + half + Vec3::Y * height,
            });
        }
    }
    out
}

/// Adds the ground plane and the buildings (in two shades of grey).
fn add_town_geometry(b: &mut GltfBuilder, buildings: &[Building], rng: &mut Pcg32) {
    let asphalt = b.add_material(matte("asphalt", [0.08; 3]));
    let mut ground = QuadMesh::default();
    ground.quad(Vec3::ZERO, Vec3::Z * HALF_TOWN, Vec3::X * HALF_TOWN);
    add_object(b, "ground", &ground, asphalt, NodeTransform::Identity);
    let mut blocks = [QuadMesh::default(), QuadMesh::default()];
    for building in buildings {
        blocks[below(rng, 2)].cuboid(building.min, building.max);
    }
    for (shade, (mesh, grey)) in blocks.iter().zip([0.35, 0.5]).enumerate() {
        let name = format!("buildings {shade}");
        let concrete = b.add_material(matte(&name, [grey; 3]));
        add_object(b, &name, mesh, concrete, NodeTransform::Identity);
    }
}

/// A place for one window: its centre (already off the facade) and the
/// horizontal facade tangent `t`, chosen so that `y × t` points outward.
struct WindowSlot {
    centre: Vec3,
    tangent: Vec3,
}

/// Every window slot of every facade, storey by storey.
fn window_slots(buildings: &[Building]) -> Vec<WindowSlot> {
    let mut slots = Vec::new();
    for bld in buildings {
        let centre = (bld.min + bld.max) * 0.5;
        let half = (bld.max - bld.min) * 0.5;
        for normal in [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z] {
            let tangent = normal.cross(Vec3::Y);
            let width = 2.0 * tangent.abs().dot(half);
            let columns = ((width - 0.6) / WINDOW_PITCH).floor().max(0.0) as usize;
            let facade = centre + normal * (normal.abs().dot(half) + WINDOW_OFFSET);
            let mut y = 1.5;
            while y + 0.5 + 0.3 <= bld.max.y {
                for c in 0..columns {
                    let along = (c as f32 - (columns as f32 - 1.0) * 0.5) * WINDOW_PITCH;
                    let centre = Vec3::new(facade.x, y, facade.z) + tangent * along;
                    slots.push(WindowSlot { centre, tangent });
                }
                y += STOREY;
            }
        }
    }
    slots
}

/// Emissive quads grouped by (two-sided, colour, level); each group becomes
/// one material and one mesh.
#[derive(Default)]
struct LightGroups {
    groups: BTreeMap<(bool, usize, usize), QuadMesh>,
}

impl LightGroups {
    /// Lights up to `count` randomly chosen window slots; returns how many.
    fn add_windows(&mut self, rng: &mut Pcg32, buildings: &[Building], count: usize) -> usize {
        let mut slots = window_slots(buildings);
        let count = count.min(slots.len());
        for i in 0..count {
            let j = i + below(rng, slots.len() - i);
            slots.swap(i, j);
            let s = &slots[i];
            let colour = [WARM, COOL, ORANGE][weighted(rng, &[65, 20, 15])];
            let level = below(rng, 18);
            let u = Vec3::Y * uniform(rng, 0.25, 0.5);
            let v = s.tangent * uniform(rng, 0.15, 0.35);
            self.group(false, colour, level).quad(s.centre, u, v);
        }
        count
    }

    /// Adds `count` downward-facing lamp quads about 4 m above the streets;
    /// returns `count`.
    fn add_lamps(&mut self, rng: &mut Pcg32, count: usize) -> usize {
        for _ in 0..count {
            let street = random_street(rng);
            let side = if below(rng, 2) == 0 { -1.0 } else { 1.0 };
            let centre = street.origin
                + street.along * uniform(rng, -29.0, 29.0)
                + street.across * (side * STREET_HALF_WIDTH * 0.6)
                + Vec3::Y * uniform(rng, 3.8, 4.2);
            let half = uniform(rng, 0.15, 0.25);
            let colour = [ORANGE, COOL][below(rng, 2)];
            let level = 12 + below(rng, LEVELS - 12);
            self.group(false, colour, level)
                .quad(centre, Vec3::X * half, Vec3::Z * half);
        }
        count
    }

    /// Adds `count` two-sided quads as short neon ribbons floating above the
    /// streets, stored in the [`NEON_FRAME`] coordinate system.
    fn add_neon(&mut self, rng: &mut Pcg32, count: usize) {
        let to_local = Mat4::from_cols_array(&NEON_FRAME).inverse();
        let mut left = count;
        while left > 0 {
            let pieces = (1 + below(rng, 5)).min(left);
            left -= pieces;
            let Street {
                origin,
                along,
                across,
            } = random_street(rng);
            let mut at = origin
                + along * uniform(rng, -27.0, 22.0)
                + across * uniform(rng, -0.8, 0.8)
                + Vec3::Y * uniform(rng, 5.0, 20.0);
            let roll = uniform(rng, -0.6, 0.6);
            let up = Vec3::Y * roll.cos() + across * roll.sin();
            let colour = [CYAN, MAGENTA][below(rng, 2)];
            let level = below(rng, LEVELS);
            for _ in 0..pieces {
                let length = uniform(rng, 0.1, 0.5);
                let u = to_local.transform_vector3(up * uniform(rng, 0.1, 0.3));
                let v = to_local.transform_vector3(along * length);
                let centre = to_local.transform_point3(at + along * length);
                self.group(true, colour, level).quad(centre, u, v);
                at += along * (2.0 * length + 0.05);
            }
        }
    }

    /// The quads of one (two-sided, colour, level) group.
    fn group(&mut self, two_sided: bool, colour: usize, level: usize) -> &mut QuadMesh {
        self.groups.entry((two_sided, colour, level)).or_default()
    }

    /// Adds one material, mesh and node per group. Neon meshes are written
    /// without indices under a parent node carrying [`NEON_FRAME`].
    fn add_to(&self, b: &mut GltfBuilder) {
        let neon = b.add_node("neon", None, None, NodeTransform::Matrix(NEON_FRAME));
        for (&(two_sided, colour, level), mesh) in &self.groups {
            let (colour_name, emissive) = COLOURS[colour];
            let kind = if two_sided { "neon" } else { "lit" };
            let name = format!("{kind} {colour_name} L{level:02}");
            let material = b.add_material(GltfMaterial {
                name: name.clone(),
                base_color: [0.1; 3],
                roughness: 0.5,
                emissive,
                emissive_strength: level_strength(level),
                double_sided: two_sided,
                ..GltfMaterial::default()
            });
            let m = if two_sided {
                b.add_mesh(&name, &mesh.triangle_soup(), None, None, material)
            } else {
                b.add_mesh(&name, &mesh.positions, None, Some(&mesh.indices), material)
            };
            let node = b.add_node(&name, Some(m), None, NodeTransform::Identity);
            if two_sided {
                b.add_child(neon, node);
            }
        }
    }
}

/// A street centre line: `origin + t * along`, with `across` the horizontal
/// unit vector perpendicular to it.
struct Street {
    origin: Vec3,
    along: Vec3,
    across: Vec3,
}

/// One of the streets between the building rows, chosen at random.
fn random_street(rng: &mut Pcg32) -> Street {
    let offset = street_line(below(rng, CELLS - 1));
    let (along, across) = if below(rng, 2) == 0 {
        (Vec3::Z, Vec3::X)
    } else {
        (Vec3::X, Vec3::Z)
    };
    Street {
        origin: across * offset,
        along,
        across,
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::gltf_write::tests::round_trip;
    use super::super::tests::{radiances, world_triangles};
    use super::*;

    #[test]
    fn town_lights_are_outside_buildings_and_above_ground() {
        let (doc, blob) = round_trip(&many_lights(3, 12_000), "glb");
        let buildings = town_buildings(&mut Pcg32::seed_from_u64(3));
        let radiance = radiances(&doc);
        let tris = world_triangles(&doc, &blob);
        for t in tris.iter().filter(|t| radiance[t.material] > 0.0) {
            let c = t.centroid();
            assert!(
                c.y > 0.5 && c.x.abs() < HALF_TOWN && c.z.abs() < HALF_TOWN,
                "{c}"
            );
            for bld in &buildings {
                let inside = c.cmpgt(bld.min).all() && c.cmplt(bld.max).all();
                assert!(!inside, "{} at {c} is inside a building", t.mesh_name);
            }
        }
        let camera = doc.nodes().find(|n| n.camera().is_some()).unwrap();
        let eye = Vec3::from(camera.transform().decomposed().0);
        assert!(buildings
            .iter()
            .all(|b| !(eye.cmpgt(b.min).all() && eye.cmplt(b.max).all())));
    }
}
