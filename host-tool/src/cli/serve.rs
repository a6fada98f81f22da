//! `--serve [ADDR]`, shared by `record`, `replay` and `demo`: the live view in Foxglove
//! (`host_tool::live`).

use anyhow::Result;
use host_tool::eprintln_best_effort;
use host_tool::live::{
    exposure_warning, resolve_addr, LiveOptions, LiveServer, LiveSummary, DEFAULT_ADDR,
};
use std::time::Duration;

/// The `--serve` option.
#[derive(clap::Args, Debug, Clone)]
pub struct ServeArgs {
    /// Serve the data live to Foxglove (WebSocket protocol foxglove.websocket.v1) on ADDR
    /// (default 127.0.0.1:8765; 0.0.0.0:8765 for viewers on the network: no password, so on a
    /// network you do not trust keep the default and use an SSH tunnel). Read-only: viewers
    /// subscribe, the board is not commanded from them. A slow viewer loses messages, never
    /// the log. `replay` and `demo` start when the first viewer subscribes.
    #[arg(
        long,
        value_name = "ADDR",
        num_args = 0..=1,
        default_missing_value = DEFAULT_ADDR
    )]
    pub serve: Option<String>,
}

impl ServeArgs {
    /// Starts the server if `--serve` was given, and says where to connect.
    pub fn start(&self) -> Result<Option<LiveServer>> {
        let Some(addr) = &self.serve else {
            return Ok(None);
        };
        let server = LiveServer::bind(resolve_addr(addr)?, LiveOptions::default())?;
        eprintln_best_effort!(
            "live view: ws://{} (Foxglove: Open connection → Foxglove WebSocket; layout \
             foxglove/rover-power.json)",
            server.local_addr()
        );
        if let Some(warning) = exposure_warning(server.local_addr()) {
            eprintln_best_effort!("warning: {warning}");
        }
        Ok(Some(server))
    }
}

/// Stops the server after its viewers' queues drain (≤ 1 s), tells them `note` (why the
/// stream ended) and prints what they got.
pub fn finish(server: Option<LiveServer>, note: &str) {
    if let Some(server) = server {
        let summary: LiveSummary = server.finish(Duration::from_secs(1), note);
        eprintln_best_effort!("{summary}");
    }
}
