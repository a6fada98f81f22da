//! I²C bus recovery (NXP UM10204 §3.1.16 "Bus clear"). A slave interrupted mid-byte (the MCU
//! reset during a read, a glitch) keeps driving SDA low while it waits for the clocks of the bit
//! it is sending; no START can be generated, and the STM32's I²C peripheral waits for a free bus
//! forever. Clocking SCL by hand until the slave lets SDA go (at most the 9 clocks of a byte and
//! its acknowledge), then a STOP, frees the bus without a power cycle.
//!
//! The sequence is generic over the two lines so it is tested on the host; the board drives
//! PB8/PB9 as open-drain GPIO (`stm32_i2c`). It is async so that after a fault the sample task
//! awaits each half period on the monotonic instead of spinning (at init, before the scheduler,
//! a spin delay serves, through [`crate::blocking::run`]).

/// The two bus lines as open-drain outputs that can be read back.
pub trait BusLines {
    /// Releases (`true`: the pull-up takes it high) or pulls low SCL.
    fn set_scl(&mut self, high: bool);
    /// Releases or pulls low SDA.
    fn set_sda(&mut self, high: bool);
    /// Whether SDA reads high (nobody pulls it low).
    fn sda_is_high(&mut self) -> bool;
    /// Whether SCL reads high (released, and no slave stretches it).
    fn scl_is_high(&mut self) -> bool;
    /// Waits half an SCL period (5 µs: 100 kHz, slow enough for weak pull-ups).
    fn half_period(&mut self) -> impl core::future::Future<Output = ()>;
}

/// At most this many clock pulses: a byte's 8 bits and its acknowledge.
pub const MAX_PULSES: u8 = 9;

/// What a bus recovery found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Recovery {
    /// SDA was high from the start (a STOP was sent anyway).
    WasFree,
    /// A slave held SDA low and let go after this many clock pulses.
    Freed { pulses: u8 },
    /// SDA is still low after [`MAX_PULSES`] pulses and the STOP, or SCL is low with the
    /// master's side released: a shorted line, a missing pull-up, or a chip that is latched up
    /// (power cycle). No clocks get through a held SCL, so SDA alone would call that bus free.
    Stuck,
}

/// Clocks SCL until SDA is released (at most [`MAX_PULSES`]), then sends a STOP. Leaves both
/// lines released.
pub async fn recover<L: BusLines>(lines: &mut L) -> Recovery {
    lines.set_sda(true);
    lines.set_scl(true);
    lines.half_period().await;
    let mut pulses = 0;
    // With SCL high, a slave holding SDA low is mid-byte: each pulse shifts out one more bit.
    while !lines.sda_is_high() && pulses < MAX_PULSES {
        lines.set_scl(false);
        lines.half_period().await;
        lines.set_scl(true);
        lines.half_period().await;
        pulses += 1;
    }
    // STOP: SDA rises while SCL is high. Any slave still in a transfer resets its interface.
    lines.set_scl(false);
    lines.half_period().await;
    lines.set_sda(false);
    lines.half_period().await;
    lines.set_scl(true);
    lines.half_period().await;
    lines.set_sda(true);
    lines.half_period().await;
    match (lines.sda_is_high() && lines.scl_is_high(), pulses) {
        (false, _) => Recovery::Stuck,
        (true, 0) => Recovery::WasFree,
        (true, pulses) => Recovery::Freed { pulses },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blocking::run;

    /// A slave that drives SDA low until it has seen `holds_for` more SCL rising edges (a stuck
    /// transmitter sending zeros); `u8::MAX` is a shorted line. With `holds_scl` it keeps SCL
    /// low. Records STOP conditions.
    #[derive(Debug)]
    struct StuckSlave {
        holds_for: u8,
        holds_scl: bool,
        scl: bool,
        sda_master: bool,
        stops: u32,
        pulses: u32,
    }

    impl StuckSlave {
        fn new(holds_for: u8) -> Self {
            Self {
                holds_for,
                holds_scl: false,
                scl: true,
                sda_master: true,
                stops: 0,
                pulses: 0,
            }
        }

        fn sda(&self) -> bool {
            self.sda_master && self.holds_for == 0
        }
    }

    impl BusLines for StuckSlave {
        fn set_scl(&mut self, high: bool) {
            if high && !self.scl {
                self.pulses += 1;
                if self.holds_for != u8::MAX {
                    self.holds_for = self.holds_for.saturating_sub(1);
                }
            }
            self.scl = high;
        }
        fn set_sda(&mut self, high: bool) {
            let before = self.sda();
            self.sda_master = high;
            if self.scl && !before && self.sda() {
                self.stops += 1;
            }
        }
        fn sda_is_high(&mut self) -> bool {
            self.sda()
        }
        fn scl_is_high(&mut self) -> bool {
            self.scl && !self.holds_scl
        }
        async fn half_period(&mut self) {}
    }

    #[test]
    fn a_free_bus_gets_just_a_stop() {
        let mut bus = StuckSlave::new(0);
        assert_eq!(run(recover(&mut bus)), Recovery::WasFree);
        assert_eq!((bus.pulses, bus.stops), (1, 1), "the STOP's own clock");
        assert!(bus.scl && bus.sda(), "both lines released");
    }

    #[test]
    fn a_slave_mid_byte_is_clocked_free_then_stopped() {
        for holds_for in 1..=MAX_PULSES {
            let mut bus = StuckSlave::new(holds_for);
            assert_eq!(
                run(recover(&mut bus)),
                Recovery::Freed { pulses: holds_for }
            );
            assert_eq!(bus.stops, 1);
            assert!(bus.scl && bus.sda());
        }
    }

    #[test]
    fn scl_held_low_is_stuck_not_free() {
        // SDA is high, but no clock and no STOP gets through (before: reported `WasFree`).
        let mut bus = StuckSlave::new(0);
        bus.holds_scl = true;
        assert_eq!(run(recover(&mut bus)), Recovery::Stuck);
    }

    #[test]
    fn a_shorted_line_is_reported_after_nine_pulses() {
        let mut bus = StuckSlave::new(u8::MAX);
        assert_eq!(run(recover(&mut bus)), Recovery::Stuck);
        assert_eq!(bus.pulses, u32::from(MAX_PULSES) + 1);
    }
}
