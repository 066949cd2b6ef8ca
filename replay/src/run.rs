//! Replaying a trace with one preset: loading, the frame loop, relative cost and quality
//! against the reference, and the results record.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use shadetrace_formats::results::{
    FrameResult, FrameTotals, RefinedPixels, RunResult, Timing, ViewResult, RESULTS_SCHEMA_VERSION,
};
use shadetrace_formats::{ContentHash, Eye, Frame, Meta, TraceReader};

use crate::images::Rgba8Image;
use crate::options::ReplayOptions;
use crate::pipeline::{
    clear_pixel, run_frame, share_still_shadow_map, Colors, CostHeat, FrameMode, FrameOutput, PreparedScene,
    FRAMES_IN_FLIGHT,
};
use crate::preset::{Preset, REFERENCE_PRESET};
use crate::quality;
use crate::schedule::Scheduler;
use crate::scheme::Effects;
use crate::scheme::ShadingScheme;

/// A trace in memory, prepared for replay.
pub struct LoadedTrace {
    pub name: String,
    pub hash: ContentHash,
    pub meta: Meta,
    pub prepared: PreparedScene,
    pub frames: Vec<Frame>,
}

/// Reads and verifies a trace; errors are one line naming the file.
pub fn load_trace(path: &Path) -> Result<LoadedTrace, String> {
    let fail = |e: shadetrace_formats::Error| format!("{}: {e}", path.display());
    let file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut reader = TraceReader::open(BufReader::new(file)).map_err(fail)?;
    let hash = reader.verify().map_err(fail)?;
    let scene = reader.scene().map_err(fail)?;
    let frames = (0..reader.frame_count())
        .map(|i| reader.frame(i))
        .collect::<Result<Vec<_>, _>>()
        .map_err(fail)?;
    let name = path
        .file_stem()
        .map_or_else(|| "trace".to_string(), |s| s.to_string_lossy().into_owned());
    Ok(LoadedTrace {
        name,
        hash,
        meta: reader.meta().clone(),
        prepared: PreparedScene::new(scene),
        frames,
    })
}

/// Images of one view of one frame.
pub struct ViewImages {
    /// Without pixels when the run skipped its colours (no sink and no reference).
    pub color: Rgba8Image,
    /// Issued shading instructions per pixel.
    pub cost_heat: Vec<u32>,
    /// Per pixel, the effects refined to per-pixel rate (`Effects` bits).
    pub refinement: Vec<u8>,
    /// Per pixel, the largest 8-bit channel difference from the reference (when it ran).
    pub error: Option<Vec<u8>>,
    /// Per pixel, `1 - SSIM` of its window against the reference (when it ran and the view
    /// is at least as large as the SSIM window).
    pub ssim_loss: Option<Vec<f32>>,
}

pub struct FrameImages {
    pub frame: u32,
    pub views: [ViewImages; 2],
}

/// Results of one replay, and the images of its first frame (reports show that one; every
/// frame's images go to the sink as they are made, so memory stays flat in frames). A
/// replay without a sink makes no images to keep.
pub struct RunOutput {
    pub result: RunResult,
    pub first_images: Option<FrameImages>,
}

/// Called with (run index, images) for every frame of every run, in frame order.
pub type ImageSink<'a> = dyn FnMut(usize, &FrameImages) -> Result<(), String> + 'a;

/// Where a [`replay_all`] has got to: `frames_done` whole frames, then `runs_done` of the
/// `runs` runs through the `in_flight` frames after them, the last of those runs `preset`.
#[derive(Clone, Copy, Debug)]
pub struct ReplayStep<'a> {
    pub frames_done: u32,
    pub in_flight: u32,
    pub runs_done: usize,
    pub runs: usize,
    pub preset: &'a str,
}

impl ReplayStep<'_> {
    /// Runs of single frames done so far.
    pub fn units_done(&self) -> u64 {
        u64::from(self.frames_done) * self.runs as u64 + self.runs_done as u64 * u64::from(self.in_flight)
    }
}

/// Replays `trace` with each `(preset, options)` of `runs`, frame by frame in lockstep with
/// the reference (`forward` under `reference` options, when given) so that relative cost and
/// quality are measured per frame while only the frames in flight have images alive. A run of the
/// reference preset itself, under the reference's options, is a copy of the reference run (one
/// replay, not two).
/// Without a `sink` no picture is wanted: the frames skip their cost heat maps (which only
/// pictures show) and keep no images; without a reference either, nothing reads a colour and
/// the frames skip them too ([`Colors`]). Every number is the same.
/// With more than one thread a run replays [`FRAMES_IN_FLIGHT`] frames at once, so the
/// reference keeps as many frames for comparison (one thread gains nothing from it and keeps
/// one). `progress` hears after every run of every such group of frames.
pub fn replay_all(
    trace: &LoadedTrace,
    runs: &[(Preset, ReplayOptions)],
    reference: Option<&ReplayOptions>,
    mut sink: Option<&mut ImageSink>,
    progress: &mut dyn FnMut(ReplayStep),
) -> Result<Vec<RunOutput>, String> {
    let heat = match sink {
        Some(_) => CostHeat::Kept,
        None => CostHeat::Skipped,
    };
    let colors = match (&sink, reference) {
        (None, None) => Colors::Skipped,
        _ => Colors::Kept,
    };
    let mut replays = runs
        .iter()
        .map(|(preset, opts)| Replay::new(trace, preset, opts))
        .collect::<Result<Vec<_>, _>>()?;
    let mut reference = match reference {
        Some(opts) => Some(Replay::new(trace, &Preset::find(REFERENCE_PRESET)?, opts)?),
        None => None,
    };
    let frames = match (&reference, replays.first()) {
        (Some(r), _) | (None, Some(r)) => r.frames.clone(),
        (None, None) => return Ok(Vec::new()),
    };
    if let Some(other) = replays.iter().find(|r| r.frames != frames) {
        return Err(format!(
            "preset {}: frames {}..{} differ from the reference's {}..{}",
            other.preset.label(),
            other.frames.start,
            other.frames.end,
            frames.start,
            frames.end
        ));
    }
    // A run of the reference preset under the reference's options would replay exactly
    // what the reference does (replays are deterministic): it records a copy of the
    // reference's frame instead.
    let mirrors: Vec<bool> = replays
        .iter()
        .map(|run| {
            reference
                .as_ref()
                .is_some_and(|r| run.preset.label() == r.preset.label() && run.opts == r.opts)
        })
        .collect();
    let frames: Vec<u32> = frames.collect();
    let in_flight = match rayon::current_num_threads() {
        1 => 1,
        _ => FRAMES_IN_FLIGHT,
    };
    for (group, indices) in frames.chunks(in_flight).enumerate() {
        let mut mirrored = None;
        let reference_frames = match reference.as_mut() {
            Some(r) => {
                let rendered = r.render(trace, indices, heat, colors);
                if mirrors.contains(&true) {
                    mirrored = Some(rendered.clone());
                }
                let mut kept = Vec::with_capacity(indices.len());
                for (&index, (out, took)) in indices.iter().zip(rendered) {
                    kept.push(r.record_reference(out, took, index)?);
                }
                kept
            }
            None => Vec::new(),
        };
        let count = replays.len();
        for (i, replay) in replays.iter_mut().enumerate() {
            let rendered = match mirrored.take_if(|_| mirrors[i]) {
                Some(copy) => copy,
                None => replay.render(trace, indices, heat, colors),
            };
            for (k, (&index, (out, took))) in indices.iter().zip(rendered).enumerate() {
                let images = replay.record(out, took, index, reference_frames.get(k))?;
                if let Some(sink) = sink.as_mut() {
                    let writing = Instant::now();
                    sink(i, &images)?;
                    *replay.stages.entry("images").or_default() += writing.elapsed();
                    replay.first_images.get_or_insert(images);
                }
            }
            progress(ReplayStep {
                frames_done: (group * in_flight) as u32,
                in_flight: indices.len() as u32,
                runs_done: i + 1,
                runs: count,
                preset: &replay.preset.label(),
            });
        }
    }
    let reference_issued = reference.map(|r| r.total.cost.issued());
    Ok(replays.into_iter().map(|r| r.finish(trace, reference_issued)).collect())
}

/// The pixels of a refinement map per refined effect. One pass per effect, each a sum of 0
/// or 1 per pixel into u32s (per chunk of fewer than 2^32 pixels) that compiles to SIMD
/// adds: one pass of four u64 sums took about 16 instructions a pixel, on the main thread.
fn refined_pixels(refinement: &[u8]) -> RefinedPixels {
    let count = |e: Effects| -> u64 {
        let has = |&r: &u8| u32::from(r & e.bits() != 0);
        let chunks = refinement.chunks(u32::MAX as usize);
        chunks.map(|chunk| u64::from(chunk.iter().map(has).sum::<u32>())).sum()
    };
    RefinedPixels {
        diffuse: count(Effects::DIFFUSE),
        specular: count(Effects::SPECULAR),
        shadow: count(Effects::SHADOW),
        any: count(Effects::all()),
    }
}

/// One preset's replay in progress.
struct Replay {
    preset: Preset,
    /// The options resolved against the preset.
    opts: ReplayOptions,
    scheduler: Box<dyn Scheduler>,
    scheme: Box<dyn ShadingScheme>,
    frames: std::ops::Range<u32>,
    results: Vec<FrameResult>,
    total: FrameTotals,
    pixels: u64,
    size: (u32, u32),
    busy: Duration,
    /// Wall time per stage over the frames so far.
    stages: BTreeMap<&'static str, Duration>,
    first_images: Option<FrameImages>,
}

/// A frame's results with its images, as the reference keeps them for comparison, and per
/// view the pixels it covers (for covered-pixel SSIM), found once for every preset.
struct ReferenceFrame {
    result: FrameResult,
    images: FrameImages,
    covered: [Vec<bool>; 2],
    /// Each view's luma, which every comparison with it reads.
    luma: [Vec<f64>; 2],
}

impl Replay {
    fn new(trace: &LoadedTrace, preset: &Preset, opts: &ReplayOptions) -> Result<Replay, String> {
        let opts = preset.resolve(opts);
        opts.check()?;
        preset.supports(&trace.prepared.scene)?;
        let count = trace.frames.len() as u32;
        let (start, end) = opts.frames.unwrap_or((0, count));
        if end > count {
            return Err(format!("--frames {start}..{end}: the trace has {count} frames"));
        }
        let size = opts
            .resolution
            .unwrap_or((trace.meta.capture.eye_width, trace.meta.capture.eye_height));
        Ok(Replay {
            preset: *preset,
            scheduler: preset.scheduler(&opts)?,
            scheme: preset.scheme(&opts),
            opts,
            frames: start..end,
            results: Vec::new(),
            total: FrameTotals::default(),
            pixels: 0,
            size,
            busy: Duration::ZERO,
            stages: BTreeMap::new(),
            first_images: None,
        })
    }

    /// Replays frames `indices` at once, sharing the pool's threads; each comes with its
    /// share of the time that took (the shares add up to it).
    fn render(
        &self,
        trace: &LoadedTrace,
        indices: &[u32],
        heat: CostHeat,
        colors: Colors,
    ) -> Vec<(FrameOutput, Duration)> {
        let started = Instant::now();
        let frame = |index: u32| &trace.frames[index as usize];
        let shared_shadow = match indices {
            [first, _, ..] => Some(share_still_shadow_map(
                &trace.prepared,
                &trace.meta,
                frame(*first),
                &self.opts,
            )),
            _ => None,
        };
        let mode = FrameMode {
            heat,
            colors,
            threads: (rayon::current_num_threads() / indices.len().max(1)).max(1),
        };
        let mut outputs: Vec<FrameOutput> = indices
            .par_iter()
            .map(|&index| {
                run_frame(
                    &trace.prepared,
                    &trace.meta,
                    frame(index),
                    &self.opts,
                    self.scheduler.as_ref(),
                    self.scheme.as_ref(),
                    mode,
                )
            })
            .collect();
        if let (Some(time), Some(first)) = (shared_shadow, outputs.first_mut()) {
            first.stage_times.push(("shadow", time));
        }
        let share = started.elapsed() / indices.len().max(1) as u32;
        outputs.into_iter().map(|out| (out, share)).collect()
    }

    /// Records the reference's frame `index` ([`Self::record`]) and keeps it, with what every
    /// comparison with it reads.
    fn record_reference(&mut self, out: FrameOutput, took: Duration, index: u32) -> Result<ReferenceFrame, String> {
        let images = self.record(out, took, index, None)?;
        let result = self.results.last().cloned().ok_or("the reference made no frame")?;
        let clear = clear_pixel();
        let covered = images
            .views
            .each_ref()
            .map(|v| v.color.pixels.iter().map(|p| *p != clear).collect());
        let luma = images.views.each_ref().map(|v| quality::luma(&v.color));
        Ok(ReferenceFrame {
            result,
            images,
            covered,
            luma,
        })
    }

    /// Records frame `index`'s output (which took `took` to replay) and returns its images;
    /// with the reference's frame, relative cost and quality are filled in.
    fn record(
        &mut self,
        out: FrameOutput,
        took: Duration,
        index: u32,
        reference: Option<&ReferenceFrame>,
    ) -> Result<FrameImages, String> {
        let started = Instant::now();
        for &(stage, time) in &out.stage_times {
            *self.stages.entry(stage).or_default() += time;
        }
        let quality_started = Instant::now();
        let info = self.preset.scheme_info();
        let mut views = Vec::new();
        let mut images = Vec::new();
        let mut views_out = Vec::with_capacity(2);
        for mut view in out.views {
            let color = Rgba8Image {
                width: view.width,
                height: view.height,
                pixels: std::mem::take(&mut view.pixels),
            };
            views_out.push((view, color));
        }
        // Both views' comparisons with the reference at once (each is deterministic alone).
        let compared: Vec<Result<_, String>> = views_out
            .par_iter()
            .enumerate()
            .map(|(v, (view, color))| match reference {
                Some(r) => {
                    let issued = r.result.views[v].cost.issued();
                    let rel = (issued > 0).then(|| view.cost.issued() as f64 / issued as f64);
                    let reference = &r.images.views[v].color;
                    let compared = quality::compare_views(reference, &r.luma[v], color, &r.covered[v])?;
                    let ssim_loss = compared.ssim_map.map(|m| m.iter().map(|&s| (1.0 - s) as f32).collect());
                    Ok((rel, Some(compared.quality), Some(compared.error_map), ssim_loss))
                }
                None => Ok((None, None, None, None)),
            })
            .collect();
        for (v, ((view, color), compared)) in views_out.into_iter().zip(compared).enumerate() {
            self.size = (view.width, view.height);
            self.pixels += (view.width * view.height) as u64;
            let (relative_cost, quality, error, ssim_loss) = compared?;
            self.total.cost.add(&view.cost);
            self.total.shaded_pixels += view.raster.fragments_shaded;
            if let Some(q) = quality.and_then(|q| q.ssim) {
                self.total.min_ssim = Some(self.total.min_ssim.map_or(q, |m: f64| m.min(q)));
            }
            if let Some(q) = quality.and_then(|q| q.ssim_covered) {
                self.total.min_ssim_covered = Some(self.total.min_ssim_covered.map_or(q, |m: f64| m.min(q)));
            }
            let refined_pixels = info.reports_refinement.then(|| refined_pixels(&view.refinement));
            views.push(ViewResult {
                eye: Eye::BOTH[v].name().to_string(),
                vertex: view.vertex,
                raster: view.raster,
                cost: view.cost,
                relative_cost,
                quality,
                refined_pixels,
                shading_cache: info.reports_cache.then_some(view.cache),
            });
            images.push(ViewImages {
                color,
                cost_heat: view.cost_heat,
                refinement: view.refinement,
                error,
                ssim_loss,
            });
        }
        self.total.traffic.add(&out.traffic);
        self.results.push(FrameResult {
            frame: index,
            views,
            traffic: out.traffic,
            caches: out.caches,
            lists: out.lists,
            shadow_pass: out.shadow_pass,
            gbuffer_bytes: out.gbuffer_bytes,
            visibility_bytes: out.visibility_bytes,
            dais: out.dais,
            reprojection: out.reprojection,
        });
        *self.stages.entry("quality").or_default() += quality_started.elapsed();
        self.busy += took + started.elapsed();
        let [left, right]: [ViewImages; 2] = images.try_into().map_err(|_| "a frame has two views".to_string())?;
        Ok(FrameImages {
            frame: index,
            views: [left, right],
        })
    }

    fn finish(mut self, trace: &LoadedTrace, reference_issued: Option<u64>) -> RunOutput {
        if let Some(issued) = reference_issued {
            self.total.relative_cost = (issued > 0).then(|| self.total.cost.issued() as f64 / issued as f64);
        }
        let wall_s = self.busy.as_secs_f64();
        RunOutput {
            result: RunResult {
                schema_version: RESULTS_SCHEMA_VERSION,
                tool_version: env!("CARGO_PKG_VERSION").to_string(),
                trace_name: trace.name.clone(),
                trace_hash: trace.hash.to_hex(),
                preset: self.preset.label(),
                scheduler: self.preset.scheduler_name(&self.opts).to_string(),
                scheme: self.preset.scheme.to_string(),
                options: self.opts.to_map(),
                options_hash: self.opts.hash(),
                eye_width: self.size.0,
                eye_height: self.size.1,
                frames: self.results,
                total: self.total,
                timing: Timing {
                    wall_s,
                    threads: rayon::current_num_threads() as u32,
                    pixels_per_s: self.pixels as f64 / wall_s.max(1e-9),
                    stages_ms: self
                        .stages
                        .iter()
                        .map(|(stage, time)| (stage.to_string(), time.as_secs_f64() * 1e3))
                        .collect(),
                },
            },
            first_images: self.first_images,
        }
    }
}
