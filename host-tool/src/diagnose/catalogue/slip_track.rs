//! `slip-track` (thesis Appendix D, Table D.1, Eq 2.2): the terrain's slip track differs from
//! the controller's, so every turn's yaw rate scales by B_s,ctrl/B_s,terrain.
//!
//! - Term (time-type): P_side on turns.
//! - Mark: the turns' yaw-timed slip beyond the calibration runs' own turns driven alike (same
//!   radius, yaw rate and angle), the same on every turn (not rising towards R′: angular slip's
//!   mark absent); with a pose track, the measured slip track against the calibration's.
//!   Two-sided t, |difference| ≥ 2 %.

use crate::diagnose::baseline::family::MAX_SLIP_SPREAD;
use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, Measurement, PathSegment, SignRule, MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::matched_slip::{
    slip_against_calibration, supply_below_calibration, supply_words, yaw_slips,
    SlipAgainstCalibration,
};
use crate::diagnose::signature::{
    Evidence, Signature, SignatureTest, ALPHA, MIN_SLIP_EXCESS, MIN_SLIP_TRACK_DIFFERENCE,
};
use crate::diagnose::stats::{moments, one_sample_upper, t_upper, welch_upper};
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;

/// `slip-track`.
#[derive(Debug)]
pub struct SlipTrack;

impl Effect for SlipTrack {
    fn id(&self) -> EffectId {
        EffectId::SlipTrack
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
        Some(if row.is_straight() {
            [0.0, 0.0]
        } else {
            [ctx.baseline.side_power_w(row, side), 0.0]
        })
    }
    fn sign_rule(&self) -> SignRule {
        SignRule::NonNegativeUnlessTurnsQuickerByYaw
    }
    // A slip track scales every turn alike and a straight has no yaw to scale.
    fn scales_every_turn(&self) -> bool {
        true
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::YawTiming
    }
    fn reads_other_marks(&self) -> bool {
        true
    }
    fn mark(&self, ev: &Evidence<'_>, marks: &Marks<'_>) -> Signature {
        slip_track(ev, marks.present_where(|e| e.mark_rises_towards_r_prime()))
    }
    // Every turn slipping alike, timed by yaw.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![MarkDrive::turn(2.0, 90.0, 2)]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "a pose track (motion capture, or RTK GNSS at 5 Hz or more): it measures the slip track itself (thesis Appendix D), which the yaw timing cannot tell from a terrain-wide angular slip",
            pose_track: true,
        }
    }
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        Some(vec![s.e_hg_j])
    }
}

/// `slip-track`: with a pose track, the measured slip track off the calibration's measured
/// one (else off the controller's B_s) by [`MIN_SLIP_TRACK_DIFFERENCE`]; else the turns'
/// yaw-timed slip off the calibration's own turns driven alike ([`slip_against_calibration`])
/// by [`MIN_SLIP_EXCESS`], either way (a narrower track makes turns quicker), and the same on
/// every turn: not rising from the point turn towards R′ as angular slip does (`slip_rises`,
/// its signature), and each radius' mean within [`MAX_SLIP_SPREAD`] of the common mean.
fn slip_track(ev: &Evidence<'_>, slip_rises: bool) -> Signature {
    let e = EffectId::SlipTrack;
    if let Some(pose) = by_pose(ev) {
        return pose;
    }
    if let Some(supply) = supply_below_calibration(ev.rows, ev.calibration_rows) {
        return Signature::masked(e, supply_words(supply));
    }
    let m =
        match slip_against_calibration(ev.rows, ev.calibration_rows, |_| true) {
            SlipAgainstCalibration::Measured(m) => m,
            SlipAgainstCalibration::NoCalibrationRuns => return Signature::masked(
                e,
                "no calibration runs and no pose track: the turns' slip has no reference ground \
                 to be compared with (drive calibration runs on the reference ground, or log a \
                 pose track)",
            ),
            SlipAgainstCalibration::NoYawTimedTurns if !ev.yaw_logged() => {
                return Signature::masked(e, "no yaw logged and no pose track")
            }
            SlipAgainstCalibration::NoYawTimedTurns => {
                return Signature::unobservable(e, "no turn timed by yaw and no pose track")
            }
            SlipAgainstCalibration::NotMatched { turns } => {
                return Signature::unobservable(
                    e,
                    format!(
                    "none of the {turns} turn(s) timed by yaw was driven as a calibration turn \
                     was (radius, yaw rate and turned angle)"
                ),
                )
            }
            SlipAgainstCalibration::TooFew { turns } => {
                return Signature::unobservable(
                    e,
                    format!(
                    "{turns} turn(s) driven as the calibration's, one per condition: no spread to \
                     test against"
                ),
                )
            }
        };
    // By yaw, a slip rising from the point turn towards R′ is angular slip's mark: not the
    // same fraction on every turn.
    let rises = slip_rises;
    // A slip track rescales every turn's yaw rate by the same B_s,ctrl/B_s (Eq 2.2): a slip
    // that differs between the runs' radii (anything that resists the turn more at some radii,
    // such as sand piling up at the point turn) is not it. The same spread the baseline allows
    // a constant calibration slip.
    let spread = regime_spread(ev);
    let uneven = spread > MAX_SLIP_SPREAD;
    let sized = m.difference.abs() >= MIN_SLIP_EXCESS && !rises && !uneven;
    let p = (2.0 * t_upper(m.t.abs(), m.df)).min(1.0);
    let test = SignatureTest {
        statistic_name: "t",
        statistic: m.t,
        df: m.df,
        p,
        present: p < ALPHA && sized,
        sized,
    };
    let shape = if rises {
        "; but it rises from the point turn towards R′ (angular slip), not the same on every turn"
            .to_string()
    } else if uneven {
        format!(
            "; but a radius' mean differs from the runs' common mean by {:.1} %, not the same on \
             every turn",
            100.0 * spread
        )
    } else {
        String::new()
    };
    Signature::tested(
        e,
        test,
        format!(
            "{} turn(s) timed by yaw slip {:+.1} % beyond {} calibration turn(s) driven alike \
             ({} condition(s): radius, yaw rate and angle){shape}",
            m.turns,
            100.0 * m.difference,
            m.calibration_turns,
            m.conditions
        ),
    )
}

/// With a pose track: the measured slip track relative to the calibration runs' measured one
/// (Welch), or to the controller's B_s without one (the calibration ground's own is then not
/// known); two-sided, [`MIN_SLIP_TRACK_DIFFERENCE`]. `None` with fewer than 2 measured turns.
fn by_pose(ev: &Evidence<'_>) -> Option<Signature> {
    let measured = |rows: &[TurnRow]| -> Vec<f64> {
        rows.iter()
            .filter_map(|r| r.measured.map(|m| m.slip_track_m))
            .filter(|v| v.is_finite())
            .collect()
    };
    let runs = measured(ev.rows);
    if runs.len() < 2 {
        return None;
    }
    let calibration = measured(ev.calibration_rows);
    let (reference_m, against) = match moments(&calibration) {
        Some((mean, _, n)) if n >= 2 => (
            mean,
            format!("the calibration runs' measured {mean:.3} m ({n} turns)"),
        ),
        _ => {
            let b_s = ev.baseline.slip_track_m;
            (b_s, format!("the controller's B_s {b_s:.3} m"))
        }
    };
    let relative = |v: &[f64]| -> Vec<f64> { v.iter().map(|m| m / reference_m - 1.0).collect() };
    let (values, reference) = (relative(&runs), relative(&calibration));
    let (mean, _, n) = moments(&values)?;
    let (t, df) = if reference.len() >= 2 {
        let (_, t, df, _) = welch_upper(&values, &reference)?;
        (t, df)
    } else {
        let (t, df, _) = one_sample_upper(&values, 0.0)?;
        (t, df)
    };
    let p = (2.0 * t_upper(t.abs(), df)).min(1.0);
    let sized = mean.abs() >= MIN_SLIP_TRACK_DIFFERENCE;
    let test = SignatureTest {
        statistic_name: if reference.len() >= 2 { "Welch t" } else { "t" },
        statistic: t,
        df,
        p,
        present: p < ALPHA && sized,
        sized,
    };
    Some(Signature::tested(
        EffectId::SlipTrack,
        test,
        format!(
            "the pose track's slip track relative to {against}: {:+.1} % over {n} turn(s)",
            100.0 * mean
        ),
    ))
}

/// Largest distance of a radius' mean yaw-timed slip (regimes with 2 or more such turns) from
/// the runs' common mean: measured within the runs, no reference needed.
fn regime_spread(ev: &Evidence<'_>) -> f64 {
    let Some((mean, _, _)) = moments(&yaw_slips(ev.rows, |_| true)) else {
        return 0.0;
    };
    let mut regimes: Vec<Regime> = ev.rows.iter().map(|r| r.regime).collect();
    regimes.sort_by_key(|r| r.id());
    regimes.dedup();
    regimes
        .into_iter()
        .filter_map(|regime| {
            let at = yaw_slips(ev.rows, |r| r.regime == regime);
            let (at_mean, _, n) = moments(&at)?;
            (n >= 2).then(|| (at_mean - mean).abs())
        })
        .fold(0.0, f64::max)
}
