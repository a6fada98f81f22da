//! `angular-slip` (thesis Section 6.2, Eq 6.3, Fig 6.7–6.8): the rover yaws slower than
//! commanded, most at R′.
//!
//! - Term (time-type): P_side·(1 − ρ, ρ) for ρ = R/R′ ≤ 1, P_side·(0, 1/ρ) above; 0 on
//!   straights.
//! - Mark: the yaw-timed slip of the turns with 0 < R ≤ R′ beyond the point turns': one-sided
//!   t ≥ 0, rise ≥ 2 %, per regime, Bonferroni ×3; measured without the power model.
//!   Inconclusive when a drive's top speed explains those turns as well ([`speed_ceiling`]).

use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, Measurement, PathSegment, MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::matched_slip::{
    asymmetry_slip, supply_below_calibration, supply_words, yaw_slips,
};
use crate::diagnose::signature::{Evidence, Signature, SignatureTest, ALPHA, MIN_SLIP_EXCESS};
use crate::diagnose::speed_ceiling;
use crate::diagnose::stats::{moments, one_sample_upper, welch_upper};
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;

/// `angular-slip`.
#[derive(Debug)]
pub struct AngularSlip;

impl Effect for AngularSlip {
    fn id(&self) -> EffectId {
        EffectId::AngularSlip
    }
    fn param_count(&self) -> usize {
        2
    }
    fn power_type(&self) -> bool {
        false
    }
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        if row.is_straight() {
            return Some([0.0, 0.0]);
        }
        let p = ctx.baseline.side_power_w(row, side);
        let rho = row.r_over_r_prime;
        Some(if rho <= 1.0 {
            [p * (1.0 - rho), p * rho]
        } else {
            [0.0, p / rho]
        })
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::YawTiming
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        angular_slip(ev)
    }
    fn mark_rises_towards_r_prime(&self) -> bool {
        true
    }
    // Slip rising from the point turn towards R′, timed by yaw.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![
            MarkDrive::turn(0.0, 90.0, 1),
            MarkDrive::turn(2.0 / 3.0, 90.0, 2),
        ]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "a pose track: each turn's actual radius and yaw rate (thesis Section 5.1), which tell the ground's slip from a drive that lags or cannot hold its wheel",
            pose_track: true,
        }
    }
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        Some(match () {
            () if s.line => vec![0.0, 0.0],
            () if s.rho <= 1.0 => vec![s.e_hg_j * (1.0 - s.rho), s.e_hg_j * s.rho],
            () => vec![0.0, s.e_hg_j / s.rho],
        })
    }
}

/// `angular-slip`: the turns between the point turn and R′ slower by yaw than the point turns
/// (the runs', else the calibration's), by at least [`MIN_SLIP_EXCESS`] (the thesis' Fig 6.8:
/// 0.27 at R = 0 to 0.38 at R′ on sand). Under the constant total-absolute-velocity constraint
/// (Eq 2.6) these turns share the point turn's yaw rate, so a slip that grows with the yaw rate
/// or a lagging speed loop does not rise; a slip constant over the radii does not either. The
/// point turns' mean is itself measured: Welch t when there are two or more. A side asymmetry
/// also raises it ([`asymmetry_slip`], read off the straights): the rise must exceed that.
fn angular_slip(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::AngularSlip;
    // The runs' own point turns, on the same terrain; the calibration's when they have none.
    if let Some(supply) = supply_below_calibration(ev.rows, ev.calibration_rows) {
        return Signature::masked(e, supply_words(supply));
    }
    let is_point = |r: &TurnRow| r.regime == Regime::Point;
    let mut point = yaw_slips(ev.rows, is_point);
    let mut whose = "the point turns'";
    if point.is_empty() {
        point = yaw_slips(ev.calibration_rows, is_point);
        whose = "the calibration's point turns'";
    }
    let Some((point_mean, _, _)) = moments(&point) else {
        if !ev.yaw_logged() {
            return Signature::masked(e, "no yaw logged");
        }
        return Signature::unobservable(e, "no point turn timed by yaw to compare with");
    };
    let regimes = [
        Regime::BelowHalfTrack,
        Regime::DraggedInner,
        Regime::AtRPrime,
    ];
    // What a side asymmetry, seen turning the straights, could raise by itself.
    let asymmetry = asymmetry_slip(ev.rows);
    let asymmetric = if asymmetry >= 0.005 {
        format!(
            "; the straights turn as sides that differ by {:.1} % would, which can raise it by \
             {:.1} % (taken off)",
            200.0 * asymmetry,
            100.0 * asymmetry
        )
    } else {
        String::new()
    };
    let mut best: Option<(SignatureTest, String)> = None;
    for regime in regimes {
        let slips = yaw_slips(ev.rows, |r| r.regime == regime);
        let rise = if point.len() >= 2 {
            welch_upper(&slips, &point).map(|(d, t, df, p)| (d, t, df, p, "Welch t"))
        } else {
            let shifted: Vec<f64> = slips.iter().map(|s| s - point_mean).collect();
            one_sample_upper(&shifted, 0.0)
                .map(|(t, df, p)| (moments(&shifted).map_or(0.0, |m| m.0), t, df, p, "t"))
        };
        let Some((mean, t, df, p, statistic_name)) = rise else {
            continue;
        };
        let p = (p * regimes.len() as f64).min(1.0);
        let test = SignatureTest {
            statistic_name,
            statistic: t,
            df,
            p,
            present: p < ALPHA && mean - asymmetry >= MIN_SLIP_EXCESS,
            sized: mean - asymmetry >= MIN_SLIP_EXCESS,
        };
        let detail = format!(
            "{} turns ({}) slip {:+.1} % beyond {whose} {:.1} % ({} turn(s)){asymmetric}",
            regime.id(),
            slips.len(),
            100.0 * mean,
            100.0 * point_mean,
            point.len()
        );
        if best
            .as_ref()
            .is_none_or(|(b, _)| (test.present, -test.p) > (b.present, -b.p))
        {
            best = Some((test, detail));
        }
    }
    match best {
        Some((mut test, mut detail)) => {
            // R′ commands the fastest wheel of the drive set: a drive's top speed is the rival.
            if test.sized {
                if let Some(ceiling) =
                    speed_ceiling::explains(ev.rows, ev.calibration_rows, point_mean, asymmetry)
                {
                    test.present = false;
                    detail = format!("{detail}; {}", ceiling.words());
                }
            }
            Signature::tested(e, test, detail)
        }
        None => Signature::unobservable(
            e,
            "fewer than 2 turns timed by yaw in each regime between the point turn and R′",
        ),
    }
}
