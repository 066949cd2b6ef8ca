//! Textures: mip chains in linear colour, trilinear filtering with the level of detail from
//! quad derivatives, and the texel addresses each fetch sends to the memory model.
//!
//! Texels are RGBA8 in memory (4 bytes), stored block-linear: one 256-byte line holds an
//! 8x8 texel block, so a bilinear footprint touches one to four lines.

use glam::{Vec2, Vec4};
use shadetrace_formats::{Texture, Wrap};
use wide::f32x4;

use crate::float::{floor, floor4};
use crate::memory::{AccessLog, Stream};

/// Texels per block edge (8x8 RGBA8 texels = one 256-byte line).
pub const BLOCK: u32 = 8;

/// One mip level.
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec4>,
    /// First cache line of this level in the texture address space.
    pub base_line: u64,
    blocks_x: u32,
}

impl Level {
    /// The bilinear blend of the 2x2 footprint of columns `u` and rows `v` with weights
    /// `fx` and `fy`, `touch` called with each texel's line in fetch order (row by row).
    /// A footprint inside one block (the usual case) touches its line once: the log drops
    /// the three repeats.
    #[inline(always)]
    fn footprint(&self, [u0, u1]: [u32; 2], [v0, v1]: [u32; 2], fx: f32, fy: f32, touch: &mut impl FnMut(u64)) -> Vec4 {
        let (row0, row1) = ((v0 / BLOCK) * self.blocks_x, (v1 / BLOCK) * self.blocks_x);
        let (column0, column1) = (u0 / BLOCK, u1 / BLOCK);
        let line = |row: u32, column: u32| self.base_line + u64::from(row + column);
        touch(line(row0, column0));
        if row0 != row1 || column0 != column1 {
            touch(line(row0, column1));
            touch(line(row1, column0));
            touch(line(row1, column1));
        }
        let (top, bottom) = (
            &self.texels[(v0 * self.width) as usize..],
            &self.texels[(v1 * self.width) as usize..],
        );
        let top = top[u0 as usize] * (1.0 - fx) + top[u1 as usize] * fx;
        let bottom = bottom[u0 as usize] * (1.0 - fx) + bottom[u1 as usize] * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Lines a level of `width x height` texels occupies.
pub fn level_lines(width: u32, height: u32) -> u64 {
    (width.div_ceil(BLOCK) * height.div_ceil(BLOCK)) as u64
}

/// The lines one trilinear sample fetches from, in fetch order (at most eight texels), a line
/// straight after itself kept once: the log drops such a repeat anyway.
#[derive(Clone, Copy, Debug, Default)]
pub struct TexelLines {
    lines: [u64; 8],
    len: u8,
}

impl TexelLines {
    #[inline(always)]
    fn push(&mut self, line: u64) {
        let len = usize::from(self.len);
        if len == 0 || self.lines[len - 1] != line {
            self.lines[len] = line;
            self.len += 1;
        }
    }

    /// Logs the sample's reads as [`MipTexture::sample_at`] does. Out of line: inlined into
    /// the lane functions, it slowed the quads that never call it (of materials without
    /// textures) by 2%.
    #[inline(never)]
    pub fn log(&self, log: &mut AccessLog) {
        for &line in &self.lines[..usize::from(self.len)] {
            log.touch(Stream::Texture, line, false);
        }
    }
}

/// Where a trilinear sample falls in a mip chain: the finer of the two levels it blends and
/// the coarser one's weight. It depends only on the texture and the screen derivatives,
/// which a quad's four lanes share: a quad finds it once ([`crate::shader::TextureLods`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lod {
    level: u32,
    t: f32,
}

/// A texture ready for sampling.
pub struct MipTexture {
    pub levels: Vec<Level>,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
}

/// sRGB 8-bit to linear.
pub fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        libm::powf((c + 0.055) / 1.055, 2.4)
    }
}

impl MipTexture {
    /// Builds the full mip chain (2x2 box filter in linear space) starting at `base_line`;
    /// returns the texture and the first free line after it. Colour textures are sRGB;
    /// data textures (`srgb` false: normal, metallic-roughness, occlusion maps) are read as
    /// they are stored.
    pub fn build(texture: &Texture, base_line: u64, srgb: bool) -> (MipTexture, u64) {
        let lut: Vec<f32> = (0..=255u8)
            .map(|c| if srgb { srgb_to_linear(c) } else { f32::from(c) / 255.0 })
            .collect();
        let base: Vec<Vec4> = texture
            .rgba8
            .chunks_exact(4)
            .map(|p| {
                Vec4::new(
                    lut[p[0] as usize],
                    lut[p[1] as usize],
                    lut[p[2] as usize],
                    p[3] as f32 / 255.0,
                )
            })
            .collect();
        let mut levels = Vec::new();
        let (mut w, mut h, mut texels) = (texture.width, texture.height, base);
        let mut line = base_line;
        loop {
            levels.push(Level {
                width: w,
                height: h,
                texels: texels.clone(),
                base_line: line,
                blocks_x: w.div_ceil(BLOCK),
            });
            line += level_lines(w, h);
            if w == 1 && h == 1 {
                break;
            }
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let mut next = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                for x in 0..nw {
                    let at =
                        |dx: u32, dy: u32| texels[((2 * y + dy).min(h - 1) * w + (2 * x + dx).min(w - 1)) as usize];
                    next.push((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) * 0.25);
                }
            }
            (w, h, texels) = (nw, nh, next);
        }
        (
            MipTexture {
                levels,
                wrap_u: texture.wrap_u,
                wrap_v: texture.wrap_v,
            },
            line,
        )
    }

    /// Trilinear sample at `uv` with screen derivatives `dx`, `dy` (uv per pixel); every
    /// texel fetched is logged.
    pub fn sample(&self, uv: Vec2, dx: Vec2, dy: Vec2, log: &mut AccessLog) -> Vec4 {
        self.sample_at(uv, self.lod(dx, dy), log)
    }

    /// Where a sample with screen derivatives `dx` and `dy` (in uv) falls in the mip chain.
    pub fn lod(&self, dx: Vec2, dy: Vec2) -> Lod {
        let base = &self.levels[0];
        let size = Vec2::new(base.width as f32, base.height as f32);
        let rho = (dx * size).length().max((dy * size).length());
        let lod = if rho.is_finite() && rho > 1.0 {
            libm::log2f(rho)
        } else {
            0.0
        };
        let max_level = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, max_level);
        let level = floor(lod) as u32;
        Lod {
            level,
            t: lod - level as f32,
        }
    }

    /// Whether `other`'s chain has this one's base size and number of levels: then its
    /// [`Self::lod`] at any derivatives is this one's (it reads nothing else).
    pub fn same_shape(&self, other: &MipTexture) -> bool {
        let (a, b) = (&self.levels[0], &other.levels[0]);
        (a.width, a.height, self.levels.len()) == (b.width, b.height, other.levels.len())
    }

    /// [`Self::sample`] at a level of detail already found ([`Self::lod`]).
    pub fn sample_at(&self, uv: Vec2, lod: Lod, log: &mut AccessLog) -> Vec4 {
        self.trilinear(uv, lod, |line| log.touch(Stream::Texture, line, false))
    }

    /// [`Self::sample_at`] with its reads kept in `reads` instead of logged: for a value
    /// wanted before its reads' turn in the log ([`TexelLines::log`] then logs them).
    pub fn sample_recording(&self, uv: Vec2, lod: Lod, reads: &mut TexelLines) -> Vec4 {
        reads.len = 0;
        self.trilinear(uv, lod, |line| reads.push(line))
    }

    /// [`Self::sample_recording`] of a quad's four lanes at one level of detail (a quad's
    /// lanes share it): each lane's value and reads, its footprint found four lanes at a
    /// time.
    pub fn sample_quad_recording(
        &self,
        uvs: [Vec2; 4],
        Lod { level, t }: Lod,
        reads: &mut [TexelLines; 4],
    ) -> [Vec4; 4] {
        for lane in reads.iter_mut() {
            lane.len = 0;
        }
        let l0 = level as usize;
        let a = self.bilinear_quad(l0, uvs, reads);
        if t > 0.0 && l0 + 1 < self.levels.len() {
            let b = self.bilinear_quad(l0 + 1, uvs, reads);
            [0, 1, 2, 3].map(|l| a[l] * (1.0 - t) + b[l] * t)
        } else {
            a
        }
    }

    /// [`Self::bilinear`] of four lanes, each lane's lines pushed to its record. A lane whose
    /// footprint needs no wrapping (the usual case) takes its coordinates and weights from
    /// the four-lane arithmetic, the same operations as `bilinear`'s; any other lane takes
    /// `bilinear`.
    #[inline(always)]
    fn bilinear_quad(&self, level: usize, uvs: [Vec2; 4], reads: &mut [TexelLines; 4]) -> [Vec4; 4] {
        let l = &self.levels[level];
        let (width, height) = (l.width as f32, l.height as f32);
        let x = f32x4::new(uvs.map(|uv| uv.x)) * f32x4::splat(width) - f32x4::splat(0.5);
        let y = f32x4::new(uvs.map(|uv| uv.y)) * f32x4::splat(height) - f32x4::splat(0.5);
        let (x0, y0) = (floor4(x), floor4(y));
        // Both columns and both rows inside the level (false for NaN and infinities).
        let inside = x0.simd_ge(f32x4::ZERO)
            & x0.simd_le(f32x4::splat(width - 2.0))
            & y0.simd_ge(f32x4::ZERO)
            & y0.simd_le(f32x4::splat(height - 2.0));
        let inside = inside.to_bitmask();
        let (fx, fy) = ((x - x0).to_array(), (y - y0).to_array());
        let (u0, v0) = (x0.fast_trunc_int().to_array(), y0.fast_trunc_int().to_array());
        // A loop rather than `array::from_fn`, whose closure was left out of line.
        let mut out = [Vec4::ZERO; 4];
        for (lane, (out, record)) in out.iter_mut().zip(reads).enumerate() {
            *out = match inside & 1 << lane {
                0 => self.bilinear_recorded(level, uvs[lane], record),
                _ => {
                    let (u, v) = (u0[lane] as u32, v0[lane] as u32);
                    l.footprint([u, u + 1], [v, v + 1], fx[lane], fy[lane], &mut |line| {
                        record.push(line)
                    })
                }
            };
        }
        out
    }

    /// [`Self::bilinear`] with its lines pushed to `record`, for the lanes of a quad that
    /// wrap: out of line, as inlined into the four-lane loop it slowed every lane.
    #[inline(never)]
    fn bilinear_recorded(&self, level: usize, uv: Vec2, record: &mut TexelLines) -> Vec4 {
        self.bilinear(level, uv, &mut |line| record.push(line))
    }

    /// The trilinear sample, `touch` called with each texel's line, in fetch order.
    #[inline(always)]
    fn trilinear(&self, uv: Vec2, Lod { level, t }: Lod, mut touch: impl FnMut(u64)) -> Vec4 {
        let l0 = level as usize;
        let a = self.bilinear(l0, uv, &mut touch);
        if t > 0.0 && l0 + 1 < self.levels.len() {
            let b = self.bilinear(l0 + 1, uv, &mut touch);
            a * (1.0 - t) + b * t
        } else {
            a
        }
    }

    #[inline(always)]
    fn bilinear(&self, level: usize, uv: Vec2, touch: &mut impl FnMut(u64)) -> Vec4 {
        let l = &self.levels[level];
        let x = uv.x * l.width as f32 - 0.5;
        let y = uv.y * l.height as f32 - 0.5;
        let (x0, y0) = (floor(x), floor(y));
        // Non-finite coordinates (only degenerate helper lanes produce them) read texel 0
        // unfiltered instead of spreading NaN.
        let (fx, fy) = if x.is_finite() && y.is_finite() {
            (x - x0, y - y0)
        } else {
            (0.0, 0.0)
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        // The footprint's two columns and two rows, wrapped once each (an infinite
        // coordinate's i64::MAX steps to i64::MIN, in any build).
        let (u1, v1) = (x0.wrapping_add(1), y0.wrapping_add(1));
        let (u0, u1) = (wrap(x0, l.width, self.wrap_u), wrap(u1, l.width, self.wrap_u));
        let (v0, v1) = (wrap(y0, l.height, self.wrap_v), wrap(v1, l.height, self.wrap_v));
        l.footprint([u0, u1], [v0, v1], fx, fy, touch)
    }
}

/// Texel coordinate after wrapping; NaN or huge inputs end up clamped, never out of range.
#[inline]
pub fn wrap(t: i64, size: u32, mode: Wrap) -> u32 {
    let n = size as i64;
    // Every mode leaves a coordinate inside the texture as it is (the usual case, without
    // the division of the others).
    if (0..n).contains(&t) {
        return t as u32;
    }
    let r = match mode {
        Wrap::Repeat => t.rem_euclid(n),
        Wrap::ClampToEdge => t.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = t.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
    };
    r as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex(w: u32, h: u32) -> Texture {
        Texture {
            name: "t".into(),
            width: w,
            height: h,
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::ClampToEdge,
            rgba8: (0..w * h * 4).map(|i| (i * 7 % 251) as u8).collect(),
        }
    }

    #[test]
    fn mip_chain_and_lines() {
        let (m, end) = MipTexture::build(&tex(20, 12), 100, true);
        let dims: Vec<(u32, u32)> = m.levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(dims, [(20, 12), (10, 6), (5, 3), (2, 1), (1, 1)]);
        assert_eq!(m.levels[1].base_line, 100 + 3 * 2);
        assert_eq!(end, 100 + 6 + 2 + 1 + 1 + 1);
    }

    #[test]
    fn wraps_stay_in_range() {
        for mode in [Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat] {
            for t in [-1_000_000_007i64, -5, -1, 0, 3, 4, 9, i64::MAX / 4] {
                assert!(wrap(t, 4, mode) < 4);
            }
        }
        assert_eq!(wrap(-1, 4, Wrap::MirroredRepeat), 0);
        assert_eq!(wrap(4, 4, Wrap::MirroredRepeat), 3);
    }

    /// Coordinates inside the texture skip the modes' arithmetic, which would leave them
    /// as they are too.
    #[test]
    fn wrapping_matches_each_modes_definition() {
        for size in [1u32, 3, 8] {
            let n = i64::from(size);
            for t in -3 * n..3 * n {
                let mirrored = t.rem_euclid(2 * n);
                let mirrored = if mirrored < n { mirrored } else { 2 * n - 1 - mirrored };
                assert_eq!(i64::from(wrap(t, size, Wrap::Repeat)), t.rem_euclid(n), "{t} in {size}");
                assert_eq!(
                    i64::from(wrap(t, size, Wrap::ClampToEdge)),
                    t.clamp(0, n - 1),
                    "{t} in {size}"
                );
                assert_eq!(
                    i64::from(wrap(t, size, Wrap::MirroredRepeat)),
                    mirrored,
                    "{t} in {size}"
                );
            }
        }
    }

    proptest::proptest! {
        /// A sample taken with its reads kept, then logged, is [`MipTexture::sample_at`]'s: the
        /// value's bits and the same reads after the same earlier read, at any level and
        /// blend, its texels in one line or across four, wrapped or clamped.
        #[test]
        fn a_recorded_sample_is_sample_ats(
            u in -2.0f32..2.0,
            v in -2.0f32..2.0,
            level in 0u32..6,
            t in proptest::prop_oneof![proptest::strategy::Just(0.0f32), 0.0f32..1.0],
            before in 0u64..40,
        ) {
            let (m, _) = MipTexture::build(&tex(37, 20), 0, true);
            let (uv, lod) = (Vec2::new(u, v), Lod { level, t });
            let (mut want_log, mut got_log) = (AccessLog::new(), AccessLog::new());
            want_log.touch(Stream::Texture, before, false);
            got_log.touch(Stream::Texture, before, false);
            let want = m.sample_at(uv, lod, &mut want_log);
            let mut reads = TexelLines::default();
            let got = m.sample_recording(uv, lod, &mut reads);
            reads.log(&mut got_log);
            proptest::prop_assert_eq!(got.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits));
            proptest::prop_assert_eq!(got_log.expanded(0, Stream::Texture), want_log.expanded(0, Stream::Texture));
        }
    }

    /// A texture of `w x h` texels wrapped by `modes` (u, v).
    fn wrapped(w: u32, h: u32, modes: (Wrap, Wrap)) -> MipTexture {
        let mut texture = tex(w, h);
        (texture.wrap_u, texture.wrap_v) = modes;
        MipTexture::build(&texture, 0, true).0
    }

    fn wrap_modes() -> impl proptest::strategy::Strategy<Value = (Wrap, Wrap)> {
        let mode = || proptest::sample::select(vec![Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat]);
        (mode(), mode())
    }

    /// Coordinates across the texture and past it, and the extremes.
    fn coordinate() -> impl proptest::strategy::Strategy<Value = f32> {
        proptest::prop_oneof![
            8 => -3.0f32..3.0,
            1 => proptest::sample::select(vec![f32::NAN, f32::INFINITY, -f32::INFINITY, 3e9, -3e9, 1e30]),
        ]
    }

    proptest::proptest! {
        /// A sample reads, in order, the line of each texel it blends: the finer level's
        /// 2x2 footprint row by row, then the coarser one's when it blends two (the log
        /// drops a line straight after itself, which a footprint in one block repeats).
        #[test]
        fn a_sample_reads_each_texels_line(
            u in coordinate(),
            v in coordinate(),
            level in 0u32..6,
            t in proptest::prop_oneof![proptest::strategy::Just(0.0f32), 0.0f32..1.0],
            modes in wrap_modes(),
        ) {
            let m = wrapped(37, 20, modes);
            let mut want = AccessLog::new();
            let levels = match t > 0.0 && (level as usize) + 1 < m.levels.len() {
                true => level..level + 2,
                false => level..level + 1,
            };
            for l in levels.map(|l| &m.levels[l as usize]) {
                let (x, y) = (u * l.width as f32 - 0.5, v * l.height as f32 - 0.5);
                let (x0, y0) = (x.floor() as i64, y.floor() as i64);
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (tu, tv) = (wrap(x0.wrapping_add(dx), l.width, modes.0), wrap(y0.wrapping_add(dy), l.height, modes.1));
                    let line = l.base_line + u64::from((tv / BLOCK) * l.blocks_x + tu / BLOCK);
                    want.touch(Stream::Texture, line, false);
                }
            }
            let mut got = AccessLog::new();
            m.sample_at(Vec2::new(u, v), Lod { level, t }, &mut got);
            proptest::prop_assert_eq!(got.expanded(0, Stream::Texture), want.expanded(0, Stream::Texture));
        }

        /// A quad's four lanes sampled together are each lane's own recorded sample: the
        /// value's bits and the reads, wrapped, clamped or mirrored, at coordinates inside
        /// the texture, past it and not finite, on levels as narrow as one texel.
        #[test]
        fn a_quads_samples_are_each_lanes_own(
            uvs in proptest::array::uniform4((coordinate(), coordinate())),
            size in proptest::sample::select(vec![(37u32, 20u32), (1, 9), (2, 2)]),
            level in 0u32..6,
            t in proptest::prop_oneof![proptest::strategy::Just(0.0f32), 0.0f32..1.0],
            modes in wrap_modes(),
        ) {
            let m = wrapped(size.0, size.1, modes);
            let level = level.min(m.levels.len() as u32 - 1);
            let (uvs, lod) = (uvs.map(|(u, v)| Vec2::new(u, v)), Lod { level, t });
            let mut reads = [TexelLines::default(); 4];
            let got = m.sample_quad_recording(uvs, lod, &mut reads);
            for lane in 0..4 {
                let mut want_reads = TexelLines::default();
                let want = m.sample_recording(uvs[lane], lod, &mut want_reads);
                proptest::prop_assert_eq!(got[lane].to_array().map(f32::to_bits), want.to_array().map(f32::to_bits));
                proptest::prop_assert_eq!(
                    &reads[lane].lines[..usize::from(reads[lane].len)],
                    &want_reads.lines[..usize::from(want_reads.len)]
                );
            }
        }
    }

    proptest::proptest! {
        /// Textures of the same shape find the same level of detail at any derivatives
        /// (what lets a quad find one per shape); shapes that differ in one size only do not.
        #[test]
        fn a_shape_decides_the_level_of_detail(
            shapes in proptest::array::uniform2(proptest::sample::select(vec![(16u32, 16u32), (64, 16), (64, 32), (16, 64), (32, 64)])),
            derivatives in proptest::array::uniform4(proptest::prop_oneof![-0.5f32..0.5, -0.01f32..0.01]),
        ) {
            let [a, b] = shapes.map(|(w, h)| MipTexture::build(&tex(w, h), 0, true).0);
            let (dx, dy) = (Vec2::new(derivatives[0], derivatives[1]), Vec2::new(derivatives[2], derivatives[3]));
            if a.same_shape(&b) {
                proptest::prop_assert_eq!(a.lod(dx, dy), b.lod(dx, dy));
            }
        }
    }

    #[test]
    fn nan_uv_does_not_panic() {
        let (m, _) = MipTexture::build(&tex(8, 8), 0, true);
        let mut log = AccessLog::new();
        let v = m.sample(Vec2::NAN, Vec2::NAN, Vec2::ZERO, &mut log);
        assert!(v.is_finite(), "{v}");
        let v = m.sample(Vec2::splat(f32::INFINITY), Vec2::ZERO, Vec2::ZERO, &mut log);
        assert!(v.is_finite(), "{v}");
    }
}
