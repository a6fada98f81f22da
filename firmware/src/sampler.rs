//! One sampling period: read both chips, stamp, count, and feed the running measurements.
//! A failing chip never stops the other chip or the stream: its part of the sample says why.

use crate::ina226::{Calibration, Ina226};
use embedded_hal_async::i2c::I2c;
use model_core::board_id::BoardIdentity;
use model_core::energy::RunningMeasurements;
use model_core::ina226::{AdcConfig, BUS_LSB_UV, SHUNT_LSB_NV};
use model_core::rate::CALIBRATION_CHECK_EVERY;
use model_core::wire::{
    ChipFault, ChipProbe, ChipReading, Command, FirmwareVersion, Hello, Model, Rejection, Sample,
    PROTOCOL_VERSION,
};
use model_core::Sides;

/// Left and right motor-driver chips (A0/A1 to GND and to VS respectively).
pub const BOARD_ADDRESSES: Sides<u8> = Sides::new(0x40, 0x45);
/// Default sampling period: one fresh 4.48 ms result per read (200 Hz).
pub const DEFAULT_SAMPLE_PERIOD_US: u32 = 5_000;

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

    /// The board sampling every `sample_period_us` with the smoothest averaging that period
    /// allows ([`AdcConfig::smoothest_for_period`]); `None` where `Configure` would refuse it.
    pub fn with_period(sample_period_us: u32) -> Option<SamplerConfig> {
        let adc = AdcConfig::smoothest_for_period(sample_period_us)?;
        let config = SamplerConfig {
            adc,
            sample_period_us,
            ..Self::BOARD
        };
        let configure = Command::Configure {
            adc,
            sample_period_us,
        };
        configure.validate().ok().map(|()| config)
    }
}

/// One chip and what the sampler knows of its health and its conversions.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Chip {
    driver: Ina226,
    /// Configured and calibrated since its last reset.
    ready: bool,
    /// Has been ready at least once (a later init is a re-initialisation).
    was_ready: bool,
    /// When the chip started converting with its current settings (writing the configuration
    /// restarts the cycle); `None`: restarted by a command, taken as the next sample's time.
    cycle_start_us: Option<u64>,
    /// Time of the latest read that returned a result.
    last_read_us: Option<u64>,
    /// Results the chip completed that no read returned, counted from the nominal conversion
    /// period (a period longer than the chip's, or a period missed).
    skipped_results: u32,
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
            cycle_start_us: None,
            last_read_us: None,
            skipped_results: 0,
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

    /// Checks the IDs and writes configuration and calibration; its conversions restart at
    /// `t_us` (`None`: at the next sample's time).
    async fn set_up<I: I2c>(&mut self, i2c: &mut I, t_us: Option<u64>) -> Result<(), ChipFault> {
        self.driver.init_async(i2c).await.map_err(|e| e.fault())?;
        if self.was_ready {
            self.reinits = self.reinits.saturating_add(1);
        }
        self.ready = true;
        self.was_ready = true;
        self.restart_conversions(t_us);
        Ok(())
    }

    /// The chip's ID and set-up registers read back, after setting it up if it is not (a
    /// `GetHello` may come before the first sample).
    async fn probe<I: I2c>(&mut self, i2c: &mut I) -> ChipProbe {
        if !self.ready {
            if let Err(fault) = self.set_up(i2c, None).await {
                self.fail(fault);
            }
        }
        match self.driver.read_back_async(i2c).await {
            Ok(registers) => ChipProbe::Answered(registers),
            Err(e) => ChipProbe::Failed(crate::ina226::fault_of(&e)),
        }
    }

    /// Its settings were written: the next result with them is a whole conversion period away.
    fn restart_conversions(&mut self, t_us: Option<u64>) {
        self.cycle_start_us = t_us;
        self.last_read_us = None;
    }

    /// Reads the chip at `t_us`. Timed, not polled: the first result is read once the
    /// conversion period (with its margin) has passed since the settings were written, and the
    /// sample period is at least that long (`Command::validate`), so each read returns a result
    /// no earlier read returned, whole (the chip swaps in a result only once it is averaged).
    async fn read<I: I2c>(
        &mut self,
        i2c: &mut I,
        t_us: u64,
        check_calibration: bool,
    ) -> ChipReading {
        if !self.ready {
            if let Err(fault) = self.set_up(i2c, Some(t_us)).await {
                return self.fail(fault);
            }
        }
        let adc = self.driver.adc();
        let start = *self.cycle_start_us.get_or_insert(t_us);
        if t_us < start.saturating_add(u64::from(adc.conversion_wait_us())) {
            // No bus traffic: nothing valid to read yet.
            return self.fail(ChipFault::AwaitingConversion);
        }
        let measurement = match self
            .driver
            .read_measurement_async(i2c, check_calibration)
            .await
        {
            Ok(m) => m,
            Err(e) => return self.fail(crate::ina226::fault_of(&e)),
        };
        let lost = match measurement.calibration {
            Some(cal) => cal.0 == 0,
            // The short read may have read register 00h of a chip that reset: CAL says.
            None if measurement.suspect_reset => {
                match self.driver.calibration_lost_async(i2c).await {
                    Ok(lost) => lost,
                    Err(e) => return self.fail(crate::ina226::fault_of(&e)),
                }
            }
            None => false,
        };
        if lost {
            return self.lost_calibration();
        }
        let Some(registers) = measurement.registers else {
            // A bus voltage the chip cannot hold: not its reading, so neither reported nor fed
            // to the energy. The pointer is kept: the read itself went through, and a chip that
            // did reset is still caught by its next short read or calibration check.
            return self.fail(ChipFault::InvalidReading);
        };
        let update_us = u64::from(adc.update_period_us().max(1));
        let results_by = |t: u64| t.saturating_sub(start) / update_us;
        if let Some(previous) = self.last_read_us {
            let new_results = results_by(t_us).saturating_sub(results_by(previous));
            let skipped = u32::try_from(new_results.saturating_sub(1)).unwrap_or(u32::MAX);
            self.skipped_results = self.skipped_results.saturating_add(skipped);
        }
        self.last_read_us = Some(t_us);
        self.last_fault = None;
        ChipReading::Fresh(registers)
    }

    /// The chip reset: its settings are the power-on defaults until it is set up again (next
    /// period), and it points at register 00h.
    fn lost_calibration(&mut self) -> ChipReading {
        self.ready = false;
        self.driver.forget_pointer();
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
    pub async fn sample_async<I: I2c>(&mut self, i2c: &mut I, t_us: u64) -> Option<Sample> {
        if !self.running {
            return None;
        }
        // Each chip's read-back in its own sample, half a cycle apart.
        let phase = self.seq % CALIBRATION_CHECK_EVERY;
        let left = self.chips.left.read(i2c, t_us, phase == 0).await;
        let right_check = phase == CALIBRATION_CHECK_EVERY / 2;
        let right = self.chips.right.read(i2c, t_us, right_check).await;
        let chips = Sides::new(left, right);
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
    pub async fn apply_async<I: I2c>(
        &mut self,
        i2c: &mut I,
        command: &Command,
    ) -> Result<(), Rejection> {
        command.validate()?;
        match *command {
            Command::Configure {
                adc,
                sample_period_us,
            } => {
                self.sample_period_us = sample_period_us;
                let mut outcome = Ok(());
                for chip in [&mut self.chips.left, &mut self.chips.right] {
                    chip.restart_conversions(None);
                    if let Err(e) = chip.driver.configure_async(i2c, adc).await {
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
                // Results converted during the pause were not skipped by the sampler.
                for chip in [&mut self.chips.left, &mut self.chips.right] {
                    chip.last_read_us = None;
                }
                Ok(())
            }
            Command::GetStatus | Command::GetHello => Ok(()),
        }
    }

    /// The hello with each chip's ID and set-up registers read back now (the answer to
    /// `GetHello`); a chip not set up yet is set up first.
    pub async fn hello_read_back_async<I: I2c>(&mut self, i2c: &mut I) -> Hello {
        let left = self.chips.left.probe(i2c).await;
        let right = self.chips.right.probe(i2c).await;
        Hello {
            chips: Sides::new(left, right),
            ..self.hello()
        }
    }

    crate::blocking::blocking_twins! {
        /// [`Self::sample_async`] on a blocking bus.
        fn sample => sample_async(t_us: u64) -> Option<Sample>;
        /// [`Self::apply_async`] on a blocking bus.
        fn apply => apply_async(command: &Command) -> Result<(), Rejection>;
        /// [`Self::hello_read_back_async`] on a blocking bus.
        fn hello_read_back => hello_read_back_async() -> Hello;
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

    /// Results each chip completed that no read returned (from the nominal conversion period:
    /// a sample period longer than the chip's conversion period skips some by design).
    pub fn skipped_results(&self) -> Sides<u32> {
        self.chips.map(|c| c.skipped_results)
    }
}

#[cfg(test)]
mod tests;
