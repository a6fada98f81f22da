//! The USB side of the board: whole frames into a bounded transmit queue, host bytes into
//! commands. Transmits only while the host holds DTR (a port nobody reads would only fill up).
//!
//! Every connection starts with a lone frame delimiter: a packet already armed in the IN endpoint
//! when the host closed the port survives the close and arrives first on the next connection,
//! usually cut mid-frame; the delimiter ends that cut frame, so it cannot swallow the hello.
//! A suspended bus is not a closed port: the host keeps DTR set through suspend and resume and
//! sends no new line state, so suspend is neither an edge nor a reason to reset the USB class.
//! A new connection (DTR's rising edge) owes nothing to the one before: the host-to-board
//! decoder, the commands not yet applied and the link's counters start afresh.
//!
//! [`Link::service_usb`] is the USB interrupt's whole use of the port, on the board (usbd-serial
//! behind [`CdcPort`] in `main.rs`) and in the tests (a fake port) alike.

use heapless::Deque;
use model_core::wire::{self, BoardFrame, FrameDecoder, HostFrame, Rejection, MAX_FRAME};

/// Transmit queue [bytes]: ~100 sample frames, half a second at the default 200 Hz.
pub const TX_CAPACITY: usize = 4096;
/// Host commands waiting for the sampler.
pub const COMMAND_CAPACITY: usize = 8;
/// USB full-speed bulk packet size: the most the port takes or hands over at once.
pub const USB_PACKET: usize = 64;

/// A change of the host's DTR ([`Link::update_usb`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DtrEdge {
    /// A host opened the port: a frame delimiter is queued, a hello is due.
    Rising,
    /// The host closed the port (or the bus was reset): the queue was dropped, and
    /// [`Link::service_usb`] resets the USB class too, so the next connection starts near its
    /// hello.
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

/// The CDC-ACM port as the USB interrupt drives it: usbd-serial's `SerialPort` on the board.
pub trait CdcPort {
    /// The host's DTR as the class last heard it (set by SET_CONTROL_LINE_STATE).
    fn dtr(&self) -> bool;
    /// Resets the class (usb-device's `UsbClass::reset`): drops its read and write buffers and
    /// clears DTR, RTS and the line coding.
    fn reset(&mut self);
    /// Moves received bytes into `buf`; 0 when none are waiting.
    fn read(&mut self, buf: &mut [u8]) -> usize;
    /// Takes bytes for the IN endpoint; 0 while it is busy.
    fn write(&mut self, bytes: &[u8]) -> usize;
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

    /// Tracks the host's DTR. On the rising edge a new connection starts ([`Self::start`]); on
    /// the falling edge whatever was queued is discarded (nobody is reading).
    pub fn set_connected(&mut self, connected: bool) {
        if connected && !self.connected {
            self.start();
        }
        if !connected {
            self.tx.clear();
        }
        self.connected = connected;
    }

    /// A new connection: nothing of an earlier one reaches its host. The transmit queue is
    /// already empty (cleared on the falling edge; `send` refuses while no host is connected).
    /// A frame cut by the previous host's close would swallow this host's first command, a
    /// command the previous host left queued would be answered to this one, and drops counted
    /// while an unplugged board sat suspended (without VBUS sensing a pulled cable reads as a
    /// suspend) would show in this host's status.
    fn start(&mut self) {
        self.rx = FrameDecoder::new();
        self.commands.clear();
        self.queue_drops = 0;
        self.rx_errors = 0;
        // Ends a stale frame the host may still receive from the previous connection; an empty
        // frame decodes to nothing. Cannot fail: the queue is empty.
        let _ = self.tx.push_back(0);
        self.hello_due = true;
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

    /// One run of the USB interrupt after usb-device's poll, `usb` the device's state then: the
    /// port's DTR edge, the host's bytes, the queued frames out while the port is open. The edge
    /// comes first, so bytes that follow a new host's DTR go to a fresh decoder; a closing host's
    /// last packet is still read (the class reset drops only usbd-serial's own buffer, which the
    /// previous run emptied) and its commands applied. Returns the edge, for the board's log.
    pub fn service_usb<P: CdcPort>(&mut self, usb: UsbState, port: &mut P) -> Option<DtrEdge> {
        let edge = self.update_usb(usb, port.dtr());
        if edge == Some(DtrEdge::Falling) {
            // The host closed the port: drop usbd-serial's 128-byte write buffer too (only a USB
            // reset would), so the next connection starts nearer its hello. A packet already in
            // the endpoint FIFO still goes out first on the next connection, usually cut
            // mid-frame: the connection's lone delimiter ends it. The class reset also clears
            // DTR/RTS and the line coding, which the host sets again on open.
            port.reset();
        }
        let mut buf = [0u8; USB_PACKET];
        loop {
            let n = port.read(&mut buf).min(buf.len());
            if n == 0 {
                break;
            }
            self.receive(&buf[..n]);
        }
        // Not while suspended: frames wait in the queue (whole frames dropped and counted once
        // it is full) and go out after the resume.
        while usb == UsbState::Configured && self.connected && !self.tx.is_empty() {
            let pending = self.pending();
            let chunk = &pending[..pending.len().min(USB_PACKET)];
            let n = port.write(chunk).min(chunk.len());
            if n == 0 {
                // Endpoint busy: the transfer-complete interrupt brings us back.
                break;
            }
            self.consume(n);
        }
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

    fn encoded_command(id: u16, command: Command) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME];
        let n = wire::encode(&HostFrame { id, command }, &mut buf).expect("fits");
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

    /// usbd-serial as the USB interrupt sees it: DTR set by the host's SET_CONTROL_LINE_STATE
    /// and cleared by a class reset (usb-device's on a bus reset, the link's on a falling edge);
    /// packets from the host waiting in the OUT endpoint; what the IN endpoint took.
    #[derive(Debug, Default)]
    struct FakePort {
        dtr: bool,
        resets: u32,
        from_host: std::collections::VecDeque<Vec<u8>>,
        to_host: Vec<u8>,
        /// The IN endpoint takes nothing (the host is not reading).
        busy: bool,
    }

    impl CdcPort for FakePort {
        fn dtr(&self) -> bool {
            self.dtr
        }

        fn reset(&mut self) {
            self.dtr = false;
            self.resets += 1;
        }

        fn read(&mut self, buf: &mut [u8]) -> usize {
            let Some(packet) = self.from_host.pop_front() else {
                return 0;
            };
            buf[..packet.len()].copy_from_slice(&packet);
            packet.len()
        }

        fn write(&mut self, bytes: &[u8]) -> usize {
            if self.busy {
                return 0;
            }
            assert!(bytes.len() <= USB_PACKET, "one packet at a time");
            self.to_host.extend_from_slice(bytes);
            bytes.len()
        }
    }

    impl FakePort {
        /// Bytes the host sends, in packets as USB carries them.
        fn send_from_host(&mut self, bytes: &[u8]) {
            self.from_host
                .extend(bytes.chunks(USB_PACKET).map(<[u8]>::to_vec));
        }

        fn take_to_host(&mut self) -> Vec<u8> {
            std::mem::take(&mut self.to_host)
        }
    }

    #[test]
    fn suspend_and_resume_with_dtr_held_keep_the_connection() {
        let mut link = Link::new();
        let mut port = FakePort {
            dtr: true,
            ..FakePort::default()
        };
        assert_eq!(
            link.service_usb(UsbState::Configured, &mut port),
            Some(DtrEdge::Rising)
        );
        assert!(link.take_hello_due());
        assert_eq!(port.take_to_host(), [0], "the delimiter went out");
        assert!(link.send(&ack(1)));

        // The host suspends the bus; the class keeps DTR, the port stays open.
        assert_eq!(link.service_usb(UsbState::Suspended, &mut port), None);
        assert!(port.dtr, "no class reset while suspended");
        assert_eq!(port.resets, 0);
        assert!(link.connected());
        assert!(port.to_host.is_empty(), "nothing sent while suspended");
        assert!(link.send(&ack(2)), "frames keep queuing while suspended");
        // Resume: usb-device is back to Configured, and the host sends no new line state.
        assert_eq!(link.service_usb(UsbState::Configured, &mut port), None);
        assert!(!link.take_hello_due(), "the same connection: no new hello");
        assert_eq!(
            port.take_to_host(),
            [encoded(&ack(1)), encoded(&ack(2))].concat(),
            "the stream goes on where it was, no delimiter in between"
        );

        // A long suspend fills the queue: whole frames are dropped and counted (the status
        // frame reports `queue_drops`, a sample's loss shows as a gap in `seq`).
        assert_eq!(link.service_usb(UsbState::Suspended, &mut port), None);
        let mut queued = 0;
        while link.send(&ack(queued)) {
            queued += 1;
        }
        assert_eq!(link.queue_drops(), 1);
        assert_eq!(link.service_usb(UsbState::Configured, &mut port), None);
        assert_eq!(decode_all(&port.take_to_host()).len(), usize::from(queued));
        assert_eq!(link.queue_drops(), 1, "the same connection keeps its count");

        // A real disconnect is a bus reset (usb-device resets the class: DTR cleared), seen as
        // Default or Addressed, even if it came during a suspend.
        assert_eq!(link.service_usb(UsbState::Suspended, &mut port), None);
        assert!(link.send(&ack(3)));
        port.dtr = false; // usb-device's class reset
        assert_eq!(
            link.service_usb(UsbState::Unconfigured, &mut port),
            Some(DtrEdge::Falling),
            "not configured is closed, whatever DTR the class last heard"
        );
        assert_eq!(link.queued(), 0);
        assert_eq!(link.service_usb(UsbState::Configured, &mut port), None);
        port.dtr = true; // re-enumerated and opened again
        assert_eq!(
            link.service_usb(UsbState::Configured, &mut port),
            Some(DtrEdge::Rising)
        );
        assert!(link.take_hello_due());
    }

    #[test]
    fn a_falling_edge_resets_the_class_and_stops_sending() {
        let mut link = Link::new();
        let mut port = FakePort {
            dtr: true,
            ..FakePort::default()
        };
        link.service_usb(UsbState::Configured, &mut port);
        port.take_to_host();
        port.busy = true;
        assert!(link.send(&ack(1)));
        assert_eq!(link.service_usb(UsbState::Configured, &mut port), None);
        assert!(link.queued() > 0, "a busy endpoint leaves the frame queued");
        port.busy = false;
        port.dtr = false; // the host closes the port
        assert_eq!(
            link.service_usb(UsbState::Configured, &mut port),
            Some(DtrEdge::Falling)
        );
        assert_eq!(port.resets, 1, "usbd-serial's buffers dropped too");
        assert_eq!((link.queued(), port.to_host.len()), (0, 0));
        assert!(!link.send(&ack(2)));
    }

    /// A self-powered board whose cable is pulled: no VBUS sensing, so usb-device reports a
    /// suspend and the link keeps the connection while its queue fills and drops. The next
    /// host's bus reset ends it; the new connection's counts and bytes are its own.
    #[test]
    fn the_next_host_sees_nothing_of_a_connection_that_ended_in_a_pulled_cable() {
        let mut link = Link::new();
        let mut port = FakePort {
            dtr: true,
            ..FakePort::default()
        };
        link.service_usb(UsbState::Configured, &mut port);
        assert!(link.take_hello_due());
        port.send_from_host(&[0x13, 0x37, 0x00]);
        link.service_usb(UsbState::Configured, &mut port);
        assert_eq!(link.rx_errors(), 1);

        // Unplugged: a suspend that lasts, with frames queued at the sampling rate.
        assert_eq!(link.service_usb(UsbState::Suspended, &mut port), None);
        for k in 0..1_000 {
            link.send(&ack(k));
        }
        assert!(link.queue_drops() > 0);
        assert!(
            link.connected(),
            "still connected, as far as the board knows"
        );

        // Plugged into the next host: bus reset (usb-device resets the class), enumeration,
        // the host opens the port.
        port.dtr = false;
        assert_eq!(
            link.service_usb(UsbState::Unconfigured, &mut port),
            Some(DtrEdge::Falling)
        );
        assert_eq!(link.service_usb(UsbState::Configured, &mut port), None);
        port.take_to_host(); // what the first host was sent before the pull
        port.dtr = true;
        assert_eq!(
            link.service_usb(UsbState::Configured, &mut port),
            Some(DtrEdge::Rising)
        );
        assert_eq!(
            (link.queue_drops(), link.rx_errors()),
            (0, 0),
            "the previous connection's counts are not this host's"
        );
        assert_eq!(
            port.take_to_host(),
            [0],
            "only the delimiter: nothing stale"
        );
    }

    #[test]
    fn a_frame_cut_by_the_previous_host_does_not_swallow_the_next_hosts_first_command() {
        let mut link = Link::new();
        let mut port = FakePort {
            dtr: true,
            ..FakePort::default()
        };
        link.service_usb(UsbState::Configured, &mut port);
        let cut = encoded_command(7, Command::GetStatus);
        port.send_from_host(&cut[..cut.len() / 2]);
        port.dtr = false; // closed mid-frame
        link.service_usb(UsbState::Configured, &mut port);
        // The next host's first command arrives in the same interrupt as its DTR.
        port.dtr = true;
        port.send_from_host(&encoded_command(1, Command::GetHello));
        assert_eq!(
            link.service_usb(UsbState::Configured, &mut port),
            Some(DtrEdge::Rising)
        );
        assert_eq!(
            link.next_command(),
            Some(HostFrame {
                id: 1,
                command: Command::GetHello
            })
        );
        assert_eq!(link.next_command(), None);
        assert_eq!(link.rx_errors(), 0);
    }

    #[test]
    fn commands_left_by_the_previous_host_are_not_answered_to_the_next() {
        let mut link = Link::new();
        let mut port = FakePort {
            dtr: true,
            ..FakePort::default()
        };
        link.service_usb(UsbState::Configured, &mut port);
        port.send_from_host(&encoded_command(3, Command::ResetEnergy));
        link.service_usb(UsbState::Configured, &mut port);
        port.dtr = false;
        link.service_usb(UsbState::Configured, &mut port);
        port.dtr = true;
        link.service_usb(UsbState::Configured, &mut port);
        assert_eq!(link.next_command(), None);
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
