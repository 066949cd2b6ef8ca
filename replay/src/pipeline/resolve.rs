//! Resolve: the samples of each pixel averaged in linear space and encoded sRGB.

use glam::Vec4;

use super::sample_buffer::{SampleBuffer, CLEAR_COLOR};
use super::Colors;
use crate::raster::Rect;
use crate::srgb::linear_to_srgb8;

/// A tile's final pixels (row-major in `rect`).
pub struct TileImage {
    pub view: u8,
    pub rect: Rect,
    /// Empty when the frame skips its colours.
    pub pixels: Vec<[u8; 4]>,
    /// Pixels with at least one sample covered by a surface.
    pub covered: u64,
}

pub fn resolve(buffer: &SampleBuffer, colors: Colors) -> TileImage {
    let samples = buffer.samples;
    let pixels = match colors {
        Colors::Kept => buffer
            .color
            .chunks_exact(samples)
            .map(|s| encode(s.iter().copied().sum::<Vec4>() / samples as f32))
            .collect(),
        Colors::Skipped => Vec::new(),
    };
    let covered = buffer.covered_pixels();
    TileImage {
        view: buffer.view,
        rect: buffer.rect,
        pixels,
        covered,
    }
}

/// The sRGB pixel of pixels nothing covers.
pub fn clear_pixel() -> [u8; 4] {
    encode(CLEAR_COLOR)
}

fn encode(c: Vec4) -> [u8; 4] {
    [linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z), 255]
}
