use super::*;
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, Operation};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

/// Counts feeds; shared with the test thread.
#[derive(Debug, Clone, Default)]
struct Counter(Arc<AtomicU32>);

impl Counter {
    fn feeds(&self) -> u32 {
        self.0.load(Ordering::SeqCst)
    }
}

impl Watchdog for Counter {
    fn feed(&mut self) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

/// An I²C bus where every transaction fails with `kind` (a stuck bus the driver bounded).
#[derive(Debug)]
struct Failing(ErrorKind);

impl ErrorType for Failing {
    type Error = ErrorKind;
}

impl I2c for Failing {
    fn transaction(&mut self, _: u8, _: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        Err(self.0)
    }
}

/// An I²C bus whose first transaction hangs until the test lets it go (then NACKs).
#[derive(Debug)]
struct Hanging {
    entered: mpsc::Sender<()>,
    release: mpsc::Receiver<()>,
}

impl ErrorType for Hanging {
    type Error = ErrorKind;
}

impl I2c for Hanging {
    fn transaction(&mut self, _: u8, _: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        let _ = self.entered.send(());
        let _ = self.release.recv();
        Err(ErrorKind::NoAcknowledge(
            embedded_hal::i2c::NoAcknowledgeSource::Address,
        ))
    }
}

/// A bus that panics: the tick is aborted half-way.
#[derive(Debug)]
struct Panicking;

impl ErrorType for Panicking {
    type Error = ErrorKind;
}

impl I2c for Panicking {
    fn transaction(&mut self, _: u8, _: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        panic!("the bus driver gave up")
    }
}

#[test]
fn a_completed_tick_feeds_the_watchdog_even_when_the_chips_fail() {
    let mut board = Board::new(SamplerConfig::BOARD);
    let mut link = Link::new();
    link.set_connected(true);
    let dog = Counter::default();
    let mut i2c = Failing(ErrorKind::Bus);
    for k in 0..3u64 {
        board.tick(&mut i2c, &mut link, &mut dog.clone(), k * 5_000);
        assert_eq!(dog.feeds(), k as u32 + 1, "fed once per tick");
    }
    // The stuck bus is reported as a fault, not left to the watchdog.
    assert_eq!(
        board.sampler().last_faults(),
        model_core::Sides::new(
            Some(model_core::wire::ChipFault::Bus),
            Some(model_core::wire::ChipFault::Bus)
        )
    );
}

#[test]
fn a_hung_tick_is_not_fed_until_it_completes() {
    let (entered_tx, entered) = mpsc::channel();
    let (release, release_rx) = mpsc::channel();
    let dog = Counter::default();
    let mut thread_dog = dog.clone();
    let ticking = std::thread::spawn(move || {
        let mut board = Board::new(SamplerConfig::BOARD);
        let mut link = Link::new();
        let mut i2c = Hanging {
            entered: entered_tx,
            release: release_rx,
        };
        board.tick(&mut i2c, &mut link, &mut thread_dog, 0);
    });
    entered
        .recv_timeout(Duration::from_secs(10))
        .expect("the tick reached the bus");
    std::thread::sleep(Duration::from_millis(50));
    assert_eq!(dog.feeds(), 0, "a tick stuck on the bus must not feed");
    // Let every transaction of the tick through.
    for _ in 0..16 {
        let _ = release.send(());
    }
    ticking.join().expect("tick completes");
    assert_eq!(dog.feeds(), 1);
}

#[test]
fn an_aborted_tick_is_not_fed() {
    let dog = Counter::default();
    let mut thread_dog = dog.clone();
    let outcome = std::panic::catch_unwind(move || {
        let mut board = Board::new(SamplerConfig::BOARD);
        let mut link = Link::new();
        board.tick(&mut Panicking, &mut link, &mut thread_dog, 0);
    });
    assert!(outcome.is_err());
    assert_eq!(dog.feeds(), 0);
}

#[test]
fn a_connection_starts_with_a_lone_delimiter_then_the_hello_then_the_stream() {
    use model_core::wire::{FrameDecoder, MAX_FRAME};
    let mut board = Board::new(SamplerConfig::BOARD);
    let mut link = Link::new();
    let mut i2c = Failing(ErrorKind::Bus);
    for k in 0..2u64 {
        link.set_connected(k == 1);
        board.tick(&mut i2c, &mut link, &mut Counter::default(), k * 5_000);
    }
    let mut bytes = Vec::new();
    while !link.pending().is_empty() {
        let n = link.pending().len();
        bytes.extend_from_slice(link.pending());
        link.consume(n);
    }
    let mut hello = [0u8; MAX_FRAME];
    let n = model_core::wire::encode(&BoardFrame::Hello(board.sampler().hello()), &mut hello)
        .expect("fits");
    assert_eq!(bytes[0], 0, "the delimiter first");
    assert_eq!(bytes[1..=n], hello[..n], "then the hello");
    let mut frames = Vec::new();
    FrameDecoder::new().feed(&bytes[1 + n..], |f: Result<BoardFrame, _>| frames.push(f));
    assert!(matches!(frames[..], [Ok(BoardFrame::Sample(s)), ..] if s.seq == 1));
}

/// A host flooding commands: whenever the tick takes the link, another command has arrived (the
/// USB interrupt runs while the tick awaits the bus), until `limit` were sent.
struct Flood {
    link: Link,
    sent: u16,
    limit: u16,
}

impl LinkAccess for Flood {
    fn with_link<R>(&mut self, f: impl FnOnce(&mut Link) -> R) -> R {
        if self.sent < self.limit {
            let frame = model_core::wire::HostFrame {
                id: self.sent,
                command: Command::ResetEnergy,
            };
            let mut buf = [0u8; model_core::wire::MAX_FRAME];
            let n = model_core::wire::encode(&frame, &mut buf).expect("fits");
            self.link.receive(&buf[..n]);
            self.sent += 1;
        }
        f(&mut self.link)
    }
}

#[test]
fn a_flooding_host_cannot_keep_a_tick_from_ending() {
    use model_core::wire::{FrameDecoder, Rejection};
    let mut board = Board::new(SamplerConfig::BOARD);
    let mut flood = Flood {
        link: Link::new(),
        sent: 0,
        limit: 200,
    };
    flood.link.set_connected(true);
    let dog = Counter::default();
    let mut acked = Vec::new();
    let mut refused = Vec::new();
    for tick in 0..100u64 {
        board.tick(
            &mut Failing(ErrorKind::Bus),
            &mut flood,
            &mut dog.clone(),
            tick * 5_000,
        );
        assert_eq!(dog.feeds(), tick as u32 + 1, "every tick ends and feeds");
        let mut bytes = Vec::new();
        while !flood.link.pending().is_empty() {
            let n = flood.link.pending().len();
            bytes.extend_from_slice(flood.link.pending());
            flood.link.consume(n);
        }
        let mut acks_this_tick = 0;
        FrameDecoder::new().feed(&bytes, |f: Result<BoardFrame, _>| match f {
            Ok(BoardFrame::Ack { id }) => {
                acks_this_tick += 1;
                acked.push(id);
            }
            Ok(BoardFrame::Rejected {
                id: Some(id),
                reason: Rejection::OutOfRange,
            }) => refused.push(id),
            Ok(_) => {}
            Err(e) => panic!("bad frame from the board: {e:?}"),
        });
        assert!(
            acks_this_tick <= COMMANDS_PER_TICK,
            "tick {tick} applied {acks_this_tick} commands"
        );
        if acked.len() + refused.len() == usize::from(flood.limit) {
            break;
        }
    }
    assert_eq!(flood.link.next_command(), None, "the queue drained");
    // Nothing the queue accepted was lost: every command was applied or refused when it came
    // (the queue full), and the applied ones in the order they were sent.
    assert!(acked.windows(2).all(|w| w[0] < w[1]), "in order: {acked:?}");
    let mut answered: Vec<u16> = acked.iter().chain(&refused).copied().collect();
    answered.sort_unstable();
    assert_eq!(answered, (0..flood.limit).collect::<Vec<_>>());
    assert!(
        acked.len() > COMMANDS_PER_TICK,
        "later ticks applied the commands left queued"
    );
}
