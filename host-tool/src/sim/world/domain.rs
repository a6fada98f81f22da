//! The domain of every world parameter ([`WorldConfig::validate`]).

use super::{WorldConfig, WorldError};

/// The domain checks, naming `origin` in their errors.
struct Check<'a> {
    origin: &'a str,
}

impl Check<'_> {
    fn bad(&self, key: &str, v: f64, what: &str) -> Result<(), WorldError> {
        self.invalid(key, format!("= {v} must be {what}"))
    }
    fn invalid(&self, key: &str, reason: String) -> Result<(), WorldError> {
        Err(WorldError::Invalid {
            origin: self.origin.to_string(),
            key: key.to_string(),
            reason,
        })
    }
    fn pos(&self, key: &str, v: f64) -> Result<(), WorldError> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            self.bad(key, v, "finite and > 0")
        }
    }
    fn nonneg(&self, key: &str, v: f64) -> Result<(), WorldError> {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            self.bad(key, v, "finite and ≥ 0")
        }
    }
    fn fin(&self, key: &str, v: f64) -> Result<(), WorldError> {
        if v.is_finite() {
            Ok(())
        } else {
            self.bad(key, v, "finite")
        }
    }
}

impl WorldConfig {
    /// Checks every parameter's domain.
    pub fn validate(&self, origin: &str) -> Result<(), WorldError> {
        let c = Check { origin };
        self.check_plant(&c)?;
        self.check_sensors(&c)?;
        self.check_mechanical_effects(&c)?;
        self.check_electrical_effects(&c)
    }

    /// The ICR model, battery, drivers, structure and motors.
    fn check_plant(&self, c: &Check<'_>) -> Result<(), WorldError> {
        c.nonneg("icr.mu", self.icr.mu)?;
        c.nonneg("icr.rolling_resistance_n", self.icr.rolling_resistance_n)?;
        c.pos("icr.slip_track_m", self.icr.slip_track_m)?;
        c.pos(
            "icr.traction_fade_radius_m",
            self.icr.traction_fade_radius_m,
        )?;
        c.pos("battery.nominal_v", self.battery.nominal_v)?;
        c.nonneg(
            "battery.internal_resistance_ohm",
            self.battery.internal_resistance_ohm,
        )?;
        c.nonneg(
            "driver.quiescent_current_a",
            self.driver.quiescent_current_a,
        )?;
        let iq = self.driver.quiescent_a();
        c.nonneg("driver.left_quiescent_current_a", iq.left)?;
        c.nonneg("driver.right_quiescent_current_a", iq.right)?;
        let s = &self.structure;
        if !(0.0..=0.5).contains(&s.angular_slip) {
            c.bad("structure.angular_slip", s.angular_slip, "in [0, 0.5]")?;
        }
        if let Some(rt) = s.threshold_radius_m {
            if self.traction_fade_radius_m().is_none() {
                c.bad(
                    "structure.threshold_radius_m",
                    rt,
                    "above R' with a rolling resistance G below the tread force F/B_s \
                     (else the inner side never regenerates)",
                )?;
            }
        }
        c.pos(
            "motor.torque_constant_nm_per_a",
            self.motor.torque_constant_nm_per_a,
        )?;
        c.pos("motor.gear_ratio", self.motor.gear_ratio)?;
        if !(self.motor.efficiency > 0.0 && self.motor.efficiency <= 1.0) {
            c.bad("motor.efficiency", self.motor.efficiency, "in (0, 1]")?;
        }
        c.nonneg(
            "motor.winding_resistance_ohm",
            self.motor.winding_resistance_ohm,
        )?;
        Ok(())
    }

    /// The sensor noise, the pose tracker and the terrain factors.
    fn check_sensors(&self, c: &Check<'_>) -> Result<(), WorldError> {
        let n = &self.noise;
        c.nonneg("noise.left_current_std_a", n.left_current_std_a)?;
        c.nonneg("noise.right_current_std_a", n.right_current_std_a)?;
        c.nonneg("noise.bus_std_v", n.bus_std_v)?;
        c.nonneg("noise.yaw_std_rad", n.yaw_std_rad)?;
        c.nonneg("noise.pitch_std_deg", n.pitch_std_deg)?;
        let tr = &self.tracker;
        if !tr.offset_m.is_finite() {
            c.bad("tracker.offset_m", tr.offset_m, "a finite number")?;
        }
        c.nonneg("tracker.rate_hz", tr.rate_hz)?;
        c.nonneg("tracker.position_std_m", tr.position_std_m)?;
        if !(0.0..=0.5).contains(&tr.dropout) {
            c.bad("tracker.dropout", tr.dropout, "in [0, 0.5]")?;
        }
        for (key, v) in [
            ("noise.manoeuvre_power_std", n.manoeuvre_power_std),
            ("noise.run_power_std", n.run_power_std),
        ] {
            if !(0.0..=0.5).contains(&v) {
                c.bad(key, v, "in [0, 0.5]")?;
            }
        }
        Ok(())
    }

    /// The effects acting through wheel torque or yaw rate.
    fn check_mechanical_effects(&self, c: &Check<'_>) -> Result<(), WorldError> {
        let e = &self.effects;
        c.nonneg("inner-drag.torque_nm", e.inner_drag.torque_nm)?;
        c.pos("inner-drag.ramp_s", e.inner_drag.ramp_s)?;
        let sb = &e.sinkage_bulldozing;
        c.nonneg(
            "sinkage-bulldozing.resistance_n_per_mm",
            sb.resistance_n_per_mm,
        )?;
        c.nonneg(
            "sinkage-bulldozing.counter_rotation_gain",
            sb.counter_rotation_gain,
        )?;
        if let Err(err) = model_core::soil::SlipSinkage2d::new(sb.sinkage_params()) {
            c.invalid("sinkage-bulldozing", format!("sinkage parameters: {err}"))?;
        }
        if let Err(err) = model_core::soil::SandBulldozing::new(sb.soil()) {
            c.invalid("sinkage-bulldozing", format!("soil parameters: {err}"))?;
        }
        for (key, v) in [
            ("angular-slip.at_zero", e.angular_slip.at_zero),
            ("angular-slip.at_r_prime", e.angular_slip.at_r_prime),
        ] {
            if !(0.0..=0.95).contains(&v) {
                c.bad(key, v, "in [0, 0.95]")?;
            }
        }
        let n = e.angular_slip.decay_exponent;
        if !(0.0..=10.0).contains(&n) {
            c.bad("angular-slip.decay_exponent", n, "in [0, 10]")?;
        }
        if let Some(b) = e.slip_track.slip_track_m {
            c.pos("slip-track.slip_track_m", b)?;
        }
        c.nonneg("braked-inner.resistance_n", e.braked_inner.resistance_n)?;
        c.nonneg("braked-inner.held_speed_mps", e.braked_inner.held_speed_mps)?;
        Ok(())
    }

    /// The effects acting on the electrical power directly (and the slope).
    fn check_electrical_effects(&self, c: &Check<'_>) -> Result<(), WorldError> {
        let e = &self.effects;
        c.fin("current-offset.left_a", e.current_offset.left_a)?;
        c.fin("current-offset.right_a", e.current_offset.right_a)?;
        let mh = &e.motor_heating;
        c.pos(
            "motor-heating.thermal_resistance_k_per_w",
            mh.thermal_resistance_k_per_w,
        )?;
        c.pos("motor-heating.time_constant_s", mh.time_constant_s)?;
        c.nonneg(
            "motor-heating.resistance_coefficient_per_k",
            mh.resistance_coefficient_per_k,
        )?;
        c.pos("motor-heating.max_rise_k", mh.max_rise_k)?;
        c.nonneg("slope.phi", e.slope.phi)?;
        c.fin("slope.pitch_deg", e.slope.pitch_deg)?;
        c.fin("slope.amplitude_deg", e.slope.amplitude_deg)?;
        if e.slope.pitch_deg.abs() + e.slope.amplitude_deg.abs() > 45.0 {
            c.bad(
                "slope.pitch_deg",
                e.slope.pitch_deg,
                "within ±45° together with amplitude_deg",
            )?;
        }
        c.pos("slope.wavelength_m", e.slope.wavelength_m)?;
        Ok(())
    }
}
