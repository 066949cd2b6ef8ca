//! Where the render targets live in the memory model's address space: each in block-linear
//! lines of [`LINE_BYTES`], one address range per view; their caches hold whole tiles.

use super::LINE_BYTES;

/// A render target and its bytes per sample (per pixel for [`RenderTarget::ListHeads`]).
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
    /// Deferred attribute interpolation's visibility samples: a 24-bit triangle-buffer
    /// reference and the triangle's 8-bit coverage mask in the pixel.
    TriangleRefs,
    /// Its multi-rate variant's reference to each sample's shading sample.
    ShadingRefs,
    /// Its linked-list variant's 32-bit list head per pixel.
    ListHeads,
}

impl RenderTarget {
    pub const fn bytes_per_sample(self) -> u32 {
        match self {
            RenderTarget::Depth => 4,
            RenderTarget::Color => 16,
            RenderTarget::GBuffer => 20,
            RenderTarget::Visibility => 8,
            RenderTarget::TriangleRefs | RenderTarget::ShadingRefs | RenderTarget::ListHeads => 4,
        }
    }

    /// Whether the target stores one value per pixel rather than per sample.
    const fn per_pixel(self) -> bool {
        matches!(self, RenderTarget::ListHeads)
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

    fn samples_of(&self, target: RenderTarget) -> u32 {
        if target.per_pixel() {
            1
        } else {
            self.samples
        }
    }

    /// Pixel block per line of `target`: (block width, block height).
    fn block(&self, target: RenderTarget) -> (u32, u32) {
        let pixels = (LINE_BYTES as u32 / (target.bytes_per_sample() * self.samples_of(target))).max(1);
        let bh = 1u32 << (pixels.trailing_zeros() / 2);
        (pixels / bh, bh)
    }

    /// The line of `target` holding pixel (x, y) of `view`.
    pub fn line(&self, target: RenderTarget, view: u8, x: u32, y: u32) -> u64 {
        let (bw, bh) = self.block(target);
        let per_row = self.width.div_ceil(bw) as u64;
        let per_view = per_row * self.height.div_ceil(bh) as u64;
        view as u64 * per_view + (y / bh) as u64 * per_row + (x / bw) as u64
    }

    /// Lines of `target` over both views: where a second target sharing its stream starts.
    pub fn lines(&self, target: RenderTarget) -> u64 {
        let (bw, bh) = self.block(target);
        2 * self.width.div_ceil(bw) as u64 * self.height.div_ceil(bh) as u64
    }

    pub fn depth_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(RenderTarget::Depth, view, x, y)
    }

    pub fn color_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(RenderTarget::Color, view, x, y)
    }

    /// Bytes of `target` for one view.
    pub fn bytes(&self, target: RenderTarget) -> u64 {
        u64::from(self.width)
            * u64::from(self.height)
            * u64::from(self.samples_of(target))
            * u64::from(target.bytes_per_sample())
    }

    /// Bytes of a cache of `target` holding `tiles` tiles of `tile`² pixels.
    pub fn cache_bytes(&self, target: RenderTarget, tile: u32, tiles: u32) -> u64 {
        u64::from(tile * tile * target.bytes_per_sample() * self.samples_of(target) * tiles)
    }
}
