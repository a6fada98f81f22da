//! rover-power host tool, library first: the CLI (`src/cli/<command>.rs`, one args struct with
//! `run` per command; `main.rs` a flat dispatch) parses arguments, calls in here and prints.

pub mod analysis;
pub mod check;
pub mod csv_table;
pub mod decode;
pub mod demo;
pub mod diagnose;
pub mod diagnose_bench;
pub mod effect_id;
pub mod excerpt;
pub mod figures;
pub mod file_error;
pub mod live;
pub mod log;
pub mod mcap_damage;
pub mod merge;
pub mod out_dir;
pub mod plan;
pub mod plot;
pub mod progress;
pub mod record;
pub mod replay;
pub mod ros2;
pub mod rover;
pub mod runs;
pub mod scenario;
pub mod serial;
pub mod sim;
pub mod stderr;
pub mod temp_paths;
pub mod toml_syntax;
pub mod validate;
pub mod wrap;
