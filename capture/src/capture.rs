//! The capture pipeline: load a source, prune it, sample motion and the camera path per
//! frame, derive feature flags and bounds, and produce the trace's chunks.

use std::io::Write;
use std::path::PathBuf;

use glam::Vec3;
use shadetrace_formats::rig::{DEFAULT_EYE_HEIGHT, DEFAULT_EYE_WIDTH, DEFAULT_IPD_M};
use shadetrace_formats::{
    validate, Aabb, AlphaMode, CaptureSettings, ContentHash, Feature, Features, Frame, Light, LightKind, Meta, Motion,
    Pose, Scene, StereoRig, TraceWriter,
};

use crate::camera_path::{main_floor, CameraPathSpec, Flythrough, Orbit, Walk};
use crate::error::{Error, Result};
use crate::gltf_import::{load_gltf, ImportLimits, ImportOptions};
use crate::procedural;
use crate::prune::prune;
use crate::source::{FrameMotion, MAX_WORLD_COORDINATE_M};
use crate::uv_atlas::has_unique_uv_atlas;

/// What to capture: a built-in scene (`builtin:NAME[?k=v]`) or a glTF file.
#[derive(Clone, Debug, PartialEq)]
pub enum Input {
    Builtin(String),
    File(PathBuf),
}

impl Input {
    pub fn parse(s: &str) -> Input {
        match s.strip_prefix("builtin:") {
            Some(spec) => Input::Builtin(spec.to_string()),
            None => Input::File(PathBuf::from(s)),
        }
    }
}

impl std::fmt::Display for Input {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Input::Builtin(spec) => write!(f, "builtin:{spec}"),
            Input::File(path) => write!(f, "{}", path.display()),
        }
    }
}

/// Capture options; the defaults are the tile-pair paper's setup.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureOptions {
    pub frames: u32,
    pub path: CameraPathSpec,
    pub ipd_m: f32,
    pub eye_width: u32,
    pub eye_height: u32,
    /// Vertical field of view; `None` takes the source camera's, the flythrough's or 90°.
    pub yfov_deg: Option<f32>,
    /// Zero-parallax distance of the off-axis frusta.
    pub convergence_m: f32,
    /// Near plane; `None` takes the source camera's znear or 5 cm.
    pub near_m: Option<f32>,
    pub max_texture: u32,
    /// Frames per second at which animation is sampled (orbit and camera paths).
    pub fps: f32,
    /// How much a glTF import may decode (geometry in all, and each image).
    pub import_limits: ImportLimits,
}

impl Default for CaptureOptions {
    fn default() -> Self {
        CaptureOptions {
            frames: 1,
            path: CameraPathSpec::Orbit,
            ipd_m: DEFAULT_IPD_M,
            eye_width: DEFAULT_EYE_WIDTH,
            eye_height: DEFAULT_EYE_HEIGHT,
            yfov_deg: None,
            convergence_m: 2.0,
            near_m: None,
            max_texture: 1024,
            fps: 30.0,
            import_limits: ImportLimits::default(),
        }
    }
}

const DEFAULT_YFOV_DEG: f32 = 90.0;
const DEFAULT_NEAR_M: f32 = 0.05;
/// Largest per-eye edge accepted (16K).
const MAX_EYE_EDGE: u32 = 16384;

impl CaptureOptions {
    fn check(&self) -> Result<()> {
        let bad = |msg: String| Err(Error::Options(msg));
        if self.frames == 0 {
            return bad("--frames must be at least 1".into());
        }
        if !(self.ipd_m.is_finite() && self.ipd_m >= 0.0) {
            return bad(format!(
                "--ipd {} must be a finite, non-negative distance in metres",
                self.ipd_m
            ));
        }
        if !(1..=MAX_EYE_EDGE).contains(&self.eye_width) || !(1..=MAX_EYE_EDGE).contains(&self.eye_height) {
            return bad(format!(
                "--res {}x{}: each edge must be 1..={MAX_EYE_EDGE}",
                self.eye_width, self.eye_height
            ));
        }
        if let Some(fov) = self.yfov_deg {
            if !(fov > 0.0 && fov < 180.0) {
                return bad(format!("--fov {fov} must be in (0, 180) degrees"));
            }
        }
        if !(self.convergence_m.is_finite() && self.convergence_m > 0.0) {
            return bad(format!(
                "--convergence {} must be a positive distance",
                self.convergence_m
            ));
        }
        if let Some(near) = self.near_m {
            if !(near.is_finite() && near > 0.0) {
                return bad(format!("--near {near} must be a positive distance"));
            }
        }
        if self.max_texture == 0 {
            return bad("--max-texture must be at least 1".into());
        }
        if !(self.fps.is_finite() && self.fps > 0.0) {
            return bad(format!("--fps {} must be positive", self.fps));
        }
        Ok(())
    }
}

/// A captured trace held in memory, ready to be written.
#[derive(Clone, Debug, PartialEq)]
pub struct Captured {
    pub meta: Meta,
    pub scene: Scene,
    pub frames: Vec<Frame>,
    /// What the source loader skipped, one line each.
    pub warnings: Vec<String>,
}

impl Captured {
    /// Writes the trace to `out` at zstd `level`; returns the sink and the content hash.
    pub fn write<W: Write>(&self, out: W, level: i32) -> Result<(W, ContentHash)> {
        let mut writer = TraceWriter::new(out, level, &self.meta, &self.scene)?;
        for frame in &self.frames {
            writer.write_frame(frame)?;
        }
        Ok(writer.finish()?)
    }
}

/// Captures `input`; `progress(done, total)` is called after each frame is sampled.
pub fn capture(input: &Input, opts: &CaptureOptions, progress: &mut dyn FnMut(u32, u32)) -> Result<Captured> {
    opts.check()?;
    let (mut source, orbit) = match input {
        Input::Builtin(spec) => {
            let (source, orbit) = procedural::build(spec)?;
            (source, Some(orbit))
        }
        Input::File(path) => (
            load_gltf(
                path,
                &ImportOptions {
                    max_texture: opts.max_texture,
                    limits: opts.import_limits,
                },
            )?,
            None,
        ),
    };
    prune(&mut source.scene);
    validate::check_scene(&source.scene, &source.scene.counts(opts.frames))?;
    if source.scene.lights.is_empty() && matches!(input, Input::File(_)) {
        source.scene.lights.push(default_sun());
    }
    for mesh in &mut source.scene.geometry.meshes {
        mesh.uv_atlas_unique = has_unique_uv_atlas(mesh);
    }

    let flythrough = match &opts.path {
        CameraPathSpec::Flythrough(path) => Some(Flythrough::load(path)?),
        _ => None,
    };
    let camera = match opts.path {
        CameraPathSpec::SourceCamera(n) => Some(source.cameras.get(n).cloned().ok_or_else(|| {
            Error::Options(format!(
                "--path camera:{n}: {} has {} camera(s)",
                source.name,
                source.cameras.len()
            ))
        })?),
        _ => None,
    };

    let times: Vec<f32> = (0..opts.frames)
        .map(|i| match &flythrough {
            Some(fly) if opts.frames > 1 => fly.start_time() + fly.duration() * i as f32 / (opts.frames - 1) as f32,
            Some(fly) => fly.start_time(),
            None => i as f32 / opts.fps,
        })
        .collect();
    let motions: Vec<FrameMotion> = times.iter().map(|&t| source.motion.sample(t)).collect();
    let bounds = scene_bounds(&source.scene, &motions);
    // Animation can carry geometry where import's static check cannot see it.
    let reach = bounds.min.abs().max(bounds.max.abs()).max_element();
    if !bounds.is_empty() && (reach.is_nan() || reach > MAX_WORLD_COORDINATE_M) {
        return Err(Error::input(
            input,
            format!(
                "geometry reaches {reach:e} m from the origin over the captured frames, beyond the \
                 ±{MAX_WORLD_COORDINATE_M:e} m capture supports (an animated node or skin)"
            ),
        ));
    }
    let orbit = orbit.unwrap_or_else(|| Orbit::around(&bounds));
    let walk = Walk::inside(&bounds, main_floor(&source.scene));

    let yfov_deg = opts
        .yfov_deg
        .or(flythrough.as_ref().and_then(|f| f.fov_deg))
        .or(camera.as_ref().map(|c| c.yfov.to_degrees()))
        .unwrap_or(DEFAULT_YFOV_DEG);
    let near = opts
        .near_m
        .or(camera.as_ref().map(|c| c.znear).filter(|z| z.is_finite() && *z > 0.0))
        .unwrap_or(DEFAULT_NEAR_M);

    let mut frames = Vec::with_capacity(opts.frames as usize);
    for (i, (motion, &time_s)) in motions.into_iter().zip(&times).enumerate() {
        let index = i as u32;
        let head = match (&opts.path, &flythrough) {
            (_, Some(fly)) => fly.pose_at(time_s),
            (CameraPathSpec::SourceCamera(n), _) => source.motion.camera_pose(*n, time_s),
            (CameraPathSpec::Walk, _) => walk.pose(index, opts.frames),
            _ => orbit.pose(index, opts.frames),
        };
        frames.push(Frame {
            index,
            time_s,
            rig: StereoRig {
                head,
                ipd_m: opts.ipd_m,
                eye_width: opts.eye_width,
                eye_height: opts.eye_height,
                yfov: yfov_deg.to_radians(),
                near,
                far: far_plane(&head, &bounds, near),
                convergence_m: opts.convergence_m,
            },
            rigid_transforms: motion.rigid_transforms,
            skinned: motion.skinned,
        });
        progress(index + 1, opts.frames);
    }
    // Checked here, not when the trace is written, so that the error names the input.
    let counts = source.scene.counts(opts.frames);
    for frame in &frames {
        validate::check_frame(frame, &counts).map_err(|e| {
            let detail = match e {
                shadetrace_formats::Error::Invalid(msg) => msg,
                other => other.to_string(),
            };
            Error::input(
                input,
                format!("{detail}, from the scene and camera path {}", opts.path.describe()),
            )
        })?;
    }

    let meta = Meta {
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        scene_name: source.name.clone(),
        source: source.source.clone(),
        capture: CaptureSettings {
            frames: opts.frames,
            camera_path: opts.path.describe(),
            ipd_m: opts.ipd_m,
            eye_width: opts.eye_width,
            eye_height: opts.eye_height,
            max_texture: opts.max_texture,
            fps: opts.fps,
        },
        features: features(&source.scene),
        counts: source.scene.counts(opts.frames),
        bounds,
    };
    Ok(Captured {
        meta,
        scene: source.scene,
        frames,
        warnings: source.warnings,
    })
}

/// The sun added to a file without lights: shadowed, from 50° above the -x/-z quadrant.
/// Replay fits the shadow map to the scene bounds.
fn default_sun() -> Light {
    let elevation = 50f32.to_radians();
    let azimuth = 35f32.to_radians();
    let towards_sun = Vec3::new(
        -libm::cosf(elevation) * libm::sinf(azimuth),
        libm::sinf(elevation),
        -libm::cosf(elevation) * libm::cosf(azimuth),
    );
    Light {
        name: "default-sun".into(),
        kind: LightKind::Directional {
            direction: -towards_sun,
        },
        color: Vec3::ONE,
        intensity: 3.0,
        shadowed: true,
    }
}

/// World bounds of everything, over all frames.
fn scene_bounds(scene: &Scene, motions: &[FrameMotion]) -> Aabb {
    let mut bounds = Aabb::EMPTY;
    for mesh in &scene.geometry.meshes {
        match mesh.motion {
            Motion::Static => mesh.positions.iter().for_each(|&p| bounds.grow(p)),
            Motion::Rigid { slot } => {
                for motion in motions {
                    if let Some(m) = motion.rigid_transforms.get(slot as usize) {
                        mesh.positions.iter().for_each(|&p| bounds.grow(m.transform_point3(p)));
                    }
                }
            }
            Motion::Skinned { slot } => {
                for motion in motions {
                    if let Some(s) = motion.skinned.get(slot as usize) {
                        s.positions.iter().for_each(|&p| bounds.grow(p));
                    }
                }
            }
        }
    }
    bounds
}

/// A far plane just beyond the farthest corner of the bounds.
fn far_plane(head: &Pose, bounds: &Aabb, near: f32) -> f32 {
    if bounds.is_empty() {
        return near * 1000.0;
    }
    let corners = (0..8).map(|i| {
        Vec3::new(
            if i & 1 == 0 { bounds.min.x } else { bounds.max.x },
            if i & 2 == 0 { bounds.min.y } else { bounds.max.y },
            if i & 4 == 0 { bounds.min.z } else { bounds.max.z },
        )
    });
    let farthest = corners.map(|c| (c - head.position).length()).fold(0.0, f32::max);
    (farthest * 1.05).max(near * 2.0)
}

/// What the (pruned) scene requires.
fn features(scene: &Scene) -> Features {
    let mut f = Features::NONE;
    let meshes = &scene.geometry.meshes;
    if !scene.textures.is_empty() {
        f.insert(Feature::Textures);
    }
    if !scene.surface_maps.is_empty() {
        f.insert(Feature::SurfaceMaps);
    }
    let shadowed = scene.lights.iter().filter(|l| l.shadowed).count();
    if shadowed > 0 {
        f.insert(Feature::ShadowedLight);
    }
    if scene.lights.len() > shadowed {
        f.insert(Feature::ExtraLights);
    }
    for m in &scene.materials {
        match m.alpha {
            AlphaMode::Mask { .. } => f.insert(Feature::AlphaMask),
            AlphaMode::Blend => f.insert(Feature::AlphaBlend),
            AlphaMode::Opaque => {}
        }
    }
    if meshes.iter().any(|m| matches!(m.motion, Motion::Rigid { .. })) {
        f.insert(Feature::Animation);
    }
    if meshes.iter().any(|m| matches!(m.motion, Motion::Skinned { .. })) {
        f.insert(Feature::Skinning);
    }
    if meshes.iter().any(|m| !m.patch_ids.is_empty()) {
        f.insert(Feature::PatchIds);
    }
    let mut textured = meshes.iter().filter(|m| !m.uvs.is_empty()).peekable();
    if textured.peek().is_some() && textured.all(|m| m.uv_atlas_unique) {
        f.insert(Feature::UniqueUvAtlas);
    }
    f
}
