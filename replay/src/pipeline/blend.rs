//! Output merge of a shaded unit: alpha test with late depth write, blending, opaque writes,
//! and the colour accesses they make.

use glam::Vec4;
use shadetrace_formats::AlphaMode;

use super::sample_buffer::{depth_passes, SampleBuffer};
use crate::memory::{AccessLog, FramebufferLayout, Stream};
use crate::raster::sample_position;
use crate::scheme::ShadeQuad;
use crate::vertex_stage::SetupTriangle;
use shadetrace_formats::results::RasterStats;

/// What one unit's shaded quads write: `quads` pairs each quad with its passing-sample
/// mask, `colors` holds the scheme's four lane colours per quad.
pub struct MergeInput<'a> {
    pub view: u8,
    pub tri: u32,
    pub setup: &'a SetupTriangle,
    pub alpha: AlphaMode,
    pub offsets: &'a [[i64; 2]],
    pub quads: &'a [(ShadeQuad, u32)],
    pub colors: &'a [[Vec4; 4]],
}

/// Returns whether a depth was written (alpha-tested fragments write late). Kept out of
/// line: inlined into `run_job` (which the compiler decides from unrelated code) it costs
/// every replay about 0.4% more instructions.
#[inline(never)]
pub fn merge(
    input: &MergeInput,
    buffer: &mut SampleBuffer,
    layout: &FramebufferLayout,
    raster: &mut RasterStats,
    log: &mut AccessLog,
) -> bool {
    // The mode is the triangle's: chosen once, so each fragment runs only its own write.
    let setup = input.setup;
    match input.alpha {
        AlphaMode::Opaque => {
            let write = |buffer: &mut SampleBuffer, i: usize, _, src: Vec4| {
                buffer.color[i] = src.truncate().extend(1.0);
                false
            };
            merge_lanes(input, buffer, layout, raster, log, |_| false, write)
        }
        AlphaMode::Blend => {
            let write = |buffer: &mut SampleBuffer, i: usize, _, src: Vec4| {
                let a = src.w.clamp(0.0, 1.0);
                buffer.color[i] = (src * a + buffer.color[i] * (1.0 - a)).truncate().extend(1.0);
                buffer.blended[i / buffer.samples] = true;
                false
            };
            merge_lanes(input, buffer, layout, raster, log, |_| false, write)
        }
        AlphaMode::Mask { cutoff } => {
            let write = |buffer: &mut SampleBuffer, i: usize, (sx, sy), src: Vec4| {
                // Late depth write: only fragments that survived the alpha test.
                let z = setup.depth(setup.edges(sx, sy));
                let passes = depth_passes(z, setup.prim, buffer.depth[i], buffer.prim[i]);
                if passes {
                    buffer.write_depth(i, z, setup.prim, input.tri);
                    buffer.color[i] = src.truncate().extend(1.0);
                }
                passes
            };
            merge_lanes(input, buffer, layout, raster, log, |alpha| alpha < cutoff, write)
        }
    }
}

/// Writes the lanes of `input` whose alpha `discards` does not reject: `write` gets each
/// passing sample (its index, position and the lane's colour) and says whether it wrote a
/// depth; each written lane touches its colour line once. One sample per pixel (the usual
/// case) gets its own compiled loop, without the loop over samples.
fn merge_lanes(
    input: &MergeInput,
    buffer: &mut SampleBuffer,
    layout: &FramebufferLayout,
    raster: &mut RasterStats,
    log: &mut AccessLog,
    discards: impl Fn(f32) -> bool,
    write: impl FnMut(&mut SampleBuffer, usize, (i64, i64), Vec4) -> bool,
) -> bool {
    match buffer.samples {
        1 => merge_samples(1, input, buffer, layout, raster, log, discards, write),
        samples => merge_samples(samples, input, buffer, layout, raster, log, discards, write),
    }
}

/// [`merge_lanes`] with `samples` per pixel, inlined into each of its calls. The buffer and
/// counters come as parameters, not as fields of one struct: the compiler then knows that
/// writing the counters leaves the buffer's rectangle alone (0.45% more instructions in
/// `forward` otherwise).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn merge_samples(
    samples: usize,
    input: &MergeInput,
    buffer: &mut SampleBuffer,
    layout: &FramebufferLayout,
    raster: &mut RasterStats,
    log: &mut AccessLog,
    discards: impl Fn(f32) -> bool,
    mut write: impl FnMut(&mut SampleBuffer, usize, (i64, i64), Vec4) -> bool,
) -> bool {
    let mut depth_written = false;
    for ((quad, passed), lane_colors) in input.quads.iter().zip(input.colors) {
        for lane in 0..4u32 {
            let bits = passed >> (lane as usize * samples) & ((1 << samples) - 1);
            if bits == 0 {
                continue;
            }
            let (x, y) = (quad.x + (lane & 1), quad.y + (lane >> 1));
            let src = lane_colors[lane as usize];
            if discards(src.w) {
                continue;
            }
            raster.fragments_shaded += 1;
            for s in (0..samples).filter(|s| bits & (1 << s) != 0) {
                raster.samples_passed += 1;
                let i = buffer.index(x, y, s);
                depth_written |= write(buffer, i, sample_position(x, y, input.offsets[s]), src);
            }
            log.touch(Stream::Color, layout.color_line(input.view, x, y), true);
        }
    }
    depth_written
}
