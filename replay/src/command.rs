//! The commands of a job, in the manner of llvmpipe's bins of commands: a scheduler emits
//! `Draw` units and sequence boundaries; the pipeline adds a depth pre-pass, swaps `Draw` for
//! `Visibility` when the scheme shades after visibility, and appends one `ShadeTile` per tile
//! a screen pass runs on. A job's commands run in order on one worker with one scheme state.

/// One triangle rasterized into one tile of one view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unit {
    pub view: u8,
    pub tile: u32,
    /// Index into the view's setup triangles (submission order).
    pub tri: u32,
    /// The scheduler's own issue rank (e.g. the multi-view traversal position); only its
    /// `issue_key` reads it.
    pub rank: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// Rasterize, early-z, shade the surviving quads with the scheme, blend.
    Draw(Unit),
    /// Rasterize and depth-test only, writing depth of opaque surfaces: a z pre-pass. Its
    /// raster work is not counted (the shading pass counts it).
    DepthPrepass(Unit),
    /// Rasterize and depth-test, writing depth and visibility ids, no shading: the geometry
    /// pass of a scheme that shades after visibility. Counted as raster work.
    Visibility(Unit),
    /// The scheduler starts a group of units that may share shading (a tile-pair sequence);
    /// the scheme's caches restart here.
    BeginSequence,
    /// A screen pass over one tile of one view, after every geometry command of the tile.
    ShadeTile { view: u8, tile: u32 },
}

impl Command {
    /// The raster unit of a geometry command.
    pub fn unit(&self) -> Option<&Unit> {
        match self {
            Command::Draw(u) | Command::DepthPrepass(u) | Command::Visibility(u) => Some(u),
            Command::BeginSequence | Command::ShadeTile { .. } => None,
        }
    }
}

/// Commands run in order by one worker with one shading-scheme state; jobs run in parallel.
/// Every unit of a (view, tile) belongs to one job, which owns that tile's buffer.
#[derive(Clone, Debug, Default)]
pub struct Job {
    pub commands: Vec<Command>,
}

impl Job {
    /// Whether the job has no geometry.
    pub fn is_empty(&self) -> bool {
        self.commands.iter().all(|c| c.unit().is_none())
    }
}
