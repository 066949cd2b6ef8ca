//! Binning: for each view and tile, the setup triangles that really overlap it (exact
//! triangle–tile test, not bounding boxes), in submission order.

use rayon::prelude::*;

use crate::raster::{overlaps, Rect};
use crate::vertex_stage::SetupTriangle;

/// The tile grid of one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileGrid {
    pub tile: u32,
    pub width: u32,
    pub height: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
}

impl TileGrid {
    pub fn new(width: u32, height: u32, tile: u32) -> TileGrid {
        TileGrid {
            tile,
            width,
            height,
            tiles_x: width.div_ceil(tile),
            tiles_y: height.div_ceil(tile),
        }
    }

    pub fn count(&self) -> usize {
        (self.tiles_x * self.tiles_y) as usize
    }

    pub fn rect(&self, tile: u32) -> Rect {
        self.rect_at(tile % self.tiles_x, tile / self.tiles_x)
    }

    /// The rectangle of the tile in column `tx` of row `ty`.
    pub fn rect_at(&self, tx: u32, ty: u32) -> Rect {
        Rect {
            x0: tx * self.tile,
            y0: ty * self.tile,
            x1: ((tx + 1) * self.tile).min(self.width),
            y1: ((ty + 1) * self.tile).min(self.height),
        }
    }
}

/// Per view, per tile (row-major): indices of overlapping setup triangles.
pub struct Bins {
    pub tile: u32,
    pub grid: TileGrid,
    pub lists: [Vec<Vec<u32>>; 2],
}

impl Bins {
    pub fn build(grid: TileGrid, views: [&[SetupTriangle]; 2]) -> Bins {
        // The views side by side: each one starts with a serial pass over its triangles.
        let (left, right) = rayon::join(|| bin_view(grid, views[0]), || bin_view(grid, views[1]));
        let lists = [left, right];
        Bins {
            tile: grid.tile,
            grid,
            lists,
        }
    }
}

/// Bins one view, a tile row per parallel work item. Triangles are first listed by the
/// rows their bounding boxes span (in submission order), so a row visits only those.
fn bin_view(grid: TileGrid, tris: &[SetupTriangle]) -> Vec<Vec<u32>> {
    let mut by_row = vec![Vec::new(); grid.tiles_y as usize];
    for (i, t) in tris.iter().enumerate() {
        let first = (t.bbox[1] / grid.tile) as usize;
        let last = ((t.bbox[3] / grid.tile) as usize).min(by_row.len().saturating_sub(1));
        for row in by_row.get_mut(first..=last).unwrap_or_default() {
            row.push(i as u32);
        }
    }
    let rows: Vec<Vec<Vec<u32>>> = by_row
        .into_par_iter()
        .enumerate()
        .map(|(ty, candidates)| {
            let ty = ty as u32;
            let mut row = vec![Vec::new(); grid.tiles_x as usize];
            let (y0, y1) = (ty * grid.tile, ((ty + 1) * grid.tile).min(grid.height));
            for i in candidates {
                let t = &tris[i as usize];
                if t.bbox[1] >= y1 || t.bbox[3] < y0 {
                    continue;
                }
                let tx0 = t.bbox[0] / grid.tile;
                let tx1 = t.bbox[2] / grid.tile;
                for tx in tx0..=tx1.min(grid.tiles_x - 1) {
                    if overlaps(t, grid.rect_at(tx, ty)) {
                        row[tx as usize].push(i);
                    }
                }
            }
            row
        })
        .collect();
    rows.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vertex_stage::setup_clip_triangle;
    use glam::Vec4;
    use proptest::prelude::*;
    use shadetrace_formats::results::VertexStats;

    proptest! {
        /// Listing triangles by row first changes nothing: each tile gets exactly the
        /// triangles that overlap it, in submission order (the definition: every triangle
        /// tested against every tile), on a view whose height is not a multiple of the tile.
        #[test]
        fn bins_hold_every_overlapping_triangle_in_order(
            corners in prop::collection::vec(prop::array::uniform3((-1.3f32..1.3, -1.3f32..1.3)), 1..40)
        ) {
            let (width, height) = (70, 53);
            let grid = TileGrid::new(width, height, 16);
            let (mut tris, mut stats) = (Vec::new(), VertexStats::default());
            for (i, c) in corners.iter().enumerate() {
                let verts = c.map(|(x, y)| Vec4::new(x, y, 0.5, 1.0));
                setup_clip_triangle(i as u32, verts, true, (width, height), &mut tris, &mut stats);
            }
            let bins = bin_view(grid, &tris);
            for tile in 0..grid.count() as u32 {
                let expected: Vec<u32> = (0..tris.len() as u32)
                    .filter(|&i| overlaps(&tris[i as usize], grid.rect(tile)))
                    .collect();
                prop_assert_eq!(&bins[tile as usize], &expected, "tile {}", tile);
            }
        }
    }
}
