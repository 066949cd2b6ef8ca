//! Passes over whole views: a view-to-view pass makes a view that the geometry pass did not
//! draw from one it did (reprojection), a per-view pass reworks a drawn view; either leaves a
//! per-pixel work list (holes for rays), which runs in fixed chunks in parallel. Their
//! accesses follow every geometry and tile command.

use glam::Vec4;
use rayon::prelude::*;

use super::job::JobOutput;
use super::resolve::encode;
use super::tile_buffer::{TileBuffer, CLEAR_COLOR, NO_PRIMITIVE};
use crate::scheme::{ShadingScheme, ViewContext, ViewPass};

/// Pixels per chunk of a work list (a chunk is one scheme job, so results do not depend on
/// the thread count).
pub const WORK_CHUNK: usize = 1024;

/// A whole view's samples, `samples` consecutive entries per pixel, pixels row-major.
#[derive(Clone)]
pub struct ViewFrame {
    pub view: u8,
    pub width: u32,
    pub height: u32,
    pub samples: usize,
    pub depth: Vec<f32>,
    pub prim: Vec<u32>,
    /// Setup-triangle id in the view that drew the sample (`NO_PRIMITIVE` in derived views
    /// unless the pass sets one).
    pub tri: Vec<u32>,
    pub color: Vec<Vec4>,
}

impl ViewFrame {
    /// A cleared view.
    pub fn new(view: u8, width: u32, height: u32, samples: usize) -> ViewFrame {
        let n = (width * height) as usize * samples;
        ViewFrame {
            view,
            width,
            height,
            samples,
            depth: vec![1.0; n],
            prim: vec![NO_PRIMITIVE; n],
            tri: vec![NO_PRIMITIVE; n],
            color: vec![CLEAR_COLOR; n],
        }
    }

    #[inline]
    pub fn index(&self, x: u32, y: u32, s: usize) -> usize {
        (y * self.width + x) as usize * self.samples + s
    }

    /// The view made of its jobs' tile buffers (tiles nobody touched stay clear).
    fn from_tiles<'a>(
        view: u8,
        width: u32,
        height: u32,
        samples: usize,
        tiles: impl Iterator<Item = &'a TileBuffer>,
    ) -> ViewFrame {
        let mut frame = ViewFrame::new(view, width, height, samples);
        for tile in tiles.filter(|t| t.view == view) {
            let r = tile.rect;
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    for s in 0..samples {
                        let (i, j) = (frame.index(x, y, s), tile.index(x, y, s));
                        frame.depth[i] = tile.depth[j];
                        frame.prim[i] = tile.prim[j];
                        frame.tri[i] = tile.tri[j];
                        frame.color[i] = tile.color[j];
                    }
                }
            }
        }
        frame
    }

    /// sRGB pixels and the number of pixels with a covered sample.
    pub fn resolve(&self) -> (Vec<[u8; 4]>, u64) {
        let pixels = self
            .color
            .chunks_exact(self.samples)
            .map(|s| encode(s.iter().copied().sum::<Vec4>() / self.samples as f32))
            .collect();
        let covered = self
            .prim
            .chunks_exact(self.samples)
            .filter(|p| p.iter().any(|&id| id != NO_PRIMITIVE))
            .count() as u64;
        (pixels, covered)
    }
}

/// What a view pass produced: the made view and the outputs of the pass and of each
/// work-list chunk, in order.
pub struct DerivedOutput {
    pub frame: ViewFrame,
    pub outputs: Vec<JobOutput>,
}

/// Runs `pass`: view `from` assembled from the jobs' tiles, `derive_view` into view `to`,
/// then the work list in chunks.
pub fn run(
    pass: ViewPass,
    scheme: &dyn ShadingScheme,
    ctx: ViewContext,
    samples: usize,
    (lights, simd_width): (usize, u32),
    jobs: &[JobOutput],
) -> DerivedOutput {
    let (width, height) = (ctx.width, ctx.height);
    let from = ViewFrame::from_tiles(
        pass.from,
        width,
        height,
        samples,
        jobs.iter().flat_map(|j| j.buffers.iter()),
    );
    let mut to = if pass.to == pass.from {
        from.clone()
    } else {
        ViewFrame::new(pass.to, width, height, samples)
    };
    let mut work = Vec::new();
    let mut first = JobOutput::new(simd_width);
    let mut log = crate::memory::AccessLog::new();
    let v = pass.to as usize;
    first.account(v, &mut log, |acc| {
        scheme
            .begin_job(lights, simd_width)
            .derive_view(&ctx, &from, &mut to, &mut work, acc)
    });
    first.logs.push((0, log));
    let chunks: Vec<(JobOutput, Vec<Vec4>)> = work
        .par_chunks(WORK_CHUNK)
        .map(|pixels| {
            let mut out = JobOutput::new(simd_width);
            let mut log = crate::memory::AccessLog::new();
            let mut colors = Vec::with_capacity(pixels.len());
            out.account(v, &mut log, |acc| {
                scheme
                    .begin_job(lights, simd_width)
                    .shade_pixels(&ctx, &to, pixels, &mut colors, acc)
            });
            out.logs.push((0, log));
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
    DerivedOutput { frame: to, outputs }
}
