//! Payload types of a trace, one per chunk kind (see `container` for the framing).
//!
//! Everything a replay back-end may need is here and nothing else: capture drops what
//! no frame uses, and optional attributes are empty vectors rather than zero-filled,
//! so a trace says by its contents (and its [`Features`]) what the scene requires.

use glam::{Mat4, Vec2, Vec3, Vec4};
use serde::{Deserialize, Serialize};

use crate::features::Features;
use crate::rig::StereoRig;

/// `Meta` chunk: provenance, capture options and what the scene requires.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    /// `shadetrace-capture` version that wrote the trace.
    pub tool_version: String,
    /// Human-readable scene name (file stem or built-in name).
    pub scene_name: String,
    pub source: Source,
    pub capture: CaptureSettings,
    pub features: Features,
    pub counts: Counts,
    /// World-space bounds of all geometry over all frames (shadow-map fitting, far plane).
    pub bounds: Aabb,
}

/// Where the geometry came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Source {
    /// A built-in procedural scene and its parameters, as given on the command line.
    Builtin { name: String, params: String },
    /// A glTF file: its file name (no directory, so the hash does not depend on where
    /// the file lives) and the SHA-256 of its bytes.
    File { file_name: String, sha256: [u8; 32] },
}

/// Options the capture ran with, recorded so a trace can be re-made.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaptureSettings {
    pub frames: u32,
    /// Camera path description, e.g. `orbit`, `gltf-camera:0`, `flythrough:path.toml`.
    pub camera_path: String,
    pub ipd_m: f32,
    pub eye_width: u32,
    pub eye_height: u32,
    /// Largest texture edge kept (textures above it are box-filtered down).
    pub max_texture: u32,
    /// Frames per second used to sample animation.
    pub fps: f32,
}

/// Element counts, so `info` and readers can size things without decoding geometry.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counts {
    pub meshes: u32,
    pub triangles: u64,
    pub vertices: u64,
    pub materials: u32,
    pub textures: u32,
    pub lights: u32,
    pub frames: u32,
    /// Length of every frame's `rigid_transforms`.
    pub rigid_slots: u32,
    /// Vertex count of every frame's `skinned[slot]`.
    pub skinned_slots: Vec<u32>,
}

/// Axis-aligned box; `min > max` on some axis means empty.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the diagonal: radius of a sphere around `center` holding the box.
    pub fn radius(&self) -> f32 {
        (self.max - self.min).length() * 0.5
    }
}

/// The static part of a trace: the `Geometry`, `Materials`, `Textures` and `Lights` chunks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    pub geometry: Geometry,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    /// Texture maps beyond base colour; empty for most scenes, and then not written.
    pub surface_maps: SurfaceMaps,
}

impl Scene {
    /// The counts `Meta` records for this scene (frames and slots filled by the caller).
    pub fn counts(&self, frames: u32) -> Counts {
        let meshes = &self.geometry.meshes;
        let mut rigid_slots = 0u32;
        let mut skinned: Vec<(u32, u32)> = Vec::new();
        for mesh in meshes {
            match mesh.motion {
                Motion::Static => {}
                Motion::Rigid { slot } => rigid_slots = rigid_slots.max(slot.saturating_add(1)),
                Motion::Skinned { slot } => skinned.push((slot, mesh.positions.len() as u32)),
            }
        }
        skinned.sort_unstable();
        Counts {
            meshes: meshes.len() as u32,
            triangles: meshes.iter().map(|m| m.triangle_count() as u64).sum(),
            vertices: meshes.iter().map(|m| m.positions.len() as u64).sum(),
            materials: self.materials.len() as u32,
            textures: self.textures.len() as u32,
            lights: self.lights.len() as u32,
            frames,
            rigid_slots,
            skinned_slots: skinned.into_iter().map(|(_, n)| n).collect(),
        }
    }
}

/// `Geometry` chunk: all meshes of the scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Geometry {
    pub meshes: Vec<Mesh>,
}

/// One drawable triangle list with one material.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub name: String,
    /// Index into the `Materials` chunk.
    pub material: u32,
    pub motion: Motion,
    /// World space for [`Motion::Static`], mesh space for [`Motion::Rigid`], bind pose
    /// (mesh space) for [`Motion::Skinned`].
    pub positions: Vec<Vec3>,
    /// Unit normals, one per position (capture generates them when the source has none).
    pub normals: Vec<Vec3>,
    /// Texture coordinates with KHR_texture_transform already applied; empty when the
    /// material samples no texture.
    pub uvs: Vec<Vec2>,
    /// Triangle list, three indices per triangle, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Surface patch id per triangle (tessellated scenes, AMFS); empty when absent.
    pub patch_ids: Vec<u32>,
    /// True when no two triangles overlap in UV space (texel shading needs it).
    pub uv_atlas_unique: bool,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// How a mesh moves over the frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Motion {
    /// Vertices are in world space and never move.
    #[default]
    Static,
    /// Each frame's `rigid_transforms[slot]` maps mesh space to world space.
    Rigid { slot: u32 },
    /// Each frame's `skinned[slot]` holds world-space positions and normals.
    Skinned { slot: u32 },
}

/// `Materials` chunk entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    /// Linear RGBA base colour factor.
    pub base_color: [f32; 4],
    /// Index into the `Textures` chunk; multiplies `base_color`.
    pub base_color_texture: Option<u32>,
    /// Phong exponent `n` of `(R·L)^n` (see capture's mapping from roughness).
    pub specular_exponent: f32,
    /// Specular weight (Fresnel at normal incidence, from metallic).
    pub specular_strength: f32,
    pub alpha: AlphaMode,
    pub double_sided: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum AlphaMode {
    Opaque,
    /// Fragments with alpha below the cutoff are discarded.
    Mask {
        cutoff: f32,
    },
    Blend,
}

/// `Textures` chunk entry: one RGBA8 base level, sRGB-encoded colour.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
    /// `width * height * 4` bytes, rows top to bottom.
    pub rgba8: Vec<u8>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// `SurfaceMaps` chunk (format minor 1, present only when a material uses one): the
/// glTF maps beyond base colour, which the shader maps to its terms in one place
/// (`replay/src/shader.rs`). Every map samples the mesh's `uvs`, like base colour.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SurfaceMaps {
    /// One per material, in `Materials` order; empty when no material has a map.
    pub materials: Vec<MaterialMaps>,
    /// One per mesh, in `Geometry` order: a MikkTSpace tangent per vertex (xyz unit, w the
    /// bitangent's sign), empty for a mesh whose material has no normal map.
    pub tangents: Vec<Vec<Vec4>>,
    /// Indices of the textures that hold data, not colour (normal, metallic-roughness,
    /// occlusion maps): sampled without the sRGB decode.
    pub linear_textures: Vec<u32>,
}

impl SurfaceMaps {
    pub fn is_empty(&self) -> bool {
        self.materials.iter().all(MaterialMaps::is_empty)
    }

    /// The maps of material `m` (none for a material past the list).
    pub fn of(&self, m: u32) -> &MaterialMaps {
        const NONE: &MaterialMaps = &MaterialMaps::NONE;
        self.materials.get(m as usize).unwrap_or(NONE)
    }
}

/// One material's maps. Textures index the `Textures` chunk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialMaps {
    /// Tangent-space normal map and its `scale` (glTF `normalTexture`).
    pub normal: Option<(u32, f32)>,
    /// glTF `metallicRoughnessTexture` (roughness in G, metallic in B) with the material's
    /// roughness and metallic factors, which it multiplies.
    pub metallic_roughness: Option<(u32, f32, f32)>,
    /// Ambient occlusion in R and its `strength` (glTF `occlusionTexture`).
    pub occlusion: Option<(u32, f32)>,
    /// Linear emitted radiance: the emissive factor times `KHR_materials_emissive_strength`.
    pub emissive: [f32; 3],
    /// sRGB emissive texture multiplying `emissive`.
    pub emissive_texture: Option<u32>,
}

impl MaterialMaps {
    pub const NONE: MaterialMaps = MaterialMaps {
        normal: None,
        metallic_roughness: None,
        occlusion: None,
        emissive: [0.0; 3],
        emissive_texture: None,
    };

    pub fn is_empty(&self) -> bool {
        *self == MaterialMaps::NONE
    }
}

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
/// metallic `m`: `0.04 (1 - m) + m`. Factors are clamped to [0, 1]. Capture maps the factors with
/// it; replay maps each texel of a metallic-roughness texture times the factors with it.
pub fn phong_from_metallic_roughness(roughness: f32, metallic: f32) -> (f32, f32) {
    let r = roughness.clamp(0.0, 1.0);
    let m = metallic.clamp(0.0, 1.0);
    let alpha = (r * r).max(MIN_ALPHA);
    let blinn = 2.0 / (alpha * alpha) - 2.0;
    let exponent = (blinn / 4.0).clamp(MIN_EXPONENT, MAX_EXPONENT);
    let strength = DIELECTRIC_F0 * (1.0 - m) + m;
    (exponent, strength)
}

/// `Lights` chunk entry. Lights are static over the trace.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Lux for directional lights, candela for point and spot lights (KHR_lights_punctual).
    pub intensity: f32,
    /// At most one light per trace casts shadows, and it is directional.
    pub shadowed: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum LightKind {
    /// `direction` is the unit direction the light travels (from the light to the scene).
    Directional {
        direction: Vec3,
    },
    Point {
        position: Vec3,
        range: Option<f32>,
    },
    Spot {
        position: Vec3,
        direction: Vec3,
        inner_cone: f32,
        outer_cone: f32,
        range: Option<f32>,
    },
}

/// `Frame` chunk: everything that changes per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    pub index: u32,
    pub time_s: f32,
    pub rig: StereoRig,
    /// Mesh-to-world matrices for [`Motion::Rigid`] meshes, by slot.
    pub rigid_transforms: Vec<Mat4>,
    /// Skinned world-space vertices for [`Motion::Skinned`] meshes, by slot.
    pub skinned: Vec<SkinnedVertices>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SkinnedVertices {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
}
