//! The memory a render of a scene will need, estimated from what the glTF file declares
//! (accessor counts, emissive and textured materials) before any buffer is read, so that a scene
//! too large for the machine or for `--max-memory` is refused with the estimate instead of
//! failing to allocate half-way through a BVH build.
//!
//! The model is a peak over the phases that coexist, BASE + the largest of: the load (the file,
//! the scene's triangles and the primitive being read), the first build and the second build
//! with the film. The geometry BVH and the lights with their light BVH are built one after the
//! other, the larger build first ([`lights_before_geometry`]), the second beside what the first
//! kept; the film comes after both, beside what they kept. Against the peak RSS (`/usr/bin/time
//! -f %M`, KiB, here converted to bytes) of `render --width 64 --height 48 --spp 1 --selector
//! bvh` (the selector that needs most) on an Intel Xeon guest, three runs each, it gives 17.9 MB
//! for scenes/town.glb (14.1–14.4 measured) and 523 MB for `gen city --lights 1000000` (434–444
//! measured; 419 with `--selector power`); the sum of all parts used before gave 19.1 and 821 MB.

use std::collections::HashSet;

use gltf::mesh::Mode;

/// Resident memory of the program with a tiny scene, with a margin: `render scenes/cornell.glb
/// --spp 1 --width 64` peaked at 6.8 MB on an AMD EPYC guest and at 7,808–8,008 KiB (8.0–8.2
/// MB) on an Intel Xeon one (`/usr/bin/time -f %M`); 10 MiB keeps the shipped scenes' estimates
/// at least 2 MB above their peaks.
const BASE_BYTES: u64 = 10 << 20;
/// A scene triangle (`scene::Triangle`: positions, normals, material).
pub const BYTES_PER_TRIANGLE: u64 = 76;
/// A triangle's texture coordinates, kept for every triangle when some material is textured.
pub const UV_BYTES_PER_TRIANGLE: u64 = 24;
/// The geometry BVH's build, per triangle of the parts built at once: obvhs's PLOC buffers and
/// Morton codes, the binary BVH, reinsertion and our collapse (`src/accel/build.rs`). The largest
/// rise of the RSS over the scene during a geometry-first build (sampled from
/// `/proc/PID/status`) was 447 B a triangle, on the 195k triangles of `gen city --lights 100000`
/// (two parts at once); 432 B on the 50k city (one part), 385 B on the town (obvhs's thorough
/// preset, built whole). 500 B keeps a 10% margin over them.
pub const BYTES_PER_TRIANGLE_BUILT: u64 = 500;
/// Alive through the parts' builds for every triangle: the id list cut into parts and the parts'
/// finished trees (obvhs's 80-byte nodes and the primitive indices), from the code: 4 B of id
/// and about 13 B of parts' trees (a node per 9 triangles on the 1M city).
pub const BYTES_PER_TRIANGLE_PARTS: u64 = 17;
/// The end of the geometry build, per triangle: the kept ray accelerator (its nodes as the walk
/// reads them, 256 B a node, the primitive index and the 36-byte test triangle: 68 B on the 1M
/// city, `Accel::bytes`) with obvhs's nodes beside it until they are dropped; 153 MB (78 B a
/// triangle) measured on the 1M city built geometry first.
pub const BYTES_PER_TRIANGLE_JOINED: u64 = 80;
/// What the geometry build leaves resident per triangle: the accelerator and the freed
/// builders' small blocks the allocator keeps (from the RSS during a light build that followed
/// it: 103–116 B on the 50k and 100k cities).
pub const BYTES_PER_TRIANGLE_KEPT: u64 = 120;
/// The light build's peak per emitter, above the scene: its `Light` (72 B), the light BVH's
/// binary build tree and primitives, and the wide tree made from them; 216–264 B measured
/// (RSS of a lights-first build) on cities of 50k to 1M emitters, before the light BVH's 8 B
/// power prefix (`select/light_tree/power_prefix.rs`) was added to its wide tree.
pub const BYTES_PER_LIGHT_BUILT: u64 = 270;
/// What the light build leaves resident per emitter: the light, the light BVH (47.7 B on the 1M
/// city, 39.7 before its power prefix) and the freed build blocks the allocator keeps; 175–196 B
/// measured on the 300k and 1M cities before the prefix.
pub const BYTES_PER_LIGHT_KEPT: u64 = 200;
/// The geometry BVH is built in parts of at most this many triangles…
pub const BVH_PART_MAX_TRIANGLES: u64 = 1 << 17;
/// …this many at a time (`src/accel/build.rs`).
pub const BVH_PARTS_AT_ONCE: u64 = 2;
/// Per film pixel: the tiles' statistics (64 B) beside the film's (64 B) while they are merged
/// (`integrator/tiles.rs`), then the f32 mean and the EXR writer's copies. 160 B: `render
/// scenes/cornell.glb --spp 4` peaked 139 B a pixel above its 64×48 render at --width 1280,
/// 155 B at --width 320 (the 88 B counted before left 1280 × 1280 81 MB short).
pub const BYTES_PER_PIXEL: u64 = 160;

/// Emitters from which the lights are built first. Chosen when the light BVH's build was counted
/// at 262 B a light and the geometry's parts at 224 B a triangle: 2·2^17·224 B = 58.7 MB, the
/// most the geometry build's parts could hold, is reached at 224,124 lights.
const LIGHTS_FIRST_MIN_EMITTERS: u64 = 224_124;

/// Whether a scene's lights and light selector should be built before its geometry BVH: the
/// larger build then runs while the other's finished structure does not exist yet. Maximum
/// resident set (`/usr/bin/time -v`, render 320×240, 1 spp, bvh + mis) of the 1M-emitter city:
/// 512,988 kB geometry first, 440,632 kB lights first. Smaller scenes keep geometry first:
/// lights first raised the town's (12k emitters, built by obvhs's thorough preset; 64×48) from
/// 13,220 to 14,604 kB and the 50k city's from 40,116 to 47,664 kB.
pub fn lights_before_geometry(emitters: u64) -> bool {
    emitters >= LIGHTS_FIRST_MIN_EMITTERS
}

/// What the budget check needs besides the file: the budget and the film's size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    /// Largest estimate allowed, in bytes.
    pub max_bytes: u64,
    /// Pixels of the film the scene will be rendered into.
    pub film_pixels: u64,
}

/// What a scene's JSON declares, from [`declared_sizes`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeclaredSizes {
    pub triangles: u64,
    pub emitters: u64,
    /// Whether some primitive's material has a texture (texture coordinates are then kept).
    pub textured: bool,
    /// The largest primitive's attributes and indices as the loader copies them out of the
    /// buffers (12 B a position or normal, 8 B a texture coordinate, 4 B an index, and the
    /// triangle list a strip or fan is rewritten into).
    pub largest_primitive_bytes: u64,
}

/// An estimate of peak memory, by phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    pub file_bytes: u64,
    pub pixels: u64,
    pub sizes: DeclaredSizes,
}

/// The phases of a render whose peaks the estimate compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    Load,
    GeometryBuild,
    LightBuild,
}

impl Phase {
    fn name(self) -> &'static str {
        match self {
            Phase::Load => "loading",
            Phase::GeometryBuild => "the geometry BVH's build",
            Phase::LightBuild => "the light BVH's build",
        }
    }
}

impl MemoryEstimate {
    /// The scene's triangles and texture coordinates, alive from the load on.
    pub fn scene(&self) -> u64 {
        let uv = if self.sizes.textured {
            UV_BYTES_PER_TRIANGLE
        } else {
            0
        };
        self.sizes.triangles.saturating_mul(BYTES_PER_TRIANGLE + uv)
    }

    /// The geometry BVH build's peak: the parts' builders beside the id list and the finished
    /// parts, or the joined tree at the end, whichever is larger.
    pub fn geometry_build(&self) -> u64 {
        let t = self.sizes.triangles;
        let at_once = t.min(BVH_PARTS_AT_ONCE * BVH_PART_MAX_TRIANGLES);
        let parts = t
            .saturating_mul(BYTES_PER_TRIANGLE_PARTS)
            .saturating_add(at_once * BYTES_PER_TRIANGLE_BUILT);
        parts.max(t.saturating_mul(BYTES_PER_TRIANGLE_JOINED))
    }

    /// The peak of each phase above the program's base, in the order they run. The film is
    /// allocated once both builds are done, beside what they kept, which is no more than the
    /// second build's peak: it is counted with that build.
    pub fn phases(&self) -> [(Phase, u64); 3] {
        let s = &self.sizes;
        let scene = self.scene();
        let load = [self.file_bytes, scene, s.largest_primitive_bytes];
        let geometry = self.geometry_build();
        let lights = s.emitters.saturating_mul(BYTES_PER_LIGHT_BUILT);
        let (first, second) = if lights_before_geometry(s.emitters) {
            let kept = s.emitters.saturating_mul(BYTES_PER_LIGHT_KEPT);
            (
                (Phase::LightBuild, lights),
                (Phase::GeometryBuild, kept.saturating_add(geometry)),
            )
        } else {
            let kept = s.triangles.saturating_mul(BYTES_PER_TRIANGLE_KEPT);
            (
                (Phase::GeometryBuild, geometry),
                (Phase::LightBuild, kept.saturating_add(lights)),
            )
        };
        let film = self.pixels.saturating_mul(BYTES_PER_PIXEL);
        let sum = |parts: &[u64]| parts.iter().copied().fold(0, u64::saturating_add);
        [
            (Phase::Load, sum(&load)),
            (first.0, sum(&[scene, first.1])),
            (second.0, sum(&[scene, second.1, film])),
        ]
    }

    /// The phase with the largest peak, and that peak with the program's base.
    pub fn peak(&self) -> (Phase, u64) {
        let (phase, bytes) = self
            .phases()
            .into_iter()
            .max_by_key(|&(_, bytes)| bytes)
            .expect("three phases");
        (phase, bytes.saturating_add(BASE_BYTES))
    }

    pub fn total(&self) -> u64 {
        self.peak().1
    }

    /// "an estimated 523 MB, at the geometry BVH's build (program 10.5 MB; scene 148 MB for
    /// 1949154 triangles at 76 B; ...; other phases: loading 299 MB, ...)": the peak phase's
    /// parts, then the other phases' totals.
    pub fn describe(&self) -> String {
        let s = &self.sizes;
        let (phase, total) = self.peak();
        let scene = format!(
            "scene {} for {} triangles at {} B",
            human(self.scene()),
            s.triangles,
            self.scene() / s.triangles.max(1)
        );
        let lights_first = lights_before_geometry(s.emitters);
        let geometry = format!(
            "geometry BVH build {} for {} triangles",
            human(self.geometry_build()),
            s.triangles
        );
        let kept_lights = format!(
            "lights kept {} for {} emitters at {BYTES_PER_LIGHT_KEPT} B",
            human(s.emitters.saturating_mul(BYTES_PER_LIGHT_KEPT)),
            s.emitters
        );
        let lights = format!(
            "light BVH build {} for {} emitters at {BYTES_PER_LIGHT_BUILT} B",
            human(s.emitters.saturating_mul(BYTES_PER_LIGHT_BUILT)),
            s.emitters
        );
        let kept_geometry = format!(
            "geometry BVH kept {} at {BYTES_PER_TRIANGLE_KEPT} B",
            human(s.triangles.saturating_mul(BYTES_PER_TRIANGLE_KEPT))
        );
        let film = format!(
            "film {} for {} pixels at {BYTES_PER_PIXEL} B",
            human(self.pixels.saturating_mul(BYTES_PER_PIXEL)),
            self.pixels
        );
        let mut parts = vec![format!("program {}", human(BASE_BYTES)), scene];
        match (phase, lights_first) {
            (Phase::Load, _) => parts.extend([
                format!("file {}", human(self.file_bytes)),
                format!("largest primitive {}", human(s.largest_primitive_bytes)),
            ]),
            (Phase::GeometryBuild, false) => parts.push(geometry),
            (Phase::LightBuild, true) => parts.push(lights),
            (Phase::GeometryBuild, true) => parts.extend([kept_lights, geometry, film]),
            (Phase::LightBuild, false) => parts.extend([kept_geometry, lights, film]),
        }
        let others: Vec<String> = self
            .phases()
            .into_iter()
            .filter(|&(p, _)| p != phase)
            .map(|(p, bytes)| format!("{} {}", p.name(), human(bytes.saturating_add(BASE_BYTES))))
            .collect();
        format!(
            "an estimated {}, at {} ({}; other phases: {})",
            human(total),
            phase.name(),
            parts.join("; "),
            others.join(", ")
        )
    }
}

/// Bytes in decimal units with three significant figures: "732 MB", "4.75 GB".
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "kB", "MB", "GB", "TB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1000.0 && unit + 1 < UNITS.len() {
        value /= 1000.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else if value >= 100.0 {
        format!("{value:.0} {}", UNITS[unit])
    } else if value >= 10.0 {
        format!("{value:.1} {}", UNITS[unit])
    } else {
        format!("{value:.2} {}", UNITS[unit])
    }
}

/// Parses a size such as `512M`, `8G`, `1.5GiB` or `1000000` (bytes): decimal units k, M, G, T
/// (powers of 1000, optionally followed by B) and binary Ki, Mi, Gi, Ti (powers of 1024).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let trimmed = text.trim();
    let split = trimmed
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(trimmed.len());
    let (number, unit) = trimmed.split_at(split);
    let unit = unit.trim();
    let unit = unit.strip_suffix('B').unwrap_or(unit);
    let scale: f64 = match unit {
        "" => 1.0,
        "k" | "K" => 1e3,
        "M" => 1e6,
        "G" => 1e9,
        "T" => 1e12,
        "Ki" => 1024.0,
        "Mi" => 1024f64.powi(2),
        "Gi" => 1024f64.powi(3),
        "Ti" => 1024f64.powi(4),
        _ => {
            return Err(format!(
                "'{text}': unknown unit (use k, M, G, T or Ki, Mi, Gi, Ti)"
            ))
        }
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("'{text}': not a size (e.g. 512M, 8G, 1.5GiB)"))?;
    let bytes = value * scale;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}': the size must be at least 1 byte"));
    }
    Ok(bytes as u64)
}

/// The memory the system reports available (`MemAvailable` in /proc/meminfo), if it can be read.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kilobytes: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kilobytes.checked_mul(1024)
}

/// Triangles and emissive triangles the scene's node instances declare, from the JSON alone:
/// Σ over nodes of their mesh's triangle, strip and fan primitives' triangles from their index
/// (or vertex) counts; a primitive counts as emissive when its material has a non-zero
/// emissive factor or an emissive texture, as textured when its material has a base colour or
/// emissive texture. A node reached twice is counted once (the traversal refuses it later).
pub fn declared_sizes(scene: &gltf::Scene) -> DeclaredSizes {
    let mut seen = HashSet::new();
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    let mut sizes = DeclaredSizes::default();
    while let Some(node) = stack.pop() {
        if !seen.insert(node.index()) {
            continue;
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let vertices = prim
                    .get(&gltf::Semantic::Positions)
                    .map_or(0, |a| a.count());
                let indices = prim.indices().map_or(vertices, |acc| acc.count());
                let count = triangle_count(prim.mode(), indices) as u64;
                sizes.triangles = sizes.triangles.saturating_add(count);
                let material = prim.material();
                let emits = material.emissive_factor().iter().any(|&c| c != 0.0)
                    || material.emissive_texture().is_some();
                if emits {
                    sizes.emitters = sizes.emitters.saturating_add(count);
                }
                sizes.textured |= material
                    .pbr_metallic_roughness()
                    .base_color_texture()
                    .is_some()
                    || material.emissive_texture().is_some();
                if count > 0 {
                    let read = primitive_bytes(&prim, vertices as u64, indices as u64, count);
                    sizes.largest_primitive_bytes = sizes.largest_primitive_bytes.max(read);
                }
            }
        }
        stack.extend(node.children());
    }
    sizes
}

/// What the loader copies out of the buffers for a primitive of `vertices` vertices, `indices`
/// indices (its vertex count when it has none) and `triangles` triangles: positions and normals
/// as 12-byte vectors, texture coordinates as 8-byte ones, indices as u32, and for a strip or a
/// fan the triangle list it is rewritten into beside them.
fn primitive_bytes(prim: &gltf::Primitive, vertices: u64, indices: u64, triangles: u64) -> u64 {
    let has = |semantic| u64::from(prim.get(&semantic).is_some());
    let per_vertex = 12 + 12 * has(gltf::Semantic::Normals) + 8 * has(gltf::Semantic::TexCoords(0));
    let list = match prim.mode() {
        Mode::Triangles => 0,
        _ => 12 * triangles,
    };
    [
        vertices.saturating_mul(per_vertex),
        indices.saturating_mul(4),
        list,
    ]
    .into_iter()
    .fold(0, u64::saturating_add)
}

/// Triangles a primitive of `mode` with `count` indices (or vertices) makes: count/3 for
/// TRIANGLES, count − 2 for strips and fans, 0 for modes without area.
pub(super) fn triangle_count(mode: Mode, count: usize) -> usize {
    match mode {
        Mode::Triangles => count / 3,
        Mode::TriangleStrip | Mode::TriangleFan => count.saturating_sub(2),
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_decimal_and_binary_units() {
        let cases = [
            ("1000000", 1_000_000),
            ("512M", 512_000_000),
            ("512MB", 512_000_000),
            ("8G", 8_000_000_000),
            ("1.5GiB", 1_610_612_736),
            ("64Ki", 65_536),
            (" 2 T ", 2_000_000_000_000),
        ];
        for (text, bytes) in cases {
            assert_eq!(parse_size(text), Ok(bytes), "{text}");
        }
        for bad in ["", "12Q", "G", "-1M", "0", "0.1", "1e3", "nanG"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn bytes_print_with_three_significant_figures() {
        let cases = [
            (0, "0 B"),
            (999, "999 B"),
            (1_000, "1.00 kB"),
            (12_345, "12.3 kB"),
            (849_946_000, "850 MB"),
            (4_750_000_000, "4.75 GB"),
        ];
        for (bytes, text) in cases {
            assert_eq!(human(bytes), text);
        }
    }

    #[test]
    fn lights_come_first_only_when_their_build_outgrows_the_geometrys_largest() {
        // As chosen: the geometry build's parts at most 2·131072 triangles at 224 B =
        // 58,720,256 B, which 262 B a light exceed from 224,123.1 lights on.
        assert!(!lights_before_geometry(0));
        assert!(!lights_before_geometry(224_123));
        assert!(lights_before_geometry(224_124));
        assert!(lights_before_geometry(u64::MAX));
    }

    #[test]
    fn per_item_sizes_are_those_of_the_types() {
        use std::mem::size_of;
        assert_eq!(
            size_of::<crate::scene::Triangle>() as u64,
            BYTES_PER_TRIANGLE
        );
        assert_eq!(size_of::<[glam::Vec2; 3]>() as u64, UV_BYTES_PER_TRIANGLE);
        // The sizes the figures' comments give for a light and a pixel's statistics.
        assert_eq!(size_of::<crate::lights::Light>(), 72);
        assert_eq!(size_of::<crate::film::PixelStats>(), 64);
    }

    /// The 1M-light city as `gen city --lights 1000000` writes it, rendered at 64×48.
    fn city() -> MemoryEstimate {
        MemoryEstimate {
            file_bytes: 86_748_568,
            pixels: 64 * 48,
            sizes: DeclaredSizes {
                triangles: 1_949_154,
                emitters: 1_000_000,
                textured: false,
                largest_primitive_bytes: 1_800_000 * 24 + 2_700_000 * 4,
            },
        }
    }

    #[test]
    fn lights_first_the_peak_is_the_geometry_build_beside_the_kept_lights() {
        let e = city();
        let scene = 1_949_154 * 76;
        // The parts (17 B a triangle and 500 B for each of the 2^18 triangles built at once)
        // outweigh the joined tree (80 B a triangle).
        assert_eq!(e.geometry_build(), 1_949_154 * 17 + (1 << 18) * 500);
        let load = 86_748_568 + scene + 54_000_000;
        let lights = scene + 1_000_000 * 270;
        let geometry = scene + 1_000_000 * 200 + 1_949_154 * 17 + (1 << 18) * 500 + 3072 * 160;
        assert_eq!(
            e.phases(),
            [
                (Phase::Load, load),
                (Phase::LightBuild, lights),
                (Phase::GeometryBuild, geometry),
            ]
        );
        assert_eq!(e.peak(), (Phase::GeometryBuild, (10 << 20) + geometry));
        assert_eq!(e.total(), 523_320_602);
        assert_eq!(
            e.describe(),
            "an estimated 523 MB, at the geometry BVH's build (program 10.5 MB; scene 148 MB for \
             1949154 triangles at 76 B; lights kept 200 MB for 1000000 emitters at 200 B; \
             geometry BVH build 164 MB for 1949154 triangles; film 492 kB for 3072 pixels at \
             160 B; other phases: loading 299 MB, the light BVH's build 429 MB)"
        );
    }

    #[test]
    fn geometry_first_the_peak_is_the_larger_of_the_two_builds() {
        // 200k textured triangles, 10 lights: the parts' builders (2^18 at once, capped by
        // the triangles) outweigh the joined tree and the light build after it.
        let e = MemoryEstimate {
            file_bytes: 50,
            pixels: 100,
            sizes: DeclaredSizes {
                triangles: 200_000,
                emitters: 10,
                textured: true,
                largest_primitive_bytes: 7,
            },
        };
        let scene = 200_000 * (76 + 24);
        let geometry = scene + 200_000 * (17 + 500);
        let lights = scene + 200_000 * 120 + 10 * 270 + 100 * 160;
        assert_eq!(
            e.phases(),
            [
                (Phase::Load, 50 + scene + 7),
                (Phase::GeometryBuild, geometry),
                (Phase::LightBuild, lights),
            ]
        );
        assert_eq!(e.peak(), (Phase::GeometryBuild, (10 << 20) + geometry));
        // A film of 10^6 pixels makes the light build (and the render after it) the peak.
        let wide = MemoryEstimate {
            pixels: 1_000_000,
            ..e
        };
        let with_film = lights - 100 * 160 + 1_000_000 * 160;
        assert_eq!(wide.peak(), (Phase::LightBuild, (10 << 20) + with_film));
        assert!(wide.describe().starts_with(
            "an estimated 214 MB, at the light BVH's build (program 10.5 MB; scene 20.0 MB for \
             200000 triangles at 100 B; geometry BVH kept 24.0 MB at 120 B;"
        ));
        let huge = MemoryEstimate {
            sizes: DeclaredSizes {
                triangles: u64::MAX,
                ..e.sizes
            },
            ..e
        };
        assert_eq!(huge.total(), u64::MAX);
    }

    #[test]
    fn declared_sizes_count_instances_emitters_textures_and_the_largest_primitive() {
        // Mesh 0: a strip of 6 vertices (4 triangles) with normals, emissive, instanced twice;
        // mesh 1: 9 indexed triangles (27 indices) over 12 vertices with texture coordinates.
        let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2]}],
            "nodes":[{"mesh":0},{"mesh":0},{"mesh":1}],
            "materials":[{"emissiveFactor":[1,1,1]},
                {"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
            "textures":[{"source":0}],"images":[{"uri":"a.png"}],
            "buffers":[{"byteLength":1024}],
            "bufferViews":[{"buffer":0,"byteLength":1024}],
            "accessors":[
                {"bufferView":0,"componentType":5126,"count":6,"type":"VEC3","min":[0,0,0],
                    "max":[1,1,1]},
                {"bufferView":0,"componentType":5126,"count":12,"type":"VEC3","min":[0,0,0],
                    "max":[1,1,1]},
                {"bufferView":0,"componentType":5126,"count":12,"type":"VEC2"},
                {"bufferView":0,"componentType":5123,"count":27,"type":"SCALAR"}],
            "meshes":[
                {"primitives":[{"attributes":{"POSITION":0,"NORMAL":0},"mode":5,"material":0}]},
                {"primitives":[{"attributes":{"POSITION":1,"TEXCOORD_0":2},"indices":3,
                    "material":1}]}]}"#;
        let gltf = gltf::Gltf::from_slice(json.as_bytes()).unwrap();
        let sizes = declared_sizes(&gltf.default_scene().unwrap());
        let strip = 6 * (12 + 12) + 6 * 4 + 4 * 12;
        let indexed = 12 * (12 + 8) + 27 * 4;
        assert_eq!(
            sizes,
            DeclaredSizes {
                triangles: 4 + 4 + 9,
                emitters: 8,
                textured: true,
                largest_primitive_bytes: strip.max(indexed),
            }
        );
    }
}
