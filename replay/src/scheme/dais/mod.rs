//! Deferred attribute interpolation shading (Schied and Dachsbacher 2015): a z-prepass,
//! then a fill pass in which every visible fragment looks its triangle up in a memoization
//! cache (2^13 entries, two per bucket, `--memo-entries`); a miss stores the triangle in the
//! triangle buffer (80 bytes, [`TriangleRecord`]) and the visibility samples reference it.
//! A compute pass computes each stored triangle's screen derivatives (Appendix A), and the
//! shading pass interpolates attributes from them (Eq. 2) and shades each distinct triangle
//! of a pixel once, weighted by its coverage (Listing 1: our resolve averages the samples,
//! which weights each shade by its multiplicity).
//!
//! - `dais`: 32 bits per visibility sample (24-bit reference, 8-bit coverage) beside the
//!   multisampled depth buffer.
//! - `dais-list`: a 32-bit list head per pixel and a 64-bit node per triangle of the pixel;
//!   a fragment that covers every sample stores its reference in the head (no node). Its
//!   pixels are `dais`'s; only memory, traffic and cost differ.
//! - `dais-multirate`: the lighting (the coarse-able part of our shader) at rate 1/2: a
//!   2x2 shading quad that the triangle covers whole has one shading sample at its centre,
//!   otherwise each of its pixels has its own (§4.4). Samples are lit in a compute pass and
//!   stored as 32-bit LogLuv (§4.4); the resolve reads them beside the full-rate albedo.
//!
//! The memoization cache is replayed by the memory model in issue order
//! ([`Stream::Memo`]): its misses are the stores, and their count is only known after it, so
//! the stores and the derivative pass are charged in [`ShadingScheme::finish_frame`].
//! Positions come from the depth buffer (full precision); the pixel takes the triangle's
//! position at its centre, as `deferred` does.

mod logluv;
mod record;

use std::collections::HashMap;

use glam::{Vec3, Vec4};
use shadetrace_formats::results::{DaisStats, ShadingCost, Traffic};

use super::deferred::VISIBILITY;
use super::distinct_triangles;
use super::{
    Accounting, FinishedFrame, Passes, SchemeJob, SchemeStats, ShadeQuad, ShadingScheme, TileContext, UnitContext,
    VisibleQuads,
};
use crate::cost::{dense_lanes, BlockSet, SimdPacker, FINE};
use crate::cost_table::Block;
use crate::memory::{
    memo_key, RenderTarget, Stream, MEMO_ENTRY_BYTES, MEMO_LOCK_BYTES, MEMO_WAYS, TRIANGLE_BUFFER,
    TRIANGLE_RECORD_BYTES,
};
use crate::pipeline::{SampleBuffer, NO_PRIMITIVE};
use crate::shader::{compose, LightingInputs, Surface, SurfacePoint};
use record::TriangleRecord;

/// Cost stage of the derivative pass (Table 1's "Compute Derivatives").
pub const DERIVATIVES: &str = "derivatives";
/// Cost stage of the multi-rate variant's shading-sample pass.
pub const COARSE: &str = "coarse";
/// Traffic class of the multi-rate variant's shading samples.
pub const SHADING_SAMPLES: &str = "shading_samples";
/// Bytes of a list node: coverage count, triangle reference, next pointer.
const LIST_NODE_BYTES: u64 = 8;
/// Bytes of a shading sample: triangle reference and screen position (8), LogLuv result (4).
const SHADING_SAMPLE_BYTES: u64 = 12;

/// Counters the jobs keep for [`ShadingScheme::finish_frame`].
const MEMO_LOOKUPS: &str = "dais_memo_lookups";
const LIST_NODES: &str = "dais_list_nodes";
const SHADING_SAMPLE_COUNT: &str = "dais_shading_samples";

/// How the visibility samples are stored and what rate lighting runs at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// A reference and coverage mask per sample (`dais`).
    Samples,
    /// A list per pixel (`dais-list`).
    List,
    /// Per-sample references plus shading samples at rate 1/2 (`dais-multirate`).
    Multirate,
}

pub struct Dais {
    pub variant: Variant,
}

impl ShadingScheme for Dais {
    fn name(&self) -> &'static str {
        match self.variant {
            Variant::Samples => "dais",
            Variant::List => "dais-list",
            Variant::Multirate => "dais-multirate",
        }
    }

    fn passes(&self) -> Passes {
        Passes::ShadeAfterVisibility
    }

    fn depth_prepass(&self) -> bool {
        true
    }

    fn visibility_targets(&self) -> &'static [RenderTarget] {
        match self.variant {
            Variant::Samples => &[RenderTarget::TriangleRefs],
            Variant::List => &[RenderTarget::ListHeads],
            Variant::Multirate => &[RenderTarget::TriangleRefs, RenderTarget::ShadingRefs],
        }
    }

    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob> {
        Box::new(DaisJob {
            variant: self.variant,
            fine: SimdPacker::new(simd_width, lights),
            coarse: SimdPacker::new(simd_width, lights),
            blocks: BlockSet::new(lights),
            sample_blocks: BlockSet::new(lights),
            records: HashMap::new(),
            samples: HashMap::new(),
            shaded: Vec::new(),
        })
    }

    fn finish_frame(&self, frame: &FinishedFrame, costs: [&mut ShadingCost; 2], traffic: &mut Traffic) -> SchemeStats {
        let memo = frame.memo.unwrap_or_default();
        let count = |name: &str| frame.counters.get(name).copied().unwrap_or(0);
        for (cost, stores) in costs.into_iter().zip(memo.misses) {
            // Each store is a divergent branch of the fill pass's SIMD group that won the lock.
            let store = Block::TriangleStore.cost();
            let fill = cost.stage_mut(VISIBILITY);
            fill.alu += stores * u64::from(store.alu);
            fill.useful_lane_alu += stores * u64::from(store.alu);
            // The derivative pass: one lane per stored triangle, packed densely.
            cost.stage_mut(DERIVATIVES)
                .add(&dense_lanes(Block::TriangleDerivatives, stores, frame.simd_width));
        }
        let stored: u64 = memo.misses.iter().sum();
        // The fill pass writes each record, the derivative pass reads and rewrites it.
        traffic.add_bytes(TRIANGLE_BUFFER, 3 * stored * TRIANGLE_RECORD_BYTES);
        let lookups = count(MEMO_LOOKUPS);
        let list_nodes = (self.variant == Variant::List).then(|| count(LIST_NODES));
        let shading_samples = (self.variant == Variant::Multirate).then(|| count(SHADING_SAMPLE_COUNT));
        let depth_bytes = 2 * frame.layout.bytes(RenderTarget::Depth);
        let visibility_bytes: u64 = self
            .visibility_targets()
            .iter()
            .map(|&t| 2 * frame.layout.bytes(t))
            .sum();
        let triangle_buffer_bytes = stored * TRIANGLE_RECORD_BYTES;
        let dais = DaisStats {
            memo_lookups: lookups,
            memo_hits: lookups.saturating_sub(stored),
            memo_misses: stored,
            redundant_stores: memo.redundant.iter().sum(),
            memo_cache_bytes: frame.memo_entries * MEMO_ENTRY_BYTES + frame.memo_entries / MEMO_WAYS * MEMO_LOCK_BYTES,
            triangle_buffer_bytes,
            depth_bytes,
            list_nodes,
            shading_samples,
            total_bytes: depth_bytes
                + visibility_bytes
                + triangle_buffer_bytes
                + list_nodes.unwrap_or(0) * LIST_NODE_BYTES
                + shading_samples.unwrap_or(0) * SHADING_SAMPLE_BYTES,
        };
        SchemeStats {
            dais: Some(dais),
            ..SchemeStats::default()
        }
    }
}

/// Where a shading sample sits: its 2x2 quad's centre (the triangle covers the quad) or a
/// pixel's centre, and its triangle.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct SampleKey {
    x: u32,
    y: u32,
    whole_quad: bool,
    tri: u32,
}

struct DaisJob {
    variant: Variant,
    fine: SimdPacker,
    /// The shading-sample pass's lanes (multi-rate).
    coarse: SimdPacker,
    blocks: BlockSet,
    sample_blocks: BlockSet,
    /// The records of the current tile's triangles, computed on first use (the values are
    /// the derivative pass's, whoever asks).
    records: HashMap<u32, TriangleRecord>,
    /// The current tile's shading samples and their decoded lighting (multi-rate).
    samples: HashMap<SampleKey, Vec3>,
    /// The current pixel's distinct triangles and their sample masks.
    shaded: Vec<(u32, u32)>,
}

impl SchemeJob for DaisJob {
    /// Never called: the scheme shades after visibility.
    fn shade_unit(&mut self, _: &UnitContext, _: &[ShadeQuad], _: &mut Vec<[Vec4; 4]>, _: &mut Accounting) {}

    /// The fill pass (after the z-prepass, so every passing fragment is visible).
    fn visible_quads(&mut self, ctx: &UnitContext, visible: &VisibleQuads, acc: &mut Accounting) {
        let samples = visible.samples;
        let all = (1u32 << samples) - 1;
        let key = memo_key(ctx.view, visible.tri);
        let layout = visible.layout;
        let shading_refs = layout.lines(RenderTarget::TriangleRefs);
        let stage = acc.cost.stage_mut(VISIBILITY);
        let mut lookups = 0;
        let mut nodes = 0;
        for &(quad, passed) in visible.quads {
            for l in 0..4u32 {
                let (x, y) = (quad.x + (l & 1), quad.y + (l >> 1));
                let coverage = passed >> (l as usize * samples) & all;
                self.blocks.clear();
                self.blocks.take(Block::MemoLookup);
                if coverage != 0 {
                    lookups += 1;
                    acc.log.touch(Stream::Memo, key, false);
                    match self.variant {
                        Variant::Samples | Variant::Multirate => {
                            acc.log.touch(
                                Stream::Visibility,
                                layout.line(RenderTarget::TriangleRefs, ctx.view, x, y),
                                true,
                            );
                        }
                        Variant::List => {
                            acc.log.touch(
                                Stream::Visibility,
                                layout.line(RenderTarget::ListHeads, ctx.view, x, y),
                                true,
                            );
                            if coverage != all {
                                self.blocks.take(Block::ListAppend);
                                nodes += 1;
                            }
                        }
                    }
                    if self.variant == Variant::Multirate {
                        self.blocks.take(Block::ShadingSampleRef);
                        let line = shading_refs + layout.line(RenderTarget::ShadingRefs, ctx.view, x, y);
                        acc.log.touch(Stream::Visibility, line, true);
                    }
                }
                self.fine
                    .lane(&self.blocks, coverage != 0, ctx.pixel_id(x, y), stage, acc.heat);
            }
        }
        self.fine.flush(stage, acc.heat);
        (acc.count)(MEMO_LOOKUPS, lookups);
        if nodes > 0 {
            (acc.count)(LIST_NODES, nodes);
            // A node is written here and read once by the shading pass.
            (acc.traffic)(VISIBILITY, 2 * nodes * LIST_NODE_BYTES);
        }
    }

    /// Shade and resolve (Listing 1): per pixel, each distinct triangle once.
    fn shade_tile(&mut self, ctx: &TileContext, buffer: &mut SampleBuffer, acc: &mut Accounting) {
        self.records.clear();
        self.samples.clear();
        let samples = buffer.samples;
        let rect = buffer.rect;
        let layout = ctx.layout;
        let view = buffer.view;
        let all = (1u32 << samples) - 1;
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                let first = buffer.index(x, y, 0);
                let ids = &buffer.tri[first..first + samples];
                if ids.iter().all(|&t| t == NO_PRIMITIVE) {
                    continue;
                }
                match self.variant {
                    Variant::Samples => acc.log.touch(
                        Stream::Visibility,
                        layout.line(RenderTarget::TriangleRefs, view, x, y),
                        false,
                    ),
                    Variant::List => acc.log.touch(
                        Stream::Visibility,
                        layout.line(RenderTarget::ListHeads, view, x, y),
                        false,
                    ),
                    Variant::Multirate => {
                        acc.log.touch(
                            Stream::Visibility,
                            layout.line(RenderTarget::TriangleRefs, view, x, y),
                            false,
                        );
                        let line = layout.lines(RenderTarget::TriangleRefs)
                            + layout.line(RenderTarget::ShadingRefs, view, x, y);
                        acc.log.touch(Stream::Visibility, line, false);
                    }
                }
                acc.log.touch(Stream::Depth, layout.depth_line(view, x, y), false);
                acc.log.touch(Stream::Color, layout.color_line(view, x, y), true);
                let mut shaded = std::mem::take(&mut self.shaded);
                distinct_triangles(&buffer.tri[first..first + samples], &mut shaded);
                for &(tri, mask) in &shaded {
                    let colour = self.shade(ctx, buffer, x, y, tri, mask == all, acc);
                    for s in (0..samples).filter(|s| mask & (1 << s) != 0) {
                        buffer.color[first + s] = colour;
                    }
                }
                self.shaded = shaded;
            }
        }
        self.fine.flush(acc.cost.stage_mut(FINE), acc.heat);
        self.coarse.flush(acc.cost.stage_mut(COARSE), acc.heat);
        (acc.count)(SHADING_SAMPLE_COUNT, self.samples.len() as u64);
        if !self.samples.is_empty() {
            // Each sample's record is written by the fill pass and read by the sample pass,
            // its result written there and read by the resolve.
            (acc.traffic)(SHADING_SAMPLES, 2 * self.samples.len() as u64 * SHADING_SAMPLE_BYTES);
        }
    }
}

impl DaisJob {
    /// Shades triangle `tri` at pixel (`x`, `y`); `whole` says it covers every sample (a
    /// list keeps it in the head, no node to walk).
    #[allow(clippy::too_many_arguments)]
    fn shade(
        &mut self,
        ctx: &TileContext,
        buffer: &SampleBuffer,
        x: u32,
        y: u32,
        tri: u32,
        whole: bool,
        acc: &mut Accounting,
    ) -> Vec4 {
        let unit = ctx.unit(tri);
        let material = unit.triangle.material;
        acc.log.touch(Stream::TriangleBuffer, memo_key(buffer.view, tri), false);
        let size = (ctx.width, ctx.height);
        let record = self
            .records
            .entry(tri)
            .or_insert_with(|| TriangleRecord::new(unit.setup, unit.triangle, ctx.geometry, size));
        let at = record.at(x as f32 + 0.5, y as f32 + 0.5);
        self.blocks.clear();
        self.blocks.take(Block::DaisInterpolate);
        if self.variant == Variant::List && !whole {
            self.blocks.take(Block::ListNode);
        }
        let position = unit.attributes(x, y).position;
        let lighting = match self.variant {
            Variant::Samples | Variant::List => {
                // The triangle record has no tangents: traces with surface maps are refused.
                let inputs = LightingInputs {
                    position,
                    normal: at.normal,
                    eye: ctx.eye,
                    material,
                    surface: SurfacePoint::default(),
                };
                ctx.env.lighting(&inputs, &mut self.blocks, acc.log)
            }
            Variant::Multirate => {
                self.blocks.take(Block::ShadingSampleRead);
                self.shading_sample(ctx, buffer, x, y, tri, acc)
            }
        };
        let albedo = ctx
            .env
            .albedo(material, at.uv, at.duv_dx, at.duv_dy, &mut self.blocks, acc.log);
        let colour = compose(&Surface::of_albedo(albedo), lighting, &mut self.blocks);
        self.fine.lane(
            &self.blocks,
            true,
            unit.pixel_id(x, y),
            acc.cost.stage_mut(FINE),
            acc.heat,
        );
        colour
    }

    /// The lighting of the shading sample pixel (`x`, `y`) of `tri` reads, lit (a lane of the
    /// sample pass) and LogLuv-quantized the first time the tile needs it.
    fn shading_sample(
        &mut self,
        ctx: &TileContext,
        buffer: &SampleBuffer,
        x: u32,
        y: u32,
        tri: u32,
        acc: &mut Accounting,
    ) -> Vec3 {
        let (qx, qy) = (x & !1, y & !1);
        let whole_quad = (0..4).all(|l| {
            let (px, py) = (qx + (l & 1), qy + (l >> 1));
            let r = buffer.rect;
            (r.x0..r.x1).contains(&px)
                && (r.y0..r.y1).contains(&py)
                && buffer.tri[buffer.index(px, py, 0)..][..buffer.samples].contains(&tri)
        });
        let key = if whole_quad {
            SampleKey {
                x: qx,
                y: qy,
                whole_quad,
                tri,
            }
        } else {
            SampleKey { x, y, whole_quad, tri }
        };
        if let Some(&lighting) = self.samples.get(&key) {
            return lighting;
        }
        let unit = ctx.unit(tri);
        // The quad's centre, or the pixel's, in pixels and in fixed point.
        let (cx, cy) = if whole_quad {
            (qx as f32 + 1.0, qy as f32 + 1.0)
        } else {
            (x as f32 + 0.5, y as f32 + 0.5)
        };
        let fixed = |c: f32| (f64::from(c) * crate::vertex_stage::SUBPIXEL as f64) as i64;
        let position = unit.attributes_at(fixed(cx), fixed(cy)).position;
        let record = &self.records[&tri];
        let blocks = &mut self.sample_blocks;
        blocks.clear();
        blocks.take(Block::DaisInterpolate);
        blocks.take(Block::ShadingSampleWrite);
        let inputs = LightingInputs {
            position,
            normal: record.at(cx, cy).normal,
            eye: ctx.eye,
            material: unit.triangle.material,
            surface: SurfacePoint::default(),
        };
        let lit = ctx.env.lighting(&inputs, blocks, acc.log);
        let lighting = logluv::decode(logluv::encode(lit));
        self.coarse
            .lane(blocks, true, unit.pixel_id(x, y), acc.cost.stage_mut(COARSE), acc.heat);
        self.samples.insert(key, lighting);
        lighting
    }
}
