//! The cost model: lanes say which shader blocks they take, a [`SimdPacker`] groups W
//! consecutive lanes and issues the union of their blocks, and the counters record issued
//! and useful instructions per stage.

use shadetrace_formats::results::{ShadingCost, StageCost};

use crate::by_name::ByName;
use crate::cost_table::{Block, BlockCost};

/// Stage of shading at pixel rate (every scheme's per-pixel lanes; FineInst in the tile-pair
/// paper).
pub const FINE: &str = "fine";

bitflags::bitflags! {
    /// The per-light blocks a lane takes.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct LightBlocks: u8 {
        const DIFFUSE = 1;
        const SPECULAR = 2;
        const SHADOW = 4;
        const LOCAL = 8;
        /// The light was considered (its range test ran), in range or not.
        const TEST = 16;
    }
}

/// The blocks one lane (or, as a union, one SIMD group) takes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BlockSet {
    /// One bit per light-independent [`Block`] (bit = `Block as u32`).
    pub fixed: u64,
    /// Per light: its blocks.
    pub lights: Vec<LightBlocks>,
}

impl BlockSet {
    pub fn new(lights: usize) -> Self {
        BlockSet {
            fixed: 0,
            lights: vec![LightBlocks::empty(); lights],
        }
    }

    pub fn clear(&mut self) {
        self.fixed = 0;
        // Once per lane: one light (the usual scene) is one store, not a call to memset.
        match self.lights.as_mut_slice() {
            [only] => *only = LightBlocks::empty(),
            lights => lights.fill(LightBlocks::empty()),
        }
    }

    #[inline]
    pub fn take(&mut self, block: Block) {
        self.fixed |= 1 << block as u64;
    }

    pub fn union_with(&mut self, other: &BlockSet) {
        self.fixed |= other.fixed;
        // Once per lane, as `clear`: one light is one `or`, not a loop.
        match (self.lights.as_mut_slice(), other.lights.as_slice()) {
            ([a], [b]) => *a |= *b,
            (lights, others) => {
                for (a, b) in lights.iter_mut().zip(others) {
                    *a |= *b;
                }
            }
        }
    }

    /// The set's cost, given that of its light-independent blocks (`fixed_cost(self.fixed)`).
    fn cost_with_fixed(&self, fixed: BlockCost) -> BlockCost {
        let add = |c: BlockCost, flags: &LightBlocks| {
            let b = LIGHT_COSTS[flags.bits() as usize];
            BlockCost {
                alu: c.alu + b.alu,
                tex: c.tex + b.tex,
            }
        };
        // Once per useful lane: one light is one lookup, not a loop.
        match self.lights.as_slice() {
            [only] => add(fixed, only),
            lights => lights.iter().fold(fixed, add),
        }
    }
}

/// The cost of `blocks`, its light-independent part taken from `memo` (bits, their cost)
/// when the bits are the same, else costed and kept there.
#[inline]
fn memoized_cost(memo: &mut (u64, BlockCost), blocks: &BlockSet) -> BlockCost {
    if blocks.fixed != memo.0 {
        *memo = (blocks.fixed, fixed_cost(blocks.fixed));
    }
    blocks.cost_with_fixed(memo.1)
}

/// The cost of the light-independent blocks whose bits `fixed` has.
fn fixed_cost(fixed: u64) -> BlockCost {
    let mut c = BlockCost { alu: 0, tex: 0 };
    let mut bits = fixed;
    while bits != 0 {
        let b = FIXED_BLOCKS[bits.trailing_zeros() as usize].cost();
        bits &= bits - 1;
        c.alu += b.alu;
        c.tex += b.tex;
    }
    c
}

/// Each light flag's block.
const LIGHT_FLAG_BLOCKS: [(LightBlocks, Block); 5] = [
    (LightBlocks::DIFFUSE, Block::Diffuse),
    (LightBlocks::SPECULAR, Block::Specular),
    (LightBlocks::SHADOW, Block::Shadow),
    (LightBlocks::LOCAL, Block::LocalLight),
    (LightBlocks::TEST, Block::LightTest),
];

/// The cost of a light's blocks by its flags' bits: one lookup per light and lane.
const _: () = assert!((LightBlocks::all().bits() as usize) < LIGHT_COSTS.len());
const LIGHT_COSTS: [BlockCost; 1 << LIGHT_FLAG_BLOCKS.len()] = {
    let mut costs = [BlockCost { alu: 0, tex: 0 }; 1 << LIGHT_FLAG_BLOCKS.len()];
    let mut bits = 0;
    while bits < costs.len() {
        let mut i = 0;
        while i < LIGHT_FLAG_BLOCKS.len() {
            let (flag, block) = LIGHT_FLAG_BLOCKS[i];
            if bits as u8 & flag.bits() != 0 {
                costs[bits].alu += block.cost().alu;
                costs[bits].tex += block.cost().tex;
            }
            i += 1;
        }
        bits += 1;
    }
    costs
};

/// `Block` by discriminant, for iterating the `fixed` bits.
const FIXED_BLOCKS: [Block; 47] = [
    Block::FineSetup,
    Block::AlbedoConstant,
    Block::AlbedoTextured,
    Block::Compose,
    Block::CoarseSetup,
    Block::Diffuse,
    Block::Specular,
    Block::Shadow,
    Block::LocalLight,
    Block::Resample,
    Block::PredicateDiffuse,
    Block::PredicateSpecular,
    Block::PredicateShadow,
    Block::CacheQuery,
    Block::ReuseTest,
    Block::ReuseCrossView,
    Block::GBufferWrite,
    Block::GBufferRead,
    Block::LightTest,
    Block::LightCull,
    Block::DepthBounds,
    Block::ClusterLookup,
    Block::VisibilityWrite,
    Block::VisibilityInterpolate,
    Block::MemoLookup,
    Block::TriangleStore,
    Block::TriangleDerivatives,
    Block::DaisInterpolate,
    Block::ListAppend,
    Block::ListNode,
    Block::ShadingSampleRef,
    Block::ShadingSampleWrite,
    Block::ShadingSampleRead,
    Block::TessFactor,
    Block::GridVertex,
    Block::WarpFragment,
    Block::RayGen,
    Block::NodeVisit,
    Block::TriangleTest,
    Block::HitAttributes,
    Block::RayCone,
    Block::BvhBuild,
    Block::NormalMap,
    Block::MetallicRoughnessMap,
    Block::OcclusionMap,
    Block::EmissiveConstant,
    Block::EmissiveTextured,
];

/// What `n` lanes of one block issue when packed densely into SIMD groups of `width` (a
/// compute pass over a buffer: every group full but the last, all lanes useful).
pub fn dense_lanes(block: Block, n: u64, width: u32) -> StageCost {
    let c = block.cost();
    let groups = n.div_ceil(u64::from(width.max(1)));
    StageCost {
        groups,
        alu: groups * u64::from(c.alu),
        tex: groups * u64::from(c.tex),
        useful_lane_alu: n * u64::from(c.alu),
        useful_lane_tex: n * u64::from(c.tex),
        useful_lanes: n,
    }
}

/// A job's cost heat: the instructions issued per pixel id, in the order they were issued
/// (consecutive adds to one pixel folded into one entry), or nothing in a frame that draws
/// no heat map: its packers then keep no lane pixels at all.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CostHeatList(Option<Vec<(u32, u32)>>);

impl CostHeatList {
    /// A list that keeps its entries (`true`) or drops them.
    pub fn new(kept: bool) -> CostHeatList {
        CostHeatList(kept.then(Vec::new))
    }

    pub fn is_kept(&self) -> bool {
        self.0.is_some()
    }

    /// A lane's heat-map id for a packer: `id()` where the list is kept, `u32::MAX` (no
    /// pixel) where it is not and nothing reads it, without computing it (a bounds test and
    /// a multiply a lane).
    #[inline(always)]
    pub fn pixel(&self, id: impl FnOnce() -> u32) -> u32 {
        match self.is_kept() {
            true => id(),
            false => u32::MAX,
        }
    }

    /// Adds `n` instructions to `pixel` (wrapping, like the map's sums).
    #[inline]
    pub fn add(&mut self, pixel: u32, n: u32) {
        if let Some(list) = &mut self.0 {
            match list.last_mut() {
                Some((last, sum)) if *last == pixel => *sum = sum.wrapping_add(n),
                _ => list.push((pixel, n)),
            }
        }
    }

    /// The entries, in order (none when not kept).
    pub fn entries(&self) -> &[(u32, u32)] {
        self.0.as_deref().unwrap_or_default()
    }
}

/// A job's counters per stage (by the stage's static name), added to the view's
/// [`ShadingCost`] once the job is done.
pub type StageCosts = ByName<StageCost>;

impl StageCosts {
    /// The counters of stage `name`, created on first use.
    #[inline]
    pub fn stage_mut(&mut self, name: &'static str) -> &mut StageCost {
        self.entry(name)
    }

    /// Adds every stage's counters to `cost` (creating the stages it lacks).
    pub fn add_to(&self, cost: &mut ShadingCost) {
        for (name, stage) in self.iter() {
            cost.stage_mut(name).add(stage);
        }
    }
}

/// Groups lanes into SIMD groups of `width` and counts what each group issues. Lanes that
/// are not useful (helper lanes, idle lanes) still widen the union when they take blocks.
pub struct SimdPacker {
    width: usize,
    lanes: usize,
    union: BlockSet,
    useful_alu: u64,
    useful_tex: u64,
    useful_lanes: u64,
    /// Pixel index of each lane in the open group (for the cost heat map).
    pixels: Vec<u32>,
    /// The last light-independent blocks costed and their cost: a unit's lanes mostly take
    /// the same ones.
    fixed_memo: (u64, BlockCost),
}

impl SimdPacker {
    pub fn new(width: u32, lights: usize) -> Self {
        SimdPacker {
            width: width.max(1) as usize,
            lanes: 0,
            union: BlockSet::new(lights),
            useful_alu: 0,
            useful_tex: 0,
            useful_lanes: 0,
            pixels: Vec::with_capacity(width as usize),
            fixed_memo: (0, BlockCost { alu: 0, tex: 0 }),
        }
    }

    /// Adds one lane; `pixel` is its heat-map id (`u32::MAX`: none). When a group issues,
    /// its instructions are added to each of its lanes' pixels in `heat`.
    // Once per lane of every scheme: inlined into each, whatever the caller's size.
    #[inline(always)]
    pub fn lane(
        &mut self,
        blocks: &BlockSet,
        useful: bool,
        pixel: u32,
        stage: &mut StageCost,
        heat: &mut CostHeatList,
    ) {
        self.union.union_with(blocks);
        let cost = useful.then(|| memoized_cost(&mut self.fixed_memo, blocks));
        self.add_lane(cost, pixel, stage, heat);
    }

    /// [`Self::lane`] of a quad's four lanes, which take the same `blocks`: `useful` has a
    /// bit per lane, `pixels` are their heat-map ids. The blocks are joined and costed once,
    /// not once per lane (again after a group issues between two lanes).
    #[inline(always)]
    pub fn quad(
        &mut self,
        blocks: &BlockSet,
        useful: u8,
        pixels: [u32; 4],
        stage: &mut StageCost,
        heat: &mut CostHeatList,
    ) {
        let cost = memoized_cost(&mut self.fixed_memo, blocks);
        for (l, pixel) in pixels.into_iter().enumerate() {
            if l == 0 || self.lanes == 0 {
                self.union.union_with(blocks);
            }
            self.add_lane((useful & 1 << l != 0).then_some(cost), pixel, stage, heat);
        }
    }

    /// Counts a lane whose blocks the group's union already holds: its cost where it is
    /// useful, its pixel for the heat map; issues the group once it is full.
    #[inline(always)]
    fn add_lane(&mut self, useful_cost: Option<BlockCost>, pixel: u32, stage: &mut StageCost, heat: &mut CostHeatList) {
        if let Some(c) = useful_cost {
            self.useful_alu += c.alu as u64;
            self.useful_tex += c.tex as u64;
            self.useful_lanes += 1;
        }
        if heat.is_kept() {
            self.pixels.push(pixel);
        }
        self.lanes += 1;
        if self.lanes == self.width {
            self.flush(stage, heat);
        }
    }

    /// Issues the open group, if any (at the end of a unit of work).
    pub fn flush(&mut self, stage: &mut StageCost, heat: &mut CostHeatList) {
        if self.lanes == 0 {
            return;
        }
        let c = memoized_cost(&mut self.fixed_memo, &self.union);
        stage.groups += 1;
        stage.alu += c.alu as u64;
        stage.tex += c.tex as u64;
        stage.useful_lane_alu += self.useful_alu;
        stage.useful_lane_tex += self.useful_tex;
        stage.useful_lanes += self.useful_lanes;
        let issued = c.alu + c.tex;
        for &p in &self.pixels {
            if p != u32::MAX {
                heat.add(p, issued);
            }
        }
        self.pixels.clear();
        self.union.clear();
        self.lanes = 0;
        self.useful_alu = 0;
        self.useful_tex = 0;
        self.useful_lanes = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_group_issues_the_union_of_its_lanes() {
        let mut packer = SimdPacker::new(4, 1);
        let mut stage = StageCost::default();
        let mut heat = CostHeatList::new(true);
        let mut lit = BlockSet::new(1);
        lit.take(Block::Compose);
        lit.lights[0] = LightBlocks::DIFFUSE | LightBlocks::SHADOW;
        let mut dark = BlockSet::new(1);
        dark.take(Block::Compose);
        dark.lights[0] = LightBlocks::DIFFUSE;
        packer.lane(&lit, true, 0, &mut stage, &mut heat);
        packer.lane(&dark, true, 1, &mut stage, &mut heat);
        packer.lane(&dark, false, 2, &mut stage, &mut heat);
        packer.flush(&mut stage, &mut heat);
        let (compose, diffuse, shadow) = (Block::Compose.cost(), Block::Diffuse.cost(), Block::Shadow.cost());
        assert_eq!(stage.groups, 1);
        assert_eq!(stage.alu, (compose.alu + diffuse.alu + shadow.alu) as u64);
        assert_eq!(stage.tex, shadow.tex as u64);
        assert_eq!(stage.useful_lanes, 2);
        assert_eq!(
            stage.useful_lane_alu,
            (2 * (compose.alu + diffuse.alu) + shadow.alu) as u64
        );
        let issued = stage.issued() as u32;
        assert_eq!(heat.entries(), [(0, issued), (1, issued), (2, issued)]);
    }

    /// One light's blocks and some of the light-independent ones, from a few bits.
    fn blocks_of(bits: u8) -> BlockSet {
        let mut blocks = BlockSet::new(1);
        for (i, block) in [Block::Compose, Block::CoarseSetup, Block::AlbedoTextured]
            .into_iter()
            .enumerate()
        {
            if bits & 1 << i != 0 {
                blocks.take(block);
            }
        }
        blocks.lights[0] = LightBlocks::from_bits_truncate(bits >> 3);
        blocks
    }

    proptest::proptest! {
        /// A quad's four lanes added at once count what four `lane` calls count, also where a
        /// group issues between two of them (widths not a multiple of four, lanes added
        /// one by one in between), with or without heat.
        #[test]
        fn a_quad_counts_as_its_four_lanes(
            width in 1u32..18,
            kept in proptest::prelude::any::<bool>(),
            // Per entry: a quad (its blocks, useful lanes) or a lone lane.
            entries in proptest::collection::vec((0u8..=255, 0u8..16, proptest::prelude::any::<bool>()), 0..24),
        ) {
            let run = |together: bool| {
                let mut packer = SimdPacker::new(width, 1);
                let (mut stage, mut heat) = (StageCost::default(), CostHeatList::new(kept));
                for (i, &(bits, useful, quad)) in entries.iter().enumerate() {
                    let blocks = blocks_of(bits);
                    let pixels: [u32; 4] = std::array::from_fn(|l| (4 * i + l) as u32);
                    match (quad, together) {
                        (true, true) => packer.quad(&blocks, useful, pixels, &mut stage, &mut heat),
                        (true, false) => {
                            for (l, pixel) in pixels.into_iter().enumerate() {
                                packer.lane(&blocks, useful & 1 << l != 0, pixel, &mut stage, &mut heat);
                            }
                        }
                        (false, _) => packer.lane(&blocks, useful & 1 != 0, pixels[0], &mut stage, &mut heat),
                    }
                }
                packer.flush(&mut stage, &mut heat);
                (stage, heat.entries().to_vec())
            };
            proptest::prop_assert_eq!(run(true), run(false));
        }
    }

    /// The table of light costs is the sum of each flag's block.
    #[test]
    fn light_costs_add_up_their_flags_blocks() {
        for bits in 0..=LightBlocks::all().bits() {
            let flags = LightBlocks::from_bits(bits).unwrap();
            let (mut alu, mut tex) = (0, 0);
            for (flag, block) in LIGHT_FLAG_BLOCKS {
                if flags.contains(flag) {
                    (alu, tex) = (alu + block.cost().alu, tex + block.cost().tex);
                }
            }
            assert_eq!(LIGHT_COSTS[bits as usize], BlockCost { alu, tex }, "{flags:?}");
        }
    }

    /// A frame without heat maps counts the same and keeps no heat.
    #[test]
    fn heat_left_out_counts_the_same() {
        let mut blocks = BlockSet::new(1);
        blocks.take(Block::Compose);
        blocks.lights[0] = LightBlocks::DIFFUSE;
        let run = |kept| {
            let mut packer = SimdPacker::new(4, 1);
            let (mut stage, mut heat) = (StageCost::default(), CostHeatList::new(kept));
            for pixel in 0..6 {
                packer.lane(&blocks, pixel % 3 != 0, pixel, &mut stage, &mut heat);
            }
            packer.flush(&mut stage, &mut heat);
            (stage, heat)
        };
        let ((kept, heat), (skipped, none)) = (run(true), run(false));
        assert_eq!(kept, skipped);
        assert_eq!(heat.entries().len(), 6);
        assert!(none.entries().is_empty());
    }

    /// A kept list gets each lane's id; a dropped one gets none and never computes it.
    #[test]
    fn only_a_kept_list_asks_for_the_pixel() {
        assert_eq!(CostHeatList::new(true).pixel(|| 7), 7);
        let unread = CostHeatList::new(false).pixel(|| panic!("an id computed for no heat map"));
        assert_eq!(unread, u32::MAX);
    }
}
