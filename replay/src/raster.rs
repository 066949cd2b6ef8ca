//! Rasterization of one triangle inside one tile into 2x2 quads, with per-sample coverage
//! (MSAA 1/4/8, standard sample positions) and pixel centres at +0.5.

use crate::vertex_stage::{SetupTriangle, SUBPIXEL, SUBPIXEL_BITS};

/// Sample offsets from the pixel's top-left corner in 1/16 pixel (D3D standard patterns).
pub fn sample_offsets(msaa: u32) -> &'static [[i64; 2]] {
    match msaa {
        4 => &[[6, 2], [14, 6], [2, 10], [10, 14]],
        8 => &[[9, 5], [7, 11], [13, 9], [5, 3], [3, 13], [1, 7], [11, 15], [15, 1]],
        _ => &[[8, 8]],
    }
}

/// Tile rectangle in pixels, inclusive-exclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

/// One 2x2 quad a triangle touches: `coverage` has bit `lane * samples + s` set for each
/// covered sample; lanes are (0,0), (1,0), (0,1), (1,1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quad {
    pub x: u32,
    pub y: u32,
    pub coverage: u32,
}

/// Fixed-point position of sample `s` of pixel (x, y).
#[inline]
pub fn sample_position(x: u32, y: u32, offset: [i64; 2]) -> (i64, i64) {
    (
        x as i64 * SUBPIXEL + offset[0] * (SUBPIXEL / 16),
        y as i64 * SUBPIXEL + offset[1] * (SUBPIXEL / 16),
    )
}

/// Fixed-point position of the pixel centre.
#[inline]
pub fn pixel_center(x: u32, y: u32) -> (i64, i64) {
    sample_position(x, y, [8, 8])
}

/// Exact test whether the triangle covers any sample position inside the rectangle's sample
/// hull (separating axes: the rectangle's edges via the bounding box, the triangle's edges
/// via the rectangle's corners). Used for binning.
pub fn overlaps(t: &SetupTriangle, r: Rect) -> bool {
    if t.bbox[0] >= r.x1 || t.bbox[2] < r.x0 || t.bbox[1] >= r.y1 || t.bbox[3] < r.y0 {
        return false;
    }
    let (x0, y0) = (r.x0 as i64 * SUBPIXEL, r.y0 as i64 * SUBPIXEL);
    let (x1, y1) = (r.x1 as i64 * SUBPIXEL - 1, r.y1 as i64 * SUBPIXEL - 1);
    let corners = [t.edges(x0, y0), t.edges(x1, y0), t.edges(x0, y1), t.edges(x1, y1)];
    (0..3).all(|i| corners.iter().any(|e| e[i] >= i64::from(t.bias[i])))
}

/// Calls `emit` for every quad of the tile the triangle covers, in raster order.
///
/// Per row of samples, each edge function is linear in x, so the samples it accepts form
/// one interval of pixel columns; a quad's coverage is then a few comparisons, and columns
/// outside every interval are never visited. The intervals are exact: each edge's bound is
/// kept as a quotient and remainder ([`ColumnSeries`]) and stepped from row to row without
/// dividing. The result is exactly the per-sample edge test's (tested against it).
///
/// Inlined, so that a caller that knows its sample count (one, mostly) gets loops over
/// the samples that unroll, and `emit` inlined into them.
#[inline(always)]
pub fn rasterize(t: &SetupTriangle, tile: Rect, offsets: &[[i64; 2]], mut emit: impl FnMut(Quad)) {
    let x0 = t.bbox[0].max(tile.x0) & !1;
    let y0 = t.bbox[1].max(tile.y0) & !1;
    let x1 = (t.bbox[2] + 1).min(tile.x1);
    let y1 = (t.bbox[3] + 1).min(tile.y1);
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    let samples = offsets.len();
    // The pixel columns the quads of [x0, x1) reach, inside the tile.
    let last_quad = x0 + (x1 - 1 - x0) / 2 * 2;
    let (col_lo, col_hi) = (x0.max(tile.x0) as i64, (last_quad + 1).min(tile.x1 - 1) as i64);
    // Per lane row (0, 1) and sample: the edges along rows y0 + r, y0 + r + 2, ...
    let steps = EdgeSteps::new(t);
    let mut series = [[ColumnSeries::default(); 8]; 2];
    for (s, &off) in offsets.iter().enumerate() {
        series[0][s] = ColumnSeries::new(t, &steps, y0, off);
        series[1][s] = series[0][s].stepped(&steps, &steps.one_row);
    }
    // Per lane row and sample: the covered columns [lo, hi] (empty when lo > hi).
    let mut spans = [[(0i64, -1i64); 8]; 2];
    // Every sample of every lane covered.
    let full = u32::MAX >> (32 - 4 * samples);
    let mut y = y0;
    while y < y1 {
        let (mut row_lo, mut row_hi) = (i64::MAX, i64::MIN);
        // The columns every span covers (empty when one is): quads inside are full.
        let (mut inner_lo, mut inner_hi) = (i64::MIN, i64::MAX);
        for (r, (row, row_series)) in spans.iter_mut().zip(&mut series).enumerate() {
            let py = y + r as u32;
            for (span, columns) in row[..samples].iter_mut().zip(&mut row_series[..samples]) {
                *span = if py >= tile.y1 || py < tile.y0 {
                    (0, -1)
                } else {
                    let (lo, hi) = columns.columns(&steps);
                    (lo.max(col_lo), hi.min(col_hi))
                };
                *columns = columns.stepped(&steps, &steps.two_rows);
                (inner_lo, inner_hi) = (inner_lo.max(span.0), inner_hi.min(span.1));
                if span.0 <= span.1 {
                    row_lo = row_lo.min(span.0);
                    row_hi = row_hi.max(span.1);
                }
            }
        }
        if row_lo <= row_hi {
            let mut x = (row_lo as u32 & !1).max(x0);
            while x < x1 && i64::from(x) <= row_hi {
                let mut coverage = full;
                if i64::from(x) < inner_lo || i64::from(x) + 1 > inner_hi {
                    coverage = 0;
                    for lane in 0..4 {
                        let (px, r) = (i64::from(x + (lane & 1)), (lane >> 1) as usize);
                        for (s, &(lo, hi)) in spans[r][..samples].iter().enumerate() {
                            if lo <= px && px <= hi {
                                coverage |= 1 << (lane as usize * samples + s);
                            }
                        }
                    }
                }
                if coverage != 0 {
                    emit(Quad { x, y, coverage });
                }
                x += 2;
            }
        }
        y += 2;
    }
}

/// Calls `emit(y, x0, x1)` for every row of the tile whose pixel centres the triangle
/// covers, top to bottom, with the covered columns `x0..x1`: one sample per pixel, the
/// pixels [`rasterize`] covers at MSAA 1 (tested against it), for a pass that needs no quads
/// (the shadow map's depth-only pass, which then walks each run of texels in turn).
#[inline(always)]
pub fn rasterize_rows(t: &SetupTriangle, tile: Rect, mut emit: impl FnMut(u32, u32, u32)) {
    let y0 = t.bbox[1].max(tile.y0);
    let y1 = (t.bbox[3] + 1).min(tile.y1);
    if y0 >= y1 || tile.x0 >= tile.x1 {
        return;
    }
    let (col_lo, col_hi) = (i64::from(tile.x0), i64::from(tile.x1) - 1);
    let steps = EdgeSteps::new(t);
    let mut series = ColumnSeries::new(t, &steps, y0, [8, 8]);
    for y in y0..y1 {
        let (lo, hi) = series.columns(&steps);
        let (lo, hi) = (lo.max(col_lo), hi.min(col_hi));
        if lo <= hi {
            emit(y, lo as u32, hi as u32 + 1);
        }
        series = series.stepped(&steps, &steps.one_row);
    }
}

/// The three edges' divisors and row steps, shared by every [`ColumnSeries`] of a triangle:
/// edge `i` accepts sample x where `d sx <= m` (`d = b1 - a1`; `m` linear in the row), so its
/// bound is `floor(m / |d|)`, kept as quotient and remainder, and one sample row down `m`
/// grows by a constant, and so does the pair, with one carry.
struct EdgeSteps {
    /// The sign of `d`: which bound the edge sets (0: none, or every column when `m < 0`).
    side: [i64; 3],
    /// `|d|` (1 where `d = 0`, so that the quotient is `m` itself).
    divisor: [i64; 3],
    /// The change of (quotient, remainder) one sample row down, and two rows down.
    one_row: [(i64, i64); 3],
    two_rows: [(i64, i64); 3],
}

impl EdgeSteps {
    fn new(t: &SetupTriangle) -> EdgeSteps {
        let mut steps = EdgeSteps {
            side: [0; 3],
            divisor: [1; 3],
            one_row: [(0, 0); 3],
            two_rows: [(0, 0); 3],
        };
        for (i, (a, b)) in t.edge_ends().into_iter().enumerate() {
            let d = b[1] - a[1];
            let divisor = d.abs().max(1);
            let dm = (b[0] - a[0]) * SUBPIXEL;
            let q = floor_div(dm, divisor);
            steps.side[i] = d.signum();
            steps.divisor[i] = divisor;
            steps.one_row[i] = (q, dm - q * divisor);
            steps.two_rows[i] = carry(2 * q, 2 * (dm - q * divisor), divisor);
        }
        steps
    }
}

/// `(q, r)` with `r` brought back under `divisor` (it is below twice it).
#[inline]
fn carry(q: i64, r: i64, divisor: i64) -> (i64, i64) {
    if r >= divisor {
        (q + 1, r - divisor)
    } else {
        (q, r)
    }
}

/// The pixel columns whose sample at one offset all three edges accept, along every other
/// sample row: per edge `m = q |d| + r` with `0 <= r < |d|` ([`EdgeSteps`]).
#[derive(Clone, Copy, Default)]
struct ColumnSeries {
    q: [i64; 3],
    r: [i64; 3],
    /// The sample's x offset in subpixels.
    ox: i64,
}

impl ColumnSeries {
    /// The series starting at sample row `py`.
    fn new(t: &SetupTriangle, steps: &EdgeSteps, py: u32, offset: [i64; 2]) -> ColumnSeries {
        let sy = py as i64 * SUBPIXEL + offset[1] * (SUBPIXEL / 16);
        let mut series = ColumnSeries {
            ox: offset[0] * (SUBPIXEL / 16),
            ..ColumnSeries::default()
        };
        for (i, (a, b)) in t.edge_ends().into_iter().enumerate() {
            // E(sx) = (b0 - a0)(sy - a1) - d (sx - a0) >= bias  <=>  d sx <= m.
            let d = b[1] - a[1];
            let m = (b[0] - a[0]) * (sy - a[1]) + d * a[0] - i64::from(t.bias[i]);
            series.q[i] = floor_div(m, steps.divisor[i]);
            series.r[i] = m - series.q[i] * steps.divisor[i];
        }
        series
    }

    /// This row's covered columns `[lo, hi]`, empty when `lo > hi`.
    #[inline]
    fn columns(&self, steps: &EdgeSteps) -> (i64, i64) {
        let (mut lo, mut hi) = (i64::MIN, i64::MAX);
        for (&q, &side) in self.q.iter().zip(&steps.side) {
            match side {
                0 if q < 0 => return (0, -1),
                0 => {}
                // sx <= floor(m / d), sx = px SUBPIXEL + ox.
                1 => hi = hi.min((q - self.ox) >> SUBPIXEL_BITS),
                // sx >= ceil(m / d) = -floor(m / |d|).
                _ => lo = lo.max(-((q + self.ox) >> SUBPIXEL_BITS)),
            }
        }
        (lo, hi)
    }

    /// The same series moved down by `by` (one of [`EdgeSteps`]' steps).
    #[inline]
    fn stepped(mut self, steps: &EdgeSteps, by: &[(i64, i64); 3]) -> ColumnSeries {
        for (i, &(q, r)) in by.iter().enumerate() {
            (self.q[i], self.r[i]) = carry(self.q[i] + q, self.r[i] + r, steps.divisor[i]);
        }
        self
    }
}

fn floor_div(a: i64, b: i64) -> i64 {
    let q = a / b;
    if (a % b != 0) && ((a < 0) != (b < 0)) {
        q - 1
    } else {
        q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition: every sample of every lane of every quad tested on its own.
    fn rasterize_by_samples(t: &SetupTriangle, tile: Rect, offsets: &[[i64; 2]], mut emit: impl FnMut(Quad)) {
        let x0 = t.bbox[0].max(tile.x0) & !1;
        let y0 = t.bbox[1].max(tile.y0) & !1;
        let x1 = (t.bbox[2] + 1).min(tile.x1);
        let y1 = (t.bbox[3] + 1).min(tile.y1);
        let samples = offsets.len();
        let mut y = y0;
        while y < y1 {
            let mut x = x0;
            while x < x1 {
                let mut coverage = 0u32;
                for lane in 0..4 {
                    let (px, py) = (x + (lane & 1), y + (lane >> 1));
                    if px >= tile.x1 || py >= tile.y1 || px < tile.x0 || py < tile.y0 {
                        continue;
                    }
                    for (s, &off) in offsets.iter().enumerate() {
                        let (sx, sy) = sample_position(px, py, off);
                        if t.inside(t.edges(sx, sy)) {
                            coverage |= 1 << (lane as usize * samples + s);
                        }
                    }
                }
                if coverage != 0 {
                    emit(Quad { x, y, coverage });
                }
                x += 2;
            }
            y += 2;
        }
    }

    #[test]
    fn spans_give_exactly_the_per_sample_coverage() {
        use crate::geometry::{FrameGeometry, Triangle};
        use crate::vertex_stage::setup_view;
        use glam::{Mat4, Vec3};
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let (width, height) = (67, 45);
        let mut checked = 0;
        for n in 0..600 {
            // Triangles from tiny to larger than the screen, some thin, some off screen; a
            // third with vertices on half-pixel positions, so that edges pass exactly
            // through sample positions (the top-left rule decides there).
            let scale = [0.02, 0.2, 1.0, 4.0][(next() * 4.0) as usize % 4];
            let c = Vec3::new(next() * 2.4 - 1.2, next() * 2.4 - 1.2, 0.5);
            let snap = |v: Vec3| {
                let hx = ((v.x + 1.0) * width as f32).round();
                let hy = ((v.y + 1.0) * height as f32).round();
                Vec3::new(hx / width as f32 - 1.0, hy / height as f32 - 1.0, v.z)
            };
            let corner = |c: Vec3, scale: f32, r: f32, q: f32| {
                let v = c + Vec3::new((r - 0.5) * scale, (q - 0.5) * scale, 0.0);
                if n % 3 == 0 {
                    snap(v)
                } else {
                    v
                }
            };
            let p = [
                corner(c, scale, next(), next()),
                corner(c, scale, next(), next()),
                corner(c, scale, next(), next()),
            ];
            let geometry = FrameGeometry {
                positions: p.to_vec(),
                normals: vec![Vec3::Z; 3],
                uvs: vec![glam::Vec2::ZERO; 3],
                tangents: Vec::new(),
                triangles: vec![Triangle {
                    vertices: [0, 1, 2],
                    material: 0,
                    patch: u32::MAX,
                    mesh: 0,
                }],
            };
            let (setups, _) = setup_view(&geometry, &[true], Mat4::IDENTITY, width, height);
            for t in &setups {
                for msaa in [1, 4, 8] {
                    let offsets = sample_offsets(msaa);
                    for tile in [
                        Rect {
                            x0: 0,
                            y0: 0,
                            x1: width,
                            y1: height,
                        },
                        Rect {
                            x0: 16,
                            y0: 16,
                            x1: 32,
                            y1: 32,
                        },
                        Rect {
                            x0: 64,
                            y0: 32,
                            x1: 67,
                            y1: 45,
                        },
                    ] {
                        let (mut fast, mut exact) = (Vec::new(), Vec::new());
                        rasterize(t, tile, offsets, |q| fast.push(q));
                        rasterize_by_samples(t, tile, offsets, |q| exact.push(q));
                        assert_eq!(fast, exact, "triangle {:?}, tile {tile:?}, msaa {msaa}", t.v);
                        if msaa == 1 {
                            let pixels = |q: &Quad| {
                                let q = *q;
                                (0..4u32)
                                    .filter(move |l| q.coverage & 1 << l != 0)
                                    .map(move |l| (q.y + (l >> 1), q.x + (l & 1)))
                            };
                            let mut by_quads: Vec<(u32, u32)> = exact.iter().flat_map(pixels).collect();
                            by_quads.sort_unstable();
                            let mut by_rows = Vec::new();
                            rasterize_rows(t, tile, |y, x0, x1| by_rows.extend((x0..x1).map(|x| (y, x))));
                            assert_eq!(by_rows, by_quads, "rows of triangle {:?}, tile {tile:?}", t.v);
                        }
                        checked += exact.len();
                    }
                }
            }
        }
        assert!(checked > 10_000, "the triangles cover quads: {checked}");
    }
}
