//! Replay options shared by `replay`, `compare`, `check` and `demo`.

use shadetrace_replay::options::MultirateOptions;
use shadetrace_replay::scheme::multirate::{CoarseMode, ReuseTest, Sampling, SimdSchedule, Thresholds};
use shadetrace_replay::ReplayOptions;

#[derive(clap::Args, Clone, Debug)]
pub struct ReplayArgs {
    /// Frames to replay, START..END (end exclusive) or a single frame N.
    #[arg(long, value_parser = parse_frames)]
    pub frames: Option<(u32, u32)>,
    /// Per-eye resolution override, WIDTHxHEIGHT (default: the trace's).
    #[arg(long, value_parser = parse_resolution)]
    pub res: Option<(u32, u32)>,
    /// Tile edge in pixels (even, 4..64).
    #[arg(long, default_value_t = 16)]
    pub tile: u32,
    /// SIMD width in lanes (1..64).
    #[arg(long, default_value_t = 16)]
    pub simd: u32,
    /// Texture cache size in KiB.
    #[arg(long, default_value_t = 16)]
    pub texture_cache_kb: u32,
    /// Triangle (vertex) data cache size in KiB.
    #[arg(long, default_value_t = 8)]
    pub triangle_cache_kb: u32,
    /// The depth and colour caches each hold this many tiles.
    #[arg(long, default_value_t = 2)]
    pub fb_cache_tiles: u32,
    /// Samples per pixel (1, 4 or 8).
    #[arg(long, default_value_t = 1)]
    pub msaa: u32,
    /// Shadow-map edge in texels.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map: u32,
    /// Depth-only pre-pass, then shade only the visible surface.
    #[arg(long)]
    pub z_prepass: bool,
    /// Run the preset's shading scheme under this scheduler (immediate, sort-middle,
    /// multiview, tile-pair).
    #[arg(long)]
    pub schedule: Option<String>,
    /// Tile-pair: process sequences leftmost first instead of nearest first (Fig. 13 ablation).
    #[arg(long)]
    pub no_disparity_order: bool,
    /// Multi-rate coarse mode, overriding the preset's: 2x2, 4x4 or dynamic.
    #[arg(long, value_parser = CoarseMode::parse)]
    pub coarse_mode: Option<CoarseMode>,
    /// Multi-rate sample placement in screen blocks (multirate, tile-pair-cache):
    /// static-center, static-corner or coverage-bbox. amfs and texel shade lattice corners.
    #[arg(long, default_value = "coverage-bbox", value_parser = Sampling::parse)]
    pub sampling: Sampling,
    /// Disable the small-triangle optimization of screen-block multi-rate shading (multirate,
    /// tile-pair-cache; amfs and texel have no such path).
    #[arg(long)]
    pub no_small_triangle: bool,
    /// Multi-rate SIMD schedule: single-thread, two-phase or two-phase-sorted.
    #[arg(long, default_value = "two-phase", value_parser = SimdSchedule::parse)]
    pub simd_schedule: SimdSchedule,
    /// Diffuse refinement threshold (variation of N·L in a block; 0 = always, inf = never).
    #[arg(long, default_value_t = Thresholds::default().diffuse)]
    pub t_diffuse: f32,
    /// Specular flatness threshold (0 = always refine, inf = never).
    #[arg(long, default_value_t = Thresholds::default().specular)]
    pub t_specular: f32,
    /// Reflection-cone enlargement λ of the specular predicate.
    #[arg(long, default_value_t = Thresholds::default().lambda)]
    pub lambda: f32,
    /// Shadow occlusion-difference threshold (0 = always refine, inf = never).
    #[arg(long, default_value_t = Thresholds::default().shadow)]
    pub t_shadow: f32,
    /// Edge-receiver threshold δ on the shadow map's negative second depth derivative.
    #[arg(long, default_value_t = Thresholds::default().edge_delta)]
    pub edge_delta: f32,
    /// Multiplies the diffuse, specular and shadow thresholds (0 = refine all, inf = none).
    #[arg(long, default_value_t = 1.0)]
    pub threshold_scale: f32,
    /// Shading-cache size of tile-pair-cache, amfs and texel in KiB per job (an epipolar tile
    /// row under tile-pair; 0 = no reuse).
    #[arg(long, default_value_t = MultirateOptions::default().cache_kb)]
    pub cache_kb: u32,
    /// Tile-pair reuse test: largest position difference, as a fraction of the eye distance.
    #[arg(long, default_value_t = ReuseTest::default().position)]
    pub reuse_position: f32,
    /// Tile-pair reuse test: largest difference of unit normals.
    #[arg(long, default_value_t = ReuseTest::default().normal)]
    pub reuse_normal: f32,
    /// Tile-pair reuse test: largest difference of R·L between the views (cross-view hits).
    #[arg(long, default_value_t = ReuseTest::default().r_dot_l)]
    pub reuse_r_dot_l: f32,
}

impl ReplayArgs {
    pub fn options(&self) -> ReplayOptions {
        ReplayOptions {
            frames: self.frames,
            resolution: self.res,
            tile: self.tile,
            simd_width: self.simd,
            texture_cache_kb: self.texture_cache_kb,
            triangle_cache_kb: self.triangle_cache_kb,
            framebuffer_cache_tiles: self.fb_cache_tiles,
            msaa: self.msaa,
            shadow_map_size: self.shadow_map,
            z_prepass: self.z_prepass,
            scheduler: self.schedule.clone(),
            disparity_order: !self.no_disparity_order,
            multirate: MultirateOptions {
                mode: self.coarse_mode,
                sampling: self.sampling,
                small_triangle: !self.no_small_triangle,
                thresholds: Thresholds {
                    diffuse: self.t_diffuse,
                    specular: self.t_specular,
                    lambda: self.lambda,
                    shadow: self.t_shadow,
                    edge_delta: self.edge_delta,
                },
                threshold_scale: self.threshold_scale,
                schedule: self.simd_schedule,
                cache_kb: self.cache_kb,
                reuse: ReuseTest {
                    position: self.reuse_position,
                    normal: self.reuse_normal,
                    r_dot_l: self.reuse_r_dot_l,
                },
            },
        }
    }
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
