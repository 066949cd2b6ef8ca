//! shadetrace-capture: turns glTF 2.0 files and built-in procedural scenes into traces.
//! It knows nothing of replay back-ends.

pub mod camera_path;
pub mod capture;
pub mod contained;
pub mod error;
pub mod gltf_import;
pub mod procedural;
pub mod prune;
pub mod source;
pub mod uv_atlas;

pub use camera_path::{CameraPathSpec, Flythrough, Orbit};
pub use capture::{capture, CaptureOptions, Captured, Input};
pub use error::{Error, Result};
pub use gltf_import::ImportLimits;
