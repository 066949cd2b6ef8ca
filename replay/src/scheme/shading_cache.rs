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

/// A cached coarse fragment, as stored and as read: its inputs, and per light its term and
/// (screen-space stores only; empty otherwise) `R · L`, the cosine between the reflected
/// view direction and the light direction, for cross-view checks.
#[derive(Clone, Copy, Debug)]
pub struct CacheEntry<'a> {
    pub position: Vec3,
    pub normal: Vec3,
    pub r_dot_l: &'a [f32],
    pub terms: &'a [LightTerm],
    pub refine: Effects,
    /// The view that shaded it (a bit of the flags word).
    pub view: u8,
}

/// Budget bytes of one entry for `lights` lights: key (8), inputs counted as f16 (12), per light a term
/// (3 x f32) and `R · L` (f32), and the flags (4).
pub fn entry_bytes(lights: usize) -> usize {
    8 + 12 + 16 * lights + 4
}

/// An entry's fields besides its per-light values, which sit at `slot` in the cache's slabs.
#[derive(Clone, Copy, Debug)]
struct Stored {
    position: Vec3,
    normal: Vec3,
    refine: Effects,
    view: u8,
    slot: u32,
    has_r_dot_l: bool,
}

/// A hash map threaded by recency (`hashlink`): lookups, stores and evictions in constant
/// time. Nothing iterates it, so the hasher's seed cannot reach a result. The per-light
/// values live in two slabs of `lights` values per slot, and a store reuses the slot of the
/// entry it replaces or evicts: no allocation per entry (the cache is cleared once per
/// tile-pair sequence, often every few blocks).
pub struct ShadingCache {
    capacity: usize,
    lights: usize,
    entries: LruCache<CacheKey, Stored>,
    terms: Vec<LightTerm>,
    r_dot_l: Vec<f32>,
    /// Slots handed out since the cache was last empty.
    slots_used: u32,
    pub counters: ShadingCacheStats,
}

impl ShadingCache {
    pub fn new(bytes: u32, lights: usize) -> ShadingCache {
        let capacity = bytes as usize / entry_bytes(lights);
        ShadingCache {
            capacity,
            lights,
            entries: LruCache::new(capacity),
            terms: Vec::new(),
            r_dot_l: Vec::new(),
            slots_used: 0,
            counters: ShadingCacheStats::default(),
        }
    }

    /// Empties the cache; its map nodes and slabs are kept for the next entries.
    pub fn clear(&mut self) {
        self.entries.drain();
        self.slots_used = 0;
    }

    /// Looks an entry up, marking it most recently used.
    pub fn get(&mut self, key: &CacheKey) -> Option<CacheEntry<'_>> {
        let stored = *self.entries.get(key)?;
        let values = self.lights * stored.slot as usize..self.lights * (stored.slot as usize + 1);
        Some(CacheEntry {
            position: stored.position,
            normal: stored.normal,
            r_dot_l: match stored.has_r_dot_l {
                true => &self.r_dot_l[values.clone()],
                false => &[],
            },
            terms: &self.terms[values],
            refine: stored.refine,
            view: stored.view,
        })
    }

    /// Inserts or replaces an entry (most recently used), evicting the least recently used
    /// when full. `entry.terms` holds one term per light, `entry.r_dot_l` one cosine per
    /// light or none.
    pub fn put(&mut self, key: CacheKey, entry: CacheEntry) {
        if self.capacity == 0 {
            return;
        }
        debug_assert_eq!(entry.terms.len(), self.lights);
        let mut stored = Stored {
            position: entry.position,
            normal: entry.normal,
            refine: entry.refine,
            view: entry.view,
            slot: 0,
            has_r_dot_l: !entry.r_dot_l.is_empty(),
        };
        match self.entries.get_mut(&key) {
            // Marked most recently used, as the insert it stands for.
            Some(old) => {
                stored.slot = old.slot;
                *old = stored;
            }
            None => {
                stored.slot = if self.entries.len() >= self.capacity {
                    self.counters.evictions += 1;
                    self.entries.remove_lru().expect("a full cache has entries").1.slot
                } else {
                    self.slots_used += 1;
                    self.slots_used - 1
                };
                self.entries.insert(key, stored);
            }
        }
        let values = self.lights * stored.slot as usize..self.lights * (stored.slot as usize + 1);
        if self.terms.len() < values.end {
            self.terms.resize(values.end, LightTerm::default());
            self.r_dot_l.resize(values.end, 0.0);
        }
        self.terms[values.clone()].copy_from_slice(entry.terms);
        if stored.has_r_dot_l {
            self.r_dot_l[values].copy_from_slice(entry.r_dot_l);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry() -> CacheEntry<'static> {
        CacheEntry {
            position: Vec3::ZERO,
            normal: Vec3::Y,
            r_dot_l: &[0.0],
            terms: &[LightTerm {
                scale: 1.0,
                diffuse: 0.0,
                specular: 0.0,
            }],
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

    /// Each key reads back the values stored under it, across replacements, evictions
    /// (which hand their slot on) and clears (which start the slots over).
    #[test]
    fn values_follow_their_keys() {
        let lights = 2;
        let mut c = ShadingCache::new(3 * entry_bytes(lights) as u32, lights);
        let term = |v: f32| LightTerm {
            scale: v,
            diffuse: v + 0.5,
            specular: v + 0.25,
        };
        let put = |c: &mut ShadingCache, k: i32, v: f32, with_r: bool| {
            let terms = [term(v), term(-v)];
            let r = [v, 2.0 * v];
            let r_dot_l: &[f32] = if with_r { &r } else { &[] };
            c.put(
                key(k),
                CacheEntry {
                    terms: &terms,
                    r_dot_l,
                    ..entry()
                },
            );
        };
        let check = |c: &mut ShadingCache, k: i32, v: f32, with_r: bool| {
            let e = c.get(&key(k)).expect("cached");
            assert_eq!(e.terms, &[term(v), term(-v)]);
            match with_r {
                true => assert_eq!(e.r_dot_l, &[v, 2.0 * v]),
                false => assert!(e.r_dot_l.is_empty()),
            }
        };
        for round in 0..2 {
            let v = round as f32 * 10.0;
            put(&mut c, 1, v + 1.0, true);
            put(&mut c, 2, v + 2.0, false);
            put(&mut c, 3, v + 3.0, true);
            put(&mut c, 2, v + 4.0, true);
            put(&mut c, 5, v + 5.0, false);
            assert!(c.get(&key(1)).is_none(), "1 was least recently used");
            check(&mut c, 2, v + 4.0, true);
            check(&mut c, 3, v + 3.0, true);
            check(&mut c, 5, v + 5.0, false);
            c.clear();
            assert!(c.get(&key(2)).is_none());
        }
    }
}
