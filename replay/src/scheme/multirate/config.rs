//! Configuration of multi-rate shading: coarse rate, sample placement, SIMD schedule and
//! refinement thresholds of He et al. (2014), and the shading cache of the tile-pair and
//! object-space schemes, with their defaults and command-line names.

/// Coarse shading rate (§3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoarseMode {
    Coarse2x2,
    Coarse4x4,
    Dynamic4x4,
}

impl CoarseMode {
    pub fn parse(s: &str) -> Result<CoarseMode, String> {
        match s {
            "2x2" => Ok(CoarseMode::Coarse2x2),
            "4x4" => Ok(CoarseMode::Coarse4x4),
            "dynamic" => Ok(CoarseMode::Dynamic4x4),
            _ => Err(format!("coarse mode `{s}`: expected 2x2, 4x4 or dynamic")),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            CoarseMode::Coarse2x2 => "2x2",
            CoarseMode::Coarse4x4 => "4x4",
            CoarseMode::Dynamic4x4 => "dynamic",
        }
    }
}

/// Where a block's four coarse samples sit (§3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// Centres of the four coarse fragments.
    StaticCenter,
    /// Centres of the block's corner pixels.
    StaticCorner,
    /// Corner pixels of the bounding box of the block's covered pixels (the paper's choice).
    CoverageBbox,
}

impl Sampling {
    pub fn parse(s: &str) -> Result<Sampling, String> {
        match s {
            "static-center" => Ok(Sampling::StaticCenter),
            "static-corner" => Ok(Sampling::StaticCorner),
            "coverage-bbox" => Ok(Sampling::CoverageBbox),
            _ => Err(format!(
                "sampling `{s}`: expected static-center, static-corner or coverage-bbox"
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Sampling::StaticCenter => "static-center",
            Sampling::StaticCorner => "static-corner",
            Sampling::CoverageBbox => "coverage-bbox",
        }
    }
}

/// How coarse and fine work is packed into SIMD groups (§3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimdSchedule {
    /// One lane per coarse fragment runs its coarse work, then its fine fragments in turn.
    SingleThread,
    /// Coarse blocks in groups of W/4, fine quads buffered and repacked in groups of W/4.
    TwoPhase,
    /// As `TwoPhase`, fine quads sorted by their block's refinement flags before packing.
    TwoPhaseSorted,
}

impl SimdSchedule {
    pub fn parse(s: &str) -> Result<SimdSchedule, String> {
        match s {
            "single-thread" => Ok(SimdSchedule::SingleThread),
            "two-phase" => Ok(SimdSchedule::TwoPhase),
            "two-phase-sorted" => Ok(SimdSchedule::TwoPhaseSorted),
            _ => Err(format!(
                "SIMD schedule `{s}`: expected single-thread, two-phase or two-phase-sorted"
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SimdSchedule::SingleThread => "single-thread",
            SimdSchedule::TwoPhase => "two-phase",
            SimdSchedule::TwoPhaseSorted => "two-phase-sorted",
        }
    }
}

/// Refinement thresholds; 0 refines unconditionally, infinity never refines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    /// Variation of N·L across the block's samples (§4.1).
    pub diffuse: f32,
    /// Flatness `1 - min(N_i · N_avg)` above which the reflection-cone test runs (§4.1).
    pub specular: f32,
    /// Cone enlargement λ: refine when `L · R_avg >= λ min(R_i · R_avg)`.
    pub lambda: f32,
    /// Occlusion difference across the block's samples (§4.2).
    pub shadow: f32,
    /// Edge-receiver threshold δ on the negative second depth derivative, map depth units.
    pub edge_delta: f32,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            diffuse: 0.1,
            specular: 0.002,
            lambda: 0.9,
            shadow: 0.05,
            edge_delta: 0.002,
        }
    }
}

impl Thresholds {
    /// All refinement thresholds multiplied by `k` (λ and δ unchanged): the sweep knob.
    pub fn scaled(self, k: f32) -> Thresholds {
        // 0 x inf must stay 0 (refine everything), not NaN.
        let mul = |t: f32| if k == 0.0 || t == 0.0 { 0.0 } else { t * k };
        Thresholds {
            diffuse: mul(self.diffuse),
            specular: mul(self.specular),
            shadow: mul(self.shadow),
            ..self
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultirateConfig {
    pub mode: CoarseMode,
    pub sampling: Sampling,
    pub small_triangle: bool,
    pub thresholds: Thresholds,
    pub schedule: SimdSchedule,
    /// The tile-pair paper's shading cache (`tile-pair-cache`); None for plain He et al.
    pub cache: Option<CacheConfig>,
}

/// Where cached coarse shading lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CacheSpace {
    /// Screen space per view, reused across views after a reuse test (tile-pair).
    Screen,
    /// Patch space: (patch, parametric grid cell), view-independent, never across patches
    /// (AMFS as adapted in the tile-pair paper; a triangle is its own patch without ids).
    Patch,
    /// Texture space: (mesh, UV texel cell at a level from screen derivatives and normal
    /// variation), view-independent; needs a unique UV atlas (texel shading).
    Texture,
}

/// Shading-cache space and size, and the reuse shader's thresholds (screen space only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheConfig {
    pub space: CacheSpace,
    pub bytes: u32,
    pub reuse: ReuseTest,
}

/// Thresholds of the tile-pair reuse shader (Algorithm 2's THRESHOLD0..2, which the paper
/// leaves open): looser reuses more and costs quality, mostly in the right view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReuseTest {
    /// Largest position difference, as a fraction of the distance to the eye.
    pub position: f32,
    /// Largest difference of unit normals.
    pub normal: f32,
    /// Largest difference of `R · L` between the views (cross-view reuse only).
    pub r_dot_l: f32,
}

impl Default for ReuseTest {
    fn default() -> Self {
        ReuseTest {
            position: 0.01,
            normal: 0.1,
            r_dot_l: 0.05,
        }
    }
}

impl Default for MultirateConfig {
    fn default() -> Self {
        MultirateConfig {
            mode: CoarseMode::Coarse2x2,
            sampling: Sampling::CoverageBbox,
            small_triangle: true,
            thresholds: Thresholds::default(),
            schedule: SimdSchedule::TwoPhase,
            cache: None,
        }
    }
}
