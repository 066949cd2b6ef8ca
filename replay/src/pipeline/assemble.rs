//! A view's results gathered from every job in job order: counters summed, tiles copied into
//! the picture, tiles no job touched cleared, per-pixel heat and refinement merged.

use shadetrace_formats::results::{RasterStats, ShadingCacheStats, ShadingCost, VertexStats};

use super::job::JobOutput;
use super::resolve::clear_pixel;
use super::{Colors, CostHeat, ViewOutput};
use crate::bins::TileGrid;

/// Heat and refinement maps key pixels as `view << 30 | y * width + x`.
const PIXEL_BITS: u32 = 30;

pub fn view<'a>(
    v: usize,
    vertex: VertexStats,
    grid: TileGrid,
    (simd_width, heat, colors): (u32, CostHeat, Colors),
    outputs: impl IntoIterator<Item = &'a JobOutput>,
) -> ViewOutput {
    let (width, height) = (grid.width, grid.height);
    let mut pixels = match colors {
        Colors::Kept => vec![clear_pixel(); (width * height) as usize],
        Colors::Skipped => Vec::new(),
    };
    let mut cost_heat = match heat {
        CostHeat::Kept => vec![0u32; (width * height) as usize],
        CostHeat::Skipped => Vec::new(),
    };
    let mut refinement = vec![0u8; (width * height) as usize];
    let mut cache = ShadingCacheStats::default();
    let mut raster = RasterStats::default();
    let mut cost = ShadingCost::new(simd_width);
    let in_view = |pixel: u32| (pixel >> PIXEL_BITS) as usize == v;
    let index = |pixel: u32| (pixel & ((1 << PIXEL_BITS) - 1)) as usize;
    for out in outputs {
        raster.add(&out.raster[v]);
        cache.add(&out.cache[v]);
        out.cost[v].add_to(&mut cost);
        for tile in out.tiles.iter().filter(|t| t.view as usize == v) {
            raster.pixels_covered += tile.covered;
            if colors == Colors::Skipped {
                continue;
            }
            let r = tile.rect;
            let tile_width = (r.x1 - r.x0) as usize;
            for (row, y) in (r.y0..r.y1).enumerate() {
                let start = (y * width + r.x0) as usize;
                pixels[start..start + tile_width]
                    .copy_from_slice(&tile.pixels[row * tile_width..(row + 1) * tile_width]);
            }
        }
        for &(pixel, n) in out.heat.entries().iter().filter(|(p, _)| in_view(*p)) {
            let sum = &mut cost_heat[index(pixel)];
            *sum = sum.wrapping_add(n);
        }
        for &(pixel, bits) in out.refinement.iter().filter(|(p, _)| in_view(*p)) {
            refinement[index(pixel)] |= bits;
        }
    }
    ViewOutput {
        vertex,
        raster,
        cost,
        width,
        height,
        pixels,
        cost_heat,
        refinement,
        cache,
    }
}
