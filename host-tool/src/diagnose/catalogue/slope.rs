//! `slope` (thesis Eq 1.16, 2.12): the Φ m g v_y sin θ term of driving on a slope.
//!
//! - Term: m g sin θ · v_c · |V_side|/(|V_l| + |V_r|), a positive coefficient.
//! - Mark: more manoeuvres off level (|pitch| > 1°) than sensor noise explains: binomial tail
//!   against 5 % of level manoeuvres reading off level, and at least two.
//! - Present, it hides the marks read from the yaw and from repeats (the downhill pull turns
//!   the rover; a repeat climbs another grade), and a rise of power through every manoeuvre is
//!   not sinkage's alone.

use crate::diagnose::adequacy::LEVEL_PITCH_DEG;
use crate::diagnose::baseline;
use crate::diagnose::effect::{
    AlsoRises, Context, Effect, MarkDrive, MarkSource, Marks, Measurement, SignRule, MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::signature::{Evidence, Signature, SignatureTest, ALPHA, OFF_LEVEL_BY_CHANCE};
use crate::diagnose::stats::binomial_upper_tail;
use crate::effect_id::EffectId;
use model_core::power::GRAVITY_M_S2;

/// `slope`.
#[derive(Debug)]
pub struct Slope;

impl Effect for Slope {
    fn id(&self) -> EffectId {
        EffectId::Slope
    }
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        row.pitch_deg?;
        let mg = f64::from(ctx.rover.mass_kg) * GRAVITY_M_S2;
        Some([mg * baseline::grade_feature_mps(row, side), 0.0])
    }
    fn sign_rule(&self) -> SignRule {
        SignRule::PositiveCoefficient
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::Pitch
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        slope(ev)
    }
    fn hides(&self, source: MarkSource) -> Option<String> {
        let why = match source {
            MarkSource::YawTiming => {
                "which changes the yaw rate of the turns too; drive the turns on level ground to \
                 see a slip"
            }
            MarkSource::Repeats => {
                "so the same manoeuvre climbs another grade at each heading; drive the repeats \
                 on level ground to see a warmer winding"
            }
            MarkSource::StandstillCurrent
            | MarkSource::Pitch
            | MarkSource::GrowthThroughManoeuvre
            | MarkSource::SideResidual => return None,
        };
        Some(format!(
            "the runs are on a slope (its signature is present), {why}"
        ))
    }
    fn also_rises_through_manoeuvres(&self, own: &Signature) -> Option<AlsoRises> {
        own.present().then_some(AlsoRises {
            words: "as the slope's changing grade does too",
            told_apart_by_driving: false,
        })
    }
    // A slope's mark is the terrain's, not a manoeuvre's.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        Vec::new()
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "the ground's inclination (the IMU's pitch, or a level on the test patch)",
            pose_track: false,
        }
    }
}

/// `slope`: more manoeuvres off level than sensor noise explains (binomial tail against
/// [`OFF_LEVEL_BY_CHANCE`]), and at least two.
fn slope(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::Slope;
    let pitched: Vec<f64> = ev.rows.iter().filter_map(|r| r.pitch_deg).collect();
    if pitched.is_empty() {
        return Signature::masked(e, "no pitch logged");
    }
    let n = pitched.len();
    let k = pitched.iter().filter(|p| p.abs() > LEVEL_PITCH_DEG).count();
    let p = binomial_upper_tail(k, n, OFF_LEVEL_BY_CHANCE);
    let test = SignatureTest {
        statistic_name: "binomial",
        statistic: k as f64,
        df: n as f64,
        p,
        present: p < ALPHA && k >= 2,
        sized: k >= 2,
    };
    Signature::tested(
        e,
        test,
        format!(
            "{k} of {n} manoeuvres have a mean pitch beyond ±{}°",
            LEVEL_PITCH_DEG
        ),
    )
}
