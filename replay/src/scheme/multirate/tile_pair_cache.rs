//! The screen-space shading cache of Yuan et al.'s tile-pair scheme (`tile-pair-cache`):
//! cache keys of a block's coarse fragments, queries in the own and the other view with the
//! reuse shader of Algorithm 2, and stores of freshly shaded fragments.

use glam::Vec3;

use super::block::CoarseBlock;
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
        let mut reused: [Option<(Vec<LightTerm>, Effects)>; 4] = [None, None, None, None];
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
            if let Some(e) = cache.get(&keys[i]) {
                self.coarse_lanes[lane].blocks.take(Block::ReuseTest);
                if fits(e) {
                    reused[i] = Some((e.terms.clone(), e.refine));
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
                let r = r_dot_l(ctx, positions[i], normal);
                let reusable =
                    |e: &CacheEntry| fits(e) && r.iter().zip(&e.r_dot_l).all(|(a, c)| (a - c).abs() <= test.r_dot_l);
                if reusable(e) {
                    let nearest = (e.terms.clone(), e.refine);
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
                    let weights = [(1.0 - fu) * (1.0 - fv), fu * (1.0 - fv), (1.0 - fu) * fv, fu * fv];
                    let mut mixed = vec![LightTerm::default(); n];
                    let mut refine = Effects::empty();
                    let mut complete = true;
                    for (key, w) in corners.iter().zip(weights) {
                        match cache.get(key) {
                            Some(c) if reusable(c) => {
                                for (m, t) in mixed.iter_mut().zip(&c.terms) {
                                    m.scale += w * t.scale;
                                    m.diffuse += w * t.diffuse;
                                    m.specular += w * t.specular;
                                }
                                refine |= c.refine;
                            }
                            _ => complete = false,
                        }
                    }
                    reused[i] = Some(if complete { (mixed, refine) } else { nearest });
                    cache.counters.cross_view_hits += 1;
                    continue;
                }
                cache.counters.rejected += 1;
            }
        }
        let all = reused.iter().all(Option::is_some);
        if all {
            cache.counters.blocks_skipped += 1;
            let mut refine = Effects::empty();
            for (i, r) in reused.into_iter().enumerate() {
                let (terms, flags) = r.expect("all four reused");
                b.terms[i * n..(i + 1) * n].copy_from_slice(&terms);
                refine |= flags;
            }
            b.refine = refine;
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
            for i in 0..4 {
                let normal = normals[i].normalize_or(Vec3::Y);
                cache.put(
                    keys[i],
                    CacheEntry {
                        position: positions[i],
                        normal,
                        r_dot_l: r_dot_l(ctx, positions[i], normal),
                        terms: b.terms[i * n..(i + 1) * n].to_vec(),
                        refine: b.refine,
                        view: ctx.view,
                    },
                );
            }
        }
    }
}

/// Per light, the cosine between the reflected view direction and the light direction at a
/// point seen from this unit's eye (the cross-view check of Algorithm 2).
fn r_dot_l(ctx: &UnitContext, position: Vec3, normal: Vec3) -> Vec<f32> {
    let v = (ctx.eye - position).normalize_or(Vec3::Z);
    let r = (2.0 * normal.dot(v) * normal - v).normalize_or(normal);
    ctx.env
        .lights
        .iter()
        .map(|light| r.dot(light.direction_from(position)))
        .collect()
}
