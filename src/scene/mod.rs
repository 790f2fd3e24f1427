//! The scene model: plain, validated data that every later stage reads.
//!
//! Triangles are stored in world space (node transforms applied at load time), each with
//! per-vertex shading normals, texture coordinates and a material index. Emission lives in
//! the material: a triangle whose material has non-zero emitted radiance is a light.

mod camera;
mod environment;
mod gltf_camera;
mod gltf_checks;
mod gltf_extensions;
mod gltf_files;
mod gltf_load;
mod gltf_materials;
mod gltf_packed;
pub mod memory;
pub mod texture;
pub mod texture_decode;

pub use camera::{Camera, CameraRays, Projection};
pub use environment::{EnvironmentError, EnvironmentImage};
pub use gltf_load::{
    load_gltf, load_gltf_allowing, load_gltf_bytes, load_gltf_bytes_allowing, read_scene_file,
    scene_folder, CameraChoice, LoadError, LoadPolicy, MAX_TRIANGLES,
};
pub use texture::{Texture, UvTransform, Wrap};

use std::sync::Arc;

use glam::{Vec2, Vec3};

/// glTF metallic-roughness material: constant factors, and optional base-colour and emissive
/// textures (indices into [`Scene::textures`]) that multiply them, read at TEXCOORD_0.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Linear Rec.709 base colour (albedo of the diffuse lobe, F0 of metals).
    pub base_color: Vec3,
    pub metallic: f32,
    /// Perceptual roughness; the GGX α is its square.
    pub roughness: f32,
    /// KHR_materials_specular `specularFactor`: scales the dielectric specular lobe (1 by default,
    /// 0 gives a pure Lambertian surface).
    pub specular: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻²: emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    /// Emits (and is a light) from both faces; otherwise only from the counter-clockwise front.
    pub double_sided: bool,
    /// Multiplies `base_color`.
    pub base_color_texture: Option<u32>,
    /// Multiplies `emission`.
    pub emissive_texture: Option<u32>,
}

impl Default for Material {
    /// glTF's default material: white, fully metallic, fully rough, not emissive.
    fn default() -> Self {
        Material {
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            specular: 1.0,
            emission: Vec3::ZERO,
            double_sided: false,
            base_color_texture: None,
            emissive_texture: None,
        }
    }
}

impl Material {
    /// A white-ish Lambertian surface of albedo `rho` with no specular lobe.
    pub fn lambert(rho: Vec3) -> Self {
        Material {
            base_color: rho,
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            ..Material::default()
        }
    }

    /// A black one-sided emitter of radiance `radiance`.
    pub fn emitter(radiance: Vec3, double_sided: bool) -> Self {
        Material {
            base_color: Vec3::ZERO,
            metallic: 0.0,
            specular: 0.0,
            emission: radiance,
            double_sided,
            ..Material::default()
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// One world-space triangle. The geometric normal is `(p1 − p0) × (p2 − p0)` normalised: the
/// counter-clockwise front face.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle {
    pub positions: [Vec3; 3],
    /// Unit shading normals per vertex (the geometric normal where the file has none).
    pub normals: [Vec3; 3],
    pub material: u32,
}

impl Triangle {
    /// A flat triangle: shading normals equal to the geometric normal, zero uvs.
    pub fn flat(positions: [Vec3; 3], material: u32) -> Self {
        let n = geometric_normal(&positions);
        Triangle {
            positions,
            normals: [n; 3],
            material,
        }
    }

    pub fn geometric_normal(&self) -> Vec3 {
        geometric_normal(&self.positions)
    }

    pub fn area(&self) -> f32 {
        triangle_area(&self.positions)
    }
}

fn edge_cross(p: &[Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0])
}

/// Unit normal of the counter-clockwise front face (zero for a degenerate triangle).
pub fn geometric_normal(p: &[Vec3; 3]) -> Vec3 {
    edge_cross(p).normalize_or_zero()
}

/// Area computed in f64 so that tiny triangles far from the origin keep their area.
pub fn triangle_area(p: &[Vec3; 3]) -> f32 {
    let a = p[1].as_dvec3() - p[0].as_dvec3();
    let b = p[2].as_dvec3() - p[0].as_dvec3();
    (0.5 * a.cross(b).length()) as f32
}

/// What the loader skipped, so that users see it instead of silently missing geometry.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LoadStats {
    /// Triangles of zero (or non-finite) area, not added to the scene.
    pub degenerate_triangles: usize,
    /// Primitives without area (POINTS, LINES, LINE_LOOP, LINE_STRIP), not added to the scene.
    pub skipped_primitives: usize,
    /// The first few of those, as "mesh M 'name' primitive P (MODE)", for warnings.
    pub skipped_primitive_names: Vec<String>,
}

/// How many skipped primitives [`LoadStats`] names.
pub const NAMED_SKIPPED_PRIMITIVES: usize = 8;

/// The kind of a KHR_lights_punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    Point,
    /// Smooth falloff between the inner and outer cone (glTF's spot attenuation).
    Spot {
        cos_inner: f32,
        cos_outer: f32,
    },
    Directional,
}

/// Luminous efficacy K_m = 683 lm/W: the lumens per watt of 555 nm light, by which the SI defines
/// the candela. KHR_lights_punctual's photometric intensities divided by it give the radiometric
/// quantities we render with (cd → W/sr, lx → W/m²), the convention Blender's exporter follows.
pub const LUMINOUS_EFFICACY: f32 = 683.0;

/// The units a scene's [`PunctualLight::intensity`] values are in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum PunctualUnits {
    /// candela (point, spot) and lux (directional), as KHR_lights_punctual specifies; divided by
    /// [`LUMINOUS_EFFICACY`] when lights are built.
    #[default]
    Photometric,
    /// W/sr and W/m², taken as they are (files written for manylights before it read the
    /// specification's units, and scenes built in code).
    Radiometric,
}

impl PunctualUnits {
    /// The factor from one unit of `intensity` to W/sr (point, spot) or W/m² (directional).
    pub fn to_radiometric(self) -> f32 {
        match self {
            PunctualUnits::Photometric => 1.0 / LUMINOUS_EFFICACY,
            PunctualUnits::Radiometric => 1.0,
        }
    }

    /// The unit of a light's intensity, as written in reports.
    pub fn unit(self, kind: PunctualKind) -> &'static str {
        match (self, kind) {
            (PunctualUnits::Photometric, PunctualKind::Directional) => "lx",
            (PunctualUnits::Photometric, _) => "cd",
            (PunctualUnits::Radiometric, PunctualKind::Directional) => "W/m²",
            (PunctualUnits::Radiometric, _) => "W/sr",
        }
    }
}

/// A KHR_lights_punctual light in world space. `intensity` = color × intensity in the scene's
/// [`PunctualUnits`]: luminous intensity or radiant intensity for point and spot lights,
/// illuminance or irradiance for directional ones.
#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLight {
    pub kind: PunctualKind,
    pub position: Vec3,
    /// Unit direction the light travels (the node's local −Z); unused for point lights.
    pub direction: Vec3,
    pub intensity: Vec3,
}

/// A validated scene: at least one triangle, every material index in range, every position
/// finite, every triangle of positive area.
#[derive(Clone, Debug)]
pub struct Scene {
    pub triangles: Vec<Triangle>,
    /// Each triangle's texture coordinates per vertex, in the order of `triangles`, where some
    /// material has a texture; empty otherwise (24 bytes a triangle that an untextured scene
    /// does not keep).
    pub uvs: Vec<[Vec2; 3]>,
    pub materials: Vec<Material>,
    /// The camera the file chose (or None when the file has no perspective camera).
    pub camera: Option<Camera>,
    pub punctual: Vec<PunctualLight>,
    /// The units of `punctual`'s intensities (glTF files: photometric unless the user says
    /// otherwise; scenes built in code: radiometric).
    pub punctual_units: PunctualUnits,
    /// The textures materials refer to, linear RGB.
    pub textures: Vec<Texture>,
    /// The environment map lighting the scene from infinitely far away (given on the command
    /// line, not by the glTF file): its texels and rotation; `lights` builds the light from it.
    pub environment: Option<Arc<EnvironmentImage>>,
    pub stats: LoadStats,
}

impl Scene {
    /// Builds a scene from triangles without texture coordinates (see
    /// [`with_uvs`](Self::with_uvs)).
    pub fn new(
        triangles: Vec<Triangle>,
        materials: Vec<Material>,
        camera: Option<Camera>,
    ) -> Result<Scene, String> {
        Scene::with_uvs(triangles, Vec::new(), materials, camera)
    }

    /// Builds a scene from triangles and their texture coordinates (`uvs`: one entry per
    /// triangle, or none), dropping (and counting) degenerate triangles. Both are filtered in
    /// place: a second copy of a 2M-triangle scene would cost 150 MB at load time.
    pub fn with_uvs(
        mut triangles: Vec<Triangle>,
        mut uvs: Vec<[Vec2; 3]>,
        materials: Vec<Material>,
        camera: Option<Camera>,
    ) -> Result<Scene, String> {
        if !uvs.is_empty() && uvs.len() != triangles.len() {
            return Err(format!(
                "{} triangles but {} triangles' texture coordinates",
                triangles.len(),
                uvs.len()
            ));
        }
        for (i, t) in triangles.iter().enumerate() {
            if t.positions.iter().any(|p| !p.is_finite()) {
                return Err(format!("triangle {i} has a non-finite vertex position"));
            }
            if t.material as usize >= materials.len() {
                return Err(format!(
                    "triangle {i} uses material {} but there are {} materials",
                    t.material,
                    materials.len()
                ));
            }
        }
        let count = triangles.len();
        let keep: Vec<bool> = triangles
            .iter()
            .map(|t| {
                let area = t.area();
                area > 0.0 && area.is_finite() && t.geometric_normal() != Vec3::ZERO
            })
            .collect();
        let mut flags = keep.iter();
        triangles.retain(|_| *flags.next().unwrap_or(&false));
        let mut flags = keep.iter();
        uvs.retain(|_| *flags.next().unwrap_or(&false));
        let stats = LoadStats {
            degenerate_triangles: count - triangles.len(),
            ..LoadStats::default()
        };
        let kept = triangles;
        if kept.is_empty() {
            return Err("the scene has no triangles of positive area".into());
        }
        Ok(Scene {
            triangles: kept,
            uvs,
            materials,
            camera,
            punctual: Vec::new(),
            punctual_units: PunctualUnits::Radiometric,
            textures: Vec::new(),
            environment: None,
            stats,
        })
    }

    /// Adds punctual lights (rejecting non-finite or negative ones).
    pub fn with_punctual(mut self, lights: Vec<PunctualLight>) -> Result<Scene, String> {
        for (i, l) in lights.iter().enumerate() {
            let finite =
                l.position.is_finite() && l.direction.is_finite() && l.intensity.is_finite();
            if !finite || l.intensity.min_element() < 0.0 {
                return Err(format!(
                    "punctual light {i} has a non-finite or negative value"
                ));
            }
        }
        self.punctual = lights;
        Ok(self)
    }

    /// Adds the textures that materials refer to (every material's texture index must be in
    /// range, and a scene with a textured material must have texture coordinates).
    pub fn with_textures(mut self, textures: Vec<Texture>) -> Result<Scene, String> {
        for (i, m) in self.materials.iter().enumerate() {
            for t in [m.base_color_texture, m.emissive_texture]
                .into_iter()
                .flatten()
            {
                if self.uvs.len() != self.triangles.len() {
                    return Err(format!(
                        "material {i} uses texture {t} but the triangles have no texture \
                         coordinates"
                    ));
                }
                if t as usize >= textures.len() {
                    return Err(format!(
                        "material {i} uses texture {t} but there are {} textures",
                        textures.len()
                    ));
                }
            }
        }
        self.textures = textures;
        Ok(self)
    }

    /// The texture coordinates of `triangle` at barycentrics (b1, b2): uv0 + b1·(uv1 − uv0) +
    /// b2·(uv2 − uv0).
    #[inline]
    pub fn uv_at(&self, triangle: usize, b1: f32, b2: f32) -> Vec2 {
        let [t0, t1, t2] = self.uvs[triangle];
        t0 + b1 * (t1 - t0) + b2 * (t2 - t0)
    }

    /// Emitted radiance of `triangle` at barycentrics (b1, b2), whatever the direction:
    /// emission factor × the emissive texture at that point's uv.
    #[inline]
    pub fn emission_at(&self, triangle: usize, b1: f32, b2: f32) -> Vec3 {
        let m = self.material_of(triangle);
        match m.emissive_texture {
            Some(t) if m.is_emissive() => {
                m.emission * self.textures[t as usize].at(self.uv_at(triangle, b1, b2))
            }
            _ => m.emission,
        }
    }

    /// Base colour of `triangle` at barycentrics (b1, b2): factor × base-colour texture.
    #[inline]
    pub fn base_color_at(&self, triangle: usize, b1: f32, b2: f32) -> Vec3 {
        let m = self.material_of(triangle);
        match m.base_color_texture {
            Some(t) => m.base_color * self.textures[t as usize].at(self.uv_at(triangle, b1, b2)),
            None => m.base_color,
        }
    }

    /// Mean emitted radiance of `triangle` over its surface: emission factor × the emissive
    /// texture's mean over the triangle's uv footprint (see
    /// [`Texture::footprint_mean`]); the factor alone when untextured.
    pub fn mean_emission(&self, triangle: usize) -> Vec3 {
        let m = self.material_of(triangle);
        match m.emissive_texture {
            Some(t) if m.is_emissive() => {
                let uvs = self.uvs[triangle];
                m.emission * self.textures[t as usize].footprint_mean(uvs)
            }
            _ => m.emission,
        }
    }

    /// Reads the punctual lights' intensities in `units`.
    pub fn with_punctual_units(mut self, units: PunctualUnits) -> Scene {
        self.punctual_units = units;
        self
    }

    /// Lights the scene with an environment map (None: no environment).
    pub fn with_environment(mut self, environment: Option<Arc<EnvironmentImage>>) -> Scene {
        self.environment = environment;
        self
    }

    /// How many triangles emit (the lights they will make).
    pub fn emissive_triangles(&self) -> usize {
        let emits = |t: &&Triangle| self.materials[t.material as usize].is_emissive();
        self.triangles.iter().filter(emits).count()
    }

    pub fn material_of(&self, triangle: usize) -> &Material {
        &self.materials[self.triangles[triangle].material as usize]
    }

    /// Axis-aligned bounds of all vertices: (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.triangles.iter().flat_map(|t| t.positions).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(z: f32, material: u32) -> Triangle {
        Triangle::flat([Vec3::new(0.0, 0.0, z), Vec3::X, Vec3::Y], material)
    }

    /// A degenerate triangle is dropped with its texture coordinates, so every kept triangle
    /// keeps its own; a textured material needs them.
    #[test]
    fn texture_coordinates_follow_their_triangles() {
        let degenerate = Triangle::flat([Vec3::ZERO, Vec3::X, Vec3::X * 2.0], 0);
        let uv = |k: f32| [Vec2::splat(k), Vec2::splat(k + 0.25), Vec2::splat(k + 0.5)];
        let tris = vec![triangle(0.0, 0), degenerate, triangle(1.0, 0)];
        let scene = Scene::with_uvs(
            tris.clone(),
            vec![uv(0.0), uv(1.0), uv(2.0)],
            vec![Material::default()],
            None,
        )
        .unwrap();
        assert_eq!(scene.triangles, vec![tris[0].clone(), tris[2].clone()]);
        assert_eq!(scene.uvs, vec![uv(0.0), uv(2.0)]);
        assert_eq!(scene.stats.degenerate_triangles, 1);
        assert!(
            Scene::with_uvs(tris.clone(), vec![uv(0.0)], vec![Material::default()], None).is_err()
        );
        let textured = Material {
            base_color_texture: Some(0),
            ..Material::default()
        };
        let texture = Texture::new(1, 1, vec![Vec3::ONE], [Wrap::Repeat; 2]).unwrap();
        let bare = Scene::new(tris.clone(), vec![textured.clone()], None).unwrap();
        assert!(bare.uvs.is_empty());
        assert!(bare.with_textures(vec![texture.clone()]).is_err());
        let with =
            Scene::with_uvs(tris, vec![uv(0.0), uv(1.0), uv(2.0)], vec![textured], None).unwrap();
        assert!(with.with_textures(vec![texture]).is_ok());
    }
}
