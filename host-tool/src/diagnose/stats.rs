//! The statistics every stage uses: the practical floors, Student's t (quantiles, intervals,
//! one-sample and Welch tests), the run bootstrap, the binomial tail and the median. One home, so
//! that a floor or a test means the same in the gaps, the marks and the verdict.

use model_core::rng::SplitMix64;

/// Smallest mean gap that counts, per side [W] (below it a gap is not worth a term).
pub const PRACTICAL_FLOOR_W: f64 = 1.5;

/// Smallest mean gap that counts relative to the power the model predicts for the group, as a
/// fraction of its mean |model power| per side (the floor is the larger of this and
/// [`PRACTICAL_FLOOR_W`]). A two-parameter steady power model (Eq 21) is not expected to hold
/// a large side power to better than a few per cent: a 2 W gap on a 200 W side is model
/// tolerance, not a missing term, whereas the same 2 W on a side the model says draws nothing is
/// not.
pub const RELATIVE_FLOOR: f64 = 0.05;

/// Fewest runs for which the runs themselves are the resampling units of [`bootstrap_mean`];
/// with fewer, a percentile bootstrap over 2–3 units spans little more than their range, so the
/// interval is Student's t over the individual manoeuvres ([`t_interval`]).
pub const MIN_BOOTSTRAP_RUNS: usize = 4;

/// Bootstrap resamples.
pub const BOOTSTRAP_RESAMPLES: usize = 2000;

/// The 97.5 % quantile of Student's t with `df` degrees of freedom (the half-width factor of a
/// two-sided 95 % interval; model-core's, so board and host share one implementation); ∞ for
/// df = 0.
pub fn t_quantile_975(df: usize) -> f64 {
    // The inversion is iterative and the diagnosis asks for a few thousand intervals: compute
    // each small degree of freedom once, when first asked (a whole table up front cost a
    // one-shot `diagnose` 15 % of its time).
    const CACHED: usize = 256;
    static TABLE: [std::sync::OnceLock<f64>; CACHED] =
        [const { std::sync::OnceLock::new() }; CACHED];
    let exact = |df: usize| model_core::fit::student_t_quantile(0.975, df).unwrap_or(f64::INFINITY);
    match df {
        0 => f64::INFINITY,
        1..=CACHED => *TABLE[df - 1].get_or_init(|| exact(df)),
        _ => exact(df),
    }
}

/// Mean and 95 % Student-t interval of `values` taken as independent repeats; `None` for no
/// values, an unbounded interval for one.
pub fn t_interval(values: &[f64]) -> Option<(f64, f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return Some((mean, f64::NEG_INFINITY, f64::INFINITY));
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let half = t_quantile_975(n - 1) * (var / n as f64).sqrt();
    Some((mean, mean - half, mean + half))
}

/// Mean and 95 % interval of `values` grouped by `groups` (runs): a percentile bootstrap
/// resampling whole groups (the repeats are the unit of noise) when there are at least
/// [`MIN_BOOTSTRAP_RUNS`] groups, else Student's t over the values ([`t_interval`]); `None` for
/// no values.
pub fn bootstrap_mean(values: &[f64], groups: &[usize], seed: u64) -> Option<(f64, f64, f64)> {
    if values.is_empty() || values.len() != groups.len() {
        return None;
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let mut ids: Vec<usize> = groups.to_vec();
    ids.sort_unstable();
    ids.dedup();
    if ids.len() < MIN_BOOTSTRAP_RUNS {
        return t_interval(values);
    }
    let units: Vec<Vec<f64>> = if ids.len() >= 2 {
        ids.iter()
            .map(|g| {
                values
                    .iter()
                    .zip(groups)
                    .filter(|(_, h)| *h == g)
                    .map(|(v, _)| *v)
                    .collect()
            })
            .collect()
    } else {
        values.iter().map(|v| vec![*v]).collect()
    };
    if units.len() < 2 {
        return Some((mean, f64::NEG_INFINITY, f64::INFINITY));
    }
    let mut rng = SplitMix64::new(seed);
    let mut means: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
        .map(|_| {
            let (mut s, mut n) = (0.0, 0usize);
            for _ in 0..units.len() {
                let u = &units[rng.below(units.len())];
                s += u.iter().sum::<f64>();
                n += u.len();
            }
            s / n.max(1) as f64
        })
        .collect();
    means.sort_by(f64::total_cmp);
    let lo = means[(0.025 * BOOTSTRAP_RESAMPLES as f64) as usize];
    let hi = means[(0.975 * BOOTSTRAP_RESAMPLES as f64) as usize - 1];
    Some((mean, lo, hi))
}

/// Mean, standard deviation and count of `values`.
pub fn moments(values: &[f64]) -> Option<(f64, f64, usize)> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let sd = if n > 1 {
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        f64::NAN
    };
    Some((mean, sd, n))
}

/// Upper-tail probability of Student's t with `df` degrees of freedom (fractional df rounded
/// down, at least 1).
pub fn t_upper(t: f64, df: f64) -> f64 {
    if t.is_nan() {
        return 1.0;
    }
    if t == f64::INFINITY {
        return 0.0;
    }
    let dof = (df.floor() as usize).max(1);
    model_core::fit::student_t_cdf(t, dof).map_or(1.0, |c| (1.0 - c).clamp(0.0, 1.0))
}

/// Largest |t| a test reports as a statistic. Beyond it the spread is not noise a sensor makes
/// (a simulated run repeated exactly, values equal to rounding): the test is degenerate.
pub const MAX_STATISTIC: f64 = 1e6;

/// A t statistic, or NaN when it is degenerate: a zero spread, or one so small against the
/// difference that |t| passes [`MAX_STATISTIC`]. A degenerate test is never significant (its
/// p is 1): a sample without variance says nothing about the noise it is to be told from.
fn t_or_degenerate(difference: f64, se: f64) -> f64 {
    let t = difference / se;
    if se > 0.0 && t.abs() <= MAX_STATISTIC {
        t
    } else {
        f64::NAN
    }
}

/// One-sided one-sample t of `values`' mean above `null`: (t, df, p); `None` under 2 values;
/// t NaN and p 1 when degenerate ([`t_or_degenerate`]).
pub fn one_sample_upper(values: &[f64], null: f64) -> Option<(f64, f64, f64)> {
    let (mean, sd, n) = moments(values)?;
    if n < 2 {
        return None;
    }
    let t = t_or_degenerate(mean - null, sd / (n as f64).sqrt());
    let df = (n - 1) as f64;
    Some((t, df, t_upper(t, df)))
}

/// One-sided Welch t of mean(`a`) above mean(`b`): (difference, t, df, p); `None` when either
/// has fewer than 2 values; t NaN and p 1 when degenerate ([`t_or_degenerate`]).
pub fn welch_upper(a: &[f64], b: &[f64]) -> Option<(f64, f64, f64, f64)> {
    let (ma, sa, na) = moments(a)?;
    let (mb, sb, nb) = moments(b)?;
    if na < 2 || nb < 2 {
        return None;
    }
    let (va, vb) = (sa * sa / na as f64, sb * sb / nb as f64);
    let se2 = va + vb;
    let diff = ma - mb;
    let t = t_or_degenerate(diff, se2.sqrt());
    let df = if se2 > 0.0 {
        se2 * se2 / (va * va / (na - 1) as f64 + vb * vb / (nb - 1) as f64)
    } else {
        (na + nb - 2) as f64
    };
    Some((diff, t, df, t_upper(t, df)))
}

/// One-sided t of the mean difference of paired groups above 0, each group a condition the
/// two samples were both taken at (`(a, b)`: a's values against b's at one condition): the
/// differences of the group means weighted by a's count, against a spread pooled within the
/// groups of both samples (a group of one value adds no degrees of freedom but still its
/// difference). (difference, t, df, p); `None` without a group holding both or without a
/// degree of freedom; t NaN and p 1 when degenerate ([`t_or_degenerate`]).
pub fn matched_upper(groups: &[(Vec<f64>, Vec<f64>)]) -> Option<(f64, f64, f64, f64)> {
    let held: Vec<_> = groups
        .iter()
        .filter(|(a, b)| !a.is_empty() && !b.is_empty())
        .collect();
    let n: usize = held.iter().map(|(a, _)| a.len()).sum();
    let (mut diff, mut var_factor, mut ss, mut df) = (0.0, 0.0, 0.0, 0usize);
    for (a, b) in &held {
        let (ma, _, na) = moments(a)?;
        let (mb, _, nb) = moments(b)?;
        let w = na as f64 / n as f64;
        diff += w * (ma - mb);
        var_factor += w * w * (1.0 / na as f64 + 1.0 / nb as f64);
        ss += a.iter().map(|v| (v - ma).powi(2)).sum::<f64>();
        ss += b.iter().map(|v| (v - mb).powi(2)).sum::<f64>();
        df += na + nb - 2;
    }
    if df == 0 {
        return None;
    }
    let se = (ss / df as f64 * var_factor).sqrt();
    let t = t_or_degenerate(diff, se);
    Some((diff, t, df as f64, t_upper(t, df as f64)))
}

/// P(X ≥ k) for X ~ Binomial(n, p).
pub fn binomial_upper_tail(k: usize, n: usize, p: f64) -> f64 {
    if k == 0 {
        return 1.0;
    }
    // Sum the lower part in log space and take its complement from the pmf directly.
    let ln_pmf = |i: usize| ln_choose(n, i) + i as f64 * p.ln() + (n - i) as f64 * (1.0 - p).ln();
    (k..=n).map(|i| ln_pmf(i).exp()).sum::<f64>().min(1.0)
}

pub fn ln_choose(n: usize, k: usize) -> f64 {
    (1..=k)
        .map(|i| ((n - k + i) as f64).ln() - (i as f64).ln())
        .sum()
}

/// The median of `values` (the mean of the middle two for an even count); `None` when empty.
pub fn median(mut values: Vec<f64>) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    })
}

/// The upper median of `values` (the higher middle one for an even count); `None` when empty.
pub fn upper_median(mut values: Vec<f64>) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    Some(values[values.len() / 2])
}

/// The held-out RMS a model removes: √(before² − after²), 0 when it makes things worse [W].
pub fn removed_rms_w(before: f64, after: f64) -> f64 {
    (before * before - after * after).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_match_the_table_and_approach_the_normal() {
        assert!((t_quantile_975(1) - 12.706).abs() < 1e-3);
        assert!((t_quantile_975(3) - 3.182).abs() < 1e-3);
        // Beyond the table: t(40) = 2.021, t(120) = 1.980.
        assert!((t_quantile_975(40) - 2.021).abs() < 2e-3);
        assert!((t_quantile_975(120) - 1.980).abs() < 2e-3);
        assert!(t_quantile_975(0).is_infinite());
    }

    #[test]
    fn few_runs_give_a_t_interval_over_the_manoeuvres() {
        // Two runs of two repeats: a bootstrap over the two runs would span only the two run
        // means (4.0 and 6.0); Student's t over the four values is much wider.
        let values = [3.0, 5.0, 5.0, 7.0];
        let runs = [0, 0, 1, 1];
        let (mean, lo, hi) = bootstrap_mean(&values, &runs, 1).expect("values");
        assert_eq!(mean, 5.0);
        let half = 3.182 * (8.0f64 / 3.0 / 4.0).sqrt();
        assert!((lo - (5.0 - half)).abs() < 1e-3 && (hi - (5.0 + half)).abs() < 1e-3);
        assert!(lo < 4.0 && hi > 6.0);
        // One value: no interval.
        let (_, lo, hi) = bootstrap_mean(&[1.0], &[0], 1).expect("value");
        assert!(lo.is_infinite() && hi.is_infinite());
    }

    #[test]
    fn many_runs_are_bootstrapped_as_units() {
        let values: Vec<f64> = (0..8).map(|i| f64::from(i % 4)).collect();
        let runs: Vec<usize> = (0..8).map(|i| i % 4).collect();
        let (mean, lo, hi) = bootstrap_mean(&values, &runs, 7).expect("values");
        assert_eq!(mean, 1.5);
        // Resampled run means lie within the runs' range.
        assert!(lo >= 0.0 && hi <= 3.0 && lo < mean && hi > mean);
    }

    #[test]
    fn the_binomial_tail_matches_closed_forms() {
        assert_eq!(binomial_upper_tail(0, 10, 0.05), 1.0);
        // P(X ≥ 1) = 1 − 0.95^10.
        assert!((binomial_upper_tail(1, 10, 0.05) - (1.0 - 0.95f64.powi(10))).abs() < 1e-12);
        // P(X = n) = p^n.
        assert!((binomial_upper_tail(3, 3, 0.05) - 0.05f64.powi(3)).abs() < 1e-15);
    }

    #[test]
    fn welch_t_is_the_pooled_t_for_equal_spreads_and_sizes() {
        let a = [3.0, 4.0, 5.0];
        let b = [0.0, 1.0, 2.0];
        let (diff, t, df, p) = welch_upper(&a, &b).expect("two samples");
        assert_eq!(diff, 3.0);
        // Pooled sd 1, se = √(2/3).
        assert!((t - 3.0 / (2.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((df - 4.0).abs() < 1e-12);
        assert!(p < 0.05 && p > 0.0);
        assert!(welch_upper(&a, &[1.0]).is_none());
    }

    #[test]
    fn one_sided_t_rejects_only_above_the_null() {
        let above = [1.1, 1.2, 1.3, 1.15];
        let (t, df, p) = one_sample_upper(&above, 1.0).expect("test");
        // mean 1.1875, sd 0.0854, n 4: t = 4.39 on 3 df, one-sided p ≈ 0.011.
        assert!((t - 4.392).abs() < 0.01 && df == 3.0, "{t} {df}");
        assert!((0.010..0.012).contains(&p), "{p}");
        let (_, _, p) = one_sample_upper(&above, 1.5).expect("test");
        assert!(p > 0.99, "{p}");
        assert!(one_sample_upper(&[1.0], 0.0).is_none());
    }

    #[test]
    fn a_sample_without_variance_is_degenerate_never_certain() {
        // Identical values, or values equal to rounding: no noise to test a difference against.
        let (t, df, p) = one_sample_upper(&[0.05, 0.05, 0.05], 0.0).expect("three values");
        assert!(t.is_nan() && df == 2.0 && p == 1.0);
        let rounding = [0.057, 0.057 + 1e-17, 0.057 - 2e-17, 0.057 + 3e-18];
        let (t, _, p) = one_sample_upper(&rounding, 0.0).expect("values");
        assert!(t.is_nan() && p == 1.0, "t {t}");
        let (_, t, _, p) = welch_upper(&[1.0, 1.0], &[0.0, 0.0]).expect("two each");
        assert!(t.is_nan() && p == 1.0);
        // Real spread still tests.
        let (t, _, p) = one_sample_upper(&[0.04, 0.05, 0.06], 0.0).expect("values");
        assert!((t - 8.66).abs() < 0.01 && p < 0.01, "t {t} p {p}");
    }

    #[test]
    fn matched_groups_compare_like_with_like_and_pool_their_spread() {
        // Two conditions whose levels differ by far more than the shift between the samples:
        // matched, only the shift (0.01 at both) is tested, against the within-group spread.
        let groups = vec![
            (vec![0.11, 0.12, 0.13], vec![0.10, 0.11]),
            (vec![0.31, 0.32, 0.33], vec![0.30, 0.31]),
        ];
        let (diff, t, df, p) = matched_upper(&groups).expect("groups");
        assert!((diff - 0.015).abs() < 1e-12, "{diff}");
        assert_eq!(df, 6.0);
        // Pooled variance: (2·0.0001 + 0.00005) × 2 / 6; factor 2·0.25·(1/3 + 1/2).
        let se = ((2.0f64 * 2e-4 + 2.0 * 5e-5) / 6.0 * (0.5 * (1.0 / 3.0 + 0.5))).sqrt();
        assert!((t - 0.015 / se).abs() < 1e-9 && p < 0.05, "t {t} p {p}");
        // A group one side of which is empty is not matched; one value per side adds no df.
        assert!(matched_upper(&[(vec![0.1], vec![0.0]), (vec![0.2], vec![])]).is_none());
        let (diff, _, df, _) =
            matched_upper(&[(vec![0.1], vec![0.0]), (vec![0.2, 0.3], vec![0.2, 0.2])])
                .expect("two df");
        assert!((diff - (0.1 / 3.0 + 2.0 / 3.0 * 0.05)).abs() < 1e-12 && df == 2.0);
    }
}
