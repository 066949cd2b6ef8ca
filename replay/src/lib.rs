//! shadetrace-replay: software models of shading pipelines replaying a trace.
//!
//! A back-end is a [`schedule::Scheduler`] times a [`scheme::ShadingScheme`], observed by
//! one memory model and one cost model; everything else (vertex stage, rasterizer, depth,
//! textures, shadows, shader) is shared so that numbers are comparable.

pub mod bins;
pub mod by_name;
pub mod command;
pub mod cost;
pub mod cost_table;
pub mod float;
pub mod geometry;
pub mod images;
pub mod lanes;
pub mod memory;
pub mod options;
pub mod pipeline;
pub mod preset;
pub mod quality;
pub mod raster;
pub mod run;
pub mod schedule;
pub mod scheme;
pub mod shader;
pub mod shadow;
pub mod srgb;
pub mod texture;
pub mod vertex_stage;

pub use options::ReplayOptions;
pub use preset::{Preset, PRESETS, REFERENCE_PRESET};
pub use run::{load_trace, replay_all, FrameImages, ImageSink, LoadedTrace, ReplayStep, RunOutput};
