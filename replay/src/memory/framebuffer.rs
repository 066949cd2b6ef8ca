//! Where the render targets live in the memory model's address space: each in block-linear
//! lines of [`LINE_BYTES`], one address range per view; their caches hold whole tiles.

use super::LINE_BYTES;

/// A per-sample render target and its bytes per sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderTarget {
    /// f32 depth.
    Depth,
    /// RGBA32F colour.
    Color,
    /// A deferred scheme's G-buffer, depth included, as in Schied and Dachsbacher's
    /// comparison: albedo RGBA8 (4), triangle id (4), linear depth f32 (4), octahedral
    /// normal 2x16 bits (4), material id (4).
    GBuffer,
    /// The visibility buffer: triangle id and instance id (depth is the depth buffer's).
    Visibility,
}

impl RenderTarget {
    pub const fn bytes_per_sample(self) -> u32 {
        match self {
            RenderTarget::Depth => 4,
            RenderTarget::Color => 16,
            RenderTarget::GBuffer => 20,
            RenderTarget::Visibility => 8,
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub struct FramebufferLayout {
    width: u32,
    height: u32,
    samples: u32,
}

impl FramebufferLayout {
    pub fn new(width: u32, height: u32, samples: u32) -> FramebufferLayout {
        FramebufferLayout { width, height, samples }
    }

    /// Pixel block per line for `bytes_per_sample`: (block width, block height).
    fn block(&self, bytes_per_sample: u32) -> (u32, u32) {
        let pixels = (LINE_BYTES as u32 / (bytes_per_sample * self.samples)).max(1);
        let bh = 1u32 << (pixels.trailing_zeros() / 2);
        (pixels / bh, bh)
    }

    /// The line of `target` holding pixel (x, y) of `view`.
    pub fn line(&self, target: RenderTarget, view: u8, x: u32, y: u32) -> u64 {
        let (bw, bh) = self.block(target.bytes_per_sample());
        let per_row = self.width.div_ceil(bw) as u64;
        let per_view = per_row * self.height.div_ceil(bh) as u64;
        view as u64 * per_view + (y / bh) as u64 * per_row + (x / bw) as u64
    }

    pub fn depth_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(RenderTarget::Depth, view, x, y)
    }

    pub fn color_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(RenderTarget::Color, view, x, y)
    }

    /// Bytes of `target` for one view.
    pub fn bytes(&self, target: RenderTarget) -> u64 {
        u64::from(self.width) * u64::from(self.height) * u64::from(self.samples) * u64::from(target.bytes_per_sample())
    }

    /// Bytes of a cache of `target` holding `tiles` tiles of `tile`² pixels.
    pub fn cache_bytes(&self, target: RenderTarget, tile: u32, tiles: u32) -> u64 {
        u64::from(tile * tile * target.bytes_per_sample() * self.samples * tiles)
    }
}
