//! rover-power host tool, library first: the CLI in `main.rs` only parses arguments.

pub mod decode;
pub mod demo;
pub mod diagnose;
pub mod effect_id;
pub mod figures;
pub mod log;
pub mod plan;
pub mod plot;
pub mod progress;
pub mod record;
pub mod replay;
pub mod rover;
pub mod serial;
pub mod sim;
pub mod validate;
