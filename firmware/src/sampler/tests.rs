use super::*;
use crate::ina226::{Register, CONFIG_POWER_ON};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

const L: u8 = 0x40;
const R: u8 = 0x45;
/// The board's period (5 ms) against its 4.48 ms conversions (4.928 ms with the margin).
const P: u64 = DEFAULT_SAMPLE_PERIOD_US as u64;

/// The transactions a chip should see, with the register it points at, so the scripts
/// follow the driver's short reads.
struct Script {
    addr: u8,
    pointer: Option<Register>,
}

impl Script {
    fn new(addr: u8) -> Self {
        Self {
            addr,
            pointer: None,
        }
    }

    fn read(&mut self, reg: Register, value: u16) -> T {
        let bytes = value.to_be_bytes().to_vec();
        let t = if self.pointer == Some(reg) {
            T::read(self.addr, bytes)
        } else {
            T::write_read(self.addr, vec![reg as u8], bytes)
        };
        self.pointer = Some(reg);
        t
    }

    fn write(&mut self, reg: Register, value: u16) -> T {
        let [hi, lo] = value.to_be_bytes();
        self.pointer = Some(reg);
        T::write(self.addr, vec![reg as u8, hi, lo])
    }

    fn init(&mut self) -> Vec<T> {
        self.init_with(0x4407)
    }

    fn init_with(&mut self, config: u16) -> Vec<T> {
        vec![
            self.read(Register::ManufacturerId, 0x5449),
            self.read(Register::DieId, 0x2260),
            self.write(Register::Configuration, config),
            self.write(Register::Calibration, 2048),
        ]
    }

    /// A sample's reads of `amps` at 24 V (on our board the shunt register counts current
    /// LSBs), the calibration read-back between them when given.
    fn measure(&mut self, amps: f64, calibration: Option<u16>) -> Vec<T> {
        self.measure_bus(amps, 19_200, calibration)
    }

    /// [`Self::measure`] with the bus register reading `bus`.
    fn measure_bus(&mut self, amps: f64, bus: u16, calibration: Option<u16>) -> Vec<T> {
        let shunt = (amps / 0.0005).round() as i16 as u16;
        let (first, second) = match self.pointer {
            Some(Register::BusVoltage) => (Register::BusVoltage, Register::ShuntVoltage),
            _ => (Register::ShuntVoltage, Register::BusVoltage),
        };
        let value = |reg| {
            if reg == Register::BusVoltage {
                bus
            } else {
                shunt
            }
        };
        let mut tx = vec![self.read(first, value(first))];
        if let Some(cal) = calibration {
            tx.push(self.read(Register::Calibration, cal));
        }
        tx.push(self.read(second, value(second)));
        tx
    }
}

#[test]
fn first_sample_initialises_both_chips_and_counts() {
    let (mut l, mut r, mut tx) = both_set_up();
    for _ in 0..2 {
        tx.extend(l.measure(2.0, None));
        tx.extend(r.measure(-1.0, None));
    }
    // Two periods missed: 4 results came and went, 2 unread.
    tx.extend(l.measure(2.0, None));
    tx.extend(r.measure(-1.0, None));
    let mut i2c = Mock::new(&tx);
    let mut s = Sampler::new(SamplerConfig::BOARD);
    let first = s.sample(&mut i2c, 0).expect("running");
    assert_eq!(first.seq, 0);
    // No conversion since the configuration write: nothing valid to read, so no read.
    let waiting = ChipReading::Failed(ChipFault::AwaitingConversion);
    assert_eq!(first.chips, Sides::new(waiting, waiting));
    let second = s.sample(&mut i2c, P).expect("running");
    assert_eq!((second.seq, second.t_us), (1, P));
    let want = model_core::ina226::Registers::derived(
        model_core::ina226::ShuntVoltageRaw(4000),
        model_core::ina226::BusVoltageRaw(19_200),
        crate::ina226::BOARD_CALIBRATION.raw(),
    )
    .expect("valid bus");
    assert_eq!(second.chips.left, ChipReading::Fresh(want));
    assert_eq!(want.power.0, 3840, "48 W in 12.5 mW LSBs");
    assert!(matches!(second.chips.right, ChipReading::Fresh(r) if r.current.0 == -2000));
    s.sample(&mut i2c, 2 * P).expect("running");
    let snap = s.model().expect("sampled").snapshot;
    // 48 W and −24 W for 5 ms (the first reading anchors time).
    assert_eq!(snap.power_lsb, Sides::new(Some(3840), Some(-1920)));
    assert_eq!(snap.energy_lsb_us, Sides::new(3840 * 5_000, -1920 * 5_000));
    assert_eq!(s.skipped_results(), Sides::new(0, 0));
    s.sample(&mut i2c, 5 * P).expect("running");
    // Results at k × 4.48 ms: the 3rd (13.44 ms) was read at 15 ms; 4th–6th came by 25 ms.
    assert_eq!(s.skipped_results(), Sides::new(2, 2));
    assert_eq!(s.i2c_errors(), Sides::new(0, 0));
    i2c.done();
}

#[test]
fn a_nacking_chip_does_not_stop_the_other_and_recovers() {
    let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    let (mut l, mut r) = (Script::new(L), Script::new(R));
    let mut tx = l.init();
    tx.push(T::write_read(R, vec![0xFE], vec![0, 0]).with_error(nack)); // right absent
    tx.extend(l.measure(1.0, None));
    tx.push(T::write_read(R, vec![0xFE], vec![0, 0]).with_error(nack));
    tx.extend(l.measure(1.0, None));
    tx.extend(r.init()); // right plugged in
    tx.extend(l.measure(1.0, None));
    tx.extend(r.measure(1.0, None));
    let mut i2c = Mock::new(&tx);
    let mut s = Sampler::new(SamplerConfig::BOARD);
    s.sample(&mut i2c, 0);
    for k in 1..4u64 {
        let sample = s.sample(&mut i2c, k * P).expect("running");
        assert!(
            matches!(sample.chips.left, ChipReading::Fresh(_)),
            "left keeps streaming"
        );
        let right = match k {
            1 => ChipReading::Failed(ChipFault::AddressNack),
            2 => ChipReading::Failed(ChipFault::AwaitingConversion),
            _ => sample.chips.right,
        };
        assert_eq!(sample.chips.right, right, "sample {k}");
    }
    assert_eq!(s.i2c_errors(), Sides::new(0, 2));
    assert_eq!(s.last_faults(), Sides::new(None, None));
    // First successful init of a chip is not a re-initialisation.
    assert_eq!(s.reinits(), Sides::new(0, 0));
    i2c.done();
}

/// The board's sampler on a mock bus scripted with `tx`, after its first two samples (the
/// set-up, awaiting conversion; the first reading).
fn sampled_twice(tx: &[T]) -> (Mock, Sampler) {
    let mut i2c = Mock::new(tx);
    let mut s = Sampler::new(SamplerConfig::BOARD);
    s.sample(&mut i2c, 0);
    s.sample(&mut i2c, P);
    (i2c, s)
}

/// The scripts of both chips, and their set-up transactions (IDs, configuration, CAL).
fn both_set_up() -> (Script, Script, Vec<T>) {
    let (mut l, mut r) = (Script::new(L), Script::new(R));
    let mut tx = l.init();
    tx.extend(r.init());
    (l, r, tx)
}

/// Both chips set up and read once at `amps`; then left's short read returns 0x4127 (the
/// configuration register's power-on value), its other read `second`, the CAL check `cal`.
fn left_reads_the_power_on_configuration(
    amps: f64,
    second: [u8; 2],
    cal: u16,
) -> (Script, Script, Vec<T>) {
    let (mut l, mut r, mut tx) = both_set_up();
    tx.extend(l.measure(amps, None));
    tx.extend(r.measure(amps, None));
    tx.push(T::read(L, CONFIG_POWER_ON.to_be_bytes().to_vec()));
    tx.push(T::write_read(L, vec![0x01], second.to_vec()));
    tx.push(T::write_read(L, vec![0x05], cal.to_be_bytes().to_vec()));
    tx.extend(r.measure(amps, None));
    (l, r, tx)
}

#[test]
fn a_reset_chip_is_found_by_its_short_read_and_reinitialised() {
    // Left browns out: it points at register 00h, which holds its power-on configuration;
    // CAL 0 confirms.
    let (mut l, mut r, mut tx) = left_reads_the_power_on_configuration(1.0, [0x07, 0xD0], 0);
    l.pointer = None;
    tx.extend(l.init());
    tx.extend(r.measure(1.0, None));
    tx.extend(l.measure(1.0, None));
    tx.extend(r.measure(1.0, None));
    let (mut i2c, mut s) = sampled_twice(&tx);
    let lost = s.sample(&mut i2c, 2 * P).expect("running");
    assert_eq!(
        lost.chips.left,
        ChipReading::Failed(ChipFault::ResetDetected)
    );
    assert!(matches!(lost.chips.right, ChipReading::Fresh(_)));
    let setup = s.sample(&mut i2c, 3 * P).expect("running");
    assert_eq!(
        setup.chips.left,
        ChipReading::Failed(ChipFault::AwaitingConversion)
    );
    let back = s.sample(&mut i2c, 4 * P).expect("running");
    assert!(matches!(back.chips.left, ChipReading::Fresh(_)));
    assert_eq!(s.reinits(), Sides::new(1, 0));
    assert_eq!(s.i2c_errors(), Sides::new(0, 0));
    i2c.done();
}

#[test]
fn a_reading_that_looks_like_a_reset_is_checked_and_kept() {
    // 0x4127 on the bus register (20.85 V) is a genuine reading: CAL is fine.
    let (_, _, tx) = left_reads_the_power_on_configuration(0.0, [0, 3], 2048);
    let (mut i2c, mut s) = sampled_twice(&tx);
    let checked = s.sample(&mut i2c, 2 * P).expect("running");
    assert!(
        matches!(checked.chips.left, ChipReading::Fresh(r) if r.bus.0 == CONFIG_POWER_ON && r.shunt.0 == 3)
    );
    assert_eq!(s.reinits(), Sides::new(0, 0));
    assert_eq!(s.last_faults(), Sides::new(None, None));
    i2c.done();
}

#[test]
fn a_bus_voltage_with_bit_15_set_is_a_fault_not_a_wrapped_power() {
    // Left draws 12 A at 24 V (23 040 power LSBs); once its bus register reads 0xFFFF (SDA high
    // through the read: a chip browning out). 24 000 × 65 535 / 20 000 does not fit the power
    // register: cast to u16 it was 13 106, a plausible 164 W.
    let (mut l, mut r, mut tx) = both_set_up();
    tx.extend(l.measure(12.0, None));
    tx.extend(r.measure(1.0, None));
    tx.extend(l.measure_bus(12.0, 0xFFFF, None));
    tx.extend(r.measure(1.0, None));
    tx.extend(l.measure(12.0, None));
    tx.extend(r.measure(1.0, None));
    let (mut i2c, mut s) = sampled_twice(&tx);
    let bad = s.sample(&mut i2c, 2 * P).expect("running");
    assert_eq!(
        bad.chips.left,
        ChipReading::Failed(ChipFault::InvalidReading)
    );
    assert!(matches!(bad.chips.right, ChipReading::Fresh(_)));
    // Counted and reported as the other faults are; the chip is not set up again.
    assert_eq!(s.i2c_errors(), Sides::new(1, 0));
    assert_eq!(s.last_faults().left, Some(ChipFault::InvalidReading));
    let back = s.sample(&mut i2c, 3 * P).expect("running");
    assert!(matches!(back.chips.left, ChipReading::Fresh(r) if r.power.0 == 23_040));
    assert_eq!(s.last_faults().left, None);
    assert_eq!(s.reinits(), Sides::new(0, 0));
    // No energy from the discarded reading: the good one at 3P covers the interval since P.
    let snap = s.model().expect("sampled").snapshot;
    assert_eq!(snap.energy_lsb_us.left, 23_040 * 2 * P as i64);
    // Its result was not read: one skipped, as for any lost read.
    assert_eq!(s.skipped_results(), Sides::new(1, 0));
    i2c.done();
}

#[test]
fn calibration_is_read_back_periodically_one_chip_per_sample() {
    let (mut l, mut r, mut tx) = both_set_up();
    let half = CALIBRATION_CHECK_EVERY / 2;
    for seq in 1..=CALIBRATION_CHECK_EVERY {
        tx.extend(l.measure(0.0, (seq == CALIBRATION_CHECK_EVERY).then_some(2048)));
        // An idle right chip that reset keeps reading plausible values: CAL shows it.
        tx.extend(r.measure(0.0, (seq == half).then_some(0)));
        if seq == half {
            break;
        }
    }
    r.pointer = None;
    tx.extend(l.measure(0.0, None));
    tx.extend(r.init());
    let mut i2c = Mock::new(&tx);
    let mut s = Sampler::new(SamplerConfig::BOARD);
    for seq in 0..half {
        let sample = s.sample(&mut i2c, u64::from(seq) * P).expect("running");
        assert_ne!(
            sample.chips.right,
            ChipReading::Failed(ChipFault::ResetDetected)
        );
    }
    let check = s.sample(&mut i2c, u64::from(half) * P).expect("running");
    assert_eq!(
        check.chips.right,
        ChipReading::Failed(ChipFault::ResetDetected)
    );
    s.sample(&mut i2c, u64::from(half + 1) * P);
    assert_eq!(s.reinits(), Sides::new(0, 1));
    i2c.done();
}

#[test]
fn energy_does_not_accumulate_across_stop_and_start() {
    let (mut l, mut r, mut tx) = both_set_up();
    for _ in 0..4 {
        tx.extend(l.measure(2.0, None));
        tx.extend(r.measure(2.0, None));
    }
    let (mut i2c, mut s) = sampled_twice(&tx);
    s.sample(&mut i2c, 2 * P);
    let before = s.model().expect("sampled").snapshot.energy_lsb_us.left;
    assert_eq!(before, 3840 * 5_000);
    assert_eq!(s.apply(&mut i2c, &Command::Stop), Ok(()));
    assert!(s.sample(&mut i2c, 3 * P).is_none());
    assert_eq!(s.apply(&mut i2c, &Command::Start), Ok(()));
    // A 60 s pause: the first reading after Start adds nothing, the next one 5 ms.
    s.sample(&mut i2c, 60_000_000);
    assert_eq!(
        s.model().expect("sampled").snapshot.energy_lsb_us.left,
        before
    );
    s.sample(&mut i2c, 60_005_000);
    assert_eq!(
        s.model().expect("sampled").snapshot.energy_lsb_us.left,
        before + 3840 * 5_000
    );
    // Nor does the pause count as results the sampler skipped.
    assert_eq!(s.skipped_results(), Sides::new(0, 0));
    i2c.done();
}

#[test]
fn commands_change_sampling() {
    let quad = AdcConfig {
        averaging: model_core::ina226::Averaging::X4,
        ..AdcConfig::BOARD_DEFAULT
    };
    let (mut l, mut r, mut tx) = both_set_up();
    tx.extend(l.measure(1.0, None));
    tx.extend(r.measure(1.0, None));
    tx.push(l.write(Register::Configuration, 0x4207));
    tx.push(T::write(R, vec![0x00, 0x42, 0x07]).with_error(ErrorKind::Bus));
    // The left chip restarted its conversions: 1.12 ms, 1.232 ms with the margin.
    r.pointer = None;
    tx.extend(r.init_with(0x4207));
    tx.extend(l.measure(1.0, None));
    tx.extend(r.measure(1.0, None));
    let (mut i2c, mut s) = sampled_twice(&tx);
    let slowest = AdcConfig {
        averaging: model_core::ina226::Averaging::X1024,
        bus_conversion: model_core::ina226::ConversionTime::Us8244,
        shunt_conversion: model_core::ina226::ConversionTime::Us8244,
    };
    let configure = |adc, sample_period_us| Command::Configure {
        adc,
        sample_period_us,
    };
    // The bus cannot go faster, the averaging cannot fill the period, or both.
    for (adc, period) in [(quad, 499), (quad, 1_231), (slowest, 1_000_000)] {
        assert_eq!(
            s.apply(&mut i2c, &configure(adc, period)),
            Err(Rejection::OutOfRange),
            "{period} µs"
        );
    }
    assert_eq!(
        s.sample_period_us(),
        DEFAULT_SAMPLE_PERIOD_US,
        "refused command changes nothing"
    );
    assert_eq!(
        s.apply(&mut i2c, &configure(quad, 1_250)),
        Err(Rejection::Chip(ChipFault::Bus))
    );
    assert_eq!(s.sample_period_us(), 1_250);
    assert_eq!(s.hello().adc, quad);
    let t = P + 1_250;
    let after = s.sample(&mut i2c, t).expect("running");
    let waiting = ChipReading::Failed(ChipFault::AwaitingConversion);
    assert_eq!(after.chips, Sides::new(waiting, waiting));
    let fresh = s.sample(&mut i2c, t + 1_250).expect("running");
    assert!(matches!(fresh.chips.left, ChipReading::Fresh(_)));
    assert!(matches!(fresh.chips.right, ChipReading::Fresh(_)));
    assert_eq!(s.apply(&mut i2c, &Command::Stop), Ok(()));
    assert!(s.sample(&mut i2c, 0).is_none());
    assert_eq!(
        s.apply(&mut i2c, &Command::SetWheelRates(Sides::new(0.0, 3.6))),
        Ok(())
    );
    assert_eq!(s.measurements().wheel_rates(), Some(Sides::new(0.0, 3.6)));
    i2c.done();
}

#[test]
fn configurations_for_a_period() {
    let fast = SamplerConfig::with_period(500).expect("2 kHz");
    assert_eq!(fast.adc.update_period_us(), 408);
    assert_eq!(
        SamplerConfig::with_period(DEFAULT_SAMPLE_PERIOD_US),
        Some(SamplerConfig::BOARD)
    );
    assert_eq!(SamplerConfig::with_period(499), None);
    assert_eq!(SamplerConfig::with_period(2_000_000), None);
}

#[test]
fn the_boards_hello_carries_each_chips_registers_read_back_now() {
    use model_core::ina226::{CalibrationRaw, ConfigurationRaw, DieIdRaw, ManufacturerIdRaw};
    use model_core::wire::ChipRegistersReadBack;
    let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    // Neither chip is set up yet (a GetHello before the first sample): set up first.
    let (mut l, mut r) = (Script::new(L), Script::new(R));
    let mut tx = l.init();
    tx.extend([
        l.read(Register::ManufacturerId, 0x5449),
        l.read(Register::DieId, 0x2260),
        l.read(Register::Configuration, 0x4407),
        l.read(Register::Calibration, 2048),
        r.read(Register::ManufacturerId, 0).with_error(nack),
    ]);
    // A failed read leaves the pointer unknown: the next read sends it again.
    r.pointer = None;
    tx.push(r.read(Register::ManufacturerId, 0).with_error(nack));
    let mut i2c = Mock::new(&tx);
    let mut s = Sampler::new(SamplerConfig::BOARD);
    let hello = s.hello_read_back(&mut i2c);
    assert_eq!(
        hello.chips,
        Sides::new(
            ChipProbe::Answered(ChipRegistersReadBack {
                manufacturer_id: ManufacturerIdRaw(0x5449),
                die_id: DieIdRaw(0x2260),
                configuration: ConfigurationRaw(0x4407),
                calibration: CalibrationRaw(2048),
            }),
            ChipProbe::Failed(ChipFault::AddressNack)
        )
    );
    assert_eq!(
        Hello {
            chips: Sides::new(ChipProbe::NotRead, ChipProbe::NotRead),
            ..hello
        },
        s.hello()
    );
    assert_eq!(s.last_faults().right, Some(ChipFault::AddressNack));
    i2c.done();
}
