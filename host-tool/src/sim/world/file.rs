//! The world TOML (`worlds/*.toml`): every key optional over the ground's defaults, effect
//! tables whose `enabled` default depends on the ground, a `rover` path relative to the file;
//! [`parse_world`], [`load_world`] and [`WorldConfig`]'s `Deserialize`.

use super::{
    Battery, Driver, EffectId, Ground, IcrParams, Motor, Noise, Structure, Tracker, WorldConfig,
    WorldError,
};
use crate::toml_syntax::TomlSyntaxError;
use model_core::Rover;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The world TOML as written: every key optional; effect tables read by hand so their
/// `enabled` default can depend on `ground`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WorldToml {
    #[serde(default)]
    ground: Ground,
    rover: Option<PathBuf>,
    icr: Option<IcrToml>,
    #[serde(default)]
    battery: Battery,
    #[serde(default)]
    driver: Driver,
    #[serde(default)]
    motor: Motor,
    #[serde(default)]
    structure: Structure,
    #[serde(default)]
    noise: Noise,
    #[serde(default)]
    tracker: Tracker,
    #[serde(rename = "inner-drag")]
    inner_drag: Option<toml::Table>,
    #[serde(rename = "sinkage-bulldozing")]
    sinkage_bulldozing: Option<toml::Table>,
    #[serde(rename = "angular-slip")]
    angular_slip: Option<toml::Table>,
    #[serde(rename = "slip-track")]
    slip_track: Option<toml::Table>,
    #[serde(rename = "braked-inner")]
    braked_inner: Option<toml::Table>,
    #[serde(rename = "current-offset")]
    current_offset: Option<toml::Table>,
    #[serde(rename = "motor-heating")]
    motor_heating: Option<toml::Table>,
    slope: Option<toml::Table>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct IcrToml {
    mu: Option<f64>,
    rolling_resistance_n: Option<f64>,
    slip_track_m: Option<f64>,
    traction_fade_radius_m: Option<f64>,
}

/// Reads one effect table: `enabled` (None if absent) and the parameters, each defaulting to
/// the ground's (`ground_default`).
fn effect_table<T: serde::de::DeserializeOwned + Serialize + Copy>(
    origin: &str,
    id: EffectId,
    table: Option<toml::Table>,
    ground_default: T,
) -> Result<(Option<bool>, T), WorldError> {
    let Some(mut table) = table else {
        return Ok((None, ground_default));
    };
    let enabled = match table.remove("enabled") {
        None => None,
        Some(toml::Value::Boolean(b)) => Some(b),
        Some(other) => {
            return Err(WorldError::Invalid {
                origin: origin.to_string(),
                key: format!("{id}.enabled"),
                reason: format!(
                    "must be true or false, found {}",
                    crate::toml_syntax::found(&other)
                ),
            })
        }
    };
    // The ground's values under the file's: a key the file leaves out keeps the ground's.
    let mut merged = toml::Table::try_from(ground_default).unwrap_or_default();
    merged.extend(table);
    let params = T::deserialize(toml::Value::Table(merged)).map_err(|e| WorldError::Invalid {
        origin: origin.to_string(),
        key: id.id().to_string(),
        reason: e.message().to_string(),
    })?;
    Ok((enabled, params))
}

fn parse_world_at(
    text: &str,
    origin: &str,
    base: Option<&Path>,
) -> Result<WorldConfig, WorldError> {
    let raw: WorldToml = toml::from_str(text).map_err(|e| WorldError::Toml {
        origin: origin.to_string(),
        source: TomlSyntaxError::new(text, &e),
    })?;
    resolve(raw, origin, base)
}

/// The world file's rover file (a relative path taken from `base`).
fn load_rover_at(path: PathBuf, origin: &str, base: Option<&Path>) -> Result<Rover, WorldError> {
    let path = match base {
        Some(dir) if path.is_relative() => dir.join(path),
        _ => path,
    };
    crate::rover::load_rover(&path).map_err(|source| WorldError::Rover {
        origin: origin.to_string(),
        source,
    })
}

impl IcrToml {
    /// The file's ICR values over `d`, the ground's.
    fn over(self, d: IcrParams) -> IcrParams {
        IcrParams {
            mu: self.mu.unwrap_or(d.mu),
            rolling_resistance_n: self.rolling_resistance_n.unwrap_or(d.rolling_resistance_n),
            slip_track_m: self.slip_track_m.unwrap_or(d.slip_track_m),
            traction_fade_radius_m: self
                .traction_fade_radius_m
                .unwrap_or(d.traction_fade_radius_m),
        }
    }
}

/// Applies what a world file says over the defaults of its ground.
fn resolve(raw: WorldToml, origin: &str, base: Option<&Path>) -> Result<WorldConfig, WorldError> {
    let mut world = WorldConfig::for_ground(raw.ground);
    if let Some(path) = raw.rover {
        world.rover = load_rover_at(path, origin, base)?;
    }
    if let Some(icr) = raw.icr {
        world.icr = icr.over(world.icr);
    }
    world.battery = raw.battery;
    world.driver = raw.driver;
    world.motor = raw.motor;
    world.structure = raw.structure;
    world.noise = raw.noise;
    let ground = world.effects;
    world.tracker = raw.tracker;
    let e = &mut world.effects;
    let mut set = |id: EffectId, on: Option<bool>| {
        if let Some(on) = on {
            e.enabled[id as usize] = on;
        }
    };
    let (on, p) = effect_table(
        origin,
        EffectId::InnerDrag,
        raw.inner_drag,
        ground.inner_drag,
    )?;
    set(EffectId::InnerDrag, on);
    let inner_drag = p;
    let (on, p) = effect_table(
        origin,
        EffectId::SinkageBulldozing,
        raw.sinkage_bulldozing,
        ground.sinkage_bulldozing,
    )?;
    set(EffectId::SinkageBulldozing, on);
    let sinkage_bulldozing = p;
    let (on, p) = effect_table(
        origin,
        EffectId::AngularSlip,
        raw.angular_slip,
        ground.angular_slip,
    )?;
    set(EffectId::AngularSlip, on);
    let angular_slip = p;
    let (on, p) = effect_table(
        origin,
        EffectId::SlipTrack,
        raw.slip_track,
        ground.slip_track,
    )?;
    set(EffectId::SlipTrack, on);
    let slip_track = p;
    let (on, p) = effect_table(
        origin,
        EffectId::BrakedInner,
        raw.braked_inner,
        ground.braked_inner,
    )?;
    set(EffectId::BrakedInner, on);
    let braked_inner = p;
    let (on, p) = effect_table(
        origin,
        EffectId::CurrentOffset,
        raw.current_offset,
        ground.current_offset,
    )?;
    set(EffectId::CurrentOffset, on);
    let current_offset = p;
    let (on, p) = effect_table(
        origin,
        EffectId::MotorHeating,
        raw.motor_heating,
        ground.motor_heating,
    )?;
    set(EffectId::MotorHeating, on);
    let motor_heating = p;
    let (on, p) = effect_table(origin, EffectId::Slope, raw.slope, ground.slope)?;
    set(EffectId::Slope, on);
    let slope = p;
    e.inner_drag = inner_drag;
    e.sinkage_bulldozing = sinkage_bulldozing;
    e.angular_slip = angular_slip;
    e.slip_track = slip_track;
    e.braked_inner = braked_inner;
    e.current_offset = current_offset;
    e.motor_heating = motor_heating;
    e.slope = slope;
    world.validate(origin)?;
    Ok(world)
}

/// World from TOML text (a `rover` path is taken relative to the working directory).
pub fn parse_world(text: &str) -> Result<WorldConfig, WorldError> {
    parse_world_at(text, "world", None)
}

/// World from a TOML file (a `rover` path is taken relative to the file's directory).
pub fn load_world(path: &Path) -> Result<WorldConfig, WorldError> {
    let text = std::fs::read_to_string(path).map_err(|source| WorldError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    parse_world_at(&text, &path.display().to_string(), path.parent())
}

impl<'de> Deserialize<'de> for WorldConfig {
    /// The world TOML (see [`WorldConfig`]); a `rover` path is relative to the working
    /// directory.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let raw = WorldToml::deserialize(deserializer)?;
        resolve(raw, "world", None).map_err(serde::de::Error::custom)
    }
}
