//! SIMD issue schedules of multi-rate shading (§3.3): how a unit's coarse, reuse and fine
//! lanes are packed into SIMD groups.

use super::config::SimdSchedule;
use super::tile_pair_cache::REUSE;
use super::{MultirateJob, COARSE};
use crate::cost::FINE;
use crate::scheme::Accounting;
use shadetrace_formats::results::StageCost;

impl MultirateJob {
    /// Issues coarse lanes (coarse stage) and cache-query lanes (reuse stage) of a range as
    /// SIMD groups, each stage packed separately.
    fn issue_coarse(&mut self, lanes: std::ops::Range<usize>, acc: &mut Accounting) {
        // Counted locally and added once: no lookup of a stage by name per lane.
        let (mut coarse, mut reuse) = (StageCost::default(), StageCost::default());
        for lane in &self.coarse_lanes[lanes] {
            if lane.reuse {
                self.reuse_packer
                    .lane(&lane.blocks, true, lane.pixel, &mut reuse, acc.heat);
            } else {
                self.coarse_packer
                    .lane(&lane.blocks, true, lane.pixel, &mut coarse, acc.heat);
            }
        }
        self.coarse_packer.flush(&mut coarse, acc.heat);
        self.reuse_packer.flush(&mut reuse, acc.heat);
        acc.cost.stage_mut(COARSE).add(&coarse);
        acc.cost.stage_mut(REUSE).add(&reuse);
    }

    /// Issues the unit's coarse and fine lanes as SIMD groups under the configured schedule.
    pub(super) fn issue(&mut self, acc: &mut Accounting) {
        match self.config.schedule {
            SimdSchedule::TwoPhase | SimdSchedule::TwoPhaseSorted => {
                self.issue_coarse(0..self.coarse_used, acc);
                self.order.clear();
                self.order.extend(0..self.fine_used / 4);
                if self.config.schedule == SimdSchedule::TwoPhaseSorted {
                    let lanes = &self.fine_lanes;
                    self.order.sort_by_key(|&q| lanes[4 * q].key);
                }
                let fine = acc.cost.stage_mut(FINE);
                for &q in &self.order {
                    for lane in &self.fine_lanes[4 * q..4 * q + 4] {
                        self.fine_packer
                            .lane(&lane.blocks, lane.useful, lane.pixel, fine, acc.heat);
                    }
                }
                self.fine_packer.flush(fine, acc.heat);
            }
            SimdSchedule::SingleThread => self.issue_single_thread(acc),
        }
    }

    /// Single thread of control: W coarse fragments per group; each lane then loops over
    /// its own covered pixels, so the group issues as many fine iterations as its busiest
    /// lane has pixels, each the union of the blocks of the lanes still looping.
    fn issue_single_thread(&mut self, acc: &mut Accounting) {
        let w = self.simd_width.max(1) as usize;
        let mut per_lane: Vec<Vec<usize>> = vec![Vec::new(); self.coarse_used];
        for (i, f) in self.fine_lanes[..self.fine_used].iter().enumerate() {
            if f.useful {
                per_lane[f.coarse_lane].push(i);
            }
        }
        // Each group and each fine iteration is issued as one (possibly partial) SIMD group.
        for start in (0..self.coarse_used).step_by(w) {
            let group = start..(start + w).min(self.coarse_used);
            self.issue_coarse(group.clone(), acc);
            let iterations = per_lane[group.clone()].iter().map(Vec::len).max().unwrap_or(0);
            let fine = acc.cost.stage_mut(FINE);
            for it in 0..iterations {
                for fragments in &per_lane[group.clone()] {
                    if let Some(&f) = fragments.get(it) {
                        let lane = &self.fine_lanes[f];
                        self.fine_packer.lane(&lane.blocks, true, lane.pixel, fine, acc.heat);
                    }
                }
                self.fine_packer.flush(fine, acc.heat);
            }
        }
    }
}
