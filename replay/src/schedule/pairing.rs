//! Which tiles of the two views share a portion of a triangle: Algorithm 1 of Yuan, Wang and
//! Bao. On one epipolar tile row, the tile boundaries of both views are mapped to the
//! triangle's perspective-correct barycentric (PB) space along the row's centre line and
//! ordered by the efficiency measure `E = d · T`, `d` the PB direction of the first left
//! tile; left and right tiles whose E intervals overlap form tile pairs.
//!
//! Robustness: PBs are extrapolated projectively, so a triangle that misses the centre line
//! still gets measures; when `d` is ~0 (the triangle is edge-on along the row) or the measures
//! are not monotonic (a row crossing the horizon of a near-clipped triangle), every left tile
//! is paired with every right tile whose interval overlaps, falling back to all pairs when the
//! measures are unusable. Pairing only decides order and reuse: every (tile, triangle) is
//! still rasterized exactly once by the scheduler's leftover pass.

use glam::Vec3;

use super::ScheduleInput;
use crate::vertex_stage::{SetupTriangle, SUBPIXEL};

/// Covered tile columns `[first, last]` of one triangle on one row, in one view.
pub type TileSpan = (u32, u32);

/// One primitive's tiles on one tile row of one view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowSpan {
    pub prim: u32,
    pub columns: TileSpan,
    /// Its first setup triangle in its first column (a clipped primitive may have several).
    pub setup: u32,
    /// Its first and last setup triangles on the row: a primitive's setups are consecutive
    /// (the vertex stage lists them in primitive order) and a tile list holds setups in
    /// that order, so the primitive's entries in any of the row's lists are those between
    /// the two, found without reading a setup.
    pub setups: (u32, u32),
}

/// On tile row `row` of view `v`: per primitive (ascending), its [`RowSpan`].
///
/// The row's entries are sorted as (setup, column) keys: setups list in primitive order, so
/// this groups each primitive's entries, and each setup is read once, in order, for its
/// primitive.
pub fn row_spans(input: &ScheduleInput, row: u32, v: usize) -> Vec<RowSpan> {
    let tiles_x = input.bins.grid.tiles_x;
    let lists = &input.bins.lists[v][(row * tiles_x) as usize..((row + 1) * tiles_x) as usize];
    let mut keys: Vec<u64> = (0..tiles_x)
        .zip(lists)
        .flat_map(|(x, list)| list.iter().map(move |&s| u64::from(s) << 32 | u64::from(x)))
        .collect();
    keys.sort_unstable();
    let mut spans: Vec<RowSpan> = Vec::new();
    let mut last_setup = None;
    let mut prim = 0;
    for key in keys {
        let (s, x) = ((key >> 32) as u32, key as u32);
        if last_setup != Some(s) {
            last_setup = Some(s);
            prim = input.setups[v][s as usize].prim;
        }
        match spans.last_mut() {
            Some(span) if span.prim == prim => {
                // Setups come in ascending order: the first seen in a column is its first.
                if x < span.columns.0 {
                    (span.columns.0, span.setup) = (x, s);
                }
                span.columns.1 = span.columns.1.max(x);
                span.setups.1 = s;
            }
            _ => {
                debug_assert!(
                    spans.last().is_none_or(|last| last.prim < prim),
                    "setups out of primitive order"
                );
                spans.push(RowSpan {
                    prim,
                    columns: (x, x),
                    setup: s,
                    setups: (s, s),
                })
            }
        }
    }
    spans
}

/// The index of primitive `prim`'s entry in [`row_spans`]' list.
pub fn span_of(spans: &[RowSpan], prim: u32) -> Option<usize> {
    spans.binary_search_by_key(&prim, |span| span.prim).ok()
}

/// PB of the point at pixel x-boundary `x` (pixels) on the row's centre line `y_fixed`.
fn pb_at(setup: &SetupTriangle, x: u32, y_fixed: i64) -> Vec3 {
    setup.original_bary(setup.edges(x as i64 * SUBPIXEL, y_fixed))
}

/// Efficiency measures of the tile boundaries `first*tile ..= (last+1)*tile` of a span.
fn measures(setup: &SetupTriangle, span: TileSpan, tile: u32, width: u32, y_fixed: i64, d: Vec3) -> Vec<f32> {
    (span.0..=span.1 + 1)
        .map(|t| d.dot(pb_at(setup, (t * tile).min(width), y_fixed)))
        .collect()
}

/// The tile pairs `(left column, right column)` of one triangle on one row.
#[allow(clippy::too_many_arguments)]
pub fn pair_tiles(
    left: &SetupTriangle,
    right: &SetupTriangle,
    l: TileSpan,
    r: TileSpan,
    row_center_y: u32,
    tile: u32,
    width: u32,
    out: &mut Vec<(u32, u32)>,
) {
    if l.0 == l.1 && r.0 == r.1 {
        out.push((l.0, r.0));
        return;
    }
    let y = row_center_y as i64 * SUBPIXEL;
    let t0 = pb_at(left, (l.0 * tile).min(width), y);
    let t1 = pb_at(left, ((l.0 + 1) * tile).min(width), y);
    let d = t1 - t0;
    let all_pairs = |out: &mut Vec<(u32, u32)>| {
        for a in l.0..=l.1 {
            for b in r.0..=r.1 {
                out.push((a, b));
            }
        }
    };
    // PB changes by at least ~1e-6 per tile on any triangle worth pairing; below that the
    // measure is float noise (an edge-on triangle).
    if !(d.is_finite() && d.length_squared() > 1e-12) {
        all_pairs(out);
        return;
    }
    let el = measures(left, l, tile, width, y, d);
    let er = measures(right, r, tile, width, y, d);
    let usable = |e: &[f32]| e.iter().all(|v| v.is_finite()) && e.windows(2).all(|w| w[0] <= w[1]);
    if !usable(&el) || !usable(&er) {
        if el.iter().chain(&er).all(|v| v.is_finite()) {
            // Not monotonic: test every pair of intervals.
            for (i, a) in el.windows(2).enumerate() {
                for (j, b) in er.windows(2).enumerate() {
                    let (a0, a1) = (a[0].min(a[1]), a[0].max(a[1]));
                    let (b0, b1) = (b[0].min(b[1]), b[0].max(b[1]));
                    if a0 < b1 && b0 < a1 {
                        out.push((l.0 + i as u32, r.0 + j as u32));
                    }
                }
            }
        } else {
            all_pairs(out);
        }
        return;
    }
    // Two-pointer merge over the sorted intervals (Algorithm 1, lines 17-24).
    let (mut i, mut j) = (0usize, 0usize);
    let (nl, nr) = (el.len() - 1, er.len() - 1);
    while i < nl && j < nr {
        if el[i] < er[j + 1] && er[j] < el[i + 1] {
            out.push((l.0 + i as u32, r.0 + j as u32));
        }
        if el[i + 1] < er[j + 1] {
            i += 1;
        } else if el[i + 1] > er[j + 1] {
            j += 1;
        } else {
            i += 1;
            j += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3, Vec4};
    use proptest::prelude::*;
    use shadetrace_formats::results::VertexStats;
    use shadetrace_formats::{Eye, Pose, StereoRig};

    use super::*;
    use crate::bins::{Bins, TileGrid};
    use crate::geometry::{FrameGeometry, Triangle};
    use crate::vertex_stage::{setup_clip_triangle, setup_view};

    fn rig(ipd: f32) -> StereoRig {
        StereoRig {
            head: Pose::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y),
            ipd_m: ipd,
            eye_width: 256,
            eye_height: 128,
            yfov: 1.2,
            near: 0.05,
            far: 100.0,
            convergence_m: 2.0,
        }
    }

    /// Setup triangles of one triangle in both views.
    fn setups(ipd: f32, v: [Vec3; 3]) -> [SetupTriangle; 2] {
        let g = FrameGeometry {
            positions: v.to_vec(),
            normals: vec![Vec3::Z; 3],
            uvs: vec![Vec2::ZERO; 3],
            tangents: Vec::new(),
            triangles: vec![Triangle {
                vertices: [0, 1, 2],
                material: 0,
                patch: u32::MAX,
                mesh: 0,
            }],
        };
        let r = rig(ipd);
        Eye::BOTH.map(|eye| setup_view(&g, &[true], r.view_projection(eye), 256, 128).0.remove(0))
    }

    fn span(t: &SetupTriangle, tile: u32) -> TileSpan {
        (t.bbox[0] / tile, t.bbox[2] / tile)
    }

    /// [`row_spans`]' definition: every entry of the row as (primitive, column, setup) in
    /// column order, grouped by primitive (a stable sort), each group's first and last
    /// column, its first entry's setup and its setups' range.
    fn row_spans_by_definition(input: &ScheduleInput, row: u32, v: usize) -> Vec<RowSpan> {
        let tiles_x = input.bins.grid.tiles_x;
        let mut seen: Vec<(u32, u32, u32)> = (0..tiles_x)
            .flat_map(|x| {
                input.bins.lists[v][(row * tiles_x + x) as usize]
                    .iter()
                    .map(move |&s| (input.setups[v][s as usize].prim, x, s))
            })
            .collect();
        seen.sort_by_key(|&(prim, _, _)| prim);
        seen.chunk_by(|a, b| a.0 == b.0)
            .map(|run| RowSpan {
                prim: run[0].0,
                columns: (run[0].1, run[run.len() - 1].1),
                setup: run[0].2,
                setups: (
                    run.iter().map(|e| e.2).min().unwrap(),
                    run.iter().map(|e| e.2).max().unwrap(),
                ),
            })
            .collect()
    }

    proptest! {
        /// Row spans from (setup, column) keys equal their definition, and a span's setup
        /// range picks out of every list of the row exactly the primitive's entries, on
        /// primitives of one to three triangles (as clipping splits one into several
        /// setups), each of which may set up as none.
        #[test]
        fn row_spans_group_each_primitives_entries(
            prims in prop::collection::vec(
                prop::collection::vec(prop::array::uniform3((-1.3f32..1.3, -1.3f32..1.3)), 1..4),
                1..30,
            )
        ) {
            let (width, height) = (70, 53);
            let grid = TileGrid::new(width, height, 16);
            let mut views = [Vec::new(), Vec::new()];
            let mut stats = VertexStats::default();
            for (prim, triangles) in prims.iter().enumerate() {
                for (v, view) in views.iter_mut().enumerate() {
                    for c in triangles {
                        let verts = c.map(|(x, y)| Vec4::new(x + 0.1 * v as f32, y, 0.5, 1.0));
                        setup_clip_triangle(prim as u32, verts, true, (width, height), view, &mut stats);
                    }
                }
            }
            let bins = Bins::build(grid, [&views[0], &views[1]]);
            let input = ScheduleInput { bins: &bins, setups: [&views[0], &views[1]] };
            for row in 0..grid.tiles_y {
                for (v, setups) in views.iter().enumerate() {
                    let spans = row_spans(&input, row, v);
                    prop_assert_eq!(&spans, &row_spans_by_definition(&input, row, v));
                    for span in &spans {
                        for x in 0..grid.tiles_x {
                            let list = &bins.lists[v][(row * grid.tiles_x + x) as usize];
                            let (first, last) = span.setups;
                            let in_range: Vec<u32> =
                                list.iter().copied().filter(|s| (first..=last).contains(s)).collect();
                            let of_prim: Vec<u32> =
                                list.iter().copied().filter(|&s| setups[s as usize].prim == span.prim).collect();
                            prop_assert_eq!(in_range, of_prim);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn zero_ipd_pairs_are_diagonal() {
        let [l, r] = setups(
            0.0,
            [
                Vec3::new(-1.5, -0.2, 0.0),
                Vec3::new(1.5, -0.2, 0.0),
                Vec3::new(0.0, 0.4, 0.0),
            ],
        );
        let mut out = Vec::new();
        pair_tiles(&l, &r, span(&l, 16), span(&r, 16), 64, 16, 256, &mut out);
        assert!(out.len() > 4);
        assert!(out.iter().all(|&(a, b)| a == b), "{out:?}");
    }

    #[test]
    fn pairs_stay_within_spans_and_follow_disparity() {
        // 1.5 m from the eyes, nearer than the 2 m convergence plane.
        let [l, r] = setups(
            0.3,
            [
                Vec3::new(-0.8, -0.2, 1.5),
                Vec3::new(0.8, -0.2, 1.5),
                Vec3::new(0.0, 0.3, 1.5),
            ],
        );
        let (sl, sr) = (span(&l, 16), span(&r, 16));
        let mut out = Vec::new();
        pair_tiles(&l, &r, sl, sr, 64, 16, 256, &mut out);
        assert!(!out.is_empty());
        for &(a, b) in &out {
            assert!((sl.0..=sl.1).contains(&a) && (sr.0..=sr.1).contains(&b));
            // In front of the convergence plane the left-eye image lies to the right.
            assert!(a >= b, "{out:?}");
        }
        // Monotonic: the order constraint keeps pairs sorted on both sides.
        assert!(out.windows(2).all(|w| w[1].0 >= w[0].0 && w[1].1 >= w[0].1), "{out:?}");
    }

    #[test]
    fn a_triangle_missing_the_centre_line_still_pairs() {
        // A thin sliver in the top rows of the tile row (the centre line is y = 64 + 8).
        let [l, r] = setups(
            0.07,
            [
                Vec3::new(-1.5, 0.16, 0.0),
                Vec3::new(1.5, 0.16, 0.0),
                Vec3::new(0.0, 0.18, 0.0),
            ],
        );
        let mut out = Vec::new();
        pair_tiles(&l, &r, span(&l, 16), span(&r, 16), 72, 16, 256, &mut out);
        assert!(!out.is_empty());
        assert!(out.iter().all(|&(a, b)| a.abs_diff(b) <= 1), "{out:?}");
    }

    #[test]
    fn zero_direction_falls_back_to_all_pairs() {
        let [mut l, mut r] = setups(
            0.07,
            [
                Vec3::new(-1.0, -0.2, 0.0),
                Vec3::new(1.0, -0.2, 0.0),
                Vec3::new(0.0, 0.4, 0.0),
            ],
        );
        // PB constant along the row: every vertex maps to the same barycentric point.
        for t in [&mut l, &mut r] {
            t.bary = [Vec3::splat(1.0 / 3.0); 3];
        }
        let mut out = Vec::new();
        pair_tiles(&l, &r, (2, 4), (1, 3), 64, 16, 256, &mut out);
        assert_eq!(out.len(), 9);
    }
}
