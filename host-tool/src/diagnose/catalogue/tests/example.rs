//! An example of a catalogue file, as a new effect is written (`DESIGN.md`, "How to add an
//! effect"), which the test `an_effect_is_its_file_and_its_line_in_the_list` registers: a
//! sensor offset written afresh, a constant extra power on each side of every manoeuvre, whose
//! mark is the runs' standstill current beyond a driver's quiescent draw (one-sample t over
//! runs and sides). It stands in for `current-offset`'s entry under that key: a new key is a
//! variant of the registry the simulator shares, which a test cannot add.

use crate::diagnose::baseline::QUIESCENT_MAX_A;
use crate::diagnose::effect::{
    Context, Effect, MarkDrive, MarkSource, Marks, Measurement, SignRule, MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::signature::{Evidence, Signature, SignatureTest, ALPHA};
use crate::diagnose::stats::{moments, one_sample_upper};
use crate::effect_id::EffectId;

/// A constant offset of each side's power.
#[derive(Debug)]
pub struct ExampleOffset;

impl Effect for ExampleOffset {
    fn id(&self) -> EffectId {
        EffectId::CurrentOffset
    }
    fn confined_to_regimes(&self) -> bool {
        false
    }
    fn regressors(
        &self,
        _row: &TurnRow,
        _side: usize,
        _ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        Some([1.0, 0.0])
    }
    fn sign_rule(&self) -> SignRule {
        SignRule::Either
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::StandstillCurrent
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        // Each run's standstill current once, both sides, as magnitudes.
        let [left, right] = ev.standstill_currents();
        let amps: Vec<f64> = left.iter().chain(&right).map(|a| a.abs()).collect();
        let (Some((t, df, p)), Some((mean, _, n))) =
            (one_sample_upper(&amps, QUIESCENT_MAX_A), moments(&amps))
        else {
            return Signature::unobservable(self.id(), "example: no standstill in two runs");
        };
        let sized = mean > QUIESCENT_MAX_A;
        let test = SignatureTest {
            statistic_name: "t",
            statistic: t,
            df,
            p,
            present: p < ALPHA && sized,
            sized,
        };
        let detail = format!("example: |standstill current| {mean:.3} A over {n} side-runs");
        Signature::tested(self.id(), test, detail)
    }
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        Vec::new()
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "each sensor's zero with the drivers switched off",
            pose_track: false,
        }
    }
}
