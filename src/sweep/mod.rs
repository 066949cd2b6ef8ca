//! Parameter studies at scale: the spec format, the results store and sharding over a
//! cluster's array jobs (used by the `sweep`, `merge` and `sweep-report` commands).

pub mod shard;
pub mod spec;
pub mod store;
