//! The cross-crate end-to-end tests, one module per path through the system, in one test
//! binary: each binary links the host tool, so one instead of five saves link time and disk.

mod board_to_host;
mod demo;
mod pty;
mod record;
mod reopen;
