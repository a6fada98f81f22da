//! The domain of every world parameter ([`WorldConfig::validate`]).

use super::{WorldConfig, WorldError};

impl WorldConfig {
    /// Checks every parameter's domain.
    pub fn validate(&self, origin: &str) -> Result<(), WorldError> {
        let bad = |key: &str, v: f64, what: &str| -> Result<(), WorldError> {
            Err(WorldError::Invalid {
                origin: origin.to_string(),
                key: key.to_string(),
                reason: format!("= {v} must be {what}"),
            })
        };
        let pos = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                bad(key, v, "finite and > 0")
            }
        };
        let nonneg = |key: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                bad(key, v, "finite and ≥ 0")
            }
        };
        let fin = |key: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                bad(key, v, "finite")
            }
        };
        nonneg("icr.mu", self.icr.mu)?;
        nonneg("icr.rolling_resistance_n", self.icr.rolling_resistance_n)?;
        pos("icr.slip_track_m", self.icr.slip_track_m)?;
        pos(
            "icr.traction_fade_radius_m",
            self.icr.traction_fade_radius_m,
        )?;
        pos("battery.nominal_v", self.battery.nominal_v)?;
        nonneg(
            "battery.internal_resistance_ohm",
            self.battery.internal_resistance_ohm,
        )?;
        nonneg(
            "driver.quiescent_current_a",
            self.driver.quiescent_current_a,
        )?;
        let iq = self.driver.quiescent_a();
        nonneg("driver.left_quiescent_current_a", iq.left)?;
        nonneg("driver.right_quiescent_current_a", iq.right)?;
        let s = &self.structure;
        if !(0.0..=0.5).contains(&s.angular_slip) {
            bad("structure.angular_slip", s.angular_slip, "in [0, 0.5]")?;
        }
        if let Some(rt) = s.threshold_radius_m {
            if self.traction_fade_radius_m().is_none() {
                bad(
                    "structure.threshold_radius_m",
                    rt,
                    "above R' with a rolling resistance G below the tread force F/B_s \
                     (else the inner side never regenerates)",
                )?;
            }
        }
        pos(
            "motor.torque_constant_nm_per_a",
            self.motor.torque_constant_nm_per_a,
        )?;
        pos("motor.gear_ratio", self.motor.gear_ratio)?;
        if !(self.motor.efficiency > 0.0 && self.motor.efficiency <= 1.0) {
            bad("motor.efficiency", self.motor.efficiency, "in (0, 1]")?;
        }
        nonneg(
            "motor.winding_resistance_ohm",
            self.motor.winding_resistance_ohm,
        )?;
        let n = &self.noise;
        nonneg("noise.left_current_std_a", n.left_current_std_a)?;
        nonneg("noise.right_current_std_a", n.right_current_std_a)?;
        nonneg("noise.bus_std_v", n.bus_std_v)?;
        nonneg("noise.yaw_std_rad", n.yaw_std_rad)?;
        nonneg("noise.pitch_std_deg", n.pitch_std_deg)?;
        let tr = &self.tracker;
        if !tr.offset_m.is_finite() {
            bad("tracker.offset_m", tr.offset_m, "a finite number")?;
        }
        nonneg("tracker.rate_hz", tr.rate_hz)?;
        nonneg("tracker.position_std_m", tr.position_std_m)?;
        if !(0.0..=0.5).contains(&tr.dropout) {
            bad("tracker.dropout", tr.dropout, "in [0, 0.5]")?;
        }
        for (key, v) in [
            ("noise.manoeuvre_power_std", n.manoeuvre_power_std),
            ("noise.run_power_std", n.run_power_std),
        ] {
            if !(0.0..=0.5).contains(&v) {
                bad(key, v, "in [0, 0.5]")?;
            }
        }
        let e = &self.effects;
        nonneg("inner-drag.torque_nm", e.inner_drag.torque_nm)?;
        pos("inner-drag.ramp_s", e.inner_drag.ramp_s)?;
        let sb = &e.sinkage_bulldozing;
        nonneg(
            "sinkage-bulldozing.resistance_n_per_mm",
            sb.resistance_n_per_mm,
        )?;
        nonneg(
            "sinkage-bulldozing.counter_rotation_gain",
            sb.counter_rotation_gain,
        )?;
        if let Err(err) = model_core::soil::SlipSinkage2d::new(sb.sinkage_params()) {
            return Err(WorldError::Invalid {
                origin: origin.to_string(),
                key: "sinkage-bulldozing".into(),
                reason: format!("sinkage parameters: {err}"),
            });
        }
        if let Err(err) = model_core::soil::SandBulldozing::new(sb.soil()) {
            return Err(WorldError::Invalid {
                origin: origin.to_string(),
                key: "sinkage-bulldozing".into(),
                reason: format!("soil parameters: {err}"),
            });
        }
        for (key, v) in [
            ("angular-slip.at_zero", e.angular_slip.at_zero),
            ("angular-slip.at_r_prime", e.angular_slip.at_r_prime),
        ] {
            if !(0.0..=0.95).contains(&v) {
                bad(key, v, "in [0, 0.95]")?;
            }
        }
        let n = e.angular_slip.decay_exponent;
        if !(0.0..=10.0).contains(&n) {
            bad("angular-slip.decay_exponent", n, "in [0, 10]")?;
        }
        if let Some(b) = e.slip_track.slip_track_m {
            pos("slip-track.slip_track_m", b)?;
        }
        nonneg("braked-inner.resistance_n", e.braked_inner.resistance_n)?;
        nonneg("braked-inner.held_speed_mps", e.braked_inner.held_speed_mps)?;
        fin("current-offset.left_a", e.current_offset.left_a)?;
        fin("current-offset.right_a", e.current_offset.right_a)?;
        let mh = &e.motor_heating;
        pos(
            "motor-heating.thermal_resistance_k_per_w",
            mh.thermal_resistance_k_per_w,
        )?;
        pos("motor-heating.time_constant_s", mh.time_constant_s)?;
        nonneg(
            "motor-heating.resistance_coefficient_per_k",
            mh.resistance_coefficient_per_k,
        )?;
        pos("motor-heating.max_rise_k", mh.max_rise_k)?;
        nonneg("slope.phi", e.slope.phi)?;
        fin("slope.pitch_deg", e.slope.pitch_deg)?;
        fin("slope.amplitude_deg", e.slope.amplitude_deg)?;
        if e.slope.pitch_deg.abs() + e.slope.amplitude_deg.abs() > 45.0 {
            bad(
                "slope.pitch_deg",
                e.slope.pitch_deg,
                "within ±45° together with amplitude_deg",
            )?;
        }
        pos("slope.wavelength_m", e.slope.wavelength_m)?;
        Ok(())
    }
}
