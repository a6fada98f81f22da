//! `braked-inner` (thesis Section 6.2, Fig 6.10–6.11): at R′ the inner wheels are held still
//! (braked) and dragged.
//!
//! - Term: at R = R′ only, the outer side's |V_o|.
//! - Mark (on the power model's residuals): the outer side at R′ against the outer side at the
//!   next commanded radius below and above, Welch t, tested beyond the larger of 1.5 W and the
//!   largest step elsewhere: a step at one radius.

use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, Measurement, PathSegment, MAX_PARAMS,
};
use crate::diagnose::features::radius_group;
use crate::diagnose::features::{SideRole, TurnRow};
use crate::diagnose::signature::{step_test, Evidence, Signature};
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;

/// `braked-inner`.
#[derive(Debug)]
pub struct BrakedInner;

impl Effect for BrakedInner {
    fn id(&self) -> EffectId {
        EffectId::BrakedInner
    }
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        _ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        let s = &row.sides[side];
        Some(
            if row.regime == Regime::AtRPrime && s.role == SideRole::Outer {
                [s.cmd_mps.abs(), 0.0]
            } else {
                [0.0, 0.0]
            },
        )
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::SideResidual
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        braked_inner(ev)
    }
    // The outer side at R′ against its neighbours.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![
            MarkDrive::turn(1.0, 90.0, 2),
            MarkDrive::turn(4.0 / 3.0, 90.0, 2),
        ]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "the inner wheels' speed at R′ (wheel encoders): held wheels pushed over the ground turn against their command",
            pose_track: false,
        }
    }
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        Some(vec![if !s.line && s.at_r_prime {
            2.0 * s.v_mps * s.t_s
        } else {
            0.0
        }])
    }
}

/// `braked-inner`: the outer side at R′ against the outer side at the next commanded radius
/// below and at the next above.
fn braked_inner(ev: &Evidence<'_>) -> Signature {
    let turns = || ev.rows.iter().filter(|r| !r.is_straight());
    let Some(at) = turns()
        .find(|r| r.regime == Regime::AtRPrime)
        .map(radius_group)
    else {
        return Signature::unobservable(EffectId::BrakedInner, "no turn at R′");
    };
    let below = turns().map(radius_group).filter(|&k| k < at).max();
    let above = turns().map(radius_group).filter(|&k| k > at).min();
    step_test(
        ev,
        EffectId::BrakedInner,
        SideRole::Outer,
        |r| radius_group(r) == at,
        [
            &|r: &TurnRow| Some(radius_group(r)) == below,
            &|r: &TurnRow| Some(radius_group(r)) == above,
        ],
        "at R′",
    )
}
