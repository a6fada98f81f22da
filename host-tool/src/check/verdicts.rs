//! The verdict of each step from what the session observed: pure functions, tested without a
//! port.

use super::{Hint, Limits, Side, Step, StepId};
use crate::serial::{PortInfo, SerialError};
use firmware::ina226::{Calibration, Ina226, DIE_ID, MANUFACTURER_ID};
use model_core::ina226::AdcConfig;
use model_core::wire::{ChipFault, ChipProbe, Hello, Rejection, PROTOCOL_VERSION};
use model_core::Sides;
use std::time::Duration;

/// Port step: the given port, or the one rover-power board among `ports`.
pub fn port(given: Option<&str>, ports: &[PortInfo]) -> (Step, Option<String>) {
    if let Some(path) = given {
        return (
            Step::pass(StepId::Port, format!("{path} (given)")),
            Some(path.into()),
        );
    }
    let boards: Vec<&PortInfo> = ports.iter().filter(|p| p.is_rover_power()).collect();
    match boards.as_slice() {
        [] => (
            Step::fail(
                StepId::Port,
                format!(
                    "none of {} serial port(s) is a rover-power board",
                    ports.len()
                ),
                Hint::NoBoardFound,
            ),
            None,
        ),
        [board] => (
            Step::pass(
                StepId::Port,
                format!(
                    "{} (16c0:27dd, serial {})",
                    board.name,
                    board.serial_number.as_deref().unwrap_or("-")
                ),
            ),
            Some(board.name.clone()),
        ),
        several => (
            Step::fail(
                StepId::Port,
                several
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                Hint::SeveralBoards,
            ),
            None,
        ),
    }
}

/// Open and DTR steps when opening failed: a refused DTR means the port did open.
pub fn open_failed(error: &SerialError) -> Vec<Step> {
    let open_fail = |hint| vec![Step::fail(StepId::Open, error.to_string(), hint)];
    match error {
        SerialError::Dtr { .. } => vec![
            Step::pass(StepId::Open, "opened"),
            Step::fail(StepId::Dtr, error.to_string(), Hint::NoDtr),
        ],
        SerialError::PermissionDenied { .. } => open_fail(Hint::PermissionDenied),
        // serialport reports EBUSY (TIOCEXCL: someone else has the port) as `NoDevice`.
        SerialError::Open { source, .. } => match source.kind() {
            serialport::ErrorKind::NoDevice => open_fail(Hint::PortBusy),
            serialport::ErrorKind::Io(std::io::ErrorKind::NotFound) => open_fail(Hint::NoSuchPort),
            _ if source.description.contains("No such") => open_fail(Hint::NoSuchPort),
            _ => open_fail(Hint::OpenFailed),
        },
        SerialError::List(_) | SerialError::ZeroTimeout => open_fail(Hint::OpenFailed),
    }
}

/// What arrived while waiting for the hello.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Heard {
    /// Bytes read.
    pub bytes: u64,
    /// Frames of any version (good, or refused only for their version).
    pub frames: u64,
    /// The protocol version of frames refused for it.
    pub foreign_version: Option<u8>,
}

/// Hello step: a hello of this protocol arrived within the timeout.
pub fn hello(hello: Option<&Hello>, heard: Heard, timeout: Duration) -> Step {
    let waited = format!("{:.1} s", timeout.as_secs_f64());
    match (hello, heard.foreign_version) {
        (Some(h), _) if h.protocol == PROTOCOL_VERSION => {
            let f = h.firmware;
            Step::pass(
                StepId::Hello,
                format!(
                    "protocol {}, firmware {}.{}.{}, {}",
                    h.protocol,
                    f.major,
                    f.minor,
                    f.patch,
                    crate::decode::identity_line(&h.identity)
                ),
            )
        }
        (Some(h), _) => Step::fail(
            StepId::Hello,
            format!("the hello says protocol {}", h.protocol),
            Hint::ProtocolMismatch { board: h.protocol },
        ),
        (None, Some(board)) => Step::fail(
            StepId::Hello,
            format!(
                "{} frame(s) of protocol {board} in {waited}, none of protocol {PROTOCOL_VERSION}",
                heard.frames
            ),
            Hint::ProtocolMismatch { board },
        ),
        (None, None) if heard.bytes == 0 => Step::fail(
            StepId::Hello,
            format!("no byte in {waited}"),
            Hint::SilentPort,
        ),
        (None, None) if heard.frames == 0 => Step::fail(
            StepId::Hello,
            format!("{} bytes in {waited}, not one frame", heard.bytes),
            Hint::NotTheBoard,
        ),
        (None, None) => Step::fail(
            StepId::Hello,
            format!("{} frame(s) in {waited} but no hello", heard.frames),
            Hint::SilentPort,
        ),
    }
}

/// The CAL the board writes for the hello's scale.
fn expected_calibration(hello: &Hello) -> Option<u16> {
    Calibration::new(hello.scale).ok().map(|c| c.value())
}

/// Chips step: both chips answered with an INA226's IDs and hold the calibration.
pub fn chips(hello: &Hello) -> Step {
    let expected = expected_calibration(hello);
    let mut found = Vec::new();
    for side in Side::ALL {
        let address = side.of(hello.addresses);
        let registers = match side.of(hello.chips) {
            ChipProbe::Answered(r) => r,
            ChipProbe::Failed(ChipFault::AddressNack) => {
                return Step::fail(
                    StepId::Chips,
                    format!("{side} {address:#04x}: no acknowledge"),
                    Hint::ChipMissing { side, address },
                )
            }
            ChipProbe::Failed(fault) => {
                return Step::fail(
                    StepId::Chips,
                    format!("{side} {address:#04x}: {fault:?}"),
                    Hint::ChipBus { side, fault },
                )
            }
            ChipProbe::NotRead => {
                return Step::fail(StepId::Chips, "not read by a board", Hint::NotABoard)
            }
        };
        let (manufacturer, die) = (registers.manufacturer_id.0, registers.die_id.0);
        if (manufacturer, die) != (MANUFACTURER_ID, DIE_ID) {
            return Step::fail(
                StepId::Chips,
                format!("{side} {address:#04x}: ID {manufacturer:#06x}/{die:#06x}"),
                Hint::WrongId {
                    side,
                    manufacturer,
                    die,
                },
            );
        }
        let expected = expected.unwrap_or(0);
        let calibration = registers.calibration.0;
        if calibration != expected {
            return Step::fail(
                StepId::Chips,
                format!("{side} {address:#04x}: CAL {calibration}"),
                Hint::CalibrationNotHeld {
                    side,
                    read: calibration,
                    expected,
                },
            );
        }
        found.push(format!(
            "{side} {address:#04x} INA226 {manufacturer:#06x}/{die:#06x} CAL {calibration}"
        ));
    }
    Step::pass(StepId::Chips, found.join("; "))
}

/// "16 × (140 + 140 µs) = 4.48 ms per result".
pub fn describe_adc(adc: &AdcConfig) -> String {
    format!(
        "{} × ({} + {} µs) = {:.2} ms per result",
        adc.averaging.count(),
        adc.bus_conversion.micros(),
        adc.shunt_conversion.micros(),
        f64::from(adc.update_period_us()) / 1e3
    )
}

/// Whether each chip's configuration register holds `adc`; the first that does not.
fn configuration_mismatch(hello: &Hello, adc: &AdcConfig) -> Option<Hint> {
    let expected = Ina226::config_word(*adc);
    Side::ALL
        .into_iter()
        .find_map(|side| match side.of(hello.chips) {
            ChipProbe::Answered(r) if r.configuration.0 != expected => {
                Some(Hint::ConfigurationMismatch {
                    side,
                    read: r.configuration.0,
                    expected,
                })
            }
            _ => None,
        })
}

/// Averaging step: both chips' configuration registers hold the board's averaging.
pub fn averaging(hello: &Hello) -> Step {
    match configuration_mismatch(hello, &hello.adc) {
        Some(hint) => Step::fail(
            StepId::Averaging,
            format!("the board reports {}", describe_adc(&hello.adc)),
            hint,
        ),
        None => Step::pass(
            StepId::Averaging,
            format!(
                "{}, read every {:.1} ms",
                describe_adc(&hello.adc),
                f64::from(hello.sample_period_us) / 1e3
            ),
        ),
    }
}

/// What the stream showed over the measuring window (after the hello).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Window {
    /// Samples received.
    pub samples: u64,
    /// First and last sample: (seq, board time [µs]).
    pub first: Option<(u32, u64)>,
    pub last: Option<(u32, u64)>,
    /// Samples lost (sequence gaps), frames refused, of them CRC errors, board restarts.
    pub lost_samples: u64,
    pub bad_frames: u64,
    pub crc_errors: u64,
    pub board_resets: u64,
    /// Frames the board dropped (its queue full), from its status frames.
    pub queue_drops: u64,
    /// Chip resets per side: samples reporting one, or re-initialisations in the status frames.
    pub resets: Sides<u64>,
    /// Readings that failed otherwise, and the latest such fault, per side.
    pub failed: Sides<u64>,
    pub last_fault: Sides<Option<ChipFault>>,
    /// Readings, and the sums of their bus voltage [V] and current [A], per side.
    pub readings: Sides<u64>,
    pub bus_v_sum: Sides<f64>,
    pub current_a_sum: Sides<f64>,
}

impl Window {
    fn mean(&self, sum: Sides<f64>, side: Side) -> Option<f64> {
        let n = side.of(self.readings);
        (n > 0).then(|| side.of(sum) / n as f64)
    }
}

/// The steps judged on the window: rate, losses, chip stability, bus voltages, standstill.
pub fn window(hello: &Hello, w: &Window, limits: &Limits) -> Vec<Step> {
    vec![
        rate(hello, w, limits),
        losses(w),
        stability(hello, w),
        bus_voltages(hello, w, limits),
        standstill(w, limits),
    ]
}

fn rate(hello: &Hello, w: &Window, limits: &Limits) -> Step {
    let configured_hz = 1e6 / f64::from(hello.sample_period_us.max(1));
    let (Some((seq0, t0)), Some((seq1, t1))) = (w.first, w.last) else {
        return Step::fail(
            StepId::Rate,
            format!(
                "{} samples in the window (stopped by a host's Stop? the next Start resumes)",
                w.samples
            ),
            Hint::RateOff,
        );
    };
    if t1 <= t0 {
        return Step::fail(StepId::Rate, "fewer than two samples", Hint::RateOff);
    }
    let measured_hz = f64::from(seq1.wrapping_sub(seq0)) / ((t1 - t0) as f64 / 1e6);
    let detail = format!(
        "{measured_hz:.1} Hz on the board's clock, configured {configured_hz:.1} Hz ({} samples)",
        w.samples
    );
    if (measured_hz / configured_hz - 1.0).abs() <= limits.rate_tolerance {
        Step::pass(StepId::Rate, detail)
    } else {
        Step::fail(StepId::Rate, detail, Hint::RateOff)
    }
}

fn losses(w: &Window) -> Step {
    let detail = format!(
        "{} lost samples, {} bad frames ({} CRC errors), {} dropped on the board, {} board restarts",
        w.lost_samples, w.bad_frames, w.crc_errors, w.queue_drops, w.board_resets
    );
    if w.lost_samples + w.bad_frames + w.queue_drops + w.board_resets == 0 {
        Step::pass(StepId::Losses, detail)
    } else {
        Step::fail(StepId::Losses, detail, Hint::Losses)
    }
}

fn stability(hello: &Hello, w: &Window) -> Step {
    let detail = format!(
        "resets left {} right {}, failed readings left {} right {}",
        w.resets.left, w.resets.right, w.failed.left, w.failed.right
    );
    for side in Side::ALL {
        let resets = side.of(w.resets);
        if resets > 0 {
            return Step::fail(
                StepId::ChipStability,
                detail,
                Hint::ChipResets { side, resets },
            );
        }
        if side.of(w.failed) > 0 {
            let hint = match side.of(w.last_fault) {
                Some(ChipFault::AddressNack) | None => Hint::ChipMissing {
                    side,
                    address: side.of(hello.addresses),
                },
                Some(fault) => Hint::ChipBus { side, fault },
            };
            return Step::fail(StepId::ChipStability, detail, hint);
        }
    }
    Step::pass(StepId::ChipStability, detail)
}

fn bus_voltages(hello: &Hello, w: &Window, limits: &Limits) -> Step {
    let (Some(left), Some(right)) = (
        w.mean(w.bus_v_sum, Side::Left),
        w.mean(w.bus_v_sum, Side::Right),
    ) else {
        let side = if w.readings.left == 0 {
            Side::Left
        } else {
            Side::Right
        };
        return Step::fail(
            StepId::BusVoltages,
            "a chip gave no reading",
            Hint::ChipMissing {
                side,
                address: side.of(hello.addresses),
            },
        );
    };
    let detail = format!(
        "left {left:.3} V, right {right:.3} V (differ by {:.3} V, tolerance {} V)",
        (left - right).abs(),
        limits.bus_tolerance_v
    );
    for (side, v) in [(Side::Left, left), (Side::Right, right)] {
        if v < limits.min_bus_v {
            return Step::fail(StepId::BusVoltages, detail, Hint::NoBattery { side });
        }
    }
    if (left - right).abs() > limits.bus_tolerance_v {
        return Step::fail(StepId::BusVoltages, detail, Hint::BusVoltagesDisagree);
    }
    Step::pass(StepId::BusVoltages, detail)
}

fn standstill(w: &Window, limits: &Limits) -> Step {
    let means = Side::ALL.map(|side| (side, w.mean(w.current_a_sum, side)));
    let detail = format!(
        "mean current left {}, right {} (limit ±{} A; the rover must stand still)",
        fmt_amps(means[0].1),
        fmt_amps(means[1].1),
        limits.standstill_max_a
    );
    for (side, mean) in means {
        if mean.is_some_and(|a| a.abs() > limits.standstill_max_a) {
            return Step::fail(StepId::Standstill, detail, Hint::StandstillCurrent { side });
        }
    }
    Step::pass(StepId::Standstill, detail)
}

fn fmt_amps(a: Option<f64>) -> String {
    a.map_or_else(|| "-".into(), |a| format!("{a:.3} A"))
}

/// A command's answer: acked, refused, or none within the timeout.
pub type Answer = Option<Result<(), Rejection>>;

/// The configure round trip: `Configure(test)`, a hello read back, `Configure(original)`, a
/// hello read back.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigureRun {
    pub original: AdcConfig,
    pub test: AdcConfig,
    pub answer: Answer,
    pub read_back: Option<Hello>,
    pub restore_answer: Answer,
    pub restored: Option<Hello>,
}

/// Configure step: both configurations were acked and read back from the chips.
pub fn configure(run: &ConfigureRun) -> Step {
    let check = |what: &str, answer: Answer, hello: Option<&Hello>, adc: &AdcConfig| match (
        answer, hello,
    ) {
        (None, _) => Err(format!("{what}: no answer")),
        (Some(Err(reason)), _) => Err(format!("{what}: refused ({reason:?})")),
        (Some(Ok(())), None) => Err(format!("{what}: no hello read back")),
        (Some(Ok(())), Some(h)) if h.adc != *adc => Err(format!(
            "{what}: the board reports {}",
            describe_adc(&h.adc)
        )),
        (Some(Ok(())), Some(h)) => match configuration_mismatch(h, adc) {
            Some(hint) => Err(format!("{what}: {hint}")),
            None => Ok(()),
        },
    };
    let sent = check("set", run.answer, run.read_back.as_ref(), &run.test).and_then(|()| {
        check(
            "restore",
            run.restore_answer,
            run.restored.as_ref(),
            &run.original,
        )
    });
    match sent {
        Ok(()) => Step::pass(
            StepId::Configure,
            format!(
                "{} averages acked and read back from both chips, {} restored and read back",
                run.test.averaging.count(),
                run.original.averaging.count()
            ),
        ),
        Err(detail) => Step::fail(StepId::Configure, detail, Hint::ConfigureFailed),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn idle(current_a: Sides<f64>, bus_v: Sides<f64>) -> Window {
        let n = 600;
        Window {
            samples: n,
            first: Some((10, 50_000)),
            last: Some((609, 50_000 + 599 * 5_000)),
            readings: Sides::new(n, n),
            bus_v_sum: bus_v.map(|v| v * n as f64),
            current_a_sum: current_a.map(|a| a * n as f64),
            ..Window::default()
        }
    }

    fn hello() -> Hello {
        crate::replay::synthetic_hello(5_000)
    }

    #[test]
    fn the_seeds_standstill_offset_fails_and_a_quiescent_draw_passes() {
        let limits = Limits::default();
        let bus = Sides::new(24.0, 24.0);
        let steps = window(&hello(), &idle(Sides::new(0.03, 0.05), bus), &limits);
        assert!(
            steps
                .iter()
                .all(|s| s.outcome == super::super::Outcome::Pass),
            "{steps:?}"
        );
        // Fig. 3.3: 0.59 A at rest.
        let steps = window(&hello(), &idle(Sides::new(0.03, 0.59), bus), &limits);
        let standstill = &steps[4];
        assert_eq!(standstill.id, StepId::Standstill);
        assert_eq!(
            standstill.hint,
            Some(Hint::StandstillCurrent { side: Side::Right })
        );
    }

    #[test]
    fn bus_voltages_must_agree_and_show_a_battery() {
        let limits = Limits::default();
        let hello = hello();
        let at = |l, r| {
            bus_voltages(
                &hello,
                &idle(Sides::new(0.0, 0.0), Sides::new(l, r)),
                &limits,
            )
        };
        assert_eq!(at(24.0, 23.85).hint, None);
        assert_eq!(at(24.0, 23.7).hint, Some(Hint::BusVoltagesDisagree));
        assert_eq!(
            at(0.0, 24.0).hint,
            Some(Hint::NoBattery { side: Side::Left })
        );
        // No reading at all from the right chip: the hint names its address.
        let mut silent_right = idle(Sides::new(0.0, 0.0), Sides::new(24.0, 0.0));
        silent_right.readings.right = 0;
        assert_eq!(
            bus_voltages(&hello, &silent_right, &limits).hint,
            Some(Hint::ChipMissing {
                side: Side::Right,
                address: 0x45
            })
        );
    }

    #[test]
    fn a_rate_off_by_more_than_the_tolerance_fails() {
        let limits = Limits::default();
        let mut w = idle(Sides::new(0.0, 0.0), Sides::new(24.0, 24.0));
        assert_eq!(rate(&hello(), &w, &limits).hint, None);
        // 599 periods took 2 % longer: a board falling behind.
        w.last = Some((609, 50_000 + 599 * 5_100));
        assert_eq!(rate(&hello(), &w, &limits).hint, Some(Hint::RateOff));
    }

    #[test]
    fn open_errors_get_their_hints_and_a_refused_dtr_means_the_port_opened() {
        let hints = |e: SerialError| -> Vec<(StepId, Option<Hint>)> {
            open_failed(&e)
                .into_iter()
                .map(|s| (s.id, s.hint))
                .collect()
        };
        let path = || "/dev/ttyACM0".to_owned();
        assert_eq!(
            hints(SerialError::PermissionDenied { path: path() }),
            vec![(StepId::Open, Some(Hint::PermissionDenied))]
        );
        let io = |kind, text: &str| serialport::Error::new(serialport::ErrorKind::Io(kind), text);
        assert_eq!(
            hints(SerialError::Open {
                path: path(),
                source: serialport::Error::new(
                    serialport::ErrorKind::NoDevice,
                    "Device or resource busy"
                ),
            }),
            vec![(StepId::Open, Some(Hint::PortBusy))]
        );
        assert_eq!(
            hints(SerialError::Open {
                path: path(),
                source: io(std::io::ErrorKind::NotFound, "No such file or directory"),
            }),
            vec![(StepId::Open, Some(Hint::NoSuchPort))]
        );
        assert_eq!(
            hints(SerialError::Open {
                path: path(),
                source: serialport::Error::new(serialport::ErrorKind::Unknown, "I/O error"),
            }),
            vec![(StepId::Open, Some(Hint::OpenFailed))]
        );
        assert_eq!(
            hints(SerialError::Dtr {
                path: path(),
                source: io(std::io::ErrorKind::Other, "no modem lines"),
            }),
            vec![(StepId::Open, None), (StepId::Dtr, Some(Hint::NoDtr))]
        );
    }

    #[test]
    fn a_synthesised_hello_has_no_chips_to_check() {
        assert_eq!(chips(&hello()).hint, Some(Hint::NotABoard));
    }

    #[test]
    fn the_port_is_the_one_board_or_a_hint() {
        let board = |name: &str| PortInfo {
            name: name.into(),
            usb: Some(crate::serial::UsbId {
                vid: 0x16c0,
                pid: 0x27dd,
            }),
            product: None,
            manufacturer: None,
            serial_number: Some("rover-power.github.io:00".into()),
        };
        let other = PortInfo {
            usb: None,
            serial_number: None,
            ..board("/dev/ttyUSB0")
        };
        let (step, path) = port(None, &[other.clone(), board("/dev/ttyACM0")]);
        assert_eq!((step.hint, path.as_deref()), (None, Some("/dev/ttyACM0")));
        assert_eq!(port(None, &[other]).0.hint, Some(Hint::NoBoardFound));
        assert_eq!(
            port(None, &[board("/dev/ttyACM0"), board("/dev/ttyACM1")])
                .0
                .hint,
            Some(Hint::SeveralBoards)
        );
        assert_eq!(port(Some("/dev/x"), &[]).1.as_deref(), Some("/dev/x"));
    }
}
