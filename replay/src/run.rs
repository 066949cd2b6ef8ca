//! Replaying a trace with one preset: loading, the frame loop, relative cost and quality
//! against the reference, and the results record.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use std::time::Instant;

use shadetrace_formats::results::{
    FrameResult, FrameTotals, RefinedPixels, RunResult, Timing, ViewResult, RESULTS_SCHEMA_VERSION,
};
use shadetrace_formats::{ContentHash, Eye, Frame, Meta, TraceReader};

use crate::images::Rgba8Image;
use crate::options::ReplayOptions;
use crate::pipeline::{run_frame, PreparedScene};
use crate::preset::Preset;
use crate::quality;
use crate::scheme::{REFINED_DIFFUSE, REFINED_SHADOW, REFINED_SPECULAR};

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
    pub color: Rgba8Image,
    /// Issued shading instructions per pixel.
    pub cost_heat: Vec<u32>,
    /// Per pixel, the effects refined to per-pixel rate (`scheme::REFINED_*` bits).
    pub refinement: Vec<u8>,
}

pub struct FrameImages {
    pub frame: u32,
    pub views: [ViewImages; 2],
}

/// Results and images of one replay.
pub struct RunOutput {
    pub result: RunResult,
    pub images: Vec<FrameImages>,
}

/// Replays `trace` with `preset`. With a `reference` run (same trace and options, preset
/// `forward`), relative cost and quality are filled in.
pub fn replay(
    trace: &LoadedTrace,
    preset: &Preset,
    opts: &ReplayOptions,
    reference: Option<&RunOutput>,
    progress: &mut dyn FnMut(u32),
) -> Result<RunOutput, String> {
    opts.check()?;
    preset.supports(&trace.prepared.scene)?;
    let count = trace.frames.len() as u32;
    let (start, end) = opts.frames.unwrap_or((0, count));
    if end > count {
        return Err(format!("--frames {start}..{end}: the trace has {count} frames"));
    }
    let scheduler = preset.scheduler(opts)?;
    let scheme = preset.scheme(opts);
    let started = Instant::now();
    let mut frames = Vec::new();
    let mut images = Vec::new();
    let mut total = FrameTotals::default();
    let mut pixels = 0u64;
    let (mut width, mut height) = opts
        .resolution
        .unwrap_or((trace.meta.capture.eye_width, trace.meta.capture.eye_height));
    for (done, index) in (start..end).enumerate() {
        let frame = &trace.frames[index as usize];
        let out = run_frame(
            &trace.prepared,
            &trace.meta,
            frame,
            opts,
            scheduler.as_ref(),
            scheme.as_ref(),
        );
        let reference_frame = reference.and_then(|r| {
            let f = r.result.frames.iter().position(|f| f.frame == index)?;
            Some((&r.result.frames[f], &r.images[f]))
        });
        let mut views = Vec::new();
        for (v, view) in out.views.iter().enumerate() {
            width = view.width;
            height = view.height;
            pixels += (view.width * view.height) as u64;
            let (relative_cost, quality) = match reference_frame {
                Some((rf, ri)) => {
                    let issued = rf.views[v].cost.issued();
                    let rel = if issued == 0 {
                        None
                    } else {
                        Some(view.cost.issued() as f64 / issued as f64)
                    };
                    (rel, Some(quality::compare(&ri.views[v].color, &view.image())?))
                }
                None => (None, None),
            };
            total.cost.add(&view.cost);
            total.shaded_pixels += view.raster.fragments_shaded;
            if let Some(q) = quality.and_then(|q| q.ssim) {
                total.min_ssim = Some(total.min_ssim.map_or(q, |m: f64| m.min(q)));
            }
            let refined_pixels = (preset.scheme != "per-pixel").then(|| {
                let count = |bit: u8| view.refinement.iter().filter(|&&r| r & bit != 0).count() as u64;
                RefinedPixels {
                    diffuse: count(REFINED_DIFFUSE),
                    specular: count(REFINED_SPECULAR),
                    shadow: count(REFINED_SHADOW),
                    any: count(REFINED_DIFFUSE | REFINED_SPECULAR | REFINED_SHADOW),
                }
            });
            views.push(ViewResult {
                eye: Eye::BOTH[v].name().to_string(),
                vertex: view.vertex,
                raster: view.raster,
                cost: view.cost.clone(),
                relative_cost,
                quality,
                refined_pixels,
                shading_cache: (preset.scheme != "per-pixel" && preset.scheme != "multirate").then_some(view.cache),
            });
        }
        total.traffic.add(&out.traffic);
        frames.push(FrameResult {
            frame: index,
            views,
            traffic: out.traffic,
            caches: out.caches,
            lists: out.lists,
            shadow_pass: out.shadow_pass,
        });
        let [l, r] = out.views;
        images.push(FrameImages {
            frame: index,
            views: [
                ViewImages {
                    color: l.image(),
                    cost_heat: l.cost_heat,
                    refinement: l.refinement,
                },
                ViewImages {
                    color: r.image(),
                    cost_heat: r.cost_heat,
                    refinement: r.refinement,
                },
            ],
        });
        progress(done as u32 + 1);
    }
    if let Some(r) = reference {
        let issued = r.result.total.cost.issued();
        total.relative_cost = (issued > 0).then(|| total.cost.issued() as f64 / issued as f64);
    }
    let wall_s = started.elapsed().as_secs_f64();
    Ok(RunOutput {
        result: RunResult {
            schema_version: RESULTS_SCHEMA_VERSION,
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
            trace_name: trace.name.clone(),
            trace_hash: trace.hash.to_hex(),
            preset: preset.label(),
            scheduler: preset.scheduler_name(opts).to_string(),
            scheme: preset.scheme.to_string(),
            options: opts.to_map(),
            options_hash: opts.hash(),
            eye_width: width,
            eye_height: height,
            frames,
            total,
            timing: Timing {
                wall_s,
                threads: rayon::current_num_threads() as u32,
                pixels_per_s: pixels as f64 / wall_s.max(1e-9),
            },
        },
        images,
    })
}
