use super::slip_sinkage_2d::chord_m;
use super::*;
use core::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use proptest::prelude::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn husky() -> SlipSinkage2d {
    SlipSinkage2d::new(SlipSinkageParams::HUSKY_GRC1).expect("Table 5.1 parameters are valid")
}

fn grc1() -> SandBulldozing {
    SandBulldozing::new(Soil::GRC1_SANDBOX).expect("Table 3.3 soil is valid")
}

// ---- Slip (Eq 1.22–1.23) ----

#[test]
fn longitudinal_slip_eq_1_22() {
    assert_eq!(longitudinal_slip(0.08, 0.02), Ok(0.75));
    assert_eq!(longitudinal_slip(0.08, 0.0), Ok(1.0));
    assert_eq!(longitudinal_slip(0.08, 0.08), Ok(0.0));
    // Skid: the wheel travels faster than it turns.
    assert!(close(
        longitudinal_slip(0.08, 0.1).unwrap_or(0.0),
        -0.25,
        1e-15
    ));
    assert!(longitudinal_slip(0.0, 0.02).is_err());
    assert!(longitudinal_slip(f64::NAN, 0.02).is_err());
    assert!(longitudinal_slip(0.08, f64::INFINITY).is_err());
}

#[test]
fn slip_angle_eq_1_23() {
    let b = |vx, vy| slip_angle_rad(vx, vy).unwrap_or(f64::NAN);
    assert!(close(b(0.1, 0.1), FRAC_PI_4, 1e-15));
    assert!(close(b(0.1, 0.0), FRAC_PI_2, 1e-15));
    assert!(close(b(0.0, 0.3), 0.0, 0.0));
    // Matches tan⁻¹(v_x / v_y) for v_y > 0.
    assert!(close(b(0.07, 0.2), libm::atan(0.07 / 0.2), 1e-15));
    // Backwards: beyond 90°, which tan⁻¹ would fold back.
    assert!(close(b(0.1, -0.1), 3.0 * FRAC_PI_4, 1e-15));
    assert!(slip_angle_rad(0.0, 0.0).is_err());
    assert!(slip_angle_rad(f64::NAN, 1.0).is_err());
}

// ---- Static sinkage (Eq 1.24–1.26) ----

/// Illustrative dry-sand Bekker values of the order Wong tabulates (n_s 1.1, k_c 0.99 kN/m^2.1,
/// k_φ 1528.43 kN/m^3.1); the seed gives none for GRC-1.
const DRY_SAND: BekkerSoil = BekkerSoil {
    cohesive_modulus_si: 990.0,
    frictional_modulus_si: 1_528_430.0,
    sinkage_exponent: 1.1,
};
/// A quarter of the Husky's weight [N].
const QUARTER_HUSKY_N: f64 = 63.0 * 9.81 / 4.0;

#[test]
fn bekker_static_sinkage_solves_eq_1_24() {
    let (r, b) = (0.165, 0.125);
    let s = DRY_SAND
        .static_sinkage(r, b, QUARTER_HUSKY_N)
        .expect("solvable");
    // θ_s carries the load (Eq 1.24) and d_0 follows Eq 1.25.
    let load = DRY_SAND.static_load_n(r, b, s.entry_angle_rad);
    assert!(close(load, QUARTER_HUSKY_N, 1e-9), "{load}");
    assert!(close(
        s.sinkage_m,
        r * (1.0 - libm::cos(s.entry_angle_rad)),
        1e-15
    ));
    // Reference: the same bisection with a 100 000-panel Simpson rule gives 14.0971 mm.
    assert!(close(s.sinkage_m, 0.014_097_1, 2e-6), "{}", s.sinkage_m);
    // No load, no sinkage; more load, more sinkage.
    let zero = DRY_SAND.static_sinkage(r, b, 0.0).expect("solvable");
    assert!(zero.sinkage_m < 1e-12);
    let heavier = DRY_SAND
        .static_sinkage(r, b, 2.0 * QUARTER_HUSKY_N)
        .expect("solvable");
    assert!(heavier.sinkage_m > s.sinkage_m);
}

#[test]
fn bekker_closed_form_eq_1_26() {
    let (r, b) = (0.165, 0.125);
    let d = DRY_SAND
        .closed_form_sinkage_m(r, b, QUARTER_HUSKY_N)
        .expect("valid");
    // [3 · 154.5075 / (1.9 · (990 + 0.125 · 1528430) · √0.33)]^(2/3.2) = 21.898 mm.
    assert!(close(d, 0.021_898_4, 1e-7), "{d}");
    // Eq 1.26 is Bekker's rolling-wheel form (front half of the arc carries the load): it
    // matches Eq 1.24's symmetric static contact at twice the load.
    let sym = DRY_SAND
        .static_sinkage(r, b, 2.0 * QUARTER_HUSKY_N)
        .expect("solvable");
    assert!(
        (sym.sinkage_m / d - 1.0).abs() < 0.01,
        "{} vs {d}",
        sym.sinkage_m
    );
    // n_s ≥ 3 has no closed form.
    let bad = BekkerSoil {
        sinkage_exponent: 3.0,
        ..DRY_SAND
    };
    assert!(bad.closed_form_sinkage_m(r, b, 100.0).is_err());
}

#[test]
fn bekker_rejects_invalid_and_unreachable() {
    let (r, b) = (0.165, 0.125);
    assert_eq!(
        DRY_SAND.static_sinkage(r, b, 1e9),
        Err(SoilError::NoSolution)
    );
    assert!(DRY_SAND.static_sinkage(r, b, -1.0).is_err());
    assert!(DRY_SAND.static_sinkage(r, b, f64::NAN).is_err());
    assert!(DRY_SAND.static_sinkage(0.0, b, 1.0).is_err());
    let soft = BekkerSoil {
        cohesive_modulus_si: 0.0,
        frictional_modulus_si: 0.0,
        ..DRY_SAND
    };
    assert!(soft.static_sinkage(r, b, 1.0).is_err());
    assert!(soft.closed_form_sinkage_m(r, b, 1.0).is_err());
}

// ---- Slip-sinkage laws (Eq 1.27–1.30) ----

#[test]
fn reece_eq_1_27() {
    assert_eq!(reece_sinkage_m(0.01, 0.015, 0.0), Ok(0.01));
    // Sinks by the grouser height at 50 % slip.
    assert!(close(
        reece_sinkage_m(0.01, 0.015, 0.5).unwrap_or(0.0),
        0.025,
        1e-15
    ));
    // Unbounded at 100 %: refused.
    assert!(reece_sinkage_m(0.01, 0.015, 1.0).is_err());
    assert!(reece_sinkage_m(0.01, 0.015, -0.1).is_err());
}

#[test]
fn vasilev_eq_1_28() {
    assert!(close(
        vasilev_sinkage_m(0.01, 0.4, 0.05).unwrap_or(0.0),
        0.03,
        1e-15
    ));
    assert!(vasilev_sinkage_m(0.01, 1.1, 0.05).is_err());
}

#[test]
fn lyasko_eq_1_29_formula_not_the_text() {
    let d0 = 0.01;
    let d = |s| lyasko_sinkage_m(d0, s).unwrap_or(f64::NAN);
    // The formula gives d_0 at 0 % slip (the seed's text says 2 d_0) …
    assert_eq!(d(0.0), d0);
    // … 2 d_0 at 50 % …
    assert!(close(d(0.5), 2.0 * d0, 1e-15));
    // … and 4 d_0 at 100 % (as the text says).
    assert!(close(d(1.0), 4.0 * d0, 1e-15));
    assert!(lyasko_sinkage_m(d0, f64::NAN).is_err());
}

#[test]
fn ding_eq_1_30() {
    let tf = 0.35;
    let d = ding_sinkage_m(0.165, tf, 0.015, 0.4, 0.002).unwrap_or(f64::NAN);
    assert!(close(
        d,
        0.165 * (1.0 - libm::cos(tf)) + 0.006 - 0.002,
        1e-15
    ));
    assert!(ding_sinkage_m(0.165, -0.1, 0.015, 0.4, 0.0).is_err());
}

// ---- Wheel (Table 5.1, Eq 5.18–5.20) ----

#[test]
fn husky_excavation_efficiency_eq_5_20_uses_contact_width() {
    // 1 − 28 · 0.085 · 0.011 / (2π · 0.165 · 1.05 · 0.125) = 1 − 0.02618 / 0.136070.
    let k = Wheel::HUSKY.excavation_efficiency(1.05).unwrap_or(0.0);
    assert!(close(k, 0.8076, 5e-5), "{k}");
    assert!(close(k, 0.807_599_36, 1e-8), "{k}");
    // B_c = B_w (rigid reading) gives 0.7980, not the published 0.8076.
    let rigid = Wheel::HUSKY.excavation_efficiency(1.0).unwrap_or(0.0);
    assert!(close(rigid, 0.797_979_3, 1e-7), "{rigid}");
    assert!((rigid - 0.8076).abs() > 5e-3);
    assert_eq!(SlipSinkageParams::HUSKY_GRC1.excavation_efficiency, k);
}

#[test]
fn wheel_rejects_invalid() {
    assert!(Wheel::HUSKY.excavation_efficiency(0.9).is_err());
    assert!(Wheel::HUSKY.excavation_efficiency(f64::NAN).is_err());
    let solid = Wheel {
        grouser_count: 400,
        ..Wheel::HUSKY
    };
    assert!(solid.excavation_efficiency(1.05).is_err());
    let no_radius = Wheel {
        radius_m: 0.0,
        ..Wheel::HUSKY
    };
    assert!(no_radius.validate().is_err());
    let slick = Wheel {
        grouser_count: 0,
        ..Wheel::HUSKY
    };
    assert_eq!(slick.excavation_efficiency(1.0), Ok(1.0));
}

#[test]
fn ground_width_eq_5_26() {
    // d_avg = 0.0085: 2 √(0.0085 · 0.3215) = 0.104551.
    assert!(close(
        ground_width_m(0.0085, 0.165).unwrap_or(0.0),
        0.104_551_4,
        1e-7
    ));
    // Full depth of the axle: the diameter.
    assert!(close(
        ground_width_m(0.165, 0.165).unwrap_or(0.0),
        0.33,
        1e-15
    ));
    assert_eq!(ground_width_m(0.0, 0.165), Ok(0.0));
    assert!(ground_width_m(0.4, 0.165).is_err());
    assert!(ground_width_m(-0.01, 0.165).is_err());
}

// ---- 2D slip-sinkage model (Eq 5.15–5.28) ----

#[test]
fn slip_sinkage_starts_at_static_sinkage_with_eq_5_15_to_5_26_geometry() {
    let m = husky();
    assert_eq!(m.sinkage_m(), 0.01);
    // Eq 5.15–5.17 at d = 0.01, λ = 0.7: θ_f = acos(1 − 0.01/0.165) = 0.349938,
    // θ_r = acos(1 − 0.007/0.165) = 0.292327, w_c = 0.165 · 0.642265 = 0.105974.
    assert!(close(m.front_angle_rad(), 0.349_938_09, 1e-8));
    assert!(close(m.rear_angle_rad(), 0.292_327_39, 1e-8));
    assert!(close(m.contact_length_m(), 0.105_973_80, 1e-8));
    // Eq 5.25–5.26.
    assert!(close(m.average_sinkage_m(), 0.0085, 1e-15));
    assert!(close(m.ground_width_m(), 0.104_551_42, 1e-8));
}

#[test]
fn one_step_by_hand_beta_0() {
    // Fig 5.10 red case: β = 0, v_CMD = 0.08, v_ACT = 0.02 m/s; δt = 0.1 s from d_0 = 0.01.
    // V_REM = 0.807599 · 0.13125 · 0.015 · 0.08 · 0.1          = 1.271969e-5 m³ (Eq 5.19)
    // V_front = 0.02 · 0.1 · 1 · 0.125 · 0.01                    = 2.5e-6 m³ (Eq 5.21, 5.23)
    // V_ADD = 0.85 · 2.5e-6                                      = 2.125e-6 m³ (Eq 5.27)
    // d = 0.01 + (1.271969e-5 − 2.125e-6) / (0.13125 · 0.105974) = 0.01076171 m (Eq 5.28)
    let mut m = husky();
    let s = m.step(0.02, 0.0, 0.08, 0.1).expect("valid");
    assert!(close(s.removed_m3, 1.271_969e-5, 1e-11), "{}", s.removed_m3);
    assert!(close(s.front_m3, 2.5e-6, 1e-18));
    assert_eq!(s.side_m3, 0.0);
    assert!(close(s.added_m3, 2.125e-6, 1e-18));
    assert!(close(s.sinkage_m, 0.010_761_711, 1e-9), "{}", s.sinkage_m);
    assert_eq!(m.sinkage_m(), s.sinkage_m);
    assert!(!s.saturated);
}

#[test]
fn one_step_by_hand_beta_90() {
    // Fig 5.10 blue case: β = 90°. V_front ≈ 0 (cos 90° rounds to 6e-17);
    // V_side = 0.02 · 0.1 · 0.1045514 · 0.01 = 2.091028e-6 m³ (Eq 5.22, 5.24, w_g of d_0);
    // V_ADD = 0.35 · V_side = 7.318600e-7 m³;
    // d = 0.01 + (1.271969e-5 − 7.3186e-7) / (0.13125 · 0.105974) = 0.01086187 m.
    let mut m = husky();
    let s = m.step(0.02, FRAC_PI_2, 0.08, 0.1).expect("valid");
    assert!(s.front_m3 < 1e-20);
    assert!(close(s.side_m3, 2.091_028e-6, 1e-12), "{}", s.side_m3);
    assert!(close(s.added_m3, 7.318_600e-7, 1e-12));
    assert!(close(s.sinkage_m, 0.010_861_872, 1e-9), "{}", s.sinkage_m);
}

/// Sinkage after `seconds` of a constant linear path at 20 Hz.
fn linear_path(v_act: f64, beta: f64, v_cmd: f64, seconds: f64) -> SlipSinkage2d {
    let mut m = husky();
    let n = (seconds * 20.0) as usize;
    for _ in 0..n {
        m.step(v_act, beta, v_cmd, 0.05).expect("valid");
    }
    m
}

#[test]
fn fig_5_10_linear_paths_qualitatively() {
    let front = |t| linear_path(0.02, 0.0, 0.08, t).sinkage_m();
    let side = |t| linear_path(0.02, FRAC_PI_2, 0.08, t).sinkage_m();
    let full_slip = |t| linear_path(0.0, 0.0, 0.08, t).sinkage_m();
    let mut last = (0.01, 0.01, 0.01);
    for t in [2.0, 5.0, 10.0, 20.0, 40.0] {
        let now = (front(t), side(t), full_slip(t));
        // All three sink.
        assert!(
            now.0 > last.0 && now.1 > last.1 && now.2 > last.2,
            "t={t}: {now:?}"
        );
        // Side-slipping sinks faster than rolling forwards (k_s w_g < k_f B_w at these
        // depths), and 100 % slip (V_ADD = 0) fastest of all.
        assert!(now.1 > now.0, "t={t}: {now:?}");
        assert!(now.2 > now.1, "t={t}: {now:?}");
        last = now;
    }
}

#[test]
fn full_slip_only_removes() {
    let mut m = husky();
    let w_c = m.contact_length_m();
    let b_c = 1.05 * 0.125;
    let s = m.step(0.0, 0.3, 0.08, 0.1).expect("valid");
    assert_eq!(s.added_m3, 0.0);
    assert!(close(s.sinkage_m - 0.01, s.removed_m3 / (b_c * w_c), 1e-15));
    // v_CMD = 0 with motion: only V_ADD, and d_0 is the floor.
    let mut m = husky();
    let s = m.step(0.05, 0.3, 0.0, 0.1).expect("valid");
    assert_eq!(s.removed_m3, 0.0);
    assert!(s.saturated);
    assert_eq!(s.sinkage_m, 0.01);
}

#[test]
fn steady_state_beta_0_where_removed_equals_added() {
    // V_REM = V_ADD ⇔ k_EX B_c h v_CMD = k_f B_w v_ACT d*
    // ⇒ d* = 0.807599 · 0.13125 · 0.015 · 0.08 / (0.85 · 0.125 · 0.02) = 0.0598574 m.
    let p = SlipSinkageParams::HUSKY_GRC1;
    let d_star = p.excavation_efficiency * 1.05 * 0.125 * 0.015 * 0.08 / (0.85 * 0.125 * 0.02);
    assert!(close(d_star, 0.059_857_4, 1e-7));
    let mut m = husky();
    m.set_sinkage_m(d_star).expect("in bounds");
    let s = m.step(0.02, 0.0, 0.08, 0.05).expect("valid");
    assert!(close(s.removed_m3, s.added_m3, 1e-18));
    assert!(close(s.sinkage_m, d_star, 1e-15));
    // Reached from d_0 too.
    let end = linear_path(0.02, 0.0, 0.08, 3000.0).sinkage_m();
    assert!(close(end, d_star, 1e-6), "{end}");
}

#[test]
fn steady_state_beta_90_solves_d_w_g_of_d() {
    // V_REM = V_ADD ⇔ d w_g(d) = k_EX B_c h v_CMD / (k_s v_ACT) (Eq 5.24–5.27 at β = 90°).
    let p = SlipSinkageParams::HUSKY_GRC1;
    let target = p.excavation_efficiency * 1.05 * 0.125 * 0.015 * 0.08 / (0.35 * 0.02);
    let f = |d: f64| d * chord_m(0.85 * d, 0.165) - target;
    let (mut lo, mut hi) = (0.01, 0.13);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d_star = 0.5 * (lo + hi);
    // Deeper than the β = 0 steady state: the side meets less sand than the front.
    assert!(d_star > 0.0599 && d_star < 0.13, "{d_star}");
    let end = linear_path(0.02, FRAC_PI_2, 0.08, 3000.0).sinkage_m();
    assert!(close(end, d_star, 1e-6), "{end} vs {d_star}");
}

#[test]
fn sign_conventions_are_magnitudes() {
    let run = |v_act: f64, beta: f64, v_cmd: f64| {
        let mut m = husky();
        m.step(v_act, beta, v_cmd, 0.1)
            .map(|s| s.sinkage_m)
            .unwrap_or(0.0)
    };
    let base = run(0.02, 0.4, 0.08);
    assert_eq!(run(-0.02, 0.4, 0.08), base);
    assert_eq!(run(0.02, -0.4, 0.08), base);
    assert_eq!(run(0.02, 0.4, -0.08), base);
    assert!(close(run(0.02, PI - 0.4, 0.08), base, 1e-15));
}

#[test]
fn saturates_at_ground_clearance() {
    let mut m = husky();
    let s = m.step(0.0, 0.0, 100.0, 1.0).expect("valid");
    assert!(s.saturated);
    assert_eq!(s.sinkage_m, 0.13);
    // Stays there while digging.
    let s = m.step(0.0, 0.0, 0.08, 0.05).expect("valid");
    assert_eq!(s.sinkage_m, 0.13);
}

#[test]
fn invalid_inputs_rejected_state_unchanged() {
    let mut m = husky();
    m.step(0.02, 0.0, 0.08, 1.0).expect("valid");
    let before = m;
    for (v, b, c, dt) in [
        (f64::NAN, 0.0, 0.08, 0.05),
        (0.02, f64::NAN, 0.08, 0.05),
        (0.02, 0.0, f64::INFINITY, 0.05),
        (0.02, 0.0, 0.08, f64::NAN),
        (0.02, 0.0, 0.08, 0.0),
        (0.02, 0.0, 0.08, -0.05),
        (0.02, f64::NEG_INFINITY, 0.08, 0.05),
    ] {
        assert!(matches!(
            m.step(v, b, c, dt),
            Err(SoilError::InvalidInput(_))
        ));
        assert_eq!(m, before);
    }
    // Finite but overflowing: ∞ − ∞.
    assert_eq!(m.step(1e300, 0.0, 1e300, 1e300), Err(SoilError::Overflow));
    assert_eq!(m, before);
    assert!(m.set_sinkage_m(0.2).is_err());
    assert!(m.set_sinkage_m(0.005).is_err());
    assert_eq!(m, before);
    m.reset();
    assert_eq!(m.sinkage_m(), 0.01);
}

#[test]
fn invalid_params_rejected() {
    let p = SlipSinkageParams::HUSKY_GRC1;
    let bad = [
        SlipSinkageParams {
            static_sinkage_m: 0.0,
            ..p
        },
        SlipSinkageParams {
            ground_clearance_m: 0.005,
            ..p
        },
        SlipSinkageParams {
            ground_clearance_m: 0.4,
            ..p
        },
        SlipSinkageParams {
            sinkage_ratio: 0.0,
            ..p
        },
        SlipSinkageParams {
            sinkage_ratio: 3.0,
            ..p
        },
        SlipSinkageParams {
            contact_ratio: 0.95,
            ..p
        },
        SlipSinkageParams {
            excavation_efficiency: 1.2,
            ..p
        },
        SlipSinkageParams {
            front_compaction: -0.1,
            ..p
        },
        SlipSinkageParams {
            side_compaction: f64::NAN,
            ..p
        },
    ];
    for params in bad {
        assert!(SlipSinkage2d::new(params).is_err(), "{params:?}");
    }
}

/// Any steps, however absurd: a step either succeeds within the sinkage bounds or is refused
/// and leaves the model as it was.
fn check_sinkage_within_bounds(steps: &[(f64, f64, f64, f64)]) -> Result<(), TestCaseError> {
    let mut m = husky();
    for &(v_act, beta, v_cmd, dt) in steps {
        let before = m;
        match m.step(v_act, beta, v_cmd, dt) {
            Ok(s) => {
                prop_assert!(s.sinkage_m >= 0.01 && s.sinkage_m <= 0.13, "{:?}", s);
                prop_assert_eq!(s.sinkage_m, m.sinkage_m());
            }
            Err(_) => prop_assert_eq!(m, before),
        }
        prop_assert!(m.sinkage_m() >= 0.01 && m.sinkage_m() <= 0.13);
        prop_assert!(m.front_angle_rad().is_finite() && m.ground_width_m().is_finite());
    }
    Ok(())
}

/// Plausible inputs repeated `n` times always step, within the bounds.
fn check_plausible_steps(
    v_act: f64,
    beta: f64,
    v_cmd: f64,
    dt: f64,
    n: usize,
) -> Result<(), TestCaseError> {
    let mut m = husky();
    for _ in 0..n {
        let s = m.step(v_act, beta, v_cmd, dt);
        prop_assert!(s.is_ok());
        prop_assert!(m.sinkage_m() >= 0.01 && m.sinkage_m() <= 0.13);
    }
    Ok(())
}

/// Cases the property tests below once found (kept as fixed tests, not as seed files).
#[test]
fn sinkage_regressions() {
    check_sinkage_within_bounds(&[(4.705012694774521e108, 0.0, 0.0, 1.157889292520559e-11)])
        .expect("a huge actual speed over a tiny step");
    check_plausible_steps(0.0, 0.0, 0.8056004784294887, 3.76796238865884, 1)
        .expect("standing still under a command for 3.8 s");
}

proptest! {
    #[test]
    fn sinkage_always_within_bounds(
        steps in proptest::collection::vec(
            (any::<f64>(), any::<f64>(), any::<f64>(), any::<f64>()), 1..40)
    ) {
        check_sinkage_within_bounds(&steps)?;
    }

    #[test]
    fn sinkage_within_bounds_for_plausible_inputs(
        v_act in -2.0f64..2.0, beta in -7.0f64..7.0, v_cmd in -2.0f64..2.0,
        dt in 1e-4f64..5.0, n in 1usize..200,
    ) {
        check_plausible_steps(v_act, beta, v_cmd, dt, n)?;
    }
}

// ---- Sand bulldozing, Section 5.4 (Eq 5.29–5.39) ----

#[test]
fn grc1_soil_table_3_3() {
    let s = Soil::GRC1_SANDBOX;
    assert_eq!(s.density_kg_m3, 1788.5);
    assert!(close(s.internal_friction_rad, 42f64.to_radians(), 1e-15));
    assert!(close(s.repose_angle_rad, 42f64.to_radians(), 1e-15));
    assert_eq!((s.external_friction_rad, s.cohesion_pa), (0.0, 0.0));
    assert!(s.validate().is_ok());
    assert!(close(grc1_bulk_density_kg_m3(65.0), s.density_kg_m3, 1e-9));
}

#[test]
fn no_pile_is_rankine_passive_at_bekker_angle() {
    // x_w = 0: Eq 5.35 is w ρg d²/2 · cot X / cot(X + φ), minimised at X = 45° − φ/2 (the
    // Bekker angle of Eq 1.35) where it equals w ρg d² K_p / 2, K_p = tan²(45° + φ/2).
    // w = 0.1, d = 0.03: 0.1 · 1788.5 · 9.81 · 0.0009 · 5.044681 / 2 = 3.982944 N.
    let f = grc1().force(0.1, 0.03, 0.0, 0.2).expect("valid");
    let x_c = f.failure_angle_rad.unwrap_or(0.0);
    assert!(close(x_c, 24f64.to_radians(), 1e-7), "{}", x_c.to_degrees());
    assert!(close(f.force_n, 3.982_944, 1e-6), "{}", f.force_n);
    assert_eq!(f.pile_base_m, 0.0);
    assert!(!f.pile_saturated);
}

#[test]
fn minimising_angle_is_interior_and_beats_neighbours_and_a_grid() {
    let m = grc1();
    let (lo, hi) = m.failure_angle_interval_rad();
    assert!(close(hi, 48f64.to_radians(), 1e-15));
    for (d, x) in [
        (0.01, 0.0),
        (0.01, 0.1),
        (0.05, 0.02),
        (0.05, 0.5),
        (0.1, 3.0),
    ] {
        let f = m.force(0.2, d, x, 10.0).expect("valid");
        let x_c = f.failure_angle_rad.unwrap_or(f64::NAN);
        assert!(x_c > lo + 1e-3 && x_c < hi - 1e-3, "{x_c}");
        let at = |a| m.force_at_angle_n(0.2, d, f.pile_base_m, a);
        assert!(close(at(x_c), f.force_n, 1e-12 * f.force_n));
        assert!(at(x_c - 1e-3) > f.force_n && at(x_c + 1e-3) > f.force_n);
        let grid_min = (1..4000)
            .map(|i| at(hi * i as f64 / 4000.0))
            .fold(f64::INFINITY, f64::min);
        assert!(
            f.force_n <= grid_min * (1.0 + 1e-12),
            "{} > {grid_min}",
            f.force_n
        );
    }
}

#[test]
fn minimiser_satisfies_the_analytic_stationarity_condition() {
    // d/dX ln[(a cot X + b) sin(X+φ)/cos(X+φ+δ)] = 0 with a = d², b = r_q² tan φ reduces to
    // a sin(X+φ) cos(X+φ+δ) = cos δ (a sin X cos X + b sin² X).
    for delta_deg in [0.0, 5.0, 20.0] {
        let soil = Soil {
            external_friction_rad: f64::to_radians(delta_deg),
            ..Soil::GRC1_SANDBOX
        };
        let m = SandBulldozing::new(soil).expect("valid");
        for (d, x) in [(0.02, 0.0), (0.02, 0.05), (0.06, 0.4)] {
            let f = m.force(0.1, d, x, 10.0).expect("valid");
            let xc = f.failure_angle_rad.unwrap_or(f64::NAN);
            let (phi, dl) = (soil.internal_friction_rad, soil.external_friction_rad);
            let a = d * d;
            let b = f.pile_base_m * f.pile_base_m * libm::tan(phi);
            let lhs = a * libm::sin(xc + phi) * libm::cos(xc + phi + dl);
            let rhs =
                libm::cos(dl) * (a * libm::sin(xc) * libm::cos(xc) + b * libm::sin(xc).powi(2));
            // Residual linear in the angle error; the search brackets X_C to ~4e-9 rad.
            assert!(
                close(lhs, rhs, 5e-8 * a),
                "δ={delta_deg} d={d} x={x}: {lhs} {rhs}"
            );
        }
    }
}

#[test]
fn force_grows_with_travel_then_levels_off_at_repose() {
    // Constant d_avg = 0.051 m (Husky near its β = 0 steady state), w_g = 0.2386 m, β = 90°,
    // v_ACT = 0.1 m/s, 20 Hz. Pile stops at x_w^MAX = (w_g tan 42°)² cot 42° / (2 · 0.051).
    let d_avg = 0.051;
    let w_g = chord_m(d_avg, 0.165);
    let mut b = SandBulldozer::new(Soil::GRC1_SANDBOX, PileLimit::SteadyStateGroundWidth(w_g))
        .expect("valid");
    assert_eq!(b.model().pile_limit_travel_m(w_g, 0.0), f64::INFINITY);
    let x_max = b.model().pile_limit_travel_m(w_g, d_avg);
    assert!(close(
        x_max,
        w_g * w_g * libm::tan(42f64.to_radians()) / (2.0 * d_avg),
        1e-12
    ));
    assert!(close(x_max, 0.5024, 1e-4), "{x_max}");
    let mut last = 0.0;
    let mut levelled = None;
    for k in 0..200 {
        let s = b.step(d_avg, w_g, FRAC_PI_2, 0.1, 0.05).expect("valid");
        assert!(close(s.travel_m, 0.005 * (k + 1) as f64, 1e-12));
        if s.travel_m < x_max - 1e-9 {
            assert!(s.force.force_n > last, "k={k}");
            assert!(!s.force.pile_saturated);
        } else {
            assert!(s.force.pile_saturated);
            // r_q^MAX = w_g^MAX for φ_r = φ_i.
            assert!(close(s.force.pile_base_m, w_g, 1e-12));
            let level = *levelled.get_or_insert(s.force.force_n);
            assert_eq!(s.force.force_n, level);
        }
        assert!(close(s.power_w, s.force.force_n * 0.1, 1e-12));
        last = s.force.force_n;
    }
    let level = levelled.unwrap_or(0.0);
    // The level equals the unsaturated force exactly at x_w^MAX.
    let at_max = b
        .model()
        .force(w_g, d_avg, x_max, 1e3)
        .expect("valid")
        .force_n;
    assert!(close(level, at_max, 1e-9 * at_max), "{level} {at_max}");
    // And is several times the no-pile force.
    let start = b
        .model()
        .force(w_g, d_avg, 0.0, w_g)
        .expect("valid")
        .force_n;
    assert!(level > 3.0 * start, "{level} {start}");
}

#[test]
fn zero_force_without_width_or_sinkage() {
    let m = grc1();
    let none = m.force(0.0, 0.05, 0.3, 0.2).expect("valid");
    assert_eq!((none.force_n, none.failure_angle_rad), (0.0, None));
    let none = m.force(0.2, 0.0, 0.3, 0.2).expect("valid");
    assert_eq!((none.force_n, none.failure_angle_rad), (0.0, None));
    // β = 0: the wheel rolls along its heading, w = 0 (Eq 5.31).
    let mut b = SandBulldozer::new(Soil::GRC1_SANDBOX, PileLimit::RunningMax).expect("valid");
    let s = b.step(0.05, 0.2, 0.0, 0.3, 0.05).expect("valid");
    assert_eq!(s.projected_width_m, 0.0);
    assert_eq!((s.force.force_n, s.power_w), (0.0, 0.0));
}

#[test]
fn force_increases_with_density() {
    let mut last = 0.0;
    for rho in [1600.0, 1700.0, 1788.5, 1890.0] {
        let soil = Soil {
            density_kg_m3: rho,
            ..Soil::GRC1_SANDBOX
        };
        let f = SandBulldozing::new(soil)
            .and_then(|m| m.force(0.2, 0.04, 0.1, 0.3))
            .expect("valid")
            .force_n;
        assert!(f > last);
        last = f;
    }
}

#[test]
fn force_increases_with_sinkage_and_width() {
    let m = grc1();
    let f = |w, d| {
        m.force(w, d, 0.1, 0.3)
            .map(|f| f.force_n)
            .unwrap_or(f64::NAN)
    };
    assert!(f(0.2, 0.02) < f(0.2, 0.04));
    assert!(close(f(0.2, 0.04), 2.0 * f(0.1, 0.04), 1e-12));
}

/// Eq 5.29 with its I_{X_C} term restored (dimensionally corrected), c = 0, α_1 = 90°.
fn full_eq_5_29(m: &SandBulldozing, w: f64, d: f64, r_q: f64, x_c: f64) -> f64 {
    let phi = m.soil().internal_friction_rad;
    let r_alpha = d / libm::tan(x_c);
    let mut bracket = d * r_alpha + r_q * r_q * libm::tan(phi);
    if r_q > r_alpha {
        bracket -= (r_q - r_alpha).powi(2) / (1.0 / libm::tan(phi) + 1.0 / libm::tan(x_c));
    }
    w * m.soil().unit_weight_n_m3() / 2.0 * bracket * libm::sin(x_c + phi)
        / libm::cos(x_c + phi + m.soil().external_friction_rad)
}

proptest! {
    #[test]
    fn indicator_is_zero_at_the_minimum(d in 1e-3f64..0.15, x in 0.0f64..5.0) {
        // The seed's I_{X_C} = 0: r_q < r_α at the minimising X_C (δ = 0) …
        let m = grc1();
        let f = m.force(0.2, d, x, 100.0).expect("valid");
        prop_assert!(f.pile_base_m < f.failure_base_m, "{:?}", f);
        // … and restoring the I term elsewhere does not find a lower force on a grid.
        let (_, hi) = m.failure_angle_interval_rad();
        for i in 1..400 {
            let a = hi * i as f64 / 400.0;
            prop_assert!(full_eq_5_29(&m, 0.2, d, f.pile_base_m, a) >= f.force_n * (1.0 - 1e-12));
        }
    }

    #[test]
    fn bulldozer_never_panics_or_goes_negative(
        steps in proptest::collection::vec(
            (any::<f64>(), any::<f64>(), any::<f64>(), any::<f64>(), any::<f64>()), 1..20)
    ) {
        let mut b = SandBulldozer::new(Soil::GRC1_SANDBOX, PileLimit::RunningMax).expect("valid");
        for (d, wg, beta, v, dt) in steps {
            let before = b;
            match b.step(d, wg, beta, v, dt) {
                Ok(s) => prop_assert!(s.force.force_n >= 0.0 && s.power_w >= 0.0),
                Err(_) => prop_assert_eq!(b, before),
            }
        }
    }
}

#[test]
fn bulldozer_running_max_and_reset() {
    let mut b = SandBulldozer::new(Soil::GRC1_SANDBOX, PileLimit::RunningMax).expect("valid");
    b.step(0.02, 0.15, 1.0, 0.1, 0.1).expect("valid");
    b.step(0.02, 0.10, 1.0, 0.2, 0.1).expect("valid");
    assert_eq!(b.max_ground_width_m(), 0.15);
    // Trapezoid: 0.1 · 0.1 (first sample, own speed) + 0.15 · 0.1.
    assert!(close(b.travel_m(), 0.025, 1e-15));
    assert!(b.step(0.02, 0.1, 1.0, 0.2, 0.0).is_err());
    assert!(b.step(-0.02, 0.1, 1.0, 0.2, 0.1).is_err());
    assert!(close(b.travel_m(), 0.025, 1e-15));
    b.reset();
    assert_eq!((b.travel_m(), b.max_ground_width_m()), (0.0, 0.0));
    assert!(
        SandBulldozer::new(Soil::GRC1_SANDBOX, PileLimit::SteadyStateGroundWidth(-1.0)).is_err()
    );
}

#[test]
fn power_and_four_wheel_totals_eq_5_37_to_5_39() {
    assert!(close(bulldozing_power_w(12.0, -0.05), 0.6, 1e-15));
    assert_eq!(four_wheel_total(1.5, 4.0), 11.0);
}

#[test]
fn bulldozing_rejects_cohesion_and_bad_angles() {
    let cohesive = Soil {
        cohesion_pa: 500.0,
        ..Soil::GRC1_SANDBOX
    };
    assert!(SandBulldozing::new(cohesive).is_err());
    let steep = Soil {
        external_friction_rad: 50f64.to_radians(),
        ..Soil::GRC1_SANDBOX
    };
    assert!(SandBulldozing::new(steep).is_err());
    let m = grc1();
    assert!(m.force(-0.1, 0.05, 0.1, 0.2).is_err());
    assert!(m.force(0.1, f64::NAN, 0.1, 0.2).is_err());
}

// ---- Ishigami bulldozing (Eq 1.31–1.35) ----

#[test]
fn ishigami_coefficients_by_hand() {
    // φ_i = 42°: X_C = 24° (Eq 1.35); cot 24° = tan 66° = 2.246037;
    // D_1 = 2 · 2.246037 = 4.492074 (Eq 1.33);
    // D_2 = 2.246037 + 2.246037² · tan 42° = 2.246037 + 4.542251 = 6.788288 (Eq 1.34).
    assert!(close(
        bekker_failure_angle_rad(42f64.to_radians()),
        24f64.to_radians(),
        1e-15
    ));
    let m = IshigamiBulldozing::new(Soil::GRC1_SANDBOX).expect("valid");
    let (d1, d2) = m.coefficients();
    assert!(close(d1, 4.492_074, 1e-6), "{d1}");
    assert!(close(d2, 6.788_288, 1e-6), "{d2}");
    // Eq 1.32 at h = 0.05 m, c = 0: D_1 D_2 ρg h²/2 = 668.767 N/m.
    assert!(close(m.resistance_n_per_m(0.05), 668.767_4, 1e-3));
    let cohesive = IshigamiBulldozing::new(Soil {
        cohesion_pa: 1000.0,
        ..Soil::GRC1_SANDBOX
    })
    .expect("valid");
    assert!(close(
        cohesive.resistance_n_per_m(0.05) - m.resistance_n_per_m(0.05),
        d1 * 1000.0 * 0.05,
        1e-9
    ));
}

#[test]
fn ishigami_side_force_zero_then_growing() {
    let m = IshigamiBulldozing::new(Soil::GRC1_SANDBOX).expect("valid");
    assert_eq!(m.side_force_for_sinkage_n(0.165, 0.0, 0.7), Ok(0.0));
    let mut last = 0.0;
    for d in [0.005, 0.01, 0.02, 0.04, 0.08] {
        let f = m.side_force_for_sinkage_n(0.165, d, 0.7).expect("valid");
        assert!(f > last, "{d}: {f}");
        last = f;
    }
    assert!(m.side_force_n(0.165, f64::NAN, 0.1).is_err());
    assert!(m.side_force_for_sinkage_n(0.165, 0.5, 0.7).is_err());
}

#[test]
fn ishigami_simpson_matches_a_fine_midpoint_rule() {
    let m = IshigamiBulldozing::new(Soil::GRC1_SANDBOX).expect("valid");
    let (r, tf, tr) = (0.165, 0.6, 0.45);
    let coarse = m.side_force_n(r, tf, tr).expect("valid");
    let n = 200_000;
    let h = (tf + tr) / n as f64;
    let fine: f64 = (0..n)
        .map(|i| {
            let t = -tr + (i as f64 + 0.5) * h;
            let depth = (r * (libm::cos(t) - libm::cos(tf))).max(0.0);
            m.resistance_n_per_m(depth) * (r - depth * libm::cos(t)) * h
        })
        .sum();
    assert!((coarse / fine - 1.0).abs() < 1e-6, "{coarse} {fine}");
}

// ---- Cone index (Eq 3.1–3.2) ----

#[test]
fn cone_index_gradient_exact_on_linear_data() {
    let mut samples = [(0.0, 0.0); 11];
    for (i, s) in samples.iter_mut().enumerate() {
        let depth = 10.0 * i as f64;
        *s = (depth, 12.0 + 7.25 * depth);
    }
    let g = cone_index_gradient_kpa_per_mm(&samples).expect("valid");
    assert!(close(g, 7.25, 1e-12), "{g}");
    // Order does not matter; an offset in CI does not matter.
    samples.reverse();
    let shifted = samples.map(|(d, ci)| (d, ci + 100.0));
    assert!(close(
        cone_index_gradient_kpa_per_mm(&shifted).unwrap_or(0.0),
        7.25,
        1e-12
    ));
    // Least squares: symmetric noise around the line leaves the slope.
    let noisy = [(0.0, 1.0), (0.0, -1.0), (10.0, 21.0), (10.0, 19.0)];
    assert!(close(
        cone_index_gradient_kpa_per_mm(&noisy).unwrap_or(0.0),
        2.0,
        1e-12
    ));
}

#[test]
fn cone_index_gradient_rejects_degenerate() {
    assert_eq!(
        cone_index_gradient_kpa_per_mm(&[]),
        Err(SoilError::DegenerateData)
    );
    assert_eq!(
        cone_index_gradient_kpa_per_mm(&[(5.0, 1.0)]),
        Err(SoilError::DegenerateData)
    );
    assert_eq!(
        cone_index_gradient_kpa_per_mm(&[(5.0, 1.0), (5.0, 3.0)]),
        Err(SoilError::DegenerateData)
    );
    assert!(matches!(
        cone_index_gradient_kpa_per_mm(&[(5.0, 1.0), (f64::NAN, 3.0)]),
        Err(SoilError::InvalidInput(_))
    ));
}

#[test]
fn grc1_relative_density_eq_3_2() {
    for d_r in [0.0, 37.5, 65.0, 100.0] {
        let g = grc1_cone_index_gradient_kpa_per_mm(d_r);
        assert!(close(grc1_relative_density_percent(g), d_r, 1e-12));
    }
    // The seed's choice, D_R = 65 %, is G_CI = 7.0021 kPa/mm …
    assert!(close(
        grc1_cone_index_gradient_kpa_per_mm(65.0),
        7.0021,
        1e-12
    ));
    // … while Table 3.4's sandbox gradient, 9.5 kPa/mm, gives 94.95 % (± 0.8 → 85.4–104.5).
    let d_r = grc1_relative_density_percent(9.5);
    assert!(close(d_r, 94.950_84, 1e-4), "{d_r}");
    assert!(grc1_relative_density_percent(8.7) > 85.0);
}
