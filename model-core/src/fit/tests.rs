use super::student_t::{cornish_fisher_t, normal_upper_quantile, t_upper_quantile_bisection};
use super::*;
use crate::kinematics::SideSpeeds;
use crate::rng::SplitMix64;
use proptest::prelude::*;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn f_upper_tail_matches_tables_and_t() {
    // F(0.95; 2, 4) = 6.944272, F(0.99; 6, 8) = 6.370681 (standard F tables).
    assert!(close(
        f_upper_tail(6.944_272, 2, 4).expect("valid"),
        0.05,
        1e-6
    ));
    assert!(close(
        f_upper_tail(6.370_681, 6, 8).expect("valid"),
        0.01,
        1e-6
    ));
    // F(1, ν) is t² with ν degrees of freedom.
    let t = 2.228_139;
    let two_tail = 2.0 * (1.0 - student_t_cdf(t, 10).expect("valid"));
    assert!(close(
        f_upper_tail(t * t, 1, 10).expect("valid"),
        two_tail,
        1e-9
    ));
    assert_eq!(f_upper_tail(0.0, 3, 3), Ok(1.0));
    assert_eq!(f_upper_tail(1.0, 0, 3), Err(FitError::InvalidParameter));
}

/// Straight-line regression: the mean response's standard error has the textbook closed
/// form s √(1/n + (x₀ − x̄)²/Sxx), and the covariance's diagonal is the squared SEs.
#[test]
fn prediction_standard_error_matches_the_straight_line_formula() {
    let xs = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
    let ys = [0.1, 1.9, 4.2, 5.8, 8.3, 9.7];
    let rows: Vec<[f64; 2]> = xs.iter().map(|&x| [1.0, x]).collect();
    let fit = LinearFit::<2>::from_rows(&rows, &ys)
        .expect("rows")
        .solve()
        .expect("solves");
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let sxx: f64 = xs.iter().map(|x| (x - mean) * (x - mean)).sum();
    let s = fit.residual_standard_error;
    for x0 in [-1.0, 0.0, 2.5, 7.0] {
        let want = s * libm::sqrt(1.0 / n + (x0 - mean) * (x0 - mean) / sxx);
        let got = fit.prediction_standard_error([1.0, x0]);
        assert!(
            close(got, want, 1e-12 * want.max(1.0)),
            "x0 {x0}: {got} vs {want}"
        );
    }
    for (i, e) in fit.estimates.iter().enumerate() {
        assert!(close(fit.covariance[i][i].sqrt(), e.standard_error, 1e-12));
    }
    assert!(close(fit.covariance[0][1], fit.covariance[1][0], 1e-15));
    assert!(
        fit.covariance[0][1] < 0.0,
        "intercept and slope anticorrelate for x̄ > 0"
    );
}

#[test]
fn t_quantiles_match_tables() {
    // Reference values from standard t tables (6 decimals).
    let cases = [
        (0.975, 1, 12.706_205),
        (0.975, 2, 4.302_653),
        (0.975, 5, 2.570_582),
        (0.975, 10, 2.228_139),
        (0.975, 30, 2.042_272),
        (0.975, 100, 1.983_972),
        (0.995, 10, 3.169_273),
        (0.9, 3, 1.637_744),
        (0.975, 1_000_000, 1.959_966),
        (0.975, usize::MAX, 1.959_964),
    ];
    for (p, dof, want) in cases {
        let got = student_t_quantile(p, dof).expect("valid");
        println!("t({p}, {dof}) = {got:.6}");
        assert!(close(got, want, 1e-5), "t({p}, {dof}) = {got}, want {want}");
        let low = student_t_quantile(1.0 - p, dof).expect("valid");
        assert!(close(low, -got, 1e-9), "symmetry at dof {dof}");
    }
    assert_eq!(student_t_quantile(0.5, 7), Ok(0.0));
}

#[test]
fn t_quantile_matches_closed_forms_for_one_and_two_dof() {
    // ν = 1 (Cauchy): tan(π(p − ½)); ν = 2: (2p − 1)/√(2p(1 − p)).
    for k in 1..200 {
        let p = k as f64 / 200.0;
        let cauchy = (core::f64::consts::PI * (p - 0.5)).tan();
        let t1 = student_t_quantile(p, 1).expect("valid");
        assert!(close(t1, cauchy, 1e-10 * cauchy.abs().max(1.0)), "p {p}");
        let two = (2.0 * p - 1.0) / (2.0 * p * (1.0 - p)).sqrt();
        let t2 = student_t_quantile(p, 2).expect("valid");
        assert!(close(t2, two, 1e-10 * two.abs().max(1.0)), "p {p}");
    }
    // Far tail: ν = 1 at p = 1 − 1e-10 → 1/(π·1e-10) to first order.
    let t = student_t_quantile(1.0 - 1e-10, 1).expect("valid");
    assert!(close(t, 1.0 / (core::f64::consts::PI * 1e-10), 1e-3 * t));
}

#[test]
fn cornish_fisher_agrees_with_bisection_where_they_meet() {
    for dof in [1000usize, 1500, 5000, 50_000] {
        for tail in [0.4, 0.1, 0.025, 0.005, 1e-4, 1e-8] {
            let nu = dof as f64;
            let cf = cornish_fisher_t(normal_upper_quantile(tail), nu);
            let bis = t_upper_quantile_bisection(tail, nu);
            assert!(
                close(cf, bis, 1e-9 * bis),
                "dof {dof} tail {tail}: {cf} vs {bis}"
            );
        }
    }
}

#[test]
fn cdf_inverts_the_quantile() {
    for dof in [1usize, 2, 3, 7, 30, 999, 1000, 20_000] {
        for p in [1e-6, 0.01, 0.2, 0.5, 0.8, 0.975, 0.999_999] {
            let t = student_t_quantile(p, dof).expect("valid");
            let back = student_t_cdf(t, dof).expect("valid");
            assert!(
                close(back, p, 1e-9 * p.max(1e-3)),
                "dof {dof} p {p}: {back}"
            );
        }
    }
}

#[test]
fn t_quantile_rejects_bad_arguments() {
    for p in [0.0, 1.0, -0.1, 1.5, f64::NAN, f64::INFINITY] {
        assert_eq!(student_t_quantile(p, 5), Err(FitError::InvalidParameter));
    }
    assert_eq!(student_t_quantile(0.9, 0), Err(FitError::InvalidParameter));
    assert_eq!(student_t_cdf(f64::NAN, 3), Err(FitError::NonFinite));
    assert_eq!(student_t_cdf(f64::INFINITY, 3), Ok(1.0));
    assert_eq!(student_t_cdf(f64::NEG_INFINITY, 3), Ok(0.0));
}

#[test]
fn exact_recovery_on_noiseless_data() {
    let truth = [2.5, -1.25, 0.75, 40.0];
    let mut fit = LinearFit::<4>::new();
    let mut rng = SplitMix64::new(1);
    for _ in 0..50 {
        let x = [
            rng.range(-3.0, 3.0),
            rng.range(0.0, 10.0),
            rng.range(-1.0, 1.0),
            1.0,
        ];
        let y: f64 = x.iter().zip(truth).map(|(a, b)| a * b).sum();
        fit.add(x, y).expect("finite");
    }
    let r = fit.solve().expect("well posed");
    for (e, t) in r.estimates.iter().zip(truth) {
        assert!(close(e.value, t, 1e-12), "{e:?} vs {t}");
        // The bounds shrink to rounding width: SE ~ 1e-15, no longer a meaningful interval.
        assert!(e.standard_error < 1e-12, "{e:?}");
    }
    assert!(r.residual_standard_error < 1e-12);
    assert!(close(r.r_squared.expect("y varies"), 1.0, 1e-12));
    assert_eq!((r.n, r.dof), (50, 46));
    let c = fit.coefficients().expect("well posed");
    assert!(close(c[3], 40.0, 1e-12));
    assert!(close(
        r.predict([1.0, 2.0, 3.0, 1.0]),
        2.5 - 2.5 + 2.25 + 40.0,
        1e-10
    ));
}

#[test]
fn exactly_determined_system_has_coefficients_but_no_bounds() {
    let fit =
        LinearFit::<2>::from_rows(&[[1.0, 1.0], [3.0, 1.0]], &[5.0, 9.0]).expect("same lengths");
    let c = fit.coefficients().expect("two points, two unknowns");
    assert!(close(c[0], 2.0, 1e-14) && close(c[1], 3.0, 1e-14));
    assert_eq!(fit.solve(), Err(FitError::TooFewSamples));
    let one = LinearFit::<2>::from_rows(&[[1.0, 1.0]], &[5.0]).expect("same lengths");
    assert_eq!(one.coefficients(), Err(FitError::TooFewSamples));
}

#[test]
fn simple_regression_matches_textbook_formulas() {
    // Independent oracle: for y = b0 + b1 x, SE(b1) = s/√Sxx, SE(b0) = s √(1/n + x̄²/Sxx).
    let mut rng = SplitMix64::new(7);
    let xs: Vec<f64> = (0..25).map(|_| rng.range(0.0, 10.0)).collect();
    let ys: Vec<f64> = xs.iter().map(|x| 1.0 + 0.5 * x + rng.normal()).collect();
    let rows: Vec<[f64; 2]> = xs.iter().map(|&x| [1.0, x]).collect();
    let r = LinearFit::from_rows(&rows, &ys)
        .expect("finite")
        .solve()
        .expect("well posed");
    let n = xs.len() as f64;
    let xbar = xs.iter().sum::<f64>() / n;
    let ybar = ys.iter().sum::<f64>() / n;
    let sxx: f64 = xs.iter().map(|x| (x - xbar).powi(2)).sum();
    let sxy: f64 = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| (x - xbar) * (y - ybar))
        .sum();
    let b1 = sxy / sxx;
    let b0 = ybar - b1 * xbar;
    let ssr: f64 = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| (y - b0 - b1 * x).powi(2))
        .sum();
    let s = (ssr / (n - 2.0)).sqrt();
    assert!(close(r.estimates[0].value, b0, 1e-12));
    assert!(close(r.estimates[1].value, b1, 1e-12));
    assert!(close(r.estimates[1].standard_error, s / sxx.sqrt(), 1e-12));
    assert!(close(
        r.estimates[0].standard_error,
        s * (1.0 / n + xbar * xbar / sxx).sqrt(),
        1e-12
    ));
    assert!(close(r.residual_standard_error, s, 1e-12));
    // t(0.975, 23) = 2.068658.
    assert!(close(r.t_quantile, 2.068_658, 1e-6));
    assert!(close(
        r.estimates[1].half_width(),
        2.068_658 * s / sxx.sqrt(),
        1e-6
    ));
}

#[test]
fn r_squared_is_one_minus_ssr_over_sst() {
    let mut rng = SplitMix64::new(3);
    let mut rows = Vec::new();
    let mut ys = Vec::new();
    for _ in 0..200 {
        let (a, b) = (rng.range(-15.0, 15.0), rng.range(0.0, 10.0));
        rows.push([a, b, 1.0]);
        ys.push(300.0 + 20.0 * a - 2.0 * b + 60.0 * rng.normal());
    }
    let r = LinearFit::from_rows(&rows, &ys)
        .expect("finite")
        .solve()
        .expect("well posed");
    let c = r.coefficients();
    let ssr: f64 = rows
        .iter()
        .zip(&ys)
        .map(|(x, y)| (y - (c[0] * x[0] + c[1] * x[1] + c[2])).powi(2))
        .sum();
    let mean = ys.iter().sum::<f64>() / ys.len() as f64;
    let sst: f64 = ys.iter().map(|y| (y - mean).powi(2)).sum();
    let r2 = r.r_squared.expect("y varies");
    assert!(
        close(r2, 1.0 - ssr / sst, 1e-12),
        "{r2} vs {}",
        1.0 - ssr / sst
    );
    assert!(close(r.residual_standard_error, (ssr / 197.0).sqrt(), 1e-9));
    assert!(r2 > 0.5 && r2 < 0.95);
}

/// Fraction of 95 % intervals that cover the truth over `trials` independent small fits, per
/// coefficient; with the t quantile, and with the normal 1.96 for contrast.
fn coverage(trials: usize, n: usize) -> ([f64; 3], [f64; 3]) {
    let truth = [1.5, -0.7, 10.0];
    let mut hits_t = [0usize; 3];
    let mut hits_z = [0usize; 3];
    for seed in 0..trials {
        let mut rng = SplitMix64::new(1000 + seed as u64);
        let mut fit = LinearFit::<3>::new();
        for _ in 0..n {
            let x = [rng.range(-2.0, 2.0), rng.range(0.0, 5.0), 1.0];
            let y: f64 = x.iter().zip(truth).map(|(a, b)| a * b).sum::<f64>() + 0.8 * rng.normal();
            fit.add(x, y).expect("finite");
        }
        let r = fit.solve().expect("well posed");
        for k in 0..3 {
            let e = r.estimates[k];
            hits_t[k] += usize::from(e.contains(truth[k]));
            hits_z[k] += usize::from((e.value - truth[k]).abs() <= 1.96 * e.standard_error);
        }
    }
    let rate = |h: [usize; 3]| h.map(|v| v as f64 / trials as f64);
    (rate(hits_t), rate(hits_z))
}

#[test]
fn confidence_intervals_cover_the_truth_95_percent_of_the_time() {
    // n = 8, N = 3: 5 residual degrees of freedom, where t(0.975, 5) = 2.571 and the normal
    // 1.96 would cover only ~89 %. 4000 trials: binomial SD of the rate 0.0034.
    let (with_t, with_z) = coverage(4000, 8);
    println!("coverage with t: {with_t:?}, with z = 1.96: {with_z:?}");
    for k in 0..3 {
        assert!(
            (0.935..=0.965).contains(&with_t[k]),
            "coefficient {k}: {}",
            with_t[k]
        );
        assert!(
            with_z[k] < 0.92,
            "the test must tell t from z: {}",
            with_z[k]
        );
    }
}

#[test]
fn singular_designs_are_refused() {
    // Second column twice the first.
    let rows: Vec<[f64; 3]> = (0..10).map(|i| [i as f64, 2.0 * i as f64, 1.0]).collect();
    let ys: Vec<f64> = (0..10).map(|i| i as f64).collect();
    let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
    assert_eq!(fit.solve(), Err(FitError::Singular));
    assert_eq!(fit.coefficients(), Err(FitError::Singular));
    // A regressor that is always zero.
    let rows: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 0.0]).collect();
    let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
    assert_eq!(fit.solve(), Err(FitError::Singular));
    // Nearly collinear: a constant column and one that varies by 1e-12 relative.
    let rows: Vec<[f64; 2]> = (0..10).map(|i| [1.0, 1.0 + 1e-12 * i as f64]).collect();
    let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
    assert_eq!(fit.solve(), Err(FitError::Singular));
    // Badly scaled but independent columns are fine (the check is scale-invariant).
    let rows: Vec<[f64; 2]> = (0..10).map(|i| [1e-9 * i as f64, 1e9]).collect();
    let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
    let c = fit.coefficients().expect("independent");
    assert!(close(c[0], 1e9, 1e-3) && close(c[1], 0.0, 1e-15));
}

#[test]
fn non_finite_and_mismatched_input_is_refused() {
    let mut fit = LinearFit::<2>::new();
    fit.add([1.0, 1.0], 2.0).expect("finite");
    let before = fit.clone();
    assert_eq!(fit.add([f64::NAN, 1.0], 2.0), Err(FitError::NonFinite));
    assert_eq!(fit.add([1.0, 1.0], f64::INFINITY), Err(FitError::NonFinite));
    assert_eq!(fit, before);
    assert_eq!(
        LinearFit::<2>::from_rows(&[[1.0, 1.0]], &[1.0, 2.0]),
        Err(FitError::LengthMismatch)
    );
    assert_eq!(
        fit.solve_with_confidence(1.0),
        Err(FitError::InvalidParameter)
    );
    // Values whose squares overflow: no panic, an error.
    let mut big = LinearFit::<1>::new();
    big.add([1.0], 1e200).expect("finite");
    big.add([1.0], -1e200).expect("finite");
    assert_eq!(big.solve(), Err(FitError::NonFinite));
    // Regressors whose squares overflow: no panic, no coefficient, an error.
    let mut wide = LinearFit::<1>::new();
    wide.add([1e160], 2e160).expect("finite");
    wide.add([3e160], 6e160).expect("finite");
    assert_eq!(wide.coefficients(), Err(FitError::NonFinite));
    assert_eq!(
        wide.coefficients_with(RankTest::RelativePivot(1e-7)),
        Err(FitError::NonFinite)
    );
}

#[test]
fn table_4_1_two_metre_row_is_recovered() {
    // P = 22.54θ − 0.07985|φ| + 338.1 (Table 4.1, R = 2 m; Table 4.2 bounds
    // ξ [21.69, 23.38], η [−1.26, 1.1], ζ [331.7, 344.5], r² 0.7069). Pitch within ±15°
    // (Section 4.1), noise chosen to give r² ≈ 0.7.
    let (xi, eta, zeta) = (22.54, -0.07985, 338.1);
    let mut rng = SplitMix64::new(42);
    let mut fit = PitchRollFit::new();
    for _ in 0..2000 {
        let pitch = rng.range(-15.0, 15.0);
        let roll = rng.range(-10.0, 10.0);
        let p = xi * pitch + eta * roll.abs() + zeta + 130.0 * rng.normal();
        fit.add(pitch, roll, p).expect("finite");
    }
    let m = fit.solve().expect("well posed");
    println!("{m:?}");
    assert!(m.xi_w_per_deg.contains(xi), "{:?}", m.xi_w_per_deg);
    assert!(m.eta_w_per_deg.contains(eta), "{:?}", m.eta_w_per_deg);
    assert!(m.zeta_w.contains(zeta), "{:?}", m.zeta_w);
    // The estimates also fall within the seed's published bounds (Table 4.2).
    assert!((21.69..=23.38).contains(&m.xi_w_per_deg.value));
    assert!((-1.26..=1.1).contains(&m.eta_w_per_deg.value));
    assert!((331.7..=344.5).contains(&m.zeta_w.value));
    let r2 = m.r_squared.expect("y varies");
    assert!((0.65..0.76).contains(&r2), "r² {r2}");
    assert_eq!(m.n, 2000);
    assert!(close(m.power_w(10.0, -2.0), m.power_w(10.0, 2.0), 1e-12));
}

#[test]
fn table_4_3_coefficients_are_recovered() {
    // P = 5.55/R + 139.4 + 6.608θ (Table 4.3) from random drives: radii from point turns to
    // beyond 20 m (dropped), pitch within ±15°.
    let (c1, c2, c3) = (5.55, 139.4, 6.608);
    let mut rng = SplitMix64::new(2019);
    let mut fit = TurnPitchFit::new();
    let mut dropped = 0;
    for k in 0..6000 {
        let r = match k % 10 {
            0 => 0.0,
            1 => f64::INFINITY,
            2 => rng.range(20.0, 60.0),
            _ => rng.range(0.2, 20.0),
        };
        let pitch = rng.range(-15.0, 15.0);
        let p = c1 / r.max(POINT_TURN_RADIUS_M) + c2 + c3 * pitch + 40.0 * rng.normal();
        if fit.add(r, pitch, p).expect("valid") == SampleUse::Dropped {
            dropped += 1;
        }
    }
    assert_eq!(dropped, 1200);
    let m = fit.solve().expect("well posed");
    println!("{m:?}");
    assert!(m.c1_w_m.contains(c1), "{:?}", m.c1_w_m);
    assert!(m.c2_w.contains(c2), "{:?}", m.c2_w);
    assert!(m.c3_w_per_deg.contains(c3), "{:?}", m.c3_w_per_deg);
    assert!((5.269..=5.831).contains(&m.c1_w_m.value));
    assert!((138.1..=140.7).contains(&m.c2_w.value));
    assert!((6.418..=6.799).contains(&m.c3_w_per_deg.value));
    assert_eq!(m.n, 4800);
    assert!(close(m.power_w(0.0, 0.0), m.power_w(0.001, 0.0), 1e-12));
}

#[test]
fn turn_pitch_conventions() {
    let mut fit = TurnPitchFit::new();
    assert_eq!(fit.add(20.0, 0.0, 1.0), Ok(SampleUse::Used));
    assert_eq!(fit.add(20.000_001, 0.0, 1.0), Ok(SampleUse::Dropped));
    assert_eq!(fit.add(f64::INFINITY, 0.0, 1.0), Ok(SampleUse::Dropped));
    assert_eq!(fit.add(-1.0, 0.0, 1.0), Err(FitError::InvalidParameter));
    assert_eq!(fit.add(f64::NAN, 0.0, 1.0), Err(FitError::NonFinite));
    assert_eq!(fit.add(30.0, f64::NAN, 1.0), Err(FitError::NonFinite));
    assert_eq!(fit.len(), 1);
    // Eq 2.4 with the controller's B_s = 1.1 m: point turn, straight line, standstill.
    let b_s = 1.1;
    let point = SideSpeeds::new(-0.3, 0.3);
    let straight = SideSpeeds::new(0.3, 0.3);
    let still = SideSpeeds::new(0.0, 0.0);
    let r_prime = SideSpeeds::new(0.0, 0.6);
    assert_eq!(
        fit.add_side_speeds(point, b_s, 0.0, 1.0),
        Ok(SampleUse::Used)
    );
    assert_eq!(
        fit.add_side_speeds(straight, b_s, 0.0, 1.0),
        Ok(SampleUse::Dropped)
    );
    assert_eq!(
        fit.add_side_speeds(still, b_s, 0.0, 1.0),
        Ok(SampleUse::Dropped)
    );
    assert_eq!(
        fit.add_side_speeds(still, b_s, f64::NAN, 1.0),
        Err(FitError::NonFinite)
    );
    assert_eq!(
        fit.add_side_speeds(r_prime, b_s, 1.0, 2.0),
        Ok(SampleUse::Used)
    );
    assert_eq!(fit.len(), 3);
    // The point turn entered as R = 0.001 m: the same state as adding 0.001 directly.
    let mut direct = TurnPitchFit::new();
    direct.add(20.0, 0.0, 1.0).expect("valid");
    direct.add(0.001, 0.0, 1.0).expect("valid");
    direct.add(0.55, 1.0, 2.0).expect("valid");
    let (a, b) = (fit.fit.coefficients(), direct.fit.coefficients());
    assert_eq!(a.is_ok(), b.is_ok());
    if let (Ok(a), Ok(b)) = (a, b) {
        for (x, y) in a.iter().zip(b) {
            assert!(close(*x, y, 1e-6 * y.abs().max(1.0)), "{a:?} vs {b:?}");
        }
    }
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1e3..1e3f64,
        1 => any::<f64>(),
        1 => Just(f64::NAN),
        1 => Just(0.0),
    ]
}

proptest! {
    #[test]
    fn fits_never_panic(rows in proptest::collection::vec((any_f64(), any_f64(), any_f64()), 0..30)) {
        let mut fit = LinearFit::<3>::new();
        let mut pr = PitchRollFit::new();
        let mut tp = TurnPitchFit::new();
        for &(a, b, y) in &rows {
            let _ = fit.add([a, b, 1.0], y);
            let _ = pr.add(a, b, y);
            let _ = tp.add(a, b, y);
            let _ = tp.add_side_speeds(SideSpeeds::new(a as f32, b as f32), 1.1, a, y);
        }
        if let Ok(r) = fit.solve() {
            for e in r.estimates {
                prop_assert!(e.lower <= e.value && e.value <= e.upper);
            }
            prop_assert!(r.residual_standard_error >= 0.0);
        }
        let _ = fit.coefficients();
        let _ = pr.solve();
        let _ = tp.solve();
    }

    #[test]
    fn t_quantile_never_panics_and_is_monotone(p in any_f64(), dof in 0usize..5000) {
        if let Ok(t) = student_t_quantile(p, dof) {
            prop_assert!(!t.is_nan());
            if p < 0.999 {
                let next = student_t_quantile(p + 0.001, dof);
                prop_assert!(next.is_ok_and(|u| u > t));
            }
        }
        let _ = student_t_cdf(p, dof);
    }
}

#[test]
fn fewer_columns_than_capacity_fit_like_the_exact_width() {
    // Two of four columns against LinearFit<2>: the same arithmetic, so the same bits.
    let rows: Vec<[f64; 2]> = (0..9).map(|i| [1.0 / (0.5 + i as f64), 1.0]).collect();
    let ys: Vec<f64> = (0..9)
        .map(|i| 50.0 / (0.5 + i as f64) + 20.0 + [0.3, -0.2, 0.1][i % 3])
        .collect();
    let exact = LinearFit::from_rows(&rows, &ys).expect("finite");
    let mut wide = LinearFit::<4>::with_columns(2).expect("2 ≤ 4");
    for (x, &y) in rows.iter().zip(&ys) {
        wide.add_row(x, y).expect("finite");
    }
    assert_eq!(wide.columns(), 2);
    let (a, b) = (exact.solve().expect("fits"), wide.solve().expect("fits"));
    assert_eq!(
        a.coefficients(),
        [b.estimates[0].value, b.estimates[1].value]
    );
    assert_eq!(a.estimates[..], b.estimates[..2]);
    assert_eq!(b.estimates[2..], [Estimate::default(); 2]);
    assert_eq!((a.dof, a.t_quantile), (b.dof, b.t_quantile));
    assert_eq!(a.covariance[1][0], b.covariance[1][0]);
    assert_eq!(b.covariance[3], [0.0; 4]);
    assert_eq!(
        exact.residual_sum_of_squares(),
        wide.residual_sum_of_squares()
    );
    assert_eq!(
        a.prediction_interval_half_width([0.8, 1.0]),
        b.prediction_interval_half_width([0.8, 1.0, 0.0, 0.0])
    );
    // A row of the wrong width, or a width beyond the capacity, is refused.
    assert_eq!(wide.add_row(&[1.0; 3], 1.0), Err(FitError::LengthMismatch));
    assert_eq!(wide.add([1.0; 4], 1.0), Err(FitError::LengthMismatch));
    assert_eq!(
        LinearFit::<4>::with_columns(5),
        Err(FitError::InvalidParameter)
    );
    assert_eq!(
        LinearFit::<4>::with_columns(0),
        Err(FitError::InvalidParameter)
    );
}

#[test]
fn relative_pivot_test_refuses_a_column_that_adds_no_direction() {
    // Third column = first + 1e-9 · (something independent): its pivot is ~1e-9 of its norm.
    let rows: Vec<[f64; 3]> = (0..12)
        .map(|i| {
            let x = i as f64;
            [x, 1.0, x + 1e-9 * (x * x)]
        })
        .collect();
    let ys: Vec<f64> = (0..12).map(|i| 2.0 * i as f64 + 1.0).collect();
    let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
    assert_eq!(
        fit.coefficients_with(RankTest::RelativePivot(1e-7)),
        Err(FitError::Singular)
    );
    // A looser pivot floor accepts it (the columns are independent in exact arithmetic).
    assert!(fit
        .coefficients_with(RankTest::RelativePivot(1e-12))
        .is_ok());
    // Independent columns pass both tests with the same coefficients.
    let rows: Vec<[f64; 2]> = (0..12).map(|i| [i as f64, 1.0]).collect();
    let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
    let by_pivot = fit
        .coefficients_with(RankTest::RelativePivot(1e-7))
        .expect("independent");
    assert_eq!(by_pivot, fit.coefficients().expect("independent"));
    assert!(close(by_pivot[0], 2.0, 1e-12) && close(by_pivot[1], 1.0, 1e-12));
    assert!(fit.residual_sum_of_squares() < 1e-20);
}

#[test]
fn prediction_interval_is_t_s_sqrt_one_plus_leverage() {
    // y = b0 + b1 x: leverage 1/n + (x0 − x̄)²/Sxx.
    let xs = [1.0, 1.5, 2.0, 2.5, 1.2];
    let ys = [70.0, 55.0, 46.0, 40.0, 62.0];
    let rows: Vec<[f64; 2]> = xs.iter().map(|&x| [x, 1.0]).collect();
    let r = LinearFit::from_rows(&rows, &ys)
        .expect("finite")
        .solve()
        .expect("fits");
    let n = xs.len() as f64;
    let xbar = xs.iter().sum::<f64>() / n;
    let sxx: f64 = xs.iter().map(|x| (x - xbar).powi(2)).sum();
    let x0 = 1.25;
    let want = r.t_quantile
        * r.residual_standard_error
        * (1.0 + 1.0 / n + (x0 - xbar).powi(2) / sxx).sqrt();
    let got = r.prediction_interval_half_width([x0, 1.0]);
    assert!(close(got, want, 1e-9 * want), "{got} vs {want}");
}

#[test]
fn a_given_t_quantile_gives_the_same_intervals_and_its_error_stops_the_fit() {
    let mut fit = LinearFit::<2>::new();
    for (x, y) in [(0.0, 1.1), (1.0, 2.9), (2.0, 5.2), (3.0, 6.8), (4.0, 9.1)] {
        fit.add([1.0, x], y).expect("finite");
    }
    let solved = fit.solve().expect("well posed");
    let mut asked = None;
    let given = fit
        .solve_with_t(SEED_CONFIDENCE, |dof| {
            asked = Some(dof);
            student_t_quantile(0.975, dof)
        })
        .expect("well posed");
    assert_eq!(asked, Some(3), "the residual degrees of freedom, n − k");
    assert_eq!(given, solved);
    // A wider quantile widens the intervals around the same estimates.
    let wide = fit
        .solve_with_t(SEED_CONFIDENCE, |_| Ok(10.0))
        .expect("well posed");
    assert_eq!(wide.estimates[1].value, solved.estimates[1].value);
    assert!(wide.estimates[1].upper > solved.estimates[1].upper);
    assert_eq!(
        fit.solve_with_t(SEED_CONFIDENCE, |_| Err(FitError::InvalidParameter)),
        Err(FitError::InvalidParameter)
    );
    assert_eq!(
        fit.solve_with_t(1.5, |_| Ok(2.0)),
        Err(FitError::InvalidParameter)
    );
}
