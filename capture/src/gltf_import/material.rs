//! glTF materials to shadetrace's Phong materials, their base-colour textures to RGBA8,
//! and their other maps (normal, metallic-roughness, occlusion, emissive) to the trace's
//! surface maps.
//!
//! Only materials used by an imported primitive, and only the textures they sample on the
//! base colour's UVs, are converted (in order of first use), so a scene pays neither time
//! nor errors for images it cannot use.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec2;
use gltf::json::extensions::texture::TextureTransform;
use gltf::json::{self, material::AlphaMode as JsonAlphaMode, texture::WrappingMode};
use image::{imageops::FilterType, DynamicImage, GenericImageView, ImageDecoder, ImageFormat, RgbaImage};
use shadetrace_formats::{
    phong_from_metallic_roughness, AlphaMode, Material, MaterialMaps, SurfaceMaps, Texture, Wrap,
};

use super::basisu;
use super::data::{self, Reader};
use super::geometry::{UvSource, UvTransform};
use super::{input, unsupported, valid, Fallible};

/// The glTF default material (spec §3.9.6): white, fully metallic, fully rough, opaque.
fn default_material() -> Material {
    let (specular_exponent, specular_strength) = phong_from_metallic_roughness(1.0, 1.0);
    Material {
        name: "default".to_string(),
        base_color: [1.0; 4],
        base_color_texture: None,
        specular_exponent,
        specular_strength,
        alpha: AlphaMode::Opaque,
        double_sided: false,
    }
}

/// Materials and textures converted so far, indexed as they will appear in the trace.
pub(super) struct Materials<'a> {
    root: &'a json::Root,
    reader: &'a Reader<'a>,
    base: &'a Path,
    max_texture: u32,
    /// Largest image decoded, as RGBA8 at full size ([`super::ImportLimits::image_bytes`]).
    max_image_bytes: u64,
    /// File material (`None`: the default material) to output index.
    by_file_index: BTreeMap<Option<usize>, u32>,
    materials: Vec<Material>,
    uv_sources: Vec<Option<UvSource>>,
    /// Each output material's maps beyond base colour.
    maps: Vec<MaterialMaps>,
    /// File texture, and whether it is decoded as data (not colour), to output index.
    texture_by_file_index: BTreeMap<(usize, bool), u32>,
    textures: Vec<Texture>,
    /// One line per material with a texture map capture cannot use, naming it and why.
    pub dropped_maps: Vec<String>,
}

/// The material's `KHR_texture_transform`, as a UV source for texture coordinate `set`.
fn uv_source(set: u32, transform: Option<&TextureTransform>) -> UvSource {
    UvSource {
        set: transform.and_then(|t| t.tex_coord).unwrap_or(set),
        transform: transform.map_or(UvTransform::IDENTITY, |t| UvTransform {
            offset: Vec2::from_array(t.offset.0),
            rotation: t.rotation.0,
            scale: Vec2::from_array(t.scale.0),
        }),
    }
}

const TRANSFORM: &str = "KHR_texture_transform";

/// The UV source of a normal or occlusion texture, whose `KHR_texture_transform` (given
/// here) the `gltf` crate keeps unparsed.
fn unparsed_uv_source(set: u32, transform: Option<&json::Value>) -> UvSource {
    let transform = transform.and_then(|t| json::deserialize::from_value::<TextureTransform>(t.clone()).ok());
    uv_source(set, transform.as_ref())
}

impl<'a> Materials<'a> {
    pub fn new(
        root: &'a json::Root,
        reader: &'a Reader<'a>,
        base: &'a Path,
        max_texture: u32,
        max_image_bytes: u64,
    ) -> Self {
        Materials {
            root,
            reader,
            base,
            max_texture,
            max_image_bytes,
            by_file_index: BTreeMap::new(),
            materials: Vec::new(),
            uv_sources: Vec::new(),
            maps: Vec::new(),
            texture_by_file_index: BTreeMap::new(),
            textures: Vec::new(),
            dropped_maps: Vec::new(),
        }
    }

    /// Output index of a primitive's material, converting it on first use, and where its
    /// texture takes UVs from (`None` without a base-colour texture).
    pub fn resolve(&mut self, material: Option<json::Index<json::Material>>) -> Fallible<(u32, Option<UvSource>)> {
        let key = material.map(|m| m.value());
        if let Some(&index) = self.by_file_index.get(&key) {
            return Ok((index, self.uv_sources[index as usize]));
        }
        let (converted, uv, maps) = match key {
            Some(i) => self.convert(i)?,
            None => (default_material(), None, MaterialMaps::NONE),
        };
        let index = self.materials.len() as u32;
        self.materials.push(converted);
        self.uv_sources.push(uv);
        self.maps.push(maps);
        self.by_file_index.insert(key, index);
        Ok((index, uv))
    }

    /// Whether output material `m` has a normal map (its meshes then need tangents).
    pub fn has_normal_map(&self, m: u32) -> bool {
        self.maps.get(m as usize).is_some_and(|maps| maps.normal.is_some())
    }

    /// Drops output material `m`'s normal map (a mesh using it cannot carry tangents).
    pub fn drop_normal_map(&mut self, m: u32, why: &str) {
        if let Some(maps) = self.maps.get_mut(m as usize).filter(|maps| maps.normal.is_some()) {
            maps.normal = None;
            let name = &self.materials[m as usize].name;
            self.dropped_maps
                .push(format!("material {name}: normal map ignored ({why})"));
        }
    }

    /// The materials, the textures, and the surface maps (tangents left for the caller).
    pub fn into_parts(self) -> (Vec<Material>, Vec<Texture>, SurfaceMaps) {
        let textures = self.texture_by_file_index.iter();
        let linear_textures = textures.filter(|((_, linear), _)| *linear).map(|(_, &t)| t).collect();
        let maps = SurfaceMaps {
            materials: self.maps,
            tangents: Vec::new(),
            linear_textures,
        };
        (self.materials, self.textures, maps)
    }

    /// The maps beyond base colour that share the base colour's UVs (`uv`; the first map's
    /// when there is no base-colour texture), decoded; the others are named in
    /// `dropped_maps`.
    fn convert_maps(
        &mut self,
        what: &str,
        material: &json::Material,
        uv: &mut Option<UvSource>,
    ) -> Fallible<MaterialMaps> {
        let pbr = &material.pbr_metallic_roughness;
        let transform_of =
            |info: &json::texture::Info| info.extensions.as_ref().and_then(|e| e.texture_transform.clone());
        // (map, texture, UV source, decoded as data)
        let candidates = [
            pbr.metallic_roughness_texture.as_ref().map(|i| {
                (
                    "metallic-roughness",
                    i.index.value(),
                    uv_source(i.tex_coord, transform_of(i).as_ref()),
                    true,
                )
            }),
            material.normal_texture.as_ref().map(|n| {
                let uv = unparsed_uv_source(n.tex_coord, n.extensions.as_ref().and_then(|e| e.others.get(TRANSFORM)));
                ("normal", n.index.value(), uv, true)
            }),
            material.occlusion_texture.as_ref().map(|o| {
                let uv = unparsed_uv_source(o.tex_coord, o.extensions.as_ref().and_then(|e| e.others.get(TRANSFORM)));
                ("occlusion", o.index.value(), uv, true)
            }),
            // Black times any texture is black: a zero emissive factor (glTF's default)
            // leaves its texture unread.
            material
                .emissive_texture
                .as_ref()
                .filter(|_| material.emissive_factor.0 != [0.0; 3])
                .map(|i| {
                    (
                        "emissive",
                        i.index.value(),
                        uv_source(i.tex_coord, transform_of(i).as_ref()),
                        false,
                    )
                }),
        ];
        let mut maps = MaterialMaps::NONE;
        let mut dropped = Vec::new();
        for (map, file_texture, source, linear) in candidates.into_iter().flatten() {
            let shared = *uv.get_or_insert(source);
            if shared != source {
                dropped.push(format!(
                    "{map} (its UVs are TEXCOORD_{} or transformed differently from the base colour's)",
                    source.set
                ));
                continue;
            }
            let t = self.texture(file_texture, linear)?;
            match map {
                "metallic-roughness" => {
                    maps.metallic_roughness = Some((t, pbr.roughness_factor.0, pbr.metallic_factor.0))
                }
                "normal" => maps.normal = material.normal_texture.as_ref().map(|n| (t, n.scale)),
                "occlusion" => maps.occlusion = material.occlusion_texture.as_ref().map(|o| (t, o.strength.0)),
                _ => maps.emissive_texture = Some(t),
            }
        }
        let strength = material
            .extensions
            .as_ref()
            .and_then(|e| e.emissive_strength.as_ref())
            .map_or(1.0, |s| s.emissive_strength.0);
        maps.emissive = material.emissive_factor.0.map(|c| c * strength);
        if maps.emissive == [0.0; 3] {
            maps.emissive_texture = None; // a zero strength
        }
        if !dropped.is_empty() {
            let name = material.name.as_deref().map_or(String::new(), |n| format!(" ({n})"));
            self.dropped_maps
                .push(format!("{what}{name}: {} map ignored", dropped.join(", ")));
        }
        if !(maps.emissive.iter().all(|c| c.is_finite())
            && maps.normal.is_none_or(|n| n.1.is_finite())
            && maps.occlusion.is_none_or(|o| o.1.is_finite()))
        {
            return Err(input(format!("{what} has non-finite map parameters")));
        }
        Ok(maps)
    }

    fn convert(&mut self, index: usize) -> Fallible<(Material, Option<UvSource>, MaterialMaps)> {
        let what = format!("material {index}");
        let material = self
            .root
            .materials
            .get(index)
            .ok_or_else(|| input(format!("{what} does not exist")))?;
        let pbr = &material.pbr_metallic_roughness;
        let (base_color_texture, mut uv) = match &pbr.base_color_texture {
            None => (None, None),
            Some(info) => {
                let texture = self.texture(info.index.value(), false)?;
                let transform = info.extensions.as_ref().and_then(|e| e.texture_transform.as_ref());
                (Some(texture), Some(uv_source(info.tex_coord, transform)))
            }
        };
        let maps = self.convert_maps(&what, material, &mut uv)?;
        let alpha = match valid(&material.alpha_mode, &what, "alphaMode")? {
            JsonAlphaMode::Opaque => AlphaMode::Opaque,
            JsonAlphaMode::Mask => AlphaMode::Mask {
                cutoff: material.alpha_cutoff.map_or(0.5, |c| c.0),
            },
            JsonAlphaMode::Blend => AlphaMode::Blend,
        };
        let roughness = pbr.roughness_factor.0;
        let metallic = pbr.metallic_factor.0;
        let (specular_exponent, specular_strength) = phong_from_metallic_roughness(roughness, metallic);
        let base_color = pbr.base_color_factor.0;
        let cutoff_ok = match alpha {
            AlphaMode::Mask { cutoff } => cutoff.is_finite(),
            AlphaMode::Opaque | AlphaMode::Blend => true,
        };
        if !(base_color.iter().all(|c| c.is_finite())
            && roughness.is_finite()
            && metallic.is_finite()
            && cutoff_ok
            && uv.is_none_or(|uv| uv.transform.is_finite()))
        {
            return Err(input(format!("{what} has non-finite parameters")));
        }
        let converted = Material {
            name: material.name.clone().unwrap_or(what),
            base_color,
            base_color_texture,
            specular_exponent,
            specular_strength,
            alpha,
            double_sided: material.double_sided,
        };
        Ok((converted, uv, maps))
    }

    /// Output index of file texture `index`, decoding its image on first use; `linear`
    /// marks a data texture (a file texture used both ways is decoded once for each).
    fn texture(&mut self, index: usize, linear: bool) -> Fallible<u32> {
        if let Some(&t) = self.texture_by_file_index.get(&(index, linear)) {
            return Ok(t);
        }
        let what = format!("texture {index}");
        let texture = self
            .root
            .textures
            .get(index)
            .ok_or_else(|| input(format!("{what} does not exist")))?;
        // KHR_texture_basisu and EXT_texture_webp name the image in their format; `source`,
        // if there is one, is a fallback for viewers without them.
        let extension_source = [basisu::EXTENSION, "EXT_texture_webp"].into_iter().find_map(|name| {
            texture
                .extensions
                .as_ref()
                .and_then(|e| e.others.get(name))
                .and_then(|w| w.get("source"))
                .and_then(|s| s.as_u64())
        });
        let image_index = match extension_source {
            Some(i) => usize::try_from(i).unwrap_or(usize::MAX),
            None => texture.source.value(),
        };
        let image = self
            .root
            .images
            .get(image_index)
            .ok_or_else(|| input(format!("{what} uses image {image_index}, which does not exist")))?;
        let core = texture.source.value();
        let pixels = match self.decode(image, image_index, index) {
            // An extension's image that does not decode falls back to the core image, as a
            // viewer without the extension would show (a file that requires it has no other).
            Err(problem) if image_index != core && self.root.images.get(core).is_some() => {
                let reason = match &problem {
                    super::Problem::Input(m) | super::Problem::Unsupported(m) => m.clone(),
                };
                self.dropped_maps
                    .push(format!("{what}: {reason}; using its fallback image {core}"));
                self.decode(&self.root.images[core], core, index)?
            }
            result => result?,
        };
        let (wrap_u, wrap_v) = match texture.sampler {
            None => (Wrap::Repeat, Wrap::Repeat),
            Some(s) => {
                let sampler = self
                    .root
                    .samplers
                    .get(s.value())
                    .ok_or_else(|| input(format!("{what} uses sampler {s}, which does not exist")))?;
                let sampler_what = format!("sampler {s}");
                (
                    wrap(valid(&sampler.wrap_s, &sampler_what, "wrapS")?),
                    wrap(valid(&sampler.wrap_t, &sampler_what, "wrapT")?),
                )
            }
        };
        let name = image
            .name
            .clone()
            .or_else(|| image.uri.as_deref().and_then(data::uri_file_name))
            .unwrap_or(what);
        let (width, height) = pixels.dimensions();
        self.textures.push(Texture {
            name,
            width,
            height,
            wrap_u,
            wrap_v,
            rgba8: pixels.into_raw(),
        });
        let t = (self.textures.len() - 1) as u32;
        self.texture_by_file_index.insert((index, linear), t);
        Ok(t)
    }

    /// Decodes a PNG, JPEG, WebP or KTX2 (Basis Universal) image to RGBA8 and scales it to
    /// the texture size cap.
    fn decode(&self, image: &json::Image, image_index: usize, texture: usize) -> Fallible<RgbaImage> {
        let what = format!("image {image_index}");
        let (bytes, data_uri_type): (Cow<[u8]>, Option<String>) = match (&image.buffer_view, &image.uri) {
            (Some(view), _) => (Cow::Borrowed(self.reader.view_bytes(*view)?), None),
            (None, Some(uri)) => {
                let (bytes, media_type) = data::read_uri(uri, self.base, &what, data::MAX_IMAGE_FILE_BYTES)?;
                if bytes.len() as u64 > data::MAX_IMAGE_FILE_BYTES {
                    return Err(input(format!(
                        "{what} is larger than the {} bytes capture reads for an image",
                        data::MAX_IMAGE_FILE_BYTES
                    )));
                }
                (Cow::Owned(bytes), media_type)
            }
            (None, None) => return Err(input(format!("{what} has neither a uri nor a bufferView"))),
        };
        let declared = image
            .mime_type
            .as_ref()
            .map(|m| m.0.as_str())
            .or(data_uri_type.as_deref());
        // The bytes decide: files often carry a wrong or missing mime type.
        if basisu::is_ktx2(&bytes) {
            let decoded = basisu::decode(&bytes, self.max_texture, self.max_image_bytes)
                .map_err(|e| input(format!("cannot decode {what} of texture {texture}: {e}")))?;
            return Ok(fit_within(DynamicImage::ImageRgba8(decoded), self.max_texture));
        }
        let format = match image::guess_format(&bytes) {
            Ok(format @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::WebP)) => format,
            Ok(other) => return Err(unsupported(format!("image format {other:?} in texture {texture}"))),
            Err(_) => {
                return Err(match declared {
                    Some(declared @ ("image/png" | "image/jpeg" | "image/webp" | "image/ktx2")) => {
                        input(format!("{what} of texture {texture} is declared {declared} but is not"))
                    }
                    Some(declared) => unsupported(format!("image format {declared} in texture {texture}")),
                    None => unsupported(format!("image format (unrecognised) in texture {texture}")),
                });
            }
        };
        let cannot = |e: image::ImageError| input(format!("cannot decode {what} of texture {texture}: {e}"));
        let mut decoder = image::ImageReader::with_format(std::io::Cursor::new(&bytes[..]), format)
            .into_decoder()
            .map_err(cannot)?;
        let (width, height) = decoder.dimensions();
        if width == 0 || height == 0 {
            return Err(input(format!("{what} of texture {texture} has no pixels")));
        }
        // Bounded by what the RGBA conversion will hold, before anything is decoded.
        let rgba_bytes = u64::from(width) * u64::from(height) * 4;
        if rgba_bytes > self.max_image_bytes {
            return Err(input(format!(
                "{what} of texture {texture} is {width}x{height}: {rgba_bytes} bytes as RGBA, more than the \
                 {} capture decodes",
                self.max_image_bytes
            )));
        }
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(self.max_image_bytes);
        decoder.set_limits(limits).map_err(cannot)?;
        let decoded = image::DynamicImage::from_decoder(decoder).map_err(cannot)?;
        Ok(fit_within(decoded, self.max_texture))
    }
}

fn wrap(mode: WrappingMode) -> Wrap {
    match mode {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

/// Scales an image down (triangle filter, aspect kept) so that its longer edge is at most
/// `max_edge` pixels (at least 1), then converts it to RGBA8: scaling first keeps a large
/// grey or RGB image from being held four channels wide at full size.
fn fit_within(image: DynamicImage, max_edge: u32) -> RgbaImage {
    let max_edge = max_edge.max(1);
    let (w, h) = image.dimensions();
    let longest = w.max(h);
    if longest <= max_edge {
        return image.into_rgba8();
    }
    let scale = f64::from(max_edge) / f64::from(longest);
    let fit = |edge: u32| ((f64::from(edge) * scale).round() as u32).clamp(1, max_edge);
    image.resize_exact(fit(w), fit(h), FilterType::Triangle).into_rgba8()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roughness_and_metallic_map_to_documented_phong_values() {
        // r = 0.5: alpha 0.25, Blinn 30, Phong 7.5.
        assert_eq!(phong_from_metallic_roughness(0.5, 0.0), (7.5, 0.04));
        assert_eq!(phong_from_metallic_roughness(1.0, 1.0), (1.0, 1.0));
        assert_eq!(phong_from_metallic_roughness(0.0, 0.5).0, 4096.0);
        let (_, half) = phong_from_metallic_roughness(0.3, 0.5);
        assert!((half - 0.52).abs() < 1e-6);
    }

    #[test]
    fn images_are_scaled_to_fit_keeping_aspect() {
        let image = DynamicImage::ImageRgba8(RgbaImage::new(100, 30));
        assert_eq!(fit_within(image.clone(), 200).dimensions(), (100, 30));
        assert_eq!(fit_within(image.clone(), 50).dimensions(), (50, 15));
        assert_eq!(fit_within(image, 0).dimensions(), (1, 1));
    }

    #[test]
    fn scaling_before_the_rgba_conversion_gives_the_same_pixels() {
        let grey = image::GrayImage::from_fn(97, 41, |x, y| image::Luma([((x * 7 + y * 13) % 256) as u8]));
        let grey = DynamicImage::ImageLuma8(grey);
        let rgba = DynamicImage::ImageRgba8(grey.to_rgba8());
        assert_eq!(fit_within(grey, 30), fit_within(rgba, 30));
    }
}
