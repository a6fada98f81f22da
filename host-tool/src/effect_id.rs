//! The catalogue of unmodelled effects: one registry that the simulated world (which can switch
//! each on) and the diagnosis (which names them) both import, so neither depends on the other:
//! their ids, names and the words of their signatures. Adding an effect means a variant here,
//! its file in `diagnose/catalogue/` with its line in that list (everything the diagnosis knows
//! about it), and its term in the simulator (`sim/world/`); the exhaustive matches point the
//! compiler at each place.

use serde::{Deserialize, Serialize};

/// The effects a world can switch on, by their stable TOML/report id.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EffectId {
    /// Section 5.2, Fig 5.6: extra inner-side torque while the inner wheels counter-rotate but
    /// are dragged forward (B/2 < R < R').
    InnerDrag,
    /// Section 5.3–5.4: 2D slip-sinkage growth (Eq 5.15–5.28), the resistance it adds, and sand
    /// bulldozing (Eq 5.35–5.39).
    SinkageBulldozing,
    /// Section 6.2, Eq 6.3: the rover yaws slower than commanded, most at R'.
    AngularSlip,
    /// Appendix D, Table D.1: the terrain's slip track differs from the controller's.
    SlipTrack,
    /// Section 6.2, Fig 6.10–6.11: at R' the inner wheels are held still (braked) and dragged.
    BrakedInner,
    /// Section 3.2, Fig 3.3: a constant offset in the current each sensor reports.
    CurrentOffset,
    /// Section 1.1.3 (Dogru's temperature-dependent motor constants): winding resistance rises
    /// as the motors heat.
    MotorHeating,
    /// Eq 1.16 / 2.12: the Φ m g v_y sin θ term of driving on a slope.
    Slope,
}

impl EffectId {
    /// How many effects the catalogue has.
    pub const COUNT: usize = 8;

    /// Every effect, in report order.
    pub const ALL: [EffectId; EffectId::COUNT] = [
        EffectId::InnerDrag,
        EffectId::SinkageBulldozing,
        EffectId::AngularSlip,
        EffectId::SlipTrack,
        EffectId::BrakedInner,
        EffectId::CurrentOffset,
        EffectId::MotorHeating,
        EffectId::Slope,
    ];

    /// The TOML table name and report id (`inner-drag`, …).
    pub const fn id(self) -> &'static str {
        match self {
            EffectId::InnerDrag => "inner-drag",
            EffectId::SinkageBulldozing => "sinkage-bulldozing",
            EffectId::AngularSlip => "angular-slip",
            EffectId::SlipTrack => "slip-track",
            EffectId::BrakedInner => "braked-inner",
            EffectId::CurrentOffset => "current-offset",
            EffectId::MotorHeating => "motor-heating",
            EffectId::Slope => "slope",
        }
    }

    /// A column head of at most 5 characters (the bench's confusion matrix).
    pub const fn short(self) -> &'static str {
        match self {
            EffectId::InnerDrag => "drag",
            EffectId::SinkageBulldozing => "sink",
            EffectId::AngularSlip => "aslip",
            EffectId::SlipTrack => "strk",
            EffectId::BrakedInner => "brake",
            EffectId::CurrentOffset => "offs",
            EffectId::MotorHeating => "heat",
            EffectId::Slope => "slope",
        }
    }

    /// The effect's signature: the observation only it produces, which the diagnosis must find
    /// in the data before it names the effect (`diagnose::signature` tests it). Observations
    /// that need no power model come first where one exists.
    pub const fn signature(self) -> &'static str {
        match self {
            EffectId::InnerDrag => {
                "the inner side alone draws more between B/2 and R′ than at the neighbouring radii"
            }
            EffectId::SinkageBulldozing => {
                "power rising through the manoeuvre on both sides as the wheels sink: through \
                 the turns below R′ more than on straights and wide turns, or through the tight \
                 turns and straights alike"
            }
            EffectId::AngularSlip => {
                "turns timed by yaw slower than the point turns, rising towards R′"
            }
            EffectId::SlipTrack => {
                "every turn's yaw off the calibration's terrain slip by the same fraction (the \
                 pose track's slip track when positions are logged)"
            }
            EffectId::BrakedInner => {
                "the outer side at R′ draws more than at the neighbouring radii: a step at one \
                 radius"
            }
            EffectId::CurrentOffset => "current at standstill beyond a driver's quiescent draw",
            EffectId::MotorHeating => "the same manoeuvre drawing more later in a run",
            EffectId::Slope => "manoeuvres measured off level by the pitch",
        }
    }

    /// Whether [`EffectId::signature`] is read off the power model's residuals. The others are
    /// measured directly (standstill current, yaw, pose, pitch, power within a turn or between
    /// repeats of one manoeuvre), so they stand when the baseline itself misfits.
    pub const fn signature_needs_power_model(self) -> bool {
        matches!(self, EffectId::InnerDrag | EffectId::BrakedInner)
    }

    /// Inverse of [`EffectId::id`].
    pub fn from_id(id: &str) -> Option<EffectId> {
        EffectId::ALL.into_iter().find(|e| e.id() == id)
    }

    /// Whether `ground = "sand"` turns the effect on by default (the terrain effects do; the
    /// sensor, motor and slope terms never do by default).
    pub const fn on_by_default_on_sand(self) -> bool {
        matches!(
            self,
            EffectId::InnerDrag
                | EffectId::SinkageBulldozing
                | EffectId::AngularSlip
                | EffectId::SlipTrack
                | EffectId::BrakedInner
        )
    }
}

impl std::fmt::Display for EffectId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.id())
    }
}

#[cfg(test)]
mod tests {
    use super::EffectId;

    #[test]
    fn ids_round_trip_and_are_unique() {
        for (i, e) in EffectId::ALL.into_iter().enumerate() {
            assert_eq!(e as usize, i, "ALL is in declaration order");
            assert_eq!(EffectId::from_id(e.id()), Some(e));
            assert!(e.short().len() <= 5);
            let same = EffectId::ALL
                .iter()
                .filter(|o| o.id() == e.id() || o.short() == e.short());
            assert_eq!(same.count(), 1, "{e}");
        }
        assert_eq!(EffectId::from_id("baseline-misfit"), None);
    }
}
