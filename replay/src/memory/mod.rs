//! The memory model: set-associative LRU caches with 256-byte lines in front of DRAM, and
//! the DRAM bytes per traffic class (ARCHITECTURE.md, Definitions).
//!
//! Work units record the cache lines they touch in an [`AccessLog`] while they run (in
//! parallel); the caches then replay all logs sequentially in the order the scheduler
//! issued the units, so traffic depends on the schedule and never on thread count.

mod framebuffer;

pub use framebuffer::FramebufferLayout;
use serde::{Deserialize, Serialize};
pub use shadetrace_formats::results::{CacheReport, CacheStats, Traffic};

pub const LINE_BYTES: u64 = 256;

/// Traffic classes of the caches below (the names results report them under).
pub const DEPTH_COLOR: &str = "depth_color";
pub const TRIANGLE_DATA: &str = "triangle_data";
pub const TEXTURE: &str = "texture";
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
}

const WRITE_BIT: u64 = 1 << 61;
const LINE_MASK: u64 = (1 << 61) - 1;

/// The cache lines one work unit touched, in order.
#[derive(Clone, Debug, Default)]
pub struct AccessLog {
    entries: Vec<u64>,
    last: [u64; 4],
}

impl AccessLog {
    pub fn new() -> Self {
        AccessLog {
            entries: Vec::new(),
            last: [u64::MAX; 4],
        }
    }

    /// Records an access; a repeat of the stream's previous access is dropped (it is a hit
    /// that cannot change any LRU state), unless it upgrades a read to a write.
    #[inline]
    pub fn touch(&mut self, stream: Stream, line: u64, write: bool) {
        let entry = (stream as u64) << 62 | if write { WRITE_BIT } else { 0 } | (line & LINE_MASK);
        let last = &mut self.last[stream as usize];
        if *last == entry || (!write && *last == entry | WRITE_BIT) {
            return;
        }
        *last = entry;
        self.entries.push(entry);
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn clear(&mut self) {
        self.entries.clear();
        self.last = [u64::MAX; 4];
    }
}

/// Cache sizes in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheSizes {
    pub depth: u64,
    pub color: u64,
    pub triangle_data: u64,
    pub texture: u64,
}

/// One set-associative LRU cache.
struct Cache {
    sets: usize,
    ways: usize,
    /// `sets * ways` (line + 1, 0 = empty), most recently used first within a set.
    tags: Vec<u64>,
    dirty: Vec<bool>,
    stats: CacheStats,
}

impl Cache {
    fn new(bytes: u64) -> Cache {
        let lines = (bytes / LINE_BYTES).max(1) as usize;
        let ways = WAYS.min(lines);
        let sets = (lines / ways).max(1);
        Cache {
            sets,
            ways,
            tags: vec![0; sets * ways],
            dirty: vec![false; sets * ways],
            stats: CacheStats::default(),
        }
    }

    /// Accesses `line`; returns (miss, evicted dirty line).
    #[inline]
    fn access(&mut self, line: u64, write: bool) -> (bool, bool) {
        self.stats.accesses += 1;
        let set = (line % self.sets as u64) as usize;
        let base = set * self.ways;
        let tags = &mut self.tags[base..base + self.ways];
        let dirty = &mut self.dirty[base..base + self.ways];
        let tag = line + 1;
        if let Some(pos) = tags.iter().position(|&t| t == tag) {
            let d = dirty[pos] | write;
            tags.copy_within(0..pos, 1);
            dirty.copy_within(0..pos, 1);
            tags[0] = tag;
            dirty[0] = d;
            return (false, false);
        }
        self.stats.misses += 1;
        let evicted_dirty = tags[self.ways - 1] != 0 && dirty[self.ways - 1];
        tags.copy_within(0..self.ways - 1, 1);
        dirty.copy_within(0..self.ways - 1, 1);
        tags[0] = tag;
        dirty[0] = write;
        if evicted_dirty {
            self.stats.writebacks += 1;
        }
        (true, evicted_dirty)
    }

    /// Writes back every dirty line (end of frame); returns how many.
    fn flush(&mut self) -> u64 {
        let n = self.dirty.iter().filter(|&&d| d).count() as u64;
        self.dirty.iter_mut().for_each(|d| *d = false);
        self.stats.writebacks += n;
        n
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

/// Replays the access logs of one frame, in the given order, through fresh caches.
pub fn simulate(sizes: CacheSizes, logs: &[&AccessLog]) -> (Traffic, CacheReport) {
    // The four caches are independent: each replays its own stream of the same order.
    let run = |stream: Stream, bytes: u64| {
        let mut cache = Cache::new(bytes);
        let mut written = LineSet::default();
        let mut dram_lines = 0u64;
        let mut writebacks = 0u64;
        for log in logs {
            for &entry in &log.entries {
                if (entry >> 62) as u8 != stream as u8 {
                    continue;
                }
                let line = entry & LINE_MASK;
                let write = entry & WRITE_BIT != 0;
                let (miss, evicted_dirty) = cache.access(line, write);
                if miss {
                    let framebuffer = matches!(stream, Stream::Depth | Stream::Color);
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
            }
        }
        writebacks += cache.flush();
        (dram_lines, writebacks, cache.stats)
    };
    let ((depth, color), (tri, tex)) = rayon::join(
        || rayon::join(|| run(Stream::Depth, sizes.depth), || run(Stream::Color, sizes.color)),
        || {
            rayon::join(
                || run(Stream::TriangleData, sizes.triangle_data),
                || run(Stream::Texture, sizes.texture),
            )
        },
    );
    let mut traffic = Traffic::default();
    traffic.add_bytes(
        DEPTH_COLOR,
        (depth.0 + depth.1) * LINE_BYTES / DEPTH_COMPRESSION + (color.0 + color.1) * LINE_BYTES / COLOR_COMPRESSION,
    );
    traffic.add_bytes(TRIANGLE_DATA, (tri.0 + tri.1) * LINE_BYTES);
    traffic.add_bytes(TEXTURE, (tex.0 + tex.1) * LINE_BYTES);
    let report = CacheReport {
        depth: depth.2,
        color: color.2,
        triangle_data: tri.2,
        texture: tex.2,
    };
    (traffic, report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(entries: &[(Stream, u64, bool)]) -> AccessLog {
        let mut l = AccessLog::new();
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
        let sizes = CacheSizes {
            depth: LINE_BYTES,
            color: LINE_BYTES,
            triangle_data: LINE_BYTES,
            texture: LINE_BYTES,
        };
        // Depth line 7 written, evicted by 8, read again: one writeback, one real fill.
        let l = log(&[
            (Stream::Depth, 7, true),
            (Stream::Depth, 8, false),
            (Stream::Depth, 7, false),
        ]);
        let (traffic, report) = simulate(sizes, &[&l]);
        assert_eq!(report.depth.misses, 3);
        assert_eq!(report.depth.cleared_fills, 2);
        assert_eq!(report.depth.writebacks, 1);
        assert_eq!(traffic.bytes(DEPTH_COLOR), 2 * LINE_BYTES / DEPTH_COMPRESSION);
        let t = log(&[
            (Stream::Texture, 1, false),
            (Stream::Texture, 1, false),
            (Stream::Texture, 2, false),
        ]);
        let (traffic, _) = simulate(sizes, &[&t]);
        assert_eq!(traffic.bytes(TEXTURE), 2 * LINE_BYTES);
    }
}
