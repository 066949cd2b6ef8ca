//! shadetrace-formats: the trace schema and its chunked, zstd-compressed, content-hashed
//! container (README.md, The trace format). This crate knows no back-end and no scene format.

pub mod atomic_file;
pub mod container;
pub mod error;
pub mod features;
pub mod hash;
pub mod results;
pub mod rig;
pub mod schema;
pub mod validate;

pub use container::{
    decompressed_limit, ChunkInfo, ChunkKind, TraceReader, TraceWriter, DEFAULT_ZSTD_LEVEL, EXPANSION_ALLOWANCE,
    FORMAT_MAJOR, FORMAT_MINOR, MAX_CHUNK_RAW_LEN, MAX_EXPANSION,
};
pub use error::{Error, Result};
pub use features::{Feature, Features};
pub use hash::ContentHash;
pub use rig::{Eye, Pose, StereoRig};
pub use schema::*;
