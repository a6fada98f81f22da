//! Which readings a run CSV may hold: [`RigRange`]. By default any physical reading (a run
//! CSV comes from any rig: an Argo J5 draws more than this board measures, a rig with a 50 A
//! Hall sensor reads it); the user can hold the files to the board's range or to a range of
//! their own, and `replay` and `convert` to MCAP hold them to the board's because they turn
//! the samples into the board's registers. The board's own logs (MCAP, the wire) keep the
//! board's range: their samples come from its registers.

use super::Column;
use model_core::ina226::{Scale, BUS_LSB_UV};
use std::fmt;

/// Highest bus voltage the INA226 reads: its bus input's full scale, 32 768 × 1.25 mV [V].
pub const BUS_V_MAX: f64 = 32_768.0 * BUS_LSB_UV as f64 / 1e6;
/// Largest current the board measures: the INA226's full scale at its calibration (5 mΩ shunt,
/// 0.5 mA current LSB), 32 768 × 0.5 mA [A].
pub const CURRENT_A_MAX: f64 = 32_768.0 * Scale::BOARD.current_lsb_na as f64 / 1e9;

/// Highest bus voltage a run CSV holds by default [V]: above any rover's battery (the Husky's
/// 24 V, an Argo's 48 V, an electric car's 800 V traction bus), below the same rover's bus
/// written in millivolts (24 V is 24 000), the unit slip it catches.
pub const PHYSICAL_BUS_V_MAX: f64 = 1000.0;
/// Largest current a run CSV holds by default [A]: well above any rover's drive current (the
/// Husky's few amperes, the Argo J5's ≈ 20, a 50 A Hall sensor's full scale), below a few
/// amperes written in milliamperes (3.5 A is 3 500), the unit slip it catches.
pub const PHYSICAL_CURRENT_A_MAX: f64 = 1000.0;

/// The readings a run CSV's bus voltage and current cells may hold: bus voltage from 0 to a
/// maximum, current within ± a maximum (every cell also finite). A reading beyond is an error
/// naming the range and how to change it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum RigRange {
    /// Any physical reading (the default): bus 0 to [`PHYSICAL_BUS_V_MAX`], current
    /// ±[`PHYSICAL_CURRENT_A_MAX`]. Beyond is a unit or scale error, whatever the rig.
    #[default]
    Physical,
    /// This board's (`--rig-range board`): the INA226's bus input and full scale at the
    /// board's calibration, [`BUS_V_MAX`] and ±[`CURRENT_A_MAX`].
    Board,
    /// A rig's range as the user states it (`--rig-range BUS_V,CURRENT_A`).
    Stated {
        /// Highest bus voltage [V].
        bus_v_max: f64,
        /// Largest current magnitude [A].
        current_a_max: f64,
    },
    /// The board's range because the samples become the board's registers (`replay`,
    /// `convert` to MCAP), whatever rig measured them.
    BoardStream,
}

impl RigRange {
    /// Highest bus voltage [V] and largest current magnitude [A].
    pub fn limits(self) -> (f64, f64) {
        match self {
            RigRange::Physical => (PHYSICAL_BUS_V_MAX, PHYSICAL_CURRENT_A_MAX),
            RigRange::Board | RigRange::BoardStream => (BUS_V_MAX, CURRENT_A_MAX),
            RigRange::Stated {
                bus_v_max,
                current_a_max,
            } => (bus_v_max, current_a_max),
        }
    }

    /// The values `column` may hold (`None`: any finite number).
    pub fn bounds(self, column: Column) -> Option<(f64, f64)> {
        let (bus_v_max, current_a_max) = self.limits();
        match column {
            Column::LeftBusV | Column::RightBusV => Some((0.0, bus_v_max)),
            Column::LeftCurrentA | Column::RightCurrentA => Some((-current_a_max, current_a_max)),
            Column::TimeS
            | Column::CmdLeftMps
            | Column::CmdRightMps
            | Column::YawRad
            | Column::PitchDeg
            | Column::XM
            | Column::YM => None,
        }
    }

    /// Whether `value` is finite and within `column`'s bounds.
    pub fn admits(self, column: Column, value: f64) -> bool {
        value.is_finite()
            && self
                .bounds(column)
                .is_none_or(|(lo, hi)| value >= lo && value <= hi)
    }

    /// `--rig-range`'s value: `physical`, `board`, or `BUS_V,CURRENT_A` (each finite, > 0 and
    /// at most the physical bound).
    pub fn parse(text: &str) -> Result<RigRange, String> {
        match text.trim() {
            "physical" => return Ok(RigRange::Physical),
            "board" => return Ok(RigRange::Board),
            _ => {}
        }
        let numbers: Option<Vec<f64>> = text.split(',').map(|v| v.trim().parse().ok()).collect();
        let within = |v: f64, max: f64| v.is_finite() && v > 0.0 && v <= max;
        match numbers.as_deref() {
            Some(&[bus_v_max, current_a_max])
                if within(bus_v_max, PHYSICAL_BUS_V_MAX)
                    && within(current_a_max, PHYSICAL_CURRENT_A_MAX) =>
            {
                Ok(RigRange::Stated {
                    bus_v_max,
                    current_a_max,
                })
            }
            _ => Err(format!(
                "{text:?}: expected `physical`, `board`, or the rig's range as BUS_V,CURRENT_A \
                 (highest bus voltage, largest current magnitude; each > 0, at most \
                 {PHYSICAL_BUS_V_MAX} V and {PHYSICAL_CURRENT_A_MAX} A; e.g. 60,50)"
            )),
        }
    }
}

/// Why a reading is refused: the range, where it comes from and how to change it.
impl fmt::Display for RigRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (bus_v_max, current_a_max) = self.limits();
        let range = format!("bus 0 to {bus_v_max} V, current ±{current_a_max} A");
        match self {
            RigRange::Physical => write!(
                f,
                "any physical reading's range ({range}): a unit or scale error (mV or mA?)"
            ),
            RigRange::Board => write!(
                f,
                "the INA226 board's range ({range}), which --rig-range board holds the file to; \
                 for another rig's file leave the option out (any physical reading) or state \
                 that rig's range: --rig-range BUS_V,CURRENT_A"
            ),
            RigRange::Stated { .. } => write!(
                f,
                "the rig's range stated by --rig-range {bus_v_max},{current_a_max} ({range}); \
                 widen it, or leave the option out (any physical reading)"
            ),
            RigRange::BoardStream => write!(
                f,
                "the INA226 board's range ({range}): `replay` and `convert` to MCAP turn the \
                 samples into the board's registers, which cannot hold it (`validate`, `plot` \
                 and `diagnose` read the file as it is)"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_board_constants_are_the_ina226_full_scale() {
        assert_eq!((BUS_V_MAX, CURRENT_A_MAX), (40.96, 16.384));
    }

    #[test]
    fn option_values_parse_and_bad_ones_say_what_is_expected() {
        assert_eq!(RigRange::parse("physical"), Ok(RigRange::Physical));
        assert_eq!(RigRange::parse("board"), Ok(RigRange::Board));
        assert_eq!(
            RigRange::parse("60, 50"),
            Ok(RigRange::Stated {
                bus_v_max: 60.0,
                current_a_max: 50.0
            })
        );
        for bad in [
            "", "Board", "50", "60,50,1", "0,50", "60,-50", "60,inf", "2000,50", "a,b",
        ] {
            let e = RigRange::parse(bad).expect_err(bad);
            assert!(e.contains("BUS_V,CURRENT_A"), "{bad}: {e}");
        }
    }

    #[test]
    fn the_default_admits_other_rigs_readings_and_refuses_the_unphysical() {
        let range = RigRange::default();
        for (column, v) in [
            (Column::LeftCurrentA, 20.0),
            (Column::RightCurrentA, -50.0),
            (Column::LeftBusV, 48.0),
            (Column::TimeS, 1e300),
        ] {
            assert!(range.admits(column, v), "{column} = {v}");
        }
        for (column, v) in [
            (Column::LeftCurrentA, 3500.0),
            (Column::LeftBusV, -0.5),
            (Column::RightBusV, 24_000.0),
            (Column::CmdLeftMps, f64::NAN),
            (Column::RightCurrentA, f64::NEG_INFINITY),
        ] {
            assert!(!range.admits(column, v), "{column} = {v}");
        }
        assert!(!RigRange::Board.admits(Column::LeftCurrentA, 20.0));
        assert!(RigRange::Board.admits(Column::LeftCurrentA, -16.384));
    }
}
