//! The refinement predicates of He et al. (2014, §4): diffuse variation, the specular
//! flatness and reflection-cone test, shadow variation and shadow-edge receivers, and the
//! helpers on refinement flags.

use glam::Vec3;

use shadetrace_formats::LightKind;

use super::block::CoarseBlock;
use super::config::Thresholds;
use super::MultirateJob;
use crate::cost_table::Block;
use crate::scheme::UnitContext;
use crate::shader::Effects;
use crate::shadow::{ReceiverHierarchy, ShadowMap};

fn min_max(v: impl Iterator<Item = f32>) -> (f32, f32) {
    v.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
}

impl MultirateJob {
    /// The refinement predicates of §4, charged to the block's four coarse lanes.
    pub(super) fn predicates(
        &mut self,
        ctx: &UnitContext,
        b: &CoarseBlock,
        positions: &[Vec3; 4],
        normals: &[Vec3; 4],
    ) -> Effects {
        let t = self.config.thresholds;
        let n = self.lights;
        let term = |i: usize, l: usize| b.terms[i * n + l];
        let material = &ctx.env.materials[ctx.triangle.material as usize];
        // The predicate blocks run: the shadow one only with a shadowed light and a map.
        let predicate_blocks = [
            Block::PredicateDiffuse,
            Block::PredicateSpecular,
            Block::PredicateShadow,
        ];
        let mut charged = &predicate_blocks[..2];

        // Directional lights: the variation of N·L itself (§4.1). Local lights: the variation
        // of their falloff-weighted Lambert term, relative to the block's mean lighting, so a
        // dim light at the edge of its range does not force refinement on its own.
        let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let mean_lighting = (0..4)
            .map(|i| luminance(ctx.env.combine(&b.terms[i * n..(i + 1) * n])))
            .sum::<f32>()
            / 4.0;
        let mut diffuse_variation = 0.0f32;
        for (l, light) in ctx.env.lights.iter().enumerate() {
            let variation = match light.kind {
                LightKind::Directional { .. } => {
                    let (lo, hi) = min_max((0..4).map(|i| term(i, l).diffuse));
                    hi - lo
                }
                _ => {
                    let (lo, hi) = min_max((0..4).map(|i| term(i, l).scale * term(i, l).diffuse));
                    (hi - lo) * luminance(light.radiance) / mean_lighting.max(1e-6)
                }
            };
            diffuse_variation = diffuse_variation.max(variation);
        }
        let diffuse = t.diffuse == 0.0 || diffuse_variation >= t.diffuse;
        let specular =
            t.specular == 0.0 || (material.specular_strength > 0.0 && near_highlight(ctx, t, positions, normals));

        let mut shadow = false;
        if let (Some(k), Some(map)) = (ctx.env.lights.iter().position(|l| l.shadowed), ctx.env.shadow) {
            charged = &predicate_blocks[..];
            // Threshold 0 refines every effect; otherwise a block wholly facing away from the
            // light has no shadow to refine.
            shadow = t.shadow == 0.0;
            if !shadow && (0..4).any(|i| term(i, k).diffuse > 0.0) {
                let (lo, hi) = min_max((0..4).map(|i| term(i, k).scale));
                shadow = hi - lo >= t.shadow;
                // An infinite shadow threshold turns the whole shadow predicate off.
                if let (false, true, Some(receivers)) = (shadow, t.shadow.is_finite(), ctx.env.receivers) {
                    shadow = receives_edge(map, receivers, positions);
                }
            }
        }
        for lane in b.first_lane..b.first_lane + 4 {
            for &block in charged {
                self.coarse_lanes[lane].blocks.take(block);
            }
        }
        let mut refine = Effects::empty();
        refine.set(Effects::DIFFUSE, diffuse);
        refine.set(Effects::SPECULAR, specular);
        refine.set(Effects::SHADOW, shadow);
        refine
    }
}

/// Flatness test, then whether some light lies in the block's enlarged reflection cone
/// (`L · R_avg >= λ min(R_i · R_avg)`).
fn near_highlight(ctx: &UnitContext, t: Thresholds, positions: &[Vec3; 4], normals: &[Vec3; 4]) -> bool {
    let n: [Vec3; 4] = normals.map(|n| n.normalize_or(Vec3::Y));
    let n_avg = (n[0] + n[1] + n[2] + n[3]).normalize_or(n[0]);
    let flatness = 1.0 - n.iter().map(|v| v.dot(n_avg)).fold(f32::INFINITY, f32::min);
    if flatness < t.specular || flatness.is_nan() {
        return false;
    }
    let r: [Vec3; 4] = std::array::from_fn(|i| {
        let v = (ctx.eye - positions[i]).normalize_or(Vec3::Z);
        (2.0 * n[i].dot(v) * n[i] - v).normalize_or(n[i])
    });
    let r_avg = (r[0] + r[1] + r[2] + r[3]).normalize_or(r[0]);
    let cone = r.iter().map(|v| v.dot(r_avg)).fold(f32::INFINITY, f32::min);
    let center = (positions[0] + positions[1] + positions[2] + positions[3]) * 0.25;
    ctx.env.lights.iter().any(|light| {
        let l = light.direction_from(center);
        l.dot(r_avg) >= t.lambda * cone
    })
}

/// Whether a shadow edge may fall inside the block: its light-space depth range overlaps
/// the receivers under its (PCF-widened) shadow-map footprint, unless that footprint lies
/// within 2x2 texels, where every lookup reads the same texels (§4.2).
fn receives_edge(map: &ShadowMap, receivers: &ReceiverHierarchy, positions: &[Vec3; 4]) -> bool {
    let mut p = [(0.0f32, 0.0f32, 0.0f32); 4];
    for (i, &pos) in positions.iter().enumerate() {
        match map.project(pos) {
            Some(q) => p[i] = q,
            None => return false,
        }
    }
    let (tx0, tx1) = min_max(p.iter().map(|q| q.0.floor()));
    let (ty0, ty1) = min_max(p.iter().map(|q| q.1.floor()));
    if tx1 - tx0 <= 1.0 && ty1 - ty0 <= 1.0 {
        return false;
    }
    let (rmin, rmax) = receivers.range(map, tx0 as i64 - 2, ty0 as i64 - 2, tx1 as i64 + 2, ty1 as i64 + 2);
    let (zmin, zmax) = min_max(p.iter().map(|q| q.2));
    rmin <= zmax && rmax >= zmin
}
