//! The world's mechanics, stepped every [`STEP_S`](super::STEP_S): kinematics, the baseline ICR
//! power per side, the effects, the DC motors and the battery (see the module docs of
//! [`world`](super)).

use super::effects::EffectId;
use super::scenario::{ManoeuvreKind, Segment, Until};
use super::timeline::{
    gaussian, ManoeuvreTruth, Sample, SegmentSpan, Timeline, MANOEUVRE_SCALE, RUN_SCALE,
};
use super::{DrivePower, PowerSplit, WorldConfig, WorldError, STEP_S};
use model_core::kinematics::{Regime, RegimeBounds, TurnDirection};
use model_core::power::GRAVITY_M_S2;
use model_core::soil::{PileLimit, SandBulldozer, SlipSinkage2d};
use model_core::Sides;

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
    /// `[structure] split`) [W]. Sums to `icr.power_w` exactly except for the `clamped` split.
    fn icr_side_power_w(&self, v: Io) -> Io {
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
        let residual_w = (1.0 - fade) * skid_w;
        let side = Io {
            inner: -k * v.inner + residual_w * v.inner.abs() / sum + g * v.inner.abs(),
            outer: k * v.outer + residual_w * v.outer.abs() / sum + g * v.outer.abs(),
        };
        match split {
            // Section 1.1.3: "any negative power calculated should be put to 0".
            PowerSplit::Clamped => Io {
                inner: side.inner.max(0.0),
                outer: side.outer.max(0.0),
            },
            PowerSplit::Threshold | PowerSplit::Regenerating => side,
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

/// Runs the segments in order.
pub(crate) fn run(
    world: &WorldConfig,
    segments: &[Segment],
    seed: u64,
) -> Result<Timeline, WorldError> {
    let plant = Plant::new(world);
    let sb = world.effects.sinkage_bulldozing;
    let sink_params = sb.sinkage_params();
    let new_soil = || -> Result<Soil, WorldError> {
        let map = |e: model_core::soil::SoilError| WorldError::Invalid {
            origin: "world".into(),
            key: "sinkage-bulldozing".into(),
            reason: e.to_string(),
        };
        let s = SlipSinkage2d::new(sink_params).map_err(map)?;
        let b = SandBulldozer::new(sb.soil(), PileLimit::RunningMax).map_err(map)?;
        Ok(Soil {
            sinkage: [s, s],
            bulldozer: [b, b],
        })
    };
    let mut state = State {
        t_s: 0.0,
        yaw_rad: 0.0,
        position_m: (0.0, 0.0),
        distance_m: 0.0,
        heat_k: Sides::new(0.0, 0.0),
    };
    let mut samples: Vec<Sample> = Vec::new();
    let mut spans = Vec::with_capacity(segments.len());
    let mut truths = Vec::new();
    // One terrain factor per run, one per manoeuvre (its index among the manoeuvres).
    let noise = world.noise;
    let run_scale = 1.0 + noise.run_power_std * gaussian(seed, RUN_SCALE, 0);
    for seg in segments {
        let start_s = state.t_s;
        let resistance_scale = if seg.scenario_index.is_some() {
            let index = truths.len() as u64;
            (run_scale * (1.0 + noise.manoeuvre_power_std * gaussian(seed, MANOEUVRE_SCALE, index)))
                .max(0.0)
        } else {
            1.0
        };
        let mut soil = new_soil()?;
        let mut tally = Tally::default();
        let v = Io::from_sides(seg.cmd_mps, seg.direction);
        let v_c = (v.inner.abs() + v.outer.abs()) / 2.0;
        // Kinematics: constant over the segment.
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
        let limit_s = 20.0 * expected_s + 60.0;
        if rate.is_nan() || rate <= 0.0 || target / rate > limit_s {
            return Err(stalled(&seg.label, limit_s));
        }
        let mut progress = 0.0;
        let mut t_in = 0.0;
        let mut last = None;
        loop {
            let remaining = target - progress;
            if remaining <= target * 1e-12 {
                break;
            }
            let dt = STEP_S.min(remaining / rate);
            if dt < 1e-9 {
                break;
            }
            let (sample, step_effects) = step(
                &plant,
                &mut state,
                &mut soil,
                seg,
                Motion {
                    v,
                    v_c,
                    w_true,
                    v_y,
                    resistance_scale,
                },
                t_in,
                dt,
            )?;
            for side in [0, 1] {
                let p = if side == 0 {
                    sample.current_a.left * sample.bus_v
                } else {
                    sample.current_a.right * sample.bus_v
                };
                if side == 0 {
                    tally.energy_j.left += p * dt;
                } else {
                    tally.energy_j.right += p * dt;
                }
            }
            for (acc, e) in tally.effect_j.iter_mut().zip(step_effects) {
                *acc += e * dt;
            }
            tally.bus_v_s += sample.bus_v * dt;
            tally.pitch_deg_s += sample.pitch_deg * dt;
            samples.push(sample);
            last = Some(sample);
            // Advance the pose (the heading at mid-step: exact to O(dt³) on an arc).
            let yaw_mid = state.yaw_rad + 0.5 * yaw_sign * w_true * dt;
            state.position_m.0 += v_y * yaw_mid.cos() * dt;
            state.position_m.1 += v_y * yaw_mid.sin() * dt;
            state.yaw_rad += yaw_sign * w_true * dt;
            state.distance_m += v_y.abs() * dt;
            state.t_s += dt;
            t_in += dt;
            progress += rate * dt;
        }
        // Hold the segment's last values up to its end, so a command change is a step.
        if let Some(mut s) = last {
            s.t_us = t_us(state.t_s);
            s.yaw_rad = state.yaw_rad;
            s.position_m = state.position_m;
            samples.push(s);
        }
        let end_s = state.t_s;
        spans.push(SegmentSpan {
            start_us: t_us(start_s),
            cmd_mps: seg.cmd_mps,
        });
        if seg.scenario_index.is_some() {
            let duration_s = end_s - start_s;
            let mut effect_energy_j = Vec::new();
            let avg_total_w = (tally.energy_j.left + tally.energy_j.right) / duration_s;
            for id in EffectId::ALL {
                if !plant.on(id) {
                    continue;
                }
                let e = match (id, seg.until) {
                    (EffectId::AngularSlip, Until::Yaw(a)) if w_terrain != 0.0 => {
                        (duration_s - a / w_terrain.abs()) * avg_total_w
                    }
                    (EffectId::SlipTrack, Until::Yaw(a)) if w_kin != 0.0 => {
                        (a / w_kin.abs() - expected_s) * avg_total_w
                    }
                    (EffectId::CurrentOffset, _) => {
                        let o = world.effects.current_offset;
                        (o.left_a + o.right_a) * tally.bus_v_s
                    }
                    _ => tally.effect_j[id as usize],
                };
                effect_energy_j.push((id, e));
            }
            let turning = matches!(seg.until, Until::Yaw(_));
            let regime = seg
                .radius_m
                .map(|r| Regime::of(r as f32, &world.rover, &RegimeBounds::default()));
            truths.push(ManoeuvreTruth {
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
                expected_duration_s: expected_s,
                commanded_yaw_rate_rad_s: yaw_sign * w_cmd,
                true_yaw_rate_rad_s: yaw_sign * w_true,
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
                effect_energy_j,
            });
        }
    }
    Ok(Timeline::new(world, seed, samples, spans, truths))
}

/// One step: the electrical state at the start of the step (returned as a sample, with each
/// effect's electrical power [W]), then the soil and the windings advance by `dt`.
fn step(
    plant: &Plant,
    state: &mut State,
    soil: &mut Soil,
    seg: &Segment,
    motion: Motion,
    t_in: f64,
    dt: f64,
) -> Result<(Sample, [f64; EffectId::COUNT]), WorldError> {
    let Motion {
        v,
        v_c,
        w_true,
        v_y,
        resistance_scale,
    } = motion;
    let world = &plant.world;
    let r = plant.wheel_radius_m;
    let moving = v.inner != 0.0 || v.outer != 0.0;
    let mut effect_w = [0.0f64; EffectId::COUNT];
    // Every term of Eq 21 is ∝ μ or G: the terrain factor scales the whole baseline.
    let icr = {
        let b = plant.icr_side_power_w(v);
        Io {
            inner: b.inner * resistance_scale,
            outer: b.outer * resistance_scale,
        }
    };
    let rate = Io {
        inner: v.inner / r,
        outer: v.outer / r,
    };
    // The baseline torque, and the drivers' baseline power ([`DrivePower`]).
    let (tau_b, base) = match world.structure.drive_power {
        DrivePower::Electrical => (
            Io {
                inner: plant.torque_for_power_nm(icr.inner, rate.inner),
                outer: plant.torque_for_power_nm(icr.outer, rate.outer),
            },
            icr,
        ),
        DrivePower::Mechanical => {
            let tau = |p: f64, w: f64| if w == 0.0 { 0.0 } else { p / w };
            let t = Io {
                inner: tau(icr.inner, rate.inner),
                outer: tau(icr.outer, rate.outer),
            };
            let p = Io {
                inner: plant.motor_power_w(t.inner, rate.inner),
                outer: plant.motor_power_w(t.outer, rate.outer),
            };
            (t, p)
        }
    };
    // Ground velocity of the inner and outer (front) wheels in the left-turn body frame.
    let (half, hl) = (plant.half_track_m, plant.length_m / 2.0);
    let wheel_v = [
        (-w_true * hl, v_y - w_true * half),
        (-w_true * hl, v_y + w_true * half),
    ];
    let side_v = [v.inner, v.outer];
    let speed = |k: usize| wheel_v[k].0.hypot(wheel_v[k].1);
    // β: angle between the actual velocity and the commanded direction (Eq 5.1–5.2; at
    // v_CMD = 0 the smallest angle to the wheel's axis).
    let slip_angle = |k: usize| {
        let (vx, vy) = wheel_v[k];
        let along = if side_v[k] < 0.0 {
            -vy
        } else if side_v[k] > 0.0 {
            vy
        } else {
            vy.abs()
        };
        vx.abs().atan2(along)
    };
    // Extra wheel torque per effect and side: [effect][inner, outer].
    let mut dtau = [[0.0f64; 2]; EffectId::COUNT];
    let supply = |id: EffectId, power_w: f64, dtau: &mut [[f64; 2]; EffectId::COUNT]| {
        // Both sides supply a resistance power in proportion to |V_side|.
        let sum = v.inner.abs() + v.outer.abs();
        if sum == 0.0 {
            return;
        }
        for (d, vk) in dtau[id as usize].iter_mut().zip(side_v) {
            if vk != 0.0 {
                *d += power_w * vk.abs() / sum * r / vk;
            }
        }
    };
    if plant.on(EffectId::InnerDrag) && v.inner < 0.0 && v_c > 0.0 {
        let v_iy = wheel_v[0].1;
        let q = v.inner.abs() * v_iy.max(0.0) / (v_c * v_c);
        let shape = (q / plant.drag_q_ref).min(2.0);
        let d = world.effects.inner_drag;
        let growth = 1.0 - (-t_in / d.ramp_s).exp();
        dtau[EffectId::InnerDrag as usize][0] += -d.torque_nm * shape * growth;
    }
    if plant.on(EffectId::SinkageBulldozing) && moving {
        let sb = world.effects.sinkage_bulldozing;
        let mut total_w = 0.0;
        // Finite inputs cannot make the soil models fail; a failure would leave them as they
        // were (no sinkage change, no bulldozing power this step).
        for (k, vk) in side_v.into_iter().enumerate() {
            let beta = slip_angle(k);
            let gain = if beta > std::f64::consts::FRAC_PI_2 {
                1.0 + sb.counter_rotation_gain
            } else {
                1.0
            };
            let s = &soil.sinkage[k];
            let d = s.sinkage_m();
            let compaction_n = sb.resistance_n_per_mm * (d - sb.static_sinkage_m) * 1000.0;
            let bulldoze = soil.bulldozer[k]
                .step(
                    s.average_sinkage_m(),
                    s.ground_width_m(),
                    beta,
                    speed(k),
                    dt,
                )
                .map(|b| b.power_w)
                .unwrap_or(0.0);
            // Eq 5.39: two wheels per side.
            total_w += 2.0 * (bulldoze + compaction_n * speed(k));
            let _ = soil.sinkage[k].step(speed(k), beta, vk.abs() * gain, dt);
        }
        supply(EffectId::SinkageBulldozing, total_w, &mut dtau);
    }
    let held = world.effects.braked_inner.held_fraction(v.inner);
    if plant.on(EffectId::BrakedInner) && held > 0.0 && w_true != 0.0 {
        let f = world.effects.braked_inner.resistance_n * held;
        let v_i = speed(0);
        if v.outer != 0.0 {
            dtau[EffectId::BrakedInner as usize][1] += 2.0 * f * v_i * r / v.outer;
        }
        if v_i > 0.0 {
            // The inner motors hold the rolling component of the drag (at stall for V_i = 0).
            dtau[EffectId::BrakedInner as usize][0] += -r * 2.0 * f * wheel_v[0].1 / v_i;
        }
    }
    // Electrical power per side.
    let c = plant.copper_w_per_nm2;
    let eta = plant.motor.efficiency;
    let mut p = [base.inner, base.outer];
    let mut tau_total = [tau_b.inner, tau_b.outer];
    let rates = [rate.inner, rate.outer];
    let taus = [tau_b.inner, tau_b.outer];
    for k in 0..2 {
        let all: f64 = dtau.iter().map(|e| e[k]).sum();
        tau_total[k] += all;
        for (id, d) in dtau.iter().enumerate() {
            let dt_k = d[k];
            if dt_k != 0.0 {
                let dp = dt_k * rates[k] / eta + c * (2.0 * taus[k] * dt_k + dt_k * all);
                p[k] += dp;
                effect_w[id] += dp;
            }
        }
    }
    let mut pitch_deg = 0.0;
    if plant.on(EffectId::Slope) {
        let s = world.effects.slope;
        pitch_deg = s.pitch_deg_at(state.distance_m);
        let sum = v.inner.abs() + v.outer.abs();
        if sum > 0.0 {
            let total = s.phi
                * f64::from(world.rover.mass_kg)
                * GRAVITY_M_S2
                * v_y
                * pitch_deg.to_radians().sin();
            for (pk, vk) in p.iter_mut().zip(side_v) {
                let dp = total * vk.abs() / sum;
                *pk += dp;
                effect_w[EffectId::Slope as usize] += dp;
            }
        }
    }
    let mut p_sides = Io {
        inner: p[0],
        outer: p[1],
    }
    .to_sides(seg.direction);
    if plant.on(EffectId::MotorHeating) {
        let h = world.effects.motor_heating;
        let cur = Io {
            inner: tau_total[0] / plant.torque_per_amp_nm,
            outer: tau_total[1] / plant.torque_per_amp_nm,
        }
        .to_sides(seg.direction);
        let rm = plant.motor.winding_resistance_ohm;
        for (heat, (i, pw)) in [
            (&mut state.heat_k.left, (cur.left, &mut p_sides.left)),
            (&mut state.heat_k.right, (cur.right, &mut p_sides.right)),
        ] {
            let extra_w = i * i * rm * h.resistance_coefficient_per_k * *heat;
            *pw += extra_w;
            effect_w[EffectId::MotorHeating as usize] += extra_w;
            let copper_w = i * i * rm * (1.0 + h.resistance_coefficient_per_k * *heat);
            let rise = (copper_w * h.thermal_resistance_k_per_w - *heat) / h.time_constant_s;
            *heat = (*heat + rise * dt).min(h.max_rise_k);
        }
    }
    // Battery and drivers: V = V_0 − R_int (I_l + I_r), I = I_q + P/V.
    let bat = world.battery;
    let iq = world.driver.quiescent_a();
    let total_w = p_sides.left + p_sides.right;
    let a = bat.nominal_v - bat.internal_resistance_ohm * (iq.left + iq.right);
    let mut bus_v = if bat.internal_resistance_ohm == 0.0 {
        bat.nominal_v
    } else {
        let disc = a * a - 4.0 * bat.internal_resistance_ohm * total_w;
        (a + disc.max(0.0).sqrt()) / 2.0
    };
    if bus_v <= 0.0 {
        bus_v = a / 2.0;
    }
    let mut current = Sides::new(
        iq.left + p_sides.left / bus_v,
        iq.right + p_sides.right / bus_v,
    );
    if current.left + current.right < 0.0 {
        // The battery cannot be charged: the drivers burn the surplus (Section 1.1.3).
        bus_v = bat.nominal_v;
        if current.left < 0.0 {
            current.left = -current.right;
        } else {
            current.right = -current.left;
        }
    }
    let sample = Sample {
        t_us: t_us(state.t_s),
        current_a: current,
        bus_v,
        yaw_rad: state.yaw_rad,
        position_m: state.position_m,
        pitch_deg,
    };
    Ok((sample, effect_w))
}
