//! The copper-loss history of a run, for the `motor-heating` term (Section 1.1.3: winding
//! resistance rises with temperature). A winding heats with its own copper loss I²R through a
//! first-order thermal mass, so its temperature rise follows a low-pass of I² with the thermal
//! time constant τ, and its extra loss is I²·R·α·ΔT ∝ I²·x_τ. Taken from the measured current
//! sample by sample, x_τ knows which manoeuvres came before (a point turn heats more than a
//! straight), which the run time alone does not: that is what tells heating apart from a term
//! of the turn itself when the runs drive the turn set in different orders.

/// The thermal time constants the `motor-heating` term is tried with [s] (small gearmotors:
/// minutes to tens of minutes); the choice counts as one fitted parameter.
pub const HEATING_TAU_GRID_S: [f64; 6] = [60.0, 150.0, 300.0, 600.0, 1200.0, 2400.0];

/// The winding's first-order temperature rise at run time `t_s` as a fraction of its final
/// value, 1 − e^(−t/τ) (a constant mean copper loss heating a first-order thermal mass).
pub fn heating_rise(t_s: f64, tau_s: f64) -> f64 {
    if tau_s > 0.0 {
        1.0 - (-t_s.max(0.0) / tau_s).exp()
    } else {
        1.0
    }
}

/// How many time constants are tried.
pub const TAUS: usize = HEATING_TAU_GRID_S.len();

/// Per τ of [`HEATING_TAU_GRID_S`], per side (left, right): a manoeuvre's mean of I²·x_τ [A⁴].
pub type CopperHeat = [[f64; 2]; TAUS];

/// The winding state of both sides through one run, cold at its start.
#[derive(Debug, Clone, Default)]
pub struct WindingHeat {
    /// x_τ per τ and side: I² low-passed with time constant τ [A²].
    state: CopperHeat,
    last_t_s: Option<f64>,
    /// The step the gains below were computed for [s] (samples are evenly spaced, so the
    /// exponentials are rarely recomputed).
    gain_dt_s: f64,
    /// 1 − e^(−dt/τ) per τ.
    gain: [f64; TAUS],
}

impl WindingHeat {
    /// Advances the windings to the sample at `t_s` with these side currents and returns
    /// I²·x_τ per τ and side at it.
    pub fn push(&mut self, t_s: f64, current_a: [f64; 2]) -> CopperHeat {
        let dt = self.last_t_s.map_or(0.0, |t0| (t_s - t0).max(0.0));
        self.last_t_s = Some(t_s);
        if (dt - self.gain_dt_s).abs() > 1e-9 {
            self.gain_dt_s = dt;
            for (g, tau) in self.gain.iter_mut().zip(HEATING_TAU_GRID_S) {
                *g = -(-dt / tau).exp_m1();
            }
        }
        let sq = current_a.map(|i| i * i);
        let mut out = [[0.0; 2]; TAUS];
        for ((x, g), o) in self.state.iter_mut().zip(self.gain).zip(out.iter_mut()) {
            for side in 0..2 {
                x[side] += (sq[side] - x[side]) * g;
                o[side] = sq[side] * x[side];
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant current heats x_τ to I² with the first-order rise 1 − e^(−t/τ), so I²·x_τ
    /// reaches I⁴ (1 − e^(−t/τ)) at t.
    #[test]
    fn a_constant_current_rises_first_order() {
        let mut w = WindingHeat::default();
        let dt = 0.02;
        let mut last = [[0.0; 2]; TAUS];
        for k in 0..=3000 {
            last = w.push(k as f64 * dt, [2.0, 0.0]);
        }
        for (k, tau) in HEATING_TAU_GRID_S.iter().enumerate() {
            let want = 16.0 * (1.0 - (-60.0 / tau).exp());
            assert!(
                (last[k][0] - want).abs() < 1e-3 * want,
                "τ = {tau}: {}",
                last[k][0]
            );
            assert_eq!(last[k][1], 0.0);
        }
    }

    /// Heat left by an earlier burst of current decays, and a later sample at a small current
    /// carries it: the history, not the run time, sets the term.
    #[test]
    fn heat_from_an_earlier_burst_decays() {
        let mut w = WindingHeat::default();
        for k in 0..500 {
            w.push(k as f64 * 0.1, [5.0, 5.0]);
        }
        let after_burst = w.push(50.0, [1.0, 1.0]);
        for k in 501..1100 {
            w.push(k as f64 * 0.1, [1.0, 1.0]);
        }
        let later = w.push(110.0, [1.0, 1.0]);
        // τ = 60 s: the burst's heat has largely gone a minute later.
        assert!(later[0][0] < 0.6 * after_burst[0][0]);
        // A run that never saw the burst sits lower still.
        let mut cold = WindingHeat::default();
        for k in 0..1100 {
            cold.push(k as f64 * 0.1, [1.0, 1.0]);
        }
        assert!(cold.push(110.0, [1.0, 1.0])[0][0] < later[0][0]);
    }
}
