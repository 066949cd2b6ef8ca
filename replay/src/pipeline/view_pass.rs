//! Passes over whole views: a view-to-view pass makes a view that the geometry pass did not
//! draw from one it did (reprojection), a per-view pass reworks a drawn view; either leaves a
//! per-pixel work list (holes for rays), which runs in fixed chunks in parallel. Their
//! accesses follow every geometry and tile command.

use glam::Vec4;
use rayon::prelude::*;

use super::job::JobOutput;
use super::sample_buffer::SampleBuffer;
use super::CostHeat;
use crate::raster::Rect;
use crate::scheme::{ShadingScheme, ViewContext, ViewPass};

/// Pixels per chunk of a work list (a chunk is one scheme job, so results do not depend on
/// the thread count).
pub const WORK_CHUNK: usize = 1024;

/// The whole view `view` as one buffer, made of its jobs' tile buffers (tiles nobody
/// touched stay clear).
fn assemble_view<'a>(
    view: u8,
    width: u32,
    height: u32,
    samples: usize,
    tiles: impl Iterator<Item = &'a SampleBuffer>,
) -> SampleBuffer {
    let rect = Rect {
        x0: 0,
        y0: 0,
        x1: width,
        y1: height,
    };
    let mut frame = SampleBuffer::new(view, rect, samples);
    for tile in tiles.filter(|t| t.view == view) {
        let r = tile.rect;
        let row = (r.x1 - r.x0) as usize * samples;
        for y in r.y0..r.y1 {
            let (i, j) = (frame.index(r.x0, y, 0), tile.index(r.x0, y, 0));
            frame.depth[i..i + row].copy_from_slice(&tile.depth[j..j + row]);
            frame.prim[i..i + row].copy_from_slice(&tile.prim[j..j + row]);
            frame.tri[i..i + row].copy_from_slice(&tile.tri[j..j + row]);
            frame.color[i..i + row].copy_from_slice(&tile.color[j..j + row]);
        }
    }
    frame
}

/// What a view pass produced: the made view and the outputs of the pass and of each
/// work-list chunk, in order.
pub struct ViewPassOutput {
    pub frame: SampleBuffer,
    pub outputs: Vec<JobOutput>,
}

/// Runs `pass`: view `from` assembled from the jobs' tiles, `derive_view` into view `to`,
/// then the work list in chunks.
pub fn run(
    pass: ViewPass,
    scheme: &dyn ShadingScheme,
    ctx: ViewContext,
    samples: usize,
    (lights, simd_width, heat): (usize, u32, CostHeat),
    jobs: &[JobOutput],
) -> ViewPassOutput {
    let (width, height) = (ctx.width, ctx.height);
    let from = assemble_view(
        pass.from,
        width,
        height,
        samples,
        jobs.iter().flat_map(|j| j.buffers.iter()),
    );
    let mut to = if pass.to == pass.from {
        from.clone()
    } else if pass.draw_to {
        assemble_view(
            pass.to,
            width,
            height,
            samples,
            jobs.iter().flat_map(|j| j.buffers.iter()),
        )
    } else {
        SampleBuffer::new(pass.to, from.rect, samples)
    };
    let mut work = Vec::new();
    let mut first = JobOutput::new(heat);
    let mut log = crate::memory::AccessLog::new();
    let v = pass.to as usize;
    let shared = first.account(v, &mut log, |acc| {
        scheme
            .begin_job(lights, simd_width)
            .derive_view(&ctx, &from, &mut to, &mut work, acc)
    });
    first.log = log;
    let chunks: Vec<(JobOutput, Vec<Vec4>)> = work
        .par_chunks(WORK_CHUNK)
        .map(|pixels| {
            let mut out = JobOutput::new(heat);
            let mut log = crate::memory::AccessLog::new();
            let mut colors = Vec::with_capacity(pixels.len());
            out.account(v, &mut log, |acc| {
                scheme
                    .begin_job(lights, simd_width)
                    .shade_pixels(&ctx, &to, pixels, shared.as_ref(), &mut colors, acc)
            });
            out.log = log;
            (out, colors)
        })
        .collect();
    let mut outputs = vec![first];
    for (pixels, (out, colors)) in work.chunks(WORK_CHUNK).zip(chunks) {
        for (&pixel, &color) in pixels.iter().zip(&colors) {
            let first = pixel as usize * samples;
            to.color[first..first + samples].fill(color.truncate().extend(1.0));
        }
        outputs.push(out);
    }
    ViewPassOutput { frame: to, outputs }
}
