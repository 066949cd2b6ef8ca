//! glTF materials to shadetrace's Phong materials, and their base-colour textures to RGBA8.
//!
//! Only materials used by an imported primitive, and only their base-colour textures, are
//! converted (in order of first use): normal, occlusion and metallic-roughness maps are
//! never decoded, so a scene pays neither time nor errors for images it cannot use.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec2;
use gltf::json::{self, material::AlphaMode as JsonAlphaMode, texture::WrappingMode};
use image::{imageops::FilterType, DynamicImage, GenericImageView, ImageDecoder, ImageFormat, RgbaImage};

/// Largest image capture decodes, as RGBA8 bytes (8192 x 8192).
const MAX_DECODED_IMAGE_BYTES: u64 = 256 << 20;
use shadetrace_formats::{AlphaMode, Material, Texture, Wrap};

use super::basisu;
use super::data::{self, Reader};
use super::geometry::{UvSource, UvTransform};
use super::{input, unsupported, valid, Fallible};

/// Specular exponents are clamped to this range (see [`phong_from_metallic_roughness`]).
const MIN_EXPONENT: f32 = 1.0;
const MAX_EXPONENT: f32 = 4096.0;
/// Smallest GGX width kept, so that a roughness of 0 gives a finite exponent.
const MIN_ALPHA: f32 = 1e-3;
/// Fresnel reflectance at normal incidence of dielectrics (glTF's metallic-roughness model).
const DIELECTRIC_F0: f32 = 0.04;

/// Maps glTF metallic-roughness factors to the Phong parameters of shadetrace's shader,
/// returning `(specular_exponent, specular_strength)`.
///
/// Roughness `r` is perceptual; the microfacet (GGX) width is `alpha = max(r², 1e-3)`. A
/// Blinn-Phong lobe with exponent `nb = 2 / alpha² - 2` has the same width (Walter et al.
/// 2007), and a Phong `(R·L)^n` lobe matches a Blinn-Phong one for `n ≈ nb / 4` (the half
/// vector's angle to the normal is about half the reflection vector's angle to the
/// light), so `n = clamp(nb / 4, 1, 4096)`. The specular strength is the Fresnel
/// reflectance at normal incidence, 0.04 for dielectrics and 1 for metals, blended by
/// metallic `m`: `0.04 (1 - m) + m`. Factors are clamped to [0, 1]; metallic-roughness
/// *textures* are not sampled.
pub fn phong_from_metallic_roughness(roughness: f32, metallic: f32) -> (f32, f32) {
    let r = roughness.clamp(0.0, 1.0);
    let m = metallic.clamp(0.0, 1.0);
    let alpha = (r * r).max(MIN_ALPHA);
    let blinn = 2.0 / (alpha * alpha) - 2.0;
    let exponent = (blinn / 4.0).clamp(MIN_EXPONENT, MAX_EXPONENT);
    let strength = DIELECTRIC_F0 * (1.0 - m) + m;
    (exponent, strength)
}

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
    /// File material (`None`: the default material) to output index.
    by_file_index: BTreeMap<Option<usize>, u32>,
    materials: Vec<Material>,
    uv_sources: Vec<Option<UvSource>>,
    /// File texture to output index.
    texture_by_file_index: BTreeMap<usize, u32>,
    textures: Vec<Texture>,
    /// One line per material whose texture maps other than base colour are not used.
    pub dropped_maps: Vec<String>,
}

impl<'a> Materials<'a> {
    pub fn new(root: &'a json::Root, reader: &'a Reader<'a>, base: &'a Path, max_texture: u32) -> Self {
        Materials {
            root,
            reader,
            base,
            max_texture,
            by_file_index: BTreeMap::new(),
            materials: Vec::new(),
            uv_sources: Vec::new(),
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
        let (converted, uv) = match key {
            Some(i) => self.convert(i)?,
            None => (default_material(), None),
        };
        let index = self.materials.len() as u32;
        self.materials.push(converted);
        self.uv_sources.push(uv);
        self.by_file_index.insert(key, index);
        Ok((index, uv))
    }

    pub fn into_parts(self) -> (Vec<Material>, Vec<Texture>) {
        (self.materials, self.textures)
    }

    fn convert(&mut self, index: usize) -> Fallible<(Material, Option<UvSource>)> {
        let what = format!("material {index}");
        let material = self
            .root
            .materials
            .get(index)
            .ok_or_else(|| input(format!("{what} does not exist")))?;
        let pbr = &material.pbr_metallic_roughness;
        let dropped: Vec<&str> = [
            ("metallic-roughness", pbr.metallic_roughness_texture.is_some()),
            ("normal", material.normal_texture.is_some()),
            ("occlusion", material.occlusion_texture.is_some()),
            ("emissive", material.emissive_texture.is_some()),
        ]
        .into_iter()
        .filter_map(|(map, present)| present.then_some(map))
        .collect();
        if !dropped.is_empty() {
            let name = material.name.as_deref().map_or(String::new(), |n| format!(" ({n})"));
            self.dropped_maps.push(format!(
                "{what}{name}: {} texture map(s) ignored (only base colour is captured)",
                dropped.join(", ")
            ));
        }
        let (base_color_texture, uv) = match &pbr.base_color_texture {
            None => (None, None),
            Some(info) => {
                let texture = self.texture(info.index.value())?;
                let transform = info.extensions.as_ref().and_then(|e| e.texture_transform.as_ref());
                let source = UvSource {
                    set: transform.and_then(|t| t.tex_coord).unwrap_or(info.tex_coord),
                    transform: transform.map_or(UvTransform::IDENTITY, |t| UvTransform {
                        offset: Vec2::from_array(t.offset.0),
                        rotation: t.rotation.0,
                        scale: Vec2::from_array(t.scale.0),
                    }),
                };
                (Some(texture), Some(source))
            }
        };
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
        Ok((converted, uv))
    }

    /// Output index of file texture `index`, decoding its image on first use.
    fn texture(&mut self, index: usize) -> Fallible<u32> {
        if let Some(&t) = self.texture_by_file_index.get(&index) {
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
        let pixels = self.decode(image, image_index, index)?;
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
        self.texture_by_file_index.insert(index, t);
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
            let decoded = basisu::decode(&bytes, self.max_texture, MAX_DECODED_IMAGE_BYTES)
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
        if rgba_bytes > MAX_DECODED_IMAGE_BYTES {
            return Err(input(format!(
                "{what} of texture {texture} is {width}x{height}: {rgba_bytes} bytes as RGBA, more than the \
                 {MAX_DECODED_IMAGE_BYTES} capture decodes"
            )));
        }
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(MAX_DECODED_IMAGE_BYTES);
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
        assert_eq!(phong_from_metallic_roughness(0.0, 0.5).0, MAX_EXPONENT);
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
