use super::fake::{Fake, Slave, Wire};
use super::*;
use crate::ina226::fault_of;
use core::future::{poll_fn, Future};
use core::pin::pin;
use core::task::Context;
use model_core::wire::ChipFault;
use std::cell::RefCell;
use std::rc::Rc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::task::Wake;

const LEFT: u8 = 0x40;
const RIGHT: u8 = 0x45;
/// Bus events before the test gives up, as the board's deadline does.
const DEADLINE_STEPS: u32 = 200;

/// Counts wake-ups.
#[derive(Debug, Default)]
struct Wakes(AtomicU32);

impl Wake for Wakes {
    fn wake(self: Arc<Self>) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

fn chips() -> Fake {
    Fake::new(&[
        (
            LEFT,
            Slave::with(&[(0x01, 0x0FA0), (0x02, 0x4B00), (0xFE, 0x5449)]),
        ),
        (RIGHT, Slave::with(&[(0x01, 0xF830), (0x02, 0x4AFF)])),
    ])
}

/// Runs one transfer: the hardware moves `latency + 1` bus events, then the handler serves its
/// request, until the transfer ends or the deadline passes (then aborted, as the
/// board's glue does). Returns the result and how often the waker was woken.
fn run(
    master: &mut Master,
    fake: &mut Fake,
    transfer: Transfer,
    latency: u32,
) -> (Result<Received, Failure>, u32) {
    // The previous STOP goes out first (the glue waits a few µs and retries).
    let mut tries = 0;
    while master.begin(fake, transfer) == Err(Busy) {
        fake.step();
        tries += 1;
        assert!(tries < 10, "STOP never went out");
    }
    let wakes = Arc::new(Wakes::default());
    let waker = Waker::from(wakes.clone());
    assert_eq!(master.poll(&waker), Poll::Pending);
    for _ in 0..DEADLINE_STEPS {
        for _ in 0..=latency {
            fake.step();
        }
        // One handler run per turn: the bus moves on between two (a flag such as BTF after a
        // repeated START request stays set until the START is on the wire).
        if fake.interrupt_pending() {
            master.on_interrupt(fake);
        }
        if let Poll::Ready(result) = master.poll(&waker) {
            assert!(!fake.interrupts_enabled(), "interrupts off at the end");
            return (result, wakes.0.load(Ordering::SeqCst));
        }
    }
    master.abort(fake);
    assert!(!fake.interrupts_enabled(), "interrupts off after an abort");
    (Err(Failure::Timeout), wakes.0.load(Ordering::SeqCst))
}

fn read_register(address: u8, register: u8) -> Transfer {
    let mut buf = [0u8; 2];
    Transfer::new(
        address,
        &[Operation::Write(&[register]), Operation::Read(&mut buf)],
    )
    .expect("a register read fits")
}

fn addr(address: u8, read: bool, acked: bool) -> Wire {
    Wire::Address {
        byte: (address << 1) | u8::from(read),
        acked,
    }
}

fn byte(byte: u8, acked: bool) -> Wire {
    Wire::Byte { byte, acked }
}

/// The wire of a register read: pointer, repeated START, 2 bytes, the second NACKed, STOP.
fn register_read_wire(address: u8, register: u8, value: u16) -> Vec<Wire> {
    let [hi, lo] = value.to_be_bytes();
    vec![
        Wire::Start,
        addr(address, false, true),
        byte(register, true),
        Wire::Start,
        addr(address, true, true),
        byte(hi, true),
        byte(lo, false),
        Wire::Stop,
    ]
}

#[test]
fn a_register_read_is_right_whatever_the_interrupt_latency() {
    // POS makes the NACK of byte 2 independent of when the handler runs (RM0383's 2-byte
    // procedure); a late handler only stretches SCL.
    for latency in 0..6 {
        let mut fake = chips();
        let mut master = Master::new();
        let (result, wakes) = run(&mut master, &mut fake, read_register(LEFT, 0x02), latency);
        assert_eq!(result.map(|r| r.bytes().to_vec()), Ok(vec![0x4B, 0x00]));
        assert_eq!(wakes, 1, "woken once, at the end");
        // The STOP goes out after the handler's last step.
        fake.step();
        assert_eq!(
            fake.wire,
            register_read_wire(LEFT, 0x02, 0x4B00),
            "{latency}"
        );
        assert_eq!(fake.violations, Vec::<&str>::new());
        assert_eq!(master.bus_errors(), 0);
        assert!(!master.busy());
    }
}

#[test]
fn an_end_before_the_first_poll_is_not_lost_and_a_late_interrupt_after_abort_does_nothing() {
    // The handler can run the whole transfer between `begin` and the task's first poll (the
    // task preempted): no waker yet, and none is needed, as poll sees the end under the lock.
    let mut fake = chips();
    let mut master = Master::new();
    master
        .begin(&mut fake, read_register(LEFT, 0x02))
        .expect("free");
    for _ in 0..DEADLINE_STEPS {
        fake.step();
        if fake.interrupt_pending() {
            master.on_interrupt(&mut fake);
        }
    }
    let wakes = Arc::new(Wakes::default());
    let waker = Waker::from(wakes.clone());
    let result = master.poll(&waker).map(|r| r.map(|r| r.bytes().to_vec()));
    assert_eq!(result, Poll::Ready(Ok(vec![0x4B, 0x00])));
    assert_eq!(wakes.0.load(Ordering::SeqCst), 0);
    // Aborted with SB pending (the deadline raced the handler): the request the NVIC still
    // holds runs the handler once more, which only switches the interrupts off again.
    master
        .begin(&mut fake, read_register(RIGHT, 0x01))
        .expect("free");
    fake.step();
    assert!(fake.interrupt_pending(), "SB");
    master.abort(&mut fake);
    master.on_interrupt(&mut fake);
    for _ in 0..4 {
        fake.step();
    }
    assert_eq!(fake.wire.last(), Some(&Wire::Start), "no address written");
    assert!(!fake.interrupts_enabled());
    assert!(!master.busy());
}

#[test]
fn a_short_read_and_a_register_write() {
    let mut fake = chips();
    let mut master = Master::new();
    // The pointer stays where the last write left it: a read without pointer.
    let mut buf = [0u8; 2];
    let short = Transfer::new(LEFT, &[Operation::Read(&mut buf)]).expect("fits");
    let write = Transfer::new(LEFT, &[Operation::Write(&[0x05, 0x08, 0x00])]).expect("fits");
    assert!(run(&mut master, &mut fake, write, 1).0.is_ok());
    let (result, _) = run(&mut master, &mut fake, short, 1);
    assert_eq!(result.map(|r| r.bytes().to_vec()), Ok(vec![0x08, 0x00]));
    fake.step();
    let mut want = vec![
        Wire::Start,
        addr(LEFT, false, true),
        byte(0x05, true),
        byte(0x08, true),
        byte(0x00, true),
        Wire::Stop,
    ];
    want.extend([
        Wire::Start,
        addr(LEFT, true, true),
        byte(0x08, true),
        byte(0x00, false),
        Wire::Stop,
    ]);
    assert_eq!(fake.wire, want);
    assert_eq!(fake.slaves[&LEFT].registers.get(&0x05), Some(&0x0800));
    assert_eq!(fake.violations, Vec::<&str>::new());
}

#[test]
fn one_byte_and_longer_reads_nack_only_the_last_byte() {
    for len in [1usize, 3, 4, 6] {
        for latency in [0, 3] {
            let mut fake = chips();
            let mut master = Master::new();
            let mut buf = [0u8; MAX_READ];
            let ops = [Operation::Write(&[0xFE]), Operation::Read(&mut buf[..len])];
            let transfer = Transfer::new(LEFT, &ops).expect("fits");
            let (result, _) = run(&mut master, &mut fake, transfer, latency);
            let want: Vec<u8> = [0x54, 0x49]
                .into_iter()
                .chain([0xFF; 4])
                .take(len)
                .collect();
            assert_eq!(result.map(|r| r.bytes().to_vec()), Ok(want.clone()));
            fake.step();
            let received: Vec<Wire> = fake.wire[5..].to_vec();
            let mut expected: Vec<Wire> = want
                .iter()
                .enumerate()
                .map(|(k, &b)| byte(b, k + 1 < len))
                .collect();
            expected.push(Wire::Stop);
            assert_eq!(received, expected, "{len} bytes, latency {latency}");
            assert_eq!(fake.violations, Vec::<&str>::new());
        }
    }
}

#[test]
fn a_missing_chip_nacks_its_address_and_the_bus_is_released() {
    let mut fake = chips();
    let mut master = Master::new();
    let (result, wakes) = run(&mut master, &mut fake, read_register(0x41, 0x02), 0);
    assert_eq!(result, Err(Failure::Nack(NoAcknowledgeSource::Address)));
    assert_eq!(wakes, 1);
    let failure = result.expect_err("nacked");
    assert_eq!(fault_of(&failure.kind()), ChipFault::AddressNack);
    assert!(!failure.needs_bus_reset(), "a STOP frees the bus");
    // The next transfer starts once that STOP is out, and works.
    let (result, _) = run(&mut master, &mut fake, read_register(LEFT, 0x01), 0);
    assert_eq!(result.map(|r| r.bytes().to_vec()), Ok(vec![0x0F, 0xA0]));
    assert_eq!(
        fake.wire[..3],
        [Wire::Start, addr(0x41, false, false), Wire::Stop]
    );
    assert_eq!(fake.violations, Vec::<&str>::new());
}

#[test]
fn a_nacked_data_byte_ends_the_write_with_a_stop() {
    let mut fake = chips();
    if let Some(slave) = fake.slaves.get_mut(&LEFT) {
        slave.nack_data_byte = Some(1);
    }
    let mut master = Master::new();
    let write = Transfer::new(LEFT, &[Operation::Write(&[0x00, 0x44, 0x07])]).expect("fits");
    let (result, _) = run(&mut master, &mut fake, write, 0);
    assert_eq!(result, Err(Failure::Nack(NoAcknowledgeSource::Data)));
    assert_eq!(
        fault_of(&Failure::Nack(NoAcknowledgeSource::Data).kind()),
        ChipFault::DataNack
    );
    // 0x07 was already in DR behind the NACKed byte: it never goes out, and the next transfer
    // (its address written over it) starts clean.
    let (result, _) = run(&mut master, &mut fake, read_register(LEFT, 0x01), 0);
    assert_eq!(result.map(|r| r.bytes().to_vec()), Ok(vec![0x0F, 0xA0]));
    fake.step();
    let mut want = vec![
        Wire::Start,
        addr(LEFT, false, true),
        byte(0x00, true),
        byte(0x44, false),
        Wire::Stop,
    ];
    want.extend(register_read_wire(LEFT, 0x01, 0x0FA0));
    assert_eq!(fake.wire, want);
    assert_eq!(fake.violations, Vec::<&str>::new());
}

#[test]
fn arbitration_lost_asks_for_a_bus_reset() {
    let mut fake = chips();
    fake.arlo_at = Some(4);
    let mut master = Master::new();
    let (result, wakes) = run(&mut master, &mut fake, read_register(LEFT, 0x01), 0);
    assert_eq!(result, Err(Failure::ArbitrationLoss));
    assert_eq!(wakes, 1);
    assert!(Failure::ArbitrationLoss.needs_bus_reset());
    assert_eq!(
        fault_of(&Failure::ArbitrationLoss.kind()),
        ChipFault::ArbitrationLoss
    );
    assert!(!fake.wire.contains(&Wire::Stop), "no STOP from a slave");
}

#[test]
fn a_spurious_bus_error_is_cleared_and_the_read_goes_on() {
    for at in 1..9 {
        let mut fake = chips();
        fake.berr_at = Some(at);
        let mut master = Master::new();
        let (result, _) = run(&mut master, &mut fake, read_register(RIGHT, 0x01), 0);
        assert_eq!(
            result.map(|r| r.bytes().to_vec()),
            Ok(vec![0xF8, 0x30]),
            "BERR at {at}"
        );
        assert_eq!(master.bus_errors(), 1);
        assert_eq!(fake.violations, Vec::<&str>::new());
    }
}

#[test]
fn a_bus_stuck_mid_transfer_ends_at_the_deadline() {
    // A slave holding SCL or SDA low from some bus event on: nothing more happens.
    for stall_at in [1, 3, 5, 7, 8] {
        let mut fake = chips();
        fake.stall_at = Some(stall_at);
        let mut master = Master::new();
        let (result, wakes) = run(&mut master, &mut fake, read_register(LEFT, 0x02), 0);
        let failure = result.expect_err("stuck");
        match failure {
            // No more events: the deadline ends it.
            Failure::Timeout => assert_eq!(wakes, 0, "stalled at {stall_at}"),
            // Stuck with BTF set (a repeated START that never goes out): the handler's own
            // count ends it before the deadline.
            Failure::Stalled => assert_eq!((stall_at, wakes), (5, 1)),
            other => panic!("stalled at {stall_at}: {other:?}"),
        }
        assert!(!master.busy(), "ended");
        assert_eq!(fault_of(&failure.kind()), ChipFault::Bus);
        assert!(failure.needs_bus_reset());
        // The bus reset sends the STOP; no CR1 write lands on the START still pending.
        assert_eq!(fake.violations, Vec::<&str>::new(), "stalled at {stall_at}");
    }
}

#[test]
fn a_slow_repeated_start_is_waited_for_up_to_the_stall_count() {
    // BTF stays set until the repeated START is on the wire (RM0383: BTF is cleared by hardware
    // at a START), so the handler runs again and again meanwhile. At 400 kHz that is ~3 µs, 2–3
    // runs of ~1.5 µs: far inside the count; only a START held off much longer is a stall.
    let limit = u32::from(MAX_IDLE_INTERRUPTS);
    for (delay, stalled) in [(limit - 1, false), (limit, true)] {
        let mut fake = chips();
        fake.restart_delay = delay;
        let mut master = Master::new();
        let (result, _) = run(&mut master, &mut fake, read_register(LEFT, 0x02), 0);
        if stalled {
            assert_eq!(result, Err(Failure::Stalled), "{delay}");
        } else {
            assert_eq!(result.map(|r| r.bytes().to_vec()), Ok(vec![0x4B, 0x00]));
            fake.step();
            assert_eq!(fake.wire, register_read_wire(LEFT, 0x02, 0x4B00));
        }
    }
}

#[test]
fn a_flag_the_handler_cannot_clear_is_a_stall_not_a_storm() {
    // The handler waits for SB. A stray BTF (no reason to be set) keeps requesting; so does a
    // BERR the hardware raises again each time it is cleared (a noisy line: before, each BERR
    // reset the stall count and the handler could run for ever at the highest priority).
    for (stray_sr1, bus_errors) in [(Sr1::BTF, 0), (Sr1::BERR, u32::from(MAX_IDLE_INTERRUPTS))] {
        let mut fake = chips();
        let mut master = Master::new();
        master
            .begin(&mut fake, read_register(LEFT, 0x02))
            .expect("free");
        let mut stray = Tampered {
            fake,
            stray_sr1,
            drop_pos: false,
        };
        for _ in 0..MAX_IDLE_INTERRUPTS {
            master.on_interrupt(&mut stray);
        }
        let waker = Waker::from(Arc::new(Wakes::default()));
        assert_eq!(master.poll(&waker), Poll::Ready(Err(Failure::Stalled)));
        assert_eq!(master.bus_errors(), bus_errors);
        assert!(!stray.fake.interrupts_enabled());
        assert_eq!(stray.fake.violations, Vec::<&str>::new());
    }
    assert_eq!(Failure::Stalled.kind(), ErrorKind::Bus);
}

/// The fake with a flag stuck on, or with CR1.POS never set (a driver that skips it).
struct Tampered {
    fake: Fake,
    stray_sr1: u16,
    drop_pos: bool,
}

impl Registers for Tampered {
    fn sr1(&mut self) -> Sr1 {
        Sr1(self.fake.sr1().0 | self.stray_sr1)
    }
    fn read_sr2(&mut self) {
        self.fake.read_sr2();
    }
    fn clear_sr1(&mut self, flags: u16) {
        self.fake.clear_sr1(flags);
    }
    fn write_dr(&mut self, byte: u8) {
        self.fake.write_dr(byte);
    }
    fn read_dr(&mut self) -> u8 {
        self.fake.read_dr()
    }
    fn start(&mut self) {
        self.fake.start();
    }
    fn stop(&mut self) {
        self.fake.stop();
    }
    fn stop_pending(&mut self) -> bool {
        self.fake.stop_pending()
    }
    fn set_ack_pos(&mut self, ack: bool, pos: bool) {
        self.fake.set_ack_pos(ack, pos && !self.drop_pos);
    }
    fn set_interrupts(&mut self, on: bool, buffer: bool) {
        self.fake.set_interrupts(on, buffer);
    }
}

#[test]
fn the_fake_catches_a_two_byte_read_without_pos() {
    // Without POS the cleared ACK applies to byte 1: the chip is NACKed a byte early, and the
    // handler waits for a BTF that never comes (the fake's ACK model has teeth).
    let mut tampered = Tampered {
        fake: chips(),
        stray_sr1: 0,
        drop_pos: true,
    };
    let mut master = Master::new();
    master
        .begin(&mut tampered, read_register(LEFT, 0x02))
        .expect("free");
    for _ in 0..DEADLINE_STEPS {
        tampered.fake.step();
        if tampered.fake.interrupt_pending() {
            master.on_interrupt(&mut tampered);
        }
    }
    assert!(
        tampered.fake.wire.contains(&byte(0x4B, false)),
        "byte 1 NACKed"
    );
    assert!(master.busy(), "never ends by itself");
}

#[test]
fn back_to_back_reads_of_both_chips() {
    // One sample: shunt and bus of each chip, each next START after the previous STOP.
    let mut fake = chips();
    let mut master = Master::new();
    let mut want = Vec::new();
    for (address, register, value) in [
        (LEFT, 0x01, 0x0FA0u16),
        (LEFT, 0x02, 0x4B00),
        (RIGHT, 0x01, 0xF830),
        (RIGHT, 0x02, 0x4AFF),
    ] {
        let (result, wakes) = run(&mut master, &mut fake, read_register(address, register), 1);
        assert_eq!(
            result.map(|r| r.bytes().to_vec()),
            Ok(value.to_be_bytes().to_vec())
        );
        assert_eq!(wakes, 1);
        want.extend(register_read_wire(address, register, value));
    }
    fake.step();
    assert_eq!(fake.wire, want);
    assert_eq!(fake.violations, Vec::<&str>::new());
}

#[test]
fn no_start_while_the_previous_stop_is_pending() {
    let mut fake = chips();
    fake.stop_stuck = true;
    let mut master = Master::new();
    let (result, _) = run(&mut master, &mut fake, read_register(LEFT, 0x01), 0);
    assert!(result.is_ok());
    fake.step();
    assert_eq!(
        master.begin(&mut fake, read_register(LEFT, 0x02)),
        Err(Busy)
    );
    assert!(!master.busy(), "nothing started");
    assert_eq!(fake.violations, Vec::<&str>::new());
}

#[test]
fn transfers_from_embedded_hal_operations() {
    let mut buf = [0u8; 2];
    let mut ops = [
        Operation::Write(&[0x05]),
        Operation::Write(&[0x08, 0x00]),
        Operation::Read(&mut buf),
    ];
    let transfer = Transfer::new(LEFT, &ops).expect("writes then a read");
    assert_eq!(&transfer.write[..transfer.write_len], [0x05, 0x08, 0x00]);
    assert_eq!(transfer.read_len, 2);
    let received = Received {
        bytes: [0xAB, 0xCD, 0, 0, 0, 0, 0, 0],
        len: 2,
    };
    transfer.copy_out(&received, &mut ops);
    assert_eq!(buf, [0xAB, 0xCD]);
    let (mut a, mut b, mut c) = ([0u8; 1], [0u8; 1], [0u8; 1]);
    let too_long = [0u8; MAX_WRITE + 1];
    for ops in [
        &[Operation::Read(&mut a), Operation::Write(&[1])][..],
        &[Operation::Read(&mut b), Operation::Read(&mut c)][..],
        &[Operation::Write(&too_long)][..],
    ] {
        assert_eq!(Transfer::new(LEFT, ops), Err(Failure::Unsupported));
        assert_eq!(Failure::Unsupported.kind(), ErrorKind::Other);
        assert!(!Failure::Unsupported.needs_bus_reset());
    }
    let probe = Transfer::new(LEFT, &[]).expect("an address probe");
    let mut fake = chips();
    let (result, _) = run(&mut Master::new(), &mut fake, probe, 0);
    assert_eq!(result.map(|r| r.bytes().len()), Ok(0));
    fake.step();
    assert_eq!(
        fake.wire,
        [Wire::Start, addr(LEFT, false, true), Wire::Stop]
    );
}

/// The hardware behind an [`AwaitedBus`] in these tests: the handler's state, the fake
/// peripheral, the time in handler turns, and the bus resets asked for.
#[derive(Debug)]
struct Hardware {
    master: Master,
    fake: Fake,
    now: u32,
    resets: Vec<Failure>,
}

type Shared = Rc<RefCell<Hardware>>;

#[derive(Debug)]
struct TestPort(Shared);

impl Port for TestPort {
    type Regs = Fake;
    fn lock<R>(&mut self, f: impl FnOnce(&mut Master, &mut Fake) -> R) -> R {
        let hw = &mut *self.0.borrow_mut();
        f(&mut hw.master, &mut hw.fake)
    }
    async fn reset_bus(&mut self, failure: Failure) {
        let hw = &mut *self.0.borrow_mut();
        hw.resets.push(failure);
        hw.fake.reset();
    }
}

#[derive(Debug)]
struct TestClock(Shared);

impl Clock for TestClock {
    type Deadline = u32;
    fn deadline(&self) -> u32 {
        self.0.borrow().now + DEADLINE_STEPS
    }
    fn passed(&self, deadline: u32) -> bool {
        self.0.borrow().now >= deadline
    }
    fn pause(&self) -> impl Future<Output = ()> {
        let mut paused = false;
        poll_fn(move |_| {
            if paused {
                Poll::Ready(())
            } else {
                paused = true;
                Poll::Pending
            }
        })
    }
    fn until<F: Future>(&self, deadline: u32, end: F) -> impl Future<Output = Option<F::Output>> {
        let hw = self.0.clone();
        async move {
            let mut end = pin!(end);
            poll_fn(|cx| match end.as_mut().poll(cx) {
                Poll::Ready(out) => Poll::Ready(Some(out)),
                Poll::Pending if hw.borrow().now >= deadline => Poll::Ready(None),
                Poll::Pending => Poll::Pending,
            })
            .await
        }
    }
}

fn awaited(fake: Fake) -> (Shared, AwaitedBus<TestPort, TestClock>) {
    let hw = Rc::new(RefCell::new(Hardware {
        master: Master::new(),
        fake,
        now: 0,
        resets: Vec::new(),
    }));
    let bus = AwaitedBus {
        port: TestPort(hw.clone()),
        clock: TestClock(hw.clone()),
    };
    (hw, bus)
}

/// Polls `future` as the sample task's executor would; between two polls the hardware moves
/// on ([`tick`]).
fn drive<F: Future>(hw: &Shared, latency: u32, future: F) -> F::Output {
    let mut future = pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return out;
        }
        tick(hw, latency);
    }
}

/// One turn of the hardware: `latency + 1` bus events, then the interrupt handler once if
/// requested.
fn tick(hw: &Shared, latency: u32) {
    let hw = &mut *hw.borrow_mut();
    hw.now += 1;
    assert!(hw.now < 100_000, "never ends");
    for _ in 0..=latency {
        hw.fake.step();
    }
    if hw.fake.interrupt_pending() {
        hw.master.on_interrupt(&mut hw.fake);
    }
}

/// Both chips as INA226 register files: IDs, and shunt/bus of 2 A at 24 V (left) and −1 A (right).
fn ina226_pair() -> Fake {
    let ids = [(0xFE, 0x5449), (0xFF, 0x2260)];
    let chip = |shunt: u16, bus: u16| {
        let mut registers = ids.to_vec();
        registers.extend([(0x01, shunt), (0x02, bus)]);
        Slave::with(&registers)
    };
    Fake::new(&[(LEFT, chip(4000, 19_200)), (RIGHT, chip(0xF830, 19_200))])
}

#[test]
fn the_sampler_reads_both_chips_over_the_awaited_bus() {
    use crate::sampler::{Sampler, SamplerConfig, DEFAULT_SAMPLE_PERIOD_US};
    use model_core::ina226::{BusVoltageRaw, Registers as Chip, ShuntVoltageRaw};
    use model_core::wire::ChipReading;
    for latency in [0, 2] {
        let (hw, mut bus) = awaited(ina226_pair());
        let mut sampler = Sampler::new(SamplerConfig::BOARD);
        // Set-up (IDs, configuration, CAL), then the first reading a period later.
        drive(&hw, latency, sampler.sample_async(&mut bus, 0));
        let period = u64::from(DEFAULT_SAMPLE_PERIOD_US);
        let sample = drive(&hw, latency, sampler.sample_async(&mut bus, period));
        let cal = crate::ina226::BOARD_CALIBRATION.raw();
        let want = |shunt: i16| Chip::derived(ShuntVoltageRaw(shunt), BusVoltageRaw(19_200), cal);
        let chips = sample.expect("running").chips;
        assert_eq!(Some(chips.left), want(4000).map(ChipReading::Fresh));
        assert_eq!(Some(chips.right), want(-2000).map(ChipReading::Fresh));
        let hw = hw.borrow();
        assert_eq!(
            hw.fake.slaves[&LEFT].registers.get(&0x05),
            Some(&2048),
            "CAL written"
        );
        assert_eq!(hw.fake.violations, Vec::<&str>::new());
        assert_eq!(hw.resets, []);
    }
}

#[test]
fn a_stuck_bus_is_a_bus_error_then_a_reset_and_the_next_read_works() {
    use embedded_hal_async::i2c::I2c as _;
    let (hw, mut bus) = awaited(chips());
    hw.borrow_mut().fake.stall_at = Some(3);
    let mut buf = [0u8; 2];
    let out = drive(&hw, 0, bus.write_read(LEFT, &[0x02], &mut buf));
    assert_eq!(out, Err(ErrorKind::Bus));
    assert_eq!(hw.borrow().resets, [Failure::Timeout]);
    assert!(!hw.borrow().master.busy(), "aborted");
    let out = drive(&hw, 0, bus.write_read(LEFT, &[0x02], &mut buf));
    assert_eq!((out, buf), (Ok(()), [0x4B, 0x00]));
}

#[test]
fn a_nack_is_an_error_without_a_bus_reset() {
    use embedded_hal_async::i2c::I2c as _;
    let (hw, mut bus) = awaited(chips());
    let mut buf = [0u8; 2];
    let out = drive(&hw, 1, bus.write_read(0x41, &[0x02], &mut buf));
    assert_eq!(
        out,
        Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address))
    );
    // Back to back: the next START waits for the NACK's STOP.
    let out = drive(&hw, 1, bus.write_read(RIGHT, &[0x01], &mut buf));
    assert_eq!((out, buf), (Ok(()), [0xF8, 0x30]));
    assert_eq!(hw.borrow().resets, []);
    assert_eq!(hw.borrow().fake.violations, Vec::<&str>::new());
}

#[test]
fn a_stop_that_never_goes_out_is_a_timeout() {
    use embedded_hal_async::i2c::I2c as _;
    let (hw, mut bus) = awaited(chips());
    let mut buf = [0u8; 2];
    assert_eq!(
        drive(&hw, 0, bus.write_read(LEFT, &[0x01], &mut buf)),
        Ok(())
    );
    hw.borrow_mut().fake.stop_stuck = true;
    drive(&hw, 0, async { hw.borrow_mut().fake.step() });
    let out = drive(&hw, 0, bus.write_read(LEFT, &[0x02], &mut buf));
    assert_eq!(out, Err(ErrorKind::Bus));
    assert_eq!(hw.borrow().resets, [Failure::Timeout]);
}

#[test]
fn a_dropped_transaction_runs_out_before_the_next_starts() {
    // A transaction future dropped mid-transfer (it lost a select!, say): the handler still
    // carries that transfer to its STOP. The next transaction waits for it instead of
    // setting START in the middle of a byte and taking the orphan's events for its own.
    use embedded_hal_async::i2c::I2c as _;
    let (hw, mut bus) = awaited(chips());
    let mut orphan_buf = [0u8; 2];
    {
        let mut orphan = pin!(bus.write_read(LEFT, &[0x02], &mut orphan_buf));
        let mut cx = Context::from_waker(Waker::noop());
        for _ in 0..3 {
            assert!(orphan.as_mut().poll(&mut cx).is_pending());
            tick(&hw, 0);
        }
    }
    let mut buf = [0u8; 2];
    let out = drive(&hw, 0, bus.write_read(RIGHT, &[0x01], &mut buf));
    assert_eq!((out, buf), (Ok(()), [0xF8, 0x30]));
    drive(&hw, 0, async { hw.borrow_mut().fake.step() });
    let hw = hw.borrow();
    let mut want = register_read_wire(LEFT, 0x02, 0x4B00);
    want.extend(register_read_wire(RIGHT, 0x01, 0xF830));
    assert_eq!(hw.fake.wire, want);
    assert_eq!(hw.fake.violations, Vec::<&str>::new());
    assert_eq!(hw.resets, []);
}

#[test]
fn unsupported_operations_never_reach_the_bus() {
    use embedded_hal_async::i2c::I2c as _;
    let (hw, mut bus) = awaited(chips());
    let long = [0u8; MAX_WRITE + 1];
    assert_eq!(drive(&hw, 0, bus.write(LEFT, &long)), Err(ErrorKind::Other));
    assert_eq!(hw.borrow().fake.wire, []);
    assert_eq!(hw.borrow().resets, []);
}
