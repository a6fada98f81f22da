//! The live view: a Foxglove WebSocket server (`foxglove.websocket.v1`) that shows a
//! recording, a replay or the demo as it happens, in the MCAP file's channels and JSON (one
//! Foxglove layout, `foxglove/rover-power.json`, serves live and recorded data).
//!
//! - [`LiveServer`] listens; each viewer gets a thread ([`viewer`](self)) and a bounded queue.
//!   Publishing ([`LiveSink`], [`LiveTee`] beside the recording's file sink) never waits: a
//!   message that does not fit a viewer's queue is dropped for that viewer and counted
//!   ([`ViewerReport::dropped`]), so a slow or vanished viewer costs the file nothing.
//! - Channels ([`LiveChannel`]): `/rover_power/sample` (one sample a message, where a file
//!   batches them), `/model`, `/status`, `/command`, `/event`, with the MCAP writer's schemas
//!   ([`crate::log::mcap::LogChannel`]).
//! - Time stamps are wall-clock [Unix ns]: a recording's wall-clock anchor plus run time (the
//!   MCAP file's `log_time`), a replay's start plus run time / speed.
//! - Viewers subscribe and unsubscribe; nothing else is offered (no client publish, services or
//!   parameters): the board is not commanded from the viewer.
//! - Built on `tungstenite` (sync, no TLS) rather than the `foxglove` SDK crate, whose
//!   TLS-free build brings tokio and ~110 crates (docs/engineering-record.md, "Live view: build cost and load").

mod channels;
pub mod client;
mod hub;
pub mod protocol;
mod replay;
mod server;
mod sink;
#[cfg(test)]
mod tests;
mod viewer;

pub use channels::LiveChannel;
pub use hub::{ViewerReport, ViewerTally};
pub use replay::{serve_run, LiveReplayStats};
pub(crate) use server::unix_now_ns;
pub use server::{exposure_warning, resolve_addr, LiveServer, LiveSummary};
pub use sink::{LiveClock, LiveSink, LiveTee};

use std::io;
use std::net::SocketAddr;
use std::time::Duration;

/// The address `--serve` uses when none is named.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

/// How the server treats its viewers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveOptions {
    /// Messages a viewer may have waiting; past it, new ones are dropped for it.
    pub queue_len: usize,
    /// Most viewers at once; past it a new viewer takes the place of one that subscribes to
    /// nothing, or is refused.
    pub max_viewers: usize,
    /// A viewer whose socket takes nothing for this long is disconnected (a laptop that left
    /// the Wi-Fi without closing); it may reconnect.
    pub stall_timeout: Duration,
    /// A connection that has not completed its WebSocket handshake by then is closed (a port
    /// scanner, a client that dribbles its request).
    pub handshake_timeout: Duration,
    /// The name in `serverInfo`.
    pub name: String,
}

impl Default for LiveOptions {
    /// 8192 messages a viewer (4 s at 2 kHz), 16 viewers, 30 s stall, 5 s handshake.
    fn default() -> Self {
        Self {
            queue_len: 8192,
            max_viewers: 16,
            stall_timeout: Duration::from_secs(30),
            handshake_timeout: Duration::from_secs(5),
            name: format!("rover-power host-tool {}", env!("CARGO_PKG_VERSION")),
        }
    }
}

/// Why the live view could not start or a client failed.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// `--serve ADDR` names no address.
    #[error("--serve {addr}: {detail}")]
    Address {
        /// What was given.
        addr: String,
        /// Why it is not an address.
        detail: String,
    },
    /// The address could not be listened on (in use, not this host's).
    #[error("live view: cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// A client's connection failed.
    #[error("live client: {0}")]
    Client(#[source] io::Error),
    /// A peer did not speak the protocol.
    #[error("foxglove.websocket.v1: {0}")]
    Protocol(String),
}
