//! Which catalogue effects the data can tell apart at all (each effect says what it needs:
//! [`ScoredWhen`]), and notes on those it cannot.

use super::baseline;
use super::catalogue;
use super::effect::ScoredWhen;
use super::features::{self, TurnRow};
use super::gaps::WhereAnalysis;
use crate::effect_id::EffectId;

/// Which catalogue effects the data can tell apart, and notes on those it cannot.
pub(super) struct Admission {
    run_time_identifiable: bool,
    standstill_current_seen: bool,
}

impl Admission {
    pub(super) fn of(rows: &[TurnRow], where_: &WhereAnalysis) -> (Self, Vec<String>) {
        let not_scored = |when: ScoredWhen| {
            catalogue::all()
                .into_iter()
                .filter(move |e| e.scored_when() == when)
                .map(|e| e.id())
        };
        // A term acting through run time: when every run drives the same manoeuvres in the
        // same order, run time is confounded with the turn set and the term would fit turn
        // shapes instead. It is only a candidate when the "where" analysis can identify a
        // run-time trend (the same kind of manoeuvre recurring at run times spread apart).
        let mut notes = Vec::new();
        let run_time_identifiable = where_.run_time.trend.is_some();
        if !run_time_identifiable {
            notes.extend(not_scored(ScoredWhen::RunTimeApartFromTurnOrder).map(|e| {
                format!(
                    "{e} not scored: run time is not identifiable apart from the turn order \
                     (repeat manoeuvres within longer runs to test it)"
                )
            }));
        }
        // A sensor's current offset reads at standstill too (thesis Fig 3.3: 0.59 A at rest):
        // when the runs have standstill samples and every side reads no more than a driver's
        // quiescent draw there, a constant extra power in the turns is something else (copper
        // loss, say).
        notes.extend(features::radius_source_note(rows));
        let offset_measured = offset_measured_at_standstill(rows);
        // Without standstill samples (a per-turn summary, runs without pauses) an offset
        // cannot be ruled out.
        let standstill_current_seen =
            offset_measured || rows.iter().all(|r| r.standstill_current_a.is_none());
        if !standstill_current_seen {
            notes.extend(not_scored(ScoredWhen::StandstillCurrentSeen).map(|e| {
                format!(
                    "{e} not scored: the standstill current is within ±{} A on both sides \
                     (a sensor offset would read there too)",
                    baseline::QUIESCENT_MAX_A
                )
            }));
        }
        let admission = Self {
            run_time_identifiable,
            standstill_current_seen,
        };
        (admission, notes)
    }

    pub(super) fn allows(&self, e: EffectId) -> bool {
        match catalogue::of(e).scored_when() {
            ScoredWhen::Always => true,
            ScoredWhen::RunTimeApartFromTurnOrder => self.run_time_identifiable,
            ScoredWhen::StandstillCurrentSeen => self.standstill_current_seen,
        }
    }
}

/// Whether some run's standstill current on some side exceeds the drivers' quiescent draw
/// ([`baseline::QUIESCENT_MAX_A`]).
fn offset_measured_at_standstill(rows: &[TurnRow]) -> bool {
    rows.iter().filter_map(|r| r.standstill_current_a).any(|s| {
        s.left.abs() > baseline::QUIESCENT_MAX_A || s.right.abs() > baseline::QUIESCENT_MAX_A
    })
}
