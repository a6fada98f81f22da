//! One viewer's connection, on its own thread: the WebSocket handshake (subprotocol
//! `foxglove.websocket.v1`), `serverInfo` and `advertise`, then a loop that reads the viewer's
//! ops and writes its queued messages. The socket is non-blocking after the handshake: a
//! viewer that stops reading fills its socket, then its queue, and the publisher drops for it.

use super::channels::LiveChannel;
use super::hub::{Hub, Outgoing, ViewerCounters};
use super::protocol::{
    parse_client_op, status_level, ClientOp, MessageData, ServerOp, SUBPROTOCOL,
};
use super::LiveOptions;
use std::collections::BTreeMap;
use std::io;
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};
use tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tungstenite::handshake::HandshakeError;
use tungstenite::http::{HeaderValue, StatusCode};
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{CloseFrame, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// Longest wait for a new message before the viewer's ops are read again.
const POLL: Duration = Duration::from_millis(10);
/// Most messages written before one flush.
const BATCH: usize = 256;
/// Pause after each batch so messages go out in batches, ~100 writes a second at most: a
/// viewer draws at its frame rate, and each write is a syscall and a wake-up (at 2 kHz,
/// a write per message cost the viewer threads 8× the CPU).
const COALESCE: Duration = Duration::from_millis(10);
/// How often a handshake that waits for bytes looks at its deadline.
const HANDSHAKE_POLL: Duration = Duration::from_millis(100);
/// Most ops read per turn of the loop: a viewer that floods ops cannot keep its thread from
/// writing, or from noticing that its socket takes nothing.
const OPS_PER_TURN: usize = 64;
/// Ops a viewer may send at once, and per second after that. A viewer subscribes panel by
/// panel (a few dozen ops); each subscription to the events copies their history, so a
/// flood costs the recording's host CPU: a viewer past this rate is let go.
const OPS_BURST: f64 = 256.0;
const OPS_PER_S: f64 = 32.0;
/// Most bytes the WebSocket may hold unsent for one viewer (a batch and the latched backlog
/// need well under this); past it the viewer is let go.
const MAX_UNSENT: usize = 2 * 1024 * 1024;

/// What the viewer's thread needs from the server.
pub(super) struct ViewerContext {
    pub(super) hub: Arc<Hub>,
    pub(super) stop: Arc<AtomicBool>,
    pub(super) options: LiveOptions,
    pub(super) session_id: String,
    /// What the viewers are told when the server finishes (set by [`super::LiveServer::finish`]).
    pub(super) ended: Arc<OnceLock<String>>,
}

/// Serves one viewer until it leaves, stalls past [`LiveOptions::stall_timeout`] or the server
/// stops; its report stays in the hub.
pub(super) fn serve(stream: TcpStream, peer: SocketAddr, cx: &ViewerContext) {
    let counters = Arc::new(ViewerCounters::default());
    let why = match handshake(stream, cx) {
        Ok(mut ws) => {
            let queue = match cx.hub.join(peer, &cx.options, counters.clone()) {
                Ok(queue) => queue,
                Err(full) => {
                    refuse_after_handshake(&mut ws, &full);
                    cx.hub.refused(full);
                    return;
                }
            };
            let why = Connection {
                ws: &mut ws,
                counters: &counters,
                hub: &cx.hub,
                subscriptions: BTreeMap::new(),
                backlog: Vec::new(),
                unflushed: false,
                ops: OpBudget::default(),
            }
            .run(&queue, cx);
            say_goodbye(&mut ws, cx, &why);
            why
        }
        Err(why) => {
            // Not a viewer (a port scan, a browser without the subprotocol): reported, so a
            // user whose viewer cannot connect sees why.
            cx.hub.refused(format!("handshake failed: {why}"));
            return;
        }
    };
    cx.hub.leave(&counters, why);
}

/// Tells a viewer there is no place for it (an error in its problems panel) and closes with
/// "try again later" (1013).
fn refuse_after_handshake(ws: &mut WebSocket<TcpStream>, why: &str) {
    let _ = ws.get_ref().set_nonblocking(false);
    let _ = ws.get_ref().set_write_timeout(Some(GOODBYE_TIMEOUT));
    let op = ServerOp::Status {
        level: status_level::ERROR,
        message: why.to_owned(),
    };
    if let Ok(text) = serde_json::to_string(&op) {
        let _ = ws.write(Message::text(text));
    }
    let _ = ws.close(Some(CloseFrame {
        code: CloseCode::Again,
        reason: close_reason(why).into(),
    }));
    let _ = ws.flush();
}

/// A close frame's reason holds at most 123 bytes.
fn close_reason(reason: &str) -> String {
    let mut end = reason.len().min(123);
    while !reason.is_char_boundary(end) {
        end -= 1;
    }
    reason[..end].to_owned()
}

/// Why [`Connection::run`] ends when a new viewer takes the place of this one, which subscribed
/// to nothing ([`Hub::join`]).
const EVICTED: &str = "subscribed to nothing while a new viewer needed its place";
/// Why [`Connection::run`] ends when the server finishes.
const SERVER_STOPPED: &str = "server stopped";
/// Longest wait for the goodbye to leave the socket.
const GOODBYE_TIMEOUT: Duration = Duration::from_secs(1);

/// Ends the connection: after a finished stream, an info status saying so and a normal close
/// (1000), so that a viewer does not take the end for a dropped connection; otherwise a
/// "going away" close (1001) with the reason.
fn say_goodbye(ws: &mut WebSocket<TcpStream>, cx: &ViewerContext, why: &str) {
    // The goodbye is written whole or given up after GOODBYE_TIMEOUT.
    let blocking = ws.get_ref().set_nonblocking(false).is_ok()
        && ws
            .get_ref()
            .set_write_timeout(Some(GOODBYE_TIMEOUT))
            .is_ok();
    let (code, reason) = match cx.ended.get() {
        Some(note) if why == SERVER_STOPPED => {
            let op = ServerOp::Status {
                level: status_level::INFO,
                message: note.clone(),
            };
            if let Ok(text) = serde_json::to_string(&op) {
                let _ = ws.write(Message::text(text));
            }
            (CloseCode::Normal, "stream ended")
        }
        _ => (CloseCode::Away, why),
    };
    let _ = ws.close(Some(CloseFrame {
        code,
        reason: close_reason(reason).into(),
    }));
    if blocking {
        let _ = ws.flush();
    }
}

fn handshake(stream: TcpStream, cx: &ViewerContext) -> Result<WebSocket<TcpStream>, String> {
    let io = |e: io::Error| e.to_string();
    // The whole handshake within [`LiveOptions::handshake_timeout`]: a client that sends its
    // request a byte at a time, or never, is let go (a connection that is not yet a viewer
    // holds no viewer's place).
    let timeout = cx.options.handshake_timeout;
    let deadline = Instant::now() + timeout;
    stream.set_nodelay(true).map_err(io)?;
    // Short waits, so that the deadline is looked at while a client dribbles its request.
    stream.set_read_timeout(Some(HANDSHAKE_POLL)).map_err(io)?;
    stream.set_write_timeout(Some(timeout)).map_err(io)?;
    let config = WebSocketConfig::default()
        .write_buffer_size(64 * 1024)
        // Backpressure is our queue's job; this bounds one batch, the backlog and control
        // frames (a viewer past it is let go: `write`).
        .max_write_buffer_size(MAX_UNSENT)
        .max_message_size(Some(1024 * 1024));
    let refusal = |e: HandshakeError<_>| match e {
        // Our refusal's body says why.
        HandshakeError::Failure(tungstenite::Error::Http(response)) => {
            String::from_utf8_lossy(response.body().as_deref().unwrap_or_default()).into_owned()
        }
        other => other.to_string(),
    };
    let mut attempt = tungstenite::accept_hdr_with_config(stream, choose_subprotocol, Some(config));
    let mut ws = loop {
        match attempt {
            Ok(ws) => break ws,
            // A read that waited HANDSHAKE_POLL for bytes.
            Err(HandshakeError::Interrupted(mid)) => {
                if Instant::now() >= deadline || cx.stop.load(Ordering::Relaxed) {
                    return Err(format!(
                        "no complete WebSocket request within {} s",
                        timeout.as_secs_f64()
                    ));
                }
                attempt = mid.handshake();
            }
            Err(e) => return Err(refusal(e)),
        }
    };
    let info = ServerOp::ServerInfo {
        name: cx.options.name.clone(),
        capabilities: Vec::new(),
        supported_encodings: Vec::new(),
        metadata: BTreeMap::from([(
            "about".to_owned(),
            "rover-power live view: read-only (the board is not commanded from here)".to_owned(),
        )]),
        session_id: Some(cx.session_id.clone()),
    };
    let advertise = ServerOp::Advertise {
        channels: LiveChannel::ALL.map(LiveChannel::advertised).to_vec(),
    };
    for op in [info, advertise] {
        let text = serde_json::to_string(&op).map_err(|e| e.to_string())?;
        ws.send(Message::text(text)).map_err(|e| e.to_string())?;
    }
    ws.get_ref().set_nonblocking(true).map_err(io)?;
    Ok(ws)
}

/// Accepts clients that speak `foxglove.websocket.v1` and names it in the response.
#[allow(clippy::result_large_err)] // tungstenite's callback signature
fn choose_subprotocol(
    request: &Request,
    mut response: Response,
) -> Result<Response, ErrorResponse> {
    let offered = request
        .headers()
        .get_all("Sec-WebSocket-Protocol")
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|p| p.trim() == SUBPROTOCOL);
    if !offered {
        let mut refusal = ErrorResponse::new(Some(format!(
            "this is a Foxglove WebSocket server: request subprotocol {SUBPROTOCOL}"
        )));
        *refusal.status_mut() = StatusCode::BAD_REQUEST;
        return Err(refusal);
    }
    response.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        HeaderValue::from_static(SUBPROTOCOL),
    );
    Ok(response)
}

struct Connection<'a> {
    ws: &'a mut WebSocket<TcpStream>,
    counters: &'a ViewerCounters,
    hub: &'a Hub,
    /// The viewer's subscription id per channel.
    subscriptions: BTreeMap<LiveChannel, u32>,
    /// What a latched channel published before the viewer subscribed to it, to send first.
    backlog: Vec<Outgoing>,
    /// Something (a status op) was written but not flushed yet.
    unflushed: bool,
    ops: OpBudget,
}

/// The ops a viewer may still send ([`OPS_BURST`], refilled at [`OPS_PER_S`]).
struct OpBudget {
    left: f64,
    at: Instant,
}

impl Default for OpBudget {
    fn default() -> Self {
        Self {
            left: OPS_BURST,
            at: Instant::now(),
        }
    }
}

impl OpBudget {
    /// Takes one op; false when the viewer sends faster than the budget allows.
    fn take(&mut self) -> bool {
        let now = Instant::now();
        let refill = now.duration_since(self.at).as_secs_f64() * OPS_PER_S;
        (self.left, self.at) = ((self.left + refill).min(OPS_BURST) - 1.0, now);
        self.left >= 0.0
    }
}

impl Connection<'_> {
    /// The loop: ops in, messages out. Returns why it ended.
    fn run(mut self, queue: &Receiver<Outgoing>, cx: &ViewerContext) -> String {
        // Since when the socket has taken nothing (a viewer that stopped reading).
        let mut blocked_since: Option<Instant> = None;
        loop {
            if cx.stop.load(Ordering::Relaxed) {
                return SERVER_STOPPED.into();
            }
            if self.counters.evicted.load(Ordering::Relaxed) {
                return EVICTED.into();
            }
            if let Err(why) = self.read_ops() {
                return why;
            }
            if blocked_since.is_some() || self.unflushed {
                let since = *blocked_since.get_or_insert_with(Instant::now);
                self.unflushed = false;
                match self.ws.flush() {
                    Ok(()) => blocked_since = None,
                    Err(e) if would_block(&e) => {
                        if since.elapsed() > cx.options.stall_timeout {
                            return format!(
                                "took nothing for {:.0} s: disconnected",
                                cx.options.stall_timeout.as_secs_f64()
                            );
                        }
                        std::thread::sleep(POLL);
                        continue;
                    }
                    Err(e) => return lost(e),
                }
            }
            if !self.backlog.is_empty() {
                match self.write_backlog() {
                    Ok(true) => {}
                    Ok(false) => blocked_since = Some(Instant::now()),
                    Err(why) => return why,
                }
                continue;
            }
            let first = match queue.recv_timeout(POLL) {
                Ok(m) => m,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => return SERVER_STOPPED.into(),
            };
            match self.write_batch(first, queue) {
                Ok(true) => std::thread::sleep(COALESCE),
                Ok(false) => blocked_since = Some(Instant::now()),
                Err(why) => return why,
            }
        }
    }

    /// Reads the ops the viewer has sent, [`OPS_PER_TURN`] at most; `Err` when it has gone.
    fn read_ops(&mut self) -> Result<(), String> {
        for _ in 0..OPS_PER_TURN {
            match self.ws.read() {
                Ok(Message::Text(text)) => {
                    if !self.ops.take() {
                        return Err(format!(
                            "sent ops faster than {OPS_PER_S:.0} a second: disconnected"
                        ));
                    }
                    self.on_op(text.as_str());
                }
                Ok(Message::Close(_)) => return Err("viewer closed the connection".into()),
                Ok(_) => {}
                Err(e) if would_block(&e) => return Ok(()),
                Err(e) => return Err(lost(e)),
            }
        }
        Ok(())
    }

    fn on_op(&mut self, text: &str) {
        match parse_client_op(text) {
            Ok(ClientOp::Subscribe { subscriptions }) => {
                for s in subscriptions {
                    match LiveChannel::from_id(s.channel_id) {
                        Some(channel) => {
                            self.subscriptions.insert(channel, s.id);
                        }
                        None => self.warn(format!("no channel {}", s.channel_id)),
                    }
                }
            }
            Ok(ClientOp::Unsubscribe { subscription_ids }) => {
                self.subscriptions
                    .retain(|_, id| !subscription_ids.contains(id));
            }
            Err(e) => self.warn(e.to_string()),
        }
        let mask = self.subscriptions.keys().fold(0, |m, c| m | c.bit());
        // What is still unsent of a channel no longer subscribed goes (it would not be sent),
        // so a viewer holds one latched history per channel however often it resubscribes.
        self.backlog.retain(|m| m.channel.bit() & mask != 0);
        let backlog = self.hub.subscribe(self.counters, mask);
        self.backlog.extend(backlog);
        self.counters
            .backlog_peak
            .fetch_max(self.backlog.len(), Ordering::Relaxed);
    }

    /// A warning in the viewer's problems panel (dropped if the socket is full).
    fn warn(&mut self, message: String) {
        let op = ServerOp::Status {
            level: status_level::WARNING,
            message,
        };
        if let Ok(text) = serde_json::to_string(&op) {
            let _ = self.ws.write(Message::text(text));
            self.unflushed = true;
        }
    }

    /// Writes `first` and whatever else is queued (up to [`BATCH`]), then flushes. `Ok(false)`:
    /// the socket is full (the rest stays in the WebSocket's buffer).
    fn write_batch(&mut self, first: Outgoing, queue: &Receiver<Outgoing>) -> Result<bool, String> {
        let mut next = Some(first);
        let mut written = 0;
        while let Some(message) = next.take() {
            self.counters.queued.fetch_sub(1, Ordering::Relaxed);
            if !self.write(&message)? {
                return Ok(false);
            }
            written += 1;
            if written < BATCH {
                next = queue.try_recv().ok();
            }
        }
        self.flush()
    }

    /// Writes the backlog of the latched channels just subscribed to, then flushes; as
    /// [`Connection::write_batch`].
    fn write_backlog(&mut self) -> Result<bool, String> {
        let mut rest = std::mem::take(&mut self.backlog).into_iter();
        while let Some(message) = rest.next() {
            if !self.write(&message)? {
                self.backlog = rest.collect();
                return Ok(false);
            }
        }
        self.flush()
    }

    /// Writes one message if its channel is subscribed (one queued before an unsubscribe is
    /// not sent); `Ok(false)`: the socket is full, the message is kept in the WebSocket's
    /// buffer and sent when it drains.
    fn write(&mut self, message: &Outgoing) -> Result<bool, String> {
        let Some(&subscription_id) = self.subscriptions.get(&message.channel) else {
            return Ok(true);
        };
        let frame = MessageData {
            subscription_id,
            timestamp_ns: message.timestamp_ns,
            payload: &message.payload,
        }
        .encode();
        let taken = match self.ws.write(Message::binary(frame)) {
            Ok(()) => true,
            Err(e) if would_block(&e) => false,
            Err(e) => return Err(lost(e)),
        };
        self.counters.sent.fetch_add(1, Ordering::Relaxed);
        Ok(taken)
    }

    fn flush(&mut self) -> Result<bool, String> {
        match self.ws.flush() {
            Ok(()) => Ok(true),
            Err(e) if would_block(&e) => Ok(false),
            Err(e) => Err(lost(e)),
        }
    }
}

/// Why a viewer is let go after a write or read failed.
fn lost(e: tungstenite::Error) -> String {
    match e {
        tungstenite::Error::WriteBufferFull(_) => format!(
            "more than {} MB unsent: disconnected",
            MAX_UNSENT / (1024 * 1024)
        ),
        e => format!("connection lost: {e}"),
    }
}

fn would_block(e: &tungstenite::Error) -> bool {
    matches!(e, tungstenite::Error::Io(e) if e.kind() == io::ErrorKind::WouldBlock)
}
