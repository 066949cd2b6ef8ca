//! The shadow map of the one shadowed directional light: an orthographic depth map fitted to
//! the scene bounds, rendered with the shared vertex stage and rasterizer (no culling), and
//! looked up with 5x5 percentage-closer filtering.

use std::sync::{Arc, Mutex};

use glam::{Mat4, Vec3, Vec4Swizzles};
use rayon::prelude::*;
use shadetrace_formats::results::ShadowPassStats;
use shadetrace_formats::Aabb;
use wide::f32x4;

use crate::geometry::FrameGeometry;
use crate::lanes::Vec3x4;
use crate::memory::{AccessLog, Stream};
use crate::raster::{rasterize_rows, Rect};
use crate::texture::{level_lines, BLOCK};
use crate::vertex_stage::{setup_view_chunks, SetupTriangle, SUBPIXEL};

/// Rows of the map rasterized per parallel work item.
const BAND: u32 = 64;
// A band is whole block rows, so that it finds its blocks' ranges itself (`draw_map`).
const _: () = assert!(BAND % BLOCK == 0);
/// PCF footprint radius in texels (5x5).
const PCF_RADIUS: i32 = 2;
const PCF_TAPS: usize = 2 * PCF_RADIUS as usize + 1;
// A footprint's rows span at most two block rows (`ShadowMap::filter`).
const _: () = assert!(PCF_TAPS <= BLOCK as usize);

/// A small map of blocks at several depths, for tests.
#[cfg(test)]
pub(crate) use tests::map_of as test_map;

/// Where a receiver's 5x5 PCF footprint lies: its centre texel, and the biased depth its taps
/// are compared with.
#[derive(Clone, Copy, Debug)]
pub struct PcfFootprint {
    tx: i32,
    ty: i32,
    receiver: f32,
}

pub struct ShadowMap {
    pub size: u32,
    pub view_projection: Mat4,
    depth: Vec<f32>,
    /// Blocks per row of the map.
    blocks: u32,
    /// Per BLOCK x BLOCK block (row-major), the (min, max) depth of the blocks a PCF
    /// footprint starting in it spans ([`FootprintRanges`]): a footprint whose blocks all lie
    /// behind (or all in front of) the receiver is decided without reading its 25 texels,
    /// which for most fragments are far apart in the 16 MiB map.
    footprint_ranges: Vec<FootprintRanges>,
    /// First cache line of the map in the texture address space.
    pub base_line: u64,
    /// Depth bias in map depth units per unit of slope.
    texel_depth: f32,
    pub stats: ShadowPassStats,
    /// Edge-receiver hierarchies already built from this map, by threshold (bits): the map is
    /// shared by every preset and frame that can use it, and so are they.
    receivers: Mutex<Vec<(u32, Arc<ReceiverHierarchy>)>>,
}

impl ShadowMap {
    /// Lines the map occupies in the texture address space.
    pub fn lines(size: u32) -> u64 {
        level_lines(size, size)
    }

    pub fn render(
        geometry: &FrameGeometry,
        materials: usize,
        direction: Vec3,
        bounds: &Aabb,
        size: u32,
        base_line: u64,
    ) -> ShadowMap {
        let dir = direction.normalize_or(Vec3::NEG_Y);
        let center = if bounds.is_empty() { Vec3::ZERO } else { bounds.center() };
        let radius = if bounds.is_empty() {
            1.0
        } else {
            bounds.radius().max(1e-3)
        };
        let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let view = Mat4::look_at_rh(center - dir * radius * 2.0, center, up);
        let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, radius * 0.5, radius * 3.5);
        let view_projection = proj * view;
        let (chunks, vstats) = setup_view_chunks(geometry, &vec![true; materials], view_projection, size, size);
        let (depth, blocks, texels_written) = draw_map(chunks.iter().flatten(), size);
        ShadowMap {
            size,
            view_projection,
            blocks: size.div_ceil(BLOCK),
            footprint_ranges: footprint_ranges(&blocks, size),
            depth,
            base_line,
            texel_depth: 1.0 / size as f32,
            stats: ShadowPassStats {
                size,
                triangles: vstats.setup_triangles,
                texels_written,
            },
            receivers: Mutex::new(Vec::new()),
        }
    }

    /// Texel coordinates (continuous) and light-space depth of a world point, or None
    /// outside the map.
    pub fn project(&self, position: Vec3) -> Option<(f32, f32, f32)> {
        let clip = self.view_projection * position.extend(1.0);
        let p = clip.xyz() / clip.w;
        if !p.is_finite() || p.x.abs() > 1.0 || p.y.abs() > 1.0 || p.z > 1.0 {
            return None;
        }
        let size = self.size as f32;
        Some(((p.x * 0.5 + 0.5) * size, (0.5 - p.y * 0.5) * size, p.z))
    }

    /// The edge-receiver min-max hierarchy of He et al. §4.2 for threshold `delta` (depth
    /// units of the map): texels whose second depth derivative is below `-delta` along x or
    /// y receive shadow edges; each node keeps the depth range of receivers beneath it.
    /// Built once per map and threshold: every run that shares the map shares it.
    pub fn receivers(&self, delta: f32) -> Arc<ReceiverHierarchy> {
        // Runs replay one after another, so the lock is never contended.
        let mut built = self.receivers.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some((_, hierarchy)) = built.iter().find(|(d, _)| *d == delta.to_bits()) {
            return hierarchy.clone();
        }
        let hierarchy = Arc::new(self.build_receivers(delta));
        built.push((delta.to_bits(), hierarchy.clone()));
        hierarchy
    }

    fn build_receivers(&self, delta: f32) -> ReceiverHierarchy {
        let n = self.size as usize;
        let words = n.div_ceil(64);
        let row = |y: usize| &self.depth[y * n..(y + 1) * n];
        // Rows are independent at every level: they are built in parallel.
        let mut base = vec![0u64; words * n];
        base.par_chunks_mut(words).enumerate().for_each(|(y, bits)| {
            let here = row(y);
            // The rows above and below (none at the map's top and bottom: no ddy there).
            let around = (y > 0 && y + 1 < n).then(|| (row(y - 1), row(y + 1)));
            let receives = |x: usize| {
                let c = here[x];
                let ddx = if x > 0 && x + 1 < n {
                    here[x - 1] - 2.0 * c + here[x + 1]
                } else {
                    0.0
                };
                let ddy = match around {
                    Some((above, below)) => above[x] - 2.0 * c + below[x],
                    None => 0.0,
                };
                (-ddx).max(-ddy) >= delta
            };
            // Inside an inner row, from column 4 (so that four bits never straddle a word)
            // to the last full four before the edge, four texels at a time: the same
            // operations per lane, and `max(-ddx, -ddy) >= delta` as `ddx <= -delta or
            // ddy <= -delta` (the same for NaN, which `max` skips and no comparison takes).
            let inner = match around {
                Some(_) if n > 8 => 4..(n - 1) / 4 * 4,
                _ => n..n,
            };
            for x in (0..inner.start).chain(inner.end..n) {
                bits[x / 64] |= u64::from(receives(x)) << (x % 64);
            }
            if let Some((above, below)) = around {
                let four = |r: &[f32], x: usize| f32x4::new([r[x], r[x + 1], r[x + 2], r[x + 3]]);
                let (two, limit) = (f32x4::splat(2.0), f32x4::splat(-delta));
                for x in inner.step_by(4) {
                    let twice = two * four(here, x);
                    let ddx = four(here, x - 1) - twice + four(here, x + 1);
                    let ddy = four(above, x) - twice + four(below, x);
                    let receives = ddx.simd_le(limit) | ddy.simd_le(limit);
                    bits[x / 64] |= (receives.to_bitmask() as u64) << (x % 64);
                }
            }
        });
        let mut hierarchy = ReceiverHierarchy {
            size: self.size,
            base,
            levels: Vec::new(),
        };
        if n > 1 {
            let half = n.div_ceil(2);
            hierarchy
                .levels
                .push((half, self.receivers_at_half(&hierarchy.base, half)));
        }
        let mut size = n.div_ceil(2);
        while size > 1 {
            let half = size.div_ceil(2);
            let mut next = vec![EMPTY_RANGE; half * half];
            let level = hierarchy.levels.len();
            next.par_chunks_mut(half).enumerate().for_each(|(y, row)| {
                for (x, node) in row.iter_mut().enumerate() {
                    let mut r = EMPTY_RANGE;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (sx, sy) = ((2 * x + dx).min(size - 1), (2 * y + dy).min(size - 1));
                        let v = hierarchy.node(&self.depth, level, sx, sy);
                        r = (r.0.min(v.0), r.1.max(v.1));
                    }
                    *node = r;
                }
            });
            hierarchy.levels.push((half, next));
            size = half;
        }
        hierarchy
    }

    /// The hierarchy's half-resolution level, from the receiver bits `base`: the same fold
    /// over each node's four texels (a texel that receives nothing leaves the range as it
    /// is), reading the bits a word at a time. Receivers are sparse: where a word pair of
    /// two rows has none, its 32 nodes are empty without looking at them.
    fn receivers_at_half(&self, base: &[u64], half: usize) -> Vec<(f32, f32)> {
        let n = self.size as usize;
        let words = n.div_ceil(64);
        let receives = |x: usize, y: usize| base[y * words + x / 64] >> (x % 64) & 1 != 0;
        let mut level = vec![EMPTY_RANGE; half * half];
        level.par_chunks_mut(half).enumerate().for_each(|(y, row)| {
            let (y0, y1) = (2 * y, (2 * y + 1).min(n - 1));
            // Nodes 32k.. cover texels 64k.., which word k of each row holds.
            for (k, nodes) in row.chunks_mut(32).enumerate() {
                if base[y0 * words + k] | base[y1 * words + k] == 0 {
                    continue;
                }
                for (i, node) in nodes.iter_mut().enumerate() {
                    let x = 32 * k + i;
                    let (x0, x1) = (2 * x, (2 * x + 1).min(n - 1));
                    let mut r = EMPTY_RANGE;
                    for (sx, sy) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
                        if receives(sx, sy) {
                            let c = self.depth[sy * n + sx];
                            r = (r.0.min(c), r.1.max(c));
                        }
                    }
                    *node = r;
                }
            }
        });
        level
    }

    /// Where the 5x5 PCF footprint of a receiver at `position` lies, its normal at cosine
    /// `n_dot_l` to the light; None outside the map, where receivers are lit.
    #[inline(always)]
    pub fn footprint(&self, position: Vec3, n_dot_l: f32) -> Option<PcfFootprint> {
        let clip = self.view_projection * position.extend(1.0);
        let p = clip.xyz() / clip.w;
        if !p.is_finite() || p.x.abs() > 1.0 || p.y.abs() > 1.0 || p.z > 1.0 {
            return None;
        }
        let size = self.size as f32;
        // Both are at least +0 (|p.x|, |p.y| <= 1), where truncation is the floor: no call to
        // `floorf`, which SSE2 lacks.
        let tx = ((p.x * 0.5 + 0.5) * size) as i32;
        let ty = ((0.5 - p.y * 0.5) * size) as i32;
        // Slope-scaled bias: steeper receivers need more.
        let slope = (1.0 - n_dot_l * n_dot_l).max(0.0).sqrt() / n_dot_l.max(0.05);
        let bias = self.texel_depth * (1.5 + 2.0 * slope.min(10.0));
        Some(PcfFootprint {
            tx,
            ty,
            receiver: p.z - bias,
        })
    }

    /// [`Self::footprint`] of a quad's four receivers, four lanes at a time: the same
    /// operations in the same order, so the same bits.
    #[inline]
    pub fn quad_footprints(&self, positions: Vec3x4, n_dot_l: f32x4) -> [Option<PcfFootprint>; 4] {
        let (clip, w) = positions.transformed_point(&self.view_projection);
        let [x, y, z] = clip.unscale(w).components();
        let one = f32x4::ONE;
        let finite = x.is_finite() & y.is_finite() & z.is_finite();
        let inside = finite & x.abs().simd_le(one) & y.abs().simd_le(one) & z.simd_le(one);
        let (half, size) = (f32x4::splat(0.5), f32x4::splat(self.size as f32));
        // Truncated as `as i32` truncates (only lanes inside the map are kept).
        let tx = ((x * half + half) * size).trunc_int().to_array();
        let ty = ((half - y * half) * size).trunc_int().to_array();
        let slope = (one - n_dot_l * n_dot_l).max(f32x4::ZERO).sqrt() / n_dot_l.max(f32x4::splat(0.05));
        let bias =
            f32x4::splat(self.texel_depth) * (f32x4::splat(1.5) + f32x4::splat(2.0) * slope.min(f32x4::splat(10.0)));
        let receiver = (z - bias).to_array();
        let inside = inside.to_bitmask();
        std::array::from_fn(|l| {
            (inside & 1 << l != 0).then(|| PcfFootprint {
                tx: tx[l],
                ty: ty[l],
                receiver: receiver[l],
            })
        })
    }

    /// Fraction of the footprint's taps that see the light (1 = lit), logging the texel lines
    /// they read.
    #[inline(always)]
    pub fn filter(&self, footprint: PcfFootprint, log: &mut AccessLog) -> f32 {
        let PcfFootprint { tx, ty, receiver } = footprint;
        let blocks_x = self.blocks;
        let last = self.size as i32 - 1;
        let mut lit = 0u32;
        if tx - PCF_RADIUS >= 0 && tx + PCF_RADIUS <= last {
            // The usual case, the footprint inside the map in x: each row's taps are one run
            // of texels in one or two blocks (the same accesses, in the same order).
            let x0 = (tx - PCF_RADIUS) as u32;
            let (b0, b1) = (x0 / BLOCK, (x0 + PCF_TAPS as u32 - 1) / BLOCK);
            // The rows' block rows: at most two (the footprint is shorter than a block),
            // the first `split` rows in the first. Only the rows at the map's edges are
            // clamped, and those lie in the outer block rows, so the rows before the second
            // block row starts are ty - R, ty - R + 1, ...
            let y0 = (ty - PCF_RADIUS).clamp(0, last) as u32;
            let y1 = (ty + PCF_RADIUS).clamp(0, last) as u32;
            let (by0, by1) = (y0 / BLOCK, y1 / BLOCK);
            let split = match by0 == by1 {
                true => PCF_TAPS as u32,
                false => by1 * BLOCK - (ty - PCF_RADIUS) as u32,
            };
            let span = usize::from(b1 != b0) | usize::from(by1 != by0) << 1;
            let (near, far) = self.footprint_ranges[(by0 * blocks_x + b0) as usize][span];
            // Every tap compares alike: the count is known without the taps.
            let decided = if receiver <= near {
                Some(1.0)
            } else if receiver > far {
                Some(0.0)
            } else {
                None
            };
            // The rows' accesses, per run of rows in one block row: its line in b0 (repeats
            // the log drops), or alternating between b0's and b1's, which the log counts as
            // one repeated pair.
            let runs = [(by0, split), (by1, PCF_TAPS as u32 - split)].map(|(by, run)| {
                let row_line = self.base_line + u64::from(by * blocks_x);
                (row_line + u64::from(b0), row_line + u64::from(b1), run)
            });
            // The first run is never empty: a footprint clamped at the top lies in one block row.
            let runs = match runs[1].2 {
                0 => &runs[..1],
                _ => &runs[..],
            };
            log.read_runs(runs);
            if let Some(decided) = decided {
                return decided;
            }
            for dy in -PCF_RADIUS..=PCF_RADIUS {
                let y = (ty + dy).clamp(0, last) as u32;
                let taps = &self.depth[(y * self.size + x0) as usize..][..PCF_TAPS];
                lit += taps.iter().map(|&d| u32::from(receiver <= d)).sum::<u32>();
            }
            return lit as f32 / (PCF_TAPS * PCF_TAPS) as f32;
        }
        let xs: [u32; PCF_TAPS] = std::array::from_fn(|i| (tx + i as i32 - PCF_RADIUS).clamp(0, last) as u32);
        for dy in -PCF_RADIUS..=PCF_RADIUS {
            let y = (ty + dy).clamp(0, last) as u32;
            let row = &self.depth[(y * self.size) as usize..][..self.size as usize];
            let row_line = self.base_line + u64::from((y / BLOCK) * blocks_x);
            // A tap in the block of the tap before it repeats that access, which the log
            // drops anyway: touch only where the block changes.
            let mut block = u32::MAX;
            for &x in &xs {
                if x / BLOCK != block {
                    block = x / BLOCK;
                    log.touch(Stream::Texture, row_line + u64::from(block), false);
                }
                lit += u32::from(receiver <= row[x as usize]);
            }
        }
        lit as f32 / (PCF_TAPS * PCF_TAPS) as f32
    }
}

/// The map's depths (each texel's nearest, 1.0 where no triangle covers it), the (min, max)
/// of each of its blocks ([`block_ranges`]) and the count of texels written: band by band in
/// parallel, each band drawn and summarized while it is in cache.
fn draw_map<'a>(tris: impl Iterator<Item = &'a SetupTriangle>, size: u32) -> (Vec<f32>, Vec<(f32, f32)>, u64) {
    let by_band = band_candidates(tris, size);
    // Cleared in parallel: the first touch of 16 MiB is itself worth spreading.
    let mut depth: Vec<f32> = (0..size * size).into_par_iter().map(|_| 1.0).collect();
    let (blocks, written): (Vec<Vec<(f32, f32)>>, Vec<u64>) = depth
        .par_chunks_mut((BAND * size) as usize)
        .zip(by_band)
        .enumerate()
        .map(|(band, (depth, candidates))| {
            let band = band as u32;
            let rect = Rect {
                x0: 0,
                y0: band * BAND,
                x1: size,
                y1: ((band + 1) * BAND).min(size),
            };
            // Nearest first (a radix sort on the nearest vertex's depth), so that the texels
            // it already holds nearer than a triangle's nearest vertex skip its depths. A
            // texel keeps the minimum of its depths, the same in any order: NaN never wins,
            // and of two zeros, whose sign may now differ, no comparison tells one from the
            // other.
            let mut near_first = candidates;
            near_first.retain(|t| t.bbox[1] < rect.y1 && t.bbox[3] >= rect.y0);
            radsort::sort_by_key(&mut near_first, |t| t.z_min);
            for t in near_first {
                rasterize_rows(t, rect, |y, x0, x1| {
                    let start = ((y - rect.y0) * size) as usize;
                    let (cx, cy) = crate::raster::pixel_center(x0, y);
                    draw_run(t, t.edges(cx, cy), &mut depth[start + x0 as usize..start + x1 as usize]);
                });
            }
            // As 0 or 1 per texel into a u32 (a band holds fewer than 2^32 texels): SIMD
            // compares and adds, where counting filtered texels went one by one.
            let written = u64::from(depth.iter().map(|&d| u32::from(d < 1.0)).sum::<u32>());
            (block_ranges(depth, size), written)
        })
        .unzip();
    (depth, blocks.concat(), written.iter().sum())
}

/// Keeps in each texel of a run the triangle covers the nearer of its depth and the
/// triangle's; `e` holds the edges at the run's first texel. A texel already nearer than the
/// triangle's nearest vertex needs no depth (the triangles come nearest first).
///
/// Four texels at a time, with the edges stepped in f64: a covered texel's edges lie in
/// `0..=area2` (they are at least 0 and sum to it), so below 2^52 every stepped value, the
/// three texels a last group reaches past the run included, is an exact integer, `e as f64`
/// itself, and each depth is [`SetupTriangle::depth`]'s bit for bit.
fn draw_run(t: &SetupTriangle, e: [i64; 3], run: &mut [f32]) {
    let right = t.edge_ends().map(|(a, b)| (a[1] - b[1]) * SUBPIXEL);
    let keep_nearer = |d: &mut f32, z: f32| {
        if z < *d {
            *d = z;
        }
    };
    if t.area2 >= 1 << 52 {
        let mut e = e;
        for d in run {
            if *d > t.z_min {
                keep_nearer(d, t.depth(e));
            }
            e = [0, 1, 2].map(|i| e[i] + right[i]);
        }
        return;
    }
    // Per edge, its value at each texel of a group of four, and the step to the next group.
    let mut lanes: [[f64; 4]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|l| (e[i] + l as i64 * right[i]) as f64));
    let step = right.map(|r| (4 * r) as f64);
    let mut groups = run.chunks_exact_mut(4);
    for group in &mut groups {
        if group.iter().any(|&d| d > t.z_min) {
            let z: [f32; 4] = std::array::from_fn(|l| t.depth_of([lanes[0][l], lanes[1][l], lanes[2][l]]));
            for (d, z) in group.iter_mut().zip(z) {
                if *d > t.z_min {
                    keep_nearer(d, z);
                }
            }
        }
        for (lane, step) in lanes.iter_mut().zip(step) {
            *lane = lane.map(|v| v + step);
        }
    }
    for (l, d) in groups.into_remainder().iter_mut().enumerate() {
        if *d > t.z_min {
            keep_nearer(d, t.depth_of([lanes[0][l], lanes[1][l], lanes[2][l]]));
        }
    }
}

/// Per band of the map, the triangles whose bounding boxes reach its rows, in submission
/// order: each band then visits only those (the band's own test still decides), instead of
/// every triangle of the scene once per band.
fn band_candidates<'a>(tris: impl Iterator<Item = &'a SetupTriangle>, size: u32) -> Vec<Vec<&'a SetupTriangle>> {
    let mut by_band = vec![Vec::new(); size.div_ceil(BAND) as usize];
    for t in tris {
        let first = (t.bbox[1] / BAND) as usize;
        let last = ((t.bbox[3] / BAND) as usize).min(by_band.len().saturating_sub(1));
        for band in by_band.get_mut(first..=last).unwrap_or_default() {
            band.push(t);
        }
    }
    by_band
}

/// (min, max) of each BLOCK x BLOCK block of `rows`, whole rows `size` texels wide from a
/// block row's first (the last block row may be short), row-major; a block holding a NaN gets
/// the whole range, so that no comparison with it is ever taken as decided.
fn block_ranges(rows: &[f32], size: u32) -> Vec<(f32, f32)> {
    const COLUMNS: usize = BLOCK as usize;
    let blocks = size.div_ceil(BLOCK) as usize;
    let size = size as usize;
    rows.chunks(COLUMNS * size)
        .flat_map(|rows| {
            (0..blocks).map(move |bx| {
                let columns = bx * COLUMNS..((bx + 1) * COLUMNS).min(size);
                // Column by column first (the eight columns of a full block at once), then
                // across: min and max are exact in any order. Each a compare and select (a
                // NaN loses every comparison, and is caught apart): `f32::min`'s NaN
                // handling cost the map's texels three times the instructions. Which zero a
                // range keeps may differ from `f32::min`'s; the comparisons that read the
                // ranges take both zeros alike.
                let (mut lo, mut hi, mut nan) =
                    ([f32::INFINITY; COLUMNS], [f32::NEG_INFINITY; COLUMNS], [false; COLUMNS]);
                for row in rows.chunks_exact(size) {
                    let mut add = |i: usize, d: f32| {
                        lo[i] = if d < lo[i] { d } else { lo[i] };
                        hi[i] = if d > hi[i] { d } else { hi[i] };
                        nan[i] |= d.is_nan();
                    };
                    match <&[f32; COLUMNS]>::try_from(&row[columns.clone()]) {
                        Ok(full) => (0..COLUMNS).for_each(|i| add(i, full[i])),
                        Err(_) => row[columns.clone()].iter().enumerate().for_each(|(i, &d)| add(i, d)),
                    }
                }
                if nan.contains(&true) {
                    return (f32::NEG_INFINITY, f32::INFINITY);
                }
                (
                    lo.into_iter().fold(f32::INFINITY, f32::min),
                    hi.into_iter().fold(f32::NEG_INFINITY, f32::max),
                )
            })
        })
        .collect()
}

/// A block's entry of [`ShadowMap::footprint_ranges`]: the (min, max) depth of the block
/// alone, with the block to its right, with the block below it, and of the 2x2 blocks it
/// leads, indexed by `right | below << 1`. A footprint is narrower and shorter than a
/// block, so these are the blocks any footprint spans. At the map's last column or row a
/// missing neighbour is left out (no footprint spans it).
type FootprintRanges = [(f32, f32); 4];

/// [`FootprintRanges`] of every block of a `size`² map, from the blocks' own ranges
/// ([`block_ranges`]). Min and max are exact in any order, and a block holding a NaN (the
/// whole range) keeps every span that holds it undecided.
fn footprint_ranges(block: &[(f32, f32)], size: u32) -> Vec<FootprintRanges> {
    let blocks = size.div_ceil(BLOCK) as usize;
    let union = |(lo, hi): (f32, f32), (lo2, hi2): (f32, f32)| (lo.min(lo2), hi.max(hi2));
    (0..block.len())
        .into_par_iter()
        .map(|i| {
            let (bx, by) = (i % blocks, i / blocks);
            let at = |right: usize, below: usize| {
                let (x, y) = ((bx + right).min(blocks - 1), (by + below).min(blocks - 1));
                block[y * blocks + x]
            };
            let right = union(at(0, 0), at(1, 0));
            let below = union(at(0, 0), at(0, 1));
            [at(0, 0), right, below, union(right, union(at(0, 1), at(1, 1)))]
        })
        .collect()
}

/// The depth range of no receiver.
const EMPTY_RANGE: (f32, f32) = (f32::INFINITY, f32::NEG_INFINITY);

/// Conservative light-space depth ranges of shadow-edge receivers (He et al. §4.2).
pub struct ReceiverHierarchy {
    /// The map's edge in texels.
    size: u32,
    /// The full-resolution level as one bit per texel (rows of whole u64 words): a
    /// receiver's range is its own depth, which the map holds, so the level costs 1/64 of
    /// storing ranges.
    base: Vec<u64>,
    /// (edge size, (min, max) per node) from half resolution up to 1x1 (each level's edge
    /// halves, rounding up).
    levels: Vec<(usize, Vec<(f32, f32)>)>,
}

impl ReceiverHierarchy {
    /// Edge in nodes of `level` (0 = full resolution).
    fn edge(&self, level: usize) -> usize {
        match level {
            0 => self.size as usize,
            _ => self.levels[level - 1].0,
        }
    }

    /// Node (`x`, `y`) of `level`; `depth` is the map's.
    #[inline]
    fn node(&self, depth: &[f32], level: usize, x: usize, y: usize) -> (f32, f32) {
        if level == 0 {
            let n = self.size as usize;
            let word = self.base[y * n.div_ceil(64) + x / 64];
            if word >> (x % 64) & 1 != 0 {
                let c = depth[y * n + x];
                return (c, c);
            }
            return EMPTY_RANGE;
        }
        let (edge, nodes) = &self.levels[level - 1];
        nodes[y * edge + x]
    }

    /// Depth range of receivers within texels `x0..=x1`, `y0..=y1` (clamped to the map),
    /// from at most 2x2 nodes of the coarsest level that covers the rectangle so; `map` is
    /// the map the hierarchy was built from. An empty range is `(inf, -inf)`.
    pub fn range(&self, map: &ShadowMap, x0: i64, y0: i64, x1: i64, y1: i64) -> (f32, f32) {
        let size = i64::from(self.size);
        let (x0, x1) = (x0.clamp(0, size - 1), x1.clamp(0, size - 1));
        let (y0, y1) = (y0.clamp(0, size - 1), y1.clamp(0, size - 1));
        let extent = (x1 - x0).max(y1 - y0).max(1) as u64;
        let level = (64 - (extent - 1).leading_zeros()).min(self.levels.len() as u32) as usize;
        let lsize = self.edge(level) as i64;
        let mut r = EMPTY_RANGE;
        for y in (y0 >> level)..=(y1 >> level).min(lsize - 1) {
            for x in (x0 >> level)..=(x1 >> level).min(lsize - 1) {
                let v = self.node(&map.depth, level, x as usize, y as usize);
                r = (r.0.min(v.0), r.1.max(v.1));
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A 64² map under the identity transform (texel x = (p.x + 1) * 32): flat blocks, a
    /// ramp and a step, so that footprints are decided by the block ranges, mixed, or at
    /// the map's edge.
    fn map() -> ShadowMap {
        map_of(64)
    }

    pub(crate) fn map_of(size: u32) -> ShadowMap {
        let depth = (0..size * size)
            .map(|i| {
                let (x, y) = (i % size, i / size);
                match (x / 16, y / 16) {
                    (0, _) => 0.25,
                    (1, _) => 0.2 + 0.01 * (x + y) as f32,
                    (2, _) if (x + y) % 7 == 0 => 0.9,
                    _ => 0.5,
                }
            })
            .collect::<Vec<f32>>();
        map_with(size, depth)
    }

    fn map_with(size: u32, depth: Vec<f32>) -> ShadowMap {
        ShadowMap {
            size,
            view_projection: Mat4::IDENTITY,
            blocks: size.div_ceil(BLOCK),
            footprint_ranges: footprint_ranges(&block_ranges(&depth, size), size),
            depth,
            base_line: 0,
            texel_depth: 1.0 / size as f32,
            stats: ShadowPassStats::default(),
            receivers: Mutex::new(Vec::new()),
        }
    }

    proptest! {
        /// Listing triangles by band first changes nothing: each band's own test picks,
        /// from its candidates, exactly the triangles it picks from all of them, in
        /// submission order, on a map whose size is not a multiple of the band.
        #[test]
        fn band_candidates_hold_every_triangle_the_band_draws(
            corners in prop::collection::vec(prop::array::uniform3((-1.3f32..1.3, -1.3f32..1.3)), 1..40)
        ) {
            use crate::vertex_stage::setup_clip_triangle;
            let size = 3 * BAND + 5;
            let (mut tris, mut stats) = (Vec::new(), shadetrace_formats::results::VertexStats::default());
            for (i, c) in corners.iter().enumerate() {
                let verts = c.map(|(x, y)| glam::Vec4::new(x, y, 0.5, 1.0));
                setup_clip_triangle(i as u32, verts, true, (size, size), &mut tris, &mut stats);
            }
            let by_band = band_candidates(tris.iter(), size);
            prop_assert_eq!(by_band.len() as u32, size.div_ceil(BAND));
            for (band, candidates) in by_band.iter().enumerate() {
                let (y0, y1) = (band as u32 * BAND, ((band as u32 + 1) * BAND).min(size));
                let draws = |t: &SetupTriangle| t.bbox[1] < y1 && t.bbox[3] >= y0;
                let picked: Vec<u32> = candidates.iter().filter(|t| draws(t)).map(|t| t.prim).collect();
                let expected: Vec<u32> = tris.iter().filter(|t| draws(t)).map(|t| t.prim).collect();
                prop_assert_eq!(picked, expected, "band {}", band);
            }
        }
    }

    proptest! {
        /// The map holds each texel's nearest depth of the triangles covering its centre (the
        /// definition, texel by texel), 1.0 elsewhere, with its blocks' ranges and the
        /// count of texels written: over bands and a short last band and block row, with
        /// triangles from a few texels to far past the map (edges too large to step in f64).
        #[test]
        fn the_map_holds_each_texels_nearest_depth(
            triangles in prop::collection::vec(
                (prop::array::uniform3((-1.3f32..1.3, -1.3f32..1.3, 0.0f32..1.0)), prop_oneof![Just(1.0f32), 0.05f32..0.3, Just(4000.0f32)]),
                1..30,
            )
        ) {
            use crate::vertex_stage::setup_clip_triangle;
            let size = 2 * BAND + 13;
            let (mut tris, mut stats) = (Vec::new(), shadetrace_formats::results::VertexStats::default());
            for (i, (corners, scale)) in triangles.iter().enumerate() {
                let verts = corners.map(|(x, y, z)| glam::Vec4::new(x * scale, y * scale, z, 1.0));
                setup_clip_triangle(i as u32, verts, true, (size, size), &mut tris, &mut stats);
            }
            let (depth, blocks, written) = draw_map(tris.iter(), size);
            for y in 0..size {
                for x in 0..size {
                    let (cx, cy) = crate::raster::pixel_center(x, y);
                    let nearest = tris
                        .iter()
                        .filter(|t| t.inside(t.edges(cx, cy)))
                        .map(|t| t.depth(t.edges(cx, cy)))
                        .fold(1.0f32, f32::min);
                    prop_assert_eq!(depth[(y * size + x) as usize], nearest, "texel ({}, {})", x, y);
                }
            }
            prop_assert_eq!(blocks, block_ranges(&depth, size));
            prop_assert_eq!(written, depth.iter().filter(|&&d| d < 1.0).count() as u64);
        }
    }

    proptest! {
        /// A quad's footprints are each lane's own, bit for bit: the two are written apart
        /// (four lanes in registers, one lane in glam) and must not drift. Positions reach past
        /// the map, the projection divides by w, and the cosines include the extremes.
        #[test]
        fn quad_footprints_are_each_lanes_own(
            positions in prop::array::uniform4((-1.5f32..1.5, -1.5f32..1.5, -0.5f32..1.5)),
            n_dot_l in prop::array::uniform4(prop_oneof![
                -1.0f32..1.0, Just(0.0f32), Just(-0.0f32), Just(f32::NAN), Just(f32::INFINITY)
            ]),
            tilt in -0.5f32..0.5,
        ) {
            let mut map = map();
            map.view_projection = Mat4::from_cols_array(&[
                1.0, 0.0, 0.0, 0.0, tilt, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, tilt, 0.0, 0.0, 0.0, 1.0,
            ]);
            let positions = positions.map(|(x, y, z)| Vec3::new(x, y, z));
            let quad = map.quad_footprints(Vec3x4::from_lanes(&positions), f32x4::new(n_dot_l));
            let bits = |f: Option<PcfFootprint>| f.map(|f| (f.tx, f.ty, f.receiver.to_bits()));
            for l in 0..4 {
                prop_assert_eq!(bits(quad[l]), bits(map.footprint(positions[l], n_dot_l[l])));
            }
        }
    }

    proptest! {
        /// A footprint decided by its blocks' depth ranges is decided as its 25 taps are
        /// counted, in whichever blocks (one, two side by side, two stacked, or 2x2) and at
        /// whichever edge of the map it falls.
        #[test]
        fn pcf_decides_by_every_block_the_footprint_spans(
            tx in -3i32..67,
            ty in -3i32..67,
            // Depth steps from block to block: the receiver at one block's depth, or a hair
            // in front of it, is decided by its blocks' ranges or counted tap by tap.
            seed in 1u32..1000,
            at_block in 0u32..64,
            nudge in prop_oneof![Just(0.0f32), Just(-1e-6), Just(1e-6)],
        ) {
            let block_depth = |bx: u32, by: u32| ((bx * 7 + by * 13) * seed % 97) as f32 / 97.0;
            let depth = (0..64 * 64).map(|i| block_depth(i % 64 / BLOCK, i / 64 / BLOCK)).collect();
            let map = map_with(64, depth);
            let receiver = block_depth(at_block % 8, at_block / 8) + nudge;
            let got = map.filter(PcfFootprint { tx, ty, receiver }, &mut AccessLog::new());
            let mut lit = 0;
            for dy in -PCF_RADIUS..=PCF_RADIUS {
                for dx in -PCF_RADIUS..=PCF_RADIUS {
                    let (sx, sy) = ((tx + dx).clamp(0, 63), (ty + dy).clamp(0, 63));
                    lit += u32::from(receiver <= map.depth[(sy * 64 + sx) as usize]);
                }
            }
            prop_assert_eq!(got, lit as f32 / 25.0);
        }

        /// The block ranges only skip work: the lit fraction is the 25 taps' count, and the
        /// log the same accesses, wherever the footprint falls.
        #[test]
        fn pcf_counts_every_tap(x in -1.0f32..1.0, y in -1.0f32..1.0, z in 0.0f32..1.0, n_dot_l in 0.0f32..1.0) {
            let map = map();
            let mut log = AccessLog::new();
            let footprint = map.footprint(Vec3::new(x, y, z), n_dot_l).unwrap();
            let got = map.filter(footprint, &mut log);
            let size = map.size as i32;
            let (tx, ty) = (((x * 0.5 + 0.5) * 64.0).floor() as i32, ((0.5 - y * 0.5) * 64.0).floor() as i32);
            let slope = (1.0 - n_dot_l * n_dot_l).max(0.0).sqrt() / n_dot_l.max(0.05);
            let receiver = z - map.texel_depth * (1.5 + 2.0 * slope.min(10.0));
            let mut lit = 0;
            let mut lines = Vec::new();
            for dy in -PCF_RADIUS..=PCF_RADIUS {
                for dx in -PCF_RADIUS..=PCF_RADIUS {
                    let (sx, sy) = ((tx + dx).clamp(0, size - 1), (ty + dy).clamp(0, size - 1));
                    lit += u32::from(receiver <= map.depth[(sy * size + sx) as usize]);
                    let line = u64::from((sy as u32 / BLOCK) * (64 / BLOCK) + sx as u32 / BLOCK);
                    if lines.last() != Some(&line) {
                        lines.push(line);
                    }
                }
            }
            prop_assert_eq!(got, lit as f32 / 25.0);
            let logged: Vec<u64> = log.expanded(0, Stream::Texture).into_iter().map(u64::from).collect();
            prop_assert_eq!(logged, lines);
        }
    }

    proptest! {
        /// The base level's bits are the receivers: on maps of noise (NaN and both zeros
        /// among the depths), whose edges are not multiples of four, and on maps too small
        /// for four texels at a time.
        #[test]
        fn receiver_bits_are_the_receivers(
            size in prop_oneof![Just(3u32), Just(9u32), Just(67u32), Just(130u32)],
            delta in prop_oneof![Just(0.0f32), Just(0.05), Just(0.3)],
            seed in any::<u64>(),
        ) {
            let mut state = seed | 1;
            let depth = (0..size * size)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    match state % 16 {
                        0 => f32::NAN,
                        1 => 0.0,
                        2 => -0.0,
                        _ => (state >> 40) as f32 / (1u64 << 24) as f32,
                    }
                })
                .collect::<Vec<f32>>();
            let map = map_with(size, depth);
            let hierarchy = map.build_receivers(delta);
            let n = size as usize;
            let z = |x: usize, y: usize| map.depth[y * n + x];
            for y in 0..n {
                for x in 0..n {
                    let c = z(x, y);
                    let ddx = if x > 0 && x + 1 < n { z(x - 1, y) - 2.0 * c + z(x + 1, y) } else { 0.0 };
                    let ddy = if y > 0 && y + 1 < n { z(x, y - 1) - 2.0 * c + z(x, y + 1) } else { 0.0 };
                    let bit = hierarchy.base[y * n.div_ceil(64) + x / 64] >> (x % 64) & 1 == 1;
                    prop_assert_eq!(bit, (-ddx).max(-ddy) >= delta, "texel ({}, {})", x, y);
                }
            }
        }
    }

    proptest! {
        /// A range is the union of the receivers (texels whose second depth derivative is
        /// below `-delta`) under the nodes covering the rectangle at its level, each the
        /// texel's own depth, wherever the rectangle falls: at the map's edges or past them,
        /// and on a map whose edge is not a power of two.
        #[test]
        fn receiver_ranges_are_the_receivers_beneath(
            size in prop_oneof![Just(64u32), Just(50u32)],
            delta in prop_oneof![Just(0.001f32), Just(0.05), Just(0.5)],
            x0 in -8i64..60, y0 in -8i64..60, w in 0i64..40, h in 0i64..40,
        ) {
            let map = map_of(size);
            let hierarchy = map.receivers(delta);
            let (x1, y1) = (x0 + w, y0 + h);
            let n = size as i64;
            let z = |x: i64, y: i64| map.depth[(y * n + x) as usize];
            let receives = |x: i64, y: i64| {
                let c = z(x, y);
                let ddx = if x > 0 && x + 1 < n { z(x - 1, y) - 2.0 * c + z(x + 1, y) } else { 0.0 };
                let ddy = if y > 0 && y + 1 < n { z(x, y - 1) - 2.0 * c + z(x, y + 1) } else { 0.0 };
                (-ddx).max(-ddy) >= delta
            };
            let (cx0, cx1, cy0, cy1) = (x0.clamp(0, n - 1), x1.clamp(0, n - 1), y0.clamp(0, n - 1), y1.clamp(0, n - 1));
            let extent = (cx1 - cx0).max(cy1 - cy0).max(1) as u64;
            let top = 64 - (n as u64 - 1).leading_zeros();
            let level = (64 - (extent - 1).leading_zeros()).min(top) as i64;
            let edge = (0..level).fold(n, |e, _| (e + 1) / 2);
            let span = |a: i64, b: i64| (a >> level << level)..(((b >> level).min(edge - 1) + 1) << level).min(n);
            let mut expected = EMPTY_RANGE;
            for y in span(cy0, cy1) {
                for x in span(cx0, cx1) {
                    if receives(x, y) {
                        expected = (expected.0.min(z(x, y)), expected.1.max(z(x, y)));
                    }
                }
            }
            prop_assert_eq!(hierarchy.range(&map, x0, y0, x1, y1), expected);
        }
    }
}
