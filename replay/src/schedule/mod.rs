//! Schedulers decide the order of raster work: which (view, tile, triangle) units run in
//! which job, and in which order the memory model sees them. They never change pixels: the
//! depth test is order-independent (ties go to the lower primitive id), so every schedule
//! yields the same visible surface; order changes overdraw, cost and traffic only.

mod immediate;
mod multiview;
pub mod pairing;
mod sort_middle;
mod tile_pair;

pub use immediate::Immediate;
pub use multiview::Multiview;
pub use sort_middle::SortMiddle;
pub use tile_pair::TilePair;

use shadetrace_formats::results::ListStats;

use crate::bins::Bins;
pub use crate::command::{Command, Job, Unit};
use crate::vertex_stage::SetupTriangle;

/// What a scheduler sees: the exact bins and the setup triangles of both views.
pub struct ScheduleInput<'a> {
    pub bins: &'a Bins,
    pub setups: [&'a [SetupTriangle]; 2],
}

/// A scheduler's output: the jobs and the binning lists they cost.
pub struct Schedule {
    pub jobs: Vec<Job>,
    pub lists: ListTraffic,
}

/// Traffic class of the binning lists, written while binning and read while rasterizing.
pub const INDICES: &str = "indices";

/// Index-list traffic and statistics of a schedule.
#[derive(Clone, Copy, Debug, Default)]
pub struct ListTraffic {
    pub index_bytes: u64,
    pub stats: ListStats,
}

pub trait Scheduler: Sync {
    fn name(&self) -> &'static str;
    /// Splits the binned work into jobs and accounts for the lists it builds.
    fn schedule(&self, input: &ScheduleInput) -> Schedule;
    /// Sort key of a unit in the order the hardware would issue it (memory-model order):
    /// `pass` is 0 for a depth pre-pass, 1 for the geometry pass; `job` and `index` (the
    /// command's position in its job) locate the unit.
    fn issue_key(&self, unit: &Unit, pass: u8, job: usize, index: usize) -> [u64; 4];
    /// Sort key of the tile pass (`ShadeTile`, command `index` of `job`) of `view`'s `tile`,
    /// with its group (0: among the geometry commands, 1: after all of them). By default
    /// after every geometry command: an immediate GPU lights once the frame is drawn.
    /// Binned schedulers that finish tiles in turn put it after the tile's own geometry, so
    /// its G-buffer is still on chip.
    fn tile_pass_key(&self, view: u8, tile: u32, _job: usize, _index: usize) -> (u8, [u64; 4]) {
        (1, [view as u64, tile as u64, 0, 0])
    }
    /// Binned architectures store the vertex stage's output in DRAM.
    fn stores_vertex_output(&self) -> bool;
}

/// Tile-list statistics of the bins (u32 entries), without traffic.
pub fn tile_list_stats(bins: &Bins) -> ListStats {
    let tiles = bins.lists.iter().flatten().filter(|l| !l.is_empty()).count() as u64;
    let entries = bins.lists.iter().flatten().map(|l| l.len() as u64).sum::<u64>();
    ListStats {
        tile_size: bins.tile,
        tiles,
        tile_entries: entries,
        tile_list_bytes: entries * TILE_ENTRY_BYTES,
        ..Default::default()
    }
}

/// Bytes of one tile-list entry (a u32 triangle index).
pub const TILE_ENTRY_BYTES: u64 = 4;

/// One job per non-empty (view, tile), its triangles in submission order: the work split
/// that tile-local schedulers share.
pub fn per_tile_jobs(bins: &Bins) -> Vec<Job> {
    let mut jobs = Vec::new();
    for (view, lists) in bins.lists.iter().enumerate() {
        for (tile, list) in lists.iter().enumerate() {
            if !list.is_empty() {
                jobs.push(Job {
                    commands: list
                        .iter()
                        .map(|&tri| {
                            Command::Draw(Unit {
                                view: view as u8,
                                tile: tile as u32,
                                tri,
                                rank: 0,
                            })
                        })
                        .collect(),
                });
            }
        }
    }
    jobs
}
