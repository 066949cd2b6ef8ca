//! The screen-space shading cache of the tile-pair paper (§5.1): coarse fragments keyed by
//! `h(q, n, v)` (coarse-fragment cell, shading rate, view), least-recently-used eviction, a
//! fixed byte budget per job (an epipolar tile row under the tile-pair scheduler), cleared
//! when a sequence of neighbouring tile pairs ends. Entries hold the coarse shader's inputs
//! (position and normal) and outputs (every light's term, the reflected-light cosines, the
//! refinement flags). The simulator keeps every value as f32 (so reuse is exact), but an
//! entry counts against the budget at the size hardware would store: inputs as f16,
//! outputs as f32 ([`entry_bytes`]).

use glam::Vec3;
use hashlink::LruCache;
use shadetrace_formats::results::ShadingCacheStats;

use crate::shader::{Effects, LightTerm};

/// Default budget per job, as in the paper (Fig. 12: 24 KB suffices).
pub const DEFAULT_CACHE_BYTES: u32 = 24 * 1024;

/// Where a cached coarse fragment sits: cell `q` at rate `n` in view `view` (screen space),
/// or cell `q` of grid level `n` on surface `surface` (patch or texture space, view 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CacheKey {
    pub qx: i32,
    pub qy: i32,
    pub n: u32,
    pub view: u8,
    /// Patch id or mesh index in object-space caches; 0 in screen space.
    pub surface: u64,
}

/// A cached coarse fragment.
#[derive(Clone, Debug)]
pub struct CacheEntry {
    pub position: Vec3,
    pub normal: Vec3,
    /// Per light: `R · L` (reflected view direction against the light) for cross-view checks.
    pub r_dot_l: Vec<f32>,
    pub terms: Vec<LightTerm>,
    pub refine: Effects,
    /// The view that shaded it (a bit of the flags word).
    pub view: u8,
}

/// Budget bytes of one entry for `lights` lights: key (8), inputs counted as f16 (12), per light a term
/// (3 x f32) and `R · L` (f32), and the flags (4).
pub fn entry_bytes(lights: usize) -> usize {
    8 + 12 + 16 * lights + 4
}

/// A hash map threaded by recency (`hashlink`): lookups, stores and evictions in constant
/// time. Nothing iterates it, so the hasher's seed cannot reach a result.
pub struct ShadingCache {
    capacity: usize,
    entries: LruCache<CacheKey, CacheEntry>,
    pub counters: ShadingCacheStats,
}

impl ShadingCache {
    pub fn new(bytes: u32, lights: usize) -> ShadingCache {
        let capacity = bytes as usize / entry_bytes(lights);
        ShadingCache {
            capacity,
            entries: LruCache::new(capacity),
            counters: ShadingCacheStats::default(),
        }
    }

    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// Looks an entry up, marking it most recently used.
    pub fn get(&mut self, key: &CacheKey) -> Option<&CacheEntry> {
        self.entries.get(key)
    }

    /// Inserts or replaces an entry (most recently used), evicting the least recently used
    /// when full.
    pub fn put(&mut self, key: CacheKey, entry: CacheEntry) {
        if self.capacity == 0 {
            return;
        }
        if self.entries.len() >= self.capacity && !self.entries.contains_key(&key) {
            self.entries.remove_lru();
            self.counters.evictions += 1;
        }
        self.entries.insert(key, entry);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry() -> CacheEntry {
        CacheEntry {
            position: Vec3::ZERO,
            normal: Vec3::Y,
            r_dot_l: vec![0.0],
            terms: vec![LightTerm::default()],
            refine: Effects::empty(),
            view: 0,
        }
    }

    fn key(qx: i32) -> CacheKey {
        CacheKey {
            qx,
            qy: 0,
            n: 2,
            view: 0,
            surface: 0,
        }
    }

    #[test]
    fn least_recently_used_is_evicted() {
        let mut c = ShadingCache::new(2 * entry_bytes(1) as u32, 1);
        c.put(key(1), entry());
        c.put(key(2), entry());
        assert!(c.get(&key(1)).is_some());
        c.put(key(3), entry());
        assert!(c.get(&key(2)).is_none(), "2 was least recently used");
        assert!(c.get(&key(1)).is_some() && c.get(&key(3)).is_some());
        assert_eq!(c.counters.evictions, 1);
        let mut empty = ShadingCache::new(0, 1);
        empty.put(key(1), entry());
        assert!(empty.get(&key(1)).is_none());
    }
}
