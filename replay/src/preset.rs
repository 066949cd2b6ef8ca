//! Named back-ends: a preset is a scheduler times a shading scheme. The tile-pair paper
//! compares schemes under one scheduler and schedulers under one scheme, so both are also
//! reachable directly as `SCHEDULER+SCHEME` (e.g. `sort-middle+per-pixel`).

use crate::options::ReplayOptions;
use crate::schedule::{Immediate, Multiview, Scheduler, SortMiddle, TilePair};
use crate::scheme::multirate::{CoarseMode, Sampling};
use crate::scheme::registry::{self, SchemeEntry, SCHEMES};
use crate::scheme::ShadingScheme;

/// The reference every relative cost and every quality number is measured against.
pub const REFERENCE_PRESET: &str = "forward";

pub const SCHEDULERS: [&str; 4] = ["immediate", "sort-middle", "multiview", "tile-pair"];

/// A named scheduler x scheme pair, with the multi-rate settings of the paper it is named
/// after (command-line flags override them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Preset {
    pub name: &'static str,
    pub scheduler: &'static str,
    pub scheme: &'static str,
    /// Coarse mode of the multi-rate schemes.
    pub mode: Option<CoarseMode>,
    /// Sample placement of screen-block multi-rate schemes.
    pub sampling: Option<Sampling>,
    /// He et al.'s small-triangle path of screen-block multi-rate schemes.
    pub small_triangle: Option<bool>,
    pub description: &'static str,
}

const fn preset(
    name: &'static str,
    scheduler: &'static str,
    scheme: &'static str,
    description: &'static str,
) -> Preset {
    Preset {
        name,
        scheduler,
        scheme,
        mode: None,
        sampling: None,
        small_triangle: None,
        description,
    }
}

const fn multirate(preset: Preset, mode: CoarseMode, sampling: Option<Sampling>) -> Preset {
    Preset {
        mode: Some(mode),
        sampling,
        ..preset
    }
}

const fn without_small_triangle_path(preset: Preset) -> Preset {
    Preset {
        small_triangle: Some(false),
        ..preset
    }
}

/// The tile-pair paper (§6) runs every multi-rate method in DYNAMIC4x4 with static-corner
/// samples (He et al. and tile-pair) under tile-pair scheduling, with He et al.'s
/// predicates. Its own method has no small-triangle path: tiny triangles meet its cache
/// (their shading cost stays flat under tessellation, Fig. 9), which exact per-pixel
/// shading of small blocks would bypass. He et al.'s own presets keep their paper's
/// coverage-bbox samples, small-triangle path and immediate pipeline.
pub const PRESETS: [Preset; 22] = [
    preset(
        "forward",
        "immediate",
        "per-pixel",
        "forward GPU: immediate-mode raster, quad shading per pixel (the reference)",
    ),
    preset(
        "sort-middle",
        "sort-middle",
        "per-pixel",
        "tile-based sort-middle: per-view tile lists, each tile finished in turn",
    ),
    multirate(
        preset(
            "he-2x2",
            "immediate",
            "multirate",
            "He et al. 2014 COARSE2x2: coarse shading per 2x2 pixels, adaptive refinement",
        ),
        CoarseMode::Coarse2x2,
        None,
    ),
    multirate(
        preset(
            "he-4x4",
            "immediate",
            "multirate",
            "He et al. 2014 COARSE4x4: coarse shading per 4x4 pixels, adaptive refinement",
        ),
        CoarseMode::Coarse4x4,
        None,
    ),
    multirate(
        preset(
            "he-dynamic",
            "immediate",
            "multirate",
            "He et al. 2014 DYNAMIC4x4: 4x4 first, refined blocks re-shaded at 2x2",
        ),
        CoarseMode::Dynamic4x4,
        None,
    ),
    preset(
        "multiview",
        "multiview",
        "per-pixel",
        "Hasselgren & Akenine-Moller 2006: each triangle rasterized to both views together",
    ),
    preset(
        "tile-pair-pp",
        "tile-pair",
        "per-pixel",
        "Yuan et al. tile-pair scheduling with per-pixel shading (the bandwidth study)",
    ),
    without_small_triangle_path(multirate(
        preset(
            "tile-pair",
            "tile-pair",
            "tile-pair-cache",
            "Yuan et al.: tile-pair scheduling, screen-space shading cache with cross-view reuse (DYNAMIC4x4, static corner)",
        ),
        CoarseMode::Dynamic4x4,
        Some(Sampling::StaticCorner),
    )),
    multirate(
        preset(
            "tile-pair-he",
            "tile-pair",
            "multirate",
            "He et al. as the tile-pair paper compares it: tile-pair scheduling, DYNAMIC4x4, static corner",
        ),
        CoarseMode::Dynamic4x4,
        Some(Sampling::StaticCorner),
    ),
    multirate(
        preset(
            "amfs",
            "tile-pair",
            "amfs",
            "AMFS-like patch-space shading cache, local and view-independent (as in the tile-pair paper, DYNAMIC4x4)",
        ),
        CoarseMode::Dynamic4x4,
        None,
    ),
    multirate(
        preset(
            "texel",
            "tile-pair",
            "texel",
            "texel shading: texture-space cache over a unique UV atlas (needs one; DYNAMIC4x4)",
        ),
        CoarseMode::Dynamic4x4,
        None,
    ),
    multirate(
        preset(
            "tile-pair-he-2x2",
            "tile-pair",
            "multirate",
            "tile-pair scheduling with He et al. COARSE2x2 shading (coverage-bbox)",
        ),
        CoarseMode::Coarse2x2,
        None,
    ),
    preset(
        "deferred",
        "immediate",
        "deferred",
        "deferred shading (RTR4 20.1): a 20-byte G-buffer pass, then a lighting pass per tile",
    ),
    preset(
        "tiled",
        "immediate",
        "tiled",
        "tiled deferred shading (RTR4 20.3): per 16x16 tile a light list from its depth bounds",
    ),
    preset(
        "clustered",
        "immediate",
        "clustered",
        "clustered deferred shading (RTR4 20.4): light lists per 64x64 px x 16 depth slices",
    ),
    preset(
        "forward+",
        "immediate",
        "forward-plus",
        "tiled forward (RTR4 20.3): z-prepass, then forward shading with per-16x16-tile light lists",
    ),
    preset(
        "visbuffer",
        "immediate",
        "visbuffer",
        "visibility buffer (RTR4 20.5): 8-byte triangle ids per sample, attributes re-fetched when shading",
    ),
    preset(
        "dais",
        "immediate",
        "dais",
        "deferred attribute interpolation (Schied and Dachsbacher 2015): z-prepass, 4-byte sample references into a memoized triangle buffer",
    ),
    preset(
        "dais-list",
        "immediate",
        "dais-list",
        "DAIS with per-pixel linked lists of visibility samples",
    ),
    preset(
        "dais-multirate",
        "immediate",
        "dais-multirate",
        "DAIS with lighting at shading rate 1/2 in 2x2 shading quads",
    ),
    preset(
        "repro-rt",
        "immediate",
        "repro-rt",
        "hybrid reprojection (Wißmann et al. 2020): left view deferred, right view warped by an adaptive grid, holes ray traced",
    ),
    preset(
        "repro-reraster",
        "immediate",
        "repro-reraster",
        "hybrid reprojection with rasterized hole filling: the right view drawn again, only its holes shaded",
    ),
];

impl Preset {
    /// A preset by name, or an ad-hoc `SCHEDULER+SCHEME` pair.
    pub fn find(name: &str) -> Result<Preset, String> {
        if let Some(p) = PRESETS.iter().find(|p| p.name == name) {
            return Ok(*p);
        }
        if let Some((scheduler, scheme)) = name.split_once('+') {
            let scheduler = SCHEDULERS.iter().find(|s| **s == scheduler);
            if let (Some(scheduler), Some(scheme)) = (scheduler, registry::scheme(scheme)) {
                return Ok(preset(
                    "custom",
                    scheduler,
                    scheme.name,
                    "scheduler x scheme chosen on the command line",
                ));
            }
        }
        let names: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
        Err(format!(
            "unknown preset `{name}` (presets: {}; or SCHEDULER+SCHEME with schedulers {} and schemes {})",
            names.join(", "),
            SCHEDULERS.join(", "),
            SCHEMES.map(|s| s.name).join(", ")
        ))
    }

    /// The scheduler, unless `--schedule` names another.
    pub fn scheduler_name<'a>(&'a self, opts: &'a ReplayOptions) -> &'a str {
        opts.scheduler.as_deref().unwrap_or(self.scheduler)
    }

    pub fn scheduler(&self, opts: &ReplayOptions) -> Result<Box<dyn Scheduler>, String> {
        match self.scheduler_name(opts) {
            "immediate" => Ok(Box::new(Immediate)),
            "sort-middle" => Ok(Box::new(SortMiddle)),
            "multiview" => Ok(Box::new(Multiview)),
            "tile-pair" => Ok(Box::new(TilePair {
                disparity_order: opts.disparity_order,
            })),
            other => Err(format!(
                "unknown scheduler `{other}` (schedulers: {})",
                SCHEDULERS.join(", ")
            )),
        }
    }

    /// `opts` with the preset's settings where the command line left them open: what the
    /// run uses and what its results record.
    pub fn resolve(&self, opts: &ReplayOptions) -> ReplayOptions {
        let mut resolved = opts.clone();
        resolved.multirate.sampling = opts.multirate.sampling.or(self.sampling);
        resolved.multirate.small_triangle = opts.multirate.small_triangle.or(self.small_triangle);
        resolved
    }

    /// The registry entry of the preset's scheme.
    pub fn scheme_info(&self) -> &'static SchemeEntry {
        registry::scheme(self.scheme).expect("presets name registered schemes")
    }

    pub fn scheme(&self, opts: &ReplayOptions) -> Box<dyn ShadingScheme> {
        (self.scheme_info().build)(self, opts)
    }

    /// Whether the preset can run on a trace; the error names the preset and what is missing.
    pub fn supports(&self, scene: &shadetrace_formats::Scene) -> Result<(), String> {
        (self.scheme_info().supports)(scene).map_err(|why| format!("preset {}: {why}", self.label()))
    }

    /// Name used in results: the preset's, or `scheduler+scheme` for ad-hoc pairs.
    pub fn label(&self) -> String {
        if self.name == "custom" {
            format!("{}+{}", self.scheduler, self.scheme)
        } else {
            self.name.to_string()
        }
    }
}
