//! Materials: base colour factor and texture (UV set, transform, sampler), unlit.

use glam::Vec4;

use super::Loader;
use crate::error::Result;
use crate::scene::{Filter, Material, Texture, TextureRef, Wrap};
use crate::util::files::decode_image;
use crate::util::limits::{MAX_IMAGE_PIXELS, MAX_SCENE_TEXELS};

impl Loader<'_> {
    pub(super) fn material(&mut self, m: gltf::Material) -> Result<usize> {
        if let Some(&i) = self.material_cache.get(&m.index()) {
            return Ok(i);
        }
        let mut mat = Material::default();
        if let Some(i) = m.index() {
            let pbr = m.pbr_metallic_roughness();
            mat.name = m.name().map(str::to_string).unwrap_or_else(|| format!("material {i}"));
            mat.base_color = Vec4::from(pbr.base_color_factor());
            if !mat.base_color.is_finite() {
                return Err(self.err(format!("material {i}: baseColorFactor is not finite")));
            }
            mat.metallic = pbr.metallic_factor().clamp(0.0, 1.0);
            mat.roughness = pbr.roughness_factor().clamp(0.0, 1.0);
            mat.unlit = m.unlit();
            if let Some(info) = pbr.base_color_texture() {
                let texture = self.texture(info.texture())?;
                let mut uv_set = info.tex_coord();
                let mut uv_transform = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
                if let Some(t) = info.texture_transform() {
                    let [ox, oy] = t.offset();
                    let r = t.rotation();
                    let [sx, sy] = t.scale();
                    let (s, c) = r.sin_cos();
                    // KHR_texture_transform: T * R * S, with R rotating UVs counter-clockwise.
                    uv_transform = [c * sx, s * sy, ox, -s * sx, c * sy, oy];
                    if let Some(set) = t.tex_coord() {
                        uv_set = set;
                    }
                }
                mat.base_color_texture = texture.map(|texture| TextureRef { texture, uv_set, uv_transform });
            }
        }
        self.scene.materials.push(mat);
        let i = self.scene.materials.len() - 1;
        self.material_cache.insert(m.index(), i);
        Ok(i)
    }

    /// Decodes a texture's image (only textures a material uses are decoded).
    pub(super) fn texture(&mut self, t: gltf::Texture) -> Result<Option<usize>> {
        if let Some(&i) = self.texture_cache.get(&t.index()) {
            return Ok(Some(i));
        }
        let image = t.source();
        let what = format!("image {} (texture {})", image.index(), t.index());
        // `Image::source` unwraps what the spec requires (a mimeType beside a bufferView, a uri
        // otherwise): a file without them panicked inside the gltf crate (found by fuzzing).
        if let Some(json) = self.doc.as_json().images.get(image.index()) {
            match (&json.buffer_view, &json.uri) {
                (Some(v), _) if v.value() >= self.doc.views().len() => {
                    return Err(self.err(format!("{what}: bufferView {} does not exist", v.value())));
                }
                (Some(_), _) if json.mime_type.is_none() => {
                    return Err(self.err(format!("{what}: an image in a bufferView needs a mimeType")));
                }
                (None, None) => return Err(self.err(format!("{what}: has neither a uri nor a bufferView"))),
                _ => {}
            }
        }
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let b = view.buffer().index();
                let data = self.buffers.get(b).ok_or_else(|| self.err(format!("{what}: missing buffer {b}")))?;
                let end = view.offset().checked_add(view.length()).filter(|e| *e <= data.len()).ok_or_else(|| {
                    self.err(format!("{what}: bufferView {} runs past the end of buffer {b}", view.index()))
                })?;
                data[view.offset()..end].to_vec()
            }
            gltf::image::Source::Uri { uri, .. } => self.read_uri(uri, &what)?,
        };
        // The size is checked against the scene's texel budget before decoding (a 66 KB
        // 1-bit PNG may declare 23000 x 23000), and texels are kept as 8-bit RGBA.
        let budget = MAX_SCENE_TEXELS.saturating_sub(self.texels).min(MAX_IMAGE_PIXELS);
        let decoded = decode_image(&bytes, budget).map_err(|e| {
            self.err(format!(
                "{what}: cannot decode: {e} (the scene's textures may hold {MAX_SCENE_TEXELS} texels in all)"
            ))
        })?;
        drop(bytes);
        self.texels += decoded.width() as u64 * decoded.height() as u64;
        let rgba = decoded.into_rgba8();
        let sampler = t.sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let filter = match sampler.mag_filter() {
            Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
            _ => Filter::Linear,
        };
        let (width, height) = rgba.dimensions();
        let texels = rgba.into_raw().chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect();
        let tex = Texture::from_texels(width, height, texels, wrap(sampler.wrap_s()), wrap(sampler.wrap_t()), filter);
        if tex.width == 0 || tex.height == 0 {
            return Err(self.err(format!("{what}: image is empty")));
        }
        self.scene.textures.push(tex);
        let i = self.scene.textures.len() - 1;
        self.texture_cache.insert(t.index(), i);
        Ok(Some(i))
    }
}
