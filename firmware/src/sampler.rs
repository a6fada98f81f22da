//! One sampling period: read both chips, stamp, count, and feed the running measurements.
//! A failing chip never stops the other chip or the stream: its part of the sample says why.

use crate::ina226::{Calibration, Ina226};
use embedded_hal::i2c::I2c;
use model_core::board_id::BoardIdentity;
use model_core::energy::RunningMeasurements;
use model_core::ina226::{AdcConfig, BUS_LSB_UV, SHUNT_LSB_NV};
use model_core::wire::{
    ChipFault, ChipProbe, ChipReading, Command, FirmwareVersion, Hello, Model, Rejection, Sample,
    PROTOCOL_VERSION,
};
use model_core::Sides;

/// Left and right motor-driver chips (A0/A1 to GND and to VS respectively).
pub const BOARD_ADDRESSES: Sides<u8> = Sides::new(0x40, 0x45);
/// Default sampling period: one fresh 4.48 ms result per read (200 Hz).
pub const DEFAULT_SAMPLE_PERIOD_US: u32 = 5_000;
/// Calibration is read back every this many samples (the register check in each sample only
/// sees a reset while current flows).
const CALIBRATION_CHECK_EVERY: u32 = 256;

/// This firmware's version, from Cargo.
pub fn firmware_version() -> FirmwareVersion {
    let v = |s: &str| s.parse().unwrap_or(0);
    FirmwareVersion {
        major: v(env!("CARGO_PKG_VERSION_MAJOR")),
        minor: v(env!("CARGO_PKG_VERSION_MINOR")),
        patch: v(env!("CARGO_PKG_VERSION_PATCH")),
    }
}

/// How the sampler starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SamplerConfig {
    pub addresses: Sides<u8>,
    pub calibration: Calibration,
    pub adc: AdcConfig,
    pub sample_period_us: u32,
    /// Unique ID and crystal, reported in the hello (the RTIC app reads them at init).
    pub identity: BoardIdentity,
}

impl SamplerConfig {
    /// Our board: 0x40/0x45, 5 mΩ shunts, 0.5 mA LSB, 16 × 140 µs averaging, 200 Hz.
    pub const BOARD: SamplerConfig = SamplerConfig {
        addresses: BOARD_ADDRESSES,
        calibration: crate::ina226::BOARD_CALIBRATION,
        adc: AdcConfig::BOARD_DEFAULT,
        sample_period_us: DEFAULT_SAMPLE_PERIOD_US,
        identity: BoardIdentity::UNKNOWN,
    };
}

/// One chip and what the sampler knows of its health.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Chip {
    driver: Ina226,
    /// Configured and calibrated since its last reset.
    ready: bool,
    /// Has been ready at least once (a later init is a re-initialisation).
    was_ready: bool,
    /// Initialised, but no conversion has completed with the new settings yet.
    awaiting_conversion: bool,
    errors: u32,
    reinits: u32,
    last_fault: Option<ChipFault>,
}

impl Chip {
    fn new(driver: Ina226) -> Self {
        Self {
            driver,
            ready: false,
            was_ready: false,
            awaiting_conversion: false,
            errors: 0,
            reinits: 0,
            last_fault: None,
        }
    }

    fn fail(&mut self, fault: ChipFault) -> ChipReading {
        if !matches!(
            fault,
            ChipFault::ResetDetected | ChipFault::AwaitingConversion
        ) {
            self.errors = self.errors.saturating_add(1);
        }
        if fault == ChipFault::AddressNack {
            // The chip was gone (unplugged, unpowered) and may come back with its power-on
            // defaults: set it up again as soon as it answers.
            self.ready = false;
        }
        self.last_fault = Some(fault);
        ChipReading::Failed(fault)
    }

    /// Checks the IDs and writes configuration and calibration.
    fn set_up<I: I2c>(&mut self, i2c: &mut I) -> Result<(), ChipFault> {
        self.driver.init(i2c).map_err(|e| e.fault())?;
        if self.was_ready {
            self.reinits = self.reinits.saturating_add(1);
        }
        self.ready = true;
        self.was_ready = true;
        // Writing the configuration cleared the conversion-ready flag; the current and power
        // registers still hold a result computed with the old calibration.
        self.awaiting_conversion = true;
        Ok(())
    }

    /// The chip's ID and set-up registers read back, after setting it up if it is not (a
    /// `GetHello` may come before the first sample).
    fn probe<I: I2c>(&mut self, i2c: &mut I) -> ChipProbe {
        if !self.ready {
            if let Err(fault) = self.set_up(i2c) {
                self.fail(fault);
            }
        }
        match self.driver.read_back(i2c) {
            Ok(registers) => ChipProbe::Answered(registers),
            Err(e) => ChipProbe::Failed(crate::ina226::fault_of(&e)),
        }
    }

    fn read<I: I2c>(&mut self, i2c: &mut I, check_calibration: bool) -> ChipReading {
        if !self.ready {
            if let Err(fault) = self.set_up(i2c) {
                return self.fail(fault);
            }
        } else if check_calibration {
            match self.driver.calibration_lost(i2c) {
                Ok(true) => return self.lost_calibration(),
                Ok(false) => {}
                Err(e) => return self.fail(crate::ina226::fault_of(&e)),
            }
        }
        let fresh = match self.driver.conversion_ready(i2c) {
            Ok(fresh) => fresh,
            Err(e) => return self.fail(crate::ina226::fault_of(&e)),
        };
        if self.awaiting_conversion {
            if !fresh {
                return self.fail(ChipFault::AwaitingConversion);
            }
            self.awaiting_conversion = false;
        }
        let regs = match self.driver.read_registers(i2c) {
            Ok(regs) => regs,
            Err(e) => return self.fail(crate::ina226::fault_of(&e)),
        };
        if self.driver.registers_show_reset(&regs) {
            // Only a suspicion: shunt and current are read in separate transactions and a result
            // lands every 4.48 ms against 5 ms reads, so at idle about 1 read in 20 pairs a new
            // shunt value with the previous (zero) current. CAL reads 0 only after a reset.
            match self.driver.calibration_lost(i2c) {
                Ok(true) => return self.lost_calibration(),
                Ok(false) => {}
                Err(e) => return self.fail(crate::ina226::fault_of(&e)),
            }
        }
        self.last_fault = None;
        if fresh {
            ChipReading::Fresh(regs)
        } else {
            ChipReading::Stale(regs)
        }
    }

    /// The chip reset: its current and power registers are meaningless until it is set up again
    /// (next period).
    fn lost_calibration(&mut self) -> ChipReading {
        self.ready = false;
        self.fail(ChipFault::ResetDetected)
    }
}

/// Polls both chips once per period and keeps the running measurements.
#[derive(Debug, Clone)]
pub struct Sampler {
    chips: Sides<Chip>,
    seq: u32,
    running: bool,
    sample_period_us: u32,
    identity: BoardIdentity,
    measurements: RunningMeasurements,
    last_sample: Option<(u64, u32)>,
}

impl Sampler {
    pub fn new(config: SamplerConfig) -> Self {
        let chip = |address| Chip::new(Ina226::new(address, config.calibration, config.adc));
        Self {
            chips: Sides::new(chip(config.addresses.left), chip(config.addresses.right)),
            seq: 0,
            running: true,
            sample_period_us: config.sample_period_us,
            identity: config.identity,
            measurements: RunningMeasurements::new(config.calibration.scale()),
            last_sample: None,
        }
    }

    /// Takes one sample stamped `t_us`; `None` while stopped by the host.
    pub fn sample<I: I2c>(&mut self, i2c: &mut I, t_us: u64) -> Option<Sample> {
        if !self.running {
            return None;
        }
        let check = self.seq.is_multiple_of(CALIBRATION_CHECK_EVERY);
        let chips = Sides::new(
            self.chips.left.read(i2c, check),
            self.chips.right.read(i2c, check),
        );
        self.measurements.update(t_us, chips.map(|c| c.registers()));
        let sample = Sample {
            t_us,
            seq: self.seq,
            chips,
        };
        self.last_sample = Some((t_us, self.seq));
        self.seq = self.seq.wrapping_add(1);
        Some(sample)
    }

    /// Carries out a command that concerns sampling; the board answers with ack or rejection.
    pub fn apply<I: I2c>(&mut self, i2c: &mut I, command: &Command) -> Result<(), Rejection> {
        command.validate()?;
        match *command {
            Command::Configure {
                adc,
                sample_period_us,
            } => {
                self.sample_period_us = sample_period_us;
                let mut outcome = Ok(());
                for chip in [&mut self.chips.left, &mut self.chips.right] {
                    if let Err(e) = chip.driver.configure(i2c, adc) {
                        // Re-initialised (with the new settings) at the next period.
                        chip.ready = false;
                        let fault = crate::ina226::fault_of(&e);
                        chip.fail(fault);
                        outcome = Err(Rejection::Chip(fault));
                    }
                }
                outcome
            }
            Command::SetWheelRates(rates) => {
                self.measurements.set_wheel_rates(Some(rates));
                Ok(())
            }
            Command::ClearWheelRates => {
                self.measurements.set_wheel_rates(None);
                Ok(())
            }
            Command::ResetEnergy => {
                self.measurements.reset_energy();
                Ok(())
            }
            Command::Start => {
                self.running = true;
                Ok(())
            }
            Command::Stop => {
                // wire.rs: "energy stops accumulating". The first reading after Start re-anchors
                // time instead of multiplying its power by the whole pause. Done at Stop (not
                // Start) so the host mirrors it on the Stop ack whatever the running state was.
                self.running = false;
                self.measurements.pause();
                Ok(())
            }
            Command::GetStatus | Command::GetHello => Ok(()),
        }
    }

    /// The hello with each chip's ID and set-up registers read back now (the answer to
    /// `GetHello`); a chip not set up yet is set up first.
    pub fn hello_read_back<I: I2c>(&mut self, i2c: &mut I) -> Hello {
        let left = self.chips.left.probe(i2c);
        let right = self.chips.right.probe(i2c);
        Hello {
            chips: Sides::new(left, right),
            ..self.hello()
        }
    }

    /// The hello without touching the bus (chips [`ChipProbe::NotRead`]).
    pub fn hello(&self) -> Hello {
        let scale = self.measurements.scale();
        Hello {
            protocol: PROTOCOL_VERSION,
            firmware: firmware_version(),
            scale,
            power_lsb_uw: scale.power_lsb_uw(),
            shunt_lsb_nv: SHUNT_LSB_NV,
            bus_lsb_uv: BUS_LSB_UV,
            addresses: self.chips.map(|c| c.driver.address()),
            adc: self.adc(),
            sample_period_us: self.sample_period_us,
            identity: self.identity,
            chips: Sides::new(ChipProbe::NotRead, ChipProbe::NotRead),
        }
    }

    /// The running measurements after the latest sample (`None` before the first).
    pub fn model(&self) -> Option<Model> {
        let (t_us, seq) = self.last_sample?;
        Some(Model {
            t_us,
            seq,
            snapshot: self.measurements.snapshot(),
        })
    }

    pub fn measurements(&self) -> &RunningMeasurements {
        &self.measurements
    }

    pub fn sample_period_us(&self) -> u32 {
        self.sample_period_us
    }

    pub fn adc(&self) -> AdcConfig {
        self.chips.left.driver.adc()
    }

    pub fn running(&self) -> bool {
        self.running
    }

    /// Samples taken so far (the next sample's sequence number).
    pub fn samples(&self) -> u32 {
        self.seq
    }

    pub fn i2c_errors(&self) -> Sides<u32> {
        self.chips.map(|c| c.errors)
    }

    pub fn reinits(&self) -> Sides<u32> {
        self.chips.map(|c| c.reinits)
    }

    pub fn last_faults(&self) -> Sides<Option<ChipFault>> {
        self.chips.map(|c| c.last_fault)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ina226::Register;
    use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
    use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

    fn read(addr: u8, reg: Register, value: u16) -> T {
        T::write_read(addr, vec![reg as u8], value.to_be_bytes().to_vec())
    }

    fn write(addr: u8, reg: Register, value: u16) -> T {
        let [hi, lo] = value.to_be_bytes();
        T::write(addr, vec![reg as u8, hi, lo])
    }

    fn init(addr: u8) -> Vec<T> {
        vec![
            read(addr, Register::ManufacturerId, 0x5449),
            read(addr, Register::DieId, 0x2260),
            write(addr, Register::Configuration, 0x4407),
            write(addr, Register::Calibration, 2048),
        ]
    }

    /// A reading of `amps` at 24 V: on our board the current register equals the shunt register.
    fn reading(addr: u8, fresh: bool, amps: f64) -> Vec<T> {
        let lsb = (amps / 0.0005).round() as i16;
        let bus = 19_200u16; // 24 V
        let power = (i32::from(lsb).unsigned_abs() * u32::from(bus) / 20_000) as u16;
        vec![
            read(addr, Register::MaskEnable, if fresh { 0x0008 } else { 0 }),
            read(addr, Register::ShuntVoltage, lsb as u16),
            read(addr, Register::BusVoltage, bus),
            read(addr, Register::Current, lsb as u16),
            read(addr, Register::Power, power),
        ]
    }

    fn cal_ok(addr: u8) -> T {
        read(addr, Register::Calibration, 2048)
    }

    #[test]
    fn first_sample_initialises_both_chips_and_counts() {
        let mut tx = init(0x40);
        tx.extend(reading(0x40, true, 2.0));
        tx.extend(init(0x45));
        // No conversion since the configuration write: nothing valid to read yet.
        tx.push(read(0x45, Register::MaskEnable, 0));
        tx.extend(reading(0x40, true, 2.0));
        tx.extend(reading(0x45, true, -1.0));
        tx.extend(reading(0x40, false, 2.0));
        tx.extend(reading(0x45, true, -1.0));
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        let first = s.sample(&mut i2c, 1_000).expect("running");
        assert_eq!(first.seq, 0);
        assert!(matches!(first.chips.left, ChipReading::Fresh(_)));
        assert_eq!(
            first.chips.right,
            ChipReading::Failed(ChipFault::AwaitingConversion)
        );
        let second = s.sample(&mut i2c, 6_000).expect("running");
        assert_eq!((second.seq, second.t_us), (1, 6_000));
        assert!(matches!(second.chips.right, ChipReading::Fresh(_)));
        let third = s.sample(&mut i2c, 11_000).expect("running");
        assert!(
            matches!(third.chips.left, ChipReading::Stale(_)),
            "re-read without a new conversion"
        );
        let snap = s.model().expect("sampled").snapshot;
        // 48 W for 10 ms on the left; −24 W for 5 ms on the right (its first reading anchors time).
        assert_eq!(snap.power_lsb, Sides::new(Some(3840), Some(-1920)));
        assert_eq!(snap.energy_lsb_us, Sides::new(3840 * 10_000, -1920 * 5_000));
        assert_eq!(s.i2c_errors(), Sides::new(0, 0));
        i2c.done();
    }

    #[test]
    fn a_nacking_chip_does_not_stop_the_other_and_recovers() {
        let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
        let mut tx = init(0x40);
        tx.extend(reading(0x40, true, 1.0));
        tx.push(read(0x45, Register::ManufacturerId, 0).with_error(nack)); // right absent
        tx.extend(reading(0x40, true, 1.0));
        tx.push(read(0x45, Register::ManufacturerId, 0).with_error(nack));
        tx.extend(reading(0x40, true, 1.0));
        tx.extend(init(0x45)); // right plugged in
        tx.extend(reading(0x45, true, 1.0));
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        for k in 0..3u64 {
            let sample = s.sample(&mut i2c, k * 5_000).expect("running");
            assert!(
                matches!(sample.chips.left, ChipReading::Fresh(_)),
                "left keeps streaming"
            );
            let right_failed = sample.chips.right == ChipReading::Failed(ChipFault::AddressNack);
            assert_eq!(right_failed, k < 2, "sample {k}: {:?}", sample.chips.right);
        }
        assert_eq!(s.i2c_errors(), Sides::new(0, 2));
        assert_eq!(s.last_faults(), Sides::new(None, None));
        // First successful init of a chip is not a re-initialisation.
        assert_eq!(s.reinits(), Sides::new(0, 0));
        i2c.done();
    }

    #[test]
    fn a_reset_chip_is_detected_and_reinitialised() {
        let mut tx = init(0x40);
        tx.extend(reading(0x40, true, 1.0));
        tx.extend(init(0x45));
        tx.extend(reading(0x45, true, 1.0));
        // Left browns out: CAL = 0 → current register 0 under load.
        tx.push(read(0x40, Register::MaskEnable, 0x0008));
        tx.push(read(0x40, Register::ShuntVoltage, 2000));
        tx.push(read(0x40, Register::BusVoltage, 19_200));
        tx.push(read(0x40, Register::Current, 0));
        tx.push(read(0x40, Register::Power, 0));
        tx.push(read(0x40, Register::Calibration, 0)); // confirmed
        tx.extend(reading(0x45, true, 1.0));
        tx.extend(init(0x40));
        tx.extend(reading(0x40, true, 1.0));
        tx.extend(reading(0x45, true, 1.0));
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        s.sample(&mut i2c, 0);
        let lost = s.sample(&mut i2c, 5_000).expect("running");
        assert_eq!(
            lost.chips.left,
            ChipReading::Failed(ChipFault::ResetDetected)
        );
        assert!(matches!(lost.chips.right, ChipReading::Fresh(_)));
        let back = s.sample(&mut i2c, 10_000).expect("running");
        assert!(matches!(back.chips.left, ChipReading::Fresh(_)));
        assert_eq!(s.reinits(), Sides::new(1, 0));
        assert_eq!(s.i2c_errors(), Sides::new(0, 0));
        i2c.done();
    }

    #[test]
    fn a_conversion_landing_between_shunt_and_current_is_not_a_reset() {
        let mut tx = init(0x40);
        tx.extend(reading(0x40, true, 0.0));
        tx.extend(init(0x45));
        tx.extend(reading(0x45, true, 0.0));
        // Idle: the shunt register already holds the next result (+3 LSB of offset), the current
        // register still the previous one (0). CAL reads back fine: no reset.
        tx.push(read(0x40, Register::MaskEnable, 0x0008));
        tx.push(read(0x40, Register::ShuntVoltage, 3));
        tx.push(read(0x40, Register::BusVoltage, 19_200));
        tx.push(read(0x40, Register::Current, 0));
        tx.push(read(0x40, Register::Power, 0));
        tx.push(cal_ok(0x40));
        tx.extend(reading(0x45, true, 0.0));
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        s.sample(&mut i2c, 0);
        let straddled = s.sample(&mut i2c, 5_000).expect("running");
        assert!(matches!(straddled.chips.left, ChipReading::Fresh(r) if r.shunt.0 == 3));
        assert_eq!(s.reinits(), Sides::new(0, 0));
        assert_eq!(s.last_faults(), Sides::new(None, None));
        i2c.done();
    }

    #[test]
    fn calibration_is_read_back_periodically() {
        let mut tx = Vec::new();
        for addr in [0x40, 0x45] {
            tx.extend(init(addr));
            tx.extend(reading(addr, true, 0.0));
        }
        for _ in 1..CALIBRATION_CHECK_EVERY {
            tx.extend(reading(0x40, true, 0.0));
            tx.extend(reading(0x45, true, 0.0));
        }
        tx.push(cal_ok(0x40));
        tx.extend(reading(0x40, true, 0.0));
        tx.push(read(0x45, Register::Calibration, 0)); // idle chip that reset: no load to show it
        tx.extend(reading(0x40, true, 0.0));
        tx.extend(init(0x45));
        tx.extend(reading(0x45, true, 0.0));
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        for k in 0..CALIBRATION_CHECK_EVERY {
            s.sample(&mut i2c, u64::from(k) * 5_000);
        }
        let check = s.sample(&mut i2c, 0).expect("running");
        assert_eq!(
            check.chips.right,
            ChipReading::Failed(ChipFault::ResetDetected)
        );
        s.sample(&mut i2c, 5_000);
        assert_eq!(s.reinits(), Sides::new(0, 1));
        i2c.done();
    }

    #[test]
    fn energy_does_not_accumulate_across_stop_and_start() {
        let mut tx = Vec::new();
        for addr in [0x40, 0x45] {
            tx.extend(init(addr));
            tx.extend(reading(addr, true, 2.0));
        }
        for _ in 0..3 {
            tx.extend(reading(0x40, true, 2.0));
            tx.extend(reading(0x45, true, 2.0));
        }
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        s.sample(&mut i2c, 0);
        s.sample(&mut i2c, 5_000);
        let before = s.model().expect("sampled").snapshot.energy_lsb_us.left;
        assert_eq!(before, 3840 * 5_000);
        assert_eq!(s.apply(&mut i2c, &Command::Stop), Ok(()));
        assert!(s.sample(&mut i2c, 10_000).is_none());
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
        i2c.done();
    }

    #[test]
    fn commands_change_sampling() {
        let tx = [
            write(0x40, Register::Configuration, 0x4FFF),
            write(0x45, Register::Configuration, 0x4FFF).with_error(ErrorKind::Bus),
        ];
        let mut i2c = Mock::new(&tx);
        let mut s = Sampler::new(SamplerConfig::BOARD);
        let slowest = AdcConfig {
            averaging: model_core::ina226::Averaging::X1024,
            bus_conversion: model_core::ina226::ConversionTime::Us8244,
            shunt_conversion: model_core::ina226::ConversionTime::Us8244,
        };
        assert_eq!(
            s.apply(
                &mut i2c,
                &Command::Configure {
                    adc: slowest,
                    sample_period_us: 1_000
                }
            ),
            Err(Rejection::OutOfRange)
        );
        assert_eq!(
            s.sample_period_us(),
            DEFAULT_SAMPLE_PERIOD_US,
            "refused command changes nothing"
        );
        assert_eq!(
            s.apply(
                &mut i2c,
                &Command::Configure {
                    adc: slowest,
                    sample_period_us: 500_000
                }
            ),
            Err(Rejection::Chip(ChipFault::Bus))
        );
        assert_eq!(s.sample_period_us(), 500_000);
        assert_eq!(s.hello().adc, slowest);
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
    fn the_boards_hello_carries_each_chips_registers_read_back_now() {
        use model_core::ina226::{CalibrationRaw, ConfigurationRaw, DieIdRaw, ManufacturerIdRaw};
        use model_core::wire::ChipRegistersReadBack;
        let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
        // Neither chip is set up yet (a GetHello before the first sample): set up first.
        let mut tx = init(0x40);
        tx.extend([
            read(0x40, Register::ManufacturerId, 0x5449),
            read(0x40, Register::DieId, 0x2260),
            read(0x40, Register::Configuration, 0x4407),
            read(0x40, Register::Calibration, 2048),
            read(0x45, Register::ManufacturerId, 0).with_error(nack),
            read(0x45, Register::ManufacturerId, 0).with_error(nack),
        ]);
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
}
