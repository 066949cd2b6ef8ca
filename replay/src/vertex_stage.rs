//! Vertex stage, one implementation for every back-end: world to clip space per view,
//! homogeneous clipping (near, far and a guard band) before the divide, back-face culling,
//! viewport transform and snapping to 8 sub-pixel bits.
//!
//! Watertightness: a shared edge clipped by a plane yields the same new vertex from both
//! triangles because intersections are always computed from the canonically ordered pair
//! of endpoints; snapped vertices are integers, so the edge functions of the two triangles
//! agree exactly and the top-left rule gives each sample on the edge to exactly one.

use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;
use shadetrace_formats::results::VertexStats;
use wide::f64x4;

use crate::float::round_to_i64;
use crate::geometry::FrameGeometry;

/// Sub-pixel precision of snapped vertices.
pub const SUBPIXEL_BITS: u32 = 8;
pub const SUBPIXEL: i64 = 1 << SUBPIXEL_BITS;
/// Half-extent of the guard band in pixels; geometry beyond it is clipped so that fixed-point
/// coordinates stay below 2^28 and edge-function products fit in i64.
const GUARD_BAND_PX: f64 = (1u64 << 19) as f64;
/// Triangles per parallel work item (fixed, so output order never depends on threads).
const SETUP_CHUNK: usize = 2048;

/// A triangle ready for rasterization in one view.
#[derive(Clone, Debug, PartialEq)]
pub struct SetupTriangle {
    /// Index into [`FrameGeometry::triangles`]: the primitive id.
    pub prim: u32,
    /// Snapped screen positions (y down), reordered if needed so that `area2 > 0`: within
    /// the guard band, a few times 2^27 sub-pixels at most, so 32 bits each (a triangle is
    /// copied per view and read per tile; the edge functions work in i64).
    pub v: [[i32; 2]; 3],
    /// Twice the signed area in fixed-point units squared (always positive).
    pub area2: i64,
    /// NDC depth in [0, 1] per vertex.
    pub z: [f32; 3],
    pub inv_w: [f32; 3],
    /// Barycentric coordinates of each vertex in the original (unclipped) triangle.
    pub bary: [Vec3; 3],
    /// Inclusive pixel bounds, clamped to the viewport.
    pub bbox: [u32; 4],
    /// The nearest vertex depth: no covered sample's [`Self::depth`] is nearer (its edge
    /// values are at least 0 and sum to `area2`, so the depth is a convex combination, and
    /// f64 rounding stays far within half an f32 step).
    pub z_min: f32,
    /// 1 where edge `i` (opposite vertex `i`) is not top-left: inside means `E_i >= bias_i`.
    pub bias: [u8; 3],
    /// Winding as submitted (false for the back side of a double-sided triangle).
    pub front_facing: bool,
}

impl SetupTriangle {
    /// Edge functions at a fixed-point sample position; `E_i` is opposite vertex `i`.
    #[inline]
    pub fn edges(&self, x: i64, y: i64) -> [i64; 3] {
        self.edge_ends()
            .map(|(a, b)| (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]))
    }

    /// [`Self::edges`] at the four lanes of a quad: lane `l` one pixel right of (`x`, `y`)
    /// when `l & 1`, one pixel down when `l & 2`. The functions are linear with integer
    /// coefficients, so lane 0's values plus exact steps are each lane's own.
    #[inline]
    pub fn quad_edges(&self, x: i64, y: i64) -> [[i64; 3]; 4] {
        let ends = self.edge_ends();
        let right = ends.map(|(a, b)| (a[1] - b[1]) * SUBPIXEL);
        let down = ends.map(|(a, b)| (b[0] - a[0]) * SUBPIXEL);
        let step = |e: [i64; 3], d: [i64; 3]| [e[0] + d[0], e[1] + d[1], e[2] + d[2]];
        let e = self.edges(x, y);
        let e_right = step(e, right);
        [e, e_right, step(e, down), step(e_right, down)]
    }

    /// Edge `i`'s end points (from, to): the edge opposite vertex `i`.
    #[inline]
    pub fn edge_ends(&self) -> [([i64; 2], [i64; 2]); 3] {
        let v = self.v.map(|p| p.map(i64::from));
        [(v[1], v[2]), (v[2], v[0]), (v[0], v[1])]
    }

    #[inline]
    pub fn inside(&self, e: [i64; 3]) -> bool {
        e[0] >= i64::from(self.bias[0]) && e[1] >= i64::from(self.bias[1]) && e[2] >= i64::from(self.bias[2])
    }

    /// Depth at a sample from its edge values (screen-space linear).
    #[inline]
    pub fn depth(&self, e: [i64; 3]) -> f32 {
        self.depth_of(e.map(|e| e as f64))
    }

    /// [`Self::depth`] from the edge values as f64 (the same bits where they are `e as f64`).
    #[inline(always)]
    pub fn depth_of(&self, e: [f64; 3]) -> f32 {
        let a = self.area2 as f64;
        ((e[0] * self.z[0] as f64 + e[1] * self.z[1] as f64 + e[2] * self.z[2] as f64) / a) as f32
    }

    /// [`Self::depth`] at four samples at once: the same operations sample by sample (so the
    /// same bits), as arrays of four that compile to SIMD instructions.
    #[inline]
    pub fn depths(&self, e: [[i64; 3]; 4]) -> [f32; 4] {
        e.map(|e| self.depth(e))
    }

    /// Perspective-correct barycentrics in the original triangle at a sample (extrapolated
    /// outside the triangle, as helper lanes need).
    #[inline]
    pub fn original_bary(&self, e: [i64; 3]) -> Vec3 {
        let m = [0, 1, 2].map(|i| e[i] as f64 * self.inv_w[i] as f64);
        let mut sum = m[0] + m[1] + m[2];
        if sum.abs() < 1e-30 {
            sum = 1e-30f64.copysign(sum);
        }
        let w = m.map(|x| (x / sum) as f32);
        self.bary[0] * w[0] + self.bary[1] * w[1] + self.bary[2] * w[2]
    }

    /// [`Self::original_bary`] at four samples at once, component-major (`[x, y, z]`, each
    /// per sample): the same operations sample by sample, so the same bits, laid out as
    /// arrays of four so that they run as SIMD instructions (a quad's divisions are most of
    /// its interpolation). Always inlined: called out of line, its arrays go through memory.
    #[inline(always)]
    pub fn original_barys(&self, e: [[i64; 3]; 4]) -> [[f32; 4]; 3] {
        let m: [[f64; 4]; 3] = std::array::from_fn(|i| e.map(|e| e[i] as f64 * self.inv_w[i] as f64));
        let sum: [f64; 4] = std::array::from_fn(|l| {
            let sum = m[0][l] + m[1][l] + m[2][l];
            if sum.abs() < 1e-30 {
                1e-30f64.copysign(sum)
            } else {
                sum
            }
        });
        let w: [[f32; 4]; 3] = std::array::from_fn(|i| std::array::from_fn(|l| (m[i][l] / sum[l]) as f32));
        let [b0, b1, b2] = self.bary.map(|b| b.to_array());
        std::array::from_fn(|c| std::array::from_fn(|l| b0[c] * w[0][l] + b1[c] * w[1][l] + b2[c] * w[2][l]))
    }
}

#[derive(Clone, Copy, Debug)]
struct ClipVertex {
    c: Vec4,
    bary: Vec3,
}

/// Clip planes as signed distances (inside >= 0): near, far and the guard band.
fn plane_distances(c: Vec4, guard: [f32; 2]) -> [f32; 6] {
    [
        c.z,
        c.w - c.z,
        guard[0] * c.w - c.x,
        guard[0] * c.w + c.x,
        guard[1] * c.w - c.y,
        guard[1] * c.w + c.y,
    ]
}

/// Runs the vertex stage for one view; output is in submission order.
/// `double_sided[m]` says whether material `m` skips back-face culling.
pub fn setup_view(
    geometry: &FrameGeometry,
    double_sided: &[bool],
    view_projection: Mat4,
    width: u32,
    height: u32,
) -> (Vec<SetupTriangle>, VertexStats) {
    let (chunks, stats) = setup_view_chunks(geometry, double_sided, view_projection, width, height);
    // One copy of the chunks in turn, a stream the memory system runs at full speed: a
    // parallel gather, element by element with a search for its chunk, took 5 to 10% more
    // of the stage at 1 and at 2 threads.
    (chunks.concat(), stats)
}

/// [`setup_view`] as the lists of consecutive chunks of submission order, for a pass that
/// needs no one list (the shadow map's bands): the chunks are not copied into one.
pub fn setup_view_chunks(
    geometry: &FrameGeometry,
    double_sided: &[bool],
    view_projection: Mat4,
    width: u32,
    height: u32,
) -> (Vec<Vec<SetupTriangle>>, VertexStats) {
    // Indexed, so that each vertex is written in place (no per-chunk lists to join).
    let clip: Vec<Vec4> = geometry
        .positions
        .par_iter()
        .with_min_len(SETUP_CHUNK * 3)
        .map(|&p| view_projection * p.extend(1.0))
        .collect();
    let guard = guard_band(width, height);
    let results: Vec<(Vec<SetupTriangle>, VertexStats)> = geometry
        .triangles
        .par_chunks(SETUP_CHUNK)
        .enumerate()
        .map(|(chunk_index, tris)| {
            let mut out = Vec::with_capacity(tris.len());
            let mut stats = VertexStats::default();
            for (i, tri) in tris.iter().enumerate() {
                let prim = (chunk_index * SETUP_CHUNK + i) as u32;
                let double_sided = double_sided[tri.material as usize];
                let verts = tri.vertices.map(|v| clip[v as usize]);
                setup_triangle(prim, verts, double_sided, guard, width, height, &mut out, &mut stats);
            }
            (out, stats)
        })
        .collect();
    // (Collected and then split: rayon's parallel `unzip` took 6% more of the stage.)
    let mut stats = VertexStats::default();
    let mut chunks = Vec::with_capacity(results.len());
    for (tris, chunk_stats) in results {
        stats.add(&chunk_stats);
        chunks.push(tris);
    }
    (chunks, stats)
}

/// The guard band's half-extent in NDC units of a `width` x `height` view.
fn guard_band(width: u32, height: u32) -> [f32; 2] {
    [
        (GUARD_BAND_PX / (width as f64 * 0.5)) as f32,
        (GUARD_BAND_PX / (height as f64 * 0.5)) as f32,
    ]
}

/// One triangle given in clip space through the same clipping, culling and snapping as
/// [`setup_view`] (for triangles no trace holds, e.g. a reprojection's warping grid);
/// `prim` is the id its setup triangles carry. Appends 0 or more triangles to `out`.
pub fn setup_clip_triangle(
    prim: u32,
    verts: [Vec4; 3],
    double_sided: bool,
    (width, height): (u32, u32),
    out: &mut Vec<SetupTriangle>,
    stats: &mut VertexStats,
) {
    setup_triangle(
        prim,
        verts,
        double_sided,
        guard_band(width, height),
        width,
        height,
        out,
        stats,
    );
}

#[allow(clippy::too_many_arguments)]
fn setup_triangle(
    prim: u32,
    verts: [Vec4; 3],
    double_sided: bool,
    guard: [f32; 2],
    width: u32,
    height: u32,
    out: &mut Vec<SetupTriangle>,
    stats: &mut VertexStats,
) {
    stats.triangles_in += 1;
    if verts.iter().any(|v| !v.is_finite()) {
        stats.culled_degenerate += 1;
        return;
    }
    let d = verts.map(|v| plane_distances(v, guard));
    if (0..6).any(|p| d.iter().all(|dv| dv[p] < 0.0)) {
        stats.culled_frustum += 1;
        return;
    }
    let corners = [Vec3::X, Vec3::Y, Vec3::Z];
    let triangle: [ClipVertex; 3] = std::array::from_fn(|i| ClipVertex {
        c: verts[i],
        bary: corners[i],
    });
    let before = out.len();
    if !(0..6).any(|p| d.iter().any(|dv| dv[p] < 0.0)) {
        // Inside every plane: the triangle itself.
        out.extend(snap(prim, triangle, double_sided, width, height, stats));
    } else {
        stats.clipped += 1;
        let mut polygon = [triangle[0]; 12];
        polygon[..3].copy_from_slice(&triangle);
        let mut len = 3;
        for plane in 0..6 {
            len = clip_polygon(&mut polygon, len, plane, guard);
            if len < 3 {
                stats.culled_frustum += 1;
                return;
            }
        }
        for k in 1..len - 1 {
            let fan = [polygon[0], polygon[k], polygon[k + 1]];
            out.extend(snap(prim, fan, double_sided, width, height, stats));
        }
    }
    stats.setup_triangles += (out.len() - before) as u64;
}

/// Sutherland–Hodgman against one plane, in place; returns the new vertex count.
fn clip_polygon(poly: &mut [ClipVertex; 12], len: usize, plane: usize, guard: [f32; 2]) -> usize {
    let dist = |v: &ClipVertex| plane_distances(v.c, guard)[plane];
    let input = *poly;
    let mut n = 0;
    for i in 0..len {
        let (a, b) = (input[i], input[(i + 1) % len]);
        let (da, db) = (dist(&a), dist(&b));
        if da >= 0.0 {
            poly[n] = a;
            n += 1;
        }
        if (da >= 0.0) != (db >= 0.0) && n < poly.len() {
            poly[n] = intersect(a, da, b, db);
            n += 1;
        }
    }
    n
}

/// Edge–plane intersection computed from the canonically ordered endpoints, so that the
/// two triangles sharing the edge produce bit-identical vertices.
fn intersect(a: ClipVertex, da: f32, b: ClipVertex, db: f32) -> ClipVertex {
    let key = |v: &ClipVertex| v.c.to_array().map(f32::to_bits);
    let ((p, dp), (q, dq)) = if key(&a) <= key(&b) {
        ((a, da), (b, db))
    } else {
        ((b, db), (a, da))
    };
    let t = dp / (dp - dq);
    ClipVertex {
        c: p.c + (q.c - p.c) * t,
        bary: p.bary + (q.bary - p.bary) * t,
    }
}

fn snap(
    prim: u32,
    fan: [ClipVertex; 3],
    double_sided: bool,
    width: u32,
    height: u32,
    stats: &mut VertexStats,
) -> Option<SetupTriangle> {
    let mut v = [[0i64; 2]; 3];
    let mut z = [0f32; 3];
    let mut inv_w = [0f32; 3];
    for i in 0..3 {
        let c = fan[i].c;
        // The four divisions by w as two SIMD ones (each lane's own IEEE quotient).
        let [x, y, z_ndc, inv] =
            (f64x4::from([c.x as f64, c.y as f64, c.z as f64, 1.0]) / f64x4::splat(c.w as f64)).to_array();
        let sx = (x * 0.5 + 0.5) * width as f64;
        let sy = (0.5 - y * 0.5) * height as f64;
        v[i] = [round_to_i64(sx * SUBPIXEL as f64), round_to_i64(sy * SUBPIXEL as f64)];
        z[i] = z_ndc.clamp(0.0, 1.0) as f32;
        inv_w[i] = inv as f32;
    }
    // Clipped to the guard band, a vertex is far within 32 bits; one past them could only
    // come of a w rounded to zero, and is no triangle to draw.
    if v.iter().flatten().any(|&c| i32::try_from(c).is_err()) {
        stats.culled_degenerate += 1;
        return None;
    }
    let area2 = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]);
    if area2 == 0 {
        stats.culled_degenerate += 1;
        return None;
    }
    // Counter-clockwise in NDC (y up) is clockwise in pixel coordinates (y down): front
    // faces have a negative signed area here.
    let front_facing = area2 < 0;
    if !front_facing && !double_sided {
        stats.culled_backface += 1;
        return None;
    }
    let mut bary = [fan[0].bary, fan[1].bary, fan[2].bary];
    // Rasterization wants positive area (see `SetupTriangle::edges` and the top-left rule).
    if area2 < 0 {
        v.swap(1, 2);
        z.swap(1, 2);
        inv_w.swap(1, 2);
        bary.swap(1, 2);
    }
    let area2 = area2.abs();
    let top_left = |a: [i64; 2], b: [i64; 2]| {
        let d = [b[0] - a[0], b[1] - a[1]];
        (d[1] == 0 && d[0] > 0) || d[1] < 0
    };
    let bias = [
        u8::from(!top_left(v[1], v[2])),
        u8::from(!top_left(v[2], v[0])),
        u8::from(!top_left(v[0], v[1])),
    ];
    let min_x = v.iter().map(|p| p[0]).min().unwrap_or(0);
    let max_x = v.iter().map(|p| p[0]).max().unwrap_or(0);
    let min_y = v.iter().map(|p| p[1]).min().unwrap_or(0);
    let max_y = v.iter().map(|p| p[1]).max().unwrap_or(0);
    let to_px = |f: i64, limit: u32| (f.div_euclid(SUBPIXEL)).clamp(0, limit as i64 - 1) as u32;
    if max_x < 0 || max_y < 0 || min_x >= width as i64 * SUBPIXEL || min_y >= height as i64 * SUBPIXEL {
        stats.culled_frustum += 1;
        return None;
    }
    Some(SetupTriangle {
        prim,
        // In range (above).
        v: v.map(|p| p.map(|c| c as i32)),
        area2,
        z,
        inv_w,
        bary,
        bbox: [
            to_px(min_x, width),
            to_px(min_y, height),
            to_px(max_x, width),
            to_px(max_y, height),
        ],
        z_min: z[0].min(z[1]).min(z[2]),
        bias,
        front_facing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn triangle(inv_w: [f32; 3], bary: [[f32; 3]; 3]) -> SetupTriangle {
        SetupTriangle {
            prim: 0,
            v: [[0, 0], [SUBPIXEL as i32, 0], [0, SUBPIXEL as i32]],
            area2: SUBPIXEL * SUBPIXEL,
            z: [0.5; 3],
            inv_w,
            bary: bary.map(Vec3::from_array),
            bbox: [0, 0, 1, 1],
            z_min: 0.5,
            bias: [0; 3],
            front_facing: true,
        }
    }

    proptest! {
        /// A quad's stepped edge functions are each lane's own, anywhere in the guard band.
        #[test]
        fn quad_edges_are_the_lanes_own(
            v in prop::array::uniform3(prop::array::uniform2(-(1i32 << 27)..1i32 << 27)),
            x in -(1i64 << 27)..1i64 << 27,
            y in -(1i64 << 27)..1i64 << 27,
        ) {
            let t = SetupTriangle { v, ..triangle([1.0; 3], [[0.0; 3]; 3]) };
            let quad = t.quad_edges(x, y);
            for (l, e) in quad.iter().enumerate() {
                let (dx, dy) = ((l & 1) as i64 * SUBPIXEL, (l >> 1) as i64 * SUBPIXEL);
                prop_assert_eq!(*e, t.edges(x + dx, y + dy));
            }
        }

        /// A covered sample's depth (edge values at least 0, summing to twice the area) is
        /// never nearer than the nearest vertex, up to edge values of 2^56 (the guard band's
        /// products), with vertex depths at 0, 1, subnormal and a few steps apart.
        #[test]
        fn covered_depths_are_never_nearer_than_the_nearest_vertex(
            e in prop::array::uniform3(prop_oneof![0i64..1i64 << 56, 0i64..4]),
            base in prop_oneof![0.0f32..=1.0, Just(0.0f32), Just(1.0f32), Just(f32::from_bits(1))],
            steps in prop::array::uniform3(0u32..3),
            spread in any::<bool>(),
            far in prop::array::uniform3(0.0f32..=1.0),
        ) {
            // Vertex depths a few f32 steps apart (where rounding could cross the nearest),
            // or anywhere in [0, 1].
            let z = match spread {
                true => far,
                false => steps.map(|k| f32::from_bits(base.to_bits() + k).min(1.0)),
            };
            prop_assume!(e.iter().sum::<i64>() > 0);
            let t = SetupTriangle {
                area2: e.iter().sum(),
                z,
                z_min: z[0].min(z[1]).min(z[2]),
                ..triangle([1.0; 3], [[0.0; 3]; 3])
            };
            prop_assert!(t.depth(e) >= t.z_min, "{} < {}", t.depth(e), t.z_min);
        }

        /// Four samples at once give each sample's own barycentrics and depth, bit for bit,
        /// also where the weights nearly cancel (the sum's clamp) and far outside the triangle.
        #[test]
        fn quad_barycentrics_and_depths_are_the_samples_own(
            inv_w in prop::array::uniform3(prop_oneof![1e-6f32..1e3, Just(1.0f32)]),
            bary in prop::array::uniform3(prop::array::uniform3(-2.0f32..2.0)),
            e in prop::array::uniform4(prop::array::uniform3(prop_oneof![-1i64 << 40..1i64 << 40, -2i64..2])),
        ) {
            let mut t = triangle(inv_w, bary);
            t.z = inv_w.map(|w| w.fract());
            let (quad, depths) = (t.original_barys(e), t.depths(e));
            for (l, &e) in e.iter().enumerate() {
                let lane = t.original_bary(e);
                let got = Vec3::new(quad[0][l], quad[1][l], quad[2][l]);
                prop_assert_eq!(got.to_array().map(f32::to_bits), lane.to_array().map(f32::to_bits));
                prop_assert_eq!(depths[l].to_bits(), t.depth(e).to_bits());
            }
        }
    }
}
