//! The standard figures of a validation (`plot`, `demo`): power vs time through each turn (seed
//! Fig 4.8), average and maximum power vs R/R′ with the fitted and hard-ground model curves
//! (Fig 4.9), τ ∝ P/ω of the inner and outer side vs R/R′ (Fig 5.6, Eq 5.14), and the residuals
//! against both models. Data comes from a [`ValidationReport`] and the runs it was made from.

use crate::log::run_csv::RunSample;
use crate::plot::{
    render_figure, Chart, Figure, Format, Legend, Marker, PlotError, Series, SeriesStyle, Shape,
};
use crate::validate::report::PlotPoint;
use crate::validate::turns::sample_power_w;
use crate::validate::{ManoeuvreKind, ValidationReport};
use model_core::kinematics::TurnDirection;
use std::path::{Path, PathBuf};

/// One run's samples, by the name the report knows it under.
#[derive(Debug, Clone, Copy)]
pub struct RunSamples<'a> {
    /// The run's name in the report ([`crate::validate::RunInput::name`]).
    pub name: &'a str,
    /// Its samples.
    pub samples: &'a [RunSample],
}

/// Which power a power-vs-time chart draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PowerTrace {
    /// Left + right.
    Total,
    /// One side.
    Side(TurnSide),
}

/// A side of the rover, for per-side traces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TurnSide {
    /// The left drivers.
    Left,
    /// The right drivers.
    Right,
}

/// Total power against time since the start of each turn of one run, one series per turn
/// (seed Fig 4.8: on sand, power rises through turns with R ≤ R′).
pub fn power_vs_time(report: &ValidationReport, run: RunSamples<'_>) -> Chart {
    power_trace_chart(report, run, PowerTrace::Total)
}

/// Power of `trace` against time since the start of each turn of one run. Each trace starts
/// where the drives have come up from standstill (the first sample at half the turn's median
/// power or more): the step from 0 W at the command change is the drives' response, not the
/// turn, and would draw a vertical line at every trace's start.
pub fn power_trace_chart(
    report: &ValidationReport,
    run: RunSamples<'_>,
    trace: PowerTrace,
) -> Chart {
    let (what, y_label) = match trace {
        PowerTrace::Total => ("Power", "left + right power [W]"),
        PowerTrace::Side(TurnSide::Left) => ("Left power", "left power [W]"),
        PowerTrace::Side(TurnSide::Right) => ("Right power", "right power [W]"),
    };
    let mut chart = Chart::new(
        format!("{what} through each turn ({})", short_name(run.name)),
        "time since the turn started [s]",
        y_label,
    );
    let turns = report
        .manoeuvres
        .iter()
        .filter(|m| m.run == run.name && m.kind == ManoeuvreKind::Turn);
    for (i, turn) in turns.enumerate() {
        let Some(samples) = run.samples.get(turn.first_sample..turn.end_sample) else {
            continue;
        };
        let power = |s: &RunSample| {
            let p = sample_power_w(s);
            match trace {
                PowerTrace::Total => p.left + p.right,
                PowerTrace::Side(TurnSide::Left) => p.left,
                PowerTrace::Side(TurnSide::Right) => p.right,
            }
        };
        let mut sorted: Vec<f64> = samples
            .iter()
            .map(power)
            .filter(|p| p.is_finite())
            .collect();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let start = samples
            .iter()
            .position(|s| power(s).abs() >= 0.5 * median.abs())
            .unwrap_or(0);
        let points = samples[start..]
            .iter()
            .map(|s| (s.t_s - turn.t_start_s, power(s)))
            .collect();
        let label = match turn.r_over_r_prime {
            Some(k) => format!("R = {k:.2} R′"),
            None => format!("turn {}", i + 1),
        };
        chart
            .series
            .push(Series::new(label, points, SeriesStyle::Line, i));
    }
    chart
}

/// Steady average and maximum total power of every turn against R/R′, with the fitted Eq 2.12
/// (and its 95 % prediction band) and the hard-ground model (paper Eq 21) as curves.
pub fn power_vs_radius(report: &ValidationReport) -> Chart {
    let plot = &report.plot;
    let mut chart = Chart::new(
        format!("Turn power vs radius (v_c = {:.2} m/s)", plot.v_c_mps),
        "R / R′",
        "power [W]",
    );
    let curve = |f: &dyn Fn(&crate::validate::report::CurvePoint) -> Option<f64>| {
        plot.model_curve
            .iter()
            .filter_map(|c| f(c).map(|y| (c.r_over_r_prime, y)))
            .collect::<Vec<_>>()
    };
    // One colour per run for the averages, so runs can be told apart.
    let mut runs: Vec<&str> = Vec::new();
    for p in &plot.points {
        if let Some(m) = report.manoeuvres.get(p.manoeuvre) {
            if !runs.contains(&m.run.as_str()) {
                runs.push(&m.run);
            }
        }
    }
    // Runs side by side at each radius (repeats sit on top of each other otherwise), each its
    // colour and shape; the maxima as rings beside their run's average.
    const RUN_COLOURS: [usize; 4] = [0, 4, 5, 3];
    const RUN_SHAPES: [Shape; 3] = [Shape::Dot, Shape::Square, Shape::Triangle];
    let (lo, hi) = data_x_range(report).unwrap_or((0.0, 1.0));
    let dodge = |k: usize| (k as f64 - (runs.len() as f64 - 1.0) / 2.0) * 0.012 * (hi - lo);
    let run_of = |p: &&PlotPoint| {
        report
            .manoeuvres
            .get(p.manoeuvre)
            .and_then(|m| runs.iter().position(|r| *r == m.run))
    };
    let max = plot
        .points
        .iter()
        .map(|p| {
            let dx = run_of(&p).map_or(0.0, dodge);
            (p.r_over_r_prime + dx, p.max_power_w)
        })
        .collect();
    for (k, run) in runs.iter().enumerate() {
        let avg = plot
            .points
            .iter()
            .filter(|p| run_of(p) == Some(k))
            .map(|p| (p.r_over_r_prime + dodge(k), p.avg_power_w.total))
            .collect();
        let name = if runs.len() == 1 {
            "measured average".to_owned()
        } else {
            format!("average, {}", short_name(run))
        };
        chart.series.push(
            Series::new(
                name,
                avg,
                SeriesStyle::Points,
                RUN_COLOURS[k % RUN_COLOURS.len()],
            )
            .with_shape(RUN_SHAPES[k % RUN_SHAPES.len()]),
        );
    }
    chart
        .series
        .push(Series::new("measured maximum", max, SeriesStyle::Points, 6).with_shape(Shape::Ring));
    chart.series.push(Series::new(
        "fitted Eq 2.12",
        curve(&|c| c.fit_w),
        SeriesStyle::Line,
        2,
    ));
    let band = |sign: f64| curve(&|c| Some(c.fit_w? + sign * c.fit_half_width_w?));
    chart.series.push(Series::new(
        "95 % prediction",
        band(1.0),
        SeriesStyle::Line,
        7,
    ));
    chart
        .series
        .push(Series::new("", band(-1.0), SeriesStyle::Line, 7));
    chart.series.push(Series::new(
        "hard-ground model",
        curve(&|c| c.hard_ground_w),
        SeriesStyle::Line,
        3,
    ));
    add_regime_markers(&mut chart, report);
    chart.x_range = data_x_range(report);
    chart
}

/// The x range of the measured turns (R/R′), with R′ in it and 5 % padding; `None` without
/// turns. Model curves beyond the widest turn are not drawn.
fn data_x_range(report: &ValidationReport) -> Option<(f64, f64)> {
    let xs = report.plot.points.iter().map(|p| p.r_over_r_prime);
    let hi = xs.clone().fold(f64::NAN, f64::max).max(1.0);
    let lo = xs.fold(f64::NAN, f64::min).min(0.0);
    let pad = 0.05 * (hi - lo);
    (hi.is_finite() && hi > lo).then_some((lo - pad, hi + pad))
}

/// τ ∝ P/ω (Eq 5.14) of the inner and the outer side of every turn against R/R′ (seed Fig 5.6:
/// on sand the inner wheels need ~70 % more torque at 2R′/3 than at R′/3).
pub fn torque_per_side(report: &ValidationReport) -> Chart {
    let mut chart = Chart::new(
        "Torque-proportional P/ω per side",
        "R / R′",
        "τ ∝ P/ω [W·s/rad]",
    );
    let mut inner = Vec::new();
    let mut outer = Vec::new();
    let mut undefined = [0usize; 2];
    for p in &report.plot.points {
        let Some(row) = report.manoeuvres.get(p.manoeuvre) else {
            continue;
        };
        let (i, o) = match row.direction {
            Some(TurnDirection::Left) => (p.torque_proportional.left, p.torque_proportional.right),
            Some(TurnDirection::Right) => (p.torque_proportional.right, p.torque_proportional.left),
            None => continue,
        };
        inner.extend(i.map(|t| (p.r_over_r_prime, t)));
        outer.extend(o.map(|t| (p.r_over_r_prime, t)));
        undefined[0] += usize::from(i.is_none());
        undefined[1] += usize::from(o.is_none());
    }
    // τ ∝ P/ω is undefined where ω ≈ 0 (the inner side at R′): say so rather than drop points
    // silently.
    let name = |side: &str, missing: usize| match missing {
        0 => format!("{side} side"),
        n => format!("{side} side ({n} undefined: ω ≈ 0, e.g. inner at R′)"),
    };
    chart.series.push(Series::new(
        name("inner", undefined[0]),
        inner,
        SeriesStyle::Points,
        0,
    ));
    chart.series.push(Series::new(
        name("outer", undefined[1]),
        outer,
        SeriesStyle::Points,
        1,
    ));
    add_regime_markers(&mut chart, report);
    chart
}

/// Measured − predicted average power of every turn against R/R′, in % of the prediction: one
/// panel per model (the fitted Eq 2.12, the hard-ground model), so each axis holds one
/// quantity.
pub fn residuals(report: &ValidationReport) -> Figure {
    let mut fit = Vec::new();
    let mut hard = Vec::new();
    for p in &report.plot.points {
        if let (Some(r), Some(pred)) = (p.residual_w, p.predicted_w) {
            if pred.abs() > f64::EPSILON {
                fit.push((p.r_over_r_prime, 100.0 * r / pred));
            }
        }
        if let Some(f) = report
            .manoeuvres
            .get(p.manoeuvre)
            .and_then(|m| m.hard_ground_residual_fraction)
        {
            hard.push((p.r_over_r_prime, 100.0 * f));
        }
    }
    let panel = |title: &str, y_label: &str, points: Vec<(f64, f64)>, colour: usize| {
        let mut chart = Chart::new(title, "R / R′", y_label);
        chart
            .series
            .push(Series::new("", points, SeriesStyle::Points, colour));
        add_regime_markers(&mut chart, report);
        chart.x_range = data_x_range(report);
        chart.legend = Legend::Hidden;
        chart
    };
    Figure::new(
        "Where measured power departs from the models",
        vec![
            panel("vs the fitted Eq 2.12", "measured − fit [% of fit]", fit, 2),
            panel(
                "vs the hard-ground model (paper Eq 21)",
                "measured − hard ground [% of hard ground]",
                hard,
                3,
            ),
        ],
        2,
    )
}

/// Writes the figures of `report` into `dir` as `NAME.png` and `NAME.svg` for each format in
/// `formats`: power vs time once per run in `runs` (`power-vs-time` for a single run,
/// `power-vs-time-STEM` for each of several, STEM the run file's stem), then power vs radius,
/// torque per side and residuals over all runs. Returns the files written.
pub fn write_figures(
    report: &ValidationReport,
    runs: &[RunSamples<'_>],
    dir: &Path,
    formats: &[Format],
) -> Result<Vec<PathBuf>, PlotError> {
    write_figures_with(report, runs, dir, formats, false)
}

/// [`write_figures`], plus with `per_side` a figure per run of the left and the right power
/// through each turn (two panels, `power-vs-time-per-side[-STEM]`).
pub fn write_figures_with(
    report: &ValidationReport,
    runs: &[RunSamples<'_>],
    dir: &Path,
    formats: &[Format],
    per_side: bool,
) -> Result<Vec<PathBuf>, PlotError> {
    let names = power_vs_time_names(runs);
    let mut figures: Vec<(String, Figure)> = names
        .iter()
        .zip(runs)
        .map(|(name, run)| (name.clone(), Figure::single(power_vs_time(report, *run))))
        .collect();
    if per_side {
        for (name, run) in names.iter().zip(runs) {
            let panels = [TurnSide::Left, TurnSide::Right]
                .map(|side| power_trace_chart(report, *run, PowerTrace::Side(side)));
            figures.push((
                name.replacen("power-vs-time", "power-vs-time-per-side", 1),
                Figure::new("", panels.to_vec(), 2),
            ));
        }
    }
    figures.extend([
        (
            "power-vs-radius".to_owned(),
            Figure::single(power_vs_radius(report)),
        ),
        (
            "torque-per-side".to_owned(),
            Figure::single(torque_per_side(report)),
        ),
        ("residuals".to_owned(), residuals(report)),
    ]);
    let mut written = Vec::new();
    for (name, figure) in &figures {
        for format in formats {
            let path = dir.join(format!("{name}.{}", extension(*format)));
            render_figure(figure, &path)?;
            written.push(path);
        }
    }
    Ok(written)
}

/// The power-vs-time file name of each run: `power-vs-time` for one run; for several,
/// `power-vs-time-STEM` (characters other than letters, digits, `-` and `_` as `_`), with the
/// run's number appended where two stems are the same.
fn power_vs_time_names(runs: &[RunSamples<'_>]) -> Vec<String> {
    if runs.len() == 1 {
        return vec!["power-vs-time".to_owned()];
    }
    let stems: Vec<String> = runs
        .iter()
        .map(|run| {
            let stem = Path::new(run.name)
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or(run.name);
            stem.chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect()
        })
        .collect();
    stems
        .iter()
        .enumerate()
        .map(|(i, stem)| {
            if stems.iter().filter(|s| *s == stem).count() > 1 {
                format!("power-vs-time-{stem}-{}", i + 1)
            } else {
                format!("power-vs-time-{stem}")
            }
        })
        .collect()
}

fn extension(format: Format) -> &'static str {
    match format {
        Format::Png => "png",
        Format::Svg => "svg",
    }
}

/// Markers at R = B/2 and R = R′, where the regimes change.
fn add_regime_markers(chart: &mut Chart, report: &ValidationReport) {
    let r_prime = report.plot.r_prime_m;
    if r_prime > 0.0 {
        let half_track = f64::from(report.rover.track_width_m) / 2.0;
        chart.markers.push(Marker::new(half_track / r_prime, "B/2"));
    }
    chart.markers.push(Marker::new(1.0, "R′"));
}

/// The file name of a run path, for titles.
fn short_name(name: &str) -> &str {
    Path::new(name)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_run_gets_its_own_power_vs_time_file() {
        // Issue 11, bug 4: `plot --runs a b c` drew the first run only.
        let runs = ["x/run-1.mcap", "y/run-2.csv", "z/run-1.csv"]
            .map(|name| RunSamples { name, samples: &[] });
        assert_eq!(
            power_vs_time_names(&runs),
            [
                "power-vs-time-run-1-1",
                "power-vs-time-run-2",
                "power-vs-time-run-1-3"
            ]
        );
        assert_eq!(power_vs_time_names(&runs[..1]), ["power-vs-time"]);
        assert!(power_vs_time_names(&[]).is_empty());
    }
}
