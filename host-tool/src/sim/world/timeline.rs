//! A simulated run: the true electrical state every ~10 ms, queried at any time with the
//! measurement noise and sensor offsets added; the commands and tracker pose; the ground truth
//! per manoeuvre.

use super::effects::EffectId;
use super::scenario::ManoeuvreKind;
use super::{Noise, Tracker, WorldConfig};
use crate::log::commands::CommandRow;
use crate::sim::board::{LoadSource, SideLoad};
use model_core::kinematics::{Regime, TurnDirection};
use model_core::rng::{self, splitmix64};
use model_core::Sides;
use std::sync::Arc;

/// The true state at one instant (values between samples are interpolated linearly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    pub t_us: u64,
    /// Driver currents [A] (true, noise-free, without sensor offset).
    pub current_a: Sides<f64>,
    /// Battery bus voltage [V].
    pub bus_v: f64,
    /// True yaw [rad], counter-clockwise positive.
    pub yaw_rad: f64,
    /// True position of the rover's centre [m].
    pub position_m: (f64, f64),
    /// True pitch [deg].
    pub pitch_deg: f64,
}

/// Where a constant command starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SegmentSpan {
    pub start_us: u64,
    pub cmd_mps: Sides<f64>,
}

/// Ground truth of one manoeuvre (one piece of an expanded path), for checking a diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct ManoeuvreTruth {
    /// Human-readable description.
    pub label: String,
    /// The kind of the scenario entry.
    pub kind: ManoeuvreKind,
    /// Index of the entry in the scenario's list.
    pub scenario_index: usize,
    /// Repeat (0-based).
    pub repeat: u32,
    /// Piece of an expanded path (arc, line, arc: 0, 1, 2); 0 otherwise.
    pub part: usize,
    /// Start [µs].
    pub start_us: u64,
    /// End [µs].
    pub end_us: u64,
    /// Commanded side speeds [m/s].
    pub cmd_mps: Sides<f64>,
    /// Side of the turn (None for straight lines and pauses).
    pub direction: Option<TurnDirection>,
    /// Commanded radius [m]: 0 point turn, INFINITY straight, None pause.
    pub commanded_radius_m: Option<f64>,
    /// Regime of the commanded radius (`Regime::of` with the rover and default bounds).
    pub regime: Option<Regime>,
    /// How long it should have taken at the commanded yaw rate or speed [s].
    pub expected_duration_s: f64,
    /// Commanded yaw rate (controller slip track, Eq 2.2) [rad/s], counter-clockwise positive.
    pub commanded_yaw_rate_rad_s: f64,
    /// True yaw rate [rad/s].
    pub true_yaw_rate_rad_s: f64,
    /// True angular slip s_ω (Eq 6.3) for turns.
    pub angular_slip: Option<f64>,
    /// True turning radius [m] (INFINITY straight; None pause).
    pub true_radius_m: Option<f64>,
    /// True electrical energy drawn by each driver [J] (quiescent included).
    pub energy_j: Sides<f64>,
    /// True average electrical power of each driver [W] (quiescent included).
    pub avg_power_w: Sides<f64>,
    /// Mean true pitch [deg].
    pub mean_pitch_deg: f64,
    /// The factor on the terrain resistance (μ and G) in this manoeuvre: 1 unless `[noise]`
    /// has `manoeuvre_power_std` or `run_power_std`.
    pub resistance_scale: f64,
    /// Each enabled effect's contribution to the energy [J]: the integral of its electrical
    /// power for power terms; for `angular-slip` and `slip-track` the energy of the extra time
    /// they cause at the manoeuvre's average power; for `current-offset` what the sensors count
    /// in excess (offset × bus voltage × time).
    pub effect_energy_j: Vec<(EffectId, f64)>,
}

impl ManoeuvreTruth {
    /// Duration [s].
    pub fn duration_s(&self) -> f64 {
        (self.end_us - self.start_us) as f64 * 1e-6
    }

    /// Average electrical power of both drivers [W].
    pub fn avg_total_power_w(&self) -> f64 {
        self.avg_power_w.left + self.avg_power_w.right
    }

    /// The contribution of `id` [J] (None when the effect is off).
    pub fn effect_energy(&self, id: EffectId) -> Option<f64> {
        self.effect_energy_j
            .iter()
            .find(|(e, _)| *e == id)
            .map(|(_, j)| *j)
    }
}

/// A simulated run of a scenario in a world.
#[derive(Debug, Clone, PartialEq)]
pub struct Timeline {
    seed: u64,
    samples: Vec<Sample>,
    spans: Vec<SegmentSpan>,
    truths: Vec<ManoeuvreTruth>,
    noise: Noise,
    tracker: Tracker,
    offset_a: Sides<f64>,
    idle: Sides<SideLoad>,
}

/// Noise streams.
const LEFT_CURRENT: u64 = 1;
const RIGHT_CURRENT: u64 = 2;
const LEFT_BUS: u64 = 3;
const RIGHT_BUS: u64 = 4;
const YAW: u64 = 5;
const PITCH: u64 = 6;
const FIX_X: u64 = 9;
const FIX_Y: u64 = 10;
const FIX_LOST: u64 = 11;
/// Streams of the terrain variation (`[noise]` run_power_std, manoeuvre_power_std).
pub(super) const RUN_SCALE: u64 = 7;
pub(super) const MANOEUVRE_SCALE: u64 = 8;

/// 64 random bits from (seed, stream, t_us) alone: counter-based, so any instant can be queried
/// in any order (splitmix64 as a hash of the three).
fn bits(seed: u64, stream: u64, t_us: u64) -> u64 {
    splitmix64(seed ^ splitmix64(stream.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ splitmix64(t_us)))
}

/// A standard normal deviate from (seed, stream, t_us) alone (Box–Muller on [`bits`] and its
/// hash).
pub(super) fn gaussian(seed: u64, stream: u64, t_us: u64) -> f64 {
    let h1 = bits(seed, stream, t_us);
    let h2 = splitmix64(h1);
    rng::box_muller(rng::unit_open(h1), rng::unit_open(h2))
}

/// A uniform deviate in (0, 1] from (seed, stream, t_us) alone, like [`gaussian`].
fn uniform(seed: u64, stream: u64, t_us: u64) -> f64 {
    rng::unit_open(bits(seed, stream, t_us))
}

impl Timeline {
    pub(crate) fn new(
        world: &WorldConfig,
        seed: u64,
        samples: Vec<Sample>,
        spans: Vec<SegmentSpan>,
        truths: Vec<ManoeuvreTruth>,
    ) -> Self {
        let offset_a = if world.effects.is_enabled(EffectId::CurrentOffset) {
            let o = world.effects.current_offset;
            Sides::new(o.left_a, o.right_a)
        } else {
            Sides::new(0.0, 0.0)
        };
        let iq = world.driver.quiescent_a();
        let v =
            world.battery.nominal_v - (iq.left + iq.right) * world.battery.internal_resistance_ohm;
        let idle = |current_a| SideLoad {
            current_a,
            bus_v: v,
        };
        Self {
            seed,
            samples,
            spans,
            truths,
            noise: world.noise,
            tracker: world.tracker,
            offset_a,
            idle: Sides::new(idle(iq.left), idle(iq.right)),
        }
    }

    /// The seed the noise was drawn with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Length of the run [s].
    pub fn duration_s(&self) -> f64 {
        self.duration_us() as f64 * 1e-6
    }

    /// Length of the run [µs].
    pub fn duration_us(&self) -> u64 {
        self.samples.last().map_or(0, |s| s.t_us)
    }

    /// Ground truth per manoeuvre, in order.
    pub fn manoeuvres(&self) -> &[ManoeuvreTruth] {
        &self.truths
    }

    /// The interpolated true sample at `t_us` (held after the end).
    fn sample_at(&self, t_us: u64) -> Option<Sample> {
        let n = self.samples.partition_point(|s| s.t_us <= t_us);
        if n == 0 {
            return self.samples.first().copied();
        }
        let a = self.samples[n - 1];
        let Some(b) = self.samples.get(n) else {
            return Some(a);
        };
        if b.t_us <= a.t_us {
            return Some(a);
        }
        let f = (t_us - a.t_us) as f64 / (b.t_us - a.t_us) as f64;
        let lerp = |x: f64, y: f64| x + (y - x) * f;
        Some(Sample {
            t_us,
            current_a: Sides::new(
                lerp(a.current_a.left, b.current_a.left),
                lerp(a.current_a.right, b.current_a.right),
            ),
            bus_v: lerp(a.bus_v, b.bus_v),
            yaw_rad: lerp(a.yaw_rad, b.yaw_rad),
            position_m: (
                lerp(a.position_m.0, b.position_m.0),
                lerp(a.position_m.1, b.position_m.1),
            ),
            pitch_deg: lerp(a.pitch_deg, b.pitch_deg),
        })
    }

    /// What each driver really draws at `t_us`: no noise, no sensor offset.
    pub fn true_load_at(&self, t_us: u64) -> Sides<SideLoad> {
        match self.sample_at(t_us) {
            Some(s) if t_us <= self.duration_us() => Sides::new(
                SideLoad {
                    current_a: s.current_a.left,
                    bus_v: s.bus_v,
                },
                SideLoad {
                    current_a: s.current_a.right,
                    bus_v: s.bus_v,
                },
            ),
            _ => self.idle,
        }
    }

    /// True electrical power of each driver at `t_us` [W].
    pub fn true_power_w(&self, t_us: u64) -> Sides<f64> {
        self.true_load_at(t_us).map(|l| l.current_a * l.bus_v)
    }

    /// What each INA226 sees at `t_us`: the true load plus the sensor offset (`current-offset`)
    /// and the measurement noise (deterministic for the seed and `t_us`). Idle after the end.
    pub fn load_at(&self, t_us: u64) -> Sides<SideLoad> {
        let t = self.true_load_at(t_us);
        let n = &self.noise;
        let g = |stream| gaussian(self.seed, stream, t_us);
        Sides::new(
            SideLoad {
                current_a: t.left.current_a
                    + self.offset_a.left
                    + n.left_current_std_a * g(LEFT_CURRENT),
                bus_v: t.left.bus_v + n.bus_std_v * g(LEFT_BUS),
            },
            SideLoad {
                current_a: t.right.current_a
                    + self.offset_a.right
                    + n.right_current_std_a * g(RIGHT_CURRENT),
                bus_v: t.right.bus_v + n.bus_std_v * g(RIGHT_BUS),
            },
        )
    }

    /// True yaw [rad] and pitch [deg] at `t_us`.
    pub fn pose_at(&self, t_us: u64) -> (f64, f64) {
        self.sample_at(t_us)
            .map_or((0.0, 0.0), |s| (s.yaw_rad, s.pitch_deg))
    }

    /// Yaw [rad] and pitch [deg] at `t_us` as the IMU reads them: [`Timeline::pose_at`] plus
    /// the world's sensor noise.
    pub fn measured_pose_at(&self, t_us: u64) -> (f64, f64) {
        let (yaw, pitch) = self.pose_at(t_us);
        (
            yaw + self.noise.yaw_std_rad * gaussian(self.seed, YAW, t_us),
            pitch + self.noise.pitch_std_deg * gaussian(self.seed, PITCH, t_us),
        )
    }

    /// True position of the rover's centre at `t_us` [m] (yaw 0 faces +x).
    pub fn centre_at(&self, t_us: u64) -> (f64, f64) {
        self.sample_at(t_us).map_or((0.0, 0.0), |s| s.position_m)
    }

    /// The world's `[tracker]`.
    pub fn tracker(&self) -> &Tracker {
        &self.tracker
    }

    /// The tracker's fix at `t_us`: the tracked point plus noise, `None` when this fix is lost
    /// (both drawn from the seed and `t_us`).
    pub fn fix_at(&self, t_us: u64) -> Option<(f64, f64)> {
        if uniform(self.seed, FIX_LOST, t_us) < self.tracker.dropout {
            return None;
        }
        let sample = self.sample_at(t_us)?;
        let (x, y) = self.tracker.point_m(sample.position_m, sample.yaw_rad);
        let std = self.tracker.position_std_m;
        Some((
            x + std * gaussian(self.seed, FIX_X, t_us),
            y + std * gaussian(self.seed, FIX_Y, t_us),
        ))
    }

    /// Every fix time of the run [µs] (lost fixes included; see [`Timeline::fix_at`]).
    pub fn fix_times_us(&self) -> Vec<u64> {
        self.tracker.fix_times_us(self.duration_us())
    }

    /// The commanded side speeds in force at `t_us` [m/s].
    pub fn command_at(&self, t_us: u64) -> Sides<f64> {
        let n = self.spans.partition_point(|s| s.start_us <= t_us);
        if n == 0 || t_us >= self.duration_us() {
            return Sides::new(0.0, 0.0);
        }
        self.spans[n - 1].cmd_mps
    }

    /// The commands CSV of the run: a row at every command change and every 1/`tracker_hz` s
    /// (none in between if `tracker_hz` is not > 0), each with the command in force from then
    /// on and the tracker's yaw and pitch (true pose plus `[noise]` tracker noise); rows at the
    /// `[tracker]`'s fix times also carry its position fix (none where the fix is lost).
    pub fn commands(&self, tracker_hz: f64) -> Vec<CommandRow> {
        let end = self.duration_us();
        let fix_times = self.fix_times_us();
        let mut times: Vec<u64> = self.spans.iter().map(|s| s.start_us).collect();
        times.push(end);
        times.extend(&fix_times);
        if tracker_hz.is_finite() && tracker_hz > 0.0 {
            let period_us = 1e6 / tracker_hz;
            let mut k = 0u64;
            loop {
                let t = (k as f64 * period_us).round() as u64;
                if t > end {
                    break;
                }
                times.push(t);
                k += 1;
            }
        }
        times.sort_unstable();
        times.dedup();
        times
            .into_iter()
            .map(|t| {
                let (yaw, pitch) = self.measured_pose_at(t);
                let fix = fix_times
                    .binary_search(&t)
                    .ok()
                    .and_then(|_| self.fix_at(t));
                CommandRow {
                    t_s: t as f64 * 1e-6,
                    cmd_mps: self.command_at(t),
                    yaw_rad: Some(yaw),
                    pitch_deg: Some(pitch),
                    x_m: fix.map(|p| p.0),
                    y_m: fix.map(|p| p.1),
                }
            })
            .collect()
    }

    /// A [`LoadSource`] for [`SimBoard::set_load`](crate::sim::board::SimBoard::set_load)
    /// replaying [`Timeline::load_at`].
    pub fn load_source(self: &Arc<Self>) -> TimelineLoad {
        TimelineLoad(Arc::clone(self))
    }

    /// Number of stored samples (memory: about 48 bytes each).
    pub fn sample_count(&self) -> usize {
        self.samples.len()
    }
}

/// A timeline as the simulated board's load.
#[derive(Debug, Clone)]
pub struct TimelineLoad(pub Arc<Timeline>);

impl LoadSource for TimelineLoad {
    fn load(&mut self, t_us: u64) -> Sides<SideLoad> {
        self.0.load_at(t_us)
    }
}

#[cfg(test)]
mod tests {
    use super::gaussian;

    #[test]
    fn counter_based_noise_is_standard_normal() {
        let n = 200_000u64;
        let (mut sum, mut sq) = (0.0, 0.0);
        for t in 0..n {
            let g = gaussian(7, 1, t * 1000);
            sum += g;
            sq += g * g;
        }
        let mean = sum / n as f64;
        let var = sq / n as f64 - mean * mean;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.02, "{var}");
        assert_eq!(gaussian(7, 1, 5), gaussian(7, 1, 5));
        assert_ne!(gaussian(7, 1, 5), gaussian(8, 1, 5));
        assert_ne!(gaussian(7, 1, 5), gaussian(7, 2, 5));
    }
}
