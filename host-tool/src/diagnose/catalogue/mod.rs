//! The catalogue of unmodelled effects: one file per effect, each a type implementing
//! [`Effect`], registered in one list ([`of`]). The stages ask an effect through the trait; this
//! list is the only place besides an effect's own file that names it. Adding an effect: its
//! [`EffectId`] variant (the key shared with the simulator), its file here, its line in [`of`]
//! (`DESIGN.md`, "How to add an effect").

mod angular_slip;
mod braked_inner;
mod current_offset;
mod inner_drag;
mod motor_heating;
mod sinkage_bulldozing;
mod slip_track;
mod slope;

use super::effect::{Effect, Marks};
use super::signature::{Evidence, Signature};
use crate::effect_id::EffectId;

/// The catalogue's entry of `effect`.
pub fn of(effect: EffectId) -> &'static dyn Effect {
    #[cfg(test)]
    if let Some(entry) = REGISTERED
        .with(std::cell::Cell::get)
        .filter(|e| e.id() == effect)
    {
        return entry;
    }
    match effect {
        EffectId::InnerDrag => &inner_drag::InnerDrag,
        EffectId::SinkageBulldozing => &sinkage_bulldozing::SinkageBulldozing,
        EffectId::AngularSlip => &angular_slip::AngularSlip,
        EffectId::SlipTrack => &slip_track::SlipTrack,
        EffectId::BrakedInner => &braked_inner::BrakedInner,
        EffectId::CurrentOffset => &current_offset::CurrentOffset,
        EffectId::MotorHeating => &motor_heating::MotorHeating,
        EffectId::Slope => &slope::Slope,
    }
}

#[cfg(test)]
thread_local! {
    /// The entry a test registers in place of the list's under its key ([`with_entry`]).
    static REGISTERED: std::cell::Cell<Option<&'static dyn Effect>> =
        const { std::cell::Cell::new(None) };
}

/// Runs `run` with `entry` registered in place of the list's entry of its key (this thread;
/// the diagnosis runs on the caller's).
#[cfg(test)]
pub(crate) fn with_entry<T>(entry: &'static dyn Effect, run: impl FnOnce() -> T) -> T {
    REGISTERED.with(|r| r.set(Some(entry)));
    let out = run();
    REGISTERED.with(|r| r.set(None));
    out
}

/// Every entry, catalogue order.
pub fn all() -> [&'static dyn Effect; EffectId::COUNT] {
    EffectId::ALL.map(of)
}

/// Every effect's mark tested on `ev`, catalogue order. The marks that read no other come
/// first; then a present mark that hides others' (a slope's pull turns the rover as a slip
/// would, and a repeat climbs another grade as a warmer winding draws more) replaces them with
/// the hidden note; then the marks that read others.
pub fn test_marks(ev: &Evidence<'_>) -> Vec<Signature> {
    let mut tested: Vec<(&'static dyn Effect, Option<Signature>)> =
        all().into_iter().map(|e| (e, None)).collect();
    for (e, mark) in &mut tested {
        if !e.reads_other_marks() {
            *mark = Some(e.mark(ev, &Marks { tested: &[] }));
        }
    }
    let hiders: Vec<&'static dyn Effect> = tested
        .iter()
        .filter(|(_, s)| s.as_ref().is_some_and(Signature::present))
        .map(|(e, _)| *e)
        .collect();
    let hidden = |e: &dyn Effect| {
        hiders.iter().find_map(|h| {
            let why = h.hides(e.mark_source())?;
            Some(Signature {
                hidden_by: Some(h.id()),
                ..Signature::masked(e.id(), why)
            })
        })
    };
    for slot in &mut tested {
        if let Some(note) = hidden(slot.0) {
            slot.1 = Some(note);
        }
    }
    // Those still untested read others' marks and are not hidden.
    for k in 0..tested.len() {
        if tested[k].1.is_none() {
            let mark = tested[k].0.mark(ev, &Marks { tested: &tested });
            tested[k].1 = Some(mark);
        }
    }
    tested.into_iter().filter_map(|(_, s)| s).collect()
}

#[cfg(test)]
mod tests;
