//! The screen-space shading cache of Yuan et al.'s tile-pair scheme (`tile-pair-cache`):
//! cache keys of a block's coarse fragments, queries in the own and the other view with the
//! reuse shader of Algorithm 2, and stores of freshly shaded fragments.

use glam::Vec3;

use super::block::{bilinear_weights, CoarseBlock};
use super::MultirateJob;
use crate::cost_table::Block;
use crate::scheme::shading_cache::{CacheEntry, CacheKey};
use crate::scheme::UnitContext;
use crate::shader::{Effects, LightTerm};

/// Stage of cache queries and the reuse test (ReuseInst in the tile-pair paper); the
/// object-space caches spend their queries here too.
pub const REUSE: &str = "reuse";

impl MultirateJob {
    /// Cache key of coarse fragment `i` of a block in `view`: the rate-`n` cell holding its
    /// sample (the rule a cross-view query uses for a projected sample too).
    pub(super) fn key(b: &CoarseBlock, i: usize, view: u8) -> CacheKey {
        let n = b.size / 2;
        CacheKey {
            qx: (b.samples[i].x / n as f32).floor() as i32,
            qy: (b.samples[i].y / n as f32).floor() as i32,
            n,
            view,
            surface: 0,
        }
    }

    /// Queries the cache for the block's four fragments, own view first, then the other view
    /// (the fragment projected there, its footprint quantized along x); every hit runs the
    /// reuse shader (Algorithm 2), all in the `reuse` stage. Returns true when all four were
    /// reused: the block's terms and flags then come from the cache and its coarse shader is
    /// skipped.
    pub(super) fn reuse_from_cache(
        &mut self,
        ctx: &UnitContext,
        b: &mut CoarseBlock,
        keys: &[CacheKey; 4],
        positions: &[Vec3; 4],
        normals: &[Vec3; 4],
        pixels: &[u32; 4],
    ) -> bool {
        let Some((config, mut cache)) = self.cache.take() else {
            return false;
        };
        let test = config.reuse;
        let n = self.lights;
        let other = 1 - ctx.view;
        let project = |p: Vec3, view: u8| {
            let c = ctx.view_projections[view as usize] * p.extend(1.0);
            (
                (c.x / c.w * 0.5 + 0.5) * ctx.width as f32,
                (0.5 - c.y / c.w * 0.5) * ctx.height as f32,
            )
        };
        // Footprint in the other view, along x: the only axis the disparity distorts.
        let span_here = (b.samples[1].x - b.samples[0].x).abs();
        let span_there = (project(positions[1], other).0 - project(positions[0], other).0).abs();
        let ratio = if span_here > 0.0 && span_there.is_finite() {
            span_there / span_here
        } else {
            1.0
        };
        // Power-of-two quantization, rounded so that an unchanged footprint keeps its rate.
        let n_other = 1u32 << (((b.size / 2) as f32 * ratio).max(1.0).log2().round() as u32).min(3);
        // Per fragment, the refinement flags of what it reuses; its terms go to `reused`.
        let mut reused: [Option<Effects>; 4] = [None; 4];
        self.cache_scratch.reused.clear();
        self.cache_scratch.reused.resize(4 * n, LightTerm::default());
        for i in 0..4 {
            let lane = self.coarse_lane(pixels[i], true);
            if i == 0 {
                b.first_lane = lane;
            }
            self.coarse_lanes[lane].blocks.take(Block::CacheQuery);
            cache.counters.queries += 1;
            let normal = normals[i].normalize_or(Vec3::Y);
            let distance = (positions[i] - ctx.eye).length();
            let fits = |e: &CacheEntry| {
                (positions[i] - e.position).length() <= test.position * distance
                    && (normal - e.normal).length() <= test.normal
            };
            let scratch = &mut self.cache_scratch;
            let slot = i * n..(i + 1) * n;
            if let Some(e) = cache.get(&keys[i]) {
                self.coarse_lanes[lane].blocks.take(Block::ReuseTest);
                if fits(&e) {
                    scratch.reused[slot].copy_from_slice(e.terms);
                    reused[i] = Some(e.refine);
                    cache.counters.local_hits += 1;
                    continue;
                }
                cache.counters.rejected += 1;
            }
            let (x, y) = project(positions[i], other);
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let there = CacheKey {
                qx: (x / n_other as f32).floor() as i32,
                qy: (y / n_other as f32).floor() as i32,
                n: n_other,
                view: other,
                surface: 0,
            };
            if let Some(e) = cache.get(&there) {
                self.coarse_lanes[lane].blocks.take(Block::ReuseCrossView);
                r_dot_l(ctx, positions[i], normal, &mut scratch.r_dot_l);
                let r = &scratch.r_dot_l;
                let reusable =
                    |e: &CacheEntry| fits(e) && r.iter().zip(e.r_dot_l).all(|(a, c)| (a - c).abs() <= test.r_dot_l);
                if reusable(&e) {
                    // The nearest, kept in case the interpolation below is incomplete.
                    scratch.reused[slot.clone()].copy_from_slice(e.terms);
                    let nearest_refine = e.refine;
                    // The projected fragment rarely sits on a cached one: interpolate the four
                    // cached neighbours bilinearly when all are there and reusable, else take
                    // the one it falls in.
                    let (u, v) = (x / n_other as f32 - 0.5, y / n_other as f32 - 0.5);
                    let (cu, cv) = (u.floor(), v.floor());
                    let (fu, fv) = (u - cu, v - cv);
                    let corners = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(dx, dy)| CacheKey {
                        qx: cu as i32 + dx,
                        qy: cv as i32 + dy,
                        ..there
                    });
                    let weights = bilinear_weights(fu, fv, 1.0);
                    let mixed = &mut scratch.mixed;
                    mixed.clear();
                    mixed.resize(n, LightTerm::default());
                    let mut refine = Effects::empty();
                    let mut complete = true;
                    for (key, w) in corners.iter().zip(weights) {
                        match cache.get(key) {
                            Some(c) if reusable(&c) => {
                                for (m, t) in mixed.iter_mut().zip(c.terms) {
                                    m.scale += w * t.scale;
                                    m.diffuse += w * t.diffuse;
                                    m.specular += w * t.specular;
                                }
                                refine |= c.refine;
                            }
                            _ => complete = false,
                        }
                    }
                    reused[i] = Some(match complete {
                        true => {
                            scratch.reused[slot].copy_from_slice(mixed);
                            refine
                        }
                        false => nearest_refine,
                    });
                    cache.counters.cross_view_hits += 1;
                    continue;
                }
                cache.counters.rejected += 1;
            }
        }
        let all = reused.iter().all(Option::is_some);
        if all {
            cache.counters.blocks_skipped += 1;
            b.terms.copy_from_slice(&self.cache_scratch.reused);
            b.refine = reused.into_iter().flatten().fold(Effects::empty(), |a, f| a | f);
        } else {
            cache.counters.blocks_shaded += 1;
        }
        self.cache = Some((config, cache));
        all
    }

    /// Stores the four freshly shaded fragments of a block under their own view's keys.
    pub(super) fn store_in_cache(
        &mut self,
        ctx: &UnitContext,
        b: &CoarseBlock,
        keys: &[CacheKey; 4],
        positions: &[Vec3; 4],
        normals: &[Vec3; 4],
    ) {
        let n = self.lights;
        if let Some((_, cache)) = self.cache.as_mut() {
            let r = &mut self.cache_scratch.r_dot_l;
            for i in 0..4 {
                let normal = normals[i].normalize_or(Vec3::Y);
                r_dot_l(ctx, positions[i], normal, r);
                cache.put(
                    keys[i],
                    CacheEntry {
                        position: positions[i],
                        normal,
                        r_dot_l: r,
                        terms: &b.terms[i * n..(i + 1) * n],
                        refine: b.refine,
                        view: ctx.view,
                    },
                );
            }
        }
    }
}

/// What cache queries and stores work in, kept across blocks (no allocation per query).
#[derive(Default)]
pub(super) struct CacheScratch {
    /// Per fragment of the block, the terms it reuses.
    reused: Vec<LightTerm>,
    /// A cross-view hit's interpolated terms.
    mixed: Vec<LightTerm>,
    /// A point's `R · L` per light.
    r_dot_l: Vec<f32>,
}

/// Per light, the cosine between the reflected view direction and the light direction at a
/// point seen from this unit's eye (the cross-view check of Algorithm 2), into `out`.
fn r_dot_l(ctx: &UnitContext, position: Vec3, normal: Vec3, out: &mut Vec<f32>) {
    let v = (ctx.eye - position).normalize_or(Vec3::Z);
    let r = (2.0 * normal.dot(v) * normal - v).normalize_or(normal);
    out.clear();
    out.extend(ctx.env.lights.iter().map(|light| r.dot(light.direction_from(position))));
}
