//! The world's mechanics, stepped every [`STEP_S`](super::STEP_S): kinematics, the baseline ICR
//! power per side, the effects, the DC motors and the battery (see the module docs of
//! [`world`](super)).

use super::effects::EffectId;
use super::scenario::{ManoeuvreKind, Segment, Until};
use super::timeline::{
    gaussian, ManoeuvreTruth, Sample, SegmentSpan, Timeline, MANOEUVRE_SCALE, RUN_SCALE,
};
use super::{PowerSplit, WorldConfig, WorldError, STEP_S};
use model_core::kinematics::{Regime, RegimeBounds, TurnDirection};
use model_core::soil::{PileLimit, SandBulldozer, SlipSinkage2d};
use model_core::Sides;
use step::step;

mod step;

/// A value per inner/outer side (inner = left for left turns and straight lines).
#[derive(Debug, Clone, Copy, Default)]
struct Io {
    inner: f64,
    outer: f64,
}

impl Io {
    fn to_sides(self, direction: Option<TurnDirection>) -> Sides<f64> {
        match direction {
            Some(TurnDirection::Right) => Sides::new(self.outer, self.inner),
            _ => Sides::new(self.inner, self.outer),
        }
    }
    fn from_sides(s: Sides<f64>, direction: Option<TurnDirection>) -> Io {
        match direction {
            Some(TurnDirection::Right) => Io {
                inner: s.right,
                outer: s.left,
            },
            _ => Io {
                inner: s.left,
                outer: s.right,
            },
        }
    }
}

/// The constants of a run.
struct Plant {
    world: WorldConfig,
    half_track_m: f64,
    length_m: f64,
    wheel_radius_m: f64,
    controller_slip_track_m: f64,
    terrain_slip_track_m: f64,
    icr: model_core::power::IcrHardGround,
    /// F / B_s: the tread force of the skid couple [N].
    tread_force_n: f64,
    motor: model_core::power::DcMotor,
    /// R_m / (K_T g η)² [W/(N·m)²].
    copper_w_per_nm2: f64,
    /// K_T g η [N·m/A] at the wheel.
    torque_per_amp_nm: f64,
    /// Peak of q = |V_i| v_iy / v_c² for an ideal turn (inner-drag normalisation).
    drag_q_ref: f64,
    /// The `threshold` split's fade radius R_f [m].
    fade_radius_m: f64,
}

impl Plant {
    fn new(world: &WorldConfig) -> Self {
        let rover = world.rover;
        let icr = world.icr.model(&rover);
        let motor = world.motor.dc_motor();
        let torque_per_amp_nm =
            motor.torque_constant_nm_per_a * motor.gear_ratio * motor.efficiency;
        let r_prime = f64::from(rover.r_prime_m());
        let half = f64::from(rover.half_track_m());
        let drag_q_ref = if r_prime > half {
            ((r_prime - half) / (2.0 * r_prime)).powi(2)
        } else {
            f64::INFINITY
        };
        Self {
            world: *world,
            half_track_m: half,
            length_m: f64::from(rover.length_m),
            wheel_radius_m: f64::from(rover.wheel_radius_m),
            controller_slip_track_m: f64::from(rover.slip_track_m),
            terrain_slip_track_m: world.terrain_slip_track_m(),
            tread_force_n: icr.skid_moment_nm() / icr.slip_track_m,
            icr,
            motor,
            copper_w_per_nm2: motor.winding_resistance_ohm
                / (torque_per_amp_nm * torque_per_amp_nm),
            torque_per_amp_nm,
            drag_q_ref,
            // Validated: a threshold radius without a fade radius is an error.
            fade_radius_m: world
                .traction_fade_radius_m()
                .unwrap_or(world.icr.traction_fade_radius_m),
        }
    }

    fn on(&self, id: EffectId) -> bool {
        self.world.effects.is_enabled(id)
    }

    /// The baseline ICR power per side (paper Eq 21 split by the tread-force couple, per
    /// `[structure] split`) [W], from the sides' speeds `v` and their forces `force`
    /// ([`Plant::icr_side_force_n`]). Sums to `icr.power_w` exactly except for the `clamped`
    /// split.
    fn icr_side_power_w(&self, v: Io, force: Io) -> Io {
        let side = Io {
            inner: force.inner * v.inner,
            outer: force.outer * v.outer,
        };
        match self.world.structure.split {
            // Section 1.1.3: "any negative power calculated should be put to 0".
            PowerSplit::Clamped => Io {
                inner: side.inner.max(0.0),
                outer: side.outer.max(0.0),
            },
            PowerSplit::Threshold | PowerSplit::Regenerating => side,
        }
    }

    /// The force each side's tread carries in the baseline ICR model, before any clamp (its
    /// power over its speed) [N]. The skid couple's tread force acts on a side commanded to
    /// stand still too (at R′ the inner tread still slides lengthwise, by ω(B_s − B)/2 on hard
    /// ground): its motor holds it at stall, the seed's braked wheel (Section 6.2), drawing
    /// the copper loss of that torque (Eq 1.18 with ω = 0). A still wheel does not roll, so
    /// it meets no rolling resistance.
    fn icr_side_force_n(&self, v: Io) -> Io {
        let g = self.icr.rolling_resistance_n;
        let sum = v.inner.abs() + v.outer.abs();
        if sum == 0.0 {
            return Io::default();
        }
        let diff = v.outer - v.inner;
        let skid_w = self.icr.skid_moment_nm() * (diff / self.icr.slip_track_m).abs();
        let split = self.world.structure.split;
        let fade = match split {
            // No yaw, no skid couple (Eq 21's F|ω_z| is 0): on a straight both sides draw G|V|,
            // whatever the split.
            _ if diff == 0.0 => 0.0,
            PowerSplit::Regenerating | PowerSplit::Clamped => 1.0,
            PowerSplit::Threshold => {
                let r = self.icr.slip_track_m / 2.0 * ((v.outer + v.inner) / diff).abs();
                1.0 / (1.0 + (r / self.fade_radius_m).powi(2))
            }
        };
        let k = self.tread_force_n * fade;
        // The unfaded part of the skid power, shared in proportion to |V|: a force of
        // residual / (|V_i| + |V_o|) along each side's motion.
        let residual_n = (1.0 - fade) * skid_w / sum;
        let along = |speed: f64| (residual_n + g) * sign_or_zero(speed);
        Io {
            inner: -k + along(v.inner),
            outer: k + along(v.outer),
        }
    }

    /// A side's electrical power for wheel torque τ at wheel rate ω by Eq 1.18 (a generating
    /// side returns τωη rather than τω/η: the motor is then a generator with the same losses).
    fn motor_power_w(&self, torque_nm: f64, rate_rad_s: f64) -> f64 {
        let shaft_w = torque_nm * rate_rad_s;
        let eta = self.motor.efficiency;
        let shaft_w = if shaft_w >= 0.0 {
            shaft_w / eta
        } else {
            shaft_w * eta
        };
        shaft_w + self.copper_w_per_nm2 * torque_nm * torque_nm
    }

    /// The wheel torque τ with DcMotor::side_power_w(τ, ω) = P (Eq 1.18 inverted on the root
    /// continuous with τ = ηP/ω); 0 at ω = 0 (an undriven side).
    fn torque_for_power_nm(&self, power_w: f64, rate_rad_s: f64) -> f64 {
        if rate_rad_s == 0.0 {
            return 0.0;
        }
        let b = rate_rad_s / self.motor.efficiency;
        let c = self.copper_w_per_nm2;
        let disc = (b * b + 4.0 * c * power_w).max(0.0);
        2.0 * power_w / (b + b.signum() * disc.sqrt())
    }
}

/// The constant motion of a segment.
#[derive(Debug, Clone, Copy)]
struct Motion {
    /// Commanded side speeds [m/s].
    v: Io,
    /// v_c [m/s].
    v_c: f64,
    /// True yaw rate (left-turn frame) [rad/s].
    w_true: f64,
    /// Forward speed [m/s].
    v_y: f64,
    /// Factor on the terrain resistance (μ, G) of this manoeuvre.
    resistance_scale: f64,
}

/// Per-manoeuvre soil state of one inner and one outer wheel.
struct Soil {
    sinkage: [SlipSinkage2d; 2],
    bulldozer: [SandBulldozer; 2],
}

/// Sums over one segment for its truth.
#[derive(Default)]
struct Tally {
    energy_j: Sides<f64>,
    effect_j: [f64; EffectId::COUNT],
    bus_v_s: f64,
    pitch_deg_s: f64,
}

/// Deterministic per-run state.
struct State {
    t_s: f64,
    yaw_rad: f64,
    /// The rover centre's position [m] (x east-like, y north-like; yaw 0 faces +x).
    position_m: (f64, f64),
    distance_m: f64,
    /// Winding temperature above ambient [K].
    heat_k: Sides<f64>,
}

fn stalled(label: &str, limit_s: f64) -> WorldError {
    WorldError::Stalled {
        label: label.to_string(),
        limit_s,
    }
}

fn t_us(t_s: f64) -> u64 {
    (t_s * 1e6).round().max(0.0) as u64
}

/// Fresh soil for a segment (each manoeuvre starts on undisturbed ground).
fn new_soil(world: &WorldConfig) -> Result<Soil, WorldError> {
    let sb = world.effects.sinkage_bulldozing;
    let map = |e: model_core::soil::SoilError| WorldError::Invalid {
        origin: "world".into(),
        key: "sinkage-bulldozing".into(),
        reason: e.to_string(),
    };
    let s = SlipSinkage2d::new(sb.sinkage_params()).map_err(map)?;
    let b = SandBulldozer::new(sb.soil(), PileLimit::RunningMax).map_err(map)?;
    Ok(Soil {
        sinkage: [s, s],
        bulldozer: [b, b],
    })
}

/// The terrain factor of the manoeuvre with this index among the manoeuvres.
fn manoeuvre_scale(world: &WorldConfig, seed: u64, run_scale: f64, index: usize) -> f64 {
    let noise = world.noise;
    (run_scale * (1.0 + noise.manoeuvre_power_std * gaussian(seed, MANOEUVRE_SCALE, index as u64)))
        .max(0.0)
}

/// A segment's kinematics: constant over the segment.
struct Kinematics {
    /// Commanded side speeds [m/s].
    v: Io,
    v_c: f64,
    /// Commanded yaw rate (controller slip track) [rad/s].
    w_cmd: f64,
    /// Yaw rate of the terrain's slip track without any loss [rad/s].
    w_kin: f64,
    /// `w_kin` after the `[structure] angular_slip` loss [rad/s].
    w_terrain: f64,
    /// True yaw rate (left-turn frame) [rad/s].
    w_true: f64,
    v_y: f64,
    /// +1 for left turns and straights, −1 for right turns.
    yaw_sign: f64,
    /// The segment ends when `progress` (advancing at `rate` per second) reaches `target`.
    target: f64,
    rate: f64,
    expected_s: f64,
}

impl Kinematics {
    fn of(plant: &Plant, seg: &Segment) -> Self {
        let world = &plant.world;
        let v = Io::from_sides(seg.cmd_mps, seg.direction);
        let v_c = (v.inner.abs() + v.outer.abs()) / 2.0;
        let w_cmd = (v.outer - v.inner) / plant.controller_slip_track_m;
        let w_kin = (v.outer - v.inner) / plant.terrain_slip_track_m;
        let r_cmd = if v.outer == v.inner {
            f64::INFINITY
        } else {
            plant.controller_slip_track_m / 2.0 * ((v.outer + v.inner) / (v.outer - v.inner)).abs()
        };
        let slip = if plant.on(EffectId::AngularSlip) && w_kin != 0.0 {
            world
                .effects
                .angular_slip
                .slip(r_cmd, plant.controller_slip_track_m / 2.0)
        } else {
            0.0
        };
        // [structure] angular_slip: the terrain's constant loss in every turn (Fig. 6.7).
        let w_terrain = w_kin * (1.0 - world.structure.angular_slip);
        let w_true = w_terrain * (1.0 - slip);
        let v_y = (v.inner + v.outer) / 2.0;
        let yaw_sign = match seg.direction {
            Some(TurnDirection::Right) => -1.0,
            _ => 1.0,
        };
        let (target, rate) = match seg.until {
            Until::Yaw(a) => (a, w_true.abs()),
            Until::Distance(d) => (d, v_y.abs()),
            Until::Time(t) => (t, 1.0),
        };
        let expected_s = match seg.until {
            Until::Yaw(a) => a / w_cmd.abs(),
            Until::Distance(d) => d / v_y.abs(),
            Until::Time(t) => t,
        };
        Self {
            v,
            v_c,
            w_cmd,
            w_kin,
            w_terrain,
            w_true,
            v_y,
            yaw_sign,
            target,
            rate,
            expected_s,
        }
    }
}

impl Tally {
    fn add(&mut self, sample: &Sample, effect_w: &[f64; EffectId::COUNT], dt: f64) {
        self.energy_j.left += sample.current_a.left * sample.bus_v * dt;
        self.energy_j.right += sample.current_a.right * sample.bus_v * dt;
        for (acc, e) in self.effect_j.iter_mut().zip(effect_w) {
            *acc += e * dt;
        }
        self.bus_v_s += sample.bus_v * dt;
        self.pitch_deg_s += sample.pitch_deg * dt;
    }
}

impl State {
    fn start() -> Self {
        Self {
            t_s: 0.0,
            yaw_rad: 0.0,
            position_m: (0.0, 0.0),
            distance_m: 0.0,
            heat_k: Sides::new(0.0, 0.0),
        }
    }

    /// Advances the pose (the heading at mid-step: exact to O(dt³) on an arc) and the clock.
    fn advance(&mut self, kin: &Kinematics, dt: f64) {
        let yaw_mid = self.yaw_rad + 0.5 * kin.yaw_sign * kin.w_true * dt;
        self.position_m.0 += kin.v_y * yaw_mid.cos() * dt;
        self.position_m.1 += kin.v_y * yaw_mid.sin() * dt;
        self.yaw_rad += kin.yaw_sign * kin.w_true * dt;
        self.distance_m += kin.v_y.abs() * dt;
        self.t_s += dt;
    }
}

/// Runs the segments in order.
pub(crate) fn run(
    world: &WorldConfig,
    segments: &[Segment],
    seed: u64,
) -> Result<Timeline, WorldError> {
    let plant = Plant::new(world);
    let mut state = State::start();
    let mut samples: Vec<Sample> = Vec::new();
    let mut spans = Vec::with_capacity(segments.len());
    let mut truths = Vec::new();
    // One terrain factor per run, one per manoeuvre (its index among the manoeuvres).
    let run_scale = 1.0 + world.noise.run_power_std * gaussian(seed, RUN_SCALE, 0);
    for seg in segments {
        let start_s = state.t_s;
        let resistance_scale = if seg.scenario_index.is_some() {
            manoeuvre_scale(world, seed, run_scale, truths.len())
        } else {
            1.0
        };
        let kin = Kinematics::of(&plant, seg);
        let tally = drive_segment(
            &plant,
            &mut state,
            seg,
            &kin,
            resistance_scale,
            &mut samples,
        )?;
        spans.push(SegmentSpan {
            start_us: t_us(start_s),
            cmd_mps: seg.cmd_mps,
        });
        if seg.scenario_index.is_some() {
            let span_s = (start_s, state.t_s);
            truths.push(manoeuvre_truth(
                &plant,
                seg,
                &kin,
                &tally,
                span_s,
                resistance_scale,
            ));
        }
    }
    Ok(Timeline::new(world, seed, samples, spans, truths))
}

/// Steps one segment to its end, appending its samples; returns its sums.
fn drive_segment(
    plant: &Plant,
    state: &mut State,
    seg: &Segment,
    kin: &Kinematics,
    resistance_scale: f64,
    samples: &mut Vec<Sample>,
) -> Result<Tally, WorldError> {
    let mut soil = new_soil(&plant.world)?;
    let limit_s = 20.0 * kin.expected_s + 60.0;
    if kin.rate.is_nan() || kin.rate <= 0.0 || kin.target / kin.rate > limit_s {
        return Err(stalled(&seg.label, limit_s));
    }
    let motion = Motion {
        v: kin.v,
        v_c: kin.v_c,
        w_true: kin.w_true,
        v_y: kin.v_y,
        resistance_scale,
    };
    let mut tally = Tally::default();
    let mut progress = 0.0;
    let mut t_in = 0.0;
    let mut last = None;
    loop {
        let remaining = kin.target - progress;
        if remaining <= kin.target * 1e-12 {
            break;
        }
        let dt = STEP_S.min(remaining / kin.rate);
        if dt < 1e-9 {
            break;
        }
        let (sample, effect_w) = step(plant, state, &mut soil, seg, motion, t_in, dt)?;
        tally.add(&sample, &effect_w, dt);
        samples.push(sample);
        last = Some(sample);
        state.advance(kin, dt);
        t_in += dt;
        progress += kin.rate * dt;
    }
    // Hold the segment's last values up to its end, so a command change is a step.
    if let Some(mut s) = last {
        s.t_us = t_us(state.t_s);
        s.yaw_rad = state.yaw_rad;
        s.position_m = state.position_m;
        samples.push(s);
    }
    Ok(tally)
}

/// Each enabled effect's energy over a manoeuvre [J]: the time-stretching effects (angular
/// slip, slip track) as their extra duration at the average power, the others as summed.
fn effect_energies(
    plant: &Plant,
    seg: &Segment,
    kin: &Kinematics,
    tally: &Tally,
    duration_s: f64,
) -> Vec<(EffectId, f64)> {
    let avg_total_w = (tally.energy_j.left + tally.energy_j.right) / duration_s;
    let mut effect_energy_j = Vec::new();
    for id in EffectId::ALL {
        if !plant.on(id) {
            continue;
        }
        let e = match (id, seg.until) {
            (EffectId::AngularSlip, Until::Yaw(a)) if kin.w_terrain != 0.0 => {
                (duration_s - a / kin.w_terrain.abs()) * avg_total_w
            }
            (EffectId::SlipTrack, Until::Yaw(a)) if kin.w_kin != 0.0 => {
                (a / kin.w_kin.abs() - kin.expected_s) * avg_total_w
            }
            (EffectId::CurrentOffset, _) => {
                let o = plant.world.effects.current_offset;
                (o.left_a + o.right_a) * tally.bus_v_s
            }
            _ => tally.effect_j[id as usize],
        };
        effect_energy_j.push((id, e));
    }
    effect_energy_j
}

/// The truth of one manoeuvre spanning `(start_s, end_s)`.
fn manoeuvre_truth(
    plant: &Plant,
    seg: &Segment,
    kin: &Kinematics,
    tally: &Tally,
    (start_s, end_s): (f64, f64),
    resistance_scale: f64,
) -> ManoeuvreTruth {
    let duration_s = end_s - start_s;
    let (w_cmd, w_true, v_y) = (kin.w_cmd, kin.w_true, kin.v_y);
    let turning = matches!(seg.until, Until::Yaw(_));
    let regime = seg
        .radius_m
        .map(|r| Regime::of(r as f32, &plant.world.rover, &RegimeBounds::default()));
    ManoeuvreTruth {
        label: seg.label.clone(),
        kind: seg.kind,
        scenario_index: seg.scenario_index.unwrap_or(0),
        repeat: seg.repeat,
        part: seg.part,
        start_us: t_us(start_s),
        end_us: t_us(end_s),
        cmd_mps: seg.cmd_mps,
        direction: seg.direction,
        commanded_radius_m: seg.radius_m,
        regime,
        expected_duration_s: kin.expected_s,
        commanded_yaw_rate_rad_s: kin.yaw_sign * w_cmd,
        true_yaw_rate_rad_s: kin.yaw_sign * w_true,
        angular_slip: turning.then(|| 1.0 - w_true / w_cmd),
        true_radius_m: (seg.kind != ManoeuvreKind::Pause).then(|| {
            if w_true == 0.0 {
                f64::INFINITY
            } else {
                (v_y / w_true).abs()
            }
        }),
        energy_j: tally.energy_j,
        avg_power_w: Sides::new(
            tally.energy_j.left / duration_s,
            tally.energy_j.right / duration_s,
        ),
        mean_pitch_deg: tally.pitch_deg_s / duration_s,
        resistance_scale,
        effect_energy_j: effect_energies(plant, seg, kin, tally, duration_s),
    }
}

/// The sign of `x`, 0 at 0 (a still wheel meets no force along its motion).
fn sign_or_zero(x: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else {
        x.signum()
    }
}
