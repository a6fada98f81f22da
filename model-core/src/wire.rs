//! The one wire format between board and host (USB CDC serial, both directions).
//!
//! A frame is `COBS(version ‖ postcard(message) ‖ CRC-32(version ‖ postcard(message)))` followed
//! by a 0x00 delimiter. COBS makes 0x00 unique to delimiters, so a receiver that sees garbage, a
//! dropped byte or a bad CRC discards just that frame and is back in sync at the next 0x00.
//! The CRC is CRC-32/ISO-HDLC (the Ethernet/zlib CRC), little-endian on the wire.

use crate::board_id::BoardIdentity;
use crate::energy::Snapshot;
use crate::ina226::{
    AdcConfig, BusVoltageRaw, CalibrationRaw, ConfigurationRaw, CurrentRaw, DieIdRaw,
    ManufacturerIdRaw, PowerRaw, Registers, Scale, ShuntVoltageRaw,
};
use crate::Sides;
use serde::{de::DeserializeOwned, Deserialize, Serialize};

/// Bumped whenever a message layout changes; both ends refuse frames of another version.
/// 2: the hello frame carries the board's identity (unique ID, crystal).
/// 3: the hello frame carries each chip's ID, configuration and calibration registers, read
/// back for a `GetHello` (`host-tool check`).
pub const PROTOCOL_VERSION: u8 = 3;

/// Largest unencoded frame body: version byte + postcard message + 4 CRC bytes.
pub const MAX_BODY: usize = 128;

/// Largest encoded frame on the wire, delimiter included.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_BODY) + 1;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Firmware version reported in the hello frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FirmwareVersion {
    pub major: u8,
    pub minor: u8,
    pub patch: u8,
}

/// First frame after the host opens the port (DTR raised), and on request: everything needed to
/// turn raw registers into SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Hello {
    pub protocol: u8,
    pub firmware: FirmwareVersion,
    /// Shunt resistance and current LSB (the power LSB is 25 current LSBs).
    pub scale: Scale,
    /// Power LSB [µW], stated explicitly for readers that do not derive it.
    pub power_lsb_uw: u32,
    /// Shunt voltage LSB [nV].
    pub shunt_lsb_nv: u32,
    /// Bus voltage LSB [µV].
    pub bus_lsb_uv: u32,
    /// 7-bit I²C addresses of the left and right chips.
    pub addresses: Sides<u8>,
    pub adc: AdcConfig,
    pub sample_period_us: u32,
    /// The MCU's unique ID (the USB serial number is built from it) and the crystal.
    pub identity: BoardIdentity,
    /// Each chip's identity and set-up registers: read back for a `GetHello`, not read for the
    /// hello sent on connect (it costs no bus time).
    pub chips: Sides<ChipProbe>,
}

/// A chip's ID and set-up registers as read back from it (datasheet Table 2: FEh, FFh, 00h,
/// 05h). An INA226 reads 0x5449 / 0x2260; a chip that reset reads CAL 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChipRegistersReadBack {
    pub manufacturer_id: ManufacturerIdRaw,
    pub die_id: DieIdRaw,
    pub configuration: ConfigurationRaw,
    pub calibration: CalibrationRaw,
}

/// What reading a chip's ID and set-up registers gave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ChipProbe {
    /// The chip answered all four reads.
    Answered(ChipRegistersReadBack),
    /// A read failed (a missing chip NACKs its address).
    Failed(ChipFault),
    /// Not read: the hello sent on connect, or one the host synthesised (replay of a run CSV).
    NotRead,
}

/// Why a chip gave no reading in a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ChipFault {
    /// The chip did not acknowledge its address (absent, unpowered, wrong address).
    AddressNack,
    /// A data byte was not acknowledged.
    DataNack,
    /// Another master won arbitration.
    ArbitrationLoss,
    /// Bus error: a transaction that did not finish within its deadline (a line held low, missing
    /// pull-ups, a misplaced START/STOP); the board reset the bus and clocked it free.
    Bus,
    /// Receive overrun.
    Overrun,
    /// Any other I²C error.
    Other,
    /// Answered, but the manufacturer/die ID is not an INA226's.
    WrongId,
    /// The calibration register read back 0: the chip reset (brown-out); it is being re-initialised.
    ResetDetected,
    /// Just (re-)initialised: its registers still hold a result computed with the old settings,
    /// so none is reported until the first conversion with the new ones completes.
    AwaitingConversion,
    /// Read, but not a value the chip holds: a bus voltage with bit 15 set (e.g. 0xFFFF, SDA left
    /// high as by a chip browning out mid-read); the reading is discarded.
    InvalidReading,
}

impl ChipFault {
    /// What the fault means at bring-up, for the board's logs.
    pub const fn explain(self) -> &'static str {
        match self {
            ChipFault::AddressNack => "address NACK (missing, unpowered, or A0/A1 strapped wrong)",
            ChipFault::DataNack => "data NACK",
            ChipFault::ArbitrationLoss => "arbitration loss",
            ChipFault::Bus => "bus error (pull-ups? SDA/SCL shorted or swapped?)",
            ChipFault::Overrun => "overrun",
            ChipFault::Other => "I2C error",
            ChipFault::WrongId => "not an INA226 (manufacturer/die ID is not 0x5449/0x2260)",
            ChipFault::ResetDetected => "reset, re-initialising",
            ChipFault::AwaitingConversion => "waiting for its first conversion",
            ChipFault::InvalidReading => {
                "bus voltage read with bit 15 set (brown-out? interference on SDA?)"
            }
        }
    }
}

/// One chip's part of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ChipReading {
    /// A new conversion result since the previous read (the board reads no sooner than the
    /// conversion period allows; firmware before issue 13 polled the conversion-ready flag).
    /// Current and power are the board's Eq 3–4 on shunt and bus, bit-identical to the chip's.
    Fresh(Registers),
    /// No new result since the previous read: the same averaged values, read again (sent by
    /// firmware before issue 13; still decoded for its logs).
    Stale(Registers),
    /// No reading this period.
    Failed(ChipFault),
}

impl ChipReading {
    /// The registers, if the chip was read.
    pub fn registers(&self) -> Option<Registers> {
        match self {
            ChipReading::Fresh(r) | ChipReading::Stale(r) => Some(*r),
            ChipReading::Failed(_) => None,
        }
    }
}

/// One sampling period: both chips' raw registers, stamped on the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sample {
    /// Board time at the start of the period [µs since boot].
    pub t_us: u64,
    /// Sample counter; a gap on the host means frames were lost.
    pub seq: u32,
    pub chips: Sides<ChipReading>,
}

/// The board's running measurements after sample `seq` (sent periodically).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Model {
    pub t_us: u64,
    pub seq: u32,
    pub snapshot: Snapshot,
}

/// Board health counters (sent periodically and on request).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Status {
    pub uptime_us: u64,
    /// Samples taken since boot (the next sample's `seq`).
    pub samples: u32,
    /// Whether sampling is running (host `Start`/`Stop`).
    pub running: bool,
    /// I²C transactions that failed, per chip.
    pub i2c_errors: Sides<u32>,
    /// Re-initialisations after a detected chip reset or a recovered fault, per chip.
    pub reinits: Sides<u32>,
    /// Results each chip completed that no read returned (reads are timed from the conversion
    /// period, not polled: a sample period longer than the chip's skips some by design, a
    /// missed period skips one).
    pub skipped_results: Sides<u32>,
    /// The latest fault per chip (`None` once the chip reads fine again).
    pub last_fault: Sides<Option<ChipFault>>,
    /// Frames dropped because the USB transmit queue was full, since this connection began
    /// (the host's DTR rising edge).
    pub queue_drops: u32,
    /// Host frames that failed to decode (bad COBS, CRC, version or content), since this
    /// connection began.
    pub rx_errors: u32,
    pub adc: AdcConfig,
    pub sample_period_us: u32,
    /// Commanded wheel rates the board uses for τ ∝ P/ω [rad/s].
    pub wheel_rates_rad_s: Option<Sides<f32>>,
}

/// Why the board refused a host command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rejection {
    /// The frame did not decode (COBS, CRC, version or unknown command); its id is unknown.
    Malformed,
    /// A value is out of its documented range.
    OutOfRange,
    /// Writing the configuration to a chip failed.
    Chip(ChipFault),
}

/// Everything the board sends.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum BoardFrame {
    Hello(Hello),
    Sample(Sample),
    Model(Model),
    Status(Status),
    /// Command `id` was carried out.
    Ack {
        id: u16,
    },
    /// Command `id` (`None` if undecodable) was refused.
    Rejected {
        id: Option<u16>,
        reason: Rejection,
    },
}

/// Shortest sampling period a host may configure [µs] (2 kHz, the I²C bus's limit; a slower
/// averaging raises it: [`AdcConfig::min_sample_period_us`]).
pub use crate::rate::MIN_SAMPLE_PERIOD_US;
/// Longest sampling period a host may configure [µs].
pub const MAX_SAMPLE_PERIOD_US: u32 = 1_000_000;
/// Largest commanded wheel rate accepted [rad/s] (≈ 165 m/s on a Husky wheel: clearly bogus).
pub const MAX_WHEEL_RATE_RAD_S: f32 = 1_000.0;

/// What the host can ask of the board.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Set averaging, conversion times and the sampling period: at most MAX_SAMPLE_PERIOD_US,
    /// at least `adc.min_sample_period_us()` (the bus's limit, or the averaging's when longer).
    Configure {
        adc: AdcConfig,
        sample_period_us: u32,
    },
    /// Commanded wheel angular rates for τ ∝ P/ω [rad/s] (finite, |ω| ≤ MAX_WHEEL_RATE_RAD_S).
    SetWheelRates(Sides<f32>),
    /// Forget the wheel rates: τ becomes undefined.
    ClearWheelRates,
    /// Zero the energy accumulators.
    ResetEnergy,
    /// Resume sampling.
    Start,
    /// Pause sampling (energy stops accumulating; time keeps running).
    Stop,
    /// Send a status frame now.
    GetStatus,
    /// Send the hello frame again, with each chip's registers read back.
    GetHello,
}

impl Command {
    /// Checks documented ranges; the board answers `Rejected(OutOfRange)` when this fails.
    pub fn validate(&self) -> Result<(), Rejection> {
        let ok = match self {
            Command::Configure {
                adc,
                sample_period_us,
            } => (adc.min_sample_period_us()..=MAX_SAMPLE_PERIOD_US).contains(sample_period_us),
            Command::SetWheelRates(rates) => [rates.left, rates.right]
                .iter()
                .all(|w| w.is_finite() && libm::fabsf(*w) <= MAX_WHEEL_RATE_RAD_S),
            _ => true,
        };
        if ok {
            Ok(())
        } else {
            Err(Rejection::OutOfRange)
        }
    }
}

/// A host command with the id its answer (ack or rejection) carries.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HostFrame {
    pub id: u16,
    pub command: Command,
}

/// Encoding failed: the message does not fit `MAX_BODY` or the output buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EncodeError;

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("frame does not fit its buffer")
    }
}

/// Encodes `message` as one delimited frame into `out`; returns the number of bytes written.
pub fn encode<T: Serialize>(message: &T, out: &mut [u8]) -> Result<usize, EncodeError> {
    let mut body = [0u8; MAX_BODY];
    body[0] = PROTOCOL_VERSION;
    let used = postcard::to_slice(message, &mut body[1..MAX_BODY - 4])
        .map_err(|_| EncodeError)?
        .len();
    let crc_at = 1 + used;
    let crc = CRC.checksum(&body[..crc_at]);
    body[crc_at..crc_at + 4].copy_from_slice(&crc.to_le_bytes());
    let body = &body[..crc_at + 4];
    if out.len() < cobs::max_encoding_length(body.len()) + 1 {
        return Err(EncodeError);
    }
    let n = cobs::encode(body, out);
    out[n] = 0;
    Ok(n + 1)
}

/// Why a received frame was discarded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// Longer than `MAX_FRAME` before a delimiter (garbage or a lost delimiter).
    Overflow,
    /// Not valid COBS.
    Cobs,
    /// Too short to hold a version and a CRC.
    Truncated,
    /// CRC mismatch: corrupted bytes.
    Crc,
    /// Another protocol version.
    Version(u8),
    /// CRC fine but the message does not decode (unknown variant, trailing bytes, bad value).
    Message,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::Overflow => f.write_str("frame longer than the maximum"),
            FrameError::Cobs => f.write_str("invalid COBS encoding"),
            FrameError::Truncated => f.write_str("frame too short"),
            FrameError::Crc => f.write_str("CRC mismatch"),
            FrameError::Version(v) => {
                write!(f, "protocol version {v}, expected {PROTOCOL_VERSION}")
            }
            FrameError::Message => f.write_str("message does not decode"),
        }
    }
}

/// Decodes one frame's COBS bytes (without the delimiter), in place.
pub fn decode_frame<T: DeserializeOwned>(cobs_bytes: &mut [u8]) -> Result<T, FrameError> {
    let n = cobs::decode_in_place(cobs_bytes).map_err(|_| FrameError::Cobs)?;
    let body = &cobs_bytes[..n];
    if body.len() < 1 + 4 {
        return Err(FrameError::Truncated);
    }
    let (payload, crc_bytes) = body.split_at(body.len() - 4);
    let crc = u32::from_le_bytes([crc_bytes[0], crc_bytes[1], crc_bytes[2], crc_bytes[3]]);
    if CRC.checksum(payload) != crc {
        return Err(FrameError::Crc);
    }
    if payload[0] != PROTOCOL_VERSION {
        return Err(FrameError::Version(payload[0]));
    }
    match postcard::take_from_bytes::<T>(&payload[1..]) {
        Ok((message, [])) => Ok(message),
        _ => Err(FrameError::Message),
    }
}

/// Streaming receiver: feed it bytes as they arrive, get messages or errors at each delimiter.
/// Never panics, whatever the input; after any error it is in sync again at the next 0x00.
#[derive(Debug)]
pub struct FrameDecoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflowed: bool,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflowed: false,
        }
    }
}

impl FrameDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Pushes one byte; at a delimiter returns the frame's outcome. Empty frames (repeated
    /// delimiters, used to flush a line) yield nothing.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return None;
        }
        let (len, overflowed) = (self.len, self.overflowed);
        self.len = 0;
        self.overflowed = false;
        if overflowed {
            Some(Err(FrameError::Overflow))
        } else if len == 0 {
            None
        } else {
            Some(decode_frame(&mut self.buf[..len]))
        }
    }

    /// Feeds a chunk of bytes, calling `on_frame` for each completed frame.
    pub fn feed<T: DeserializeOwned>(
        &mut self,
        bytes: &[u8],
        mut on_frame: impl FnMut(Result<T, FrameError>),
    ) {
        for &b in bytes {
            if let Some(outcome) = self.push(b) {
                on_frame(outcome);
            }
        }
    }

    /// Bytes of an unfinished frame waiting for their delimiter.
    pub fn pending(&self) -> usize {
        self.len
    }
}

/// A typical sample frame, 10 minutes into a run at 2 A and 24.6 V on each side: the fixture
/// the wire tests and the on-target check (`firmware/src/bin/model_core_qemu.rs`) measure
/// encoding with (36 bytes on the wire).
pub fn typical_sample() -> BoardFrame {
    let regs = Registers {
        shunt: ShuntVoltageRaw(4000),
        bus: BusVoltageRaw(19_680),
        current: CurrentRaw(4000),
        power: PowerRaw(3936),
    };
    BoardFrame::Sample(Sample {
        t_us: 600_000_000,
        seq: 120_000,
        chips: Sides::new(ChipReading::Fresh(regs), ChipReading::Fresh(regs)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ina226::{Averaging, ConversionTime};
    use proptest::prelude::*;

    fn full_scale_registers() -> Registers {
        Registers {
            shunt: ShuntVoltageRaw(i16::MIN),
            bus: BusVoltageRaw(0x7FFF),
            current: CurrentRaw(i16::MIN),
            power: PowerRaw(u16::MAX),
        }
    }

    fn worst_case_sample() -> BoardFrame {
        BoardFrame::Sample(Sample {
            t_us: u64::MAX,
            seq: u32::MAX,
            chips: Sides::new(
                ChipReading::Fresh(full_scale_registers()),
                ChipReading::Stale(full_scale_registers()),
            ),
        })
    }

    fn worst_case_status() -> BoardFrame {
        BoardFrame::Status(Status {
            uptime_us: u64::MAX,
            samples: u32::MAX,
            running: true,
            i2c_errors: Sides::new(u32::MAX, u32::MAX),
            reinits: Sides::new(u32::MAX, u32::MAX),
            skipped_results: Sides::new(u32::MAX, u32::MAX),
            last_fault: Sides::new(Some(ChipFault::ResetDetected), Some(ChipFault::Other)),
            queue_drops: u32::MAX,
            rx_errors: u32::MAX,
            adc: AdcConfig::BOARD_DEFAULT,
            sample_period_us: u32::MAX,
            wheel_rates_rad_s: Some(Sides::new(f32::MAX, f32::MIN)),
        })
    }

    fn round_trip<T: Serialize + DeserializeOwned + PartialEq + core::fmt::Debug>(
        msg: &T,
    ) -> usize {
        let mut out = [0u8; MAX_FRAME];
        let n = encode(msg, &mut out).expect("fits");
        assert_eq!(out[n - 1], 0);
        assert!(
            !out[..n - 1].contains(&0),
            "COBS leaves 0x00 only as the delimiter"
        );
        let mut dec = FrameDecoder::new();
        let mut got = None;
        dec.feed::<T>(&out[..n], |r| got = Some(r));
        assert_eq!(got.expect("one frame").as_ref(), Ok(msg));
        n
    }

    #[test]
    fn every_board_frame_round_trips_and_fits() {
        round_trip(&worst_case_sample());
        round_trip(&worst_case_status());
        round_trip(&BoardFrame::Rejected {
            id: Some(u16::MAX),
            reason: Rejection::Chip(ChipFault::WrongId),
        });
        round_trip(&BoardFrame::Ack { id: 7 });
        round_trip(&BoardFrame::Hello(Hello {
            protocol: PROTOCOL_VERSION,
            firmware: FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
            scale: Scale::BOARD,
            power_lsb_uw: 12_500,
            shunt_lsb_nv: 2_500,
            bus_lsb_uv: 1_250,
            addresses: Sides::new(0x40, 0x45),
            adc: AdcConfig::BOARD_DEFAULT,
            sample_period_us: 5_000,
            identity: BoardIdentity {
                uid: [0xFF; crate::board_id::UID_LEN],
                hse_mhz: 25,
            },
            chips: Sides::new(
                ChipProbe::Answered(ChipRegistersReadBack {
                    manufacturer_id: ManufacturerIdRaw(u16::MAX),
                    die_id: DieIdRaw(u16::MAX),
                    configuration: ConfigurationRaw(u16::MAX),
                    calibration: CalibrationRaw(u16::MAX),
                }),
                ChipProbe::Failed(ChipFault::AwaitingConversion),
            ),
        }));
        round_trip(&BoardFrame::Model(Model {
            t_us: u64::MAX,
            seq: u32::MAX,
            snapshot: Snapshot {
                power_lsb: Sides::new(Some(i32::MIN), Some(i32::MAX)),
                energy_lsb_us: Sides::new(i64::MIN, i64::MAX),
                torque_proportional: Sides::new(Some(f32::MAX), None),
            },
        }));
    }

    #[test]
    fn every_command_round_trips() {
        let adc = AdcConfig {
            averaging: Averaging::X1024,
            bus_conversion: ConversionTime::Us8244,
            shunt_conversion: ConversionTime::Us140,
        };
        for command in [
            Command::Configure {
                adc,
                sample_period_us: 5_000,
            },
            Command::SetWheelRates(Sides::new(-1.5, 3.6)),
            Command::ClearWheelRates,
            Command::ResetEnergy,
            Command::Start,
            Command::Stop,
            Command::GetStatus,
            Command::GetHello,
        ] {
            round_trip(&HostFrame { id: 42, command });
        }
    }

    #[test]
    fn sample_frame_size_on_the_wire() {
        let typical = round_trip(&typical_sample());
        let worst = round_trip(&worst_case_sample());
        // Reported in the closing note; guards against an accidental layout blow-up.
        println!("sample frame bytes on the wire: typical {typical}, worst case {worst}");
        assert!(typical <= 40, "typical sample frame is {typical} bytes");
        assert!(worst <= 50, "worst-case sample frame is {worst} bytes");
    }

    #[test]
    fn corrupted_frames_are_rejected_and_the_next_frame_decodes() {
        let mut good = [0u8; MAX_FRAME];
        let n = encode(&typical_sample(), &mut good).expect("fits");
        for i in 0..n - 1 {
            for flip in [0x01u8, 0x80, 0xFF] {
                let mut bad = good;
                bad[i] ^= flip;
                let mut stream = [0u8; 2 * MAX_FRAME];
                stream[..n].copy_from_slice(&bad[..n]);
                stream[n..2 * n].copy_from_slice(&good[..n]);
                let mut results = [None, None, None];
                let mut k = 0;
                FrameDecoder::new().feed::<BoardFrame>(&stream[..2 * n], |r| {
                    if k < 3 {
                        results[k] = Some(r);
                    }
                    k += 1;
                });
                // A flip that creates a 0x00 splits the bad frame in two; either way every bad
                // part is rejected and the good frame after it decodes.
                let last = results[k - 1].expect("a result");
                assert_eq!(last, Ok(typical_sample()), "byte {i} ^ {flip:#x}");
                for r in &results[..k - 1] {
                    assert!(
                        r.expect("a result").is_err(),
                        "byte {i} ^ {flip:#x} accepted"
                    );
                }
            }
        }
    }

    #[test]
    fn wrong_version_and_overflow_are_reported() {
        let mut body = [0u8; 16];
        body[0] = PROTOCOL_VERSION + 1;
        let crc = CRC.checksum(&body[..3]);
        body[3..7].copy_from_slice(&crc.to_le_bytes());
        let mut enc = [0u8; 32];
        let n = cobs::encode(&body[..7], &mut enc);
        assert_eq!(
            decode_frame::<BoardFrame>(&mut enc[..n]),
            Err(FrameError::Version(PROTOCOL_VERSION + 1))
        );

        let mut dec = FrameDecoder::new();
        for _ in 0..MAX_FRAME + 10 {
            assert!(dec.push::<BoardFrame>(0x55).is_none());
        }
        assert_eq!(dec.push::<BoardFrame>(0), Some(Err(FrameError::Overflow)));
        assert_eq!(dec.push::<BoardFrame>(0), None);
    }

    #[test]
    fn out_of_range_commands_are_refused() {
        let adc = AdcConfig::BOARD_DEFAULT;
        let configure = |adc, sample_period_us| Command::Configure {
            adc,
            sample_period_us,
        };
        // The board default's 16 × 280 µs averaging needs 4928 µs (10 % margin).
        assert_eq!(configure(adc, 4_927).validate(), Err(Rejection::OutOfRange));
        assert_eq!(configure(adc, 4_928).validate(), Ok(()));
        // Without averaging the bus sets the floor: 2 kHz.
        let fast = AdcConfig {
            averaging: Averaging::X1,
            ..adc
        };
        assert_eq!(configure(fast, 499).validate(), Err(Rejection::OutOfRange));
        assert_eq!(configure(fast, 500).validate(), Ok(()));
        assert_eq!(
            configure(fast, MAX_SAMPLE_PERIOD_US + 1).validate(),
            Err(Rejection::OutOfRange)
        );
        assert_eq!(
            Command::SetWheelRates(Sides::new(f32::NAN, 0.0)).validate(),
            Err(Rejection::OutOfRange)
        );
        assert_eq!(
            Command::SetWheelRates(Sides::new(0.0, -1001.0)).validate(),
            Err(Rejection::OutOfRange)
        );
        assert_eq!(
            Command::SetWheelRates(Sides::new(0.0, -3.0)).validate(),
            Ok(())
        );
    }

    proptest! {
        #[test]
        fn decoder_never_panics_and_resyncs(garbage in proptest::collection::vec(any::<u8>(), 0..600)) {
            let mut good = [0u8; MAX_FRAME];
            let n = encode(&typical_sample(), &mut good).expect("fits");
            let mut dec = FrameDecoder::new();
            dec.feed::<BoardFrame>(&garbage, |_| {});
            dec.feed::<HostFrame>(&garbage, |_| {});
            // Whatever came before, a delimiter then a good frame decodes.
            let mut last = None;
            dec.feed::<BoardFrame>(&[0], |_| {});
            dec.feed::<BoardFrame>(&good[..n], |r| last = Some(r));
            prop_assert_eq!(last, Some(Ok(typical_sample())));
        }

        #[test]
        fn arbitrary_frames_decode_or_error(mut bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = decode_frame::<BoardFrame>(&mut bytes.clone());
            let _ = decode_frame::<HostFrame>(&mut bytes);
        }

        #[test]
        fn valid_crc_arbitrary_payloads_never_panic(payload in proptest::collection::vec(any::<u8>(), 0..100)) {
            // Bypass the CRC so postcard itself sees arbitrary bytes.
            let mut body = [0u8; 110];
            body[0] = PROTOCOL_VERSION;
            body[1..1 + payload.len()].copy_from_slice(&payload);
            let end = 1 + payload.len();
            let crc = CRC.checksum(&body[..end]);
            body[end..end + 4].copy_from_slice(&crc.to_le_bytes());
            let mut enc = [0u8; 130];
            let n = cobs::encode(&body[..end + 4], &mut enc);
            // Decoding works in place, so each decoder gets its own copy.
            let mut copy = enc;
            let _ = decode_frame::<BoardFrame>(&mut copy[..n]);
            let _ = decode_frame::<HostFrame>(&mut enc[..n]);
        }
    }
}
