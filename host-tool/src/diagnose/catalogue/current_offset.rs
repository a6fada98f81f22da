//! `current-offset` (thesis Section 3.2, Fig 3.3): a constant offset in the current each sensor
//! reports.
//!
//! - Term: V_bus on every manoeuvre and side (an offset current), either sign.
//! - Mark: the standstill current per run and side beyond a driver's quiescent draw (0.25 A):
//!   one-sided t of |mean| per side, Bonferroni ×2; measured without the power model.
//! - Scored only with a standstill current beyond the quiescent draw, or none measured.

use crate::diagnose::baseline;
use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, Measurement, PathSegment, ScoredWhen, SignRule,
    When, MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::signature::{Evidence, Signature, SignatureTest, ALPHA};
use crate::diagnose::stats::{moments, one_sample_upper};
use crate::effect_id::EffectId;

/// `current-offset`.
#[derive(Debug)]
pub struct CurrentOffset;

impl Effect for CurrentOffset {
    fn id(&self) -> EffectId {
        EffectId::CurrentOffset
    }
    fn confined_to_regimes(&self) -> bool {
        false
    }
    fn regressors(
        &self,
        row: &TurnRow,
        _side: usize,
        _ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        Some([row.bus_v, 0.0])
    }
    fn sign_rule(&self) -> SignRule {
        SignRule::Either
    }
    fn scored_when(&self) -> ScoredWhen {
        ScoredWhen::StandstillCurrentSeen
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::StandstillCurrent
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        current_offset(ev)
    }
    // A standstill: the pause after any drive.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![MarkDrive {
            r_over_r_prime: None,
            turn_deg: 0.0,
            when: When::Any,
            repeats: 1,
        }]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "each sensor's zero: 5 s or more at standstill with the drivers switched off, at the start of a run",
            pose_track: false,
        }
    }
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        Some(vec![s.t_s])
    }
}

/// `current-offset`: the standstill current of some side beyond a driver's quiescent draw.
fn current_offset(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::CurrentOffset;
    let sides = ev.standstill_currents();
    if sides[0].is_empty() {
        return Signature::unobservable(e, "no run stands still long enough");
    }
    let q = baseline::QUIESCENT_MAX_A;
    let mut best: Option<(SignatureTest, String)> = None;
    for (name, values) in ["left", "right"].into_iter().zip(&sides) {
        let (mean, _, n) = moments(values).expect("non-empty");
        let magnitudes: Vec<f64> = values.iter().map(|v| v * mean.signum()).collect();
        let detail = format!(
            "{name} side reads {mean:+.3} A at standstill over {n} run(s), a driver's quiescent \
             draw at most {q} A"
        );
        let test = match one_sample_upper(&magnitudes, q) {
            Some((t, df, p)) => {
                let p = (2.0 * p).min(1.0);
                SignatureTest {
                    statistic_name: "t",
                    statistic: t,
                    df,
                    p,
                    present: p < ALPHA && mean.abs() > q,
                    sized: mean.abs() > q,
                }
            }
            // One run: no repeat to test the offset against.
            None => SignatureTest {
                statistic_name: "t",
                statistic: f64::NAN,
                df: 0.0,
                p: 1.0,
                present: false,
                sized: false,
            },
        };
        if best
            .as_ref()
            .is_none_or(|(b, _)| test.p < b.p || (test.present && !b.present))
        {
            best = Some((test, detail));
        }
    }
    let (test, detail) = best.expect("two sides");
    Signature::tested(e, test, detail)
}
