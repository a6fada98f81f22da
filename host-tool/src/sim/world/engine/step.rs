//! One step of the mechanics: the baseline, each effect's torque or power, the battery.

use super::{t_us, Io, Motion, Plant, Soil, State};
use crate::sim::world::effects::EffectId;
use crate::sim::world::scenario::Segment;
use crate::sim::world::timeline::Sample;
use crate::sim::world::{DrivePower, WorldConfig, WorldError};
use model_core::power::GRAVITY_M_S2;
use model_core::Sides;

/// Extra wheel torque per effect and side: `[effect][inner, outer]` [N·m].
type EffectTorques = [[f64; 2]; EffectId::COUNT];

/// One step: the electrical state at the start of the step (returned as a sample, with each
/// effect's electrical power [W]), then the soil and the windings advance by `dt`.
pub(super) fn step(
    plant: &Plant,
    state: &mut State,
    soil: &mut Soil,
    seg: &Segment,
    motion: Motion,
    t_in: f64,
    dt: f64,
) -> Result<(Sample, [f64; EffectId::COUNT]), WorldError> {
    let mut effect_w = [0.0f64; EffectId::COUNT];
    let base = Baseline::of(plant, &motion);
    let wheels = Wheels::of(plant, &motion);
    let mut dtau: EffectTorques = [[0.0f64; 2]; EffectId::COUNT];
    inner_drag_torque(plant, &motion, &wheels, t_in, &mut dtau);
    sinkage_bulldozing_torque(plant, &motion, &wheels, soil, dt, &mut dtau);
    braked_inner_torque(plant, &motion, &wheels, &mut dtau);
    let (mut p, tau_total) = effect_torque_power(plant, &base, &dtau, &mut effect_w);
    let pitch_deg = slope_power(plant, state, &motion, &mut p, &mut effect_w);
    let mut p_sides = Io {
        inner: p[0],
        outer: p[1],
    }
    .to_sides(seg.direction);
    motor_heating_power(
        plant,
        state,
        seg,
        tau_total,
        dt,
        &mut p_sides,
        &mut effect_w,
    );
    let (bus_v, current) = battery_and_drivers(&plant.world, p_sides);
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

/// The baseline per side: wheel rate, torque and the drivers' power ([`DrivePower`]).
struct Baseline {
    rate: Io,
    tau: Io,
    power_w: Io,
}

impl Baseline {
    fn of(plant: &Plant, motion: &Motion) -> Self {
        let v = motion.v;
        let r = plant.wheel_radius_m;
        let force = plant.icr_side_force_n(v);
        // Every term of Eq 21 is ∝ μ or G: the terrain factor scales the whole baseline.
        let icr = {
            let b = plant.icr_side_power_w(v, force);
            Io {
                inner: b.inner * motion.resistance_scale,
                outer: b.outer * motion.resistance_scale,
            }
        };
        let rate = Io {
            inner: v.inner / r,
            outer: v.outer / r,
        };
        let (tau, power_w) = match plant.world.structure.drive_power {
            DrivePower::Electrical => (
                Io {
                    inner: plant.torque_for_power_nm(icr.inner, rate.inner),
                    outer: plant.torque_for_power_nm(icr.outer, rate.outer),
                },
                icr,
            ),
            DrivePower::Mechanical => {
                // A side commanded still holds its tread's force at stall (torque, no power).
                let tau = |p: f64, w: f64, f: f64| {
                    if w == 0.0 {
                        f * r * motion.resistance_scale
                    } else {
                        p / w
                    }
                };
                let t = Io {
                    inner: tau(icr.inner, rate.inner, force.inner),
                    outer: tau(icr.outer, rate.outer, force.outer),
                };
                let p = Io {
                    inner: plant.motor_power_w(t.inner, rate.inner),
                    outer: plant.motor_power_w(t.outer, rate.outer),
                };
                (t, p)
            }
        };
        Self { rate, tau, power_w }
    }
}

/// Ground velocity of the inner and outer (front) wheels in the left-turn body frame.
struct Wheels {
    /// (v_x, v_y) per wheel [m/s].
    ground_v: [(f64, f64); 2],
    /// Commanded side speeds [inner, outer] [m/s].
    side_v: [f64; 2],
}

impl Wheels {
    fn of(plant: &Plant, motion: &Motion) -> Self {
        let (half, hl) = (plant.half_track_m, plant.length_m / 2.0);
        let (w, v_y) = (motion.w_true, motion.v_y);
        Self {
            ground_v: [(-w * hl, v_y - w * half), (-w * hl, v_y + w * half)],
            side_v: [motion.v.inner, motion.v.outer],
        }
    }

    fn speed(&self, k: usize) -> f64 {
        self.ground_v[k].0.hypot(self.ground_v[k].1)
    }

    /// β: angle between the actual velocity and the commanded direction (Eq 5.1–5.2; at
    /// v_CMD = 0 the smallest angle to the wheel's axis).
    fn slip_angle(&self, k: usize) -> f64 {
        let (vx, vy) = self.ground_v[k];
        let along = if self.side_v[k] < 0.0 {
            -vy
        } else if self.side_v[k] > 0.0 {
            vy
        } else {
            vy.abs()
        };
        vx.abs().atan2(along)
    }

    /// Spreads a resistance power over both sides in proportion to |V_side|, as wheel torque.
    fn supply(&self, r: f64, power_w: f64, dtau: &mut [f64; 2]) {
        let sum = self.side_v[0].abs() + self.side_v[1].abs();
        if sum == 0.0 {
            return;
        }
        for (d, vk) in dtau.iter_mut().zip(self.side_v) {
            if vk != 0.0 {
                *d += power_w * vk.abs() / sum * r / vk;
            }
        }
    }
}

/// Inner-drag: a drag torque on a counter-rotating inner side, growing over the manoeuvre.
fn inner_drag_torque(
    plant: &Plant,
    motion: &Motion,
    wheels: &Wheels,
    t_in: f64,
    dtau: &mut EffectTorques,
) {
    let (v, v_c) = (motion.v, motion.v_c);
    if plant.on(EffectId::InnerDrag) && v.inner < 0.0 && v_c > 0.0 {
        let v_iy = wheels.ground_v[0].1;
        let q = v.inner.abs() * v_iy.max(0.0) / (v_c * v_c);
        let shape = (q / plant.drag_q_ref).min(2.0);
        let d = plant.world.effects.inner_drag;
        let growth = 1.0 - (-t_in / d.ramp_s).exp();
        dtau[EffectId::InnerDrag as usize][0] += -d.torque_nm * shape * growth;
    }
}

/// Sinkage and bulldozing: compaction and bulldozing power of both sides; the soil advances.
fn sinkage_bulldozing_torque(
    plant: &Plant,
    motion: &Motion,
    wheels: &Wheels,
    soil: &mut Soil,
    dt: f64,
    dtau: &mut EffectTorques,
) {
    let moving = motion.v.inner != 0.0 || motion.v.outer != 0.0;
    if !(plant.on(EffectId::SinkageBulldozing) && moving) {
        return;
    }
    let sb = plant.world.effects.sinkage_bulldozing;
    let mut total_w = 0.0;
    // Finite inputs cannot make the soil models fail; a failure would leave them as they
    // were (no sinkage change, no bulldozing power this step).
    for (k, vk) in wheels.side_v.into_iter().enumerate() {
        let beta = wheels.slip_angle(k);
        let speed = wheels.speed(k);
        let gain = if beta > std::f64::consts::FRAC_PI_2 {
            1.0 + sb.counter_rotation_gain
        } else {
            1.0
        };
        let s = &soil.sinkage[k];
        let d = s.sinkage_m();
        let compaction_n = sb.resistance_n_per_mm * (d - sb.static_sinkage_m) * 1000.0;
        let bulldoze = soil.bulldozer[k]
            .step(s.average_sinkage_m(), s.ground_width_m(), beta, speed, dt)
            .map(|b| b.power_w)
            .unwrap_or(0.0);
        // Eq 5.39: two wheels per side.
        total_w += 2.0 * (bulldoze + compaction_n * speed);
        let _ = soil.sinkage[k].step(speed, beta, vk.abs() * gain, dt);
    }
    let r = plant.wheel_radius_m;
    wheels.supply(r, total_w, &mut dtau[EffectId::SinkageBulldozing as usize]);
}

/// Braked inner side: the outer side drags the held inner wheels through the turn.
fn braked_inner_torque(plant: &Plant, motion: &Motion, wheels: &Wheels, dtau: &mut EffectTorques) {
    let (v, r) = (motion.v, plant.wheel_radius_m);
    let braked = plant.world.effects.braked_inner;
    let held = braked.held_fraction(v.inner);
    if plant.on(EffectId::BrakedInner) && held > 0.0 && motion.w_true != 0.0 {
        let f = braked.resistance_n * held;
        let v_i = wheels.speed(0);
        let d = &mut dtau[EffectId::BrakedInner as usize];
        if v.outer != 0.0 {
            d[1] += 2.0 * f * v_i * r / v.outer;
        }
        if v_i > 0.0 {
            // The inner motors hold the rolling component of the drag (at stall for V_i = 0).
            d[0] += -r * 2.0 * f * wheels.ground_v[0].1 / v_i;
        }
    }
}

/// Electrical power per side [inner, outer] with the effects' torques (each effect's share of
/// the copper cross term booked to it), and the total wheel torque per side.
fn effect_torque_power(
    plant: &Plant,
    base: &Baseline,
    dtau: &EffectTorques,
    effect_w: &mut [f64; EffectId::COUNT],
) -> ([f64; 2], [f64; 2]) {
    let c = plant.copper_w_per_nm2;
    let eta = plant.motor.efficiency;
    let mut p = [base.power_w.inner, base.power_w.outer];
    let mut tau_total = [base.tau.inner, base.tau.outer];
    let rates = [base.rate.inner, base.rate.outer];
    let taus = [base.tau.inner, base.tau.outer];
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
    (p, tau_total)
}

/// Slope: the climbing power; each track pushes its half of the weight's along-track
/// component at its own (signed) speed, so the sides sum to Eq 1.16's Φ m g v_y sin θ.
/// Returns the pitch [°].
fn slope_power(
    plant: &Plant,
    state: &State,
    motion: &Motion,
    p: &mut [f64; 2],
    effect_w: &mut [f64; EffectId::COUNT],
) -> f64 {
    if !plant.on(EffectId::Slope) {
        return 0.0;
    }
    let world = &plant.world;
    let s = world.effects.slope;
    let pitch_deg = s.pitch_deg_at(state.distance_m);
    let half_weight_n = s.phi * f64::from(world.rover.mass_kg) * GRAVITY_M_S2 / 2.0;
    for (pk, vk) in p.iter_mut().zip([motion.v.inner, motion.v.outer]) {
        let dp = half_weight_n * pitch_deg.to_radians().sin() * vk;
        *pk += dp;
        effect_w[EffectId::Slope as usize] += dp;
    }
    pitch_deg
}

/// Motor heating: the warm windings' extra copper loss; the windings' temperature advances.
fn motor_heating_power(
    plant: &Plant,
    state: &mut State,
    seg: &Segment,
    tau_total: [f64; 2],
    dt: f64,
    p_sides: &mut Sides<f64>,
    effect_w: &mut [f64; EffectId::COUNT],
) {
    if !plant.on(EffectId::MotorHeating) {
        return;
    }
    let h = plant.world.effects.motor_heating;
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

/// Battery and drivers: V = V_0 − R_int (I_l + I_r), I = I_q + P/V. Returns (bus V, currents).
fn battery_and_drivers(world: &WorldConfig, p_sides: Sides<f64>) -> (f64, Sides<f64>) {
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
    (bus_v, current)
}
