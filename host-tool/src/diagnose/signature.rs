//! Each catalogue effect's signature ([`EffectId::signature`]): the observation only it
//! produces, tested on the data with its statistic, degrees of freedom and p-value. An effect
//! is named only when its signature is present; one whose signature needs no power model
//! ([`EffectId::signature_needs_power_model`]) is also named when the baseline misfits its
//! calibration, with the misfit reported beside it.
//!
//! | effect | observation | test |
//! |---|---|---|
//! | `current-offset` | standstill current per run and side | one-sided t of \|mean\| over the quiescent draw (0.25 A), per side, Bonferroni ×2 |
//! | `angular-slip` | yaw-timed slip of the turns with 0 < R ≤ R′ minus the point turns' | one-sided t ≥ 0, rise ≥ 2 %, per regime, Bonferroni ×3 |
//! | `slip-track` | every turn's slip beyond the calibration's terrain slip, not rising towards R′ (pose: measured slip track vs the terrain's) | two-sided t, \|mean\| ≥ 2 %, angular slip's rise absent |
//! | `slope` | manoeuvres off level (\|pitch\| > 1°) | binomial tail against 5 % of level manoeuvres reading off level |
//! | `motor-heating` | within-manoeuvre-kind trend of power over run time, a manoeuvre repeated within a run | permutation test (the "where" analysis), rising |
//! | `sinkage-bulldozing` | growth through the manoeuvre (second half − first half of its steady part), each side: of turns below R′, or of turns below R′ and straights | Welch t per side against straights and wide turns, or one-sample t per side against none (not with heating's or the slope's mark present); ≥ 1.5 W on both, the weaker side's p ×2, the stronger reading's p ×2 |
//! | `inner-drag` | inner-side residual in dragged-inner turns | Welch t against the inner side of each neighbouring regime, ≥ 1.5 W above both and beyond the largest step between neighbouring radii elsewhere on that side (the baseline's structure) |
//! | `braked-inner` | outer-side residual at R′ | Welch t against the outer side of each neighbouring radius, ≥ 1.5 W above both and beyond the largest step elsewhere, as for `inner-drag` |

use super::baseline::family::MAX_SLIP_SPREAD;
use super::baseline::{self, Baseline};
use super::calibration::{Calibration, Source};
use super::cv::{self, PRACTICAL_FLOOR_W};
use super::features::{SideRole, TurnRow};
use super::gaps::WhereAnalysis;
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;
use serde::Serialize;

/// Significance level of every signature test (after its Bonferroni factor).
pub const ALPHA: f64 = 0.05;

/// Smallest angular slip beyond the reference that counts as seen in the yaw (the spread of a
/// calibration's constant slip).
pub const MIN_SLIP_EXCESS: f64 = 0.02;

/// Smallest relative difference of a measured slip track from the terrain's.
pub const MIN_SLIP_TRACK_DIFFERENCE: f64 = 0.02;

/// Share of level manoeuvres whose mean pitch may read beyond the level threshold (sensor
/// noise, a bump): the null of the slope signature's binomial test.
pub const OFF_LEVEL_BY_CHANCE: f64 = 0.05;

/// One effect's signature test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Signature {
    /// The effect.
    pub effect: EffectId,
    /// What its signature is ([`EffectId::signature`]).
    pub observation: &'static str,
    /// Whether the observation is read off the power model's residuals.
    pub needs_power_model: bool,
    /// The test, when the data can show the signature at all.
    pub test: Option<SignatureTest>,
    /// What was measured, or why the data cannot show it.
    pub detail: String,
    /// Not observable on these runs whatever is driven next: a slope hides it, or a sensor it
    /// reads is not logged. (Any other unobservable signature needs more manoeuvres.)
    pub masked: bool,
    /// The effect whose own mark, present in the data, hides this one (a slope's pull turns
    /// the rover as a slip would): what this term fits there is that effect's doing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hidden_by: Option<EffectId>,
    /// The effect whose own mark must first be looked for and found missing before this mark,
    /// there in size, can be read as this effect's: it makes the same mark (a warming winding
    /// raises power through every manoeuvre as sinking wheels do). Its drives tell them apart.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub told_apart_by: Option<EffectId>,
}

/// A signature's statistical test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SignatureTest {
    /// `t`, `Welch t`, `binomial` or `permutation`.
    pub statistic_name: &'static str,
    /// The statistic's value.
    pub statistic: f64,
    /// Its degrees of freedom (observations for the binomial and permutation tests).
    pub df: f64,
    /// Its p-value, multiple-comparison factor applied.
    pub p: f64,
    /// p below [`ALPHA`] and the effect size beyond its practical floor.
    pub present: bool,
    /// The effect size beyond its practical floor, significant or not: without `present`, the
    /// mark is there in size but not yet beyond the noise (more of the same manoeuvres could
    /// show it), not missing.
    pub sized: bool,
}

impl SignatureTest {
    /// `present`, `inconclusive` (its size in the data, not yet beyond the noise) or `absent`.
    pub fn verdict(&self) -> &'static str {
        match (self.present, self.sized) {
            (true, _) => "present",
            (false, true) => "inconclusive",
            (false, false) => "absent",
        }
    }
}

impl Signature {
    /// Whether the data show the signature.
    pub fn present(&self) -> bool {
        self.test.is_some_and(|t| t.present)
    }

    /// Whether it was looked for and is missing: tested, and not even its size reaches the
    /// floor (a mark of that size not yet beyond the noise is not missing).
    pub fn absent(&self) -> bool {
        self.test.is_some_and(|t| !t.present && !t.sized)
    }

    /// The test's outcome for the report: `present: t = 4.39, df 3, p = 0.011`, or
    /// `not observable`.
    pub fn outcome(&self) -> String {
        match &self.test {
            Some(t) => format!(
                "{}: {} = {:.2}, df {:.0}, p = {}",
                t.verdict(),
                t.statistic_name,
                t.statistic,
                t.df,
                format_p(t.p)
            ),
            None => "not observable".to_owned(),
        }
    }

    /// One line for the report: the test and what it measured.
    pub fn describe(&self) -> String {
        match &self.test {
            Some(_) => format!("{} — {}", self.outcome(), self.detail),
            None => format!("not observable: {}", self.detail),
        }
    }

    /// Whether its candidate cannot be named on these runs: its mark was looked for and is
    /// missing, or another effect's present mark hides it (the verdict does not weigh it).
    pub fn rules_out(&self) -> bool {
        self.absent() || self.hidden_by.is_some()
    }

    /// Whether its size is in the data but not yet beyond the noise: more of the manoeuvres its
    /// test reads can show it.
    pub fn inconclusive(&self) -> bool {
        self.test.is_some_and(|t| !t.present && t.sized)
    }

    /// Whether the data cannot show it yet but more manoeuvres can (not tested, not masked).
    pub fn observable_by_driving(&self) -> bool {
        self.test.is_none() && !self.masked
    }

    fn unobservable(effect: EffectId, why: impl Into<String>) -> Self {
        Self {
            effect,
            observation: effect.signature(),
            needs_power_model: effect.signature_needs_power_model(),
            test: None,
            detail: why.into(),
            masked: false,
            hidden_by: None,
            told_apart_by: None,
        }
    }

    fn masked(effect: EffectId, why: impl Into<String>) -> Self {
        Self {
            masked: true,
            ..Self::unobservable(effect, why)
        }
    }

    fn tested(effect: EffectId, test: SignatureTest, detail: String) -> Self {
        Self {
            effect,
            observation: effect.signature(),
            needs_power_model: effect.signature_needs_power_model(),
            test: Some(test),
            detail,
            masked: false,
            hidden_by: None,
            told_apart_by: None,
        }
    }
}

/// A p-value for the report: 3 significant digits, scientific below 0.001.
pub fn format_p(p: f64) -> String {
    if p < 1e-3 {
        format!("{p:.2e}")
    } else {
        format!("{p:.3}")
    }
}

/// What the signature tests read.
#[derive(Debug, Clone, Copy)]
pub struct Evidence<'a> {
    /// The diagnosed rows.
    pub rows: &'a [TurnRow],
    /// Every row of the calibration runs (empty when the runs calibrate themselves).
    pub calibration_rows: &'a [TurnRow],
    /// The baseline on the calibration manoeuvres.
    pub baseline: &'a Baseline,
    /// The "where" analysis (its run-time trend).
    pub where_: &'a WhereAnalysis,
}

impl<'a> Evidence<'a> {
    /// The evidence of a diagnosis calibrated as `calibration` says.
    pub fn new(
        rows: &'a [TurnRow],
        calibration: Calibration<'a>,
        baseline: &'a Baseline,
        where_: &'a WhereAnalysis,
    ) -> Self {
        let calibration_rows = match calibration.source {
            Source::FromRuns => &[][..],
            Source::Rows(cal) => cal,
        };
        Self {
            rows,
            calibration_rows,
            baseline,
            where_,
        }
    }
}

impl Evidence<'_> {
    /// Whether any manoeuvre, the calibration's included, was timed by a logged yaw.
    fn yaw_logged(&self) -> bool {
        self.rows
            .iter()
            .chain(self.calibration_rows)
            .any(|r| r.turned_from_yaw)
    }
}

/// Every effect's signature test, catalogue order.
pub fn test_all(ev: &Evidence<'_>) -> Vec<Signature> {
    // On a slope the downhill pull turns the rover too, and a manoeuvre climbs another grade
    // at each heading: the yaw's timing is no longer a mark only a slip produces, nor a
    // repeat's extra power one only a warmer winding does. Those marks are hidden by the slope,
    // and what their terms fit there is the slope's doing.
    let slope = slope(ev);
    let on_slope = |e: EffectId, why: &str| Signature {
        hidden_by: Some(EffectId::Slope),
        ..Signature::masked(
            e,
            format!("the runs are on a slope (its signature is present), {why}"),
        )
    };
    let slip = "which changes the yaw rate of the turns too; drive the turns on level ground to \
                see a slip";
    // Angular slip's rise towards R′ is also what a slip track's yaw must not show.
    let angular = angular_slip(ev);
    // A warming winding, or a grade changing under the rover, makes a manoeuvre's power rise
    // through it too: until repeats have ruled the winding out, a rise through every
    // manoeuvre is not sinkage's alone.
    let heating = motor_heating(ev);
    let rising_otherwise = if slope.present() {
        Some(EffectId::Slope)
    } else {
        (!heating.absent()).then_some(EffectId::MotorHeating)
    };
    EffectId::ALL
        .map(|e| match e {
            EffectId::CurrentOffset => current_offset(ev),
            EffectId::AngularSlip | EffectId::SlipTrack if slope.present() => on_slope(e, slip),
            EffectId::MotorHeating if slope.present() => on_slope(
                e,
                "so the same manoeuvre climbs another grade at each heading; drive the repeats \
                 on level ground to see a warmer winding",
            ),
            EffectId::AngularSlip => angular.clone(),
            EffectId::SlipTrack => slip_track(ev, angular.present()),
            EffectId::Slope => slope.clone(),
            EffectId::MotorHeating => heating.clone(),
            EffectId::SinkageBulldozing => sinkage(ev, rising_otherwise),
            EffectId::InnerDrag => inner_drag(ev),
            EffectId::BrakedInner => braked_inner(ev),
        })
        .to_vec()
}

/// Mean, standard deviation and count of `values`.
fn moments(values: &[f64]) -> Option<(f64, f64, usize)> {
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
fn t_upper(t: f64, df: f64) -> f64 {
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
fn one_sample_upper(values: &[f64], null: f64) -> Option<(f64, f64, f64)> {
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
fn welch_upper(a: &[f64], b: &[f64]) -> Option<(f64, f64, f64, f64)> {
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

/// The standstill current of each run, per side (left, right), diagnosed and calibration runs.
fn standstill_currents(ev: &Evidence<'_>) -> [Vec<f64>; 2] {
    let mut seen: Vec<(bool, usize)> = Vec::new();
    let mut sides = [Vec::new(), Vec::new()];
    let all = ev
        .rows
        .iter()
        .map(|r| (false, r))
        .chain(ev.calibration_rows.iter().map(|r| (true, r)));
    for (cal, row) in all {
        let Some(s) = row.standstill_current_a else {
            continue;
        };
        if seen.contains(&(cal, row.run_index)) {
            continue;
        }
        seen.push((cal, row.run_index));
        sides[0].push(s.left);
        sides[1].push(s.right);
    }
    sides
}

/// `current-offset`: the standstill current of some side beyond a driver's quiescent draw.
fn current_offset(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::CurrentOffset;
    let sides = standstill_currents(ev);
    if sides[0].is_empty() {
        return Signature::unobservable(e, "no run stands still long enough");
    }
    let q = baseline::QUIESCENT_MAX_A;
    let mut best: Option<(SignatureTest, String)> = None;
    for (name, values) in ["left", "right"].into_iter().zip(&sides) {
        let (mean, _, n) = moments(values).expect("non-empty");
        let magnitudes: Vec<f64> = values.iter().map(|v| v * mean.signum()).collect();
        let detail = format!(
            "{name} side reads {mean:+.3} A at standstill over {n} run(s), a driver's quiescent \
             draw at most {q} A"
        );
        let test = match one_sample_upper(&magnitudes, q) {
            Some((t, df, p)) => {
                let p = (2.0 * p).min(1.0);
                SignatureTest {
                    statistic_name: "t",
                    statistic: t,
                    df,
                    p,
                    present: p < ALPHA && mean.abs() > q,
                    sized: mean.abs() > q,
                }
            }
            // One run: no repeat to test the offset against.
            None => SignatureTest {
                statistic_name: "t",
                statistic: f64::NAN,
                df: 0.0,
                p: 1.0,
                present: false,
                sized: false,
            },
        };
        if best
            .as_ref()
            .is_none_or(|(b, _)| test.p < b.p || (test.present && !b.present))
        {
            best = Some((test, detail));
        }
    }
    let (test, detail) = best.expect("two sides");
    Signature::tested(e, test, detail)
}

/// The measured angular slip of each yaw-timed turn of `regime` in `rows`, less the terrain's
/// constant slip the calibration fitted (`baseline.turn_slip`).
pub(super) fn excess_slips<'r>(
    rows: impl IntoIterator<Item = &'r TurnRow>,
    baseline: &Baseline,
    keep: impl Fn(&TurnRow) -> bool,
) -> Vec<f64> {
    rows.into_iter()
        .filter(|r| r.turned_from_yaw && !r.is_straight() && keep(r))
        .filter_map(|r| r.angular_slip.map(|s| s - baseline.turn_slip))
        .collect()
}

/// `angular-slip`: the turns between the point turn and R′ slower by yaw than the point turns
/// (the runs', else the calibration's), by at least [`MIN_SLIP_EXCESS`] (the thesis' Fig 6.8:
/// 0.27 at R = 0 to 0.38 at R′ on sand). A slip constant over the radii does not rise.
fn angular_slip(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::AngularSlip;
    // The runs' own point turns, on the same terrain; the calibration's when they have none.
    let is_point = |r: &TurnRow| r.regime == Regime::Point;
    let mut point = excess_slips(ev.rows, ev.baseline, is_point);
    if point.is_empty() {
        point = excess_slips(ev.calibration_rows, ev.baseline, is_point);
    }
    let Some((point_mean, _, _)) = moments(&point) else {
        if !ev.yaw_logged() {
            return Signature::masked(e, "no yaw logged");
        }
        return Signature::unobservable(e, "no point turn timed by yaw to compare with");
    };
    let regimes = [
        Regime::BelowHalfTrack,
        Regime::DraggedInner,
        Regime::AtRPrime,
    ];
    let mut best: Option<(SignatureTest, String)> = None;
    for regime in regimes {
        let rise: Vec<f64> = excess_slips(ev.rows, ev.baseline, |r| r.regime == regime)
            .into_iter()
            .map(|s| s - point_mean)
            .collect();
        let Some((t, df, p)) = one_sample_upper(&rise, 0.0) else {
            continue;
        };
        let (mean, _, n) = moments(&rise).expect("two or more");
        let p = (p * regimes.len() as f64).min(1.0);
        let test = SignatureTest {
            statistic_name: "t",
            statistic: t,
            df,
            p,
            present: p < ALPHA && mean >= MIN_SLIP_EXCESS,
            sized: mean >= MIN_SLIP_EXCESS,
        };
        let detail = format!(
            "{} turns ({n}) slip {:+.1} % beyond the point turns' {:.1} % (the calibration's \
             terrain slip {:.1} % taken off both)",
            regime.id(),
            100.0 * mean,
            100.0 * point_mean,
            100.0 * ev.baseline.turn_slip
        );
        if best
            .as_ref()
            .is_none_or(|(b, _)| (test.present, -test.p) > (b.present, -b.p))
        {
            best = Some((test, detail));
        }
    }
    match best {
        Some((test, detail)) => Signature::tested(e, test, detail),
        None => Signature::unobservable(
            e,
            "fewer than 2 turns timed by yaw in each regime between the point turn and R′",
        ),
    }
}

/// `slip-track`: with a pose track, the measured slip track off the terrain's (the controller's
/// B_s widened by the calibration's constant slip) by [`MIN_SLIP_TRACK_DIFFERENCE`]; else
/// every turn's yaw-timed slip off the calibration's terrain slip by [`MIN_SLIP_EXCESS`], either
/// way (a narrower track makes turns quicker than commanded), and the same on every turn: not
/// rising from the point turn towards R′ as angular slip does (`slip_rises`, its signature),
/// and each radius' mean within [`MAX_SLIP_SPREAD`] of the common mean.
fn slip_track(ev: &Evidence<'_>, slip_rises: bool) -> Signature {
    let e = EffectId::SlipTrack;
    let terrain_m = ev.baseline.slip_track_m / (1.0 - ev.baseline.turn_slip);
    let measured: Vec<f64> = ev
        .rows
        .iter()
        .filter_map(|r| r.measured.map(|m| m.slip_track_m / terrain_m - 1.0))
        .filter(|v| v.is_finite())
        .collect();
    let by_yaw = measured.len() < 2;
    let (values, floor, what) = if !by_yaw {
        (
            measured,
            MIN_SLIP_TRACK_DIFFERENCE,
            format!("the pose track's slip track relative to the terrain's {terrain_m:.3} m"),
        )
    } else {
        (
            excess_slips(ev.rows, ev.baseline, |_| true),
            MIN_SLIP_EXCESS,
            format!(
                "the turns' slip beyond the calibration's terrain slip {:.1} %",
                100.0 * ev.baseline.turn_slip
            ),
        )
    };
    let Some((mean, _, n)) = moments(&values) else {
        if !ev.yaw_logged() {
            return Signature::masked(e, "no yaw logged and no pose track");
        }
        return Signature::unobservable(e, "no turn timed by yaw and no pose track");
    };
    // By yaw, a slip rising from the point turn towards R′ is angular slip's mark: not the
    // same fraction on every turn. (A pose track measures the slip track itself.)
    let rises = by_yaw && slip_rises;
    // A slip track rescales every turn's yaw rate by the same B_s,ctrl/B_s (Eq 2.2): by yaw, a
    // slip that differs between the radii (anything that resists the turn more at some radii,
    // such as sand piling up at the point turn) is not it. The same spread the baseline allows
    // a constant calibration slip.
    let spread = if by_yaw { regime_spread(ev, mean) } else { 0.0 };
    let uneven = spread > MAX_SLIP_SPREAD;
    let flipped: Vec<f64> = values.iter().map(|v| v * mean.signum()).collect();
    let Some((t, df, p)) = one_sample_upper(&flipped, 0.0) else {
        return Signature::unobservable(e, "a single turn timed by yaw");
    };
    let p = (2.0 * p).min(1.0);
    let test = SignatureTest {
        statistic_name: "t",
        statistic: t,
        df,
        p,
        present: p < ALPHA && mean.abs() >= floor && !rises && !uneven,
        sized: mean.abs() >= floor && !rises && !uneven,
    };
    let shape = if rises {
        "; but it rises from the point turn towards R′ (angular slip), not the same on every turn"
            .to_string()
    } else if uneven {
        format!(
            "; but a radius' mean differs from it by {:.1} %, not the same on every turn",
            100.0 * spread
        )
    } else {
        String::new()
    };
    Signature::tested(
        e,
        test,
        format!("{what}: {:+.1} % over {n} turn(s){shape}", 100.0 * mean),
    )
}

/// Largest distance of a radius' mean excess slip (regimes with 2 or more yaw-timed turns) from
/// `mean`, the turns' common mean.
fn regime_spread(ev: &Evidence<'_>, mean: f64) -> f64 {
    let mut regimes: Vec<Regime> = ev.rows.iter().map(|r| r.regime).collect();
    regimes.sort_by_key(|r| r.id());
    regimes.dedup();
    regimes
        .into_iter()
        .filter_map(|regime| {
            let at = excess_slips(ev.rows, ev.baseline, |r| r.regime == regime);
            let (at_mean, _, n) = moments(&at)?;
            (n >= 2).then(|| (at_mean - mean).abs())
        })
        .fold(0.0, f64::max)
}

/// `slope`: more manoeuvres off level than sensor noise explains (binomial tail against
/// [`OFF_LEVEL_BY_CHANCE`]), and at least two.
fn slope(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::Slope;
    let pitched: Vec<f64> = ev.rows.iter().filter_map(|r| r.pitch_deg).collect();
    if pitched.is_empty() {
        return Signature::masked(e, "no pitch logged");
    }
    let n = pitched.len();
    let k = pitched
        .iter()
        .filter(|p| p.abs() > super::adequacy::LEVEL_PITCH_DEG)
        .count();
    let p = binomial_upper_tail(k, n, OFF_LEVEL_BY_CHANCE);
    let test = SignatureTest {
        statistic_name: "binomial",
        statistic: k as f64,
        df: n as f64,
        p,
        present: p < ALPHA && k >= 2,
        sized: k >= 2,
    };
    Signature::tested(
        e,
        test,
        format!(
            "{k} of {n} manoeuvres have a mean pitch beyond ±{}°",
            super::adequacy::LEVEL_PITCH_DEG
        ),
    )
}

/// P(X ≥ k) for X ~ Binomial(n, p).
fn binomial_upper_tail(k: usize, n: usize, p: f64) -> f64 {
    if k == 0 {
        return 1.0;
    }
    // Sum the lower part in log space and take its complement from the pmf directly.
    let ln_pmf = |i: usize| ln_choose(n, i) + i as f64 * p.ln() + (n - i) as f64 * (1.0 - p).ln();
    (k..=n).map(|i| ln_pmf(i).exp()).sum::<f64>().min(1.0)
}

fn ln_choose(n: usize, k: usize) -> f64 {
    (1..=k)
        .map(|i| ((n - k + i) as f64).ln() - (i as f64).ln())
        .sum()
}

/// Whether some run drives the same commanded radius twice, at run times at least
/// [`MIN_TREND_SPREAD_S`](super::gaps::MIN_TREND_SPREAD_S) apart.
fn repeats_within_a_run(rows: &[TurnRow]) -> bool {
    rows.iter().enumerate().any(|(i, a)| {
        rows[i + 1..].iter().any(|b| {
            a.run_index == b.run_index
                && cv::radius_group(a) == cv::radius_group(b)
                && (a.t_start_s - b.t_start_s).abs() >= super::gaps::MIN_TREND_SPREAD_S
        })
    })
}

/// `motor-heating`: the same manoeuvre drawing more later in a run: some run repeats a
/// manoeuvre, and the "where" analysis' run-time trend is significant and rising. Without a
/// repeat within a run, a trend over the runs' shuffled orders compares different runs, whose
/// own variation a winding's slow rise cannot be told from.
fn motor_heating(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::MotorHeating;
    if !repeats_within_a_run(ev.rows) {
        return Signature::unobservable(
            e,
            "no run drives a manoeuvre twice (repeat manoeuvres within longer runs to see it)",
        );
    }
    let Some(trend) = ev.where_.run_time.trend.as_ref() else {
        return Signature::unobservable(
            e,
            ev.where_.run_time.note.clone().unwrap_or_else(|| {
                "run time is not identifiable apart from the turn order".to_owned()
            }),
        );
    };
    // The residuals' trend over run time mixes manoeuvres (a run that ends on a cheaper one
    // trends too): the mark is the same manoeuvre itself drawing more when driven again later
    // in the run, measured without the power model.
    let rises = repeat_rises(ev.rows);
    let rise = one_sample_upper(&rises, 0.0);
    let rise_moments = moments(&rises);
    let test = SignatureTest {
        statistic_name: "permutation",
        statistic: trend.slope_w_per_min,
        df: trend.n as f64,
        p: trend.p_value,
        present: trend.significant
            && trend.change_w > 0.0
            && rise.is_some_and(|(_, _, p)| p < ALPHA),
        sized: trend.change_w > trend.floor_w
            && rise_moments.is_some_and(|(mean, _, _)| mean > 0.0),
    };
    let repeats = match (rise, rise_moments) {
        (Some((t, df, p)), Some((mean, _, n))) => format!(
            "; driven again later in the same run, a manoeuvre draws {mean:+.1} W ({n} repeat(s), \
             t = {t:.2}, df {df:.0}, p = {})",
            format_p(p)
        ),
        _ => format!(
            "; {} repeat(s) of a manoeuvre later in its run: too few to tell whether it draws more",
            rises.len()
        ),
    };
    Signature::tested(
        e,
        test,
        format!(
            "the same manoeuvres draw {:+.1} W/min more later in a run ({:+.1} W over a {:.1} min \
             run; floor {:.1} W){repeats}",
            trend.slope_w_per_min, trend.change_w, trend.run_length_min, trend.floor_w
        ),
    )
}

/// Each manoeuvre driven again later in its run (the same radius, v_c and direction, at least
/// [`MIN_TREND_SPREAD_S`](super::gaps::MIN_TREND_SPREAD_S) after its first drive there): how
/// much more both sides' measured average power is than at that first drive [W].
fn repeat_rises(rows: &[TurnRow]) -> Vec<f64> {
    let total = |r: &TurnRow| r.sides[0].avg_power_w + r.sides[1].avg_power_w;
    let same = |a: &TurnRow, b: &TurnRow| {
        a.run_index == b.run_index
            && cv::radius_group(a) == cv::radius_group(b)
            && (a.v_c_mps - b.v_c_mps).abs() < 0.005
            && a.direction == b.direction
    };
    let measured: Vec<&TurnRow> = rows.iter().filter(|r| total(r).is_finite()).collect();
    measured
        .iter()
        .filter_map(|later| {
            // The first drive of the same manoeuvre (`later` itself when it is the first).
            let first = measured
                .iter()
                .filter(|r| same(r, later))
                .min_by(|a, b| a.t_start_s.total_cmp(&b.t_start_s))?;
            (later.t_start_s - first.t_start_s >= super::gaps::MIN_TREND_SPREAD_S)
                .then(|| total(later) - total(first))
        })
        .collect()
}

/// The growth through the turn of both sides of `row`, when both have it.
fn both_growths(row: &TurnRow) -> Option<[f64; 2]> {
    Some([row.sides[0].growth_w?, row.sides[1].growth_w?])
}

/// `sinkage-bulldozing`: the wheels sink after each start, so power rises through the
/// manoeuvre on **each** side by at least [`PRACTICAL_FLOOR_W`], read two ways: the turns below
/// R′ beyond the straights and wide turns (runs and calibration; slip sinks them deeper), by
/// Welch t per side; or, where the sand yields on the straights as much (a heavy rover), the
/// turns below R′ and the straights beyond no growth at all, by one-sample t per side, unless
/// `rising_otherwise` raises a manoeuvre's power through it as well: a warmer winding (motor
/// heating's mark not yet looked for and missing; it does not start over at the next manoeuvre
/// as sinkage does: heating's drives tell them apart, so such a rise in size leaves the mark
/// inconclusive, not missing) or a grade changing under the rover (the slope's mark). The weaker
/// side's test, its p doubled, of the stronger reading, its p doubled again. A drag of the
/// inner side alone (which also grows) does not pass on the outer side; an acceleration
/// transient makes power fall through the manoeuvre, not rise.
fn sinkage(ev: &Evidence<'_>, rising_otherwise: Option<EffectId>) -> Signature {
    let e = EffectId::SinkageBulldozing;
    let tight: Vec<[f64; 2]> = ev
        .rows
        .iter()
        .filter(|r| !r.is_straight() && r.r_over_r_prime < 1.0)
        .filter_map(both_growths)
        .collect();
    if tight.len() < 2 {
        return Signature::unobservable(e, "fewer than 2 turns below R′ with their growth");
    }
    let rows = || ev.rows.iter().chain(ev.calibration_rows);
    let mut wide: Vec<f64> = rows()
        .filter(|r| r.is_straight() || r.r_over_r_prime > 1.0)
        .filter_map(both_growths)
        .map(|g| 0.5 * (g[0] + g[1]))
        .collect();
    if wide.len() < 2 {
        // Nothing to compare with: against no growth at all.
        wide = vec![0.0, 0.0];
    }
    let driven: Vec<[f64; 2]> = tight
        .iter()
        .copied()
        .chain(rows().filter(|r| r.is_straight()).filter_map(both_growths))
        .collect();
    // Per side: (growth beyond the reference, t, df, p).
    let beyond_wide = |s: usize| -> Option<(f64, f64, f64, f64)> {
        let growth: Vec<f64> = tight.iter().map(|g| g[s]).collect();
        welch_upper(&growth, &wide)
    };
    let beyond_none = |s: usize| -> Option<(f64, f64, f64, f64)> {
        let growth: Vec<f64> = driven.iter().map(|g| g[s]).collect();
        let (t, df, p) = one_sample_upper(&growth, 0.0)?;
        Some((growth.iter().sum::<f64>() / growth.len() as f64, t, df, p))
    };
    let weaker = |inner: (f64, f64, f64, f64), outer: (f64, f64, f64, f64)| {
        let w = if inner.3 >= outer.3 { inner } else { outer };
        (inner.0.min(outer.0), w.1, w.2, (2.0 * w.3).min(1.0))
    };
    let (Some(inner), Some(outer)) = (beyond_wide(0), beyond_wide(1)) else {
        return Signature::unobservable(e, "growth without spread");
    };
    let turns = weaker(inner, outer);
    let sized = |r: &(f64, f64, f64, f64)| r.0 >= PRACTICAL_FLOOR_W;
    let all_grow = match (beyond_none(0), beyond_none(1)) {
        (Some(i), Some(o)) => Some((weaker(i, o), i.0, o.0)),
        _ => None,
    };
    let everywhere = all_grow.filter(|_| rising_otherwise.is_none());
    // A rise through every manoeuvre that the other effect's drives can still tell apart.
    let told_apart_by = rising_otherwise
        .filter(|&other| other == EffectId::MotorHeating)
        .filter(|_| all_grow.is_some_and(|(all, _, _)| sized(&all)));
    let turns_detail = format!(
        "turns below R′ grow {:+.1} W on the inner side and {:+.1} W on the outer side \
         through the turn beyond {} straight(s) and wide turn(s)",
        inner.0,
        outer.0,
        wide.len()
    );
    // The stronger reading: the one reaching the floor, else the smaller p.
    let (chosen, name, detail) = match everywhere {
        Some((all, i, o)) if sized(&all) && (!sized(&turns) || all.3 < turns.3) => (
            all,
            "t",
            format!(
                "{} tight turns and straights grow {i:+.1} W on the inner (left) side and \
                 {o:+.1} W on the outer (right) side through the manoeuvre ({turns_detail})",
                driven.len()
            ),
        ),
        _ => match all_grow {
            Some((all, i, o)) if rising_otherwise.is_some() && sized(&all) => (
                turns,
                "Welch t",
                format!(
                    "{turns_detail}; the tight turns and straights grow {i:+.1} W and {o:+.1} W \
                     through the manoeuvre, {}",
                    if told_apart_by.is_some() {
                        "as a warming winding would too (drive a manoeuvre again and again in \
                         one run to tell)"
                    } else {
                        "as the slope's changing grade does too"
                    }
                ),
            ),
            _ => (turns, "Welch t", turns_detail),
        },
    };
    let readings = if everywhere.is_some() { 2.0 } else { 1.0 };
    let test = SignatureTest {
        statistic_name: name,
        statistic: chosen.1,
        df: chosen.2,
        p: (readings * chosen.3).min(1.0),
        present: readings * chosen.3 < ALPHA && sized(&chosen),
        sized: sized(&chosen) || told_apart_by.is_some(),
    };
    Signature {
        told_apart_by,
        ..Signature::tested(e, test, detail)
    }
}

/// The residual of the `role` side of each of `rows` matching `keep` [W].
fn side_residuals(ev: &Evidence<'_>, role: SideRole, keep: impl Fn(&TurnRow) -> bool) -> Vec<f64> {
    ev.rows
        .iter()
        .filter(|r| !r.is_straight() && !r.is_total_only() && keep(r))
        .flat_map(|r| {
            let res = ev.baseline.residual_w(r);
            (0..2)
                .filter(move |&s| r.sides[s].role == role)
                .map(move |s| res[s])
        })
        .filter(|v| v.is_finite())
        .collect()
}

/// A step test of the `role` side's residual: the rows matching `at` against each group of
/// `around` that has rows (the neighbours below and above), by Welch t, at least
/// [`PRACTICAL_FLOOR_W`] above each. An effect confined to some radii is a plateau with an
/// edge on both sides; a misfit smooth in the radius (copper loss, the split) rises towards
/// it from a neighbour. The statistic is the weakest edge's, its p doubled.
fn step_test(
    ev: &Evidence<'_>,
    effect: EffectId,
    role: SideRole,
    at: impl Fn(&TurnRow) -> bool,
    around: [&dyn Fn(&TurnRow) -> bool; 2],
    what: &str,
) -> Signature {
    let here = side_residuals(ev, role, &at);
    let edges: Vec<(f64, f64, f64, f64, usize)> = around
        .iter()
        .map(|keep| side_residuals(ev, role, keep))
        .filter(|there| !there.is_empty())
        .filter_map(|there| {
            welch_upper(&here, &there).map(|(d, t, df, p)| (d, t, df, p, there.len()))
        })
        .collect();
    let Some(&(diff, t, df, p, n)) = edges.iter().max_by(|a, b| a.3.total_cmp(&b.3)) else {
        return Signature::unobservable(
            effect,
            format!(
                "fewer than 2 turns {what} or beside it with the {} side",
                role.id()
            ),
        );
    };
    let p = (p * edges.len() as f64).min(1.0);
    let smallest_step = edges.iter().map(|e| e.0).fold(f64::INFINITY, f64::min);
    // A step is this effect's own only where the model's residual does not step as far between
    // radii where no such effect acts: there the step is the baseline's structure.
    let elsewhere = largest_step_elsewhere(ev, role, &at);
    Signature::tested(
        effect,
        SignatureTest {
            statistic_name: "Welch t",
            statistic: t,
            df,
            p,
            present: p < ALPHA && smallest_step >= PRACTICAL_FLOOR_W.max(elsewhere),
            sized: smallest_step >= PRACTICAL_FLOOR_W.max(elsewhere),
        },
        format!(
            "the {} side {what} draws {diff:+.1} W beyond the model more than at its weaker edge \
             ({} against {n} turns; {} edge(s) tested); the largest step between neighbouring \
             radii elsewhere on that side is {elsewhere:.1} W",
            role.id(),
            here.len(),
            edges.len()
        ),
    )
}

/// The largest |difference| of the `role` side's mean residual between neighbouring radii of
/// the turns, over the pairs where neither radius matches `at` [W] (0 without such a pair).
fn largest_step_elsewhere(
    ev: &Evidence<'_>,
    role: SideRole,
    at: &impl Fn(&TurnRow) -> bool,
) -> f64 {
    let mut groups: Vec<i64> = ev
        .rows
        .iter()
        .filter(|r| !r.is_straight() && !r.is_total_only())
        .map(cv::radius_group)
        .collect();
    groups.sort_unstable();
    groups.dedup();
    let means: Vec<(bool, f64)> = groups
        .into_iter()
        .filter_map(|g| {
            let in_group = |r: &TurnRow| cv::radius_group(r) == g;
            let values = side_residuals(ev, role, in_group);
            let (mean, _, _) = moments(&values)?;
            let is_at = ev.rows.iter().any(|r| in_group(r) && at(r));
            Some((is_at, mean))
        })
        .collect();
    means
        .windows(2)
        .filter(|w| !w[0].0 && !w[1].0)
        .map(|w| (w[1].1 - w[0].1).abs())
        .fold(0.0, f64::max)
}

/// `inner-drag`: the inner side in the dragged-inner regime against the inner side of each
/// regime beside it (below B/2, at R′).
fn inner_drag(ev: &Evidence<'_>) -> Signature {
    step_test(
        ev,
        EffectId::InnerDrag,
        SideRole::Inner,
        |r| r.regime == Regime::DraggedInner,
        [
            &|r: &TurnRow| r.regime == Regime::BelowHalfTrack,
            &|r: &TurnRow| r.regime == Regime::AtRPrime,
        ],
        "between B/2 and R′",
    )
}

/// `braked-inner`: the outer side at R′ against the outer side at the next commanded radius
/// below and at the next above.
fn braked_inner(ev: &Evidence<'_>) -> Signature {
    let turns = || ev.rows.iter().filter(|r| !r.is_straight());
    let Some(at) = turns()
        .find(|r| r.regime == Regime::AtRPrime)
        .map(cv::radius_group)
    else {
        return Signature::unobservable(EffectId::BrakedInner, "no turn at R′");
    };
    let below = turns().map(cv::radius_group).filter(|&k| k < at).max();
    let above = turns().map(cv::radius_group).filter(|&k| k > at).min();
    step_test(
        ev,
        EffectId::BrakedInner,
        SideRole::Outer,
        |r| cv::radius_group(r) == at,
        [
            &|r: &TurnRow| Some(cv::radius_group(r)) == below,
            &|r: &TurnRow| Some(cv::radius_group(r)) == above,
        ],
        "at R′",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

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
