//! glTF materials and their textures, as scene materials: converted on first use, each
//! texture (with its uv transform) decoded once.

use glam::{Vec2, Vec3};

use super::gltf_files::read_uri;
use super::gltf_load::{quoted, Loader, Located};
use super::texture_decode::decode_image;
use super::{Material, Texture, UvTransform, Wrap};

impl Loader<'_> {
    pub(super) fn material_index(&mut self, material: &gltf::Material) -> Result<u32, Located> {
        let slot = material.index().unwrap_or(self.material_map.len() - 1);
        if let Some(i) = self.material_map[slot] {
            return Ok(i);
        }
        let mut m = convert_material(material);
        let element = |what: &str| match material.index() {
            Some(i) => format!("material {i}{} {what}", quoted(material.name())),
            None => format!("default material {what}"),
        };
        let base = material.pbr_metallic_roughness().base_color_texture();
        m.base_color_texture = self.texture_index(base, || element("baseColorTexture"))?;
        if m.is_emissive() {
            let emissive = material.emissive_texture();
            m.emissive_texture = self.texture_index(emissive, || element("emissiveTexture"))?;
        }
        let i = self.materials.len() as u32;
        self.materials.push(m);
        self.material_map[slot] = Some(i);
        Ok(i)
    }

    /// The scene texture for a material's texture reference, decoded on first use.
    pub(super) fn texture_index(
        &mut self,
        info: Option<gltf::texture::Info>,
        element: impl Fn() -> String,
    ) -> Result<Option<u32>, Located> {
        let Some(info) = info else {
            return Ok(None);
        };
        let transform = info.texture_transform().map(|t| {
            UvTransform::from_offset_rotation_scale(
                Vec2::from(t.offset()),
                t.rotation(),
                Vec2::from(t.scale()),
            )
        });
        if transform.is_some_and(|t| !t.is_finite()) {
            return Err((
                element(),
                "KHR_texture_transform gives a non-finite offset, rotation or scale".into(),
            ));
        }
        // KHR_texture_transform's texCoord overrides the reference's.
        let set = info
            .texture_transform()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        if set != 0 {
            return Err((
                element(),
                format!("reads TEXCOORD_{set}; only TEXCOORD_0 is supported"),
            ));
        }
        let texture = info.texture();
        let key = (
            texture.index(),
            transform.map(|t| {
                [t.x_axis, t.y_axis, t.offset]
                    .map(|v| v.to_array().map(f32::to_bits))
                    .concat()
                    .try_into()
                    .expect("six numbers")
            }),
        );
        if let Some(&i) = self.texture_map.get(&key) {
            return Ok(Some(i));
        }
        let image = texture.source();
        let mut image_element = format!(
            "image {}{} (texture {})",
            image.index(),
            quoted(image.name()),
            texture.index()
        );
        let bytes = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let data = self.buffers.get(view.buffer().index());
                let range = view.offset()..view.offset().saturating_add(view.length());
                let bytes = data.and_then(|d| d.get(range)).ok_or_else(|| {
                    let message = format!(
                        "buffer view {} (offset {}, length {}) extends past its buffer {}",
                        view.index(),
                        view.offset(),
                        view.length(),
                        view.buffer().index()
                    );
                    (image_element.clone(), message)
                })?;
                std::borrow::Cow::Borrowed(bytes)
            }
            gltf::image::Source::Uri { uri, .. } => {
                if !uri.starts_with("data:") {
                    image_element = format!("{image_element} '{uri}'");
                }
                let bytes =
                    read_uri(uri, None, self.files).map_err(|m| (image_element.clone(), m))?;
                std::borrow::Cow::Owned(bytes)
            }
        };
        let decoded = decode_image(&bytes).map_err(|m| (image_element.clone(), m))?;
        let sampler = texture.sampler();
        let wrap = [
            convert_wrap(sampler.wrap_s()),
            convert_wrap(sampler.wrap_t()),
        ];
        let texture_out = Texture::new(decoded.width, decoded.height, decoded.texels, wrap)
            .ok_or_else(|| (image_element, "texel count does not match its size".into()))?
            .with_transform(transform);
        let i = self.textures.len() as u32;
        self.textures.push(texture_out);
        self.texture_map.insert(key, i);
        Ok(Some(i))
    }
}

pub(super) fn convert_wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
    }
}

/// The material's constant factors (its textures are added by the loader).
pub(super) fn convert_material(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let specular = m.specular().map_or(1.0, |s| s.specular_factor());
    Material {
        base_color: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
        metallic: pbr.metallic_factor().clamp(0.0, 1.0),
        roughness: pbr.roughness_factor().clamp(0.0, 1.0),
        specular: specular.clamp(0.0, 1.0),
        emission: (Vec3::from(m.emissive_factor()) * strength).max(Vec3::ZERO),
        double_sided: m.double_sided(),
        base_color_texture: None,
        emissive_texture: None,
    }
}
