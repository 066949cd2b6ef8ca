//! `tile-pair` (Yuan, Wang and Bao): per epipolar tile row, triangles are binned into the
//! per-view tile lists (u32) and, by Algorithm 1, into tile-pair lists (u16 entries); tile
//! pairs are grouped into sequences of neighbours by a depth-first search from the leftmost
//! unprocessed pair (neighbours (L+1,R), (L+1,R+1), (L,R+1)); sequences run nearest first
//! (disparity order: larger `L - R` tile offset means nearer) unless that is switched off.
//! Both tiles of a pair are rasterized together; a triangle is rasterized once per tile (the
//! paper's negative-index tag); triangles that paired nowhere (one view only) run last.
//! Rows are independent jobs, run in parallel.

use rayon::prelude::*;

use super::pairing::{pair_tiles, row_spans, span_of};
use super::{tile_list_stats, Command, Job, ListTraffic, Schedule, ScheduleInput, Scheduler, Unit};

/// Bytes of one tile-pair list entry (a u16 index into a tile list).
pub const PAIR_ENTRY_BYTES: u64 = 2;

pub struct TilePair {
    /// Order sequences nearest first (the paper's disparity constraint, §4.2 and Fig. 13).
    pub disparity_order: bool,
}

/// One row's job and its pair-list statistics.
struct RowSchedule {
    job: Job,
    pairs: u64,
    pair_entries: u64,
}

impl Scheduler for TilePair {
    fn name(&self) -> &'static str {
        "tile-pair"
    }

    fn schedule(&self, input: &ScheduleInput) -> Schedule {
        let rows: Vec<RowSchedule> = (0..input.bins.grid.tiles_y)
            .into_par_iter()
            .map(|row| self.row(input, row))
            .collect();
        let mut stats = tile_list_stats(input.bins);
        stats.tile_pairs = rows.iter().map(|r| r.pairs).sum();
        stats.tile_pair_entries = rows.iter().map(|r| r.pair_entries).sum();
        stats.tile_pair_list_bytes = stats.tile_pair_entries * PAIR_ENTRY_BYTES;
        Schedule {
            jobs: rows.into_iter().map(|r| r.job).filter(|j| !j.is_empty()).collect(),
            // Both kinds of lists are written while binning and read while rasterizing.
            lists: ListTraffic {
                index_bytes: 2 * (stats.tile_list_bytes + stats.tile_pair_list_bytes),
                stats,
            },
        }
    }

    fn issue_key(&self, _unit: &Unit, pass: u8, job: usize, index: usize) -> [u64; 4] {
        [job as u64, pass as u64, index as u64, 0]
    }

    /// After the row's geometry: a job's tile passes follow its geometry commands.
    fn tile_pass_key(&self, _view: u8, _tile: u32, job: usize, index: usize) -> (u8, [u64; 4]) {
        (0, [job as u64, 1, index as u64, 0])
    }

    fn stores_vertex_output(&self) -> bool {
        true
    }
}

impl TilePair {
    fn row(&self, input: &ScheduleInput, row: u32) -> RowSchedule {
        let grid = input.bins.grid;
        let tiles_x = grid.tiles_x;
        let list = |v: usize, x: u32| &input.bins.lists[v][(row * tiles_x + x) as usize];
        let spans = [0, 1].map(|v| row_spans(input, row, v));
        let rect = grid.rect(row * tiles_x);
        let center_y = (rect.y0 + rect.y1) / 2;
        // (pair, the primitive's index in each view's `spans`) in pairing order.
        let mut entries: Vec<((u32, u32), [u32; 2])> = Vec::new();
        let mut pairs = Vec::new();
        for (i, left) in spans[0].iter().enumerate() {
            let Some(j) = span_of(&spans[1], left.prim) else {
                continue;
            };
            let right = &spans[1][j];
            pairs.clear();
            let (left_setup, right_setup) = (
                &input.setups[0][left.setup as usize],
                &input.setups[1][right.setup as usize],
            );
            pair_tiles(
                left_setup,
                right_setup,
                left.columns,
                right.columns,
                center_y,
                grid.tile,
                grid.width,
                &mut pairs,
            );
            entries.extend(pairs.iter().map(|&p| (p, [i as u32, j as u32])));
        }
        let pair_lists = PairLists::new(entries);
        let pair_entries = pair_lists.spans.len() as u64;
        let sequences = self.sequences(&pair_lists);

        // Units: both tiles of each pair, a triangle once per tile, then the leftovers.
        let mut done: [Vec<Vec<bool>>; 2] =
            [0, 1].map(|v| (0..tiles_x).map(|x| vec![false; list(v, x).len()]).collect());
        let mut commands = Vec::new();
        let mut current = 0u32;
        let mut emit = |v: usize, x: u32, setups: Option<(u32, u32)>, sequence: u32, commands: &mut Vec<Command>| {
            let l = list(v, x);
            let range = match setups {
                Some((first, last)) => l.partition_point(|&s| s < first)..l.partition_point(|&s| s <= last),
                None => 0..l.len(),
            };
            for i in range {
                if !done[v][x as usize][i] {
                    done[v][x as usize][i] = true;
                    if sequence != current {
                        current = sequence;
                        commands.push(Command::BeginSequence);
                    }
                    commands.push(Command::Draw(Unit {
                        view: v as u8,
                        tile: row * tiles_x + x,
                        tri: l[i],
                        rank: 0,
                    }));
                }
            }
        };
        for (s, sequence) in sequences.iter().enumerate() {
            let number = s as u32 + 1;
            for &pair in sequence {
                for &[i, j] in pair_lists.spans_of(pair) {
                    emit(0, pair.0, Some(spans[0][i as usize].setups), number, &mut commands);
                    emit(1, pair.1, Some(spans[1][j as usize].setups), number, &mut commands);
                }
            }
        }
        for v in 0..2 {
            for x in 0..tiles_x {
                emit(v, x, None, 0, &mut commands);
            }
        }
        RowSchedule {
            job: Job { commands },
            pairs: pair_lists.pairs.len() as u64,
            pair_entries,
        }
    }

    /// Sequences of neighbouring pairs by depth-first search from the leftmost unprocessed
    /// pair, ordered nearest first when the disparity order is on.
    fn sequences(&self, pair_lists: &PairLists) -> Vec<Vec<(u32, u32)>> {
        let pairs = &pair_lists.pairs;
        let mut processed = vec![false; pairs.len()];
        let mut sequences = Vec::new();
        for (seed, &seed_pair) in pairs.iter().enumerate() {
            if processed[seed] {
                continue;
            }
            let mut sequence = Vec::new();
            let mut stack = vec![seed_pair];
            while let Some(p) = stack.pop() {
                match pair_lists.index(p) {
                    Some(i) if !processed[i] => processed[i] = true,
                    _ => continue,
                }
                sequence.push(p);
                let (l, r) = p;
                for n in [(l, r + 1), (l + 1, r + 1), (l + 1, r)] {
                    if pair_lists.index(n).is_some_and(|i| !processed[i]) {
                        stack.push(n);
                    }
                }
            }
            sequences.push(sequence);
        }
        if self.disparity_order {
            sequences.sort_by_key(|s| std::cmp::Reverse(s[0].0 as i64 - s[0].1 as i64));
        }
        sequences
    }
}

/// A row's tile-pair lists: the pairs in order, each with its primitives in the order they
/// were paired, as their spans in each view's [`row_spans`] (sorted arrays, searched: a row
/// holds a few hundred pairs).
struct PairLists {
    pairs: Vec<(u32, u32)>,
    /// Where each pair's primitives start in `spans` (one more entry than pairs).
    starts: Vec<usize>,
    spans: Vec<[u32; 2]>,
}

impl PairLists {
    /// From (pair, primitive's spans) entries in pairing order.
    fn new(mut entries: Vec<((u32, u32), [u32; 2])>) -> PairLists {
        // Stable: a pair's primitives keep their pairing order.
        entries.sort_by_key(|&(pair, _)| pair);
        let (mut pairs, mut starts) = (Vec::new(), Vec::new());
        for (i, &(pair, _)) in entries.iter().enumerate() {
            if pairs.last() != Some(&pair) {
                pairs.push(pair);
                starts.push(i);
            }
        }
        starts.push(entries.len());
        PairLists {
            pairs,
            starts,
            spans: entries.into_iter().map(|(_, spans)| spans).collect(),
        }
    }

    fn index(&self, pair: (u32, u32)) -> Option<usize> {
        self.pairs.binary_search(&pair).ok()
    }

    fn spans_of(&self, pair: (u32, u32)) -> &[[u32; 2]] {
        self.index(pair)
            .map_or(&[], |i| &self.spans[self.starts[i]..self.starts[i + 1]])
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};
    use shadetrace_formats::{Eye, Pose, StereoRig};

    use super::*;
    use crate::bins::{Bins, TileGrid};
    use crate::geometry::{FrameGeometry, Triangle};
    use crate::vertex_stage::setup_view;

    #[test]
    fn every_binned_triangle_is_rasterized_once_per_tile() {
        // Overlapping triangles at several depths, one visible in the left view only.
        let mut g = FrameGeometry::default();
        let tris = [
            [
                Vec3::new(-2.0, -1.0, -1.0),
                Vec3::new(2.0, -1.0, -1.0),
                Vec3::new(0.0, 1.0, -1.0),
            ],
            [
                Vec3::new(-1.0, -0.5, 1.0),
                Vec3::new(1.0, -0.5, 1.0),
                Vec3::new(0.0, 0.8, 1.0),
            ],
            [
                Vec3::new(-3.0, -2.0, -4.0),
                Vec3::new(3.0, -2.0, -4.0),
                Vec3::new(0.0, 2.0, -4.0),
            ],
            [
                Vec3::new(1.05, -0.1, 2.0),
                Vec3::new(1.2, -0.1, 2.0),
                Vec3::new(1.1, 0.1, 2.0),
            ],
        ];
        for t in tris {
            let base = g.positions.len() as u32;
            g.positions.extend(t);
            g.normals.extend([Vec3::Z; 3]);
            g.uvs.extend([Vec2::ZERO; 3]);
            g.triangles.push(Triangle {
                vertices: [base, base + 1, base + 2],
                material: 0,
                patch: u32::MAX,
                mesh: 0,
            });
        }
        let rig = StereoRig {
            head: Pose::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y),
            ipd_m: 0.3,
            eye_width: 160,
            eye_height: 96,
            yfov: 1.2,
            near: 0.05,
            far: 100.0,
            convergence_m: 2.0,
        };
        let setups = Eye::BOTH.map(|eye| setup_view(&g, &[true], rig.view_projection(eye), 160, 96).0);
        let bins = Bins::build(TileGrid::new(160, 96, 16), [&setups[0], &setups[1]]);
        for disparity_order in [true, false] {
            let schedule = TilePair { disparity_order }.schedule(&ScheduleInput {
                bins: &bins,
                setups: [&setups[0], &setups[1]],
            });
            let mut seen: Vec<(u8, u32, u32)> = schedule
                .jobs
                .iter()
                .flat_map(|j| {
                    j.commands
                        .iter()
                        .filter_map(|c| c.unit())
                        .map(|u| (u.view, u.tile, u.tri))
                })
                .collect();
            let total = seen.len();
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), total, "a (view, tile, triangle) ran twice");
            let binned: usize = bins.lists.iter().flatten().map(Vec::len).sum();
            assert_eq!(total, binned, "every binned triangle runs once");
            assert!(schedule.lists.stats.tile_pairs > 0);
        }
    }
}
