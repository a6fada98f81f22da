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

/// One-sided one-sample t of `values`' mean above `null`: (t, df, p); `None` under 2 values.
pub fn one_sample_upper(values: &[f64], null: f64) -> Option<(f64, f64, f64)> {
    let (mean, sd, n) = moments(values)?;
    if n < 2 {
        return None;
    }
    let se = sd / (n as f64).sqrt();
    let t = if se > 0.0 {
        (mean - null) / se
    } else if mean > null {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    };
    let df = (n - 1) as f64;
    Some((t, df, t_upper(t, df)))
}

/// One-sided Welch t of mean(`a`) above mean(`b`): (difference, t, df, p); `None` when either
/// has fewer than 2 values.
pub fn welch_upper(a: &[f64], b: &[f64]) -> Option<(f64, f64, f64, f64)> {
    let (ma, sa, na) = moments(a)?;
    let (mb, sb, nb) = moments(b)?;
    if na < 2 || nb < 2 {
        return None;
    }
    let (va, vb) = (sa * sa / na as f64, sb * sb / nb as f64);
    let se2 = va + vb;
    let diff = ma - mb;
    if se2 <= 0.0 {
        let t = if diff > 0.0 {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        };
        return Some((diff, t, (na + nb - 2) as f64, t_upper(t, 1.0)));
    }
    let t = diff / se2.sqrt();
    let df = se2 * se2 / (va * va / (na - 1) as f64 + vb * vb / (nb - 1) as f64);
    Some((diff, t, df, t_upper(t, df)))
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
}
