//! Named back-ends: a preset is a scheduler times a shading scheme. The tile-pair paper
//! compares schemes under one scheduler and schedulers under one scheme, so both are also
//! reachable directly as `SCHEDULER+SCHEME` (e.g. `sort-middle+per-pixel`).

use crate::options::ReplayOptions;
use crate::schedule::{Immediate, Multiview, Scheduler, SortMiddle, TilePair};
use crate::scheme::multirate::CoarseMode;
use crate::scheme::registry::{self, SchemeEntry, SCHEMES};
use crate::scheme::ShadingScheme;

/// The reference every relative cost and every quality number is measured against.
pub const REFERENCE_PRESET: &str = "forward";

pub const SCHEDULERS: [&str; 4] = ["immediate", "sort-middle", "multiview", "tile-pair"];

/// A named scheduler x scheme pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Preset {
    pub name: &'static str,
    pub scheduler: &'static str,
    pub scheme: &'static str,
    /// Coarse mode of the `multirate` scheme.
    pub mode: Option<CoarseMode>,
    pub description: &'static str,
}

pub const PRESETS: [Preset; 11] = [
    Preset {
        name: "forward",
        scheduler: "immediate",
        scheme: "per-pixel",
        mode: None,
        description: "forward GPU: immediate-mode raster, quad shading per pixel (the reference)",
    },
    Preset {
        name: "sort-middle",
        scheduler: "sort-middle",
        scheme: "per-pixel",
        mode: None,
        description: "tile-based sort-middle: per-view tile lists, each tile finished in turn",
    },
    Preset {
        name: "he-2x2",
        scheduler: "immediate",
        scheme: "multirate",
        mode: Some(CoarseMode::Coarse2x2),
        description: "He et al. 2014 COARSE2x2: coarse shading per 2x2 pixels, adaptive refinement",
    },
    Preset {
        name: "he-4x4",
        scheduler: "immediate",
        scheme: "multirate",
        mode: Some(CoarseMode::Coarse4x4),
        description: "He et al. 2014 COARSE4x4: coarse shading per 4x4 pixels, adaptive refinement",
    },
    Preset {
        name: "he-dynamic",
        scheduler: "immediate",
        scheme: "multirate",
        mode: Some(CoarseMode::Dynamic4x4),
        description: "He et al. 2014 DYNAMIC4x4: 4x4 first, refined blocks re-shaded at 2x2",
    },
    Preset {
        name: "multiview",
        scheduler: "multiview",
        scheme: "per-pixel",
        mode: None,
        description: "Hasselgren & Akenine-Moller 2006: each triangle rasterized to both views together",
    },
    Preset {
        name: "tile-pair-pp",
        scheduler: "tile-pair",
        scheme: "per-pixel",
        mode: None,
        description: "Yuan et al. tile-pair scheduling with per-pixel shading (the bandwidth study)",
    },
    Preset {
        name: "tile-pair",
        scheduler: "tile-pair",
        scheme: "tile-pair-cache",
        mode: Some(CoarseMode::Coarse2x2),
        description: "Yuan et al.: tile-pair scheduling, screen-space shading cache with cross-view reuse",
    },
    Preset {
        name: "amfs",
        scheduler: "tile-pair",
        scheme: "amfs",
        mode: Some(CoarseMode::Coarse2x2),
        description: "AMFS-like patch-space shading cache, local and view-independent (as in the tile-pair paper)",
    },
    Preset {
        name: "texel",
        scheduler: "tile-pair",
        scheme: "texel",
        mode: Some(CoarseMode::Coarse2x2),
        description: "texel shading: texture-space cache over a unique UV atlas (needs one)",
    },
    Preset {
        name: "tile-pair-he-2x2",
        scheduler: "tile-pair",
        scheme: "multirate",
        mode: Some(CoarseMode::Coarse2x2),
        description: "tile-pair scheduling with He et al. COARSE2x2 shading",
    },
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
                return Ok(Preset {
                    name: "custom",
                    scheduler,
                    scheme: scheme.name,
                    mode: None,
                    description: "scheduler x scheme chosen on the command line",
                });
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
