//! glTF extensions: which ones a file may require (any other is refused with what it would
//! change), and KHR_lights_punctual lights placed by their nodes.

use glam::{Mat4, Vec3};

use super::{PunctualKind, PunctualLight};

/// The extensions this loader implements; a file may require these and no others.
const SUPPORTED_EXTENSIONS: [&str; 4] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_texture_transform",
];

/// What a required extension we do not implement would change, for the refusal message.
fn extension_effect(name: &str) -> &'static str {
    match name {
        "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
            "the geometry is stored compressed and cannot be read without it"
        }
        "KHR_mesh_quantization" => "vertex attributes are stored as integers it would rescale",
        "KHR_texture_basisu" | "EXT_texture_webp" | "EXT_texture_avif" => {
            "textures are in an image format we do not decode (we read PNG and JPEG)"
        }
        "KHR_materials_pbrSpecularGlossiness" => "materials use the specular-glossiness model",
        "KHR_materials_unlit" => "materials would be shown unlit (their colour as emission)",
        "KHR_materials_transmission" | "KHR_materials_volume" | "KHR_materials_ior" => {
            "materials would transmit or refract light"
        }
        "KHR_materials_clearcoat"
        | "KHR_materials_sheen"
        | "KHR_materials_iridescence"
        | "KHR_materials_anisotropy" => "materials would gain another reflection lobe",
        "EXT_mesh_gpu_instancing" => "meshes would be instanced by per-instance transforms",
        "KHR_materials_variants" => "materials would be chosen among variants",
        _ => "an extension we do not know, so its effect on the scene is unknown",
    }
}

/// A file that lists in `extensionsRequired` an extension we do not implement is refused,
/// naming it and what it would change (the `gltf` crate would only say "Unsupported extension").
pub(super) fn check_required_extensions(root: &gltf::json::Root) -> Result<(), String> {
    for name in &root.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&name.as_str()) {
            return Err(format!(
                "requires the extension {name}, which manylights does not implement \
                 ({}); supported: {}",
                extension_effect(name),
                SUPPORTED_EXTENSIONS.join(", ")
            ));
        }
    }
    Ok(())
}

/// A KHR_lights_punctual light placed by its node: at the node's origin, pointing down its −Z.
/// Its intensity stays in the file's photometric units (cd, lx), converted when lights are built;
/// `range` is ignored (physical inverse-square falloff everywhere).
pub(super) fn convert_light(
    light: &gltf::khr_lights_punctual::Light,
    world: &Mat4,
) -> PunctualLight {
    use gltf::khr_lights_punctual::Kind;
    let kind = match light.kind() {
        Kind::Point => PunctualKind::Point,
        Kind::Directional => PunctualKind::Directional,
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let outer = outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2);
            let inner = inner_cone_angle.clamp(0.0, outer);
            PunctualKind::Spot {
                cos_inner: inner.cos(),
                cos_outer: outer.cos(),
            }
        }
    };
    PunctualLight {
        kind,
        position: world.transform_point3(Vec3::ZERO),
        direction: world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z),
        intensity: Vec3::from(light.color()) * light.intensity(),
    }
}
