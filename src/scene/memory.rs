//! The memory a render of a scene will need, estimated from what the glTF file declares
//! (accessor counts, emissive materials) before any buffer is read, so that a scene too large
//! for the machine or for `--max-memory` is refused with the estimate instead of failing to
//! allocate half-way through the BVH build.
//!
//! The model is peak resident memory ≈ BASE + file + T·B_tri + B_build·min(T, 2·2^17) +
//! E·(B_light + B_select) + P·B_px for T triangles, E emissive triangles and P film pixels.
//! B_tri is what a triangle holds after the build (scene triangle and ray accelerator); the
//! geometry BVH is built in parts of at most 2^17 triangles, two at a time
//! (`src/accel/build.rs`), whose builders hold B_build per triangle; B_select is the light BVH's
//! build peak per light. The terms are summed although the file, the two builds and the film are
//! not alive at once (the two builds run one after the other, the larger first: see
//! [`lights_before_geometry`]), so the estimate errs high: against the peak RSS
//! (`/usr/bin/time -f %M`) of `render --width 64 --height 48 --spp 1 --selector bvh` (the
//! selector that needs most) it gives 19.2 MB for scenes/town.glb (14.0–14.5 measured on an
//! Intel Xeon guest; 12.6 on an AMD EPYC one) and 821 MB for `gen city --lights 1000000`
//! (434–443 there; 419 with `--selector power`); an untextured scene does not keep the 24 B a
//! triangle of texture coordinates that the estimate counts.

use std::collections::HashSet;

use gltf::mesh::Mode;

/// Resident memory of the program with a tiny scene, with a margin: `render scenes/cornell.glb
/// --spp 1 --width 64` peaked at 6.8 MB on an AMD EPYC guest and at 7,808–8,008 KiB (8.0–8.2
/// MB) on an Intel Xeon one (`/usr/bin/time -f %M`), where 7 MiB left the estimate below the
/// peak of six of the nine scenes in `scenes/` (by 0.2–0.7 MB).
const BASE_BYTES: u64 = 9 << 20;
/// Scene triangle (76 B) and its texture coordinates (24 B, kept only where a material has a
/// texture but counted here always) + the geometry BVH's nodes as the walk reads them (child
/// boxes as f32 planes with obvhs's indices, 256 B a node), primitive index and 36-byte test
/// triangle (68 B on the 1M city, `Accel::bytes`), per triangle.
pub const BYTES_PER_TRIANGLE: u64 = 170;
/// One `Light` (72 B) per emissive triangle.
pub const BYTES_PER_LIGHT: u64 = 72;
/// The geometry BVH's builder per triangle of the parts being built: PLOC's node buffers and
/// Morton codes, the binary BVH, the conversion's decision table (~210 B measured: the RSS a
/// whole-scene obvhs build added on the 1M city, 7360741, sampled from `/proc/PID/status`; our
/// collapse, `accel/collapse.rs`, keeps 39 B per binary node where obvhs's conversion kept 56,
/// so this now errs high).
pub const BYTES_PER_TRIANGLE_BUILT: u64 = 224;
/// The geometry BVH is built in parts of at most this many triangles (a part's builder then
/// holds at most ~28 MB)…
pub const BVH_PART_MAX_TRIANGLES: u64 = 1 << 17;
/// …this many at a time (`src/accel/build.rs`).
pub const BVH_PARTS_AT_ONCE: u64 = 2;
/// Film statistics (64 B) and the f32 mean and variance written out (24 B), per pixel.
pub const BYTES_PER_PIXEL: u64 = 88;

/// The light selector's bytes per emitter, for the largest one: the light BVH's build peak (its
/// 8-wide nodes, 132 B per light on the 1M city, with the binary build tree beside them), fitted
/// on the town; the alias table needs 16 B.
pub const SELECTOR_BYTES_PER_LIGHT: u64 = 262;

/// Whether a scene's lights and light selector should be built before its geometry BVH: when the
/// light BVH's build (E·SELECTOR_BYTES_PER_LIGHT) needs more than the geometry BVH's build can
/// at most (its parts built at once, 2·2^17·BYTES_PER_TRIANGLE_BUILT = 58.7 MB), i.e. above
/// ~224k emitters. The larger build then runs while the other's finished structure does not
/// exist yet. Maximum resident set (`/usr/bin/time -v`, render 320×240, 1 spp, bvh + mis) of the
/// 1M-emitter city: 512,988 kB geometry first, 440,632 kB lights first. Smaller scenes keep
/// geometry first: lights first raised the town's (12k emitters, built by obvhs's thorough
/// preset; 64×48) from 13,220 to 14,604 kB and the 50k city's from 40,116 to 47,664 kB.
pub fn lights_before_geometry(emitters: u64) -> bool {
    let geometry_build = BVH_PARTS_AT_ONCE * BVH_PART_MAX_TRIANGLES * BYTES_PER_TRIANGLE_BUILT;
    emitters.saturating_mul(SELECTOR_BYTES_PER_LIGHT) > geometry_build
}

/// What the budget check needs besides the file: the budget and the film's size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    /// Largest estimate allowed, in bytes.
    pub max_bytes: u64,
    /// Pixels of the film the scene will be rendered into.
    pub film_pixels: u64,
}

/// An estimate of peak memory, by part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    pub file_bytes: u64,
    pub triangles: u64,
    pub emitters: u64,
    pub pixels: u64,
}

impl MemoryEstimate {
    pub fn geometry(&self) -> u64 {
        self.triangles.saturating_mul(BYTES_PER_TRIANGLE)
    }

    /// The geometry BVH builders' temporaries, for the parts built at once.
    pub fn bvh_build(&self) -> u64 {
        let at_once = BVH_PARTS_AT_ONCE * BVH_PART_MAX_TRIANGLES;
        self.triangles.min(at_once) * BYTES_PER_TRIANGLE_BUILT
    }

    pub fn lights(&self) -> u64 {
        let per_light = BYTES_PER_LIGHT + SELECTOR_BYTES_PER_LIGHT;
        self.emitters.saturating_mul(per_light)
    }

    pub fn film(&self) -> u64 {
        self.pixels.saturating_mul(BYTES_PER_PIXEL)
    }

    pub fn total(&self) -> u64 {
        [
            self.file_bytes,
            self.geometry(),
            self.bvh_build(),
            self.lights(),
            self.film(),
        ]
        .into_iter()
        .fold(BASE_BYTES, u64::saturating_add)
    }

    /// "an estimated 850 MB, mostly geometry and BVH (552 MB for 1949154 triangles at 283 B;
    /// lights ...; file ...; film ...; program ...)", the parts largest first.
    pub fn describe(&self) -> String {
        let mut parts = [
            (
                self.geometry(),
                "geometry and BVH",
                format!("for {} triangles at {BYTES_PER_TRIANGLE} B", self.triangles),
            ),
            (
                self.bvh_build(),
                "BVH build",
                format!(
                    "for {} triangles at once at {BYTES_PER_TRIANGLE_BUILT} B",
                    self.triangles
                        .min(BVH_PARTS_AT_ONCE * BVH_PART_MAX_TRIANGLES)
                ),
            ),
            (
                self.lights(),
                "lights",
                format!(
                    "for {} emitters at {} B",
                    self.emitters,
                    BYTES_PER_LIGHT + SELECTOR_BYTES_PER_LIGHT
                ),
            ),
            (
                self.film(),
                "film",
                format!("for {} pixels at {BYTES_PER_PIXEL} B", self.pixels),
            ),
            (self.file_bytes, "file", String::new()),
            (BASE_BYTES, "program", String::new()),
        ];
        parts.sort_by_key(|(bytes, _, _)| std::cmp::Reverse(*bytes));
        let listed: Vec<String> = parts
            .iter()
            .map(|(bytes, name, detail)| {
                format!("{name} {} {detail}", human(*bytes))
                    .trim_end()
                    .to_string()
            })
            .collect();
        format!(
            "an estimated {}, mostly {} ({})",
            human(self.total()),
            parts[0].1,
            listed.join("; ")
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
/// emissive factor or an emissive texture. A node reached twice is counted once (the traversal
/// refuses it later).
pub fn declared_sizes(scene: &gltf::Scene) -> (u64, u64) {
    let mut seen = HashSet::new();
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    let (mut triangles, mut emitters) = (0u64, 0u64);
    while let Some(node) = stack.pop() {
        if !seen.insert(node.index()) {
            continue;
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let count = match prim.indices() {
                    Some(acc) => acc.count(),
                    None => prim
                        .get(&gltf::Semantic::Positions)
                        .map_or(0, |a| a.count()),
                };
                let count = triangle_count(prim.mode(), count) as u64;
                triangles = triangles.saturating_add(count);
                let material = prim.material();
                let emits = material.emissive_factor().iter().any(|&c| c != 0.0)
                    || material.emissive_texture().is_some();
                if emits {
                    emitters = emitters.saturating_add(count);
                }
            }
        }
        stack.extend(node.children());
    }
    (triangles, emitters)
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
        // The geometry build's most: 2·131072 triangles at 224 B = 58,720,256 B; at 262 B per
        // light that is 224,123.1 lights.
        assert!(!lights_before_geometry(0));
        assert!(!lights_before_geometry(224_123));
        assert!(lights_before_geometry(224_124));
        assert!(lights_before_geometry(u64::MAX));
    }

    #[test]
    fn the_estimate_sums_its_parts_and_names_the_largest() {
        let e = MemoryEstimate {
            file_bytes: 50,
            triangles: 1_000_000,
            emitters: 10,
            pixels: 100,
        };
        let parts =
            9 * 1024 * 1024 + 50 + 1_000_000 * 170 + (1 << 18) * 224 + 10 * (72 + 262) + 100 * 88;
        assert_eq!(e.total(), parts);
        assert_eq!(
            e.describe(),
            "an estimated 238 MB, mostly geometry and BVH (geometry and BVH 170 MB for 1000000 \
             triangles at 170 B; BVH build 58.7 MB for 262144 triangles at once at 224 B; \
             program 9.44 MB; film 8.80 kB for 100 pixels at 88 B; lights 3.34 kB for 10 \
             emitters at 334 B; file 50 B)"
        );
        let huge = MemoryEstimate {
            triangles: u64::MAX,
            ..e
        };
        assert_eq!(huge.total(), u64::MAX);
    }
}
