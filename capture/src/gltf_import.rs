//! glTF 2.0 import: `.gltf` (with external files or `data:` URIs) and `.glb`, to a
//! [`SourceScene`].
//!
//! What is imported, from the default scene (or scene 0) only:
//! - triangle primitives (lists, strips and fans; strips and fans become lists) of every
//!   node reachable from the scene, one [`Mesh`] per (node, primitive). Static meshes are
//!   flattened to world space; meshes under an animated node are rigid (one slot per
//!   node); meshes with a skin and `JOINTS_0`/`WEIGHTS_0` are skinned (one slot each);
//! - missing normals are generated, smooth and area-weighted (flat without indices);
//! - `pbrMetallicRoughness` base colour factor and texture (with KHR_texture_transform
//!   baked into the UVs), alpha mode, double-sidedness, and a Phong approximation of
//!   metallic/roughness ([`phong_from_metallic_roughness`]);
//! - PNG, JPEG and WebP images (WebP also through EXT_texture_webp) and KTX2 Basis Universal
//!   images (KHR_texture_basisu, [`basisu`]) as RGBA8, scaled down to
//!   [`ImportOptions::max_texture`]; normal (with tangents, [`tangents`]), metallic-roughness,
//!   occlusion and emissive maps on the base colour's UVs, with `KHR_materials_emissive_strength`
//!   (others are dropped with a warning);
//! - compressed geometry: Draco primitives (KHR_draco_mesh_compression, [`draco`]),
//!   meshopt buffer views (EXT_/KHR_meshopt_compression, [`meshopt`]) and quantized
//!   attributes (KHR_mesh_quantization);
//! - KHR_lights_punctual lights (at their pose at t = 0; the first directional light
//!   casts shadows), perspective cameras, and translation/rotation/scale animation of
//!   all animations played together, with linear-blend skinning.
//!
//! Skipped with a warning: points and lines, orthographic cameras, morph targets and
//! weight animation, and extensions the file uses but does not require. A file that
//! *requires* an extension this importer does not implement (the README's coverage table
//! lists them) is rejected, as are invalid data (NaN/Inf positions, out-of-range indices,
//! missing POSITION, dangling references, corrupt compressed streams) and missing files,
//! each with one line naming the file and the problem.

mod basisu;
mod budget;
mod data;
mod draco;
mod geometry;
mod material;
mod meshopt;
mod motion;
mod tangents;

use std::path::Path;

use glam::{Mat4, Vec3, Vec4};
use gltf::json::{
    self, camera::Type as CameraType, extensions::scene::khr_lights_punctual::Type as LightType, mesh::Mode,
    mesh::Semantic, validation::Checked,
};
use serde::Deserialize;
use sha2::{Digest, Sha256};
use shadetrace_formats::{Geometry, Light, LightKind, Mesh, Motion, Scene, Source};

use crate::source::{SourceCamera, SourceScene, MAX_WORLD_COORDINATE_M};
use crate::{Error, Result};
use geometry::{TriangleMode, Triangles};

pub use budget::ImportLimits;
pub use shadetrace_formats::phong_from_metallic_roughness;

/// Largest `.gltf` / `.glb` file capture reads.
const MAX_GLTF_FILE_BYTES: u64 = 4 << 30;

/// How a glTF file is imported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Largest texture edge kept, in pixels; bigger images are scaled down with a
    /// triangle filter, keeping their aspect ratio.
    pub max_texture: u32,
    /// How much the import may decode before it stops with an error.
    pub limits: ImportLimits,
}

/// Extensions whose effect the importer reproduces.
/// KHR_mesh_quantization needs nothing more: every attribute is read through the spec's
/// integer-to-float conversion, normalized or not, and node transforms dequantize.
const IMPLEMENTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_texture_transform",
    "EXT_texture_webp",
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_draco_mesh_compression",
    "KHR_texture_basisu",
    "KHR_materials_emissive_strength",
];

/// Loads a `.gltf` or `.glb` file. Errors name `path` and the problem on one line.
pub fn load_gltf(path: &Path, opts: &ImportOptions) -> Result<SourceScene> {
    let shown = path.display().to_string();
    import(path, &shown, opts).map_err(|problem| problem.into_error(&shown))
}

/// A problem found while importing, before the file's path is attached.
#[derive(Debug)]
enum Problem {
    Input(String),
    Unsupported(String),
}

impl Problem {
    fn into_error(self, path: &str) -> Error {
        match self {
            Problem::Input(msg) => Error::input(path, one_line(&msg)),
            Problem::Unsupported(feature) => Error::unsupported(path, one_line(&feature)),
        }
    }
}

type Fallible<T> = std::result::Result<T, Problem>;

fn input(msg: impl Into<String>) -> Problem {
    Problem::Input(msg.into())
}

fn unsupported(feature: impl Into<String>) -> Problem {
    Problem::Unsupported(feature.into())
}

/// Messages from other crates (I/O, JSON, image decoding) may span lines; ours may not.
fn one_line(text: &str) -> String {
    text.replace(['\r', '\n'], " ")
}

/// The value of a JSON enum field, or an error when the file gave an unknown value.
fn valid<T: Copy>(value: &Checked<T>, what: &str, field: &str) -> Fallible<T> {
    match value {
        Checked::Valid(v) => Ok(*v),
        Checked::Invalid => Err(input(format!("{what} has an invalid {field}"))),
    }
}

/// Things skipped while importing, one line each, prefixed with the file's path.
struct Warnings {
    path: String,
    lines: Vec<String>,
}

impl Warnings {
    fn push(&mut self, msg: impl std::fmt::Display) {
        self.lines.push(one_line(&format!("{}: {msg}", self.path)));
    }
}

/// The extension lists, read on their own before the full document so that a file built
/// around an unsupported extension is reported as such.
#[derive(Deserialize)]
struct ExtensionLists {
    #[serde(default, rename = "extensionsUsed")]
    used: Vec<String>,
    #[serde(default, rename = "extensionsRequired")]
    required: Vec<String>,
}

fn check_extensions(json_bytes: &[u8], warnings: &mut Warnings) -> Fallible<()> {
    let lists: ExtensionLists =
        json::deserialize::from_slice(json_bytes).map_err(|e| input(format!("invalid glTF JSON: {e}")))?;
    let implemented = |ext: &str| IMPLEMENTED_EXTENSIONS.contains(&ext);
    if let Some(ext) = lists.required.iter().find(|ext| !implemented(ext)) {
        return Err(unsupported(format!("glTF extension {ext} (required by the file)")));
    }
    let mut ignored: Vec<&str> = Vec::new();
    for ext in lists.used.iter().chain(&lists.required) {
        if !implemented(ext) && !ignored.contains(&ext.as_str()) {
            ignored.push(ext);
        }
    }
    for ext in ignored {
        warnings.push(format!("glTF extension {ext} is not supported and is ignored"));
    }
    Ok(())
}

/// Root nodes of the default scene, or of scene 0 when the file names none.
fn scene_roots(root: &json::Root, warnings: &mut Warnings) -> Fallible<Vec<usize>> {
    let scene = match root.scene {
        Some(s) => s.value(),
        None if root.scenes.is_empty() => {
            warnings.push("the file has no scene; nothing imported");
            return Ok(Vec::new());
        }
        None => 0,
    };
    let scene = root
        .scenes
        .get(scene)
        .ok_or_else(|| input(format!("default scene {scene} does not exist")))?;
    Ok(scene.nodes.iter().map(|n| n.value()).collect())
}

fn import(path: &Path, shown: &str, opts: &ImportOptions) -> Fallible<SourceScene> {
    let bytes =
        data::read_regular_file(path, MAX_GLTF_FILE_BYTES).map_err(|e| input(format!("cannot read file: {e}")))?;
    if bytes.len() as u64 > MAX_GLTF_FILE_BYTES {
        return Err(input(format!(
            "larger than the {MAX_GLTF_FILE_BYTES} bytes capture reads"
        )));
    }
    if bytes.starts_with(b"STRC") {
        return Err(input(
            "this is a shadetrace trace, not a glTF file (use `shadetrace info` or `replay` on it)",
        ));
    }
    let sha256: [u8; 32] = Sha256::digest(&bytes).into();
    let container = data::split_container(&bytes)?;
    let mut warnings = Warnings {
        path: shown.to_string(),
        lines: Vec::new(),
    };
    check_extensions(container.json, &mut warnings)?;
    let root = json::Root::from_slice(container.json).map_err(|e| input(format!("invalid glTF JSON: {e}")))?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let base = folder
        .canonicalize()
        .map_err(|e| input(format!("cannot resolve the model's folder: {e}")))?;
    let base = base.as_path();
    let reader = data::Reader::new(&root, container.bin, base, opts.limits.geometry_bytes)?;
    let motion = motion::GltfMotion::new(&root, &reader, &mut warnings)?;
    let roots = scene_roots(&root, &mut warnings)?;
    let order = motion.nodes().traverse(&roots)?;

    let mut importer = Importer {
        root: &root,
        reader: &reader,
        materials: material::Materials::new(&root, &reader, base, opts.max_texture, opts.limits.image_bytes),
        world: motion.world_matrices(0.0),
        motion,
        meshes: Vec::new(),
        tangents: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
        warnings,
    };
    for &n in &order {
        importer.add_node(n)?;
    }

    let Importer {
        mut materials,
        motion,
        meshes,
        tangents,
        lights,
        cameras,
        mut warnings,
        ..
    } = importer;
    for line in std::mem::take(&mut materials.dropped_maps) {
        warnings.push(line);
    }
    let (materials, textures, mut surface_maps) = materials.into_parts();
    // A normal map dropped after some of its meshes were read leaves them tangents
    // nothing reads.
    surface_maps.tangents = meshes
        .iter()
        .zip(tangents)
        .map(|(mesh, t)| {
            if surface_maps.of(mesh.material).normal.is_some() {
                t
            } else {
                Vec::new()
            }
        })
        .collect();
    if surface_maps.is_empty() {
        surface_maps = Default::default();
    }
    let lossy = |s: Option<&std::ffi::OsStr>| s.map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(SourceScene {
        name: lossy(path.file_stem()),
        source: Source::File {
            file_name: lossy(path.file_name()),
            sha256,
        },
        scene: Scene {
            geometry: Geometry { meshes },
            materials,
            textures,
            lights,
            surface_maps,
        },
        cameras,
        animation_duration_s: motion.duration_s(),
        motion: Box::new(motion),
        warnings: warnings.lines,
    })
}

/// Converts the scene's nodes, in traversal order, into meshes, lights and cameras.
struct Importer<'a> {
    root: &'a json::Root,
    reader: &'a data::Reader<'a>,
    materials: material::Materials<'a>,
    motion: motion::GltfMotion,
    /// World matrix of every node at t = 0.
    world: Vec<Mat4>,
    meshes: Vec<Mesh>,
    /// Each mesh's tangents (empty without a normal map).
    tangents: Vec<Vec<Vec4>>,
    lights: Vec<Light>,
    cameras: Vec<SourceCamera>,
    warnings: Warnings,
}

impl Importer<'_> {
    fn add_node(&mut self, n: usize) -> Fallible<()> {
        let node = &self.root.nodes[n];
        if let Some(mesh) = node.mesh {
            self.add_mesh(n, mesh.value())?;
        }
        if let Some(light) = node.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()) {
            self.add_light(n, light.light.value())?;
        }
        if let Some(camera) = node.camera {
            self.add_camera(n, camera.value())?;
        }
        Ok(())
    }

    fn add_mesh(&mut self, n: usize, m: usize) -> Fallible<()> {
        let root = self.root;
        let node = &root.nodes[n];
        let mesh = root
            .meshes
            .get(m)
            .ok_or_else(|| input(format!("node {n} uses mesh {m}, which does not exist")))?;
        let mesh_label = match &mesh.name {
            Some(name) => format!("mesh {m} ({name})"),
            None => format!("mesh {m}"),
        };
        let mesh_name = mesh.name.clone().unwrap_or_else(|| format!("mesh {m}"));
        let animated = self.motion.is_animated(n);
        let mut rigid_slot = None;
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let label = format!("{mesh_label} primitive {p}");
            let mode = match valid(&primitive.mode, &label, "mode")? {
                Mode::Triangles => TriangleMode::List,
                Mode::TriangleStrip => TriangleMode::Strip,
                Mode::TriangleFan => TriangleMode::Fan,
                other => {
                    self.warnings.push(format!(
                        "{label}: skipped {} primitive (only triangles are supported)",
                        mode_name(other)
                    ));
                    continue;
                }
            };
            if primitive.targets.as_ref().is_some_and(|t| !t.is_empty()) {
                self.warnings
                    .push(format!("{label}: morph targets ignored (base shape used)"));
            }
            let has = |semantic| primitive.attributes.contains_key(&Checked::Valid(semantic));
            let skin = node
                .skin
                .filter(|_| has(Semantic::Joints(0)) && has(Semantic::Weights(0)))
                .map(|s| s.value());
            let (material, uv) = self.materials.resolve(primitive.material)?;
            if skin.is_some() {
                // Frames carry skinned positions and normals, not tangents.
                self.materials.drop_normal_map(material, "on a skinned mesh");
            }
            let mut triangles = Triangles::read(
                self.reader,
                primitive,
                mode,
                &label,
                uv,
                skin.is_some(),
                self.materials.has_normal_map(material),
                &mut self.warnings,
            )?;
            if triangles.indices.is_empty() {
                self.warnings.push(format!("{label}: no complete triangles; skipped"));
                continue;
            }
            let motion = if let Some(skin) = skin {
                let slot = self
                    .motion
                    .add_skinned(root, self.reader, skin, n, &triangles, &label)?;
                Motion::Skinned { slot }
            } else if animated {
                triangles.keep_front_faces(self.world[n]);
                let slot = *rigid_slot.get_or_insert_with(|| self.motion.add_rigid(n));
                Motion::Rigid { slot }
            } else {
                triangles.transform(self.world[n]);
                if !triangles.positions.iter().all(|p| p.is_finite()) {
                    return Err(input(format!("node {n}: non-finite world position in {label}")));
                }
                if let Some(p) = triangles
                    .positions
                    .iter()
                    .find(|p| p.abs().max_element() > MAX_WORLD_COORDINATE_M)
                {
                    return Err(input(format!(
                        "node {n}: {label} reaches world position [{:e}, {:e}, {:e}] m, beyond the \
                         ±{MAX_WORLD_COORDINATE_M:e} m capture supports (check the node's translation and scale)",
                        p.x, p.y, p.z
                    )));
                }
                Motion::Static
            };
            let name = if mesh.primitives.len() > 1 {
                format!("{mesh_name}/{p}")
            } else {
                mesh_name.clone()
            };
            self.tangents.push(triangles.tangents);
            self.meshes.push(Mesh {
                name,
                material,
                motion,
                positions: triangles.positions,
                normals: triangles.normals,
                uvs: triangles.uvs,
                indices: triangles.indices,
                patch_ids: Vec::new(),
                uv_atlas_unique: false,
            });
        }
        Ok(())
    }

    /// A KHR_lights_punctual light at its node's pose at t = 0. The first directional
    /// light in traversal order casts shadows.
    fn add_light(&mut self, n: usize, l: usize) -> Fallible<()> {
        let what = format!("light {l}");
        let light = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .and_then(|k| k.lights.get(l))
            .ok_or_else(|| input(format!("node {n} uses {what}, which does not exist")))?;
        let world = self.world[n];
        let position = world.w_axis.truncate();
        let direction = motion::rotation_of(world) * Vec3::NEG_Z;
        let kind = match valid(&light.type_, &what, "type")? {
            LightType::Directional => LightKind::Directional { direction },
            LightType::Point => LightKind::Point {
                position,
                range: light.range,
            },
            LightType::Spot => {
                let spot = light
                    .spot
                    .as_ref()
                    .ok_or_else(|| input(format!("{what} is a spot light without spot parameters")))?;
                if !(spot.inner_cone_angle.is_finite() && spot.outer_cone_angle.is_finite()) {
                    return Err(input(format!("{what} has non-finite cone angles")));
                }
                LightKind::Spot {
                    position,
                    direction,
                    inner_cone: spot.inner_cone_angle,
                    outer_cone: spot.outer_cone_angle,
                    range: light.range,
                }
            }
        };
        let color = Vec3::from_array(light.color);
        if !(color.is_finite() && light.intensity.is_finite() && light.range.is_none_or(f32::is_finite)) {
            return Err(input(format!("{what} has non-finite parameters")));
        }
        let directional = |kind: &LightKind| matches!(kind, LightKind::Directional { .. });
        let shadowed = directional(&kind) && !self.lights.iter().any(|l| directional(&l.kind));
        self.lights.push(Light {
            name: light.name.clone().unwrap_or(what),
            kind,
            color,
            intensity: light.intensity,
            shadowed,
        });
        Ok(())
    }

    fn add_camera(&mut self, n: usize, c: usize) -> Fallible<()> {
        let what = format!("camera {c}");
        let camera = self
            .root
            .cameras
            .get(c)
            .ok_or_else(|| input(format!("node {n} uses {what}, which does not exist")))?;
        let name = camera
            .name
            .clone()
            .or_else(|| self.root.nodes[n].name.clone())
            .unwrap_or_else(|| what.clone());
        match valid(&camera.type_, &what, "type")? {
            CameraType::Orthographic => {
                self.warnings.push(format!(
                    "{what} ({name}) is orthographic; skipped (only perspective cameras are supported)"
                ));
            }
            CameraType::Perspective => {
                let p = camera
                    .perspective
                    .as_ref()
                    .ok_or_else(|| input(format!("{what} is perspective but has no perspective parameters")))?;
                let valid_fov = p.yfov.is_finite() && p.yfov > 0.0 && p.yfov < std::f32::consts::PI;
                let valid_near = p.znear.is_finite() && p.znear > 0.0;
                let valid_far = p.zfar.is_none_or(|far| far.is_finite() && far > p.znear);
                if !(valid_fov && valid_near && valid_far) {
                    return Err(input(format!(
                        "{what} has invalid parameters (yfov {}, znear {}, zfar {:?})",
                        p.yfov, p.znear, p.zfar
                    )));
                }
                self.cameras.push(SourceCamera {
                    name,
                    yfov: p.yfov,
                    znear: p.znear,
                    zfar: p.zfar,
                });
                self.motion.add_camera(n);
            }
        }
        Ok(())
    }
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}
