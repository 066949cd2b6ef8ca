//! One job: its commands in order on one worker, with one scheme state and the tile buffers
//! of the tiles its units touch; the tiles are resolved when the commands are done.

use std::collections::BTreeMap;

use glam::{Mat4, Vec3, Vec4};
use shadetrace_formats::results::{RasterStats, ShadingCacheStats};
use shadetrace_formats::AlphaMode;

use super::blend::{merge, MergeInput};
use super::resolve::{resolve, TileImage};
use super::sample_buffer::{depth_passes, SampleBuffer};
use super::{Colors, CostHeat};
use crate::bins::TileGrid;
use crate::by_name::ByName;
use crate::command::{Command, Job, Unit};
use crate::cost::{CostHeatList, StageCosts};
use crate::geometry::FrameGeometry;
use crate::memory::{AccessLog, FramebufferLayout, Stream, LINE_BYTES};
use crate::raster::{rasterize, sample_position, Quad, Rect};
use crate::scheme::{
    Accounting, SchemeJob, ShadeQuad, ShadingScheme, TileContext, UnitContext, ViewContext, VisibleQuads,
};
use crate::shader::ShaderEnv;
use crate::vertex_stage::SetupTriangle;

/// Bytes per vertex of triangle data: position, normal, uv (8 floats).
pub const VERTEX_BYTES: u64 = 32;

/// What every job of a frame reads.
pub struct JobContext<'a> {
    pub grid: TileGrid,
    pub setups: [&'a [SetupTriangle]; 2],
    pub geometry: &'a FrameGeometry,
    pub env: &'a ShaderEnv<'a>,
    pub eyes: [Vec3; 2],
    pub view_projections: [Mat4; 2],
    /// The rig's near and far planes (view-space distances).
    pub depth_range: (f32, f32),
    pub layout: FramebufferLayout,
    pub offsets: &'static [[i64; 2]],
    pub simd_width: u32,
    /// The texture cache's size, which the job's log counts hits in.
    pub texture_cache_bytes: u64,
    /// A depth pre-pass ran first: later passes test for equal depth and write none.
    pub z_prepass: bool,
    /// Keep tile buffers after the resolve (a view pass reads them).
    pub keep_buffers: bool,
    pub heat: CostHeat,
    pub colors: Colors,
}

/// Everything a job produced; per-view arrays are indexed by view.
pub struct JobOutput {
    /// The job's accesses, one segment per command (by its index in the job).
    pub log: AccessLog,
    pub raster: [RasterStats; 2],
    pub cost: [StageCosts; 2],
    pub tiles: Vec<TileImage>,
    /// Instructions per pixel id (none kept when the frame skips its heat maps) and
    /// refinement bits per pixel id, in the order the job produced them (repeats of the last
    /// pixel folded in); the view's assembly adds them up, which is order-independent
    /// (wrapping sums, bitwise or).
    pub heat: CostHeatList,
    pub refinement: Vec<(u32, u8)>,
    pub cache: [ShadingCacheStats; 2],
    /// The tile buffers themselves, kept when a view pass reads the finished view.
    pub buffers: Vec<SampleBuffer>,
    /// DRAM bytes that bypass the caches (light lists written and read once), by traffic
    /// class: added to the frame's [`Traffic`](shadetrace_formats::results::Traffic).
    pub traffic: ByName<u64>,
    /// The scheme's named event counts ([`Accounting::count`]).
    pub counters: Counters,
}

/// Named event counts of a scheme, summed over a frame's jobs.
pub type Counters = BTreeMap<&'static str, u64>;

impl JobContext<'_> {
    /// What passes over view `view` may read.
    pub fn view(&self, view: u8) -> ViewContext<'_> {
        ViewContext {
            view,
            eye: self.eyes[view as usize],
            view_projections: self.view_projections,
            eyes: self.eyes,
            depth_range: self.depth_range,
            width: self.grid.width,
            height: self.grid.height,
            geometry: self.geometry,
            env: self.env,
            setups: self.setups[view as usize],
            layout: self.layout,
        }
    }
}

impl JobOutput {
    pub fn new(heat: CostHeat) -> JobOutput {
        JobOutput {
            log: AccessLog::new(),
            raster: [RasterStats::default(); 2],
            cost: Default::default(),
            tiles: Vec::new(),
            heat: CostHeatList::new(heat == CostHeat::Kept),
            refinement: Vec::new(),
            cache: [ShadingCacheStats::default(); 2],
            buffers: Vec::new(),
            traffic: ByName::default(),
            counters: Counters::new(),
        }
    }

    /// Runs `f` with the accounting of view `v`: its cost, the command's log, the job's heat
    /// and refinement maps and its cache statistics.
    pub fn account<R>(&mut self, v: usize, log: &mut AccessLog, f: impl FnOnce(&mut Accounting) -> R) -> R {
        let refinement = &mut self.refinement;
        let traffic = &mut self.traffic;
        let counters = &mut self.counters;
        f(&mut Accounting {
            cost: &mut self.cost[v],
            log,
            heat: &mut self.heat,
            refinement: &mut |pixel, bits| match refinement.last_mut() {
                Some((last, all)) if *last == pixel => *all |= bits,
                _ => refinement.push((pixel, bits)),
            },
            cache: &mut self.cache[v],
            traffic: &mut |class, bytes| *traffic.entry(class) += bytes,
            count: &mut |name, n| *counters.entry(name).or_default() += n,
        })
    }
}

/// Reusable per-job scratch (no allocation per unit), and the log a job writes into: kept by
/// each worker thread from one job to the next, so that a frame's thousands of jobs do not
/// each grow them from empty. Only their capacity carries over.
#[derive(Default)]
struct Scratch {
    quads: Vec<(ShadeQuad, u32)>,
    shade_quads: Vec<ShadeQuad>,
    colors: Vec<[Vec4; 4]>,
    log: AccessLog,
    /// A job's tile buffers by (view, tile), sorted (empty between jobs), and finished
    /// jobs' buffers for the next job's tiles.
    buffers: Vec<((u8, u32), SampleBuffer)>,
    spare_buffers: Vec<SampleBuffer>,
}

impl Scratch {
    /// A cleared buffer for `view`'s tile `rect`: a finished job's, else a new one.
    fn tile_buffer(&mut self, view: u8, rect: Rect, samples: usize) -> SampleBuffer {
        match self.spare_buffers.pop() {
            Some(mut buffer) => {
                buffer.reset(view, rect, samples);
                buffer
            }
            None => SampleBuffer::new(view, rect, samples),
        }
    }
}

thread_local! {
    /// The worker's [`Scratch`], taken by the job running on it (a job that a nested parallel
    /// call starts meanwhile finds none and makes its own).
    static SCRATCH: std::cell::Cell<Option<Box<Scratch>>> = const { std::cell::Cell::new(None) };
}

pub fn run_job(ctx: &JobContext, job: &Job, scheme: &dyn ShadingScheme) -> JobOutput {
    let mut scheme_job = scheme.begin_job(ctx.env.lights.len(), ctx.simd_width);
    let mut out = JobOutput::new(ctx.heat);
    let mut scratch = SCRATCH.take().unwrap_or_default();
    let mut buffers = std::mem::take(&mut scratch.buffers);
    let mut log = std::mem::take(&mut scratch.log);
    log.reset(ctx.texture_cache_bytes);
    // Tiles whose pre-passed depth the scheme has seen.
    let mut prepared = std::collections::BTreeSet::new();
    for (index, command) in job.commands.iter().enumerate() {
        log.begin(index);
        match *command {
            Command::BeginSequence => scheme_job.begin_sequence(),
            Command::Draw(unit) | Command::DepthPrepass(unit) | Command::Visibility(unit) => {
                let key = (unit.view, unit.tile);
                let at = match buffers.binary_search_by_key(&key, |(key, _)| *key) {
                    Ok(at) => at,
                    Err(at) => {
                        let buffer = scratch.tile_buffer(unit.view, ctx.grid.rect(unit.tile), ctx.offsets.len());
                        buffers.insert(at, (key, buffer));
                        at
                    }
                };
                let buffer = &mut buffers[at].1;
                let scheme_job = scheme_job.as_mut();
                if ctx.z_prepass && matches!(command, Command::Draw(_)) && prepared.insert((unit.view, unit.tile)) {
                    let tile_ctx = TileContext {
                        view_ctx: ctx.view(unit.view),
                        tile: unit.tile,
                        offsets: ctx.offsets,
                    };
                    out.account(unit.view as usize, &mut log, |acc| {
                        scheme_job.tile_prepared(&tile_ctx, buffer, acc)
                    });
                }
                geometry_command(ctx, command, unit, buffer, scheme_job, &mut scratch, &mut log, &mut out);
            }
            Command::ShadeTile { view, tile } => {
                if let Ok(at) = buffers.binary_search_by_key(&(view, tile), |(key, _)| *key) {
                    shade_tile(ctx, tile, &mut buffers[at].1, scheme_job.as_mut(), &mut log, &mut out);
                }
            }
        }
    }
    out.log = log.take();
    scratch.log = log;
    out.tiles = buffers.iter().map(|(_, buffer)| resolve(buffer, ctx.colors)).collect();
    let finished = buffers.drain(..).map(|(_, buffer)| buffer);
    match ctx.keep_buffers {
        true => out.buffers = finished.collect(),
        false => scratch.spare_buffers.extend(finished),
    }
    scratch.buffers = buffers;
    SCRATCH.set(Some(scratch));
    out
}

/// Raster, depth test and (for `Draw`) shading and output merge of one unit. Always
/// inlined into its one caller: left to the compiler, whether it is varies with unrelated
/// code, and so, by about 1%, do the instructions of every replay.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn geometry_command(
    ctx: &JobContext,
    command: &Command,
    unit: Unit,
    buffer: &mut SampleBuffer,
    scheme_job: &mut dyn SchemeJob,
    scratch: &mut Scratch,
    log: &mut AccessLog,
    out: &mut JobOutput,
) {
    let prepass = matches!(command, Command::DepthPrepass(_));
    let shading = matches!(command, Command::Draw(_));
    let visibility = matches!(command, Command::Visibility(_));
    let samples = buffer.samples;
    let v = unit.view as usize;
    let setup = &ctx.setups[v][unit.tri as usize];
    let triangle = &ctx.geometry.triangles[setup.prim as usize];
    let material = &ctx.env.materials[triangle.material as usize];
    let raster = &mut out.raster[v];
    if !prepass {
        raster.units += 1;
    }
    let opaque = material.alpha == AlphaMode::Opaque;
    if !shading && !opaque {
        // Depth-only passes skip surfaces whose visibility needs their shading (alpha).
        return;
    }
    if setup.z_min > buffer.max_depth {
        if !prepass {
            raster.hiz_culled_units += 1;
        }
        return;
    }
    for vertex in triangle.vertices {
        log.touch(Stream::TriangleData, vertex as u64 * VERTEX_BYTES / LINE_BYTES, false);
    }
    // Rasterize and depth-test; opaque surfaces write depth at once (early-z). The sample
    // count and the test are the unit's: each pairing gets its own compiled loop, so that a
    // fragment runs neither the other test nor a loop over a sample count it does not have.
    scratch.quads.clear();
    let rect = buffer.rect;
    let mut test = EarlyDepthTest {
        setup,
        offsets: ctx.offsets,
        layout: &ctx.layout,
        unit,
        counts_quads: !prepass,
        writes_depth: opaque && (prepass || !ctx.z_prepass),
        keeps_quads: shading || visibility,
        buffer,
        raster,
        log,
        quads: &mut scratch.quads,
        depth_written: false,
    };
    let equal_to_prepass = |z, prim, buf_z, buf_prim| z == buf_z && prim == buf_prim;
    match (samples, ctx.z_prepass && !prepass && opaque) {
        (1, false) => rasterize(setup, rect, &ctx.offsets[..1], |q| test.quad(q, 1, depth_passes)),
        (1, true) => rasterize(setup, rect, &ctx.offsets[..1], |q| test.quad(q, 1, equal_to_prepass)),
        (_, false) => rasterize(setup, rect, ctx.offsets, |q| test.quad(q, samples, depth_passes)),
        (_, true) => rasterize(setup, rect, ctx.offsets, |q| test.quad(q, samples, equal_to_prepass)),
    }
    let mut depth_written = test.depth_written;
    if visibility && !scratch.quads.is_empty() {
        let unit_ctx = UnitContext {
            view_ctx: ctx.view(unit.view),
            setup,
            triangle,
        };
        let visible = VisibleQuads {
            quads: &scratch.quads,
            tri: unit.tri,
            tile: unit.tile,
            rect: buffer.rect,
            samples,
            layout: ctx.layout,
        };
        out.account(v, log, |acc| scheme_job.visible_quads(&unit_ctx, &visible, acc));
    }
    if shading {
        scratch.shade_quads.clear();
        scratch.shade_quads.extend(scratch.quads.iter().map(|q| q.0));
        scratch.colors.clear();
        let unit_ctx = UnitContext {
            view_ctx: ctx.view(unit.view),
            setup,
            triangle,
        };
        out.account(v, log, |acc| {
            scheme_job.shade_unit(&unit_ctx, &scratch.shade_quads, &mut scratch.colors, acc)
        });
        let raster = &mut out.raster[v];
        raster.quads_shaded += scratch.quads.len() as u64;
        let input = MergeInput {
            view: unit.view,
            tri: unit.tri,
            setup,
            alpha: material.alpha,
            offsets: ctx.offsets,
            quads: &scratch.quads,
            colors: &scratch.colors,
        };
        depth_written |= merge(&input, buffer, &ctx.layout, raster, log);
    }
    // The tile's farthest depth only moves where depth was written.
    if depth_written {
        buffer.update_max_depth();
    }
}

/// The early depth test of one unit's quads, as the raster emits them: each covered
/// sample's test and (for opaque surfaces) write, the tile's depth accesses, and the quads
/// with a passing sample.
struct EarlyDepthTest<'a> {
    setup: &'a SetupTriangle,
    offsets: &'a [[i64; 2]],
    layout: &'a FramebufferLayout,
    unit: Unit,
    /// A pre-pass's quads are not counted: the pass that shades them counts them.
    counts_quads: bool,
    writes_depth: bool,
    /// Keep the passing quads (for shading, or for the visibility pass).
    keeps_quads: bool,
    buffer: &'a mut SampleBuffer,
    raster: &'a mut RasterStats,
    log: &'a mut AccessLog,
    quads: &'a mut Vec<(ShadeQuad, u32)>,
    depth_written: bool,
}

impl EarlyDepthTest<'_> {
    /// Tests one quad's covered samples with `passes(z, prim, buffer z, buffer prim)`.
    /// Inlined into each of the caller's (sample count, test) pairings.
    #[inline(always)]
    fn quad(&mut self, q: Quad, samples: usize, passes: impl Fn(f32, u32, f32, u32) -> bool) {
        let setup = self.setup;
        if self.counts_quads {
            self.raster.quads_rasterized += 1;
        }
        // Each covered sample's depth, four lanes at a time (pure: the tests and writes below
        // keep their order).
        let mut depths = [[0f32; 4]; 8];
        for (s, &offset) in self.offsets[..samples].iter().enumerate() {
            if q.coverage & sample_lanes(s, samples) != 0 {
                let (sx, sy) = sample_position(q.x, q.y, offset);
                depths[s] = setup.depths(setup.quad_edges(sx, sy));
            }
        }
        let mut targets = self.buffer.depth_targets();
        let mut passed = 0u32;
        for lane in 0..4u32 {
            let lane_bits = q.coverage >> (lane as usize * samples) & ((1 << samples) - 1);
            if lane_bits == 0 {
                continue;
            }
            let (x, y) = (q.x + (lane & 1), q.y + (lane >> 1));
            let mut wrote = false;
            // A range, not the depths' slice: at one sample the loop is one step, and no
            // loop is compiled (through the slice's iterator a lane kept its bookkeeping).
            #[allow(clippy::needless_range_loop)]
            for s in 0..samples {
                // At one sample per pixel, a lane that got here has its sample covered.
                if samples > 1 && lane_bits & (1 << s) == 0 {
                    continue;
                }
                let z = depths[s][lane as usize];
                let i = targets.index(x, y, s);
                if passes(z, setup.prim, targets.depth[i], targets.prim[i]) {
                    passed |= 1 << (lane as usize * samples + s);
                    if self.writes_depth {
                        targets.write(i, z, setup.prim, self.unit.tri);
                        wrote = true;
                    }
                }
            }
            self.log
                .touch(Stream::Depth, self.layout.depth_line(self.unit.view, x, y), wrote);
            self.depth_written |= wrote;
        }
        if passed != 0 && self.keeps_quads {
            self.quads.push((
                ShadeQuad {
                    x: q.x,
                    y: q.y,
                    lanes: lane_mask(passed, samples),
                },
                passed,
            ));
        }
    }
}

/// A screen pass over one tile: the scheme reads the resolved visibility and writes colour.
fn shade_tile(
    ctx: &JobContext,
    tile: u32,
    buffer: &mut SampleBuffer,
    scheme_job: &mut dyn SchemeJob,
    log: &mut AccessLog,
    out: &mut JobOutput,
) {
    let v = buffer.view as usize;
    let raster = &mut out.raster[v];
    let samples = buffer.samples;
    for first in (0..buffer.depth.len()).step_by(samples) {
        let visible = buffer.prim[first..first + samples]
            .iter()
            .filter(|&&p| p != super::sample_buffer::NO_PRIMITIVE)
            .count();
        raster.samples_passed += visible as u64;
        raster.fragments_shaded += u64::from(visible > 0);
    }
    let tile_ctx = TileContext {
        view_ctx: ctx.view(buffer.view),
        tile,
        offsets: ctx.offsets,
    };
    out.account(v, log, |acc| scheme_job.shade_tile(&tile_ctx, buffer, acc));
}

/// The coverage bits of sample `s` in the four lanes of a quad.
fn sample_lanes(s: usize, samples: usize) -> u32 {
    (0..4).fold(0, |mask, lane| mask | 1 << (lane * samples + s))
}

fn lane_mask(passed: u32, samples: usize) -> u8 {
    (0..4).fold(0u8, |m, lane| {
        if passed >> (lane * samples) & ((1 << samples) - 1) != 0 {
            m | 1 << lane
        } else {
            m
        }
    })
}
