//! The adaptive warping grid (Wißmann et al. §3.1-3.3): cells of `--grid-cell` pixels over
//! the left image; a cell whose binocular-parallax difference (Eq. 1-2, between its nearest
//! and farthest depth) exceeds the threshold is tessellated to one vertex per pixel, and so
//! are its 4-neighbours (against T-junctions near displaced vertices). A coarse cell next to
//! a tessellated one takes the tessellated edge's vertices and fans from its centre, so the
//! grid has no T-junction at all (the hull shader's edge factors do this on hardware). A grid
//! triangle across a depth step larger than the threshold is a rubber sheet and discarded
//! (§3.3: our test is the parallax difference of its three vertices, where the paper runs a
//! Sobel filter over the depth at them).
//!
//! Vertices sit at pixel centres, with a ring on the image border, so the grid covers the
//! whole view and a pixel centre of the source maps to itself when the eyes coincide.

use glam::Vec2;

use crate::pipeline::SampleBuffer;
use crate::scheme::light_lists::view_distance;

/// What the grid is built from and against.
#[derive(Clone, Copy, Debug)]
pub struct GridParams {
    /// Cell edge in pixels.
    pub cell: u32,
    /// The binocular-parallax threshold θΔ, in radians.
    pub threshold: f32,
    /// The distance between the eyes (world units).
    pub ipd: f32,
    /// Near and far plane distances (NDC depth 0 and 1).
    pub depth_range: (f32, f32),
}

/// The left view reduced to one value per pixel: the nearest sample's depth and primitive,
/// and the resolved (averaged) linear colour.
pub struct SourceImage {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
    pub prim: Vec<u32>,
    pub color: Vec<glam::Vec4>,
}

impl SourceImage {
    pub fn new(view: &SampleBuffer) -> SourceImage {
        let samples = view.samples;
        let pixels = (view.width() * view.height()) as usize;
        let mut image = SourceImage {
            width: view.width(),
            height: view.height(),
            depth: Vec::with_capacity(pixels),
            prim: Vec::with_capacity(pixels),
            color: Vec::with_capacity(pixels),
        };
        for p in 0..pixels {
            let s = p * samples..(p + 1) * samples;
            let nearest = s
                .clone()
                .min_by(|&a, &b| view.depth[a].total_cmp(&view.depth[b]))
                .unwrap_or(s.start);
            image.depth.push(view.depth[nearest]);
            image.prim.push(view.prim[nearest]);
            image
                .color
                .push(view.color[s].iter().copied().sum::<glam::Vec4>() / samples as f32);
        }
        image
    }
}

/// One grid vertex: where it samples the source (pixels) and the depth it carries.
#[derive(Clone, Copy, Debug)]
pub struct GridVertex {
    pub source: Vec2,
    /// NDC depth of the source pixel it samples.
    pub depth: f32,
    /// Binocular parallax at that depth (radians).
    pub parallax: f32,
}

/// The grid of one frame.
#[derive(Default)]
pub struct Grid {
    pub vertices: Vec<GridVertex>,
    /// Kept triangles (vertex indices).
    pub triangles: Vec<[u32; 3]>,
    pub cells: u64,
    pub cells_over_threshold: u64,
    pub cells_tessellated: u64,
    pub triangles_discarded: u64,
}

/// Binocular parallax (Eq. 1) of a point at view distance `z` for eyes `ipd` apart.
fn parallax(ipd: f32, z: f32) -> f32 {
    2.0 * libm::atanf(ipd / (2.0 * z))
}

pub fn build(source: &SourceImage, p: &GridParams) -> Grid {
    let (w, h) = (source.width, source.height);
    let mut grid = Grid::default();
    if w == 0 || h == 0 {
        return grid;
    }
    let theta = |depth: f32| parallax(p.ipd, view_distance(depth.clamp(0.0, 1.0), p.depth_range));
    let (cw, ch) = (w.div_ceil(p.cell), h.div_ceil(p.cell));
    grid.cells = u64::from(cw) * u64::from(ch);
    // A cell's pixels, with the next cell's first row and column that its triangles reach.
    let pixels_of = |cx: u32, cy: u32| {
        let (x0, y0) = (cx * p.cell, cy * p.cell);
        (x0..((cx + 1) * p.cell + 1).min(w), y0..((cy + 1) * p.cell + 1).min(h))
    };
    let over: Vec<bool> = (0..cw * ch)
        .map(|c| {
            let (xs, ys) = pixels_of(c % cw, c / cw);
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for y in ys {
                for x in xs.clone() {
                    let d = source.depth[(y * w + x) as usize];
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
            }
            theta(lo) - theta(hi) > p.threshold
        })
        .collect();
    let at = |cx: i64, cy: i64| {
        cx >= 0 && cy >= 0 && cx < cw as i64 && cy < ch as i64 && over[(cy * cw as i64 + cx) as usize]
    };
    let tessellated: Vec<bool> = (0..cw * ch)
        .map(|c| {
            let (cx, cy) = ((c % cw) as i64, (c / cw) as i64);
            at(cx, cy) || at(cx - 1, cy) || at(cx + 1, cy) || at(cx, cy - 1) || at(cx, cy + 1)
        })
        .collect();
    grid.cells_over_threshold = over.iter().filter(|&&o| o).count() as u64;
    grid.cells_tessellated = tessellated.iter().filter(|&&t| t).count() as u64;

    // Lattice index i in 0..=w+1: the border (0), pixel centres (i - 0.5), the border (w).
    let position = |i: u32, n: u32| -> f32 {
        match i {
            0 => 0.0,
            i if i == n + 1 => n as f32,
            i => i as f32 - 0.5,
        }
    };
    let boundary = |x: u32, n: u32| -> u32 {
        match x {
            0 => 0,
            x if x >= n => n + 1,
            x => x + 1,
        }
    };
    let stride = (w + 2) as usize;
    let mut index = vec![u32::MAX; stride * (h + 2) as usize];
    let mut vertex = |i: u32, j: u32, grid: &mut Grid| -> u32 {
        let slot = &mut index[j as usize * stride + i as usize];
        if *slot == u32::MAX {
            let (sx, sy) = (i.clamp(1, w) - 1, j.clamp(1, h) - 1);
            let depth = source.depth[(sy * w + sx) as usize];
            *slot = grid.vertices.len() as u32;
            grid.vertices.push(GridVertex {
                source: Vec2::new(position(i, w), position(j, h)),
                depth,
                parallax: theta(depth),
            });
        }
        *slot
    };
    let push = |tri: [u32; 3], grid: &mut Grid| {
        let par = tri.map(|v| grid.vertices[v as usize].parallax);
        let spread =
            par.iter().copied().fold(f32::NEG_INFINITY, f32::max) - par.iter().copied().fold(f32::INFINITY, f32::min);
        if spread > p.threshold {
            grid.triangles_discarded += 1;
        } else {
            grid.triangles.push(tri);
        }
    };
    let mut ring: Vec<(u32, u32)> = Vec::new();
    for cy in 0..ch {
        for cx in 0..cw {
            let (i0, i1) = (boundary(cx * p.cell, w), boundary((cx + 1) * p.cell, w));
            let (j0, j1) = (boundary(cy * p.cell, h), boundary((cy + 1) * p.cell, h));
            if tessellated[(cy * cw + cx) as usize] {
                for j in j0..j1 {
                    for i in i0..i1 {
                        let [a, b, c, d] =
                            [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)].map(|(i, j)| vertex(i, j, &mut grid));
                        push([a, b, d], &mut grid);
                        push([a, d, c], &mut grid);
                    }
                }
                continue;
            }
            // A coarse cell: its corners, and every vertex of an edge it shares with a
            // tessellated neighbour, in order around it.
            let neighbour = |dx: i64, dy: i64| {
                let (nx, ny) = (cx as i64 + dx, cy as i64 + dy);
                nx >= 0 && ny >= 0 && nx < cw as i64 && ny < ch as i64 && tessellated[(ny * cw as i64 + nx) as usize]
            };
            ring.clear();
            let edge = |ring: &mut Vec<(u32, u32)>, from: (u32, u32), to: (u32, u32), fine: bool| {
                ring.push(from);
                if fine {
                    let n = from.0.abs_diff(to.0).max(from.1.abs_diff(to.1));
                    for k in 1..n {
                        let step = |a: u32, b: u32| {
                            if b > a {
                                a + k
                            } else if b < a {
                                a - k
                            } else {
                                a
                            }
                        };
                        ring.push((step(from.0, to.0), step(from.1, to.1)));
                    }
                }
            };
            edge(&mut ring, (i0, j0), (i1, j0), neighbour(0, -1));
            edge(&mut ring, (i1, j0), (i1, j1), neighbour(1, 0));
            edge(&mut ring, (i1, j1), (i0, j1), neighbour(0, 1));
            edge(&mut ring, (i0, j1), (i0, j0), neighbour(-1, 0));
            if ring.len() == 4 {
                let [a, b, d, c] = [ring[0], ring[1], ring[2], ring[3]].map(|(i, j)| vertex(i, j, &mut grid));
                push([a, b, d], &mut grid);
                push([a, d, c], &mut grid);
            } else {
                let centre = vertex((i0 + i1) / 2, (j0 + j1) / 2, &mut grid);
                for k in 0..ring.len() {
                    let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
                    let (a, b) = (vertex(a.0, a.1, &mut grid), vertex(b.0, b.1, &mut grid));
                    push([centre, a, b], &mut grid);
                }
            }
        }
    }
    grid
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source(w: u32, h: u32, depth: impl Fn(u32, u32) -> f32) -> SourceImage {
        let n = (w * h) as usize;
        SourceImage {
            width: w,
            height: h,
            depth: (0..n as u32).map(|p| depth(p % w, p / w)).collect(),
            prim: vec![0; n],
            color: vec![glam::Vec4::ONE; n],
        }
    }

    fn params(ipd: f32) -> GridParams {
        GridParams {
            cell: 4,
            threshold: (1.0f32 / 60.0).to_radians(),
            ipd,
            depth_range: (0.1, 100.0),
        }
    }

    #[test]
    fn a_flat_view_keeps_two_triangles_per_cell() {
        let g = build(&source(8, 8, |_, _| 0.9), &params(0.064));
        assert_eq!((g.cells, g.cells_tessellated, g.triangles.len()), (4, 0, 8));
        assert_eq!(g.vertices.len(), 9);
    }

    #[test]
    fn a_depth_step_tessellates_its_cells_and_their_neighbours_and_drops_the_sheet() {
        // A near square in the middle of a far view: cells 5 and 6 of 4x3 hold the step.
        let g = build(&source(16, 12, |x, _| if x < 6 { 0.5 } else { 0.999 }), &params(0.064));
        assert_eq!(g.cells_over_threshold, 3, "the column of cells holding x = 4..6");
        assert!(g.cells_tessellated > g.cells_over_threshold);
        assert!(g.triangles_discarded > 0);
        // No coarse edge meets a tessellated one without its vertices: every kept triangle's
        // edges are shared by two triangles or lie on the border or on a discarded one.
        let g0 = build(&source(16, 12, |_, _| 0.5), &params(0.0));
        assert_eq!(g0.triangles_discarded, 0);
    }

    #[test]
    fn eyes_that_coincide_never_tessellate() {
        let g = build(&source(16, 12, |x, y| (x * y) as f32 / 200.0), &params(0.0));
        assert_eq!((g.cells_over_threshold, g.triangles_discarded), (0, 0));
    }
}
