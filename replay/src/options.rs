//! Replay options: everything besides the trace and the preset that can change a number.
//! Their canonical text (a sorted key=value list) is hashed to key golden files.

use std::collections::BTreeMap;

use sha2::{Digest, Sha256};

use crate::scheme::multirate::{CoarseMode, ReuseTest, Sampling, SimdSchedule, Thresholds};
use crate::scheme::shading_cache::DEFAULT_CACHE_BYTES;

/// Options shared by every back-end.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayOptions {
    /// Frames to replay, `start..end` (None: all).
    pub frames: Option<(u32, u32)>,
    /// Per-eye resolution override (None: the trace's).
    pub resolution: Option<(u32, u32)>,
    /// Tile edge in pixels (even, 4..=64).
    pub tile: u32,
    /// SIMD width in lanes (1..=64).
    pub simd_width: u32,
    pub texture_cache_kb: u32,
    pub triangle_cache_kb: u32,
    /// The depth and colour caches each hold this many tiles.
    pub framebuffer_cache_tiles: u32,
    /// Samples per pixel: 1, 4 or 8.
    pub msaa: u32,
    pub shadow_map_size: u32,
    /// Depth-only pass first, then shade only the visible surface.
    pub z_prepass: bool,
    /// Runs the preset's shading scheme under another scheduler.
    pub scheduler: Option<String>,
    /// Tile-pair sequences nearest first (the disparity constraint); off for the ablation.
    pub disparity_order: bool,
    pub multirate: MultirateOptions,
}

/// Options of the `multirate` scheme (ignored by other schemes, but part of every options
/// hash so that a golden never matches a run made with other thresholds).
#[derive(Clone, Debug, PartialEq)]
pub struct MultirateOptions {
    /// Overrides the preset's coarse mode.
    pub mode: Option<CoarseMode>,
    pub sampling: Sampling,
    pub small_triangle: bool,
    pub thresholds: Thresholds,
    /// Multiplies the refinement thresholds: 0 refines everything, inf nothing.
    pub threshold_scale: f32,
    pub schedule: SimdSchedule,
    /// Shading-cache size of the cache schemes, KiB per job (an epipolar tile row).
    pub cache_kb: u32,
    /// The tile-pair reuse shader's thresholds.
    pub reuse: ReuseTest,
}

impl Default for MultirateOptions {
    fn default() -> Self {
        MultirateOptions {
            mode: None,
            sampling: Sampling::CoverageBbox,
            small_triangle: true,
            thresholds: Thresholds::default(),
            threshold_scale: 1.0,
            schedule: SimdSchedule::TwoPhase,
            cache_kb: DEFAULT_CACHE_BYTES / 1024,
            reuse: ReuseTest::default(),
        }
    }
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            frames: None,
            resolution: None,
            tile: 16,
            simd_width: 16,
            texture_cache_kb: 16,
            triangle_cache_kb: 8,
            framebuffer_cache_tiles: 2,
            msaa: 1,
            shadow_map_size: 2048,
            z_prepass: false,
            scheduler: None,
            disparity_order: true,
            multirate: MultirateOptions::default(),
        }
    }
}

impl ReplayOptions {
    /// Checks ranges; the message names the flag.
    pub fn check(&self) -> Result<(), String> {
        if !(4..=64).contains(&self.tile) || self.tile % 2 != 0 {
            return Err(format!("--tile {} must be even and within 4..=64", self.tile));
        }
        if !(1..=64).contains(&self.simd_width) {
            return Err(format!("--simd {} must be within 1..=64", self.simd_width));
        }
        if ![1, 4, 8].contains(&self.msaa) {
            return Err(format!("--msaa {} must be 1, 4 or 8", self.msaa));
        }
        if !(16..=16384).contains(&self.shadow_map_size) {
            return Err(format!(
                "--shadow-map {} must be within 16..=16384",
                self.shadow_map_size
            ));
        }
        if self.framebuffer_cache_tiles == 0 {
            return Err("--fb-cache-tiles must be at least 1".into());
        }
        if let Some((w, h)) = self.resolution {
            if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
                return Err(format!("--res {w}x{h}: each edge must be 1..=16384"));
            }
        }
        let t = &self.multirate.thresholds;
        for (name, v) in [
            ("--t-diffuse", t.diffuse),
            ("--t-specular", t.specular),
            ("--t-shadow", t.shadow),
            ("--threshold-scale", self.multirate.threshold_scale),
            ("--reuse-position", self.multirate.reuse.position),
            ("--reuse-normal", self.multirate.reuse.normal),
            ("--reuse-r-dot-l", self.multirate.reuse.r_dot_l),
        ] {
            if v.is_nan() || v < 0.0 {
                return Err(format!("{name} {v} must be a non-negative number (inf allowed)"));
            }
        }
        if !(t.lambda.is_finite() && t.edge_delta.is_finite() && t.edge_delta >= 0.0) {
            return Err(format!(
                "--lambda {} and --edge-delta {} must be finite",
                t.lambda, t.edge_delta
            ));
        }
        if let Some((a, b)) = self.frames {
            if a >= b {
                return Err(format!("--frames {a}..{b} is empty"));
            }
        }
        Ok(())
    }

    /// Every option by name, as recorded in results. Options added after goldens were first
    /// keyed (the reuse thresholds) appear only when set away from their defaults, so the
    /// options hash of every existing golden, ours and users', stays the same.
    pub fn to_map(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        let frames = self.frames.map_or("all".to_string(), |(a, b)| format!("{a}..{b}"));
        let res = self.resolution.map_or("trace".to_string(), |(w, h)| format!("{w}x{h}"));
        m.insert("frames".into(), frames);
        m.insert("resolution".into(), res);
        m.insert("tile".into(), self.tile.to_string());
        m.insert("simd_width".into(), self.simd_width.to_string());
        m.insert("texture_cache_kb".into(), self.texture_cache_kb.to_string());
        m.insert("triangle_cache_kb".into(), self.triangle_cache_kb.to_string());
        m.insert(
            "framebuffer_cache_tiles".into(),
            self.framebuffer_cache_tiles.to_string(),
        );
        m.insert("msaa".into(), self.msaa.to_string());
        m.insert("shadow_map_size".into(), self.shadow_map_size.to_string());
        m.insert("z_prepass".into(), self.z_prepass.to_string());
        m.insert(
            "scheduler".into(),
            self.scheduler.clone().unwrap_or_else(|| "preset".into()),
        );
        m.insert("disparity_order".into(), self.disparity_order.to_string());
        let mr = &self.multirate;
        m.insert("multirate.cache_kb".into(), mr.cache_kb.to_string());
        let t = &mr.thresholds;
        m.insert(
            "multirate.mode".into(),
            mr.mode.map_or("preset".to_string(), |c| c.name().to_string()),
        );
        m.insert("multirate.sampling".into(), mr.sampling.name().into());
        m.insert("multirate.small_triangle".into(), mr.small_triangle.to_string());
        m.insert("multirate.schedule".into(), mr.schedule.name().into());
        m.insert("multirate.threshold_scale".into(), mr.threshold_scale.to_string());
        m.insert("multirate.t_diffuse".into(), t.diffuse.to_string());
        m.insert("multirate.t_specular".into(), t.specular.to_string());
        m.insert("multirate.t_shadow".into(), t.shadow.to_string());
        m.insert("multirate.lambda".into(), t.lambda.to_string());
        m.insert("multirate.edge_delta".into(), t.edge_delta.to_string());
        let (reuse, default) = (mr.reuse, ReuseTest::default());
        for (name, v, d) in [
            ("position", reuse.position, default.position),
            ("normal", reuse.normal, default.normal),
            ("r_dot_l", reuse.r_dot_l, default.r_dot_l),
        ] {
            if v != d {
                m.insert(format!("multirate.reuse_{name}"), v.to_string());
            }
        }
        m
    }

    /// SHA-256 of the canonical `key=value\n` text of [`ReplayOptions::to_map`].
    pub fn hash(&self) -> String {
        let mut h = Sha256::new();
        for (k, v) in self.to_map() {
            h.update(format!("{k}={v}\n"));
        }
        h.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }
}
