//! The USB side of the board: whole frames into a bounded transmit queue, host bytes into
//! commands. Transmits only while the host holds DTR (a port nobody reads would only fill up).
//!
//! Every connection starts with a lone frame delimiter: a packet already armed in the IN endpoint
//! when the host closed the port survives the close and arrives first on the next connection,
//! usually cut mid-frame; the delimiter ends that cut frame, so it cannot swallow the hello.
//! A suspended bus is not a closed port: the host keeps DTR set through suspend and resume and
//! sends no new line state, so suspend is neither an edge nor a reason to reset the USB class.

use heapless::Deque;
use model_core::wire::{self, BoardFrame, FrameDecoder, HostFrame, Rejection, MAX_FRAME};

/// Transmit queue [bytes]: ~100 sample frames, half a second at the default 200 Hz.
pub const TX_CAPACITY: usize = 4096;
/// Host commands waiting for the sampler.
pub const COMMAND_CAPACITY: usize = 8;

/// A change of the host's DTR ([`Link::update_usb`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DtrEdge {
    /// A host opened the port: a frame delimiter is queued, a hello is due.
    Rising,
    /// The host closed the port (or the bus was reset): the queue was dropped; the caller drops
    /// its USB class's own write buffer too, so the next connection starts near its hello.
    Falling,
}

/// The USB device's state as the link reads it (usb-device's `UsbDeviceState`, which only the
/// target build has; `main.rs` maps it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UsbState {
    /// Just reset or addressed: no port, whatever the class last heard of DTR.
    Unconfigured,
    /// Enumerated: the class's DTR is the host's.
    Configured,
    /// The bus is suspended (host asleep, or unplugged while powered otherwise); on resume
    /// usb-device returns to the state before, on a bus reset to `Unconfigured`.
    Suspended,
}

/// Bytes out, commands in.
#[derive(Debug, Default)]
pub struct Link {
    tx: Deque<u8, TX_CAPACITY>,
    rx: FrameDecoder,
    commands: Deque<HostFrame, COMMAND_CAPACITY>,
    connected: bool,
    hello_due: bool,
    queue_drops: u32,
    rx_errors: u32,
}

impl Link {
    pub fn new() -> Self {
        Self::default()
    }

    /// Tracks the host's DTR. On the rising edge the connection starts with a lone frame
    /// delimiter and the board owes the host a hello; on the falling edge whatever was queued is
    /// discarded (nobody is reading).
    pub fn set_connected(&mut self, connected: bool) {
        if connected && !self.connected {
            self.tx.clear();
            // Ends a stale frame the host may still receive from the previous connection; an
            // empty frame decodes to nothing. Cannot fail: the queue was just emptied.
            let _ = self.tx.push_back(0);
            self.hello_due = true;
        }
        if !connected {
            self.tx.clear();
        }
        self.connected = connected;
    }

    /// Tracks the port as the USB interrupt sees it, the device's state and the class's DTR,
    /// and returns the edge, if this call saw one. While suspended nothing changes: a falling
    /// edge would reset the class, clearing the DTR the host still holds, and the stream would
    /// not come back on resume.
    pub fn update_usb(&mut self, usb: UsbState, dtr: bool) -> Option<DtrEdge> {
        match usb {
            UsbState::Suspended => None,
            UsbState::Configured => self.update_dtr(dtr),
            UsbState::Unconfigured => self.update_dtr(false),
        }
    }

    /// Tracks DTR and returns the edge, if this call saw one.
    fn update_dtr(&mut self, dtr: bool) -> Option<DtrEdge> {
        let edge = match (self.connected, dtr) {
            (false, true) => Some(DtrEdge::Rising),
            (true, false) => Some(DtrEdge::Falling),
            _ => None,
        };
        self.set_connected(dtr);
        edge
    }

    pub fn connected(&self) -> bool {
        self.connected
    }

    /// Whether a hello must be sent (cleared by this call).
    pub fn take_hello_due(&mut self) -> bool {
        core::mem::take(&mut self.hello_due)
    }

    /// Queues one frame whole, or not at all (counted as a drop when the queue is full).
    /// Frames are discarded silently while no host is connected.
    pub fn send(&mut self, frame: &BoardFrame) -> bool {
        if !self.connected {
            return false;
        }
        let mut buf = [0u8; MAX_FRAME];
        let Ok(n) = wire::encode(frame, &mut buf) else {
            // Every BoardFrame fits MAX_FRAME (tested in model-core); count it rather than panic.
            self.queue_drops = self.queue_drops.saturating_add(1);
            return false;
        };
        if self.tx.capacity() - self.tx.len() < n {
            self.queue_drops = self.queue_drops.saturating_add(1);
            return false;
        }
        for &b in &buf[..n] {
            // Cannot fail: room checked above.
            let _ = self.tx.push_back(b);
        }
        true
    }

    /// The next contiguous run of bytes to hand to USB.
    pub fn pending(&self) -> &[u8] {
        self.tx.as_slices().0
    }

    /// Marks `n` bytes of `pending()` as written.
    pub fn consume(&mut self, n: usize) {
        for _ in 0..n {
            if self.tx.pop_front().is_none() {
                break;
            }
        }
    }

    /// Bytes waiting to go out.
    pub fn queued(&self) -> usize {
        self.tx.len()
    }

    /// Feeds bytes from the host. Decoded commands wait for [`Link::next_command`]; frames that
    /// fail to decode are answered with a `Malformed` rejection, a full command queue with
    /// `OutOfRange` for that command's id.
    pub fn receive(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match self.rx.push::<HostFrame>(b) {
                None => {}
                Some(Ok(frame)) => self.queue_command(frame),
                Some(Err(_)) => {
                    self.rx_errors = self.rx_errors.saturating_add(1);
                    self.send(&BoardFrame::Rejected {
                        id: None,
                        reason: Rejection::Malformed,
                    });
                }
            }
        }
    }

    /// Queues a decoded command; a full queue rejects it by its id.
    fn queue_command(&mut self, frame: HostFrame) {
        if self.commands.push_back(frame).is_err() {
            self.send(&BoardFrame::Rejected {
                id: Some(frame.id),
                reason: Rejection::OutOfRange,
            });
        }
    }

    pub fn next_command(&mut self) -> Option<HostFrame> {
        self.commands.pop_front()
    }

    pub fn queue_drops(&self) -> u32 {
        self.queue_drops
    }

    pub fn rx_errors(&self) -> u32 {
        self.rx_errors
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use model_core::wire::{Command, FrameError};

    fn ack(id: u16) -> BoardFrame {
        BoardFrame::Ack { id }
    }

    fn drain(link: &mut Link) -> Vec<u8> {
        let mut out = Vec::new();
        while !link.pending().is_empty() {
            // USB writes at most 64 bytes at a time.
            let chunk: Vec<u8> = link.pending().iter().take(64).copied().collect();
            link.consume(chunk.len());
            out.extend(chunk);
        }
        out
    }

    fn decode_all(bytes: &[u8]) -> Vec<Result<BoardFrame, FrameError>> {
        let mut out = Vec::new();
        FrameDecoder::new().feed(bytes, |r| out.push(r));
        out
    }

    #[test]
    fn sends_only_while_connected_and_greets_on_connect() {
        let mut link = Link::new();
        assert!(!link.send(&ack(1)));
        assert_eq!(link.queued(), 0);
        link.set_connected(true);
        assert!(link.take_hello_due());
        assert!(!link.take_hello_due());
        assert!(link.send(&ack(2)));
        assert_eq!(decode_all(&drain(&mut link)), vec![Ok(ack(2))]);
        assert!(link.send(&ack(3)));
        link.set_connected(false);
        assert_eq!(link.queued(), 0, "queue discarded when the host goes away");
        link.set_connected(true);
        assert!(link.take_hello_due());
    }

    #[test]
    fn dtr_edges_are_reported_once_and_gate_the_queue() {
        let mut link = Link::new();
        assert_eq!(link.update_usb(UsbState::Configured, false), None);
        assert_eq!(
            link.update_usb(UsbState::Configured, true),
            Some(DtrEdge::Rising)
        );
        assert!(link.take_hello_due());
        assert_eq!(link.update_usb(UsbState::Configured, true), None);
        assert!(!link.take_hello_due(), "one hello per connection");
        assert!(link.send(&ack(1)));
        assert_eq!(
            link.update_usb(UsbState::Configured, false),
            Some(DtrEdge::Falling)
        );
        assert_eq!(link.queued(), 0);
        assert!(!link.send(&ack(2)));
        assert_eq!(
            link.update_usb(UsbState::Configured, true),
            Some(DtrEdge::Rising)
        );
        assert!(link.take_hello_due());
    }

    fn encoded(frame: &BoardFrame) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME];
        let n = wire::encode(frame, &mut buf).expect("fits");
        buf[..n].to_vec()
    }

    #[test]
    fn every_connection_starts_with_a_lone_delimiter_before_its_hello() {
        let hello = BoardFrame::Hello(
            crate::sampler::Sampler::new(crate::sampler::SamplerConfig::BOARD).hello(),
        );
        let mut link = Link::new();
        for connection in 0..3u16 {
            assert_eq!(
                link.update_usb(UsbState::Configured, true),
                Some(DtrEdge::Rising)
            );
            assert_eq!(link.pending(), [0], "the delimiter goes out first");
            assert!(link.take_hello_due());
            assert!(link.send(&hello));
            assert!(link.send(&ack(connection)));
            let expected = [vec![0], encoded(&hello), encoded(&ack(connection))].concat();
            assert_eq!(drain(&mut link), expected);
            // Left queued when the host closes the port: dropped, the next one starts afresh.
            assert!(link.send(&ack(99)));
            assert_eq!(
                link.update_usb(UsbState::Configured, false),
                Some(DtrEdge::Falling)
            );
            assert_eq!(link.queued(), 0);
        }
    }

    /// usbd-serial's DTR: set by the host's SET_CONTROL_LINE_STATE, cleared by a class reset
    /// (usb-device's on a bus reset, `main.rs`'s on a falling edge).
    struct Port {
        dtr: bool,
    }

    /// One run of the USB interrupt as `main.rs` does it: the edge, and the class reset on a
    /// falling one.
    fn interrupt(link: &mut Link, port: &mut Port, usb: UsbState) -> Option<DtrEdge> {
        let edge = link.update_usb(usb, port.dtr);
        if edge == Some(DtrEdge::Falling) {
            port.dtr = false;
        }
        edge
    }

    #[test]
    fn suspend_and_resume_with_dtr_held_keep_the_connection() {
        let mut link = Link::new();
        let mut port = Port { dtr: true };
        assert_eq!(
            interrupt(&mut link, &mut port, UsbState::Configured),
            Some(DtrEdge::Rising)
        );
        assert!(link.take_hello_due());
        drain(&mut link);
        assert!(link.send(&ack(1)));

        // The host suspends the bus; the class keeps DTR, the port stays open.
        assert_eq!(interrupt(&mut link, &mut port, UsbState::Suspended), None);
        assert!(port.dtr, "no class reset while suspended");
        assert!(link.connected());
        assert!(link.send(&ack(2)), "frames keep queuing while suspended");
        // Resume: usb-device is back to Configured, and the host sends no new line state.
        assert_eq!(interrupt(&mut link, &mut port, UsbState::Configured), None);
        assert!(!link.take_hello_due(), "the same connection: no new hello");
        assert_eq!(
            drain(&mut link),
            [encoded(&ack(1)), encoded(&ack(2))].concat(),
            "the stream goes on where it was, no delimiter in between"
        );

        // A long suspend fills the queue: whole frames are dropped and counted (the status
        // frame reports `queue_drops`, a sample's loss shows as a gap in `seq`).
        assert_eq!(interrupt(&mut link, &mut port, UsbState::Suspended), None);
        let mut queued = 0;
        while link.send(&ack(queued)) {
            queued += 1;
        }
        assert_eq!(link.queue_drops(), 1);
        assert_eq!(interrupt(&mut link, &mut port, UsbState::Configured), None);
        assert_eq!(decode_all(&drain(&mut link)).len(), usize::from(queued));

        // A real disconnect is a bus reset (usb-device resets the class: DTR cleared), seen as
        // Default or Addressed, even if it came during a suspend.
        assert_eq!(interrupt(&mut link, &mut port, UsbState::Suspended), None);
        assert!(link.send(&ack(3)));
        assert_eq!(
            interrupt(&mut link, &mut port, UsbState::Unconfigured),
            Some(DtrEdge::Falling),
            "not configured is closed, whatever DTR the class last heard"
        );
        assert_eq!(link.queued(), 0);
        assert_eq!(interrupt(&mut link, &mut port, UsbState::Configured), None);
        port.dtr = true; // re-enumerated and opened again
        assert_eq!(
            interrupt(&mut link, &mut port, UsbState::Configured),
            Some(DtrEdge::Rising)
        );
        assert!(link.take_hello_due());
    }

    #[test]
    fn a_full_queue_drops_whole_frames_and_counts_them() {
        let mut link = Link::new();
        link.set_connected(true);
        let mut sent = 0;
        while link.send(&ack(sent)) {
            sent += 1;
        }
        assert!(!link.send(&ack(9)));
        assert_eq!(
            link.queue_drops(),
            2,
            "the frame that did not fit, and this one"
        );
        let frames = decode_all(&drain(&mut link));
        assert_eq!(frames.len(), usize::from(sent));
        assert!(frames
            .iter()
            .enumerate()
            .all(|(i, f)| *f == Ok(ack(i as u16))));
    }

    #[test]
    fn commands_in_rejections_out() {
        let mut link = Link::new();
        link.set_connected(true);
        let mut buf = [0u8; MAX_FRAME];
        let n = wire::encode(
            &HostFrame {
                id: 5,
                command: Command::ResetEnergy,
            },
            &mut buf,
        )
        .expect("fits");
        // Garbage, then a good command split across two USB packets.
        link.receive(&[0x13, 0x37, 0x00]);
        link.receive(&buf[..3]);
        link.receive(&buf[3..n]);
        assert_eq!(
            link.next_command(),
            Some(HostFrame {
                id: 5,
                command: Command::ResetEnergy
            })
        );
        assert_eq!(link.next_command(), None);
        assert_eq!(link.rx_errors(), 1);
        assert_eq!(
            decode_all(&drain(&mut link)),
            vec![Ok(BoardFrame::Rejected {
                id: None,
                reason: Rejection::Malformed
            })]
        );
        for _ in 0..COMMAND_CAPACITY + 1 {
            link.receive(&buf[..n]);
        }
        assert_eq!(
            decode_all(&drain(&mut link)),
            vec![Ok(BoardFrame::Rejected {
                id: Some(5),
                reason: Rejection::OutOfRange
            })]
        );
    }
}
