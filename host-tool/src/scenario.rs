//! Scenario TOML: what the rover is commanded to do.
//!
//! ```toml
//! repeats = 3        # the whole list, this many times (default 1)
//! pause_s = 2.0      # standstill between manoeuvres (default 2 s)
//! lead_in_s = 2.0    # standstill before the first manoeuvre (default 2 s)
//! lead_out_s = 2.0   # standstill after the last one (default 2 s)
//!
//! [[manoeuvres]]
//! kind = "turn"           # constant-v_c turn (Appendix A) until the true yaw has turned angle_deg
//! r_over_r_prime = 0.667  # or radius_m = 0.367; exactly one of the two
//! angle_deg = 90          # default 90
//! v_c_mps = 0.3           # default 0.3 (Eq 2.6)
//! direction = "left"      # default left
//!
//! [[manoeuvres]]
//! kind = "point-turn"     # side speeds ±side_speed_mps (default 0.3) through angle_deg (default 90)
//!
//! [[manoeuvres]]
//! kind = "straight"       # distance_m (required) at speed_mps (default 0.3)
//! distance_m = 2.0
//!
//! [[manoeuvres]]
//! kind = "pause"          # standstill for duration_s (required)
//! duration_s = 5.0
//!
//! [[manoeuvres]]
//! kind = "clc"            # paper Fig. 5: arc, line, arc between two poses (model_core::paths)
//! start_heading_deg = 45  # θ_A, θ_C both in (0, 90] or both in [−90, 0) (paper Eq 50)
//! end_heading_deg = 45
//! distance_m = 10.0
//! r_over_r_prime = 1.0    # or radius_m; both arcs use it (R1 = R2)
//! v_c_mps = 0.3
//!
//! [[manoeuvres]]
//! kind = "plp"            # the same ends with point turns (paper Fig. 2)
//! start_heading_deg = 45
//! end_heading_deg = 45
//! distance_m = 10.0
//! ```
//!
//! R' is the rover's (its controller slip track B_s / 2, Eq 2.5). Unknown keys are errors.
//!
//! Neutral ground between the simulator, which runs a scenario (`crate::sim::world` re-exports
//! this module), and the diagnosis, whose what-to-drive-next writes one: nothing here imports
//! `crate::sim`.

use crate::rover::decimal_f64;
use crate::toml_syntax::TomlSyntaxError;
use model_core::kinematics::{side_speeds_for, TurnDirection};
use model_core::paths::{ClcEnds, ClcPath};
use model_core::Rover;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Why a world or scenario could not be read or simulated (here because reading a scenario
/// returns it; `crate::sim::world::WorldError` is this type).
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Not valid TOML, an unknown key or a value of the wrong type (the message names the key
    /// and, where TOML knows it, the line).
    #[error("{origin}: {source}")]
    Toml {
        /// The file (or "world"/"scenario" for text).
        origin: String,
        /// The parser's error.
        #[source]
        source: TomlSyntaxError,
    },
    /// A value outside its domain.
    #[error("{origin}: `{key}` {reason}")]
    Invalid {
        /// The file (or "world"/"scenario" for text).
        origin: String,
        /// The key, dotted (`inner-drag.torque_nm`, `manoeuvres[2].angle_deg`).
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// The world's `rover` file.
    #[error("{origin}: `rover`: {source}")]
    Rover {
        /// The world file.
        origin: String,
        /// The rover file's error.
        #[source]
        source: crate::rover::RoverFileError,
    },
    /// A manoeuvre that does not finish (e.g. the rover cannot turn).
    #[error("manoeuvre `{label}` did not finish within {limit_s:.0} s")]
    Stalled {
        /// The manoeuvre.
        label: String,
        /// The time limit [s].
        limit_s: f64,
    },
}

/// A list of manoeuvres, repeated, with standstill pauses between them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// How many times the list runs (≥ 1).
    #[serde(default = "one")]
    pub repeats: u32,
    /// Standstill between manoeuvres [s].
    #[serde(default = "two_seconds")]
    pub pause_s: f64,
    /// Standstill before the first manoeuvre [s].
    #[serde(default = "two_seconds")]
    pub lead_in_s: f64,
    /// Standstill after the last manoeuvre [s].
    #[serde(default = "two_seconds")]
    pub lead_out_s: f64,
    /// The manoeuvres, in order.
    pub manoeuvres: Vec<Manoeuvre>,
}

fn one() -> u32 {
    1
}
fn two_seconds() -> f64 {
    2.0
}
fn ninety() -> f64 {
    90.0
}
fn v_c() -> f64 {
    0.3
}
fn left() -> Side {
    Side::Left
}

/// Side of a turn in scenario files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Side {
    /// Counter-clockwise.
    Left,
    /// Clockwise.
    Right,
}

impl From<Side> for TurnDirection {
    fn from(s: Side) -> Self {
        match s {
            Side::Left => TurnDirection::Left,
            Side::Right => TurnDirection::Right,
        }
    }
}

/// A radius given absolutely or as a multiple of R'.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadiusSpec {
    /// R [m].
    pub radius_m: Option<f64>,
    /// R / R' (R' = the rover's B_s / 2).
    pub r_over_r_prime: Option<f64>,
}

/// One entry of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Manoeuvre {
    /// A constant-v_c turn of radius R (Appendix A), held until the true yaw has changed by
    /// `angle_deg`.
    Turn {
        /// R [m] (exactly one of this and `r_over_r_prime`).
        radius_m: Option<f64>,
        /// R / R'.
        r_over_r_prime: Option<f64>,
        /// Turn angle [deg] (default 90).
        #[serde(default = "ninety")]
        angle_deg: f64,
        /// v_c, Eq 2.6 [m/s] (default 0.3).
        #[serde(default = "v_c")]
        v_c_mps: f64,
        /// Side (default left).
        #[serde(default = "left")]
        direction: Side,
    },
    /// A point turn at ±`side_speed_mps` through `angle_deg`.
    PointTurn {
        /// Turn angle [deg] (default 90).
        #[serde(default = "ninety")]
        angle_deg: f64,
        /// Speed of each side [m/s] (default 0.3).
        #[serde(default = "v_c")]
        side_speed_mps: f64,
        /// Side (default left).
        #[serde(default = "left")]
        direction: Side,
    },
    /// A straight line forwards of `distance_m` (true distance) at `speed_mps`.
    Straight {
        /// Distance [m].
        distance_m: f64,
        /// Speed of both sides [m/s] (default 0.3).
        #[serde(default = "v_c")]
        speed_mps: f64,
    },
    /// Standstill.
    Pause {
        /// Duration [s].
        duration_s: f64,
    },
    /// A CLC path (paper Fig. 5, Eq 47–50) with R1 = R2 = the given radius.
    Clc {
        /// θ_A [deg].
        start_heading_deg: f64,
        /// θ_C [deg].
        end_heading_deg: f64,
        /// |AC| [m].
        distance_m: f64,
        /// R1 = R2 [m] (exactly one of this and `r_over_r_prime`).
        radius_m: Option<f64>,
        /// R1 / R' = R2 / R'.
        r_over_r_prime: Option<f64>,
        /// v_c [m/s] (default 0.3); also the line's speed.
        #[serde(default = "v_c")]
        v_c_mps: f64,
    },
    /// The PLP path with the same ends (paper Fig. 2).
    Plp {
        /// θ_A [deg].
        start_heading_deg: f64,
        /// θ_C [deg].
        end_heading_deg: f64,
        /// |AC| [m].
        distance_m: f64,
        /// v_c [m/s] (default 0.3); also the line's speed.
        #[serde(default = "v_c")]
        v_c_mps: f64,
    },
}

/// The kind of a scenario entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ManoeuvreKind {
    /// A constant-v_c turn.
    Turn,
    /// A point turn.
    PointTurn,
    /// A straight line.
    Straight,
    /// Standstill.
    Pause,
    /// A piece of a CLC path.
    Clc,
    /// A piece of a PLP path.
    Plp,
}

impl Manoeuvre {
    /// Its kind.
    pub fn kind(&self) -> ManoeuvreKind {
        match self {
            Manoeuvre::Turn { .. } => ManoeuvreKind::Turn,
            Manoeuvre::PointTurn { .. } => ManoeuvreKind::PointTurn,
            Manoeuvre::Straight { .. } => ManoeuvreKind::Straight,
            Manoeuvre::Pause { .. } => ManoeuvreKind::Pause,
            Manoeuvre::Clc { .. } => ManoeuvreKind::Clc,
            Manoeuvre::Plp { .. } => ManoeuvreKind::Plp,
        }
    }
}

/// What ends a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Until {
    /// The true yaw has changed by this much [rad].
    Yaw(f64),
    /// The true distance driven reaches this [m].
    Distance(f64),
    /// This long [s].
    Time(f64),
}

/// One constant-command piece of a scenario, after expansion.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Segment {
    /// The kind of the scenario entry it comes from (Pause for the automatic pauses).
    pub kind: ManoeuvreKind,
    /// Commanded side speeds [m/s].
    pub cmd_mps: model_core::Sides<f64>,
    /// Side of the turn (None for straight lines and standstill).
    pub direction: Option<TurnDirection>,
    /// Commanded radius [m] (INFINITY straight, None standstill).
    pub radius_m: Option<f64>,
    /// When it ends.
    pub until: Until,
    /// Index of the manoeuvre in the scenario; None for the automatic pauses.
    pub scenario_index: Option<usize>,
    /// Repeat (0-based).
    pub repeat: u32,
    /// Part of an expanded path (0 for single manoeuvres).
    pub part: usize,
    /// Human-readable label.
    pub label: String,
}

fn key_err(origin: &str, key: String, reason: impl Into<String>) -> WorldError {
    WorldError::Invalid {
        origin: origin.to_string(),
        key,
        reason: reason.into(),
    }
}

fn positive(origin: &str, key: String, x: f64) -> Result<f64, WorldError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(key_err(
            origin,
            key,
            format!("= {x} must be finite and > 0"),
        ))
    }
}

fn radius(
    origin: &str,
    prefix: &str,
    radius_m: Option<f64>,
    ratio: Option<f64>,
    r_prime_m: f64,
) -> Result<f64, WorldError> {
    let r = match (radius_m, ratio) {
        (Some(r), None) => (r, "radius_m"),
        (None, Some(k)) => (k * r_prime_m, "r_over_r_prime"),
        _ => {
            return Err(key_err(
                origin,
                format!("{prefix}radius_m"),
                "give exactly one of radius_m and r_over_r_prime",
            ))
        }
    };
    if r.0.is_nan() || r.0 < 0.0 {
        return Err(key_err(
            origin,
            format!("{prefix}{}", r.1),
            format!("= {} must be ≥ 0 (inf for straight)", r.0),
        ));
    }
    Ok(r.0)
}

fn turn_segment(
    v_c_mps: f64,
    radius_m: f64,
    angle_rad: f64,
    direction: TurnDirection,
    r_prime_m: f64,
) -> (model_core::Sides<f64>, Until) {
    let s = side_speeds_for(v_c_mps as f32, radius_m as f32, r_prime_m as f32, direction);
    let cmd = model_core::Sides::new(decimal_f64(s.left_mps), decimal_f64(s.right_mps));
    (cmd, Until::Yaw(angle_rad))
}

impl Scenario {
    /// Checks every value and expands the manoeuvres (paths into arcs and lines) into
    /// constant-command segments with the pauses in between, for `rover`.
    pub(crate) fn segments(&self, rover: &Rover, origin: &str) -> Result<Vec<Segment>, WorldError> {
        self.check_timing(origin)?;
        let r_prime = f64::from(rover.r_prime_m());
        let mut body: Vec<Segment> = Vec::new();
        for (i, m) in self.manoeuvres.iter().enumerate() {
            let kind = m.kind();
            for (part, cmd, direction, radius_m, until, label) in m.pieces(i, origin, r_prime)? {
                body.push(Segment {
                    kind,
                    cmd_mps: cmd,
                    direction,
                    radius_m,
                    until,
                    scenario_index: Some(i),
                    repeat: 0,
                    part,
                    label,
                });
            }
        }
        Ok(self.repeat_with_pauses(&body))
    }

    /// The repeat count, the pauses and the manoeuvre list.
    fn check_timing(&self, origin: &str) -> Result<(), WorldError> {
        if self.repeats == 0 {
            return Err(key_err(origin, "repeats".into(), "must be ≥ 1"));
        }
        for (key, v) in [
            ("pause_s", self.pause_s),
            ("lead_in_s", self.lead_in_s),
            ("lead_out_s", self.lead_out_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(key_err(origin, key.into(), format!("= {v} must be ≥ 0")));
            }
        }
        if self.manoeuvres.is_empty() {
            return Err(key_err(origin, "manoeuvres".into(), "is empty"));
        }
        Ok(())
    }

    /// The manoeuvres' segments `repeats` times, a pause between manoeuvres (not between the
    /// parts of one path), with the lead-in and lead-out.
    fn repeat_with_pauses(&self, body: &[Segment]) -> Vec<Segment> {
        let pause = |t: f64, label: &str, repeat: u32| Segment {
            kind: ManoeuvreKind::Pause,
            cmd_mps: model_core::Sides::new(0.0, 0.0),
            direction: None,
            radius_m: None,
            until: Until::Time(t),
            scenario_index: None,
            repeat,
            part: 0,
            label: label.to_string(),
        };
        let mut out = Vec::new();
        if self.lead_in_s > 0.0 {
            out.push(pause(self.lead_in_s, "lead-in", 0));
        }
        for repeat in 0..self.repeats {
            for (k, seg) in body.iter().enumerate() {
                // Parts of one path follow each other without a stop.
                let continues_path =
                    k > 0 && seg.part > 0 && body[k - 1].scenario_index == seg.scenario_index;
                let first = repeat == 0 && k == 0;
                if !first && !continues_path && self.pause_s > 0.0 {
                    out.push(pause(self.pause_s, "pause", repeat));
                }
                let mut s = seg.clone();
                s.repeat = repeat;
                out.push(s);
            }
        }
        if self.lead_out_s > 0.0 {
            out.push(pause(self.lead_out_s, "lead-out", self.repeats - 1));
        }
        out
    }
}

/// A manoeuvre of one constant command.
fn single(
    cmd: model_core::Sides<f64>,
    direction: Option<TurnDirection>,
    radius_m: Option<f64>,
    until: Until,
    label: String,
) -> Vec<PathPiece> {
    vec![(0, cmd, direction, radius_m, until, label)]
}

/// A CLC/PLP path's end conditions, checked.
fn path_ends(
    origin: &str,
    at: &dyn Fn(&str) -> String,
    start_heading_deg: f64,
    end_heading_deg: f64,
    distance_m: f64,
) -> Result<ClcEnds, WorldError> {
    ClcEnds::new(
        start_heading_deg.to_radians(),
        end_heading_deg.to_radians(),
        distance_m,
    )
    .map_err(|e| key_err(origin, at("start_heading_deg"), e.to_string()))
}

impl Manoeuvre {
    /// This manoeuvre's constant-command pieces (one, or a path's arcs and line), its values
    /// checked; `i` is its index in the scenario (for the error keys).
    fn pieces(&self, i: usize, origin: &str, r_prime: f64) -> Result<Vec<PathPiece>, WorldError> {
        let at = |k: &str| format!("manoeuvres[{i}].{k}");
        Ok(match *self {
            Manoeuvre::Turn {
                radius_m,
                r_over_r_prime,
                angle_deg,
                v_c_mps,
                direction,
            } => {
                let r = radius(origin, &at(""), radius_m, r_over_r_prime, r_prime)?;
                let angle = positive(origin, at("angle_deg"), angle_deg)?.to_radians();
                let v = positive(origin, at("v_c_mps"), v_c_mps)?;
                let dir: TurnDirection = direction.into();
                if r.is_infinite() {
                    return Err(key_err(
                        origin,
                        at("radius_m"),
                        "an infinite radius never turns; use kind = \"straight\"",
                    ));
                }
                let (cmd, until) = turn_segment(v, r, angle, dir, r_prime);
                let label = format!(
                    "turn R={r:.3} m ({:.3} R') {angle_deg}° {direction:?}",
                    r / r_prime
                );
                single(cmd, Some(dir), Some(r), until, label)
            }
            Manoeuvre::PointTurn {
                angle_deg,
                side_speed_mps,
                direction,
            } => {
                let angle = positive(origin, at("angle_deg"), angle_deg)?.to_radians();
                let v = positive(origin, at("side_speed_mps"), side_speed_mps)?;
                let dir: TurnDirection = direction.into();
                let (cmd, until) = turn_segment(v, 0.0, angle, dir, r_prime);
                let label = format!("point turn {angle_deg}° {direction:?}");
                single(cmd, Some(dir), Some(0.0), until, label)
            }
            Manoeuvre::Straight {
                distance_m,
                speed_mps,
            } => {
                let d = positive(origin, at("distance_m"), distance_m)?;
                let v = positive(origin, at("speed_mps"), speed_mps)?;
                let cmd = model_core::Sides::new(v, v);
                let label = format!("straight {d} m");
                single(cmd, None, Some(f64::INFINITY), Until::Distance(d), label)
            }
            Manoeuvre::Pause { duration_s } => {
                let t = positive(origin, at("duration_s"), duration_s)?;
                let cmd = model_core::Sides::new(0.0, 0.0);
                single(cmd, None, None, Until::Time(t), format!("pause {t} s"))
            }
            Manoeuvre::Clc {
                start_heading_deg,
                end_heading_deg,
                distance_m,
                radius_m,
                r_over_r_prime,
                v_c_mps,
            } => {
                let r = radius(origin, &at(""), radius_m, r_over_r_prime, r_prime)?;
                let v = positive(origin, at("v_c_mps"), v_c_mps)?;
                let ends = path_ends(origin, &at, start_heading_deg, end_heading_deg, distance_m)?;
                let path = ClcPath::new(&ends, r, r)
                    .map_err(|e| key_err(origin, at("radius_m"), e.to_string()))?;
                path_segments(&ends, &path, v, r_prime, "clc")
            }
            Manoeuvre::Plp {
                start_heading_deg,
                end_heading_deg,
                distance_m,
                v_c_mps,
            } => {
                let v = positive(origin, at("v_c_mps"), v_c_mps)?;
                let ends = path_ends(origin, &at, start_heading_deg, end_heading_deg, distance_m)?;
                path_segments(&ends, &ClcPath::plp(&ends), v, r_prime, "plp")
            }
        })
    }
}

type PathPiece = (
    usize,
    model_core::Sides<f64>,
    Option<TurnDirection>,
    Option<f64>,
    Until,
    String,
);

/// Arc, line, arc of a CLC/PLP path: the first arc turns with the sign k (paper Eq 49,
/// clockwise for θ_A > 0), the second the other way; zero-length pieces are dropped.
fn path_segments(
    ends: &ClcEnds,
    path: &ClcPath,
    v_c_mps: f64,
    r_prime_m: f64,
    kind: &str,
) -> Vec<PathPiece> {
    let first_dir = if ends.turn_sign() > 0.0 {
        TurnDirection::Left
    } else {
        TurnDirection::Right
    };
    let second_dir = match first_dir {
        TurnDirection::Left => TurnDirection::Right,
        TurnDirection::Right => TurnDirection::Left,
    };
    let mut out = Vec::new();
    let mut part = 0;
    for (r, angle, dir, name) in [
        (path.r1_m, path.first_turn_rad, first_dir, "first arc"),
        (f64::INFINITY, 0.0, first_dir, "line"),
        (path.r2_m, path.second_turn_rad, second_dir, "second arc"),
    ] {
        if r.is_infinite() {
            if path.line_length_m > 1e-9 {
                out.push((
                    part,
                    model_core::Sides::new(v_c_mps, v_c_mps),
                    None,
                    Some(f64::INFINITY),
                    Until::Distance(path.line_length_m),
                    format!("{kind} line {:.3} m", path.line_length_m),
                ));
                part += 1;
            }
        } else if angle > 1e-9 {
            let (cmd, until) = turn_segment(v_c_mps, r, angle, dir, r_prime_m);
            out.push((
                part,
                cmd,
                Some(dir),
                Some(r),
                until,
                format!("{kind} {name} R={r:.3} m {:.1}°", angle.to_degrees()),
            ));
            part += 1;
        }
    }
    out
}

/// Scenario from TOML text; `origin` names it in errors.
pub(crate) fn parse_scenario_at(text: &str, origin: &str) -> Result<Scenario, WorldError> {
    toml::from_str(text).map_err(|e| WorldError::Toml {
        origin: origin.to_string(),
        source: TomlSyntaxError::new(text, &e),
    })
}

/// Scenario from TOML text (checked when simulated).
pub fn parse_scenario(text: &str) -> Result<Scenario, WorldError> {
    let s = parse_scenario_at(text, "scenario")?;
    s.segments(&Rover::HUSKY_A200, "scenario")?;
    Ok(s)
}

/// Scenario from a TOML file.
pub fn load_scenario(path: &Path) -> Result<Scenario, WorldError> {
    let text = std::fs::read_to_string(path).map_err(|source| WorldError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let origin = path.display().to_string();
    let s = parse_scenario_at(&text, &origin)?;
    s.segments(&Rover::HUSKY_A200, &origin)?;
    Ok(s)
}

impl Scenario {
    /// The seed's sandbox turn set (Section 4.4, Fig 4.8–4.9): 90° left turns at R = 0, R'/3,
    /// 2R'/3, R', 4R'/3, 2R' and a straight line (1 m), at v_c, `repeats` times.
    pub fn seed_turns(v_c_mps: f64, repeats: u32) -> Scenario {
        let mut manoeuvres: Vec<Manoeuvre> = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 4.0 / 3.0, 2.0]
            .into_iter()
            .map(|k| Manoeuvre::Turn {
                radius_m: None,
                r_over_r_prime: Some(k),
                angle_deg: 90.0,
                v_c_mps,
                direction: Side::Left,
            })
            .collect();
        manoeuvres.push(Manoeuvre::Straight {
            distance_m: 1.0,
            speed_mps: v_c_mps,
        });
        Scenario::with_default_pauses(manoeuvres, repeats)
    }

    /// `manoeuvres` run `repeats` times with the TOML defaults' standstills (2 s lead-in,
    /// pauses and lead-out).
    pub fn with_default_pauses(manoeuvres: Vec<Manoeuvre>, repeats: u32) -> Scenario {
        Scenario {
            repeats,
            pause_s: two_seconds(),
            lead_in_s: two_seconds(),
            lead_out_s: two_seconds(),
            manoeuvres,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_with_defaults_and_rejects_unknown_keys() {
        let s = parse_scenario(
            "repeats = 2\n[[manoeuvres]]\nkind = \"turn\"\nr_over_r_prime = 1.0\n\
             [[manoeuvres]]\nkind = \"straight\"\ndistance_m = 1.5\n",
        )
        .expect("valid");
        assert_eq!(s.repeats, 2);
        assert_eq!(s.pause_s, 2.0);
        assert!(matches!(
            s.manoeuvres[0],
            Manoeuvre::Turn { angle_deg, v_c_mps, direction: Side::Left, .. }
                if angle_deg == 90.0 && v_c_mps == 0.3
        ));
        let e =
            parse_scenario("[[manoeuvres]]\nkind = \"turn\"\nr_over_r_prime = 1.0\nradius = 2\n")
                .expect_err("unknown key");
        assert!(e.to_string().contains("radius"), "{e}");
        let e = parse_scenario("[[manoeuvres]]\nkind = \"turn\"\n").expect_err("no radius");
        assert!(e.to_string().contains("manoeuvres[0].radius_m"), "{e}");
        let e = parse_scenario("[[manoeuvres]]\nkind = \"hop\"\n").expect_err("unknown kind");
        assert!(e.to_string().contains("hop"), "{e}");
        let e = parse_scenario("pause_s = -1\n[[manoeuvres]]\nkind = \"pause\"\nduration_s = 1\n")
            .expect_err("negative pause");
        assert!(e.to_string().contains("pause_s"), "{e}");
    }

    #[test]
    fn expansion_puts_pauses_between_manoeuvres_and_keeps_paths_whole() {
        let s = parse_scenario(
            "repeats = 2\n[[manoeuvres]]\nkind = \"clc\"\nstart_heading_deg = 45\n\
             end_heading_deg = 45\ndistance_m = 10\nr_over_r_prime = 1\n\
             [[manoeuvres]]\nkind = \"point-turn\"\n",
        )
        .expect("valid");
        let segs = s.segments(&Rover::HUSKY_A200, "t").expect("expands");
        let labels: Vec<&str> = segs.iter().map(|s| s.label.as_str()).collect();
        // lead-in, arc, line, arc, pause, point turn, pause, arc, line, arc, pause, point, lead-out
        assert_eq!(segs.len(), 13, "{labels:?}");
        assert_eq!(
            segs[1].direction,
            Some(TurnDirection::Right),
            "clockwise first"
        );
        assert_eq!(segs[3].direction, Some(TurnDirection::Left));
        assert!(matches!(segs[2].until, Until::Distance(d) if d > 8.0 && d < 10.0));
        assert_eq!(segs[7].repeat, 1);
        // PLP: point turns of 45° and the full line.
        let plp = parse_scenario(
            "[[manoeuvres]]\nkind = \"plp\"\nstart_heading_deg = 45\nend_heading_deg = 45\ndistance_m = 10\n",
        )
        .expect("valid")
        .segments(&Rover::HUSKY_A200, "t")
        .expect("expands");
        assert!(matches!(plp[2].until, Until::Distance(d) if (d - 10.0).abs() < 1e-12));
        assert!(matches!(plp[1].until, Until::Yaw(a) if (a - 45f64.to_radians()).abs() < 1e-12));
    }
}
