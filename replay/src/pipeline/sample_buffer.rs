//! The samples of a rectangle of one view: depth, primitive id, setup-triangle id and linear
//! colour per sample, plus the farthest depth used to cull whole units. Jobs own the tiles
//! their units touch (a tile's on-chip buffers); tile passes read the finished samples, and
//! view passes get the whole view as one buffer.

use glam::Vec4;

use crate::raster::Rect;

/// Linear colour of samples no triangle covers.
pub const CLEAR_COLOR: Vec4 = Vec4::new(0.05, 0.06, 0.08, 1.0);
/// Primitive and setup ids of samples no triangle covers.
pub const NO_PRIMITIVE: u32 = u32::MAX;

/// Per-sample buffers of a rectangle (a tile, or a whole view) of one view, `samples`
/// consecutive entries per pixel, pixels row-major inside `rect`.
#[derive(Clone)]
pub struct SampleBuffer {
    pub view: u8,
    pub rect: Rect,
    pub samples: usize,
    pub depth: Vec<f32>,
    /// Primitive id of the visible surface (the depth test's tie-breaker).
    pub prim: Vec<u32>,
    /// Index of the visible surface's setup triangle in its view (the visibility id).
    pub tri: Vec<u32>,
    pub color: Vec<Vec4>,
    /// Per pixel: whether a blended fragment wrote its colour (blending leaves no id).
    pub blended: Vec<bool>,
    /// Farthest depth of any sample: a unit whose nearest depth lies behind it is culled
    /// whole (one bound per tile, recomputed after every unit that writes depth).
    pub max_depth: f32,
}

/// A buffer's depth, primitive and setup ids as slices, with its shape: a loop that tests
/// and writes them through these does not reload the buffer's fields after every write, as
/// it must through the buffer (a store could change them, as far as the compiler knows).
pub struct DepthTargets<'a> {
    rect: Rect,
    samples: usize,
    pub depth: &'a mut [f32],
    pub prim: &'a mut [u32],
    tri: &'a mut [u32],
}

impl DepthTargets<'_> {
    /// [`SampleBuffer::index`].
    #[inline]
    pub fn index(&self, x: u32, y: u32, s: usize) -> usize {
        sample_index(self.rect, self.samples, x, y, s)
    }

    /// [`SampleBuffer::write_depth`].
    #[inline]
    pub fn write(&mut self, i: usize, z: f32, prim: u32, tri: u32) {
        self.depth[i] = z;
        self.prim[i] = prim;
        self.tri[i] = tri;
    }
}

/// Index of sample `s` of pixel (x, y) of `rect`, row-major, `samples` per pixel.
#[inline]
fn sample_index(rect: Rect, samples: usize, x: u32, y: u32, s: usize) -> usize {
    (((y - rect.y0) * (rect.x1 - rect.x0) + (x - rect.x0)) as usize) * samples + s
}

impl SampleBuffer {
    pub fn new(view: u8, rect: Rect, samples: usize) -> SampleBuffer {
        let mut buffer = SampleBuffer {
            view,
            rect,
            samples,
            depth: Vec::new(),
            prim: Vec::new(),
            tri: Vec::new(),
            color: Vec::new(),
            blended: Vec::new(),
            max_depth: 1.0,
        };
        buffer.reset(view, rect, samples);
        buffer
    }

    /// The buffer cleared for another tile, as [`Self::new`] makes it, its allocations kept.
    pub fn reset(&mut self, view: u8, rect: Rect, samples: usize) {
        let n = ((rect.x1 - rect.x0) * (rect.y1 - rect.y0)) as usize * samples;
        fn refill<T: Clone>(v: &mut Vec<T>, n: usize, value: T) {
            v.clear();
            v.resize(n, value);
        }
        (self.view, self.rect, self.samples, self.max_depth) = (view, rect, samples, 1.0);
        refill(&mut self.depth, n, 1.0);
        refill(&mut self.prim, n, NO_PRIMITIVE);
        refill(&mut self.tri, n, NO_PRIMITIVE);
        refill(&mut self.color, n, CLEAR_COLOR);
        refill(&mut self.blended, n / samples, false);
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        self.rect.x1 - self.rect.x0
    }

    pub fn height(&self) -> u32 {
        self.rect.y1 - self.rect.y0
    }

    /// Index of sample `s` of pixel (x, y), in the rectangle's row-major order.
    #[inline]
    pub fn index(&self, x: u32, y: u32, s: usize) -> usize {
        sample_index(self.rect, self.samples, x, y, s)
    }

    /// Records the visible surface of a sample.
    #[inline]
    pub fn write_depth(&mut self, i: usize, z: f32, prim: u32, tri: u32) {
        self.depth_targets().write(i, z, prim, tri);
    }

    /// The depth test's targets, borrowed apart from the buffer.
    #[inline]
    pub fn depth_targets(&mut self) -> DepthTargets<'_> {
        DepthTargets {
            rect: self.rect,
            samples: self.samples,
            depth: &mut self.depth,
            prim: &mut self.prim,
            tri: &mut self.tri,
        }
    }

    /// Whether any surface covers a sample of the pixel whose samples start at `first`.
    pub fn covered(&self, first: usize) -> bool {
        self.blended[first / self.samples]
            || self.prim[first..first + self.samples]
                .iter()
                .any(|&p| p != NO_PRIMITIVE)
    }

    /// How many pixels a surface covers ([`Self::covered`]); one sample per pixel (the usual
    /// case) is each pixel's own test, without a loop over its samples.
    pub fn covered_pixels(&self) -> u64 {
        let pixels = self.blended.len();
        let count = match self.samples {
            1 => (self.blended.iter().zip(&self.prim))
                .filter(|&(&blended, &prim)| blended || prim != NO_PRIMITIVE)
                .count(),
            samples => (0..pixels).filter(|&p| self.covered(p * samples)).count(),
        };
        count as u64
    }

    /// Eight running maxima, each a compare and select (one SIMD `max` instruction), so
    /// that the scan runs four or eight samples at a time: a fold through `f32::max` is one
    /// chain of dependent steps, each with a NaN check. The order changes at most the sign
    /// of a zero maximum, which the cull's `>` does not see; a NaN (never written) loses
    /// every comparison, so it is skipped as `max` skips it. Not inlined: it runs once per
    /// unit, and its loops would crowd the per-quad code it is called beside.
    #[inline(never)]
    pub fn update_max_depth(&mut self) {
        let larger = |m: f32, d: f32| if d > m { d } else { m };
        let mut lanes = [0.0f32; 8];
        let chunks = self.depth.chunks_exact(lanes.len());
        let rest = chunks.remainder();
        for chunk in chunks {
            for (m, &d) in lanes.iter_mut().zip(chunk) {
                *m = larger(*m, d);
            }
        }
        self.max_depth = lanes.into_iter().chain(rest.iter().copied()).fold(0.0, larger);
    }
}

/// Depth test with order-independent ties: the lower primitive id wins, as LESS does in
/// submission order.
#[inline]
pub fn depth_passes(z: f32, prim: u32, buf_z: f32, buf_prim: u32) -> bool {
    z < buf_z || (z == buf_z && prim < buf_prim)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A buffer reset for another tile is the one `new` makes for it, whatever it held and
    /// whether it was larger or smaller.
    #[test]
    fn a_reset_buffer_is_a_new_one() {
        let small = Rect {
            x0: 16,
            y0: 0,
            x1: 32,
            y1: 16,
        };
        let large = Rect {
            x0: 0,
            y0: 32,
            x1: 64,
            y1: 40,
        };
        let mut buffer = SampleBuffer::new(1, large, 4);
        for (view, rect, samples) in [(0, small, 1), (1, large, 8), (0, small, 4)] {
            buffer.depth.fill(0.25);
            buffer.prim.fill(3);
            buffer.tri.fill(7);
            buffer.color.fill(Vec4::ONE);
            buffer.blended.fill(true);
            buffer.max_depth = 0.5;
            buffer.reset(view, rect, samples);
            let new = SampleBuffer::new(view, rect, samples);
            assert_eq!(
                (buffer.view, buffer.rect, buffer.samples),
                (new.view, new.rect, new.samples)
            );
            assert_eq!(
                (&buffer.depth, &buffer.prim, &buffer.tri),
                (&new.depth, &new.prim, &new.tri)
            );
            assert_eq!((&buffer.color, &buffer.blended), (&new.color, &new.blended));
            assert_eq!(buffer.max_depth.to_bits(), new.max_depth.to_bits());
        }
    }

    proptest! {
        /// The covered pixels counted at once are those [`SampleBuffer::covered`] finds one
        /// by one, at one sample per pixel and at four.
        #[test]
        fn covered_pixels_are_counted_as_each_pixel_is_tested(
            samples in prop_oneof![Just(1usize), Just(4)],
            pixels in prop::collection::vec((any::<bool>(), prop::array::uniform4(any::<bool>())), 0..40),
        ) {
            let rect = Rect { x0: 0, y0: 0, x1: pixels.len() as u32, y1: 1 };
            let mut buffer = SampleBuffer::new(0, rect, samples);
            for (p, &(blended, drawn)) in pixels.iter().enumerate() {
                buffer.blended[p] = blended;
                for (prim, &drawn) in buffer.prim[p * samples..][..samples].iter_mut().zip(&drawn) {
                    *prim = if drawn { p as u32 } else { NO_PRIMITIVE };
                }
            }
            let one_by_one = (0..pixels.len()).filter(|&p| buffer.covered(p * samples)).count() as u64;
            prop_assert_eq!(buffer.covered_pixels(), one_by_one);
        }

        /// The eight-lane scan finds the value `fold(0.0, f32::max)` finds, over any number
        /// of samples (a remainder too), with NaN, both zeros and negative depths among them.
        #[test]
        fn max_depth_is_the_folded_maximum(
            depth in prop::collection::vec(
                prop_oneof![-2.0f32..2.0, Just(0.0), Just(-0.0), Just(f32::NAN), Just(1.0)],
                0..80,
            ),
        ) {
            let rect = Rect { x0: 0, y0: 0, x1: depth.len() as u32, y1: 1 };
            let mut buffer = SampleBuffer::new(0, rect, 1);
            buffer.depth.copy_from_slice(&depth);
            buffer.update_max_depth();
            let folded = depth.iter().copied().fold(0.0f32, f32::max);
            prop_assert_eq!(buffer.max_depth, folded, "{:?}", depth);
        }
    }
}
