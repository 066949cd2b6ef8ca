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

const TARGETS: [RenderTarget; 7] = [
    RenderTarget::Depth,
    RenderTarget::Color,
    RenderTarget::GBuffer,
    RenderTarget::Visibility,
    RenderTarget::TriangleRefs,
    RenderTarget::ShadingRefs,
    RenderTarget::ListHeads,
];

#[derive(Clone, Copy, Debug)]
pub struct FramebufferLayout {
    width: u32,
    height: u32,
    samples: u32,
    /// Each target's line geometry, in [`TARGETS`] order, worked out once: [`Self::line`]
    /// runs for every sample a pass touches.
    geometry: [LineGeometry; TARGETS.len()],
}

/// How a target's pixels map to its lines.
#[derive(Clone, Copy, Debug)]
struct LineGeometry {
    /// Block width in pixels, and its log2 when a power of two (a shift, not a division).
    block_width: u32,
    width_shift: Option<u32>,
    /// Block height in pixels: always a power of two.
    height_shift: u32,
    per_row: u64,
    per_view: u64,
}

impl FramebufferLayout {
    pub fn new(width: u32, height: u32, samples: u32) -> FramebufferLayout {
        let mut layout = FramebufferLayout {
            width,
            height,
            samples,
            geometry: [LineGeometry {
                block_width: 1,
                width_shift: Some(0),
                height_shift: 0,
                per_row: 0,
                per_view: 0,
            }; TARGETS.len()],
        };
        layout.geometry = TARGETS.map(|target| {
            let (bw, bh) = layout.block(target);
            debug_assert!(bh.is_power_of_two());
            let per_row = width.div_ceil(bw) as u64;
            LineGeometry {
                block_width: bw,
                width_shift: bw.is_power_of_two().then(|| bw.trailing_zeros()),
                height_shift: bh.trailing_zeros(),
                per_row,
                per_view: per_row * height.div_ceil(bh) as u64,
            }
        });
        layout
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
    #[inline]
    pub fn line(&self, target: RenderTarget, view: u8, x: u32, y: u32) -> u64 {
        let g = &self.geometry[target as usize];
        let column = match g.width_shift {
            Some(shift) => x >> shift,
            None => x / g.block_width,
        };
        view as u64 * g.per_view + (y >> g.height_shift) as u64 * g.per_row + column as u64
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The geometry worked out once gives every target's lines as the block shape says,
    /// with and without multisampling, on views whose edges the blocks do not divide.
    #[test]
    fn lines_follow_each_targets_blocks() {
        for (i, &target) in TARGETS.iter().enumerate() {
            assert_eq!(target as usize, i, "{target:?}");
        }
        for samples in [1, 2, 4, 8] {
            let layout = FramebufferLayout::new(70, 45, samples);
            for target in TARGETS {
                let (bw, bh) = layout.block(target);
                let per_row = u64::from(70u32.div_ceil(bw));
                let per_view = per_row * u64::from(45u32.div_ceil(bh));
                for (view, x, y) in [(0u8, 0u32, 0u32), (1, 69, 44), (0, 13, 7), (1, 36, 21)] {
                    let expected = u64::from(view) * per_view + u64::from(y / bh) * per_row + u64::from(x / bw);
                    assert_eq!(
                        layout.line(target, view, x, y),
                        expected,
                        "{target:?} x{samples} ({x}, {y})"
                    );
                }
            }
        }
    }
}
