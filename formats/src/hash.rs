//! Content hash: names a trace in results and goldens.
//!
//! SHA-256 over, for each payload chunk in file order, its kind (u32 LE), its
//! decompressed length (u64 LE) and its decompressed bytes. Framing and compression
//! level do not enter it, so re-compressing a trace keeps its name.

use sha2::{Digest, Sha256};

/// A SHA-256 content hash.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ContentHash(pub [u8; 32]);

impl ContentHash {
    pub fn to_hex(&self) -> String {
        self.0.iter().map(|b| format!("{b:02x}")).collect()
    }

    /// The first 12 hex digits, enough to tell traces apart in tables.
    pub fn short(&self) -> String {
        self.to_hex()[..12].to_string()
    }

    pub fn from_hex(s: &str) -> Option<ContentHash> {
        if s.len() != 64 || !s.is_ascii() {
            return None;
        }
        let mut out = [0u8; 32];
        for (i, byte) in out.iter_mut().enumerate() {
            *byte = u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()?;
        }
        Some(ContentHash(out))
    }
}

impl std::fmt::Display for ContentHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.to_hex())
    }
}

impl std::fmt::Debug for ContentHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ContentHash({})", self.to_hex())
    }
}

/// Incremental content hasher fed one chunk at a time.
#[derive(Default)]
pub(crate) struct ContentHasher(Sha256);

impl ContentHasher {
    pub fn add_chunk(&mut self, kind: u32, raw: &[u8]) {
        self.begin_chunk(kind, raw.len() as u64);
        self.update(raw);
    }

    /// Starts a chunk whose `raw_len` decompressed bytes follow through [`Self::update`].
    pub fn begin_chunk(&mut self, kind: u32, raw_len: u64) {
        self.0.update(kind.to_le_bytes());
        self.0.update(raw_len.to_le_bytes());
    }

    pub fn update(&mut self, bytes: &[u8]) {
        self.0.update(bytes);
    }

    pub fn finish(self) -> ContentHash {
        ContentHash(self.0.finalize().into())
    }
}
