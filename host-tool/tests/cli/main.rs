//! The host tool's integration tests, one module per area, in one test binary: each binary
//! links the whole tool, so one of them instead of eighteen saves most of the test build's
//! link time and disk (docs/engineering-record.md, "Build time and disk").

mod common;

mod check_cli;
mod closed_output_cli;
mod demo_cli;
mod diagnose_cli;
mod error_messages_cli;
mod foreign_datasets_cli;
mod live_cli;
mod loop_cli;
mod merge_cli;
mod next_runs_cli;
mod plan_cli;
mod record_cli;
mod ros2_bag_cli;
mod ros2_fixtures;
mod salvage_cli;
mod signals_cli;
mod studio_rules_cli;
mod validate_cli;
