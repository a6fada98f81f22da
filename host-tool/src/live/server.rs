//! [`LiveServer`]: the listening socket, its accept thread and one thread per viewer.

use super::channels::LiveChannel;
use super::hub::{Hub, ViewerReport, ViewerTally};
use super::sink::{LiveClock, LiveSink};
use super::viewer::{self, ViewerContext};
use super::{LiveError, LiveOptions};
use std::fmt;
use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// How often the accept thread looks for new viewers and for the stop flag.
const ACCEPT_POLL: Duration = Duration::from_millis(20);
/// Connections in their handshake at once, besides the viewers: each is let go within the
/// handshake's deadline, so a flood of silent connections delays a viewer by that at most.
const HANDSHAKES: usize = 32;

/// The Foxglove WebSocket server of the live view (see the [module docs](super)).
pub struct LiveServer {
    addr: SocketAddr,
    hub: Arc<Hub>,
    stop: Arc<AtomicBool>,
    /// What the viewers are told when the server finishes.
    ended: Arc<OnceLock<String>>,
    accept: Option<JoinHandle<()>>,
}

impl fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LiveServer")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

/// What the viewers got, when the server stopped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveSummary {
    /// The address served.
    pub addr: SocketAddr,
    /// Messages published to at least one subscribed viewer.
    pub published: u64,
    /// The viewers that connected (the first that left, and those still connected).
    pub viewers: Vec<ViewerReport>,
    /// Viewers that left beyond those listed in `viewers`.
    pub more_viewers: ViewerTally,
    /// Connections that never became viewers, by reason.
    pub refused: Vec<(String, u64)>,
}

impl LiveSummary {
    /// Messages dropped for all viewers together.
    pub fn dropped(&self) -> u64 {
        self.viewers.iter().map(|v| v.dropped).sum::<u64>() + self.more_viewers.dropped
    }
}

impl fmt::Display for LiveSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "live view ws://{}: {} viewer(s), {} messages published, {} dropped for slow viewers",
            self.addr,
            self.viewers.len() as u64 + self.more_viewers.viewers,
            self.published,
            self.dropped()
        )?;
        for v in &self.viewers {
            write!(f, "\n  {v}")?;
        }
        let more = &self.more_viewers;
        if more.viewers > 0 {
            write!(
                f,
                "\n  {} more viewers: {} messages sent, {} dropped",
                more.viewers, more.sent, more.dropped
            )?;
        }
        for (why, n) in &self.refused {
            write!(f, "\n  {n} connection(s) refused: {why}")?;
        }
        Ok(())
    }
}

/// The address of `--serve ADDR`: `HOST:PORT`, `[V6]:PORT`, or a bare port on the loopback.
pub fn resolve_addr(text: &str) -> Result<SocketAddr, LiveError> {
    let text = text.trim();
    let bad = |detail: String| LiveError::Address {
        addr: text.to_owned(),
        detail,
    };
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::from(([127, 0, 0, 1], port)));
    }
    text.to_socket_addrs()
        .map_err(|e| bad(e.to_string()))?
        .next()
        .ok_or_else(|| bad("names no address".into()))
}

/// What a user should know before serving on `addr`: beyond the loopback, anyone who can reach
/// the port watches, with no password and no encryption. `None` on the loopback.
pub fn exposure_warning(addr: SocketAddr) -> Option<String> {
    if addr.ip().is_loopback() {
        return None;
    }
    let port = addr.port();
    Some(format!(
        "live view on {addr}: every host that can reach port {port} here may watch (no password, \
         no encryption). On a network you do not trust, serve on the loopback (the default) and \
         tunnel from your laptop: ssh -L {port}:127.0.0.1:{port} USER@ROVER, then open \
         ws://127.0.0.1:{port}"
    ))
}

impl LiveServer {
    /// Listens on `addr` and starts accepting viewers.
    pub fn bind(addr: SocketAddr, options: LiveOptions) -> Result<Self, LiveError> {
        let listener =
            TcpListener::bind(addr).map_err(|source| LiveError::Bind { addr, source })?;
        let addr = listener
            .local_addr()
            .map_err(|source| LiveError::Bind { addr, source })?;
        listener
            .set_nonblocking(true)
            .map_err(|source| LiveError::Bind { addr, source })?;
        let hub = Arc::new(Hub::default());
        let stop = Arc::new(AtomicBool::new(false));
        let ended = Arc::new(OnceLock::new());
        let cx = ViewerContext {
            hub: hub.clone(),
            stop: stop.clone(),
            ended: ended.clone(),
            options,
            session_id: format!("{}-{}", std::process::id(), unix_now_ns()),
        };
        let accept = std::thread::Builder::new()
            .name("live-accept".into())
            .spawn(move || accept_loop(&listener, cx))
            .map_err(|source| LiveError::Bind { addr, source })?;
        Ok(Self {
            addr,
            hub,
            stop,
            ended,
            accept: Some(accept),
        })
    }

    /// The address it listens on (the port chosen when bound to port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// A sink for a recording: time stamps are the log's wall clock (its
    /// [`crate::log::run_log::LogEvent::WallClock`] anchor plus run time), the host's clock
    /// before the anchor comes.
    pub fn recording_sink(&self) -> LiveSink {
        LiveSink::new(
            self.hub.clone(),
            LiveClock::Recording { zero_unix_ns: None },
        )
    }

    /// A sink for a paced replay: run time `t0_s` is stamped now, later times at `speed`.
    pub fn replay_sink(&self, t0_s: f64, speed: f64) -> LiveSink {
        LiveSink::new(
            self.hub.clone(),
            LiveClock::Replay {
                zero_unix_ns: i128::from(unix_now_ns()),
                t0_s,
                speed,
            },
        )
    }

    /// The channels some viewer subscribes to now.
    pub fn subscribed_channels(&self) -> Vec<LiveChannel> {
        let mask = self.hub.subscribed();
        LiveChannel::ALL
            .into_iter()
            .filter(|c| mask & c.bit() != 0)
            .collect()
    }

    /// Viewers connected now.
    pub fn viewers(&self) -> usize {
        self.hub.viewers()
    }

    /// Waits until some viewer subscribes to a channel, up to `limit`, or until `stop` is
    /// set; true if one did.
    pub fn wait_for_subscriber(&self, limit: Option<Duration>, stop: &AtomicBool) -> bool {
        let start = Instant::now();
        while self.hub.subscribed() == 0 {
            if stop.load(Ordering::Relaxed) || limit.is_some_and(|l| start.elapsed() >= l) {
                return false;
            }
            std::thread::sleep(ACCEPT_POLL);
        }
        // A viewer subscribes panel by panel: wait until its channels settle (none new for
        // 300 ms, 2 s at most), so that every panel starts with the run's first samples. The
        // events do not depend on it: their channel is latched (`LiveChannel::latched`).
        let first = Instant::now();
        let (mut mask, mut since) = (self.hub.subscribed(), Instant::now());
        while since.elapsed() < Duration::from_millis(300)
            && first.elapsed() < Duration::from_secs(2)
        {
            std::thread::sleep(ACCEPT_POLL);
            let now = self.hub.subscribed();
            if now != mask {
                (mask, since) = (now, Instant::now());
            }
        }
        true
    }

    /// What each viewer got so far.
    pub fn reports(&self) -> Vec<ViewerReport> {
        self.hub.reports()
    }

    /// The most latched messages each connected viewer has had waiting at once.
    #[cfg(test)]
    pub(super) fn backlog_peaks(&self) -> Vec<usize> {
        self.hub.backlog_peaks()
    }

    /// Connections refused so far, by reason.
    pub fn refusals(&self) -> Vec<(String, u64)> {
        self.hub.refusals()
    }

    /// Stops after the viewers' queues have drained (at most `drain`), tells every viewer
    /// `note` (an info status: why the stream ended), closes each connection normally (1000)
    /// and reports.
    pub fn finish(mut self, drain: Duration, note: &str) -> LiveSummary {
        let _ = self.ended.set(note.to_owned());
        let start = Instant::now();
        while !self.hub.queues_empty() && start.elapsed() < drain {
            std::thread::sleep(ACCEPT_POLL);
        }
        self.shut_down();
        LiveSummary {
            addr: self.addr,
            published: self.hub.published(),
            viewers: self.hub.reports(),
            more_viewers: self.hub.more_viewers(),
            refused: self.hub.refusals(),
        }
    }

    fn shut_down(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(accept) = self.accept.take() {
            let _ = accept.join();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        self.shut_down();
    }
}

/// Accepts viewers until the stop flag is set, then waits for their threads.
fn accept_loop(listener: &TcpListener, cx: ViewerContext) {
    let cx = Arc::new(cx);
    let mut threads: Vec<JoinHandle<()>> = Vec::new();
    while !cx.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, peer)) => {
                threads.retain(|t| !t.is_finished());
                // Viewers are limited in the hub (an idle one gives its place); this bounds
                // the threads of connections still in their handshake.
                if threads.len() >= cx.options.max_viewers + HANDSHAKES {
                    let why = format!(
                        "busy: {} connections open already",
                        cx.options.max_viewers + HANDSHAKES
                    );
                    answer_busy(stream, &why);
                    cx.hub.refused(why);
                    continue;
                }
                let viewer_cx = cx.clone();
                let spawned = std::thread::Builder::new()
                    .name("live-viewer".into())
                    .spawn(move || {
                        // The listener is non-blocking; the viewer's socket starts blocking
                        // for the handshake.
                        if stream.set_nonblocking(false).is_ok() {
                            viewer::serve(stream, peer, &viewer_cx);
                        }
                    });
                match spawned {
                    Ok(t) => threads.push(t),
                    Err(e) => cx.hub.refused(format!("no thread for it: {e}")),
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => std::thread::sleep(ACCEPT_POLL),
            // A connection reset before it was accepted, out of descriptors: go on.
            Err(_) => std::thread::sleep(ACCEPT_POLL),
        }
    }
    for t in threads {
        let _ = t.join();
    }
}

/// Answers a connection there is no thread for with HTTP 503 and its reason, never blocking
/// the accept thread (a reset without an answer reads as a server that is down).
fn answer_busy(mut stream: TcpStream, why: &str) {
    if stream.set_nonblocking(true).is_err() {
        return;
    }
    // The request read so far is taken, so that closing does not reset the connection before
    // the answer is read.
    let mut request = [0u8; 4096];
    let _ = stream.read(&mut request);
    let answer = format!(
        "HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain\r\nContent-Length: {}\r\n\
         Retry-After: 5\r\nConnection: close\r\n\r\n{why}",
        why.len()
    );
    let _ = stream.write_all(answer.as_bytes());
    let _ = stream.shutdown(Shutdown::Write);
}

/// The host's clock [ns since the Unix epoch].
pub(crate) fn unix_now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serving_beyond_the_loopback_says_who_may_watch_and_how_to_tunnel() {
        for quiet in ["8765", "127.0.0.1:8765", "[::1]:8765"] {
            let addr = resolve_addr(quiet).expect("an address");
            assert_eq!(exposure_warning(addr), None, "{quiet}");
        }
        for open in ["0.0.0.0:8765", "[::]:8765", "10.0.0.7:8765"] {
            let addr = resolve_addr(open).expect("an address");
            let warning = exposure_warning(addr).expect("a warning");
            assert!(warning.contains("no password"), "{warning}");
            assert!(warning.contains("ssh -L 8765:127.0.0.1:8765"), "{warning}");
        }
    }
}
