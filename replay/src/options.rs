//! Replay options: everything besides the trace and the preset that can change a number.
//! One struct is the command line (clap), the defaults and the options map recorded in
//! results (serde); the map's canonical text (sorted `key=value` lines) is hashed to key
//! golden files. Scheme families own their options (`MultirateOptions`).

use std::collections::BTreeMap;
use std::fmt::Display;

use serde::{Serialize, Serializer};
use serde_json::Value;
use sha2::{Digest, Sha256};

pub use crate::scheme::multirate::config::MultirateOptions;

/// Options shared by every back-end.
#[derive(Clone, Debug, PartialEq, clap::Args, Serialize)]
pub struct ReplayOptions {
    /// Frames to replay, START..END (end exclusive) or a single frame N.
    #[arg(long, value_name = "START..END", value_parser = parse_frames)]
    #[serde(serialize_with = "frames_text")]
    pub frames: Option<(u32, u32)>,
    /// Per-eye resolution override, WIDTHxHEIGHT (default: the trace's).
    #[arg(long = "res", value_name = "WIDTHxHEIGHT", value_parser = parse_resolution)]
    #[serde(serialize_with = "resolution_text")]
    pub resolution: Option<(u32, u32)>,
    /// Tile edge in pixels (even, 4..64).
    #[arg(long, default_value_t = DEFAULT_OPTIONS.tile)]
    pub tile: u32,
    /// SIMD width in lanes (1..64).
    #[arg(long = "simd", default_value_t = DEFAULT_OPTIONS.simd_width)]
    pub simd_width: u32,
    /// Texture cache size in KiB.
    #[arg(long, default_value_t = DEFAULT_OPTIONS.texture_cache_kb)]
    pub texture_cache_kb: u32,
    /// Triangle (vertex) data cache size in KiB.
    #[arg(long, default_value_t = DEFAULT_OPTIONS.triangle_cache_kb)]
    pub triangle_cache_kb: u32,
    /// The depth and colour caches each hold this many tiles.
    #[arg(long = "fb-cache-tiles", default_value_t = DEFAULT_OPTIONS.framebuffer_cache_tiles)]
    pub framebuffer_cache_tiles: u32,
    /// Samples per pixel (1, 4 or 8).
    #[arg(long, default_value_t = DEFAULT_OPTIONS.msaa)]
    pub msaa: u32,
    /// Shadow-map edge in texels.
    #[arg(long = "shadow-map", default_value_t = DEFAULT_OPTIONS.shadow_map_size)]
    pub shadow_map_size: u32,
    /// Depth-only pre-pass, then shade only the visible surface.
    #[arg(long)]
    pub z_prepass: bool,
    /// Run the preset's shading scheme under this scheduler (immediate, sort-middle,
    /// multiview, tile-pair).
    #[arg(long = "schedule")]
    #[serde(serialize_with = "scheduler_text")]
    pub scheduler: Option<String>,
    /// Tile-pair: process sequences leftmost first instead of nearest first (Fig. 13
    /// ablation).
    #[arg(long = "no-disparity-order", action = clap::ArgAction::SetFalse)]
    pub disparity_order: bool,
    /// DAIS: entries of the memoization cache that stores each visible triangle once (a
    /// power of two, two per bucket; the paper's 2^13 by default).
    #[arg(long, default_value_t = DEFAULT_OPTIONS.memo_entries)]
    #[serde(skip_serializing_if = "default_memo_entries")]
    pub memo_entries: u64,
    /// Reprojection: the warping grid's cell edge in pixels (the paper's 16).
    #[arg(long, default_value_t = DEFAULT_OPTIONS.grid_cell)]
    #[serde(skip_serializing_if = "default_grid_cell")]
    pub grid_cell: u32,
    /// Reprojection: the binocular-parallax difference, in minutes of arc, above which a grid
    /// cell is tessellated to pixels and a grid triangle is a depth discontinuity (the
    /// paper's 1, the stereo acuity).
    #[arg(long, default_value_t = DEFAULT_OPTIONS.parallax_threshold)]
    #[serde(serialize_with = "display", skip_serializing_if = "default_parallax")]
    pub parallax_threshold: f32,
    /// Ray-traced hole filling: BVH cache size in KiB.
    #[arg(long, default_value_t = DEFAULT_OPTIONS.bvh_cache_kb)]
    #[serde(skip_serializing_if = "default_bvh_cache")]
    pub bvh_cache_kb: u32,
    /// Reprojection: measure the specular-only error, the right view's error from carrying
    /// the left eye's shading (each reprojected pixel's surface shaded from both eyes; costs
    /// simulator time, not modelled instructions).
    #[arg(long)]
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub specular_error: bool,
    #[command(flatten)]
    pub multirate: MultirateOptions,
}

pub const DEFAULT_OPTIONS: ReplayOptions = ReplayOptions {
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
    memo_entries: 1 << 13,
    grid_cell: 16,
    parallax_threshold: 1.0,
    bvh_cache_kb: 32,
    specular_error: false,
    multirate: crate::scheme::multirate::config::DEFAULT_MULTIRATE,
};

impl Default for ReplayOptions {
    fn default() -> Self {
        DEFAULT_OPTIONS
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
        if !(2..=1 << 24).contains(&self.memo_entries) || !self.memo_entries.is_power_of_two() {
            return Err(format!(
                "--memo-entries {} must be a power of two within 2..=16777216",
                self.memo_entries
            ));
        }
        if !(2..=256).contains(&self.grid_cell) {
            return Err(format!("--grid-cell {} must be within 2..=256", self.grid_cell));
        }
        if !self.parallax_threshold.is_finite() || self.parallax_threshold < 0.0 {
            return Err(format!(
                "--parallax-threshold {} must be a finite number of arc minutes, at least 0",
                self.parallax_threshold
            ));
        }
        if self.bvh_cache_kb == 0 {
            return Err("--bvh-cache-kb must be at least 1".into());
        }
        if self.framebuffer_cache_tiles == 0 {
            return Err("--fb-cache-tiles must be at least 1".into());
        }
        if let Some((w, h)) = self.resolution {
            if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
                return Err(format!("--res {w}x{h}: each edge must be 1..=16384"));
            }
        }
        if let Some((a, b)) = self.frames {
            if a >= b {
                return Err(format!("--frames {a}..{b} is empty"));
            }
        }
        self.multirate.check()
    }

    /// Every option by name (`multirate.` before a scheme family's own), as recorded in
    /// results. Options added after goldens were first keyed appear only when set away from
    /// their defaults, so the options hash of every existing golden, ours and users', stays.
    pub fn to_map(&self) -> BTreeMap<String, String> {
        let mut map = BTreeMap::new();
        let value = serde_json::to_value(self).expect("options serialize to JSON");
        flatten("", &value, &mut map);
        map
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

/// Added after goldens were first keyed: in the options map only when set.
fn default_memo_entries(v: &u64) -> bool {
    *v == DEFAULT_OPTIONS.memo_entries
}

fn default_grid_cell(v: &u32) -> bool {
    *v == DEFAULT_OPTIONS.grid_cell
}

fn default_parallax(v: &f32) -> bool {
    *v == DEFAULT_OPTIONS.parallax_threshold
}

fn default_bvh_cache(v: &u32) -> bool {
    *v == DEFAULT_OPTIONS.bvh_cache_kb
}

/// Nested objects become dotted keys; values their text.
fn flatten(prefix: &str, value: &Value, map: &mut BTreeMap<String, String>) {
    match value {
        Value::Object(fields) => {
            for (k, v) in fields {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, map);
            }
        }
        Value::String(s) => {
            map.insert(prefix.to_string(), s.clone());
        }
        other => {
            map.insert(prefix.to_string(), other.to_string());
        }
    }
}

/// Serializes a value as its `Display` text (floats as `0.002`, `1`, `inf`: JSON numbers
/// would print `1.0` and lose infinity).
pub fn display<T: Display, S: Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(v)
}

fn frames_text<S: Serializer>(frames: &Option<(u32, u32)>, s: S) -> Result<S::Ok, S::Error> {
    match frames {
        Some((a, b)) => s.collect_str(&format_args!("{a}..{b}")),
        None => s.serialize_str("all"),
    }
}

fn resolution_text<S: Serializer>(res: &Option<(u32, u32)>, s: S) -> Result<S::Ok, S::Error> {
    match res {
        Some((w, h)) => s.collect_str(&format_args!("{w}x{h}")),
        None => s.serialize_str("trace"),
    }
}

fn scheduler_text<S: Serializer>(scheduler: &Option<String>, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(scheduler.as_deref().unwrap_or("preset"))
}

pub fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}` is not WIDTHxHEIGHT"))
    };
    Ok((parse(w)?, parse(h)?))
}

fn parse_frames(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not START..END or N");
    match s.split_once("..") {
        Some((a, b)) => Ok((a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?)),
        None => {
            let n: u32 = s.parse().map_err(|_| bad())?;
            Ok((n, n.saturating_add(1)))
        }
    }
}
