//! `multiview` (Hasselgren and Akenine-Möller 2006, as described in the tile-pair paper):
//! immediate mode, each triangle rasterized into both views together, its tiles visited in
//! texture-coherent order: on every tile row, the left and right tiles are interleaved by
//! their position in the triangle's barycentric space (the same traversal measure as
//! Algorithm 1), so both views read the same texels close in time. No binning lists.

use std::collections::HashMap;

use rayon::prelude::*;
use shadetrace_formats::results::ListStats;

use super::pairing::{pair_tiles, row_spans, span_of, RowSpan};
use super::{per_tile_jobs, Command, ListTraffic, Schedule, ScheduleInput, Scheduler, Unit};

pub struct Multiview;

impl Scheduler for Multiview {
    fn name(&self) -> &'static str {
        "multiview"
    }

    fn schedule(&self, input: &ScheduleInput) -> Schedule {
        let grid = input.bins.grid;
        // Rank of every (view, tile, prim) on its row: the position of the tile in the pair
        // traversal, left tile of a pair before its right tile. Rows are independent.
        let ranks: Vec<HashMap<(u8, u32, u32), u32>> = (0..grid.tiles_y)
            .into_par_iter()
            .map(|row| {
                let mut ranks = HashMap::new();
                let mut pairs = Vec::new();
                let spans = [0, 1].map(|v| row_spans(input, row, v));
                let rect = grid.rect(row * grid.tiles_x);
                for v in 0..2u8 {
                    for &RowSpan {
                        prim,
                        columns: span,
                        setup: s,
                        ..
                    } in &spans[v as usize]
                    {
                        let tile = |x: u32| row * grid.tiles_x + x;
                        let mut next = 0u32;
                        let mut rank = |view: u8, x: u32, ranks: &mut HashMap<(u8, u32, u32), u32>| {
                            ranks.entry((view, tile(x), prim)).or_insert_with(|| {
                                next += 1;
                                next
                            });
                        };
                        match (v, span_of(&spans[1], prim).map(|j| spans[1][j])) {
                            (0, Some(other)) => {
                                let (r, rs) = (other.columns, other.setup);
                                pairs.clear();
                                let (left, right) = (&input.setups[0][s as usize], &input.setups[1][rs as usize]);
                                let center_y = (rect.y0 + rect.y1) / 2;
                                pair_tiles(left, right, span, r, center_y, grid.tile, grid.width, &mut pairs);
                                for &(a, b) in &pairs {
                                    rank(0, a, &mut ranks);
                                    rank(1, b, &mut ranks);
                                }
                                for x in span.0..=span.1 {
                                    rank(0, x, &mut ranks);
                                }
                                for x in r.0..=r.1 {
                                    rank(1, x, &mut ranks);
                                }
                            }
                            (0, None) | (1, _) => {
                                for x in span.0..=span.1 {
                                    rank(v, x, &mut ranks);
                                }
                            }
                            _ => {}
                        }
                    }
                }
                ranks
            })
            .collect();
        let mut jobs = per_tile_jobs(input.bins);
        for job in &mut jobs {
            for unit in job.commands.iter_mut().filter_map(|c| match c {
                Command::Draw(u) => Some(u),
                _ => None,
            }) {
                let prim = input.setups[unit.view as usize][unit.tri as usize].prim;
                let row = unit.tile / grid.tiles_x;
                let position = ranks[row as usize]
                    .get(&(unit.view, unit.tile, prim))
                    .copied()
                    .unwrap_or(0);
                // Triangle first (both views together), then row, then traversal position:
                // 32 + 12 + 13 bits (rows <= 4096, positions <= 2 x 4096 columns).
                unit.rank = (prim as u64) << 25 | (row as u64 & 0xfff) << 13 | (position as u64 & 0x1fff);
            }
        }
        Schedule {
            jobs,
            lists: ListTraffic {
                index_bytes: 0,
                stats: ListStats {
                    tile_size: grid.tile,
                    ..Default::default()
                },
            },
        }
    }

    fn issue_key(&self, unit: &Unit, pass: u8, _job: usize, _index: usize) -> [u64; 4] {
        [pass as u64, unit.rank, unit.view as u64, unit.tri as u64]
    }

    fn stores_vertex_output(&self) -> bool {
        false
    }
}
