//! What a scene source (a glTF file or a procedural generator) hands to capture: the
//! static scene, its cameras and how it moves. Capture then prunes, samples the camera
//! path and the motion per frame, and writes the trace.

use glam::Mat4;
use shadetrace_formats::{Pose, Scene, SkinnedVertices, Source};

/// Largest world coordinate, in metres, a scene may reach: beyond it f32 camera, depth
/// and raster maths lose all precision (and products overflow).
pub const MAX_WORLD_COORDINATE_M: f32 = 1e9;

/// A loaded scene before pruning and frame sampling.
pub struct SourceScene {
    pub name: String,
    pub source: Source,
    /// Meshes carry their [`shadetrace_formats::Motion`]; materials, textures and lights
    /// may include unused entries (capture drops them).
    pub scene: Scene,
    pub cameras: Vec<SourceCamera>,
    pub motion: Box<dyn SceneMotion>,
    /// Length of the longest animation in seconds (0 for a static scene).
    pub animation_duration_s: f32,
    /// Things skipped while loading, one line each (printed by the CLI).
    pub warnings: Vec<String>,
}

/// A perspective camera defined by the source (glTF cameras).
#[derive(Clone, Debug, PartialEq)]
pub struct SourceCamera {
    pub name: String,
    /// Vertical field of view, radians.
    pub yfov: f32,
    pub znear: f32,
    pub zfar: Option<f32>,
}

/// Everything that moves at a given time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameMotion {
    /// Mesh-to-world matrix per rigid slot.
    pub rigid_transforms: Vec<Mat4>,
    /// World-space skinned vertices per skinned slot.
    pub skinned: Vec<SkinnedVertices>,
}

/// Samples a source's animation. Must be deterministic: same time, same bits.
pub trait SceneMotion: Send + Sync {
    fn sample(&self, time_s: f32) -> FrameMotion;
    /// World pose of source camera `camera` at `time_s` (its node may be animated).
    fn camera_pose(&self, camera: usize, time_s: f32) -> Pose;
}

/// Motion of a scene where nothing moves and there are no cameras.
pub struct NoMotion;

impl SceneMotion for NoMotion {
    fn sample(&self, _time_s: f32) -> FrameMotion {
        FrameMotion::default()
    }

    fn camera_pose(&self, camera: usize, _time_s: f32) -> Pose {
        unreachable!("a static procedural scene has no camera {camera}")
    }
}
