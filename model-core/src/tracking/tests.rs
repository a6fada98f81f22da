use super::*;
use crate::geometry::Rover;
use crate::kinematics;
use crate::rng::SplitMix64;
use core::f64::consts::FRAC_PI_2;
use core::f64::consts::PI;
use proptest::prelude::*;

const HUSKY: Rover = Rover::HUSKY_A200;
const DT: f64 = TOTAL_STATION_PERIOD_S;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn dist(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

/// A rigid left turn: the rover's centre circles `centre` at radius `r_act_m` with yaw rate
/// `yaw_rate_rad_s`; θ_H (the rover's X axis, Eq 5.3) points from the centre to the rover.
#[derive(Debug, Clone, Copy)]
struct Turn {
    centre: (f64, f64),
    r_act_m: f64,
    yaw_rate_rad_s: f64,
    theta0_rad: f64,
}

impl Turn {
    fn theta_h(&self, t_s: f64) -> f64 {
        self.theta0_rad + self.yaw_rate_rad_s * t_s
    }

    /// The prism, δx_lp outboard of the centre.
    fn prism(&self, t_s: f64) -> (f64, f64) {
        let r = self.r_act_m + PRISM_OFFSET_M;
        let th = self.theta_h(t_s);
        (self.centre.0 + r * th.cos(), self.centre.1 + r * th.sin())
    }

    fn track(&self, samples: usize, noise_m: f64, rng: &mut SplitMix64) -> Vec<(f64, f64)> {
        (0..samples)
            .map(|k| {
                let p = self.prism(k as f64 * DT);
                (p.0 + noise_m * rng.normal(), p.1 + noise_m * rng.normal())
            })
            .collect()
    }
}

/// 90° at the Husky's commanded yaw rate for R ≤ R' (2 v_c / B_s = 0.545 rad/s at 0.3 m/s).
fn r_prime_turn() -> Turn {
    Turn {
        centre: (3.2, -1.7),
        r_act_m: 0.55,
        yaw_rate_rad_s: 0.6 / 1.1,
        theta0_rad: -2.5,
    }
}

fn samples_for(turn: &Turn, angle_rad: f64) -> usize {
    (angle_rad / (turn.yaw_rate_rad_s * DT)).round() as usize + 1
}

/// [`r_prime_turn`] at actual radius `r_act` [m], and the samples of its 90°.
fn quarter_turn_at(r_act: f64) -> (Turn, usize) {
    let turn = Turn {
        r_act_m: r_act,
        ..r_prime_turn()
    };
    let n = samples_for(&turn, PI / 2.0);
    (turn, n)
}

#[test]
fn circle_fit_is_exact_on_noiseless_points() {
    let turn = r_prime_turn();
    let track = turn.track(
        samples_for(&turn, 2.0 * PI) - 1,
        0.0,
        &mut SplitMix64::new(0),
    );
    let c = fit_circle(&track).expect("a circle");
    assert!(close(c.centre_x_m, 3.2, 1e-12) && close(c.centre_y_m, -1.7, 1e-12));
    assert!(close(c.radius_m, 0.76, 1e-12));
    assert!(close(
        actual_radius_m(&c, PRISM_OFFSET_M).expect("valid"),
        0.55,
        1e-12
    ));
    // Three points determine the circle; far from the origin costs nothing.
    let far: Vec<(f64, f64)> = [0.1, 1.3, 2.9]
        .iter()
        .map(|a: &f64| (1.0e4 + 2.0 * a.cos(), -3.0e4 + 2.0 * a.sin()))
        .collect();
    let c = fit_circle(&far).expect("a circle");
    assert!(close(c.centre_x_m, 1.0e4, 1e-8) && close(c.centre_y_m, -3.0e4, 1e-8));
    assert!(close(c.radius_m, 2.0, 1e-9));
}

/// Cramér–Rao bound on the SD of the fitted radius for points at `angles_rad` on a circle with
/// independent noise `sigma_m` in x and y: σ √[(JᵀJ)⁻¹]_rr, J rows (−cos φ, −sin φ, −1).
fn radius_crb_m(angles_rad: &[f64], sigma_m: f64) -> f64 {
    let mut m = [[0.0f64; 3]; 3];
    for th in angles_rad {
        let j = [-th.cos(), -th.sin(), -1.0];
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += j[a] * j[b];
            }
        }
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    sigma_m * ((m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det).sqrt()
}

#[test]
fn circle_fit_recovers_r_act_from_noisy_arcs() {
    // R_ACT = 0.55 m with the prism 0.21 m outboard, 2 mm noise per coordinate, 5 Hz at the
    // commanded 0.545 rad/s.
    let turn = r_prime_turn();
    for (arc_rad, tolerance_m) in [(2.0 * PI, 2e-3), (PI, 5e-3)] {
        let n = samples_for(&turn, arc_rad);
        let mut worst = 0.0_f64;
        for seed in 0..50 {
            let track = turn.track(n, 0.002, &mut SplitMix64::new(seed));
            let c = fit_circle(&track).expect("a circle");
            let r_act = actual_radius_m(&c, PRISM_OFFSET_M).expect("valid");
            worst = worst.max((r_act - 0.55).abs());
        }
        println!(
            "arc {arc_rad:.3} rad, {n} points: worst |R_ACT − 0.55| over 50 seeds {worst:.4} m"
        );
        assert!(worst < tolerance_m, "arc {arc_rad}: {worst}");
    }
    // Partial arcs without noise are exact.
    for arc_rad in [PI / 4.0, PI / 2.0] {
        let track = turn.track(samples_for(&turn, arc_rad), 0.0, &mut SplitMix64::new(0));
        let r_act = actual_radius_m(&fit_circle(&track).expect("a circle"), PRISM_OFFSET_M);
        assert!(close(r_act.expect("valid"), 0.55, 1e-9));
    }
    // A 90° turn is only 15 points: no estimator can promise 5 mm every time (the Cramér–Rao
    // bound on the radius' SD is 4.9 mm here). The fit is unbiased and efficient (RMS error at
    // the bound), and its median error is below 5 mm.
    for (arc_rad, rate) in [
        (PI / 2.0, 0.6 / 1.1),
        (PI / 2.0, 0.3),
        (2.0 * PI / 3.0, 0.6 / 1.1),
    ] {
        let turn = Turn {
            yaw_rate_rad_s: rate,
            ..r_prime_turn()
        };
        let n = samples_for(&turn, arc_rad);
        let angles: Vec<f64> = (0..n).map(|k| turn.theta_h(k as f64 * DT)).collect();
        let crb = radius_crb_m(&angles, 0.002);
        let mut errors: Vec<f64> = (0..2000)
            .map(|seed| {
                let track = turn.track(n, 0.002, &mut SplitMix64::new(seed));
                let c = fit_circle(&track).expect("a circle");
                actual_radius_m(&c, PRISM_OFFSET_M).expect("valid") - 0.55
            })
            .collect();
        let mean = errors.iter().sum::<f64>() / 2000.0;
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / 2000.0).sqrt();
        errors.iter_mut().for_each(|e| *e = e.abs());
        errors.sort_by(f64::total_cmp);
        let within_5mm = errors.iter().filter(|e| **e < 0.005).count() as f64 / 2000.0;
        println!(
            "arc {arc_rad:.3} rad, {n} points: mean {mean:.5} m, RMS {rms:.5} m (CRB {crb:.5}), \
             median {:.5} m, 95th pct {:.5} m, within 5 mm {within_5mm:.3}",
            errors[1000], errors[1900]
        );
        assert!(mean.abs() < 0.1 * crb, "biased: {mean}");
        assert!(rms < 1.1 * crb, "RMS {rms} vs CRB {crb}");
        assert!(errors[1000] < 0.005);
    }
}

#[test]
fn circle_fit_is_a_geometric_least_squares_minimum() {
    let turn = r_prime_turn();
    let track = turn.track(samples_for(&turn, PI / 2.0), 0.01, &mut SplitMix64::new(5));
    let c = fit_circle(&track).expect("a circle");
    let cost = |cx: f64, cy: f64, r: f64| -> f64 {
        track.iter().map(|p| (dist(*p, (cx, cy)) - r).powi(2)).sum()
    };
    let best = cost(c.centre_x_m, c.centre_y_m, c.radius_m);
    for (dx, dy, dr) in [
        (1e-4, 0.0, 0.0),
        (0.0, 1e-4, 0.0),
        (0.0, 0.0, 1e-4),
        (1e-4, -1e-4, 1e-4),
    ] {
        for s in [-1.0, 1.0] {
            assert!(
                cost(
                    c.centre_x_m + s * dx,
                    c.centre_y_m + s * dy,
                    c.radius_m + s * dr
                ) > best
            );
        }
    }
}

#[test]
fn circle_fit_refuses_degenerate_input() {
    assert_eq!(
        fit_circle(&[(0.0, 0.0), (1.0, 1.0)]),
        Err(TrackingError::TooFewPoints)
    );
    assert_eq!(
        fit_circle(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0), (3.5, 3.5)]),
        Err(TrackingError::Degenerate)
    );
    assert_eq!(fit_circle(&[(1.0, 2.0); 5]), Err(TrackingError::Degenerate));
    assert_eq!(
        fit_circle(&[(0.0, 0.0), (1.0, f64::NAN), (2.0, 0.0)]),
        Err(TrackingError::NonFinite)
    );
    let c = Circle {
        centre_x_m: 0.0,
        centre_y_m: 0.0,
        radius_m: 0.2,
    };
    assert_eq!(actual_radius_m(&c, 0.21), Ok(0.0));
    assert_eq!(
        actual_radius_m(&c, -0.1),
        Err(TrackingError::InvalidParameter)
    );
}

/// The naive Hampel identifier of MATLAB's "Hampel filter algorithm" example, with allocation:
/// an independent oracle for [`hampel`].
fn hampel_oracle(x: &[f64], k: usize, nsigma: f64) -> Vec<HampelPoint> {
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        }
    };
    (0..x.len())
        .map(|j| {
            let lo = j.saturating_sub(k);
            let hi = (j + k).min(x.len() - 1);
            let mut w: Vec<f64> = x[lo..=hi].to_vec();
            let med = median(&mut w);
            let mut dev: Vec<f64> = x[lo..=hi].iter().map(|v| (v - med).abs()).collect();
            let sd = median(&mut dev) / (0.476_936_276_204_469_9 * 2f64.sqrt());
            HampelPoint {
                median: med,
                sigma: sd,
                outlier: (x[j] - med).abs() > nsigma * sd,
            }
        })
        .collect()
}

#[test]
fn hampel_by_hand_and_at_the_edges() {
    let x = [1.0, 2.0, 3.0, 4.0, 100.0, 5.0, 6.0, 7.0];
    let mut out = [HampelPoint::default(); 8];
    let n = hampel(&x, &HampelConfig::default(), &mut out).expect("valid");
    assert_eq!(n, 1);
    // Sample 4: window [2, 3, 4, 100, 5, 6, 7] → median 5, MAD 2.
    assert!(
        out[4].outlier && out[4].median == 5.0 && close(out[4].sigma, 2.0 * MAD_TO_SIGMA, 1e-12)
    );
    // Sample 0: truncated window [1, 2, 3, 4] → median 2.5, MAD 1.
    assert!(!out[0].outlier && out[0].median == 2.5 && close(out[0].sigma, MAD_TO_SIGMA, 1e-12));
    // The last sample's window [100, 5, 6, 7] → median 6.5.
    assert_eq!(out[7].median, 6.5);
    // A constant window (MAD 0) flags any difference at all.
    let mut out = [HampelPoint::default(); 5];
    hampel(
        &[1.0, 1.0, 1.0, 1.0, 1.0 + 1e-12],
        &HampelConfig::default(),
        &mut out,
    )
    .expect("valid");
    assert!(out[4].outlier && !out[3].outlier);
    // k = 0: every window is the sample itself; nothing is an outlier.
    let cfg = HampelConfig {
        half_window: 0,
        n_sigmas: 3.0,
    };
    assert_eq!(hampel(&x, &cfg, &mut [HampelPoint::default(); 8]), Ok(0));
}

#[test]
fn hampel_matches_the_matlab_algorithm() {
    let mut rng = SplitMix64::new(11);
    for trial in 0..50 {
        let n = 1 + trial * 3;
        let mut x: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.3).sin() + 0.1 * rng.normal())
            .collect();
        for _ in 0..n / 8 {
            let i = (rng.uniform() * n as f64) as usize % n;
            x[i] += 5.0 * rng.normal();
        }
        for (k, nsigma) in [(3, 3.0), (1, 2.0), (5, 1.0)] {
            let cfg = HampelConfig {
                half_window: k,
                n_sigmas: nsigma,
            };
            let mut out = vec![HampelPoint::default(); n];
            let count = hampel(&x, &cfg, &mut out).expect("valid");
            let want = hampel_oracle(&x, k, nsigma);
            for (j, (got, want)) in out.iter().zip(&want).enumerate() {
                assert_eq!(got.median, want.median, "n {n} k {k} sample {j}");
                assert!(
                    close(got.sigma, want.sigma, 1e-12),
                    "n {n} k {k} sample {j}"
                );
                // The scale constants agree to ~1e-16; a tie at the threshold is possible in
                // principle but not in this data.
                assert_eq!(got.outlier, want.outlier, "n {n} k {k} sample {j}");
            }
            assert_eq!(count, want.iter().filter(|p| p.outlier).count());
        }
    }
}

#[test]
fn hampel_refuses_bad_input() {
    let mut out = [HampelPoint::default(); 3];
    let cfg = HampelConfig::default();
    assert_eq!(
        hampel(&[1.0, f64::NAN, 2.0], &cfg, &mut out),
        Err(TrackingError::NonFinite)
    );
    assert_eq!(
        hampel(&[1.0; 4], &cfg, &mut out),
        Err(TrackingError::OutputTooSmall)
    );
    let wide = HampelConfig {
        half_window: MAX_HAMPEL_HALF_WINDOW + 1,
        n_sigmas: 3.0,
    };
    assert_eq!(
        hampel(&[1.0; 3], &wide, &mut out),
        Err(TrackingError::InvalidParameter)
    );
    let bad = HampelConfig {
        half_window: 3,
        n_sigmas: f64::NAN,
    };
    assert_eq!(
        hampel(&[1.0; 3], &bad, &mut out),
        Err(TrackingError::InvalidParameter)
    );
    assert_eq!(hampel(&[], &cfg, &mut []), Ok(0));
}

/// Removes samples `at .. at + count` from a 5 Hz track and checks that exactly `count` points
/// come back, each within 1 cm of the removed truth. Returns the largest error of an inserted
/// point.
fn check_refill(turn: &Turn, n: usize, at: usize, count: usize, noise_m: f64, seed: u64) -> f64 {
    let truth: Vec<(f64, f64)> = (0..n).map(|k| turn.prism(k as f64 * DT)).collect();
    let mut rng = SplitMix64::new(seed);
    let measured: Vec<(f64, f64)> = truth
        .iter()
        .enumerate()
        .filter(|(k, _)| *k < at || *k >= at + count)
        .map(|(_, p)| (p.0 + noise_m * rng.normal(), p.1 + noise_m * rng.normal()))
        .collect();
    let mut out = vec![(0.0, 0.0); n + 20];
    let report = fill_gaps(&measured, &GapFillConfig::default(), &mut out).expect("fits");
    assert_eq!(report.inserted, count, "gap of {count} at {at}");
    assert_eq!(report.len, n);
    assert_eq!(report.skipped_gaps, 0);
    let mut worst = 0.0_f64;
    for k in 0..n {
        let err = dist(out[k], truth[k]);
        let inserted = (at..at + count).contains(&k);
        if inserted {
            worst = worst.max(err);
        }
        let tol = if inserted {
            0.01
        } else {
            5.0 * noise_m + 1e-12
        };
        assert!(
            err < tol,
            "gap of {count} at {at}, sample {k}: off by {err} m"
        );
    }
    // Measured points are copied exactly.
    assert_eq!(out[..at], measured[..at]);
    assert_eq!(out[at + count..n], measured[at..]);
    worst
}

#[test]
fn lost_samples_are_reinserted_one_two_and_three() {
    let turn = r_prime_turn();
    let n = samples_for(&turn, PI / 2.0) + 10; // a 90° turn and a bit (25 samples)
    for count in 1..=3 {
        let (mut clean, mut noisy) = (0.0_f64, 0.0_f64);
        for at in [1, 6, 12, n - count - 1] {
            clean = clean.max(check_refill(&turn, n, at, count, 0.0, 0));
            for seed in 0..10 {
                noisy = noisy.max(check_refill(&turn, n, at, count, 0.002, seed));
            }
        }
        println!("{count} lost: worst inserted error {clean:.4} m noiseless, {noisy:.4} m with 2 mm noise");
    }
    // Two gaps in one track, within one Hampel window of each other.
    let truth: Vec<(f64, f64)> = (0..n).map(|k| turn.prism(k as f64 * DT)).collect();
    let measured: Vec<(f64, f64)> = truth
        .iter()
        .enumerate()
        .filter(|(k, _)| ![8, 11, 12].contains(k))
        .map(|(_, p)| *p)
        .collect();
    let mut out = vec![(0.0, 0.0); n];
    let report = fill_gaps(&measured, &GapFillConfig::default(), &mut out).expect("fits");
    assert_eq!((report.len, report.inserted), (n, 3));
    for (got, want) in out.iter().zip(&truth) {
        assert!(dist(*got, *want) < 0.01);
    }
}

#[test]
fn point_turn_track_is_refilled_too() {
    // R_ACT = 0: the prism circles the rover's centre at δx_lp (2.3 cm per sample).
    let turn = Turn {
        r_act_m: 0.0,
        ..r_prime_turn()
    };
    let n = samples_for(&turn, PI / 2.0) + 4;
    check_refill(&turn, n, 9, 2, 0.0, 0);
    check_refill(&turn, n, 9, 3, 0.0005, 1);
}

#[test]
fn clean_tracks_are_untouched() {
    let turn = r_prime_turn();
    let mut out = vec![(0.0, 0.0); 40];
    for noise in [0.0, 0.002] {
        let track = turn.track(30, noise, &mut SplitMix64::new(9));
        let report = fill_gaps(&track, &GapFillConfig::default(), &mut out).expect("fits");
        assert_eq!(
            report,
            GapFill {
                len: 30,
                inserted: 0,
                skipped_gaps: 0
            }
        );
        assert_eq!(out[..30], track[..]);
    }
    // A straight line at constant speed.
    let line: Vec<(f64, f64)> = (0..20)
        .map(|k| (0.06 * k as f64, 1.0 + 0.02 * k as f64))
        .collect();
    let report = fill_gaps(&line, &GapFillConfig::default(), &mut out).expect("fits");
    assert_eq!((report.len, report.inserted), (20, 0));
    assert_eq!(out[..20], line[..]);
    // Nothing and one point.
    assert_eq!(
        fill_gaps(&[], &GapFillConfig::default(), &mut []),
        Ok(GapFill::default())
    );
    let one = fill_gaps(&[(1.0, 2.0)], &GapFillConfig::default(), &mut out).expect("fits");
    assert_eq!((one.len, out[0]), (1, (1.0, 2.0)));
}

#[test]
fn gap_filling_reports_errors_and_skips() {
    let turn = r_prime_turn();
    let mut track = turn.track(20, 0.0, &mut SplitMix64::new(0));
    track.remove(10);
    let mut small = vec![(0.0, 0.0); 19];
    assert_eq!(
        fill_gaps(&track, &GapFillConfig::default(), &mut small),
        Err(TrackingError::OutputTooSmall)
    );
    assert_eq!(small, vec![(0.0, 0.0); 19]);
    let none = GapFillConfig {
        max_inserted_per_gap: 0,
        ..GapFillConfig::default()
    };
    let mut out = vec![(0.0, 0.0); 25];
    let report = fill_gaps(&track, &none, &mut out).expect("fits");
    assert_eq!(
        report,
        GapFill {
            len: 19,
            inserted: 0,
            skipped_gaps: 1
        }
    );
    let zero = GapFillConfig {
        neighbours_per_side: 0,
        ..GapFillConfig::default()
    };
    assert_eq!(
        fill_gaps(&track, &zero, &mut out),
        Err(TrackingError::InvalidParameter)
    );
    // One neighbour per side: linear interpolation across the gap.
    let linear = GapFillConfig {
        neighbours_per_side: 1,
        ..GapFillConfig::default()
    };
    let report = fill_gaps(&track, &linear, &mut out).expect("fits");
    assert_eq!(report.inserted, 1);
    let mid = (
        (track[9].0 + track[10].0) / 2.0,
        (track[9].1 + track[10].1) / 2.0,
    );
    assert!(dist(out[10], mid) < 1e-12);
    track[3].0 = f64::NAN;
    assert_eq!(
        fill_gaps(&track, &GapFillConfig::default(), &mut out),
        Err(TrackingError::NonFinite)
    );
}

/// What [`process`] computes for a synthetic turn.
struct Processed {
    circle: Circle,
    track: Vec<(f64, f64)>,
    theta_h: Vec<f64>,
    inner: Vec<f64>,
    outer: Vec<f64>,
}

/// Runs Section 5.1 on a synthetic rigid turn: circle fit, Eq 5.4–5.5 headings from an IMU yaw
/// with an unknown offset (and wrapped), wheel speeds (Eq 5.10, 5.12–5.13).
fn process(turn: &Turn, n: usize) -> Processed {
    let track = turn.track(n, 0.0, &mut SplitMix64::new(0));
    let yaw: Vec<f64> = (0..n)
        .map(|k| wrap_angle_rad(turn.theta_h(k as f64 * DT) + FRAC_PI_2 - 1.234))
        .collect();
    let circle = fit_circle(&track).expect("a circle");
    let mut theta_h = vec![0.0; n];
    assert_eq!(
        corrected_headings_rad(&circle, &track, &yaw, &mut theta_h),
        Ok(n)
    );
    let (mut inner, mut outer) = (vec![0.0; n - 1], vec![0.0; n - 1]);
    let count = inner_outer_speeds(
        &track,
        &theta_h,
        &HUSKY,
        PRISM_OFFSET_M,
        DT,
        &mut inner,
        &mut outer,
    )
    .expect("valid");
    assert_eq!(count, n - 1);
    Processed {
        circle,
        track,
        theta_h,
        inner,
        outer,
    }
}

#[test]
fn rigid_turn_wheel_speeds_are_yaw_rate_times_distance_to_the_centre() {
    let (b, l) = (f64::from(HUSKY.track_width_m), f64::from(HUSKY.length_m));
    // Below B/2, dragged inner (B/2 < R < R'), at R' and beyond, and a point turn.
    for r_act in [0.0, 0.15, 0.4, 0.55, 0.8, 2.0] {
        let (turn, n) = quarter_turn_at(r_act);
        let Processed {
            track,
            theta_h,
            inner,
            outer,
            ..
        } = process(&turn, n);
        for k in 0..n {
            // Eq 5.5 recovers the true θ_H (mod 2π).
            let err = wrap_angle_rad(theta_h[k] - turn.theta_h(k as f64 * DT));
            assert!(err.abs() < 1e-9, "R {r_act} sample {k}: θ_H off by {err}");
            // The wheels sit where the rover's geometry puts them around its centre.
            let w = wheel_positions(track[k], theta_h[k], &HUSKY, PRISM_OFFSET_M);
            let centre_of_rover = turn.prism(k as f64 * DT);
            let (s, c) = theta_h[k].sin_cos();
            let rover_centre = (
                centre_of_rover.0 - PRISM_OFFSET_M * c,
                centre_of_rover.1 - PRISM_OFFSET_M * s,
            );
            let expect = |bx: f64, by: f64| {
                (
                    rover_centre.0 + c * bx - s * by,
                    rover_centre.1 + s * bx + c * by,
                )
            };
            assert!(dist(w.inner_front_m, expect(-b / 2.0, l / 2.0)) < 1e-12);
            assert!(dist(w.outer_back_m, expect(b / 2.0, -l / 2.0)) < 1e-12);
        }
        let rho_inner = (r_act - b / 2.0).hypot(l / 2.0);
        let rho_outer = (r_act + b / 2.0).hypot(l / 2.0);
        let omega = turn.yaw_rate_rad_s;
        // Eq 5.10 measures the chord: 2ρ sin(ω δt / 2) / δt, within (ω δt)²/24 of ω ρ.
        let chord = |rho: f64| 2.0 * rho * (omega * DT / 2.0).sin() / DT;
        for k in 0..n - 1 {
            assert!(
                close(inner[k], chord(rho_inner), 1e-9),
                "R {r_act}: {} vs {}",
                inner[k],
                chord(rho_inner)
            );
            assert!(close(outer[k], chord(rho_outer), 1e-9));
            assert!(close(inner[k], omega * rho_inner, 1e-3 * omega * rho_inner));
            assert!(close(outer[k], omega * rho_outer, 1e-3 * omega * rho_outer));
        }
    }
}

#[test]
fn wheel_velocity_directions_give_the_eq_5_1_slip_angles() {
    // β = angle between a wheel's velocity (Eq 5.11) and its commanded direction: forward
    // (θ_H + 90°) for the outer wheels, and for the inner wheels backward below R'_ACT,
    // forward above (Section 2.1.2).
    let r_prime_act = 0.55;
    for r_act in [0.15, 0.4, 0.8, 2.0] {
        let (turn, n) = quarter_turn_at(r_act);
        let Processed {
            circle,
            track,
            theta_h,
            ..
        } = process(&turn, n);
        let expected =
            measured_slip_angles(&circle, PRISM_OFFSET_M, r_prime_act, &HUSKY).expect("valid");
        assert_eq!(
            expected,
            kinematics::slip_angles(r_act as f32, r_prime_act as f32, &HUSKY)
        );
        for k in 0..n {
            let w = wheel_positions(track[k], theta_h[k], &HUSKY, PRISM_OFFSET_M);
            let forward = theta_h[k] + FRAC_PI_2;
            let inner_cmd = if r_act < r_prime_act {
                forward + PI
            } else {
                forward
            };
            let beta = |wheel: (f64, f64), cmd: f64| {
                wrap_angle_rad(velocity_direction_rad(wheel, &circle) - cmd)
                    .abs()
                    .to_degrees()
            };
            for wheel in [w.outer_front_m, w.outer_back_m] {
                let got = beta(wheel, forward);
                assert!(
                    close(got, f64::from(expected.outer_deg), 1e-3),
                    "R {r_act}: {got} vs {expected:?}"
                );
            }
            for wheel in [w.inner_front_m, w.inner_back_m] {
                let got = beta(wheel, inner_cmd);
                assert!(
                    close(got, f64::from(expected.inner_deg), 1e-3),
                    "R {r_act}: {got} vs {expected:?}"
                );
            }
        }
    }
}

#[test]
fn moving_average_starts_at_the_third_sample() {
    let x = [3.0, 6.0, 9.0, 0.0, 3.0];
    let mut out = [0.0; 3];
    assert_eq!(moving_average(&x, MOVING_AVERAGE_WINDOW, &mut out), Ok(3));
    assert_eq!(out, [6.0, 5.0, 4.0]);
    assert_eq!(moving_average(&x[..2], 3, &mut out), Ok(0));
    assert_eq!(
        moving_average(&x, 3, &mut [0.0; 2]),
        Err(TrackingError::OutputTooSmall)
    );
    assert_eq!(
        moving_average(&x, 0, &mut out),
        Err(TrackingError::InvalidParameter)
    );
    assert_eq!(
        moving_average(&[f64::NAN; 3], 3, &mut out),
        Err(TrackingError::NonFinite)
    );
    let mut same = [0.0; 5];
    assert_eq!(moving_average(&x, 1, &mut same), Ok(5));
    assert_eq!(same, x);
}

#[test]
fn angular_slip_and_time_to_turn_from_a_slow_turn() {
    // Commanded 0.545 rad/s (R' at v_c = 0.3 m/s); the rover only manages 0.4 rad/s.
    let turn = Turn {
        yaw_rate_rad_s: 0.4,
        ..r_prime_turn()
    };
    let n = samples_for(&turn, PI / 2.0) + 5;
    let track = turn.track(n, 0.0, &mut SplitMix64::new(0));
    let circle = fit_circle(&track).expect("a circle");
    let rate = yaw_rate_from_track_rad_s(&circle, &track, DT).expect("valid");
    assert!(close(rate, 0.4, 1e-12));
    let cmd = (0.6 / 1.1) as f32;
    let slip = angular_slip_from_track(cmd, &circle, &track, DT)
        .expect("valid")
        .expect("commanded");
    assert!(close(
        f64::from(slip),
        (f64::from(cmd) - 0.4) / f64::from(cmd),
        1e-6
    ));
    assert_eq!(angular_slip_from_track(0.0, &circle, &track, DT), Ok(None));
    // IMU yaw, wrapped at ±π: the 90° takes (π/2)/0.4 = 3.927 s.
    let yaw: Vec<f64> = (0..n)
        .map(|k| wrap_angle_rad(3.0 + 0.4 * k as f64 * DT))
        .collect();
    assert!(
        yaw.iter().any(|&y| y < 0.0),
        "the series must wrap for this test"
    );
    assert!(close(
        yaw_rate_from_headings_rad_s(&yaw, DT).expect("valid"),
        0.4,
        1e-12
    ));
    assert!(close(
        heading_change_rad(&yaw).expect("valid"),
        0.4 * (n - 1) as f64 * DT,
        1e-12
    ));
    let t = time_to_heading_change_s(&yaw, DT, PI / 2.0)
        .expect("valid")
        .expect("turned");
    assert!(close(t, PI / 2.0 / 0.4, 1e-9), "{t}");
    assert_eq!(time_to_heading_change_s(&yaw, DT, PI), Ok(None));
    // A right turn counts too.
    let right: Vec<f64> = yaw.iter().map(|y| -y).collect();
    let t = time_to_heading_change_s(&right, DT, PI / 2.0)
        .expect("valid")
        .expect("turned");
    assert!(close(t, PI / 2.0 / 0.4, 1e-9));
    assert_eq!(
        time_to_heading_change_s(&yaw, 0.0, 1.0),
        Err(TrackingError::InvalidParameter)
    );
    assert_eq!(
        time_to_heading_change_s(&yaw, DT, -1.0),
        Err(TrackingError::InvalidParameter)
    );
    assert_eq!(
        time_to_heading_change_s(&yaw[..1], DT, 1.0),
        Err(TrackingError::TooFewPoints)
    );
}

#[test]
fn heading_inputs_are_checked() {
    let c = Circle {
        centre_x_m: 0.0,
        centre_y_m: 0.0,
        radius_m: 1.0,
    };
    assert_eq!(
        final_heading_rad(&c, (0.0, 0.0)),
        Err(TrackingError::Degenerate)
    );
    assert!(close(
        final_heading_rad(&c, (-1.0, 0.0)).expect("defined"),
        PI,
        1e-15
    ));
    let mut out = [0.0; 2];
    assert_eq!(
        corrected_headings_rad(&c, &[(1.0, 0.0)], &[0.0, 1.0], &mut out),
        Err(TrackingError::LengthMismatch)
    );
    assert_eq!(
        corrected_headings_rad(&c, &[], &[], &mut out),
        Err(TrackingError::TooFewPoints)
    );
    assert_eq!(
        corrected_headings_rad(&c, &[(1.0, 0.0); 3], &[0.0; 3], &mut out),
        Err(TrackingError::OutputTooSmall)
    );
    let (mut a, mut b) = ([0.0; 1], [0.0; 1]);
    assert_eq!(
        inner_outer_speeds(
            &[(0.0, 0.0), (1.0, 0.0)],
            &[0.0, 0.0],
            &HUSKY,
            0.21,
            0.0,
            &mut a,
            &mut b
        ),
        Err(TrackingError::InvalidParameter)
    );
    assert_eq!(
        inner_outer_speeds(
            &[(0.0, 0.0), (1.0, 0.0)],
            &[0.0, f64::NAN],
            &HUSKY,
            0.21,
            DT,
            &mut a,
            &mut b
        ),
        Err(TrackingError::NonFinite)
    );
    assert_eq!(
        inner_outer_speeds(
            &[(0.0, 0.0), (1.0, 0.0)],
            &[0.0, 0.0],
            &HUSKY,
            0.21,
            DT,
            &mut a,
            &mut b
        ),
        Ok(1)
    );
    assert!(close(a[0], 5.0, 1e-12) && close(b[0], 5.0, 1e-12));
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -10.0..10.0f64,
        1 => any::<f64>(),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(0.0),
    ]
}

fn any_points(max: usize) -> impl Strategy<Value = Vec<(f64, f64)>> {
    proptest::collection::vec((any_f64(), any_f64()), 0..max)
}

proptest! {
    #[test]
    fn circle_fit_never_panics(points in any_points(40)) {
        if let Ok(c) = fit_circle(&points) {
            prop_assert!(c.radius_m.is_finite() && c.radius_m >= 0.0);
            let _ = actual_radius_m(&c, PRISM_OFFSET_M);
            let _ = measured_slip_angles(&c, PRISM_OFFSET_M, 0.55, &HUSKY);
            let _ = swept_angle_rad(&c, &points);
            let _ = yaw_rate_from_track_rad_s(&c, &points, DT);
            let _ = angular_slip_from_track(0.5, &c, &points, DT);
        }
    }

    #[test]
    fn hampel_never_panics(values in proptest::collection::vec(any_f64(), 0..60), k in 0usize..20, nsigma in any_f64()) {
        let mut out = vec![HampelPoint::default(); values.len()];
        let cfg = HampelConfig { half_window: k, n_sigmas: nsigma };
        if let Ok(n) = hampel(&values, &cfg, &mut out) {
            prop_assert!(n <= values.len());
            if k == 0 { prop_assert_eq!(n, 0); }
        }
    }

    #[test]
    fn gap_filling_never_panics_and_keeps_the_measurements(
        points in any_points(50),
        k in 0usize..5,
        max in 0usize..12,
    ) {
        let cfg = GapFillConfig { neighbours_per_side: k, max_inserted_per_gap: max, ..GapFillConfig::default() };
        let mut out = vec![(0.0, 0.0); points.len() * (1 + max)];
        if let Ok(report) = fill_gaps(&points, &cfg, &mut out) {
            prop_assert_eq!(report.len, points.len() + report.inserted);
            // The measured points appear in order (a subsequence of the output).
            let mut it = out[..report.len].iter();
            for p in &points {
                prop_assert!(it.any(|q| q == p));
            }
        }
        // A tight buffer is refused or suffices, never overrun.
        let mut tight = vec![(0.0, 0.0); points.len()];
        let _ = fill_gaps(&points, &cfg, &mut tight);
    }

    #[test]
    fn wheel_processing_never_panics(
        rows in proptest::collection::vec((any_f64(), any_f64(), any_f64()), 0..30),
        dt in any_f64(),
        offset in any_f64(),
        change in any_f64(),
    ) {
        let prism: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
        let yaw: Vec<f64> = rows.iter().map(|r| r.2).collect();
        let n = rows.len();
        let (mut inner, mut outer, mut th) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let _ = inner_outer_speeds(&prism, &yaw, &HUSKY, offset, dt, &mut inner, &mut outer);
        let _ = moving_average(&yaw, 3, &mut inner);
        let _ = time_to_heading_change_s(&yaw, dt, change);
        let _ = yaw_rate_from_headings_rad_s(&yaw, dt);
        let c = Circle { centre_x_m: offset, centre_y_m: change, radius_m: 1.0 };
        let _ = corrected_headings_rad(&c, &prism, &yaw, &mut th);
    }
}
