//! The shared pipeline of one frame, as a short list of stages over named intermediate
//! results (in the manner of cudaraster's `launchStages`):
//!
//! 1. [`FrameGeometry`] — world-space triangles; 2. the shadow pass; 3. per view the vertex
//!    stage ([`ViewSetup`]); 4. [`Bins`]; 5. the scheduler's jobs, made into command lists
//!    for the scheme's passes ([`commands_for`]); 6. jobs in parallel ([`job::run_job`]);
//!    7. the memory model replays the commands' accesses in issue order; 8. the views are
//!    assembled from the jobs' tiles.

mod assemble;
mod blend;
mod issue_order;
mod job;
mod resolve;
mod sample_buffer;
mod stage_clock;
mod view_pass;

use glam::Vec3;
use rayon::prelude::*;
use shadetrace_formats::results::{
    CacheReport, DaisStats, ListStats, RasterStats, ReprojectionStats, ShadingCacheStats, ShadingCost, ShadowPassStats,
    Traffic, VertexStats,
};
use shadetrace_formats::{Eye, Frame, LightKind, Meta, Motion, Scene, StereoRig};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::bins::{Bins, TileGrid};
use crate::command::{Command, Job};
use crate::geometry::FrameGeometry;
use crate::memory::{simulate, CacheSizes, FramebufferLayout, LogSegment, RenderTarget, Replayed, TRIANGLE_DATA};
use crate::options::ReplayOptions;
use crate::raster::sample_offsets;
use crate::schedule::{ScheduleInput, Scheduler, INDICES};
use crate::scheme::{FinishedFrame, Passes, ShadingScheme, ViewPass};
use crate::shader::{ShaderEnv, ShadingLight};
use crate::shadow::{ReceiverHierarchy, ShadowMap};
use crate::texture::MipTexture;
use crate::vertex_stage::{setup_view, SetupTriangle};
use issue_order::{issue_order, IssueKey};
pub use job::Counters;
pub use job::VERTEX_BYTES;
use job::{run_job, JobContext, JobOutput};
pub use resolve::clear_pixel;
pub use sample_buffer::{depth_passes, SampleBuffer, CLEAR_COLOR, NO_PRIMITIVE};
use stage_clock::{timed, StageClock};
pub use view_pass::WORK_CHUNK;

/// Scene data prepared once per trace: mip chains and lights.
pub struct PreparedScene {
    pub scene: Scene,
    pub textures: Vec<MipTexture>,
    pub lights: Vec<ShadingLight>,
    pub double_sided: Vec<bool>,
    /// First free line of the texture address space (the shadow map goes there).
    pub texture_lines: u64,
    /// Shadow maps already rendered, shared by every run over this scene: a map depends on
    /// the casters' positions and its size only, so a scene whose meshes never move renders
    /// each size once, and a moving one once per frame for all presets ("model only what a
    /// scene requires"). Only the maps of the frames in flight are kept, so memory stays flat.
    shadow_maps: Mutex<Vec<(ShadowKey, Arc<ShadowMap>)>>,
    /// No mesh moves: every frame's shadow map is the same.
    static_casters: bool,
}

/// Which shadow map: the frame it was rendered for (`None` when the casters never move) and
/// its size.
type ShadowKey = (Option<u32>, u32);

impl PreparedScene {
    pub fn new(scene: Scene) -> PreparedScene {
        let mut line = 0;
        let mut linear = vec![false; scene.textures.len()];
        for &t in &scene.surface_maps.linear_textures {
            if let Some(flag) = linear.get_mut(t as usize) {
                *flag = true;
            }
        }
        let textures = scene
            .textures
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let (m, next) = MipTexture::build(t, line, !linear[i]);
                line = next;
                m
            })
            .collect();
        let lights = scene
            .lights
            .iter()
            .map(|l| ShadingLight::new(l.kind, l.color * l.intensity, l.shadowed))
            .collect();
        let double_sided = scene.materials.iter().map(|m| m.double_sided).collect();
        let static_casters = scene.geometry.meshes.iter().all(|m| m.motion == Motion::Static);
        PreparedScene {
            scene,
            textures,
            lights,
            double_sided,
            texture_lines: line,
            shadow_maps: Mutex::new(Vec::new()),
            static_casters,
        }
    }
}

/// Everything one frame of one back-end produced.
#[derive(Clone)]
pub struct FrameOutput {
    pub views: [ViewOutput; 2],
    pub traffic: Traffic,
    pub caches: CacheReport,
    pub lists: ListStats,
    pub shadow_pass: Option<ShadowPassStats>,
    /// Bytes of the G-buffer of both views, when the scheme wrote one.
    pub gbuffer_bytes: Option<u64>,
    /// Bytes of the visibility buffer of both views, when the scheme wrote one.
    pub visibility_bytes: Option<u64>,
    /// Deferred attribute interpolation's buffers and memoization cache.
    pub dais: Option<DaisStats>,
    /// The reprojected view's grid, holes and rays.
    pub reprojection: Option<ReprojectionStats>,
    /// Wall time of each stage of this frame.
    pub stage_times: Vec<(&'static str, std::time::Duration)>,
}

#[derive(Clone)]
pub struct ViewOutput {
    pub vertex: VertexStats,
    pub raster: RasterStats,
    pub cost: ShadingCost,
    pub width: u32,
    pub height: u32,
    /// sRGB pixels, row-major; empty when the frame skipped them ([`Colors::Skipped`]).
    pub pixels: Vec<[u8; 4]>,
    /// Issued instructions per pixel (every SIMD group adds its count to each of its lanes);
    /// empty when the frame skipped it ([`CostHeat::Skipped`]).
    pub cost_heat: Vec<u32>,
    /// Per pixel, the union of `Effects` bits over its fragments (multi-rate schemes).
    pub refinement: Vec<u8>,
    pub cache: ShadingCacheStats,
}

/// The vertex stage's output for one view.
pub struct ViewSetup {
    pub triangles: Vec<SetupTriangle>,
    pub stats: VertexStats,
}

/// Whether a frame keeps its per-pixel cost heat map. Only pictures show it, so a run that
/// writes none skips it: its per-lane bookkeeping and its lists (tens of MB at 1280x1440
/// per eye). No counter depends on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CostHeat {
    Kept,
    Skipped,
}

/// Whether anything reads a frame's colours: a picture, or a comparison with the
/// reference. A run of numbers alone skips them: each tile's resolve to sRGB and the views'
/// pictures (7 MB per frame at 1280x1440 per eye). Coverage is counted either way, and no
/// counter depends on the colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colors {
    Kept,
    Skipped,
}

/// How a frame runs apart from what it replays: nothing here changes a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameMode {
    pub heat: CostHeat,
    pub colors: Colors,
    /// The pool's threads this frame has to itself (frames in flight share the pool): its
    /// memory replay runs in as many parts. More parts would only have each scan the whole
    /// log for its own sets while the other frame's work waits.
    pub threads: usize,
}

impl FrameMode {
    /// A frame that has the pool to itself, with its colours.
    pub fn alone(heat: CostHeat) -> FrameMode {
        FrameMode {
            heat,
            colors: Colors::Kept,
            threads: rayon::current_num_threads(),
        }
    }
}

/// Frames a run replays at once with more than one thread ([`crate::replay_all`]). A frame's
/// serial stages (vertex setup and binning at its start, the memory replay's parts at its
/// end) leave threads idle that the other frame's parallel stages take. Every number is the
/// same at any count: frames are independent.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// Runs one frame through `scheduler` x `scheme`, as `mode` says.
pub fn run_frame(
    prepared: &PreparedScene,
    meta: &Meta,
    frame: &Frame,
    opts: &ReplayOptions,
    scheduler: &dyn Scheduler,
    scheme: &dyn ShadingScheme,
    mode: FrameMode,
) -> FrameOutput {
    let FrameMode { heat, colors, threads } = mode;
    let (width, height) = opts.resolution.unwrap_or((frame.rig.eye_width, frame.rig.eye_height));
    let mut rig = frame.rig;
    rig.eye_width = width;
    rig.eye_height = height;
    let mut clock = StageClock::start();
    let geometry = FrameGeometry::build(&prepared.scene, frame);
    clock.lap("geometry");
    // The shadow pass (when its map is not kept) and the eyes' vertex stage read only the
    // geometry: side by side, each fills the threads the other's serial parts leave idle.
    let declared = scheme.view_pass();
    let shadows = || {
        let shadow = shadow_pass(prepared, meta, frame.index, &geometry, opts);
        let receivers: Option<Arc<ReceiverHierarchy>> = match (&shadow, scheme.edge_receiver_delta()) {
            (Some(map), Some(delta)) => Some(map.receivers(delta)),
            _ => None,
        };
        (shadow, receivers)
    };
    let (((shadow, receivers), shadow_time), (views, vertex_time)) = rayon::join(
        || timed(shadows),
        || timed(|| eye_setups(prepared, &geometry, &rig, declared, (width, height))),
    );
    clock.overlapped(&[("shadow", shadow_time), ("vertex", vertex_time)]);
    let env = ShaderEnv {
        materials: &prepared.scene.materials,
        textures: &prepared.textures,
        lights: &prepared.lights,
        shadow: shadow.as_deref(),
        receivers: receivers.as_deref(),
        maps: &prepared.scene.surface_maps,
    };
    let setups = [views[0].triangles.as_slice(), views[1].triangles.as_slice()];
    let grid = TileGrid::new(width, height, opts.tile);
    let bins = Bins::build(grid, setups);
    let schedule = scheduler.schedule(&ScheduleInput { bins: &bins, setups });
    let z_prepass = opts.z_prepass || scheme.depth_prepass();
    let jobs: Vec<Job> = schedule
        .jobs
        .into_iter()
        .map(|job| commands_for(job, z_prepass, scheme.passes()))
        .collect();
    clock.lap("bins");
    let layout = FramebufferLayout::new(width, height, opts.msaa);
    let ctx = JobContext {
        grid,
        setups,
        geometry: &geometry,
        env: &env,
        eyes: Eye::BOTH.map(|eye| rig.eye_position(eye)),
        view_projections: Eye::BOTH.map(|eye| rig.view_projection(eye)),
        depth_range: (rig.near, rig.far),
        layout,
        offsets: sample_offsets(opts.msaa),
        simd_width: opts.simd_width,
        texture_cache_bytes: opts.texture_cache_kb as u64 * 1024,
        z_prepass,
        keep_buffers: declared.is_some(),
        heat,
        colors,
    };
    let outputs: Vec<JobOutput> = jobs.par_iter().map(|job| run_job(&ctx, job, scheme)).collect();
    clock.lap("raster_shade");
    let made = declared.map(|pass| {
        let budget = (prepared.lights.len(), opts.simd_width, heat);
        (
            pass,
            view_pass::run(pass, scheme, ctx.view(pass.to), ctx.offsets.len(), budget, &outputs),
        )
    });
    if made.is_some() {
        clock.lap("view_pass");
    }
    let sizes = CacheSizes {
        depth: layout.cache_bytes(RenderTarget::Depth, opts.tile, opts.framebuffer_cache_tiles),
        color: layout.cache_bytes(RenderTarget::Color, opts.tile, opts.framebuffer_cache_tiles),
        triangle_data: opts.triangle_cache_kb as u64 * 1024,
        texture: opts.texture_cache_kb as u64 * 1024,
        gbuffer: layout.cache_bytes(RenderTarget::GBuffer, opts.tile, opts.framebuffer_cache_tiles),
        visibility: scheme
            .visibility_targets()
            .iter()
            .map(|&t| layout.cache_bytes(t, opts.tile, opts.framebuffer_cache_tiles))
            .sum(),
        triangle_buffer: opts.triangle_cache_kb as u64 * 1024,
        bvh: opts.bvh_cache_kb as u64 * 1024,
        memo_entries: opts.memo_entries,
    };
    let passes = made.as_ref().map(|(_, made)| made.outputs.as_slice());
    let [left, right] = views;
    // The two views assemble independently, at once.
    let assemble_view = |v: usize, setup: ViewSetup| match &made {
        Some((pass, made)) if pass.to as usize == v => {
            let mut view = assemble::view(
                v,
                setup.stats,
                grid,
                (opts.simd_width, heat, colors),
                outputs.iter().chain(&made.outputs),
            );
            let image = resolve::resolve(&made.frame, colors);
            (view.pixels, view.raster.pixels_covered) = (image.pixels, image.covered);
            view
        }
        _ => assemble::view(v, setup.stats, grid, (opts.simd_width, heat, colors), &outputs),
    };
    // The memory replay and the views' assembly only read the jobs' outputs: they run at once
    // (the replay's parts leave a thread idle that the assembly takes).
    let ((replayed, memory_time), (views, assemble_time)) = rayon::join(
        || timed(|| memory_pass(sizes, scheduler, &jobs, &outputs, passes, threads)),
        || timed(|| rayon::join(|| assemble_view(0, left), || assemble_view(1, right))),
    );
    clock.overlapped(&[("memory", memory_time), ("assemble", assemble_time)]);
    let Replayed {
        mut traffic,
        caches,
        memo,
    } = replayed;
    // Bytes the jobs moved past the caches (light lists), in job order.
    for (class, bytes) in outputs.iter().flat_map(|out| out.traffic.iter()) {
        traffic.add_bytes(class, *bytes);
    }
    traffic.add_bytes(INDICES, schedule.lists.index_bytes);
    if scheduler.stores_vertex_output() {
        traffic.add_bytes(TRIANGLE_DATA, geometry.positions.len() as u64 * VERTEX_BYTES);
    }
    let mut views = [views.0, views.1];
    let mut counters = Counters::new();
    let pass_outputs = made.iter().flat_map(|(_, made)| &made.outputs);
    for (name, n) in outputs.iter().chain(pass_outputs).flat_map(|out| &out.counters) {
        *counters.entry(name).or_default() += n;
    }
    let finished = FinishedFrame {
        layout,
        memo,
        counters: &counters,
        simd_width: opts.simd_width,
        memo_entries: opts.memo_entries,
    };
    let [l, r] = &mut views;
    let reported = scheme.finish_frame(&finished, [&mut l.cost, &mut r.cost], &mut traffic);
    FrameOutput {
        views,
        traffic,
        gbuffer_bytes: caches.gbuffer.map(|_| 2 * layout.bytes(RenderTarget::GBuffer)),
        visibility_bytes: caches.visibility.map(|_| {
            let targets = scheme.visibility_targets();
            targets.iter().map(|&t| 2 * layout.bytes(t)).sum()
        }),
        dais: reported.dais,
        reprojection: reported.reprojection,
        caches,
        lists: schedule.lists.stats,
        shadow_pass: shadow.map(|s| s.stats),
        stage_times: clock.laps,
    }
}

/// Renders the shadow map that every frame of a still scene shares unless it is cached, so
/// that frames about to run at once all find it instead of each rendering it; returns how
/// long that took (shadow-stage time).
pub fn share_still_shadow_map(prepared: &PreparedScene, meta: &Meta, frame: &Frame, opts: &ReplayOptions) -> Duration {
    let started = Instant::now();
    let key = shadow_key(prepared, frame.index, opts);
    if prepared.static_casters
        && shadowed_direction(prepared).is_some()
        && cached(&shadow_maps(prepared), key).is_none()
    {
        shadow_pass(
            prepared,
            meta,
            frame.index,
            &FrameGeometry::build(&prepared.scene, frame),
            opts,
        );
    }
    started.elapsed()
}

/// The direction of the trace's shadowed directional light, if it has one.
fn shadowed_direction(prepared: &PreparedScene) -> Option<Vec3> {
    prepared.lights.iter().find(|l| l.shadowed).and_then(|l| match l.kind {
        LightKind::Directional { direction } => Some(direction),
        _ => None,
    })
}

/// What a frame's shadow map depends on: its casters (the frame, unless none moves) and size.
fn shadow_key(prepared: &PreparedScene, frame: u32, opts: &ReplayOptions) -> ShadowKey {
    ((!prepared.static_casters).then_some(frame), opts.shadow_map_size)
}

/// The scene's shadow-map cache, locked (a panic elsewhere leaves only whole maps in it).
fn shadow_maps(prepared: &PreparedScene) -> MutexGuard<'_, Vec<(ShadowKey, Arc<ShadowMap>)>> {
    prepared
        .shadow_maps
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The cached map of `key`, if any.
fn cached(maps: &[(ShadowKey, Arc<ShadowMap>)], key: ShadowKey) -> Option<Arc<ShadowMap>> {
    maps.iter().find(|(k, _)| *k == key).map(|(_, map)| map.clone())
}

/// Both eyes' setup triangles, side by side. A view that a view-to-view pass makes is not
/// drawn: no vertex work, no bins, no units.
fn eye_setups(
    prepared: &PreparedScene,
    geometry: &FrameGeometry,
    rig: &StereoRig,
    declared: Option<ViewPass>,
    (width, height): (u32, u32),
) -> [ViewSetup; 2] {
    let view = |eye: Eye| {
        if declared.is_some_and(|p| p.to != p.from && !p.draw_to && p.to as usize == eye as usize) {
            return ViewSetup {
                triangles: Vec::new(),
                stats: VertexStats::default(),
            };
        }
        let projection = rig.view_projection(eye);
        let (triangles, stats) = setup_view(geometry, &prepared.double_sided, projection, width, height);
        ViewSetup { triangles, stats }
    };
    let (left, right) = rayon::join(|| view(Eye::Left), || view(Eye::Right));
    [left, right]
}

/// The shadow map of the trace's shadowed directional light, if it has one: rendered, or
/// the one already rendered for the same casters and size.
fn shadow_pass(
    prepared: &PreparedScene,
    meta: &Meta,
    frame: u32,
    geometry: &FrameGeometry,
    opts: &ReplayOptions,
) -> Option<Arc<ShadowMap>> {
    let direction = shadowed_direction(prepared)?;
    let key = shadow_key(prepared, frame, opts);
    if let Some(map) = cached(&shadow_maps(prepared), key) {
        return Some(map);
    }
    // Rendered without the lock, which a frame in flight beside this one may want: a
    // thread never waits on another, and the map is the same whoever renders it (the
    // first kept is the one used).
    let map = Arc::new(ShadowMap::render(
        geometry,
        prepared.scene.materials.len(),
        direction,
        &meta.bounds,
        opts.shadow_map_size,
        prepared.texture_lines,
    ));
    let mut maps = shadow_maps(prepared);
    if let Some(kept) = cached(&maps, key) {
        return Some(kept);
    }
    // A moving scene's maps of frames no longer in flight are dropped.
    maps.retain(|((f, _), _)| match (*f, key.0) {
        (Some(f), Some(frame)) => f.abs_diff(frame) < FRAMES_IN_FLIGHT as u32,
        _ => true,
    });
    maps.push((key, map.clone()));
    Some(map)
}

/// A scheduler's job as the commands of the scheme's passes: a depth pre-pass of every unit
/// first when asked; `Visibility` instead of `Draw` and a `ShadeTile` per touched tile (in
/// (view, tile) order) for schemes that shade after visibility.
pub fn commands_for(job: Job, z_prepass: bool, passes: Passes) -> Job {
    let mut commands = Vec::with_capacity(job.commands.len() * (1 + z_prepass as usize));
    if z_prepass {
        commands.extend(job.commands.iter().filter_map(|c| match c {
            Command::Draw(u) => Some(Command::DepthPrepass(*u)),
            _ => None,
        }));
    }
    match passes {
        Passes::Forward => commands.extend(job.commands),
        Passes::ShadeAfterVisibility => {
            let mut tiles = std::collections::BTreeSet::new();
            for command in job.commands {
                match command {
                    Command::Draw(u) => {
                        tiles.insert((u.view, u.tile));
                        commands.push(Command::Visibility(u));
                    }
                    other => commands.push(other),
                }
            }
            commands.extend(tiles.into_iter().map(|(view, tile)| Command::ShadeTile { view, tile }));
        }
    }
    Job { commands }
}

/// Replays every command's accesses through the caches in the order the hardware would
/// issue them: geometry commands by the scheduler's issue key, tile passes where the
/// scheduler puts them (after all geometry, or after their tile's), then a view pass and its
/// work-list chunks in order.
fn memory_pass(
    sizes: CacheSizes,
    scheduler: &dyn Scheduler,
    jobs: &[Job],
    outputs: &[JobOutput],
    view_pass: Option<&[JobOutput]>,
    threads: usize,
) -> Replayed {
    let keys: Vec<IssueKey> = outputs
        .par_iter()
        .enumerate()
        .flat_map_iter(|(j, out)| {
            out.log.segments().filter_map(move |(segment, index)| {
                let key = match jobs[j].commands[index] {
                    Command::DepthPrepass(u) => (0, scheduler.issue_key(&u, 0, j, index)),
                    Command::Draw(u) | Command::Visibility(u) => (0, scheduler.issue_key(&u, 1, j, index)),
                    Command::ShadeTile { view, tile } => scheduler.tile_pass_key(view, tile, j, index),
                    Command::BeginSequence => return None,
                };
                Some((key.0, key.1, j, segment))
            })
        })
        .collect();
    let mut ordered: Vec<LogSegment> = issue_order(keys)
        .into_iter()
        .map(|(j, segment)| (&outputs[j].log, segment))
        .collect();
    if let Some(pass) = view_pass {
        ordered.extend(
            pass.iter()
                .flat_map(|out| out.log.segments().map(|(segment, _)| (&out.log, segment))),
        );
    }
    simulate(sizes, &ordered, threads)
}
