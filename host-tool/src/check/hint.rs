//! What to do when a bring-up step fails: one typed hint per cause (tests assert the kind), with
//! the text a user at the bench reads. The wiring they refer to is the README's diagram
//! (`docs/wiring.svg`): INA226 left at 0x40 (A0, A1 to GND), right at 0x45 (A0, A1 to VS), SCL on
//! PB8, SDA on PB9, 2.2–4.7 kΩ pull-ups to 3V3.

use crate::serial::PERMISSION_HINT;
use model_core::wire::ChipFault;
use std::fmt;

/// Which chip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Side {
    Left,
    Right,
}

impl Side {
    /// Both sides, left first.
    pub const ALL: [Side; 2] = [Side::Left, Side::Right];

    /// The side's part of a pair.
    pub fn of<T: Copy>(self, sides: model_core::Sides<T>) -> T {
        match self {
            Side::Left => sides.left,
            Side::Right => sides.right,
        }
    }

    /// The board's address straps for this side (datasheet Table 6).
    fn straps(self) -> &'static str {
        match self {
            Side::Left => "A0 and A1 to GND",
            Side::Right => "A0 and A1 to VS",
        }
    }
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Side::Left => "left",
            Side::Right => "right",
        })
    }
}

/// Why a step failed and what to do, by cause.
#[derive(Debug, Clone, PartialEq)]
pub enum Hint {
    /// No port carries the board's VID:PID and serial prefix.
    NoBoardFound,
    /// More than one board is plugged in.
    SeveralBoards,
    /// The port exists but the user may not open it.
    PermissionDenied,
    /// Another program holds the port.
    PortBusy,
    /// The port does not exist (any more).
    NoSuchPort,
    /// The port exists but opening it failed otherwise.
    OpenFailed,
    /// The port refused DTR; the board transmits only while DTR is held.
    NoDtr,
    /// Nothing arrived after DTR.
    SilentPort,
    /// Bytes arrived but none was a frame of any protocol version.
    NotTheBoard,
    /// Frames arrived in another protocol version.
    ProtocolMismatch { board: u8 },
    /// A chip does not acknowledge its address.
    ChipMissing { side: Side, address: u8 },
    /// A chip's transfers fail on the bus (not a clean NACK).
    ChipBus { side: Side, fault: ChipFault },
    /// A chip answered with IDs that are not an INA226's.
    WrongId {
        side: Side,
        manufacturer: u16,
        die: u16,
    },
    /// A chip's CAL register does not hold what the board wrote.
    CalibrationNotHeld {
        side: Side,
        read: u16,
        expected: u16,
    },
    /// A chip's configuration register does not hold the board's averaging.
    ConfigurationMismatch {
        side: Side,
        read: u16,
        expected: u16,
    },
    /// A chip reset (lost its registers) while the check ran.
    ChipResets { side: Side, resets: u64 },
    /// Samples went missing or arrived corrupted.
    Losses,
    /// The board samples at another rate than it was configured for.
    RateOff,
    /// A chip reads no battery voltage.
    NoBattery { side: Side },
    /// The two chips read different voltages of the one battery.
    BusVoltagesDisagree,
    /// A large current at standstill (the seed's Fig. 3.3 offset).
    StandstillCurrent { side: Side },
    /// The board refused or did not carry out `Configure`.
    ConfigureFailed,
    /// No chip registers to check: a replay, or a firmware that does not read them back.
    NotABoard,
}

impl Hint {
    /// The hint's kind, as `check --json` names it.
    pub fn kind(&self) -> &'static str {
        match self {
            Hint::NoBoardFound => "no-board-found",
            Hint::SeveralBoards => "several-boards",
            Hint::PermissionDenied => "permission-denied",
            Hint::PortBusy => "port-busy",
            Hint::NoSuchPort => "no-such-port",
            Hint::OpenFailed => "open-failed",
            Hint::NoDtr => "no-dtr",
            Hint::SilentPort => "silent-port",
            Hint::NotTheBoard => "not-the-board",
            Hint::ProtocolMismatch { .. } => "protocol-mismatch",
            Hint::ChipMissing { .. } => "chip-missing",
            Hint::ChipBus { .. } => "chip-bus",
            Hint::WrongId { .. } => "wrong-id",
            Hint::CalibrationNotHeld { .. } => "calibration-not-held",
            Hint::ConfigurationMismatch { .. } => "configuration-mismatch",
            Hint::ChipResets { .. } => "chip-resets",
            Hint::Losses => "losses",
            Hint::RateOff => "rate-off",
            Hint::NoBattery { .. } => "no-battery",
            Hint::BusVoltagesDisagree => "bus-voltages-disagree",
            Hint::StandstillCurrent { .. } => "standstill-current",
            Hint::ConfigureFailed => "configure-failed",
            Hint::NotABoard => "not-a-board",
        }
    }
}

/// What a part's die ID says, for the wrong-ID hint.
fn known_die(manufacturer: u16, die: u16) -> &'static str {
    match (manufacturer, die) {
        (0x5449, 0x2270) => " (an INA260: it has its own shunt and fixed scaling)",
        (0xFFFF, 0xFFFF) | (0, 0) => " (nothing drives SDA: a device that is not a TI monitor?)",
        _ => "",
    }
}

impl fmt::Display for Hint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Hint::NoBoardFound => f.write_str(
                "no port with the board's USB ID 16c0:27dd and a rover-power serial number: plug \
                 the board in with a data cable (not a charge-only one), flash the firmware \
                 (docs/board.md, \"Flashing\"), list the ports with `host-tool ports`, or pass --port",
            ),
            Hint::SeveralBoards => f.write_str(
                "several rover-power boards are plugged in: pick one with --port (see `host-tool ports`)",
            ),
            Hint::PermissionDenied => write!(f, "you may not open the port: {PERMISSION_HINT}"),
            Hint::PortBusy => f.write_str(
                "another program holds the port (a `record` still running, a serial monitor, \
                 ModemManager probing new modems: the udev rule tells it to keep away)",
            ),
            Hint::NoSuchPort => f.write_str(
                "no such port: the board re-enumerated or was unplugged; list the ports with \
                 `host-tool ports` (or use /dev/rover-power from the udev rule)",
            ),
            Hint::OpenFailed => f.write_str(
                "the port did not open: re-plug the board and look at `dmesg` for USB errors (a \
                 charge-only or long cable, an under-powered hub)",
            ),
            Hint::NoDtr => f.write_str(
                "the port refused DTR, and the board sends only while the host holds DTR: this \
                 is not the board's own USB CDC port (a USB-UART adapter without modem lines, a \
                 pseudo-terminal?); connect the Black Pill's USB-C port directly",
            ),
            Hint::SilentPort => f.write_str(
                "nothing arrived after DTR. Look at the LED on PC13: dark = the firmware is not \
                 running (flash it; BOOT0 must be low); a slow 1 s blink = \
                 the board does not see DTR (a hub or program dropping it); quick flashes = a chip \
                 fault, but it should still send; a heartbeat = it sends, so this port is not it \
                 (see `host-tool ports`)",
            ),
            Hint::NotTheBoard => f.write_str(
                "bytes arrived but no frame of any rover-power protocol: another device is on \
                 this port (see `host-tool ports`)",
            ),
            Hint::ProtocolMismatch { board } => write!(
                f,
                "the board speaks protocol {board}, this host-tool {}: flash the firmware built \
                 from the same checkout (`cargo fw`, docs/board.md, \"Flashing\") or use the host-tool \
                 that matches the board",
                model_core::wire::PROTOCOL_VERSION
            ),
            Hint::ChipMissing { side, address } => write!(
                f,
                "the {side} INA226 does not acknowledge {address:#04x}: check its supply (VS to \
                 3V3, GND), SCL to PB8 and SDA to PB9, the pull-ups (2.2–4.7 kΩ to 3V3), and its \
                 address straps ({})",
                side.straps()
            ),
            Hint::ChipBus { side, fault } => write!(
                f,
                "the {side} chip's transfers fail ({fault:?}): a bus problem rather than a \
                 missing chip; check the pull-ups (2.2–4.7 kΩ, none is a hang), SDA and SCL not \
                 swapped or shorted, short wires away from the motor leads"
            ),
            Hint::WrongId {
                side,
                manufacturer,
                die,
            } => write!(
                f,
                "the {side} chip answers manufacturer/die ID {manufacturer:#06x}/{die:#06x}{}, \
                 not an INA226 (0x5449/0x2260): check the part (INA226AIDGSR) and that no other \
                 device shares the address ({})",
                known_die(*manufacturer, *die),
                side.straps()
            ),
            Hint::CalibrationNotHeld {
                side,
                read,
                expected,
            } => write!(
                f,
                "the {side} chip's CAL reads {read}, the board wrote {expected}: it reset since \
                 (a brown-out on VS: add 100 nF at the VS pin, power it from the Black Pill's \
                 3V3) or the write did not reach it"
            ),
            Hint::ConfigurationMismatch {
                side,
                read,
                expected,
            } => write!(
                f,
                "the {side} chip's configuration reads {read:#06x}, the board set {expected:#06x} \
                 (averaging and conversion times): it reset or missed the write; re-run the \
                 check, and if it stays, look at its supply and the bus"
            ),
            Hint::ChipResets { side, resets } => write!(
                f,
                "the {side} chip reset {resets} time(s) during the check: its supply browns out; \
                 100 nF at VS, VS from the Black Pill's 3V3 (not from the motor side), a solid \
                 ground between board and chip"
            ),
            Hint::Losses => f.write_str(
                "samples were lost or corrupted between board and host: plug the board into the \
                 computer directly (no passive hub), use a short shielded cable away from the \
                 motor leads, and close programs loading the host",
            ),
            Hint::RateOff => f.write_str(
                "the board samples off its configured period: it falls behind (a stuck I²C bus \
                 retried every period, see the chip steps) or its crystal is not the one the \
                 firmware was built for (25 MHz default, FW_FEATURES=hse-8mhz)",
            ),
            Hint::NoBattery { side } => write!(
                f,
                "the {side} chip reads no bus voltage: wire its VBUS pin to the battery side of \
                 the shunt and switch the battery (or a bench supply) on"
            ),
            Hint::BusVoltagesDisagree => f.write_str(
                "both chips measure the one battery but read different voltages: a loose or thin \
                 supply wire to one motor driver, or one VBUS pin wired after a fuse or switch",
            ),
            Hint::StandstillCurrent { side } => write!(
                f,
                "the {side} side draws current at standstill: stop the motors (drivers idle) and \
                 re-run; if it stays, it is an offset like the thesis' Fig. 3.3 (0.59 A on the \
                 Husky's built-in sensing): connect VIN+ and VIN− by separate Kelvin traces at \
                 the shunt's pads, VIN+ on the battery side"
            ),
            Hint::ConfigureFailed => f.write_str(
                "the board did not carry out Configure as sent: a chip refused the write (see \
                 the chip steps) or the firmware is older than this host-tool",
            ),
            Hint::NotABoard => f.write_str(
                "the stream has no chips to check: it does not answer GetHello with their \
                 registers (a replay, not a board, or a firmware older than this host-tool); run \
                 the check on the board's port",
            ),
        }
    }
}
