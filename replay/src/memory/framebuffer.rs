//! Where the framebuffer lives in the memory model's address space: depth (4 bytes per
//! sample) and colour (RGBA32F, 16 bytes per sample) in block-linear lines of
//! [`LINE_BYTES`], one address range per view; the depth and colour caches hold whole tiles.

use super::LINE_BYTES;

/// Bytes per visibility-buffer sample: triangle id and instance id (depth is the depth
/// buffer's).
pub const VISIBILITY_SAMPLE_BYTES: u32 = 8;

/// Bytes per G-buffer sample, depth included, as in Schied and Dachsbacher's comparison:
/// albedo RGBA8 (4), triangle id (4), linear depth f32 (4), octahedral normal 2x16 bits (4),
/// material id (4).
pub const GBUFFER_SAMPLE_BYTES: u32 = 20;

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

    fn line(&self, view: u8, x: u32, y: u32, bytes_per_sample: u32) -> u64 {
        let (bw, bh) = self.block(bytes_per_sample);
        let per_row = self.width.div_ceil(bw) as u64;
        let per_view = per_row * self.height.div_ceil(bh) as u64;
        view as u64 * per_view + (y / bh) as u64 * per_row + (x / bw) as u64
    }

    pub fn depth_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(view, x, y, 4)
    }

    pub fn color_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(view, x, y, 16)
    }

    /// A deferred scheme's G-buffer sample (albedo, triangle id, linear depth, normal,
    /// material id: [`GBUFFER_SAMPLE_BYTES`]), in its own address range.
    pub fn gbuffer_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(view, x, y, GBUFFER_SAMPLE_BYTES)
    }

    /// Bytes of the G-buffer of one view.
    pub fn gbuffer_bytes(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height) * u64::from(self.samples) * u64::from(GBUFFER_SAMPLE_BYTES)
    }

    /// Bytes of a G-buffer cache holding `tiles` tiles of `tile`² pixels.
    pub fn gbuffer_cache_bytes(&self, tile: u32, tiles: u32) -> u64 {
        (tile * tile * GBUFFER_SAMPLE_BYTES * self.samples * tiles) as u64
    }

    /// A visibility-buffer sample ([`VISIBILITY_SAMPLE_BYTES`]), in its own address range.
    pub fn visibility_line(&self, view: u8, x: u32, y: u32) -> u64 {
        self.line(view, x, y, VISIBILITY_SAMPLE_BYTES)
    }

    /// Bytes of the visibility buffer of one view.
    pub fn visibility_bytes(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height) * u64::from(self.samples) * u64::from(VISIBILITY_SAMPLE_BYTES)
    }

    /// Bytes of a visibility-buffer cache holding `tiles` tiles of `tile`² pixels.
    pub fn visibility_cache_bytes(&self, tile: u32, tiles: u32) -> u64 {
        (tile * tile * VISIBILITY_SAMPLE_BYTES * self.samples * tiles) as u64
    }

    /// Bytes of a depth cache holding `tiles` tiles of `tile`² pixels.
    pub fn depth_cache_bytes(&self, tile: u32, tiles: u32) -> u64 {
        (tile * tile * 4 * self.samples * tiles) as u64
    }

    /// Bytes of a colour cache holding `tiles` tiles of `tile`² pixels.
    pub fn color_cache_bytes(&self, tile: u32, tiles: u32) -> u64 {
        (tile * tile * 16 * self.samples * tiles) as u64
    }
}
