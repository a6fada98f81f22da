use super::*;

// An example file, as a new effect is written; the test below registers it.
mod example;

#[test]
fn every_effect_has_its_own_entry() {
    for e in EffectId::ALL {
        assert_eq!(of(e).id(), e);
    }
}

/// Adding an effect is a file and a line in the list: every stage asks the entry, so a
/// catalogue file written afresh (`example.rs`: a constant power offset with its own mark),
/// registered in one line, is what the diagnosis fits, tests and names; a control world
/// without its mark does not get it named.
#[test]
fn an_effect_is_its_file_and_its_line_in_the_list() {
    use crate::diagnose::calibration::Calibration;
    use crate::diagnose::tests::{rows_of, scenario, simulate_run};
    use crate::diagnose::verdict::Verdict;
    use crate::diagnose::{diagnose, fit_model};
    use crate::sim::world::WorldConfig;
    let rover = model_core::Rover::HUSKY_A200;
    let rows_in = |world: &WorldConfig| {
        let runs: Vec<_> = (0..3)
            .map(|k| simulate_run(world, &scenario(), 10 + k))
            .collect();
        rows_of(&runs)
    };
    let e = EffectId::CurrentOffset;
    let example: &'static dyn Effect = &example::ExampleOffset;
    let rows = rows_in(&WorldConfig::hard_ground().with_effect(e, true));
    let (d, fitted) = with_entry(example, || {
        let d = diagnose(&rover, &rows).expect("diagnoses");
        (d, fit_model(&rover, &rows, &[e], Calibration::FROM_RUNS))
    });
    let mark = d.signature(e).expect("tested");
    assert!(mark.detail.starts_with("example: "), "{}", mark.describe());
    assert!(mark.present(), "{}", mark.describe());
    assert_eq!(d.effect, Verdict::Effect(e), "{:?}", d.candidates);
    // Its term is the example's: the same power on every side of every manoeuvre.
    let (baseline, model) = fitted.expect("fits");
    let term = model.effects[0];
    let ctx = model.context(&rover, &baseline);
    let powers: Vec<f64> = rows
        .iter()
        .flat_map(|r| [0, 1].map(|s| with_entry(example, || term.term_w(r, s, &ctx))))
        .collect();
    assert!(
        powers.iter().all(|w| *w == powers[0] && *w != 0.0),
        "{powers:?}"
    );
    // Without its registration the list's own entry answers (V_bus-shaped).
    let listed: Vec<f64> = rows.iter().map(|r| term.term_w(r, 0, &ctx)).collect();
    assert!(listed.iter().any(|w| *w != powers[0]), "{listed:?}");
    let control = rows_in(&WorldConfig::hard_ground());
    let d = with_entry(example, || diagnose(&rover, &control).expect("diagnoses"));
    let mark = d.signature(e).expect("tested");
    assert!(
        mark.detail.starts_with("example: ") && !mark.present(),
        "{}",
        mark.describe()
    );
    assert_ne!(d.effect, Verdict::Effect(e));
}
