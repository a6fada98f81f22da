//! The noise the separations are in: the repeat noise of manoeuvres driven alike, and the
//! misfit the best model leaves out of sample, the same on every repeat.

use super::super::diagnosis::Diagnosis;
use super::super::features::{Observed, TurnRow};
use super::super::stats::PRACTICAL_FLOOR_W;

/// The smallest noise σ taken, a fraction of the practical floor (a perfectly repeatable
/// simulation would otherwise make every difference infinitely many σ).
const MIN_SIGMA_OF_FLOOR: f64 = 0.05;

/// The noise a separation is measured against: the repeat noise, and the misfit the best
/// model leaves (held-out), which is the same on every repeat of a manoeuvre.
#[derive(Debug, Clone, Copy)]
pub(super) struct Noise {
    repeat_w: f64,
    misfit_w: f64,
}

impl Noise {
    /// The repeat noise `repeat_w` and the misfit of `d`'s best model: the held-out RMS error
    /// of its best candidate, of the baseline alone or of the diagnosed model with its stepwise
    /// steps, whichever is lowest, beyond the repeat noise.
    fn of(repeat_w: f64, d: &Diagnosis) -> Self {
        // The diagnosed model with its stepwise steps, when it has them, leaves the least.
        let stepwise = d.secondary.last().map(|s| s.heldout_error_after);
        let best = d
            .candidates
            .first()
            .map(|c| c.heldout_error_after.min(c.heldout_error_before))
            .into_iter()
            .chain(stepwise)
            .filter(|e| e.is_finite())
            .reduce(f64::min)
            .unwrap_or(repeat_w);
        Self {
            repeat_w,
            misfit_w: (best * best - repeat_w * repeat_w).max(0.0).sqrt(),
        }
    }

    /// σ of one side of one manoeuvre [W].
    pub(super) fn sigma_w(&self) -> f64 {
        self.repeat_w.hypot(self.misfit_w)
    }

    /// The weight of each of `n` repeats of one manoeuvre: their mean is worth n / (1 + (n − 1)ρ)
    /// independent drives, ρ the misfit's share of the variance (the design effect of
    /// correlated repeats).
    pub(super) fn repeat_weight(&self, n: u32) -> f64 {
        let total = self.sigma_w().powi(2);
        let rho = if total > 0.0 {
            self.misfit_w.powi(2) / total
        } else {
            0.0
        };
        1.0 / (1.0 + f64::from(n.saturating_sub(1)) * rho)
    }
}

/// Manoeuvres driven alike: R/R′ in hundredths (straights `i64::MAX`), v_c in cm/s, the turned
/// angle in tens of degrees, and the side (2: a total-only row).
type DriveKey = (i64, i64, i64, usize);

/// The repeat noise of one side of one manoeuvre [W] and where it was measured: the pooled
/// standard deviation of the effective power of manoeuvres driven alike (radius, v_c and turned
/// angle), over the diagnosed and calibration runs; else the calibration's lack-of-fit test's
/// pure error; else the practical floor.
fn repeat_noise(train: &[&TurnRow], d: &Diagnosis) -> (f64, String) {
    let mut groups: Vec<(DriveKey, Vec<f64>)> = Vec::new();
    for row in train {
        let angle = (row.expected_duration_s * row.yaw_rate_cmd_rad_s).to_degrees();
        let key_of = |side| {
            (
                if row.is_straight() {
                    i64::MAX
                } else {
                    (row.r_over_r_prime * 100.0).round() as i64
                },
                (row.v_c_mps * 100.0).round() as i64,
                (angle / 10.0).round() as i64,
                side,
            )
        };
        let values: Vec<(usize, f64)> = match row.observed {
            Observed::Sides => vec![
                (0, row.sides[0].effective_power_w),
                (1, row.sides[1].effective_power_w),
            ],
            Observed::Total { avg_power_w } => vec![(2, avg_power_w)],
        };
        for (side, v) in values {
            if !v.is_finite() {
                continue;
            }
            let key = key_of(side);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, g)) => g.push(v),
                None => groups.push((key, vec![v])),
            }
        }
    }
    let (mut ss, mut df) = (0.0, 0usize);
    for (_, g) in &groups {
        if g.len() < 2 {
            continue;
        }
        let mean = g.iter().sum::<f64>() / g.len() as f64;
        ss += g.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        df += g.len() - 1;
    }
    let floor = MIN_SIGMA_OF_FLOOR * PRACTICAL_FLOOR_W;
    if df >= 2 {
        return (
            (ss / df as f64).sqrt().max(floor),
            format!("manoeuvres driven alike, {df} df"),
        );
    }
    let pure = d
        .adequacy
        .per_side
        .as_ref()
        .unwrap_or(&d.adequacy.total)
        .repeat_sigma_w;
    if pure.is_finite() && pure > 0.0 {
        return (pure.max(floor), "the calibration's repeats".into());
    }
    (
        PRACTICAL_FLOOR_W,
        "no repeated manoeuvre: the practical floor taken".into(),
    )
}

/// Decides the σ of one side of one manoeuvre the separations are in, and says where it came
/// from.
pub(super) fn measure_noise(train: &[&TurnRow], d: &Diagnosis) -> (Noise, String) {
    let (repeat_w, repeat_from) = repeat_noise(train, d);
    let noise = Noise::of(repeat_w, d);
    let noise_from = format!(
        "repeat noise {repeat_w:.2} W ({repeat_from}) and {:.2} W the best model leaves \
         unexplained out of sample, the same on every repeat",
        noise.misfit_w
    );
    (noise, noise_from)
}
