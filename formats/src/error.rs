//! The one error type of trace reading and writing. Every message fits on one line.

use crate::container::ChunkKind;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
    #[error("not a shadetrace trace (bad magic {0:02x?}, expected \"STRC\")")]
    BadMagic([u8; 4]),
    #[error(
        "trace format {found_major}.{found_minor} is newer than this reader ({supported_major}.x); upgrade shadetrace"
    )]
    NewerMajor {
        found_major: u16,
        found_minor: u16,
        supported_major: u16,
    },
    #[error("trace format major version {0} is not supported (this reader reads {1}.x)")]
    OlderMajor(u16, u16),
    #[error("truncated: {0}")]
    Truncated(String),
    #[error("{kind} chunk at byte {offset} declares {len} bytes, more than {limit} allowed")]
    Oversized {
        kind: ChunkKind,
        offset: u64,
        len: u64,
        limit: u64,
    },
    #[error(
        "{kind} chunk at byte {offset} declares {raw_len} bytes from {packed_len} compressed, more than the {limit} a reader allows (a decompression bomb, or a corrupt header)"
    )]
    Expansion {
        kind: ChunkKind,
        offset: u64,
        raw_len: u64,
        packed_len: u64,
        limit: u64,
    },
    #[error("corrupt: {0}")]
    Corrupt(String),
    #[error("{kind} chunk does not decompress: {msg}")]
    Decompress { kind: ChunkKind, msg: String },
    #[error("{kind} chunk does not decode: {msg}")]
    Decode { kind: ChunkKind, msg: String },
    #[error("content hash mismatch: header says {stored}, payloads hash to {computed}")]
    HashMismatch { stored: String, computed: String },
    #[error("frame {index} out of range (trace has {count} frames)")]
    FrameOutOfRange { index: u32, count: u32 },
    #[error("invalid trace: {0}")]
    Invalid(String),
    #[error("cannot encode {kind} chunk: {msg}")]
    Encode { kind: ChunkKind, msg: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
