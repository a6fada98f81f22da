//! The diagnosis' conclusion as types: what it names ([`Verdict`]) and where ([`Scope`]). Both
//! serialise to the report's stable strings (`none`, `ambiguous`, `outside-catalogue`,
//! `baseline-misfit`, an effect
//! id; `all`, `gap`, a regime id), so the JSON keeps its keys and values.

use crate::effect_id::EffectId;
use model_core::kinematics::Regime;
use serde::{Serialize, Serializer};

/// What the diagnosis concluded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// No significant departure from the baseline.
    None,
    /// A significant departure, but no catalogue term explains it clearly yet: a candidate
    /// that improves the held-out fit could still be named (its mark present beside a rival,
    /// not yet beyond the noise, or not yet observed).
    Ambiguous,
    /// A significant departure that no catalogued effect explains: no effect's mark is present,
    /// and every candidate improving the held-out fit had its own mark looked for and missing,
    /// hidden, or unobservable whatever is driven. The cause is one the catalogue does not hold.
    OutsideCatalogue,
    /// The baseline itself does not fit its calibration manoeuvres beyond their repeat noise:
    /// no effect can be named against it.
    BaselineMisfit,
    /// A catalogue effect, named against an adequate baseline.
    Effect(EffectId),
}

impl Verdict {
    /// The report string: `none`, `ambiguous`, `outside-catalogue`, `baseline-misfit` or the
    /// effect id.
    pub const fn label(self) -> &'static str {
        match self {
            Verdict::None => "none",
            Verdict::Ambiguous => "ambiguous",
            Verdict::OutsideCatalogue => "outside-catalogue",
            Verdict::BaselineMisfit => "baseline-misfit",
            Verdict::Effect(e) => e.id(),
        }
    }

    /// The named effect, if any.
    pub const fn effect(self) -> Option<EffectId> {
        match self {
            Verdict::Effect(e) => Some(e),
            Verdict::None
            | Verdict::Ambiguous
            | Verdict::OutsideCatalogue
            | Verdict::BaselineMisfit => None,
        }
    }

    /// Inverse of [`Verdict::label`].
    pub fn from_label(label: &str) -> Option<Verdict> {
        match label {
            "none" => Some(Verdict::None),
            "ambiguous" => Some(Verdict::Ambiguous),
            "outside-catalogue" => Some(Verdict::OutsideCatalogue),
            "baseline-misfit" => Some(Verdict::BaselineMisfit),
            other => EffectId::from_id(other).map(Verdict::Effect),
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

impl Serialize for Verdict {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.label())
    }
}

impl PartialEq<&str> for Verdict {
    fn eq(&self, other: &&str) -> bool {
        self.label() == *other
    }
}

/// Which rows a conclusion or an error figure is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// Every row.
    All,
    /// The rows of the regimes with a significant gap.
    Gap,
    /// One regime.
    Regime(Regime),
}

impl Scope {
    /// The report string: `all`, `gap` or the regime id.
    pub const fn label(self) -> &'static str {
        match self {
            Scope::All => "all",
            Scope::Gap => "gap",
            Scope::Regime(r) => r.id(),
        }
    }

    /// Inverse of [`Scope::label`].
    pub fn from_label(label: &str) -> Option<Scope> {
        match label {
            "all" => Some(Scope::All),
            "gap" => Some(Scope::Gap),
            other => Regime::from_id(other).map(Scope::Regime),
        }
    }
}

impl std::fmt::Display for Scope {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

impl Serialize for Scope {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.label())
    }
}

impl PartialEq<&str> for Scope {
    fn eq(&self, other: &&str) -> bool {
        self.label() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_and_serialise_as_todays_strings() {
        let verdicts = [
            Verdict::None,
            Verdict::Ambiguous,
            Verdict::OutsideCatalogue,
            Verdict::BaselineMisfit,
        ]
        .into_iter()
        .chain(EffectId::ALL.map(Verdict::Effect));
        for v in verdicts {
            assert_eq!(Verdict::from_label(v.label()), Some(v));
            assert_eq!(
                serde_json::to_value(v).expect("serialises"),
                serde_json::json!(v.label())
            );
        }
        assert_eq!(Verdict::BaselineMisfit.label(), "baseline-misfit");
        let scopes = [Scope::All, Scope::Gap]
            .into_iter()
            .chain(Regime::ALL.map(Scope::Regime));
        for s in scopes {
            assert_eq!(Scope::from_label(s.label()), Some(s));
            assert_eq!(
                serde_json::to_value(s).expect("serialises"),
                serde_json::json!(s.label())
            );
        }
        assert_eq!(Verdict::from_label("sideways"), None);
    }
}
