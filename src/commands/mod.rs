//! One module per subcommand.

pub mod capture;
pub mod check;
pub mod compare;
pub mod demo;
pub mod info;
pub mod merge;
pub mod presets;
pub mod replay;
pub mod summary;
pub mod sweep;
pub mod sweep_report;
