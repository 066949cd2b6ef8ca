//! The results schema: what a replay reports, as JSON (schema-versioned) and CSV. It lives
//! here, beside the trace schema, so tools can read results without linking a back-end.
//!
//! Integers are exact model counts; floats are quality metrics and derived ratios. Wall-clock
//! timing is kept apart in [`Timing`] so that golden comparisons and determinism checks can
//! ignore it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Bumped when a field changes meaning or disappears (adding fields is compatible).
pub const RESULTS_SCHEMA_VERSION: u32 = 1;

/// One replay of one trace with one preset and one set of options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    pub schema_version: u32,
    pub tool_version: String,
    pub trace_name: String,
    pub trace_hash: String,
    pub preset: String,
    pub scheduler: String,
    pub scheme: String,
    /// Every option that can change a number, by name.
    pub options: BTreeMap<String, String>,
    /// SHA-256 over the canonical `options` text: with the trace hash and the preset it keys
    /// golden files.
    pub options_hash: String,
    pub eye_width: u32,
    pub eye_height: u32,
    pub frames: Vec<FrameResult>,
    /// Sums over frames.
    pub total: FrameTotals,
    pub timing: Timing,
}

impl RunResult {
    /// Every float field that is NaN or infinite, by path. JSON has no NaN (serde_json
    /// writes `null`), so results are checked before they are written.
    pub fn non_finite_fields(&self) -> Vec<String> {
        let mut bad = Vec::new();
        let mut check = |path: String, v: Option<f64>| {
            if v.is_some_and(|v| !v.is_finite()) {
                bad.push(path);
            }
        };
        for (f, frame) in self.frames.iter().enumerate() {
            for (v, view) in frame.views.iter().enumerate() {
                let at = format!("frames[{f}].views[{v}]");
                check(format!("{at}.relative_cost"), view.relative_cost);
                if let Some(q) = view.quality {
                    check(format!("{at}.quality.ssim"), q.ssim);
                    check(format!("{at}.quality.ssim_covered"), q.ssim_covered);
                    check(format!("{at}.quality.psnr_db"), q.psnr_db);
                }
            }
        }
        check("total.relative_cost".into(), self.total.relative_cost);
        check("total.min_ssim".into(), self.total.min_ssim);
        check("total.min_ssim_covered".into(), self.total.min_ssim_covered);
        check("timing.wall_s".into(), Some(self.timing.wall_s));
        check("timing.pixels_per_s".into(), Some(self.timing.pixels_per_s));
        for (stage, &ms) in &self.timing.stages_ms {
            check(format!("timing.stages_ms.{stage}"), Some(ms));
        }
        bad
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameResult {
    pub frame: u32,
    pub views: Vec<ViewResult>,
    pub traffic: Traffic,
    pub caches: CacheReport,
    pub lists: ListStats,
    pub shadow_pass: Option<ShadowPassStats>,
    /// Bytes of the G-buffer of both views (deferred schemes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gbuffer_bytes: Option<u64>,
    /// Bytes of the visibility buffer of both views (`visbuffer` and `dais` schemes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visibility_bytes: Option<u64>,
    /// The triangle buffer, its memoization cache and the memory of the shading pass
    /// (`dais` schemes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dais: Option<DaisStats>,
    /// The right view made from the left one (`repro-*` presets only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reprojection: Option<ReprojectionStats>,
}

/// Hybrid reprojection (Wißmann et al. 2020): the adaptive warping grid, the holes it
/// leaves in the right view and how they were filled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ReprojectionStats {
    pub grid_cells: u64,
    /// Cells whose binocular-parallax difference exceeds the threshold.
    pub cells_over_threshold: u64,
    /// Cells tessellated to one vertex per pixel: those, and their 4-neighbours.
    pub cells_tessellated: u64,
    pub grid_vertices: u64,
    pub grid_triangles: u64,
    /// Grid triangles across a depth discontinuity (rubber sheets), not drawn.
    pub grid_triangles_discarded: u64,
    /// Right-view pixels that the warped grid covers.
    pub reprojected_pixels: u64,
    /// Right-view pixels no kept grid triangle covers: traced or re-rasterized.
    pub hole_pixels: u64,
    /// Primary rays traced (`repro-rt`), the ones that hit, and the work of their traversal.
    pub rays: u64,
    pub ray_hits: u64,
    pub node_visits: u64,
    pub triangle_tests: u64,
    /// The frame's BVH (`repro-rt`): nodes and bytes (nodes and triangles).
    pub bvh_nodes: u64,
    pub bvh_bytes: u64,
    /// With `--specular-error`: over the reprojected pixels, the largest channel difference
    /// (8-bit sRGB) between their surface shaded from the left eye (what is carried) and from
    /// the right eye: its sum (the mean is `/ reprojected_pixels`), its maximum and the pixels
    /// where it is not 0. The view-dependent error alone, without resampling or holes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular_error: Option<SpecularError>,
}

/// The view-dependent error of reprojection (see [`ReprojectionStats::specular_error`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SpecularError {
    pub sum: u64,
    pub max: u64,
    pub pixels: u64,
}

/// Deferred attribute interpolation (Schied and Dachsbacher 2015), both views: the
/// memoization cache that stores each visible triangle once, and the buffers of Table 1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DaisStats {
    /// Fragment invocations of the fill pass, each looking its triangle up.
    pub memo_lookups: u64,
    pub memo_hits: u64,
    /// Lookups that found no entry: each stores its triangle in the triangle buffer.
    pub memo_misses: u64,
    /// Misses on a triangle that was stored before and evicted since: stored twice.
    pub redundant_stores: u64,
    /// Bytes of the memoization cache (entries and per-bucket locks).
    pub memo_cache_bytes: u64,
    /// Triangles stored, 80 bytes each.
    pub triangle_buffer_bytes: u64,
    /// The multisampled depth buffer.
    pub depth_bytes: u64,
    /// Linked-list nodes (`dais-list`: one per triangle of a pixel not fully covered by one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub list_nodes: Option<u64>,
    /// Shading samples at the reduced rate (`dais-multirate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading_samples: Option<u64>,
    /// Everything the shading pass reads, as Table 1's total: depth, visibility buffer (or
    /// list heads and nodes), triangle buffer, shading-sample references and samples.
    pub total_bytes: u64,
}

/// Per-view counters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewResult {
    pub eye: String,
    pub vertex: VertexStats,
    pub raster: RasterStats,
    pub cost: ShadingCost,
    /// Issued instructions relative to the reference (immediate x per-pixel) on the same
    /// frame and view; absent when the reference was not run.
    pub relative_cost: Option<f64>,
    pub quality: Option<Quality>,
    /// Pixels whose shading refined each effect to per-pixel rate (multi-rate schemes only).
    pub refined_pixels: Option<RefinedPixels>,
    /// Shading-cache activity (cache schemes: `tile-pair-cache`, `amfs`, `texel`).
    pub shading_cache: Option<ShadingCacheStats>,
}

/// Activity of a shading cache in one view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShadingCacheStats {
    /// Coarse fragments looked up.
    pub queries: u64,
    /// Hits on shading of this view.
    pub local_hits: u64,
    /// Hits on shading of the other view: after the reuse test (tile-pair), or as it is
    /// (object-space caches, which are view-independent).
    pub cross_view_hits: u64,
    /// Hits whose reuse test failed.
    pub rejected: u64,
    pub evictions: u64,
    /// Coarse blocks (object space: cells) whose shader was skipped (all four fragments or
    /// corners reused).
    pub blocks_skipped: u64,
    pub blocks_shaded: u64,
}

impl ShadingCacheStats {
    pub fn add(&mut self, o: &ShadingCacheStats) {
        self.queries += o.queries;
        self.local_hits += o.local_hits;
        self.cross_view_hits += o.cross_view_hits;
        self.rejected += o.rejected;
        self.evictions += o.evictions;
        self.blocks_skipped += o.blocks_skipped;
        self.blocks_shaded += o.blocks_shaded;
    }
}

/// Pixel counts per refined effect.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RefinedPixels {
    pub diffuse: u64,
    pub specular: u64,
    pub shadow: u64,
    /// Pixels with at least one refined effect.
    pub any: u64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameTotals {
    pub cost: ShadingCost,
    pub traffic: Traffic,
    pub relative_cost: Option<f64>,
    /// Lowest SSIM over all frames and views.
    pub min_ssim: Option<f64>,
    /// Lowest covered-pixel SSIM over all frames and views.
    #[serde(default)]
    pub min_ssim_covered: Option<f64>,
    pub shaded_pixels: u64,
}

/// What the vertex stage did in one view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct VertexStats {
    pub triangles_in: u64,
    pub culled_frustum: u64,
    pub culled_backface: u64,
    pub culled_degenerate: u64,
    pub clipped: u64,
    pub setup_triangles: u64,
}

impl VertexStats {
    pub fn add(&mut self, o: &VertexStats) {
        self.triangles_in += o.triangles_in;
        self.culled_frustum += o.culled_frustum;
        self.culled_backface += o.culled_backface;
        self.culled_degenerate += o.culled_degenerate;
        self.clipped += o.clipped;
        self.setup_triangles += o.setup_triangles;
    }
}

/// Rasterization and depth-test counts in one view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RasterStats {
    /// (triangle, tile) pairs the scheduler issued.
    pub units: u64,
    /// Units culled whole: their nearest depth lies behind the farthest depth of the tile
    /// (one bound per tile; the name is schema 1's).
    pub hiz_culled_units: u64,
    pub quads_rasterized: u64,
    /// Quads with at least one sample passing early-z (sent to shading).
    pub quads_shaded: u64,
    /// Covered samples passing early-z.
    pub samples_passed: u64,
    /// Pixels with at least one passing sample, summed over all fragments (overdraw
    /// included) and pixels of the view covered at least once.
    pub fragments_shaded: u64,
    pub pixels_covered: u64,
}

impl RasterStats {
    pub fn add(&mut self, o: &RasterStats) {
        self.units += o.units;
        self.hiz_culled_units += o.hiz_culled_units;
        self.quads_rasterized += o.quads_rasterized;
        self.quads_shaded += o.quads_shaded;
        self.samples_passed += o.samples_passed;
        self.fragments_shaded += o.fragments_shaded;
        self.pixels_covered += o.pixels_covered;
    }
}

/// Instructions issued by SIMD groups of one stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StageCost {
    pub groups: u64,
    /// Issued SIMD instructions (one per group per instruction).
    pub alu: u64,
    pub tex: u64,
    /// Instructions times lanes that did useful work (covered, non-helper lanes).
    pub useful_lane_alu: u64,
    pub useful_lane_tex: u64,
    pub useful_lanes: u64,
}

impl StageCost {
    pub fn issued(&self) -> u64 {
        self.alu + self.tex
    }

    pub fn add(&mut self, o: &StageCost) {
        self.groups += o.groups;
        self.alu += o.alu;
        self.tex += o.tex;
        self.useful_lane_alu += o.useful_lane_alu;
        self.useful_lane_tex += o.useful_lane_tex;
        self.useful_lanes += o.useful_lanes;
    }
}

/// Stages and traffic classes every result reports, zero or not: results schema 1 had them
/// as fixed fields. Any other counter appears only where something was spent on it.
pub const ALWAYS_REPORTED_STAGES: [&str; 3] = ["fine", "coarse", "reuse"];
pub const ALWAYS_REPORTED_TRAFFIC: [&str; 4] = ["depth_color", "indices", "triangle_data", "texture"];

/// The stage names of `costs` in report order: the always-reported stages first, then the
/// others alphabetically.
pub fn stage_names<'a>(costs: impl IntoIterator<Item = &'a ShadingCost>) -> Vec<String> {
    report_order(costs.into_iter().flat_map(|c| c.stages.keys()), &ALWAYS_REPORTED_STAGES)
}

/// The traffic class names of `traffic` in report order (as [`stage_names`]).
pub fn traffic_names<'a>(traffic: impl IntoIterator<Item = &'a Traffic>) -> Vec<String> {
    report_order(
        traffic.into_iter().flat_map(|t| t.classes.keys()),
        &ALWAYS_REPORTED_TRAFFIC,
    )
}

fn report_order<'a>(names: impl Iterator<Item = &'a String>, first: &[&str]) -> Vec<String> {
    let mut out: Vec<String> = first.iter().map(|s| s.to_string()).collect();
    let rest: std::collections::BTreeSet<&String> = names.filter(|n| !first.contains(&n.as_str())).collect();
    out.extend(rest.into_iter().cloned());
    out
}

/// Shading cost by stage name (the tile-pair paper's FineInst / CoarseInst / ReuseInst, and
/// whatever stages later schemes register beside the code that spends them).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShadingCost {
    pub simd_width: u32,
    #[serde(flatten)]
    pub stages: BTreeMap<String, StageCost>,
}

impl Default for ShadingCost {
    fn default() -> Self {
        ShadingCost::new(0)
    }
}

impl ShadingCost {
    pub fn new(simd_width: u32) -> ShadingCost {
        ShadingCost {
            simd_width,
            stages: ALWAYS_REPORTED_STAGES
                .iter()
                .map(|s| (s.to_string(), StageCost::default()))
                .collect(),
        }
    }

    /// The counters of stage `name`, created on first use.
    #[inline]
    pub fn stage_mut(&mut self, name: &str) -> &mut StageCost {
        if !self.stages.contains_key(name) {
            self.stages.insert(name.to_string(), StageCost::default());
        }
        self.stages.get_mut(name).expect("inserted above")
    }

    /// The counters of stage `name` (zero when nothing was spent on it).
    pub fn stage(&self, name: &str) -> StageCost {
        self.stages.get(name).copied().unwrap_or_default()
    }

    pub fn issued(&self) -> u64 {
        self.stages.values().map(StageCost::issued).sum()
    }

    pub fn add(&mut self, o: &ShadingCost) {
        self.simd_width = self.simd_width.max(o.simd_width);
        for (name, stage) in &o.stages {
            self.stage_mut(name).add(stage);
        }
    }

    /// Useful lane instructions over issued lane slots.
    pub fn simd_utilization(&self) -> f64 {
        let useful = self
            .stages
            .values()
            .map(|s| s.useful_lane_alu + s.useful_lane_tex)
            .sum::<u64>();
        useful as f64 / (self.issued() as f64 * self.simd_width.max(1) as f64).max(1.0)
    }
}

/// DRAM bytes by traffic class name.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Traffic {
    #[serde(flatten)]
    pub classes: BTreeMap<String, u64>,
}

impl Default for Traffic {
    fn default() -> Self {
        Traffic {
            classes: ALWAYS_REPORTED_TRAFFIC.iter().map(|c| (c.to_string(), 0)).collect(),
        }
    }
}

impl Traffic {
    /// Adds `bytes` to class `name`.
    pub fn add_bytes(&mut self, name: &str, bytes: u64) {
        match self.classes.get_mut(name) {
            Some(b) => *b += bytes,
            None => {
                self.classes.insert(name.to_string(), bytes);
            }
        }
    }

    /// Bytes of class `name` (zero when none).
    pub fn bytes(&self, name: &str) -> u64 {
        self.classes.get(name).copied().unwrap_or(0)
    }

    pub fn total(&self) -> u64 {
        self.classes.values().sum()
    }

    pub fn add(&mut self, o: &Traffic) {
        for (name, &bytes) in &o.classes {
            self.add_bytes(name, bytes);
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheStats {
    pub accesses: u64,
    pub misses: u64,
    /// Dirty lines written back (on eviction or at the end of the frame).
    pub writebacks: u64,
    /// Misses that needed no DRAM read: the line was not yet written this frame (fast clear).
    pub cleared_fills: u64,
}

impl CacheStats {
    pub fn add(&mut self, o: &CacheStats) {
        self.accesses += o.accesses;
        self.misses += o.misses;
        self.writebacks += o.writebacks;
        self.cleared_fills += o.cleared_fills;
    }
}

/// Statistics of every cache of the memory model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheReport {
    pub depth: CacheStats,
    pub color: CacheStats,
    pub triangle_data: CacheStats,
    pub texture: CacheStats,
    /// Only deferred schemes have a G-buffer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gbuffer: Option<CacheStats>,
    /// Only the visibility-buffer schemes have one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visibility: Option<CacheStats>,
    /// Reads of the triangle buffer (`dais` schemes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangle_buffer: Option<CacheStats>,
    /// BVH fetches of ray traversal (`repro-rt`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bvh: Option<CacheStats>,
}

/// Binning lists (the tile-pair paper's Table 1 columns), both views together.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ListStats {
    pub tile_size: u32,
    /// Non-empty triangle tile lists.
    pub tiles: u64,
    /// Entries over all tile lists.
    pub tile_entries: u64,
    /// Bytes of all tile lists (u32 entries).
    pub tile_list_bytes: u64,
    pub tile_pairs: u64,
    pub tile_pair_entries: u64,
    /// Bytes of all tile-pair lists (u16 entries).
    pub tile_pair_list_bytes: u64,
}

/// The shadow-map pass (shared by both views, outside the shading cost).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShadowPassStats {
    pub size: u32,
    pub triangles: u64,
    pub texels_written: u64,
}

/// Image quality of one view against the reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quality {
    /// None when the image is smaller than the 11x11 SSIM window.
    pub ssim: Option<f64>,
    /// SSIM over the windows centred on pixels the reference covers (background excluded);
    /// None where no such window exists. Absent from results written before it existed.
    #[serde(default)]
    pub ssim_covered: Option<f64>,
    /// None when the images are identical (infinite PSNR).
    pub psnr_db: Option<f64>,
    pub max_abs_error: u8,
}

/// Wall-clock cost of the replay itself (not deterministic; never compared by goldens).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    pub wall_s: f64,
    pub threads: u32,
    /// Pixels of all views and frames replayed per second.
    pub pixels_per_s: f64,
    /// Wall milliseconds per stage over all frames, so users see where their time goes:
    /// geometry, shadow, vertex, bins, raster_shade, view_pass, memory, assemble, quality,
    /// images (writing this run's pictures). Shadow and vertex run at once, as do memory and
    /// assemble, each timed on its own, as are the two frames a run replays at once.
    #[serde(default)]
    pub stages_ms: BTreeMap<String, f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_fields_are_named() {
        let mut r = RunResult {
            schema_version: RESULTS_SCHEMA_VERSION,
            tool_version: String::new(),
            trace_name: String::new(),
            trace_hash: String::new(),
            preset: String::new(),
            scheduler: String::new(),
            scheme: String::new(),
            options: BTreeMap::new(),
            options_hash: String::new(),
            eye_width: 1,
            eye_height: 1,
            frames: Vec::new(),
            total: FrameTotals::default(),
            timing: Timing::default(),
        };
        assert!(r.non_finite_fields().is_empty());
        r.total.min_ssim = Some(f64::NAN);
        r.timing.pixels_per_s = f64::INFINITY;
        assert_eq!(r.non_finite_fields(), ["total.min_ssim", "timing.pixels_per_s"]);
    }
}
