//! Synthetic calibration rows: a plain tread-couple world passes, a no-regeneration world and a
//! world with a misfit the model has no term for fail, and one run cannot be tested.

use super::*;
use crate::diagnose::baseline::{Baseline, Split, Structure};
use crate::diagnose::features::{Observed, SideObs};
use model_core::kinematics::Regime;
use model_core::rng::SplitMix64;
use model_core::Rover;

const HUSKY: Rover = Rover::HUSKY_A200;
/// a = F/B_s and G of the synthetic world [N].
const A_N: f64 = 150.0;
const G_N: f64 = 40.0;
const V_C: f64 = 0.3;

/// The commanded (inner, outer) speeds at R/R′ (∞: straight) with the Husky's B_s.
fn speeds(r_over_r_prime: f64) -> (f64, f64) {
    if r_over_r_prime.is_infinite() {
        return (V_C, V_C);
    }
    let half = f64::from(HUSKY.slip_track_m) / 2.0;
    let r = r_over_r_prime * half;
    if r == 0.0 {
        return (-V_C, V_C);
    }
    (V_C * (r - half) / r, V_C * (r + half) / r)
}

/// A calibration row whose sides draw `power(inner_cmd, outer_cmd)` plus noise of σ = 0.5 W.
fn row(
    run: usize,
    r_over_r_prime: f64,
    rng: &mut SplitMix64,
    power: &dyn Fn(f64, f64) -> [f64; 2],
) -> TurnRow {
    let (vi, vo) = speeds(r_over_r_prime);
    let p = power(vi, vo);
    let mut noise = || (rng.next_u64() % 1001) as f64 / 1000.0 - 0.5;
    let side = |role, cmd_mps, w: f64| SideObs {
        role,
        cmd_mps,
        avg_power_w: w,
        max_power_w: w,
        energy_j: w * 5.0,
        effective_power_w: w,
        growth_w: None,
    };
    let regime = match r_over_r_prime {
        r if r.is_infinite() => Regime::Straight,
        0.0 => Regime::Point,
        _ => Regime::AboveRPrime,
    };
    TurnRow {
        run: format!("run-{run}"),
        run_index: run,
        manoeuvre: 0,
        regime,
        radius_cmd_m: r_over_r_prime * f64::from(HUSKY.r_prime_m()),
        r_over_r_prime,
        v_c_mps: V_C,
        yaw_rate_cmd_rad_s: 0.0,
        duration_s: 5.0,
        expected_duration_s: 5.0,
        turned_from_yaw: false,
        angular_slip: None,
        yaw_rate_act_rad_s: None,
        t_start_s: 0.0,
        pitch_deg: None,
        standstill_current_a: None,
        standstill_w: [0.0; 2],
        bus_v: 24.0,
        sides: [
            side(SideRole::Inner, vi, p[0] + noise()),
            side(SideRole::Outer, vo, p[1] + noise()),
        ],
        calibration_kind: true,
        observed: Observed::Sides,
        copper_heat_a4: None,
        measured: None,
        direction: None,
    }
}

/// The tread couple with regeneration (the baseline's own structure).
fn couple(vi: f64, vo: f64) -> [f64; 2] {
    let straight = (vi - vo).abs() < 1e-12;
    let skid = if straight { 0.0 } else { A_N };
    [-skid * vi + G_N * vi.abs(), skid * vo + G_N * vo.abs()]
}

fn calibration(runs: usize, power: &dyn Fn(f64, f64) -> [f64; 2]) -> Vec<TurnRow> {
    let mut rng = SplitMix64::new(7);
    (0..runs)
        .flat_map(|run| [0.0, 2.0, 3.0, f64::INFINITY].map(|r| (run, r)))
        .map(|(run, r)| row(run, r, &mut rng, power))
        .collect()
}

/// The adequacy of the plain member (the family is tested in
/// `the_family_finds_the_no_regeneration_clamp`).
fn adequacy_of(rows: &[TurnRow]) -> Adequacy {
    let refs: Vec<&TurnRow> = rows.iter().collect();
    let baseline = Baseline::fit_plain(&HUSKY, &refs).expect("fits");
    test(&refs, 2, |r, s| baseline.side_power_w(r, s))
}

#[test]
fn the_baselines_own_structure_is_adequate() {
    let a = adequacy_of(&calibration(2, &couple));
    assert_eq!(a.adequate, Some(true), "{a:#?}");
    // 4 manoeuvres × 2 runs: df 2 and 4 on the total, 6 and 8 per side.
    assert_eq!((a.total.df_lack_of_fit, a.total.df_pure_error), (2, 4));
    let sides = a.per_side.as_ref().expect("per side");
    assert_eq!((sides.df_lack_of_fit, sides.df_pure_error), (6, 8));
    assert!(
        sides.repeat_sigma_w > 0.05 && sides.repeat_sigma_w < 0.6,
        "{sides:?}"
    );
    assert!(a.split_fits());
    assert!(a.suggestions.is_empty());
}

/// The family's clamp member, chosen by cross-validation over the 2 calibration runs, fits
/// the world the plain member misfits (below); the plain world keeps the plain member.
#[test]
fn the_family_finds_the_no_regeneration_clamp() {
    let clamp = |vi: f64, vo: f64| couple(vi, vo).map(|p| p.max(0.0));
    for (power, split) in [
        (
            &clamp as &dyn Fn(f64, f64) -> [f64; 2],
            Split::Returning { fraction: 0.0 },
        ),
        (&couple, Split::Regenerating),
    ] {
        let rows = calibration(2, power);
        let refs: Vec<&TurnRow> = rows.iter().collect();
        let b = Baseline::fit(&HUSKY, &refs).expect("fits");
        assert_eq!(b.structure.split, split, "{b:?}");
        assert!(!b.structure.copper_loss, "{b:?}");
        assert!(b.cv_rmse_w.expect("2 runs") < 1.0, "{b:?}");
        let a = test(&refs, 2, |r, s| b.side_power_w(r, s));
        assert_eq!(a.adequate, Some(true), "{a:#?}");
    }
}

#[test]
fn a_no_regeneration_world_misfits_and_says_so() {
    let clamp = |vi: f64, vo: f64| couple(vi, vo).map(|p| p.max(0.0));
    let a = adequacy_of(&calibration(2, &clamp));
    assert_eq!(a.adequate, Some(false), "{a:#?}");
    let sides = a.per_side.as_ref().expect("per side");
    assert!(sides.p_value.expect("testable") < ALPHA);
    let worst = &sides.groups_fit[0];
    assert!(
        worst.beyond_floor() && worst.mean_residual_w.abs() > 5.0,
        "{worst:?}"
    );
    assert!(
        a.suggestions.iter().any(|s| s.contains("no-regeneration")),
        "{:?}",
        a.suggestions
    );
}

#[test]
fn a_misfit_below_the_practical_floor_is_adequate() {
    // 1 W more on every straight side: significant against 0.3 W of noise, but under the floor.
    let small = |vi: f64, vo: f64| {
        let p = couple(vi, vo);
        if (vi - vo).abs() < 1e-12 {
            p.map(|w| w + 1.0)
        } else {
            p
        }
    };
    let a = adequacy_of(&calibration(3, &small));
    assert!(a.total.p_value.expect("testable") < ALPHA, "{a:#?}");
    assert_eq!(a.adequate, Some(true), "{a:#?}");
}

#[test]
fn without_repeats_adequacy_is_not_tested() {
    let a = adequacy_of(&calibration(1, &couple));
    assert_eq!(a.adequate, None);
    assert_eq!(a.total.p_value, None);
    assert_eq!(a.total.df_pure_error, 0);
}

/// The copper loss of the synthetic copper worlds, c in c·F² [W/N²].
const COPPER_W_PER_N2: f64 = 1e-3;

/// The tread-couple world plus each side's copper loss c·F², F = P/V its traction force.
fn with_copper_loss(vi: f64, vo: f64) -> [f64; 2] {
    let p = couple(vi, vo);
    [
        p[0] + COPPER_W_PER_N2 * (p[0] / vi).powi(2),
        p[1] + COPPER_W_PER_N2 * (p[1] / vo).powi(2),
    ]
}

/// Copper loss escalates the family: a world whose copper loss the copper-free members misfit
/// gets a copper member that fits; an excess at the point turn alone (sinkage-like, an effect)
/// is not bent into one.
#[test]
fn the_family_escalates_to_copper_loss_only_when_it_fits() {
    let point_turn_excess = |vi: f64, vo: f64| {
        let p = couple(vi, vo);
        if vi < 0.0 && (vi + vo).abs() < 1e-12 {
            p.map(|w| w + 15.0)
        } else {
            p
        }
    };
    for (power, escalates) in [
        (&with_copper_loss as &dyn Fn(f64, f64) -> [f64; 2], true),
        (&point_turn_excess, false),
    ] {
        let rows = calibration(2, power);
        let refs: Vec<&TurnRow> = rows.iter().collect();
        let b = Baseline::fit(&HUSKY, &refs).expect("fits");
        assert_eq!(b.structure.copper_loss, escalates, "{b:?}");
        let a = test(&refs, 2, |r, s| b.side_power_w(r, s));
        assert_eq!(a.adequate, Some(escalates), "{a:#?}");
    }
}

/// The copper-loss fit (not a family member, see `baseline::family::members`) recovers the
/// coefficient of a world whose sides add c·F², F = P/V the traction force.
#[test]
fn the_copper_member_recovers_its_coefficient() {
    let rows = calibration(2, &with_copper_loss);
    let refs: Vec<&TurnRow> = rows.iter().collect();
    let structure = Structure {
        copper_loss: true,
        ..Structure::PLAIN
    };
    let b = Baseline::fit_member(&HUSKY, &refs, structure).expect("fits");
    assert!(
        (b.copper_w_per_n2 - COPPER_W_PER_N2).abs() < 0.2 * COPPER_W_PER_N2,
        "{b:?}"
    );
    let plain = Baseline::fit_plain(&HUSKY, &refs).expect("fits");
    assert!(
        b.residual_std_w < 0.5 * plain.residual_std_w,
        "{b:?} {plain:?}"
    );
}

/// A side held at stall (the inner side at R′, commanded still) carries the skid couple's
/// tread force a without turning: the copper member predicts its copper loss c·a², the world's
/// C·A², not 0. A side the clamp puts to 0 has no torque (Section 1.1.3: "if the applied torque
/// is 0"), so no copper loss either.
#[test]
fn a_side_held_at_stall_draws_copper_loss_and_a_clamped_side_none() {
    let rows = calibration(2, &with_copper_loss);
    let refs: Vec<&TurnRow> = rows.iter().collect();
    let copper_member = |split| Structure {
        split,
        copper_loss: true,
    };
    let b = Baseline::fit_member(&HUSKY, &refs, copper_member(Split::Regenerating)).expect("fits");
    let mut rng = SplitMix64::new(3);
    let turn_at = |k: f64, rng: &mut SplitMix64| {
        let mut r = row(0, k, rng, &|_, _| [0.0, 0.0]);
        r.yaw_rate_cmd_rad_s = V_C / r.radius_cmd_m;
        r.regime = if k == 1.0 {
            Regime::AtRPrime
        } else {
            Regime::AboveRPrime
        };
        r
    };
    let at_r_prime = turn_at(1.0, &mut rng);
    assert_eq!(at_r_prime.sides[0].cmd_mps, 0.0);
    let held_w = b.side_power_w(&at_r_prime, 0);
    let expected_w = COPPER_W_PER_N2 * A_N * A_N;
    assert!(
        (held_w - expected_w).abs() < 0.2 * expected_w,
        "{held_w} vs {expected_w}"
    );
    let clamped = Baseline::fit_member(
        &HUSKY,
        &refs,
        copper_member(Split::Returning { fraction: 0.0 }),
    )
    .expect("fits");
    let generating = turn_at(2.0, &mut rng);
    assert_eq!(clamped.side_power_w(&generating, 0), 0.0);
    assert!(b.side_power_w(&generating, 0) < 0.0);
}
