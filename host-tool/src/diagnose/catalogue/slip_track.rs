//! `slip-track` (thesis Appendix D, Table D.1, Eq 2.2): the terrain's slip track differs from
//! the controller's, so every turn's yaw rate scales by B_s,ctrl/B_s,terrain.
//!
//! - Term (time-type): P_side on turns.
//! - Mark: every turn's slip beyond the calibration's terrain slip, the same on every turn (not
//!   rising towards R′: angular slip's mark absent); with a pose track, the measured slip track
//!   against the terrain's. Two-sided t, |mean| ≥ 2 %.

use crate::diagnose::baseline::family::MAX_SLIP_SPREAD;
use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, PathSegment, SignRule, MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::signature::{
    excess_slips, Evidence, Signature, SignatureTest, ALPHA, MIN_SLIP_EXCESS,
    MIN_SLIP_TRACK_DIFFERENCE,
};
use crate::diagnose::stats::{moments, one_sample_upper};
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
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        Some(vec![s.e_hg_j])
    }
}

/// `slip-track`: with a pose track, the measured slip track off the terrain's (the controller's
/// B_s widened by the calibration's constant slip) by [`MIN_SLIP_TRACK_DIFFERENCE`]; else
/// every turn's yaw-timed slip off the calibration's terrain slip by [`MIN_SLIP_EXCESS`], either
/// way (a narrower track makes turns quicker than commanded), and the same on every turn: not
/// rising from the point turn towards R′ as angular slip does (`slip_rises`, its signature),
/// and each radius' mean within [`MAX_SLIP_SPREAD`] of the common mean.
fn slip_track(ev: &Evidence<'_>, slip_rises: bool) -> Signature {
    let e = EffectId::SlipTrack;
    let terrain_m = ev.baseline.slip_track_m / (1.0 - ev.baseline.turn_slip);
    let measured: Vec<f64> = ev
        .rows
        .iter()
        .filter_map(|r| r.measured.map(|m| m.slip_track_m / terrain_m - 1.0))
        .filter(|v| v.is_finite())
        .collect();
    let by_yaw = measured.len() < 2;
    let (values, floor, what) = if !by_yaw {
        (
            measured,
            MIN_SLIP_TRACK_DIFFERENCE,
            format!("the pose track's slip track relative to the terrain's {terrain_m:.3} m"),
        )
    } else {
        (
            excess_slips(ev.rows, ev.baseline, |_| true),
            MIN_SLIP_EXCESS,
            format!(
                "the turns' slip beyond the calibration's terrain slip {:.1} %",
                100.0 * ev.baseline.turn_slip
            ),
        )
    };
    let Some((mean, _, n)) = moments(&values) else {
        if !ev.yaw_logged() {
            return Signature::masked(e, "no yaw logged and no pose track");
        }
        return Signature::unobservable(e, "no turn timed by yaw and no pose track");
    };
    // By yaw, a slip rising from the point turn towards R′ is angular slip's mark: not the
    // same fraction on every turn. (A pose track measures the slip track itself.)
    let rises = by_yaw && slip_rises;
    // A slip track rescales every turn's yaw rate by the same B_s,ctrl/B_s (Eq 2.2): by yaw, a
    // slip that differs between the radii (anything that resists the turn more at some radii,
    // such as sand piling up at the point turn) is not it. The same spread the baseline allows
    // a constant calibration slip.
    let spread = if by_yaw { regime_spread(ev, mean) } else { 0.0 };
    let uneven = spread > MAX_SLIP_SPREAD;
    let flipped: Vec<f64> = values.iter().map(|v| v * mean.signum()).collect();
    let Some((t, df, p)) = one_sample_upper(&flipped, 0.0) else {
        return Signature::unobservable(e, "a single turn timed by yaw");
    };
    let p = (2.0 * p).min(1.0);
    let test = SignatureTest {
        statistic_name: "t",
        statistic: t,
        df,
        p,
        present: p < ALPHA && mean.abs() >= floor && !rises && !uneven,
        sized: mean.abs() >= floor && !rises && !uneven,
    };
    let shape = if rises {
        "; but it rises from the point turn towards R′ (angular slip), not the same on every turn"
            .to_string()
    } else if uneven {
        format!(
            "; but a radius' mean differs from it by {:.1} %, not the same on every turn",
            100.0 * spread
        )
    } else {
        String::new()
    };
    Signature::tested(
        e,
        test,
        format!("{what}: {:+.1} % over {n} turn(s){shape}", 100.0 * mean),
    )
}

/// Largest distance of a radius' mean excess slip (regimes with 2 or more yaw-timed turns) from
/// `mean`, the turns' common mean.
fn regime_spread(ev: &Evidence<'_>, mean: f64) -> f64 {
    let mut regimes: Vec<Regime> = ev.rows.iter().map(|r| r.regime).collect();
    regimes.sort_by_key(|r| r.id());
    regimes.dedup();
    regimes
        .into_iter()
        .filter_map(|regime| {
            let at = excess_slips(ev.rows, ev.baseline, |r| r.regime == regime);
            let (at_mean, _, n) = moments(&at)?;
            (n >= 2).then(|| (at_mean - mean).abs())
        })
        .fold(0.0, f64::max)
}
