//! The USB side of the board: whole frames into a bounded transmit queue, host bytes into
//! commands. Transmits only while the host holds DTR (a port nobody reads would only fill up).

use heapless::Deque;
use model_core::wire::{self, BoardFrame, FrameDecoder, HostFrame, Rejection, MAX_FRAME};

/// Transmit queue [bytes]: ~100 sample frames, half a second at the default 200 Hz.
pub const TX_CAPACITY: usize = 4096;
/// Host commands waiting for the sampler.
pub const COMMAND_CAPACITY: usize = 8;

/// A change of the host's DTR ([`Link::update_dtr`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DtrEdge {
    /// A host opened the port: a hello is due.
    Rising,
    /// The host closed the port: the queue was dropped; the caller drops its USB class's own
    /// write buffer too, so the next connection starts near its hello.
    Falling,
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

    /// Tracks the host's DTR. On the rising edge the board owes the host a hello; on the falling
    /// edge whatever was queued is discarded (nobody is reading).
    pub fn set_connected(&mut self, connected: bool) {
        if connected && !self.connected {
            self.hello_due = true;
        }
        if !connected {
            self.tx.clear();
        }
        self.connected = connected;
    }

    /// Tracks DTR as the USB interrupt sees it (device configured and DTR set) and returns the
    /// edge, if this call saw one.
    pub fn update_dtr(&mut self, dtr: bool) -> Option<DtrEdge> {
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
        assert_eq!(link.update_dtr(false), None);
        assert_eq!(link.update_dtr(true), Some(DtrEdge::Rising));
        assert!(link.take_hello_due());
        assert_eq!(link.update_dtr(true), None);
        assert!(!link.take_hello_due(), "one hello per connection");
        assert!(link.send(&ack(1)));
        assert_eq!(link.update_dtr(false), Some(DtrEdge::Falling));
        assert_eq!(link.queued(), 0);
        assert!(!link.send(&ack(2)));
        assert_eq!(link.update_dtr(true), Some(DtrEdge::Rising));
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
