//! `inner-drag` (thesis Section 5.2, Fig 5.6–5.7): extra inner-side torque while the inner
//! wheels counter-rotate but are dragged forward (B/2 < R < R′).
//!
//! - Term: inner side q·|V_i| with q = |V_i|·v_iy/v_c², v_iy = ω(R − B/2), for B/2 < R < R′; it
//!   grows through the turn (the inner wheels' excavated pile, Fig 5.7b).
//! - Mark (on the power model's residuals): the inner side between B/2 and R′ against the inner
//!   side of each regime beside it, Welch t, tested beyond the larger of 1.5 W and the largest
//!   step between neighbouring radii elsewhere on that side.

use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, Measurement, PathSegment, MAX_PARAMS,
};
use crate::diagnose::features::{SideRole, TurnRow};
use crate::diagnose::signature::{step_test, Evidence, Signature};
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;

/// `inner-drag`.
#[derive(Debug)]
pub struct InnerDrag;

impl Effect for InnerDrag {
    fn id(&self) -> EffectId {
        EffectId::InnerDrag
    }
    fn grows(&self) -> bool {
        true
    }
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        let s = &row.sides[side];
        let v = s.cmd_mps.abs();
        let r_prime = f64::from(ctx.rover.r_prime_m());
        let half_track = f64::from(ctx.rover.track_width_m) / 2.0;
        let r = row.radius_cmd_m;
        Some(
            if !row.is_straight()
                && s.role == SideRole::Inner
                && r > half_track
                && r < r_prime
                && row.v_c_mps > 0.0
            {
                let v_iy = row.yaw_rate_cmd_rad_s * (r - half_track);
                let q = v * v_iy / (row.v_c_mps * row.v_c_mps);
                [q * v, 0.0]
            } else {
                [0.0, 0.0]
            },
        )
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::SideResidual
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        inner_drag(ev)
    }
    // The inner side between B/2 and R′ against its neighbours.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![
            MarkDrive::turn(2.0 / 3.0, 90.0, 2),
            MarkDrive::turn(1.0, 90.0, 2),
        ]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "the inner wheels' speed (wheel encoders): dragged against its command, the inner side is pushed forwards over the ground between B/2 and R′",
            pose_track: false,
        }
    }
    // q·|V_i| with q = |V_i| v_iy / v_c², B/2 < R < R' (ω = v_c/R').
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        let (v, rp) = (s.v_mps, s.r_prime_m);
        let half = s.width_m / 2.0;
        let p = if !s.line && s.radius_m > half && s.radius_m < rp {
            let w = v / rp;
            let vi = w * (rp - s.radius_m);
            let viy = w * (s.radius_m - half);
            vi * viy / (v * v) * vi
        } else {
            0.0
        };
        Some(vec![p * s.t_s])
    }
}

/// `inner-drag`: the inner side in the dragged-inner regime against the inner side of each
/// regime beside it (below B/2, at R′).
fn inner_drag(ev: &Evidence<'_>) -> Signature {
    step_test(
        ev,
        EffectId::InnerDrag,
        SideRole::Inner,
        |r| r.regime == Regime::DraggedInner,
        [
            &|r: &TurnRow| r.regime == Regime::BelowHalfTrack,
            &|r: &TurnRow| r.regime == Regime::AtRPrime,
        ],
        "between B/2 and R′",
    )
}
