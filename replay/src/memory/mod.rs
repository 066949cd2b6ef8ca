//! The memory model: set-associative LRU caches with 256-byte lines in front of DRAM, and
//! the DRAM bytes per traffic class (ARCHITECTURE.md, Definitions).
//!
//! Work units record the cache lines they touch in an [`AccessLog`] while they run (in
//! parallel); the caches then replay all logs sequentially in the order the scheduler
//! issued the units, so traffic depends on the schedule and never on thread count.
//!
//! One structure in the log is not memory but a cache all the same: the memoization cache
//! of deferred attribute interpolation ([`Stream::Memo`]), keyed by triangle, whose misses
//! allocate the triangle buffer's slots. It replays first, in the same order, so that the
//! triangle buffer's reads ([`Stream::TriangleBuffer`]) go to the slots the stores chose.

mod framebuffer;

pub use framebuffer::{FramebufferLayout, RenderTarget};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
pub use shadetrace_formats::results::{CacheReport, CacheStats, Traffic};

pub const LINE_BYTES: u64 = 256;

/// Traffic classes of the caches below (the names results report them under).
pub const DEPTH_COLOR: &str = "depth_color";
pub const TRIANGLE_DATA: &str = "triangle_data";
pub const TEXTURE: &str = "texture";
/// Written and read only by deferred schemes' G-buffers (reported only where used).
pub const GBUFFER: &str = "gbuffer";
/// Written and read only by the visibility buffer (reported only where used).
pub const VISIBILITY: &str = "visibility";
/// The triangle buffer of deferred attribute interpolation (reported only where used).
pub const TRIANGLE_BUFFER: &str = "triangle_buffer";
/// The BVH of ray-traced hole filling: its nodes and triangles (reported only where used).
pub const BVH: &str = "bvh";
/// Bytes of one triangle in the triangle buffer (Schied and Dachsbacher §5): 1/w, normal
/// and uv, each with its x and y derivatives (18 floats), the material id and padding.
pub const TRIANGLE_RECORD_BYTES: u64 = 80;
/// The memoization cache's buckets hold two entries each (§4.1).
pub const MEMO_WAYS: u64 = 2;
/// Bytes of a memoization-cache entry (triangle id, buffer offset) and of a bucket's lock:
/// 2^13 entries take 80 KiB, the paper's figure.
pub const MEMO_ENTRY_BYTES: u64 = 8;
pub const MEMO_LOCK_BYTES: u64 = 4;
/// Associativity of every cache (fewer ways when a cache has fewer lines).
const WAYS: usize = 4;
/// Depth is compressed 4x and colour 2x on their way to DRAM (Seiler et al., as in the
/// tile-pair paper's bandwidth study).
const DEPTH_COMPRESSION: u64 = 4;
const COLOR_COMPRESSION: u64 = 2;

/// Which cache an access goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Stream {
    Depth = 0,
    Color = 1,
    TriangleData = 2,
    Texture = 3,
    /// A deferred scheme's G-buffer: a render target like colour, uncompressed.
    GBuffer = 4,
    /// The visibility buffer's triangle and instance ids per sample.
    Visibility = 5,
    /// Memoization-cache lookups of a triangle key ([`memo_key`]), not memory.
    Memo = 6,
    /// Reads of a stored triangle, logged by its [`memo_key`] and replayed at its slot.
    TriangleBuffer = 7,
    /// BVH nodes and triangles fetched by ray traversal.
    Bvh = 8,
}

/// The key a triangle is memoized and read under: its setup index in its view, and the view.
pub fn memo_key(view: u8, tri: u32) -> u64 {
    u64::from(tri) << 1 | u64::from(view & 1)
}

/// Log entries are 32-bit: a line number below [`REPEAT_BASE`] and a write bit. Every
/// stream's address space fits: the largest, texture, holds at most a trace's 4 GiB Textures
/// chunk with its mips and the shadow map, about 2^25 lines.
const STREAMS: usize = 9;
const WRITE_BIT: u32 = 1 << 31;
const LINE_MASK: u32 = WRITE_BIT - 1;
/// Line values from here up are counted repeats, not lines: "the stream's two previous
/// entries again, `value - REPEAT_BASE + 1` more times" ([`AccessLog::read_pair`]).
const REPEAT_BASE: u32 = LINE_MASK - 0xFFFF;
const REPEAT_MAX: u32 = LINE_MASK - REPEAT_BASE + 1;

/// A log entry's line and write bit.
#[inline]
fn decoded(entry: u32) -> (u64, bool) {
    (u64::from(entry & LINE_MASK), entry & WRITE_BIT != 0)
}

/// The repeats a log entry stands for, if it is a counted repeat.
#[inline]
fn repeat_count(entry: u32) -> Option<u64> {
    let value = entry & LINE_MASK;
    (value >= REPEAT_BASE).then(|| u64::from(value - REPEAT_BASE + 1))
}
/// The cache lines a job's commands touched: one growing list per stream (so each cache
/// replays only its own accesses), cut into segments, one per command that made accesses.
/// One log per job, reused from command to command: no allocation per unit.
#[derive(Clone, Debug)]
pub struct AccessLog {
    entries: [Vec<u32>; STREAMS],
    last: [u32; STREAMS],
    segments: Vec<Segment>,
    /// The mask of [`Self::texture_recent`]'s slots, when the log knows the texture cache
    /// and its sets are a power of two (as for every size a power of two in KiB): texture
    /// reads it can tell are hits are then counted ([`AccessLog::touch`]) instead of logged.
    texture_slot_mask: Option<u32>,
    /// Per slot (a texture cache set, or at most [`MRU_SLOTS`] sets sharing one), the two
    /// lines this command read or wrote there last, the most recent first, each under the
    /// command's segment number (`number << 32 | line`: an earlier command's is stale).
    /// Sets sharing a slot only displace each other's lines, which then are logged, not
    /// counted: still exact.
    texture_recent: Vec<[u64; 2]>,
    /// Whether the texture cache's sets hold two ways or more: a read of a slot's line
    /// before its most recent is then a hit too ([`AccessLog::touch`]).
    texture_second_hits: bool,
    /// One bit per slot: the slot's two recent lines were last read in the other order
    /// than the replay has them, by hits counted, not logged ([`AccessLog::touch`]).
    texture_reordered: [u64; MRU_SLOTS as usize / 64],
    /// Texture reads counted as hits, in all.
    texture_hits: u64,
    /// The texture cache's ways (0 where the log does not know the cache).
    texture_ways: usize,
    /// The last footprint read ([`AccessLog::read_runs`]) in this command, and how many
    /// texture entries were logged when it ended.
    last_footprint: Option<(Footprint, usize)>,
}

/// The most runs of reads in one footprint ([`AccessLog::read_runs`]).
const FOOTPRINT_RUNS: usize = 2;

/// The lines of a footprint's runs of reads ([`AccessLog::read_runs`]), and how many lines
/// that is (a line's sets counted apart).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Footprint {
    runs: [(u32, u32); FOOTPRINT_RUNS],
    len: usize,
    lines: usize,
}

impl Footprint {
    /// Whether `self`'s runs are the last runs of `other`'s.
    #[inline(always)]
    fn ends(&self, other: &Footprint) -> bool {
        // Unused runs are alike, so a footprint of as many runs compares whole.
        match other.len.checked_sub(self.len) {
            Some(0) => self.runs == other.runs,
            Some(skipped) => self.runs[..self.len] == other.runs[skipped..other.len],
            None => false,
        }
    }
}

/// Where one command's accesses start in each stream (and in the counted texture hits);
/// they end where the next segment starts.
#[derive(Clone, Copy, Debug)]
struct Segment {
    command: usize,
    start: [usize; STREAMS],
    texture_hits: u64,
}

impl Segment {
    /// Whether the segment starts where the log ends (it has no accesses yet).
    fn is_at(&self, entries: &[Vec<u32>; STREAMS], texture_hits: u64) -> bool {
        self.texture_hits == texture_hits && self.start.iter().zip(entries).all(|(&s, e)| s == e.len())
    }
}

impl Default for AccessLog {
    fn default() -> Self {
        AccessLog::new()
    }
}

impl AccessLog {
    /// A log whose first segment (command 0) has begun.
    pub fn new() -> Self {
        AccessLog {
            entries: Default::default(),
            last: [u32::MAX; STREAMS],
            segments: vec![Segment {
                command: 0,
                start: [0; STREAMS],
                texture_hits: 0,
            }],
            texture_slot_mask: None,
            texture_recent: Vec::new(),
            texture_second_hits: false,
            texture_reordered: [0; MRU_SLOTS as usize / 64],
            texture_hits: 0,
            texture_ways: 0,
            last_footprint: None,
        }
    }

    /// A log for a texture cache of `bytes`: reads of the line a command last touched in
    /// its set are counted hits, not entries. The log is replayed a command at a time, so
    /// within a command that line is still its set's most recent, and reading it changes
    /// no state: the counts are those of logging it. (Most of a pixel's texels are its
    /// neighbour's.) With two ways or more, so are reads of the line before it in its set,
    /// which only swap the two: the order is logged before the set's next logged access.
    /// (A shadow footprint over two block rows alternates between two lines of a set.)
    pub fn with_texture_cache(bytes: u64) -> Self {
        let mut log = AccessLog::new();
        log.reset(bytes);
        log
    }

    /// Empties the log for a texture cache of `bytes` ([`Self::with_texture_cache`]),
    /// keeping its buffers: a worker's next job logs into the capacity its last one grew.
    pub fn reset(&mut self, texture_cache_bytes: u64) {
        let shape = SetShape::of(texture_cache_bytes);
        self.texture_ways = shape.ways;
        self.texture_slot_mask = shape.set_mask.map(|mask| mask.min(MRU_SLOTS - 1) as u32);
        self.texture_second_hits = shape.ways >= 2;
        let slots = self.texture_slot_mask.map_or(0, |mask| mask as usize + 1);
        self.texture_recent.resize(slots, [0; 2]);
        self.clear();
    }

    /// Moves the accesses out into a log of exactly their size, leaving this one empty with
    /// its buffers ([`Self::reset`]): what a job hands to the memory replay.
    pub fn take(&mut self) -> AccessLog {
        self.settle_texture_order();
        let taken = AccessLog {
            entries: self.entries.each_ref().map(|entries| entries.as_slice().to_vec()),
            last: self.last,
            segments: self.segments.clone(),
            texture_slot_mask: self.texture_slot_mask,
            texture_recent: Vec::new(),
            texture_second_hits: self.texture_second_hits,
            texture_reordered: [0; MRU_SLOTS as usize / 64],
            texture_hits: self.texture_hits,
            texture_ways: self.texture_ways,
            last_footprint: None,
        };
        self.clear();
        taken
    }

    /// Starts the accesses of command `command` (an index its job knows it by). A previous
    /// segment without accesses is dropped, as if it had never begun.
    pub fn begin(&mut self, command: usize) {
        self.settle_texture_order();
        match self.segments.last_mut() {
            Some(last) if last.is_at(&self.entries, self.texture_hits) => last.command = command,
            _ => self.segments.push(Segment {
                command,
                start: self.entries.each_ref().map(Vec::len),
                texture_hits: self.texture_hits,
            }),
        }
        self.last = [u32::MAX; STREAMS];
        self.last_footprint = None;
    }

    /// Records an access; a repeat of the stream's previous access within the command is
    /// dropped (it is a hit that cannot change any LRU state), unless it upgrades a read to
    /// a write.
    #[inline(always)]
    pub fn touch(&mut self, stream: Stream, line: u64, write: bool) {
        debug_assert!(
            line < u64::from(REPEAT_BASE),
            "line {line} beyond the log's address space"
        );
        let entry = if write { WRITE_BIT } else { 0 } | (line as u32 & LINE_MASK);
        let s = stream as usize;
        let last = &mut self.last[s];
        if *last == entry || (!write && *last == entry | WRITE_BIT) {
            return;
        }
        *last = entry;
        if let (Stream::Texture, Some(mask)) = (stream, self.texture_slot_mask) {
            // Under the segment number, which entries of earlier commands never match.
            let stamped = (self.segments.len() as u64) << 32 | u64::from(line as u32);
            let slot = (line as u32 & mask) as usize;
            let [recent, before] = self.texture_recent[slot];
            if !write && recent == stamped {
                self.texture_hits += 1;
                return;
            }
            // The slot's line before (both this command's) is held with two ways or more:
            // the second most recent line of the set, whose read only swaps the two (or,
            // where sets share the slot, the most recent of another set, whose read changes
            // nothing). A hit: the replay is told the order before the slot's next logged
            // access ([`Self::settle_slot_order`]).
            if !write && before == stamped && self.texture_second_hits {
                self.texture_recent[slot] = [before, recent];
                self.texture_reordered[slot / 64] ^= 1 << (slot % 64);
                self.texture_hits += 1;
                // The last footprint's lines are no longer in the order it left them.
                self.last_footprint = None;
                return;
            }
            self.settle_slot_order(slot);
            self.texture_recent[slot] = [stamped, recent];
        }
        self.entries[s].push(entry);
    }

    /// Where the replay would have a slot's two recent lines in the other order, logs a
    /// read of the more recent (instead of counting the read that made it so: the
    /// set's other accesses since were counted hits of these two lines, so the set ends in
    /// the same state).
    #[inline]
    fn settle_slot_order(&mut self, slot: usize) {
        let word = &mut self.texture_reordered[slot / 64];
        if *word & 1 << (slot % 64) != 0 {
            *word &= !(1 << (slot % 64));
            self.texture_hits -= 1;
            let recent = self.texture_recent[slot][0] as u32 & LINE_MASK;
            self.entries[Stream::Texture as usize].push(recent);
        }
    }

    /// [`Self::settle_slot_order`] of every slot, as the command ends: the replay takes each
    /// command's accesses apart (other jobs' commands come between).
    fn settle_texture_order(&mut self) {
        for w in 0..self.texture_reordered.len() {
            while self.texture_reordered[w] != 0 {
                let bit = self.texture_reordered[w].trailing_zeros() as usize;
                self.settle_slot_order(w * 64 + bit);
            }
        }
    }

    /// Reads `a`, then `b`, `times` times over (`a b a b ...`): a filter footprint's rows
    /// that each span the same two lines. The same accesses as that many [`Self::touch`]
    /// pairs, logged as one pair and a counted repeat.
    pub fn read_pair(&mut self, stream: Stream, a: u64, b: u64, times: u32) {
        if times == 0 {
            return;
        }
        self.touch(stream, a, false);
        self.touch(stream, b, false);
        let mut rest = times - 1;
        let s = stream as usize;
        if rest > 0 && self.counts_pair(stream, a, b) {
            // What the reads below would do: each one a counted hit, `b` the last access.
            self.texture_hits += 2 * u64::from(rest);
            self.last[s] = b as u32 & LINE_MASK;
            return;
        }
        let entries = &self.entries[s];
        let start = self.segments.last().map_or(0, |segment| segment.start[s]);
        let n = entries.len();
        // The repeat stands for the two entries before it, which must be this pair, logged
        // in this command (a dropped repeat, a write, or `a == b` leaves others there).
        let logged = n >= start + 2 && entries[n - 2..] == [a as u32, b as u32];
        while logged && rest > 0 {
            let step = rest.min(REPEAT_MAX);
            self.entries[s].push(REPEAT_BASE + step - 1);
            rest -= step;
        }
        for _ in 0..rest {
            self.touch(stream, a, false);
            self.touch(stream, b, false);
        }
    }

    /// A filter footprint's texture reads, in runs, each at least once: `a b a b ...`
    /// `times` over ([`Self::read_pair`]), or `a` once where `b == a` (rows inside one line).
    ///
    /// A footprint read right after one whose runs end in its own (in the same command,
    /// with no texture access logged in between) hits on every read, as long as no set holds
    /// more of the earlier footprint's lines than the cache has ways: each set's most recent
    /// lines are then that footprint's. And it leaves the cache as it found it: a run ends
    /// on `a b` however many times it repeats, and the earlier footprint's last runs were
    /// these, so the lines' last reads come in the same order. Such a footprint is counted,
    /// not logged, and the earlier one stays the one to compare with. (Neighbouring pixels'
    /// shadow footprints mostly lie in the same blocks.)
    #[inline(always)]
    pub fn read_runs(&mut self, runs: &[(u64, u64, u32)]) {
        assert!(runs.len() <= FOOTPRINT_RUNS, "a footprint of {} runs", runs.len());
        debug_assert!(runs.iter().all(|run| run.2 > 0), "an empty run");
        let s = Stream::Texture as usize;
        let mut footprint = Footprint {
            runs: [(u32::MAX, u32::MAX); FOOTPRINT_RUNS],
            len: runs.len(),
            lines: 0,
        };
        for (i, &(a, b, _)) in runs.iter().enumerate() {
            footprint.runs[i] = (a as u32 & LINE_MASK, b as u32 & LINE_MASK);
            footprint.lines += 1 + usize::from(a != b);
        }
        let logged = self.entries[s].len();
        // A match, not a closure: the compiler left the closure out of line.
        let repeats = match self.last_footprint {
            Some((last, at)) => at == logged && last.lines <= self.texture_ways && footprint.ends(&last),
            None => false,
        };
        if repeats {
            // What the reads would do: each one a counted hit, but for a run's first read
            // that repeats the access before it, which the log drops.
            let mut previous = self.last[s];
            for (i, &(_, _, times)) in runs.iter().enumerate() {
                let (a, b) = footprint.runs[i];
                let dropped = previous == a || previous == a | WRITE_BIT;
                let reads = if a == b { 1 } else { 2 * u64::from(times) };
                self.texture_hits += reads - u64::from(dropped);
                previous = b;
            }
            self.last[s] = previous;
            return;
        }
        for &(a, b, times) in runs {
            match a == b {
                true => self.touch(Stream::Texture, a, false),
                false => self.read_pair(Stream::Texture, a, b, times),
            }
        }
        self.last_footprint = Some((footprint, self.entries[s].len()));
    }

    /// Whether reading `a` and then `b` again, right after touching them, counts both as
    /// hits: texture lines, distinct, in different slots of the table (so in different
    /// sets). A line just touched is its slot's most recent in this command (logged, a hit
    /// on it, or a swap that made it so), and the other's touch left it so.
    fn counts_pair(&self, stream: Stream, a: u64, b: u64) -> bool {
        let (Stream::Texture, Some(mask)) = (stream, self.texture_slot_mask) else {
            return false;
        };
        let (a, b) = (a as u32, b as u32);
        a != b && (a ^ b) & mask != 0
    }

    /// The segments that made accesses: (segment index, command index), in order. Only the
    /// last can be empty ([`Self::begin`] reuses an empty one). The replay reads a log
    /// handed on by [`Self::take`], whose sets' orders are settled.
    pub fn segments(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        debug_assert!(
            self.texture_reordered.iter().all(|&w| w == 0),
            "a log read with reads out of order not logged"
        );
        let open_empty = self
            .segments
            .last()
            .is_some_and(|last| last.is_at(&self.entries, self.texture_hits));
        self.segments[..self.segments.len() - usize::from(open_empty)]
            .iter()
            .enumerate()
            .map(|(i, seg)| (i, seg.command))
    }

    /// Stream `s`'s accesses of segment `i`.
    pub(crate) fn stream(&self, i: usize, s: usize) -> &[u32] {
        let start = self.segments[i].start[s];
        let end = self
            .segments
            .get(i + 1)
            .map_or(self.entries[s].len(), |next| next.start[s]);
        &self.entries[s][start..end]
    }

    /// The texture reads of segment `i` counted as hits.
    fn texture_hits(&self, i: usize) -> u64 {
        let end = self
            .segments
            .get(i + 1)
            .map_or(self.texture_hits, |next| next.texture_hits);
        end - self.segments[i].texture_hits
    }

    /// Stream `s`'s accesses of segment `i` with every counted repeat written out: what
    /// the log stands for.
    #[cfg(test)]
    pub(crate) fn expanded(&self, i: usize, stream: Stream) -> Vec<u32> {
        let mut out: Vec<u32> = Vec::new();
        for &entry in self.stream(i, stream as usize) {
            match repeat_count(entry) {
                Some(times) => {
                    let pair = [out[out.len() - 2], out[out.len() - 1]];
                    (0..times).for_each(|_| out.extend(pair));
                }
                None => out.push(entry),
            }
        }
        out
    }

    pub fn len(&self) -> usize {
        self.entries.iter().map(Vec::len).sum()
    }

    /// Forgets every access, keeping the allocation (a log kept only to satisfy code that
    /// logs, e.g. a measurement that is not replayed).
    pub fn clear(&mut self) {
        self.entries.iter_mut().for_each(Vec::clear);
        self.last = [u32::MAX; STREAMS];
        self.segments.truncate(1);
        self.segments[0] = Segment {
            command: 0,
            start: [0; STREAMS],
            texture_hits: 0,
        };
        // Stamps carry the segment number, which starts again at 1: none may survive.
        self.texture_recent.fill([0; 2]);
        self.texture_reordered.fill(0);
        self.texture_hits = 0;
        self.last_footprint = None;
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Slots of a log's texture table at most: a job's log stays small whatever the cache.
const MRU_SLOTS: u64 = 256;

/// One command's accesses: a log and one of its segments.
pub type LogSegment<'a> = (&'a AccessLog, usize);

/// Every stream's accesses in replay order, as the segments' non-empty runs, and the texture
/// reads the logs counted as hits. Gathered in one pass over the segments: replay order
/// jumps between jobs' logs, so a segment's bounds are a cache miss, paid here once instead
/// of once per stream and part.
#[derive(Default)]
struct StreamRuns<'a> {
    runs: [Vec<&'a [u32]>; STREAMS],
    texture_hits: u64,
}

/// Segments per parallel work item of [`StreamRuns::gather`] (fixed, so that nothing
/// depends on the thread count).
const GATHER_CHUNK: usize = 8192;

impl<'a> StreamRuns<'a> {
    /// Chunks of segments are gathered in parallel (their misses overlap) and joined in order.
    fn gather(segments: &[LogSegment<'a>]) -> StreamRuns<'a> {
        let chunks: Vec<StreamRuns<'a>> = segments
            .par_chunks(GATHER_CHUNK)
            .map(StreamRuns::gather_serial)
            .collect();
        let mut gathered = StreamRuns::default();
        for chunk in chunks {
            gathered.texture_hits += chunk.texture_hits;
            for (runs, chunk_runs) in gathered.runs.iter_mut().zip(chunk.runs) {
                runs.extend(chunk_runs);
            }
        }
        gathered
    }

    fn gather_serial(segments: &[LogSegment<'a>]) -> StreamRuns<'a> {
        let mut gathered = StreamRuns::default();
        for &(log, i) in segments {
            gathered.texture_hits += log.texture_hits(i);
            for (s, runs) in gathered.runs.iter_mut().enumerate() {
                let run = log.stream(i, s);
                if !run.is_empty() {
                    runs.push(run);
                }
            }
        }
        gathered
    }

    fn of(&self, stream: Stream) -> &[&'a [u32]] {
        &self.runs[stream as usize]
    }
}

/// Cache sizes in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheSizes {
    pub depth: u64,
    pub color: u64,
    pub triangle_data: u64,
    pub texture: u64,
    pub gbuffer: u64,
    pub visibility: u64,
    pub triangle_buffer: u64,
    pub bvh: u64,
    /// Entries of the memoization cache (0: none).
    pub memo_entries: u64,
}

/// One set-associative LRU cache, or the part of one that holds the sets `part` of
/// `parts` (a set's state depends only on the lines that map to it, so parts of a cache
/// replay the same accesses independently and their counts add up to the whole's).
struct Cache {
    shape: SetShape,
    part: u64,
    parts: u64,
    /// `sets * ways` slots: `line + 1` (0 = empty) with [`DIRTY`] set when written, most
    /// recently used first within a set.
    slots: Vec<u64>,
    stats: CacheStats,
}

/// A cache's sets and ways, and which set a line maps to.
#[derive(Clone, Copy, Debug)]
struct SetShape {
    sets: u64,
    ways: usize,
    /// `sets - 1` when `sets` is a power of two, for a mask instead of a division.
    set_mask: Option<u64>,
}

impl SetShape {
    /// The shape of a cache of `bytes`: [`WAYS`] ways (fewer when it has fewer lines).
    fn of(bytes: u64) -> SetShape {
        let lines = (bytes / LINE_BYTES).max(1) as usize;
        let ways = WAYS.min(lines);
        SetShape::new((lines / ways).max(1) as u64, ways)
    }

    fn new(sets: u64, ways: usize) -> SetShape {
        SetShape {
            sets,
            ways,
            set_mask: sets.is_power_of_two().then_some(sets - 1),
        }
    }

    #[inline]
    fn set_of(&self, line: u64) -> u64 {
        match self.set_mask {
            Some(mask) => line & mask,
            None => line % self.sets,
        }
    }
}

/// The sets of one part of a cache and their shape, apart from the cache's state.
#[derive(Clone, Copy)]
struct PartFilter {
    shape: SetShape,
    part: u64,
    parts: u64,
}

impl PartFilter {
    /// Whether `line` maps to a set of the part (`parts` is a power of two).
    #[inline]
    fn holds(&self, line: u64) -> bool {
        self.parts == 1 || self.shape.set_of(line) & (self.parts - 1) == self.part
    }

    /// Whether reading `a` and `b` again, right after reading them, hits twice and leaves
    /// every set as it was: they are the two most recent lines of their set (or each the
    /// most recent of its own), unless one way holds a set they share.
    fn repeats_hit(&self, a: u64, b: u64) -> bool {
        self.shape.ways >= 2 || self.shape.set_of(a) != self.shape.set_of(b)
    }
}

/// A slot's dirty bit (tags stay below 2^61).
const DIRTY: u64 = 1 << 63;

impl Cache {
    #[cfg(test)]
    fn new(bytes: u64) -> Cache {
        Cache::part(bytes, 0, 1)
    }

    fn part(bytes: u64, part: u64, parts: u64) -> Cache {
        Cache::shaped(SetShape::of(bytes), part, parts)
    }

    fn shaped(shape: SetShape, part: u64, parts: u64) -> Cache {
        debug_assert!(parts.is_power_of_two() && part < parts);
        Cache {
            shape,
            part,
            parts,
            slots: vec![0; shape.sets as usize * shape.ways],
            stats: CacheStats::default(),
        }
    }

    /// Which lines map to the sets this part holds, and the shape that decides repeats.
    fn part_filter(&self) -> PartFilter {
        PartFilter {
            shape: self.shape,
            part: self.part,
            parts: self.parts,
        }
    }

    /// Accesses `line`; returns (miss, evicted dirty line).
    #[inline]
    fn access(&mut self, line: u64, write: bool) -> (bool, bool) {
        self.stats.accesses += 1;
        let ways = self.shape.ways;
        let base = self.shape.set_of(line) as usize * ways;
        let (tag, dirty) = (line + 1, if write { DIRTY } else { 0 });
        // Every cache of [`WAYS`] ways (all but the smallest) goes through a set of known
        // length, whose search and shift the compiler unrolls.
        let evicted = match <&mut [u64; WAYS]>::try_from(&mut self.slots[base..base + ways]) {
            Ok(set) => move_to_front(set, tag, dirty),
            Err(_) => move_to_front(&mut self.slots[base..base + ways], tag, dirty),
        };
        let Some(moved) = evicted else {
            return (false, false);
        };
        self.stats.misses += 1;
        let evicted_dirty = moved != 0 && moved & DIRTY != 0;
        if evicted_dirty {
            self.stats.writebacks += 1;
        }
        (true, evicted_dirty)
    }

    /// Writes back every dirty line (end of frame); returns how many.
    fn flush(&mut self) -> u64 {
        let n = self.slots.iter().filter(|&&s| s & DIRTY != 0).count() as u64;
        self.slots.iter_mut().for_each(|s| *s &= !DIRTY);
        self.stats.writebacks += n;
        n
    }
}

/// Looks `tag` up in a set's slots (most recently used first) and moves it to the front,
/// marked `dirty` when written: None on a hit, else the slot the miss evicted. Inlined, so
/// that a set of known length is searched and shifted without a loop.
#[inline(always)]
fn move_to_front(slots: &mut [u64], tag: u64, dirty: u64) -> Option<u64> {
    // A hit on the most recently used line changes nothing but its dirty bit: the common
    // case (a texture footprint alternates between lines of different sets).
    if slots[0] & !DIRTY == tag {
        slots[0] |= dirty;
        return None;
    }
    // Move to front: the slots before the hit (or all but the last, on a miss) shift back
    // by one.
    let hit = slots.iter().position(|&s| s & !DIRTY == tag);
    let last = hit.unwrap_or(slots.len() - 1);
    let moved = slots[last];
    // A loop, not `copy_within`: a shift of at most three slots is cheaper than a call to
    // `memmove`.
    for i in (1..=last).rev() {
        slots[i] = slots[i - 1];
    }
    match hit {
        Some(_) => {
            slots[0] = moved | dirty;
            None
        }
        None => {
            slots[0] = tag | dirty;
            Some(moved)
        }
    }
}

/// A growable bit set over line numbers (framebuffer addresses are dense from 0).
#[derive(Default)]
struct LineSet(Vec<u64>);

impl LineSet {
    fn insert(&mut self, line: u64) {
        let word = (line / 64) as usize;
        if word >= self.0.len() {
            self.0.resize(word + 1, 0);
        }
        self.0[word] |= 1 << (line % 64);
    }

    fn contains(&self, line: u64) -> bool {
        self.0
            .get((line / 64) as usize)
            .is_some_and(|w| w & (1 << (line % 64)) != 0)
    }
}

/// What one frame's replay gives.
#[derive(Debug, PartialEq)]
pub struct Replayed {
    pub traffic: Traffic,
    pub caches: CacheReport,
    /// The memoization cache, when the frame looked triangles up in one.
    pub memo: Option<MemoOutcome>,
}

/// The memoization cache's replay, per view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoOutcome {
    /// Lookups that missed: each stored its triangle in a new slot.
    pub misses: [u64; 2],
    /// Misses on a triangle stored before (evicted since).
    pub redundant: [u64; 2],
}

/// The triangle buffer's slots: where each key was first stored.
struct Slots(Vec<u32>);

impl Slots {
    const NONE: u32 = u32::MAX;

    /// The lines holding the record of `key` (a record may straddle two), if it was stored.
    fn lines(&self, key: u64) -> Option<(u64, u64)> {
        let slot = *self.0.get(key as usize)?;
        (slot != Slots::NONE).then(|| {
            let start = u64::from(slot) * TRIANGLE_RECORD_BYTES;
            (start / LINE_BYTES, (start + TRIANGLE_RECORD_BYTES - 1) / LINE_BYTES)
        })
    }
}

/// Replays the memoization cache (one part: its misses allocate slots in order).
fn replay_memo(entries: u64, runs: &[&[u32]]) -> (MemoOutcome, Slots, CacheStats) {
    let ways = MEMO_WAYS as usize;
    let mut cache = Cache::shaped(SetShape::new((entries / MEMO_WAYS).max(1), ways), 0, 1);
    let mut outcome = MemoOutcome::default();
    let mut slots = Slots(Vec::new());
    let mut next = 0u32;
    for run in runs {
        for &entry in *run {
            let key = u64::from(entry & LINE_MASK);
            if !cache.access(key, false).0 {
                continue;
            }
            let view = (key & 1) as usize;
            outcome.misses[view] += 1;
            let k = key as usize;
            if k >= slots.0.len() {
                slots.0.resize(k + 1, Slots::NONE);
            }
            if slots.0[k] == Slots::NONE {
                slots.0[k] = next;
            } else {
                outcome.redundant[view] += 1;
            }
            next = next.saturating_add(1);
        }
    }
    (outcome, slots, cache.stats)
}

/// Replays the accesses of one frame, segment by segment in the given order, through
/// fresh caches, on up to `threads` threads (the counts do not depend on how many).
pub fn simulate(sizes: CacheSizes, segments: &[LogSegment], threads: usize) -> Replayed {
    let runs = StreamRuns::gather(segments);
    // Streams without an entry replay nothing: their caches are skipped.
    let used: [bool; STREAMS] = std::array::from_fn(|s| !runs.runs[s].is_empty());
    let (memo, slots, memo_stats) = if used[Stream::Memo as usize] {
        replay_memo(sizes.memo_entries, runs.of(Stream::Memo))
    } else {
        (MemoOutcome::default(), Slots(Vec::new()), CacheStats::default())
    };
    // The caches are independent: each replays its own stream of the same order, in parts
    // of its sets, one task per stream and part (the counts do not depend on how many). A
    // part still reads its whole stream, so halving the sets saved only a tenth of a
    // stream's time (measured): parts only from four threads on. Two threads replay the
    // texture stream on one and the others on the other.
    // A power of two, so that a set's part is a mask of its index.
    let parts = 1u64 << (threads / 2).max(1).ilog2();
    let run_part = |stream: Stream, bytes: u64, part: u64| {
        if !used[stream as usize] {
            return (0, 0, CacheStats::default());
        }
        let mut cache = Cache::part(bytes, part, parts);
        let filter = cache.part_filter();
        let mut written = LineSet::default();
        let mut dram_lines = 0u64;
        let mut writebacks = 0u64;
        let framebuffer = matches!(
            stream,
            Stream::Depth | Stream::Color | Stream::GBuffer | Stream::Visibility
        );
        let mut access = |(line, write): (u64, bool)| {
            let (miss, evicted_dirty) = cache.access(line, write);
            if miss {
                if framebuffer && !written.contains(line) {
                    cache.stats.cleared_fills += 1;
                } else {
                    dram_lines += 1;
                }
            }
            if evicted_dirty {
                writebacks += 1;
            }
            if write {
                written.insert(line);
            }
        };
        // The stream's two previous entries, which a counted repeat repeats.
        let mut pair = [0u32; 2];
        // Hits counted rather than replayed: the repeats this part decides, and (in one
        // part) the texture reads the logs counted.
        let mut counted_hits = if stream == Stream::Texture && part == 0 {
            runs.texture_hits
        } else {
            0
        };
        let mut held = [0u32; 256];
        for &entries in runs.of(stream) {
            if stream == Stream::TriangleBuffer {
                for &entry in entries {
                    let write = entry & WRITE_BIT != 0;
                    if let Some((first, last)) = slots.lines(u64::from(entry & LINE_MASK)) {
                        (first..=last)
                            .filter(|&l| filter.holds(l))
                            .for_each(|l| access((l, write)));
                    }
                }
                continue;
            }
            // With parts, this part's entries are picked without a branch per entry (half
            // of them would mispredict), then replayed.
            let mut n = 0;
            for &entry in entries {
                if let Some(times) = repeat_count(entry) {
                    let [a, b] = pair.map(|e| u64::from(e & LINE_MASK));
                    if filter.repeats_hit(a, b) {
                        counted_hits += times * (u64::from(filter.holds(a)) + u64::from(filter.holds(b)));
                        continue;
                    }
                    for &e in &held[..n] {
                        access(decoded(e));
                    }
                    n = 0;
                    for _ in 0..times {
                        for e in pair.into_iter().filter(|&e| filter.holds(u64::from(e & LINE_MASK))) {
                            access(decoded(e));
                        }
                    }
                    continue;
                }
                pair = [pair[1], entry];
                if parts == 1 {
                    access(decoded(entry));
                    continue;
                }
                held[n] = entry;
                n += usize::from(filter.holds(u64::from(entry & LINE_MASK)));
                if n == held.len() {
                    for &e in &held {
                        access(decoded(e));
                    }
                    n = 0;
                }
            }
            for &e in &held[..n] {
                access(decoded(e));
            }
        }
        cache.stats.accesses += counted_hits;
        writebacks += cache.flush();
        (dram_lines, writebacks, cache.stats)
    };
    const REPLAYED: [Stream; 8] = [
        Stream::Depth,
        Stream::Color,
        Stream::TriangleData,
        Stream::Texture,
        Stream::GBuffer,
        Stream::Visibility,
        Stream::TriangleBuffer,
        Stream::Bvh,
    ];
    let bytes = |stream: Stream| match stream {
        Stream::Depth => sizes.depth,
        Stream::Color => sizes.color,
        Stream::TriangleData => sizes.triangle_data,
        Stream::Texture => sizes.texture,
        Stream::GBuffer => sizes.gbuffer,
        Stream::Visibility => sizes.visibility,
        Stream::TriangleBuffer | Stream::Memo => sizes.triangle_buffer,
        Stream::Bvh => sizes.bvh,
    };
    // One task per stream and part (the texture stream first: it is the longest).
    let mut tasks: Vec<(usize, u64)> = (0..REPLAYED.len())
        .flat_map(|s| (0..parts).map(move |part| (s, part)))
        .collect();
    tasks.sort_by_key(|&(s, _)| REPLAYED[s] != Stream::Texture);
    let results: Vec<(u64, u64, CacheStats)> = tasks
        .par_iter()
        .with_max_len(1)
        .map(|&(s, part)| run_part(REPLAYED[s], bytes(REPLAYED[s]), part))
        .collect();
    let [depth, color, tri, tex, gbuffer, visibility, triangle_buffer, bvh] = std::array::from_fn(|s| {
        results.iter().zip(&tasks).filter(|(_, &(stream, _))| stream == s).fold(
            (0, 0, CacheStats::default()),
            |(d, w, mut stats), ((pd, pw, ps), _)| {
                stats.add(ps);
                (d + pd, w + pw, stats)
            },
        )
    });
    let mut traffic = Traffic::default();
    traffic.add_bytes(
        DEPTH_COLOR,
        (depth.0 + depth.1) * LINE_BYTES / DEPTH_COMPRESSION + (color.0 + color.1) * LINE_BYTES / COLOR_COMPRESSION,
    );
    traffic.add_bytes(TRIANGLE_DATA, (tri.0 + tri.1) * LINE_BYTES);
    traffic.add_bytes(TEXTURE, (tex.0 + tex.1) * LINE_BYTES);
    let used = |stats: &CacheStats| stats.accesses > 0;
    for (class, replayed) in [
        (GBUFFER, &gbuffer),
        (VISIBILITY, &visibility),
        (TRIANGLE_BUFFER, &triangle_buffer),
        (BVH, &bvh),
    ] {
        if used(&replayed.2) {
            traffic.add_bytes(class, (replayed.0 + replayed.1) * LINE_BYTES);
        }
    }
    let caches = CacheReport {
        depth: depth.2,
        color: color.2,
        triangle_data: tri.2,
        texture: tex.2,
        gbuffer: used(&gbuffer.2).then_some(gbuffer.2),
        visibility: used(&visibility.2).then_some(visibility.2),
        triangle_buffer: used(&triangle_buffer.2).then_some(triangle_buffer.2),
        bvh: used(&bvh.2).then_some(bvh.2),
    };
    Replayed {
        traffic,
        caches,
        memo: used(&memo_stats).then_some(memo),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One-line framebuffer, triangle and texture caches; 4 KiB for the others.
    fn tiny_caches(memo_entries: u64) -> CacheSizes {
        CacheSizes {
            depth: LINE_BYTES,
            color: LINE_BYTES,
            triangle_data: LINE_BYTES,
            texture: LINE_BYTES,
            gbuffer: 4096,
            visibility: 4096,
            triangle_buffer: 4096,
            bvh: 4096,
            memo_entries,
        }
    }

    fn log(entries: &[(Stream, u64, bool)]) -> AccessLog {
        let mut l = AccessLog::new();
        l.begin(0);
        for &(s, line, w) in entries {
            l.touch(s, line, w);
        }
        l
    }

    #[test]
    fn lru_within_a_set() {
        let mut c = Cache::new(4 * LINE_BYTES); // one set, four ways
        for line in [1, 2, 3, 4, 1, 5, 2] {
            c.access(line, false);
        }
        // 1,2,3,4 miss; 1 hits; 5 evicts 2 (LRU); 2 misses again.
        assert_eq!(c.stats.misses, 6);
    }

    #[test]
    fn fast_clear_and_writebacks() {
        let sizes = tiny_caches(0);
        // Depth line 7 written, evicted by 8, read again: one writeback, one real fill.
        let l = log(&[
            (Stream::Depth, 7, true),
            (Stream::Depth, 8, false),
            (Stream::Depth, 7, false),
        ]);
        let Replayed {
            traffic,
            caches: report,
            ..
        } = simulate(sizes, &[(&l, 0)], 1);
        assert_eq!(report.depth.misses, 3);
        assert_eq!(report.depth.cleared_fills, 2);
        assert_eq!(report.depth.writebacks, 1);
        assert_eq!(traffic.bytes(DEPTH_COLOR), 2 * LINE_BYTES / DEPTH_COMPRESSION);
        let t = log(&[
            (Stream::Texture, 1, false),
            (Stream::Texture, 1, false),
            (Stream::Texture, 2, false),
        ]);
        let traffic = simulate(sizes, &[(&t, 0)], 1).traffic;
        assert_eq!(traffic.bytes(TEXTURE), 2 * LINE_BYTES);
    }

    #[test]
    fn memo_misses_allocate_the_slots_the_triangle_buffer_is_read_at() {
        // Two buckets of two: keys 0, 2, 4 share bucket 0, so 4 evicts 0 (LRU) and the
        // second lookup of 0 stores it again.
        let l = log(&[
            (Stream::Memo, 0, false),
            (Stream::Memo, 2, false),
            (Stream::Memo, 4, false),
            (Stream::Memo, 0, false),
            (Stream::Memo, 3, false),
            (Stream::TriangleBuffer, 4, false),
            (Stream::TriangleBuffer, 3, false),
        ]);
        let sizes = tiny_caches(4);
        let replayed = simulate(sizes, &[(&l, 0)], 1);
        let memo = replayed.memo.expect("lookups were logged");
        assert_eq!(memo.misses, [4, 1]);
        assert_eq!(memo.redundant, [1, 0]);
        // Key 4 sits in slot 2 (bytes 160..240, line 0), key 3 in slot 4 (320..400: line 1).
        let tb = replayed.caches.triangle_buffer.expect("read");
        assert_eq!((tb.accesses, tb.misses), (2, 2));
        assert_eq!(replayed.traffic.bytes(TRIANGLE_BUFFER), 2 * LINE_BYTES);
        // A record across a line boundary is two lines: slot 3 is bytes 240..320.
        assert_eq!(Slots(vec![0, 1, 2, 3]).lines(3), Some((0, 1)));
        assert_eq!(Slots(vec![0]).lines(5), None);
    }

    #[test]
    fn counts_do_not_depend_on_how_many_parts_replay_a_cache() {
        // A pseudo-random mix of reads and writes over a few hundred lines, in two segments.
        let mut l = AccessLog::new();
        let mut x = 12345u64;
        for command in 0..2 {
            l.begin(command);
            for _ in 0..5000 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let stream = [
                    Stream::Depth,
                    Stream::Color,
                    Stream::TriangleData,
                    Stream::Texture,
                    Stream::GBuffer,
                    Stream::Memo,
                    Stream::TriangleBuffer,
                ][(x >> 60) as usize % 7];
                l.touch(stream, (x >> 33) % 300, x >> 20 & 1 == 1);
            }
        }
        let sizes = CacheSizes {
            depth: 8 * LINE_BYTES,
            color: 12 * LINE_BYTES, // 3 sets: not a power of two
            triangle_data: LINE_BYTES,
            texture: 64 * LINE_BYTES,
            gbuffer: 4096,
            visibility: 4096,
            triangle_buffer: 4096,
            bvh: 4096,
            memo_entries: 64,
        };
        let segments: Vec<LogSegment> = l.segments().map(|(i, _)| (&l, i)).collect();
        let with = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| simulate(sizes, &segments, threads))
        };
        let one = with(1);
        for threads in [2, 3, 4, 8, 16] {
            assert_eq!(with(threads), one, "{threads} threads");
        }
    }

    /// A counted repeat replays as the pairs it stands for: on every cache shape (one line,
    /// so one way shared by the pair; sets not a power of two; pairs in one set and in two),
    /// with any number of parts, and where its pair was partly dropped or written.
    #[test]
    fn repeated_pairs_replay_as_the_pairs_written_out() {
        let mut x = 99u64;
        let mut next = |n: u64| {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (x >> 33) % n
        };
        let (mut counted, mut literal) = (AccessLog::new(), AccessLog::new());
        for command in 0..3 {
            counted.begin(command);
            literal.begin(command);
            for _ in 0..3000 {
                let (a, b, times) = (next(200), next(200), next(6) as u32);
                counted.read_pair(Stream::Texture, a, b, times);
                for _ in 0..times {
                    literal.touch(Stream::Texture, a, false);
                    literal.touch(Stream::Texture, b, false);
                }
                if next(4) == 0 {
                    let (line, write) = (next(200), next(2) == 1);
                    counted.touch(Stream::Texture, line, write);
                    literal.touch(Stream::Texture, line, write);
                }
            }
        }
        // More repeats than one counted entry holds.
        counted.read_pair(Stream::Texture, 7, 8, REPEAT_MAX + 5);
        for _ in 0..REPEAT_MAX + 5 {
            literal.touch(Stream::Texture, 7, false);
            literal.touch(Stream::Texture, 8, false);
        }
        assert!(counted.len() < literal.len(), "no repeat was counted");
        for lines in [1, 2, 12, 64] {
            let sizes = CacheSizes {
                texture: lines * LINE_BYTES,
                ..tiny_caches(0)
            };
            let replay = |log: &AccessLog, threads| {
                let segments: Vec<LogSegment> = log.segments().map(|(i, _)| (log, i)).collect();
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| simulate(sizes, &segments, threads))
            };
            let expected = replay(&literal, 1);
            for threads in [1, 2, 4, 8] {
                assert_eq!(replay(&counted, threads), expected, "{lines} lines, {threads} threads");
            }
        }
    }

    /// A log that knows the texture cache counts the reads it can tell are hits, and they
    /// replay as the reads logged: on every shape (one set; sets not a power of two, where
    /// it counts none but repeated footprints; more sets than the log's table has slots;
    /// fewer lines than a footprint has), with another job's commands replayed between a
    /// log's (a line read in its previous command is not assumed still there), with writes,
    /// counted repeats, footprints' lines (all or some of their runs) read again, a set's
    /// lines read again out of their order, and a log cleared and reused.
    #[test]
    fn texture_hits_the_log_counts_replay_as_the_reads_logged() {
        // (cache lines, lines touched)
        for (lines, span) in [(1u64, 5u64), (2, 8), (8, 26), (12, 38), (64, 194), (4096, 600)] {
            let bytes = lines * LINE_BYTES;
            let mut x = 7u64;
            let mut next = |n: u64| {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (x >> 33) % n
            };
            // Two jobs' logs, each logged by a log that knows the cache and by one that does not.
            let mut knowing = [0, 1].map(|_| AccessLog::with_texture_cache(bytes));
            let mut plain = [0, 1].map(|_| AccessLog::new());
            let mut replays = Vec::new();
            // Per job, the last footprint read.
            let mut footprints = [Vec::new(), Vec::new()];
            for (round, commands) in [1, 4].into_iter().enumerate() {
                for command in 0..commands {
                    for job in 0..2 {
                        let (knowing, plain) = (&mut knowing[job], &mut plain[job]);
                        let footprint = &mut footprints[job];
                        knowing.begin(command);
                        plain.begin(command);
                        // The previous command's last footprint first: not a repeat, the other
                        // job's command is replayed in between.
                        knowing.read_runs(footprint);
                        plain.read_runs(footprint);
                        for _ in 0..3000 {
                            let line = next(span);
                            match next(10) {
                                // A footprint: one or two runs of one or two lines, the second
                                // run's lines often in the first's sets.
                                3 => {
                                    let b = if next(3) == 0 { line } else { line + 1 };
                                    let step = [1, lines.next_power_of_two(), 2 * lines][next(3) as usize];
                                    *footprint = vec![(line, b, 1 + next(5) as u32)];
                                    if next(2) == 0 {
                                        footprint.push((line + step, b + step, 1 + next(4) as u32));
                                    }
                                    knowing.read_runs(footprint);
                                    plain.read_runs(footprint);
                                }
                                // The last footprint's lines again, often right after
                                // it, each run as many times over or not; or only its
                                // first or its last run.
                                4 => {
                                    footprint.iter_mut().for_each(|run| run.2 = 1 + next(5) as u32);
                                    let part = match (next(3), footprint.len()) {
                                        (1, 2) => &footprint[..1],
                                        (2, 2) => &footprint[1..],
                                        _ => &footprint[..],
                                    };
                                    knowing.read_runs(part);
                                    plain.read_runs(part);
                                }
                                0 => {
                                    let (b, times) = (next(span), next(5) as u32);
                                    knowing.read_pair(Stream::Texture, line, b, times);
                                    plain.read_pair(Stream::Texture, line, b, times);
                                }
                                1 => {
                                    knowing.touch(Stream::Texture, line, true);
                                    plain.touch(Stream::Texture, line, true);
                                }
                                2 => {
                                    knowing.touch(Stream::Depth, line, false);
                                    plain.touch(Stream::Depth, line, false);
                                }
                                _ => {
                                    knowing.touch(Stream::Texture, line, false);
                                    plain.touch(Stream::Texture, line, false);
                                }
                            }
                        }
                        knowing.read_runs(footprint);
                        plain.read_runs(footprint);
                    }
                }
                // Handed on as a job hands its log to the replay.
                let taken = knowing.each_mut().map(AccessLog::take);
                let length = |logs: &[AccessLog; 2]| logs.iter().map(AccessLog::len).sum::<usize>();
                // One set's most recent line is the stream's previous access, which every
                // log drops.
                if SetShape::of(bytes).sets > 1 {
                    assert!(length(&taken) < length(&plain), "{lines} lines: no hit was counted");
                }
                let sizes = CacheSizes {
                    texture: bytes,
                    ..tiny_caches(0)
                };
                // The jobs' commands interleaved, as the issue order puts them, and all of
                // them twice over: every command's last state then meets later accesses.
                let replay = |logs: &[AccessLog; 2], threads| {
                    let segments: Vec<LogSegment> = (0..2 * commands)
                        .flat_map(|i| [(&logs[0], i % commands), (&logs[1], i % commands)])
                        .collect();
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    pool.install(|| simulate(sizes, &segments, threads))
                };
                let expected = replay(&plain, 1);
                for threads in [1, 2, 4, 8] {
                    assert_eq!(
                        replay(&taken, threads),
                        expected,
                        "{lines} lines, round {round}, {threads} threads"
                    );
                }
                replays.push(expected);
                knowing.iter_mut().chain(&mut plain).for_each(AccessLog::clear);
            }
            assert_ne!(replays[0], replays[1]);
        }
    }

    /// A set's lines read out of the order the log last logged them (counted hits) are
    /// logged in their order before another command's accesses replay: whether its next
    /// miss evicts the one or the other depends on it. Here the set is the cache's one of
    /// two ways: X Y X leaves Y least recent, so another job's Z evicts Y and X hits.
    #[test]
    fn a_commands_last_order_of_a_set_is_what_replays_next() {
        let bytes = 2 * LINE_BYTES;
        let (x, y, z) = (1, 2, 3);
        let sizes = CacheSizes {
            texture: bytes,
            ..tiny_caches(0)
        };
        // Both ends of a command: the next command of the job, or the job's log handed on.
        for ended_by_begin in [true, false] {
            let mut counting = AccessLog::with_texture_cache(bytes);
            let mut plain = AccessLog::new();
            for log in [&mut counting, &mut plain] {
                log.begin(0);
                for line in [x, y, x] {
                    log.touch(Stream::Texture, line, false);
                }
            }
            assert_eq!(counting.texture_hits, 1, "the second read of X was not counted");
            if ended_by_begin {
                for log in [&mut counting, &mut plain] {
                    log.begin(1);
                    log.touch(Stream::Depth, 0, false);
                }
            }
            let counting = counting.take();
            let mut other = AccessLog::new();
            other.touch(Stream::Texture, z, false);
            other.touch(Stream::Texture, x, false);
            let replay = |log: &AccessLog| {
                let segments: Vec<LogSegment> = log.segments().map(|(i, _)| (log, i)).chain([(&other, 0)]).collect();
                simulate(sizes, &segments, 1).caches.texture
            };
            let expected = replay(&plain);
            assert_eq!(expected.misses, 3, "X, Y, then Z: X stays");
            assert_eq!(replay(&counting), expected, "ended by begin: {ended_by_begin}");
        }
    }

    /// A log handed on with `take` holds what was logged, exactly as a log of its own would,
    /// and the log left behind, reset, logs the next job as a fresh one does (a worker reuses
    /// its log from job to job).
    #[test]
    fn a_taken_log_is_what_was_logged_and_the_rest_starts_afresh() {
        let bytes = 16 * 1024;
        let fill = |log: &mut AccessLog, seed: u64, commands: usize| {
            let mut x = seed;
            let mut next = |n: u64| {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (x >> 33) % n
            };
            for command in 0..commands {
                log.begin(command);
                for _ in 0..400 {
                    match next(4) {
                        0 => log.read_pair(Stream::Texture, next(40), next(40), next(6) as u32),
                        1 => log.touch(Stream::Depth, next(50), next(2) == 0),
                        _ => log.touch(Stream::Texture, next(40), false),
                    }
                }
            }
        };
        let contents = |log: &AccessLog| -> Vec<(usize, usize, u64, Vec<Vec<u32>>)> {
            log.segments()
                .map(|(i, command)| {
                    let streams = (0..STREAMS).map(|s| log.stream(i, s).to_vec()).collect();
                    (i, command, log.texture_hits(i), streams)
                })
                .collect()
        };
        let mut reused = AccessLog::with_texture_cache(bytes);
        // The last job repeats the one before it: lines its predecessor read in the same
        // segment number are not hits in a job of their own.
        for (seed, commands) in [(1, 5), (2, 1), (2, 1)] {
            let mut fresh = AccessLog::with_texture_cache(bytes);
            fill(&mut fresh, seed, commands);
            reused.reset(bytes);
            fill(&mut reused, seed, commands);
            let taken = reused.take();
            let fresh = fresh.take();
            assert!(contents(&fresh).iter().any(|(_, _, hits, _)| *hits > 0));
            assert_eq!(contents(&taken), contents(&fresh), "seed {seed}");
            assert!(reused.is_empty());
        }
    }
}
