use super::*;
use crate::diagnose::tests::{rows_of, simulate_run};
use crate::diagnose::{diagnose, features::TurnRow};
use crate::effect_id::EffectId;
use crate::plan::parse_model;
use crate::sim::world::{Manoeuvre, Scenario, WorldConfig};
use model_core::paths::SegmentEnergy;

const HUSKY: Rover = Rover::HUSKY_A200;

/// The seed's turn set with 4R′ in place of 4R′/3 (wide calibration turns).
fn scenario() -> Scenario {
    let mut s = Scenario::seed_turns(0.3, 1);
    if let Some(Manoeuvre::Turn {
        r_over_r_prime: Some(k),
        ..
    }) = s.manoeuvres.get_mut(4)
    {
        *k = 4.0;
    }
    s
}

fn rows_of_world(world: &WorldConfig) -> Vec<TurnRow> {
    let runs: Vec<_> = (0..3)
        .map(|k| simulate_run(world, &scenario(), 20 + k))
        .collect();
    rows_of(&runs)
}

/// Planned energy of the turns of `rows` (their commanded radius and measured heading
/// change) against their measured energy: the largest relative error.
fn worst_turn_error(model: &EnergyModel, rows: &[TurnRow]) -> f64 {
    let law = model.law().expect("valid model");
    rows.iter()
        .filter(|r| !r.is_straight() && r.turned_from_yaw)
        .map(|r| {
            let angle = r.expected_duration_s * r.yaw_rate_cmd_rad_s;
            let planned = law.arc_energy_j(r.radius_cmd_m, angle);
            let measured = r.sides[0].energy_j + r.sides[1].energy_j;
            ((planned - measured) / measured).abs()
        })
        .fold(0.0, f64::max)
}

/// Angular slip is a time-type effect: the turns last longer than commanded at unchanged
/// power. The diagnosis tabulates it as effective power (energy over the commanded
/// duration), `plan` prices an arc as power × commanded duration, so the model file's arc
/// energies are the measured turn energies; the hard-ground base alone is far off.
#[test]
fn model_file_round_trips_and_prices_angular_slip_turns_at_their_measured_energy() {
    let world = WorldConfig::hard_ground().with_effect(EffectId::AngularSlip, true);
    let rows = rows_of_world(&world);
    let d = diagnose(&HUSKY, &rows).expect("diagnoses");
    assert_eq!(d.effect, "angular-slip");
    let model = energy_model(&HUSKY, &d, &rows, Calibration::FROM_RUNS).expect("model");
    let text = model.to_toml().expect("toml");
    assert_eq!(parse_model(&text).expect("parses"), model);
    assert_eq!(model.effects.len(), 1);

    let with_effect = worst_turn_error(&model, &rows);
    let base_only = worst_turn_error(
        &EnergyModel {
            effects: Vec::new(),
            ..model.clone()
        },
        &rows,
    );
    assert!(with_effect < 0.06, "{with_effect}");
    assert!(base_only > 0.15, "{base_only}");
}

/// The demo's sand experiment (the seed's turn set on the sand world, three runs): the
/// diagnosed model moves the energy-optimal CLC arc of a 90° – 10 m – 90° path from R′
/// (where the hard-ground model fitted to the same runs puts it, paper Eq 26) out to
/// about 2 R′, as the thesis measured on sand (Table 6.1: 2R′ < R < 2.5R′; Fig. C.3).
#[test]
fn sand_model_moves_the_optimal_arc_out_from_r_prime() {
    let runs: Vec<_> = (1..=3)
        .map(|k| simulate_run(&WorldConfig::sand(), &Scenario::seed_turns(0.3, 1), k))
        .collect();
    let rows = rows_of(&runs);
    let mut d = diagnose(&HUSKY, &rows).expect("diagnoses");
    // On sand the hard-ground baseline misfits its own calibration manoeuvres, so the
    // verdict is `baseline-misfit`; the model file's machinery is tested with the best
    // candidate, as a user would after reading the report.
    if d.effect == crate::diagnose::Verdict::BaselineMisfit {
        d.effect = crate::diagnose::Verdict::Effect(d.candidates[0].effect);
    }
    let model = energy_model(&HUSKY, &d, &rows, Calibration::FROM_RUNS).expect("model");
    let mut hard = model.clone();
    hard.effects.clear();
    let source = crate::plan::ModelSource::Preset(crate::plan::Preset::HuskyHardGround);
    let with = crate::plan::plan(&model, &source, 90.0, 90.0, 10.0).expect("plans");
    let without = crate::plan::plan(&hard, &source, 90.0, 90.0, 10.0).expect("plans");
    let k = |p: &crate::plan::PlanReport| p.clc.r1_m / p.setting.r_prime_m;
    assert!((k(&without) - 1.0).abs() < 0.05, "{without:?}");
    // 2R′ is also the widest turn these runs measured (the table's last turn breakpoint).
    assert!((1.95..=3.0).contains(&k(&with)), "{}: {with:?}", d.effect);
    assert!(with.saving_pct > 0.0, "{with:?}");
}

#[test]
fn control_runs_give_the_fitted_base_without_effect_terms() {
    let rows = rows_of_world(&WorldConfig::hard_ground());
    let d = diagnose(&HUSKY, &rows).expect("diagnoses");
    assert_eq!(d.effect, "none");
    let model = energy_model(&HUSKY, &d, &rows, Calibration::FROM_RUNS).expect("model");
    assert!(model.effects.is_empty());
    assert_eq!(model.v_c_mps, 0.3);
    assert_eq!(model.base.slip_track_m, 1.1);
    assert!((model.base.mu - d.baseline.mu).abs() < 1e-6);
    // The file's values are rounded to 1e-6.
    assert!((model.base.rolling_resistance_n - d.baseline.rolling_resistance_n).abs() < 1e-6);
    // Hard ground: every turn within a few percent of its planned energy.
    assert!(worst_turn_error(&model, &rows) < 0.05);
}

#[test]
fn synthetic_turns_have_appendix_a_speeds_and_the_grid_ends_at_a_straight() {
    let baseline = Baseline {
        skid_force_n: 160.0,
        skid_force_ci_n: 0.0,
        rolling_resistance_n: 31.0,
        rolling_resistance_ci_n: 0.0,
        slip_track_m: 1.1,
        mu: 0.74,
        residual_std_w: 0.0,
        n: 10,
        structure: crate::diagnose::baseline::Structure::PLAIN,
        copper_w_per_n2: 0.0,
        turn_slip: 0.0,
        cv_rmse_w: None,
        calibration_grade_n: 0.0,
        covariance: [[0.0; 2]; 2],
        copper_refused: None,
    };
    let at = Conditions {
        v_c_mps: 0.3,
        turn_rad: std::f64::consts::FRAC_PI_2,
        bus_v: 24.0,
        t_start_s: 10.0,
    };
    for (k, regime) in [
        (0.0, Regime::Point),
        (0.3, Regime::BelowHalfTrack),
        (2.0 / 3.0, Regime::DraggedInner),
        (1.0, Regime::AtRPrime),
        (2.0, Regime::AboveRPrime),
        (f64::INFINITY, Regime::Straight),
    ] {
        let row = synthetic_row(&HUSKY, &baseline, k, &at);
        assert_eq!(row.regime, regime, "{k}");
        let [i, o] = [row.sides[0].cmd_mps, row.sides[1].cmd_mps];
        assert!((i.abs() + o.abs() - 0.6).abs() < 1e-6, "{k}: {i} {o}");
        assert!(i <= o, "{k}");
        assert_eq!(
            row.sides[0].effective_power_w,
            baseline.side_power_w(&row, 0)
        );
    }
    let g = grid(&HUSKY, f64::INFINITY);
    assert!(g.windows(2).all(|w| w[0] < w[1]));
    let last = *g.last().expect("grid");
    assert!((last * 0.55 - 20.0).abs() < 1e-3, "{last}");
    let straight = synthetic_row(&HUSKY, &baseline, last, &at);
    assert!(straight.is_straight());
    // Turns beyond the widest diagnosed one are not tabulated: straight to the straight line.
    let clipped = grid(&HUSKY, 2.0);
    assert_eq!(clipped[clipped.len() - 2], 2.0);
    assert_eq!(clipped.last(), g.last());
}
