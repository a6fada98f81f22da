//! I²C1 for the board (target only): the interrupt-driven transfer of [`crate::i2c_master`] on
//! the PAC's I2C1 registers. The stm32f4xx-hal 0.23 driver still enables, resets and times the
//! peripheral and sets up PB8/PB9; its transfers are not used.
//!
//! Why our own interrupt driver rather than the HAL's (read in `stm32f4xx-hal-0.23.0/src/i2c*`):
//! - its blocking transfers spin on every flag with no timeout (its `Error::Timeout` is only the
//!   SMBus flag), so a slave holding SDA low hangs the caller;
//! - its 2-byte read clears ACK only after byte 1 is read: preempted there for more than a byte
//!   time (~20 µs at 400 kHz), byte 2 is ACKed and the INA226 keeps SDA low (stm32f4xx-hal PRs
//!   #91, #736);
//! - its DMA mode (`i2c::dma`, `I2CMasterDma`) moves only the data bytes by DMA: every START and
//!   address phase still spins, without a timeout, on SB, MSL/BUSY and ADDR (`send_start`,
//!   `send_address`), and it takes two DMA streams; for our 1-byte pointer and 2-byte result the
//!   spinning would be most of the transfer.
//!
//! Here [`I2c1`] is an RTIC resource shared by the I2C1_EV/I2C1_ER handlers (priority above the
//! USB task) and the sample task, which awaits each transfer through [`AwaitedBus`] (an
//! `embedded_hal_async::i2c::I2c`) over [`BoardPort`] and [`MonoClock`]: while the bus works the
//! sample task is suspended and the USB and LED tasks run. Every transfer has a deadline on the
//! TIM2 monotonic
//! ([`TRANSACTION_BUDGET_US`]); when it passes, or the handler reports arbitration lost, an
//! overrun or a stall, the peripheral is reset and the bus clocked free
//! ([`crate::bus_recovery`]), and the transfer fails with `ErrorKind::Bus` (wire
//! `ChipFault::Bus`, or the matching fault): a reported fault, not a watchdog reset.

use crate::blocking;
use crate::bus_recovery::{self, BusLines, Recovery};
use crate::i2c_master::{AwaitedBus, Clock, Failure, Master, Port, Registers, Sr1};
use core::future::Future;
use rtic_time::Monotonic;
use stm32f4xx_hal::{i2c::I2c as HalI2c, pac, timer::MonoTimerUs};

/// The board's monotonic (TIM2, 1 MHz), which times the deadlines.
type Mono = MonoTimerUs<pac::TIM2>;
type Duration = <Mono as Monotonic>::Duration;

/// Deadline of one transaction [µs]: a register read takes 120 µs at 400 kHz (48 SCL periods);
/// 1 ms is ~8× that. At the default 5 ms period a stuck transaction costs no sample; at 2 kHz it
/// costs two periods, which the sample task skips (its sequence stays continuous, the time gap
/// shows).
pub const TRANSACTION_BUDGET_US: u64 = 1_000;
/// How long to wait before looking again whether the previous STOP has gone out [µs] (a STOP
/// takes about one SCL period, 2.5 µs).
const STOP_POLL_US: u64 = 2;
/// Half an SCL period of a bus recovery [µs] (100 kHz).
const HALF_PERIOD_US: u32 = 5;

/// SR1's flags cleared by writing 0 (RM0383 §18.6.6: BERR, ARLO, AF, OVR, PECERR, TIMEOUT,
/// SMBALERT).
const SR1_RC_W0: u16 = 0xDF00;

/// I2C1's registers as the transfer state machine sees them.
#[derive(Debug)]
pub struct I2c1Registers(pac::I2C1);

impl Registers for I2c1Registers {
    fn sr1(&mut self) -> Sr1 {
        Sr1(self.0.sr1().read().bits())
    }

    fn read_sr2(&mut self) {
        let _ = self.0.sr2().read();
    }

    #[allow(unsafe_code)]
    fn clear_sr1(&mut self, flags: u16) {
        // SAFETY: SR1's flags in `SR1_RC_W0` are cleared by writing 0 and unchanged by writing
        // 1; its other bits are read-only or reserved (written 0). Writing 1 to all but `flags`
        // clears exactly those, and (unlike a read-modify-write) never a flag raised in between.
        self.0
            .sr1()
            .write(|w| unsafe { w.bits(SR1_RC_W0 & !flags) });
    }

    fn write_dr(&mut self, byte: u8) {
        self.0.dr().write(|w| w.dr().set(byte));
    }

    fn read_dr(&mut self) -> u8 {
        self.0.dr().read().dr().bits()
    }

    fn start(&mut self) {
        self.0.cr1().modify(|_, w| w.start().set_bit());
    }

    fn stop(&mut self) {
        self.0.cr1().modify(|_, w| w.stop().set_bit());
    }

    fn stop_pending(&mut self) -> bool {
        self.0.cr1().read().stop().bit_is_set()
    }

    fn set_ack_pos(&mut self, ack: bool, pos: bool) {
        self.0.cr1().modify(|_, w| w.ack().bit(ack).pos().bit(pos));
    }

    fn set_interrupts(&mut self, on: bool, buffer: bool) {
        self.0.cr2().modify(|_, w| {
            w.itevten()
                .bit(on)
                .iterren()
                .bit(on)
                .itbufen()
                .bit(on && buffer)
        });
    }
}

/// The shared part: registers and the transfer in flight (the interrupt handlers' resource).
#[derive(Debug)]
pub struct I2c1 {
    regs: I2c1Registers,
    master: Master,
}

impl I2c1 {
    /// The I2C1_EV and I2C1_ER handler.
    pub fn on_interrupt(&mut self) {
        self.master.on_interrupt(&mut self.regs);
    }

    /// Spurious BERR flags cleared so far (`i2c_master` module doc).
    pub fn bus_errors(&self) -> u32 {
        self.master.bus_errors()
    }

    /// Interrupts off, transfer forgotten, peripheral held in reset: the bus is being reset.
    /// Not PE=0: RM0383 (I2C_CR1.PE) defers that to the end of a communication under way and
    /// forbids it in master mode before then, and an aborted transfer has not ended, so the
    /// peripheral could still hold SCL low when the pins go back to it. SWRST stops it at once
    /// and holds the lines released until [`Self::reenable`].
    fn disable(&mut self) {
        self.master.abort(&mut self.regs);
        self.regs.0.cr1().write(|w| w.swrst().set_bit());
    }

    /// Software reset released (after the pins are back on the peripheral: it also clears a
    /// latched BUSY), timing restored, peripheral on.
    #[allow(unsafe_code)]
    fn reenable(&mut self, timing: Timing) {
        let i2c = &self.regs.0;
        i2c.cr1().write(|w| w.swrst().set_bit());
        i2c.cr1().write(|w| w.swrst().clear_bit());
        // SAFETY: the very values the HAL computed and wrote at init (read back from these
        // registers), written again after the software reset cleared them.
        unsafe {
            i2c.cr2().write(|w| w.bits(timing.cr2));
            i2c.ccr().write(|w| w.bits(timing.ccr));
            i2c.trise().write(|w| w.bits(timing.trise));
        }
        i2c.cr1().write(|w| w.pe().set_bit());
    }
}

/// CR2 (clock frequency), CCR and TRISE as the HAL computed them for 400 kHz.
#[derive(Debug, Clone, Copy)]
struct Timing {
    cr2: u16,
    ccr: u16,
    trise: u16,
}

/// The sample task's part: what a bus reset needs, and its counters.
#[derive(Debug)]
pub struct BusControl {
    timing: Timing,
    timeouts: u32,
    last_recovery: Option<Recovery>,
}

impl BusControl {
    /// Takes over an I²C1 the HAL has set up (PB8 SCL, PB9 SDA, 400 kHz) and clocks the bus
    /// free: after a reset in the middle of a read an INA226 may still hold SDA low. Runs in
    /// `init`, before any task.
    pub fn new(hal: HalI2c<pac::I2C1>, sysclk_hz: u32) -> (I2c1, BusControl) {
        // The pins stay in their alternate-function, open-drain mode (dropping the HAL's pin
        // types changes no register).
        let (i2c, _pins) = hal.release();
        let timing = Timing {
            cr2: i2c.cr2().read().bits(),
            ccr: i2c.ccr().read().bits(),
            trise: i2c.trise().read().bits(),
        };
        let mut shared = I2c1 {
            regs: I2c1Registers(i2c),
            master: Master::new(),
        };
        shared.disable();
        // Before the scheduler runs: each half period spun in a delay loop.
        let mut lines = Pb8Pb9::take(Some(sysclk_hz / 1_000_000 * HALF_PERIOD_US));
        let recovery = blocking::run(bus_recovery::recover(&mut lines));
        drop(lines);
        shared.reenable(timing);
        let control = BusControl {
            timing,
            timeouts: 0,
            last_recovery: Some(recovery),
        };
        (shared, control)
    }

    /// Transfers that ran out of time or stalled (each followed by a bus reset).
    pub fn timeouts(&self) -> u32 {
        self.timeouts
    }

    /// What the latest bus reset found (at init, then after each timeout).
    pub fn last_recovery(&self) -> Option<Recovery> {
        self.last_recovery
    }

    /// The awaitable bus over the shared [`I2c1`] (`shared`: the sample task's RTIC lock).
    pub fn bus<'a, M: rtic::Mutex<T = I2c1>>(
        &'a mut self,
        shared: &'a mut M,
    ) -> AwaitedBus<BoardPort<'a, M>, MonoClock> {
        AwaitedBus {
            port: BoardPort {
                shared,
                control: self,
            },
            clock: MonoClock,
        }
    }
}

/// I2C1 behind the sample task's RTIC lock, and the bus reset.
#[derive(Debug)]
pub struct BoardPort<'a, M> {
    shared: &'a mut M,
    control: &'a mut BusControl,
}

impl<M: rtic::Mutex<T = I2c1>> Port for BoardPort<'_, M> {
    type Regs = I2c1Registers;

    fn lock<R>(&mut self, f: impl FnOnce(&mut Master, &mut I2c1Registers) -> R) -> R {
        self.shared.lock(|bus| f(&mut bus.master, &mut bus.regs))
    }

    /// Peripheral held in reset under the lock; the bus clocked free outside it, each half period
    /// awaited on the monotonic (≈ 20 of them: USB and the LED task run meanwhile); then reset
    /// and on again under the lock.
    async fn reset_bus(&mut self, failure: Failure) {
        if matches!(failure, Failure::Timeout | Failure::Stalled) {
            self.control.timeouts = self.control.timeouts.saturating_add(1);
        }
        let timing = self.control.timing;
        self.shared.lock(I2c1::disable);
        let recovery = bus_recovery::recover(&mut Pb8Pb9::take(None)).await;
        self.control.last_recovery = Some(recovery);
        self.shared.lock(|bus| bus.reenable(timing));
    }
}

/// Deadlines on the TIM2 monotonic.
#[derive(Debug, Clone, Copy)]
pub struct MonoClock;

impl Clock for MonoClock {
    type Deadline = <Mono as Monotonic>::Instant;

    fn deadline(&self) -> Self::Deadline {
        Mono::now() + Duration::micros(TRANSACTION_BUDGET_US)
    }

    fn passed(&self, deadline: Self::Deadline) -> bool {
        Mono::now() >= deadline
    }

    fn pause(&self) -> impl Future<Output = ()> {
        Mono::delay(Duration::micros(STOP_POLL_US))
    }

    async fn until<F: Future>(&self, deadline: Self::Deadline, end: F) -> Option<F::Output> {
        Mono::timeout_at(deadline, end).await.ok()
    }
}

/// PB8 (SCL) and PB9 (SDA) as open-drain GPIO outputs for the length of a bus recovery; back
/// to their I²C alternate function when dropped.
struct Pb8Pb9 {
    gpio: &'static pac::gpiob::RegisterBlock,
    /// Half a period spun in CPU cycles (at init), or `None`: awaited on the monotonic.
    spin_cycles: Option<u32>,
}

impl Pb8Pb9 {
    fn take(spin_cycles: Option<u32>) -> Self {
        // SAFETY: PB8/PB9 belong to I2C1, which this driver owns; BSRR writes are atomic, and
        // MODER is read-modified-written only here (at init, then from the sample task), after
        // init set up every GPIOB pin: no interrupt handler and nothing else changes GPIOB modes
        // at run time. The HAL already made both pins open-drain (OTYPER), with AF4 selected
        // (AFRH), which mode changes keep.
        #[allow(unsafe_code)]
        let gpio: &'static pac::gpiob::RegisterBlock = unsafe { &*pac::GPIOB::ptr() };
        gpio.bsrr().write(|w| w.bs8().set_bit().bs9().set_bit());
        gpio.moder()
            .modify(|_, w| w.moder8().output().moder9().output());
        Self { gpio, spin_cycles }
    }
}

impl Drop for Pb8Pb9 {
    fn drop(&mut self) {
        self.gpio
            .moder()
            .modify(|_, w| w.moder8().alternate().moder9().alternate());
    }
}

impl BusLines for Pb8Pb9 {
    fn set_scl(&mut self, high: bool) {
        self.gpio.bsrr().write(|w| {
            if high {
                w.bs8().set_bit()
            } else {
                w.br8().set_bit()
            }
        });
    }

    fn set_sda(&mut self, high: bool) {
        self.gpio.bsrr().write(|w| {
            if high {
                w.bs9().set_bit()
            } else {
                w.br9().set_bit()
            }
        });
    }

    fn sda_is_high(&mut self) -> bool {
        self.gpio.idr().read().idr9().bit_is_set()
    }

    fn scl_is_high(&mut self) -> bool {
        self.gpio.idr().read().idr8().bit_is_set()
    }

    async fn half_period(&mut self) {
        match self.spin_cycles {
            Some(cycles) => cortex_m::asm::delay(cycles),
            None => Mono::delay(Duration::micros(u64::from(HALF_PERIOD_US))).await,
        }
    }
}
