//! `sort-middle`: triangles are binned into per-view tile lists (u32 entries written to
//! DRAM), then each tile is rasterized and shaded to completion, tile after tile. The
//! framebuffer is touched one tile at a time; triangles spanning several tiles are fetched
//! once per tile (bin spread).

use super::{per_tile_jobs, tile_list_stats, ListTraffic, Schedule, ScheduleInput, Scheduler, Unit};

pub struct SortMiddle;

impl Scheduler for SortMiddle {
    fn name(&self) -> &'static str {
        "sort-middle"
    }

    fn schedule(&self, input: &ScheduleInput) -> Schedule {
        let stats = tile_list_stats(input.bins);
        Schedule {
            jobs: per_tile_jobs(input.bins),
            // Lists are written once while binning and read once while rasterizing.
            lists: ListTraffic {
                index_bytes: 2 * stats.tile_list_bytes,
                stats,
            },
        }
    }

    fn issue_key(&self, unit: &Unit, pass: u8, _job: usize, _index: usize) -> [u64; 4] {
        [unit.view as u64, unit.tile as u64, pass as u64, unit.tri as u64]
    }

    /// After the tile's geometry ([`Self::issue_key`] orders by tile, then pass).
    fn tile_pass_key(&self, view: u8, tile: u32, _job: usize, _index: usize) -> (u8, [u64; 4]) {
        (0, [view as u64, tile as u64, 2, 0])
    }

    fn stores_vertex_output(&self) -> bool {
        true
    }
}
