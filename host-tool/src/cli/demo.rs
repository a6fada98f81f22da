//! `host-tool demo`: the whole pipeline on the simulated board.

use super::output;
use super::replay::positive_factor;
use anyhow::{bail, Result};
use firmware::sampler::SamplerConfig;
use host_tool::demo::{self, DemoOptions, DemoOutcome};
use host_tool::diagnose::report;
use host_tool::eprintln_best_effort;
use host_tool::out_dir::{is_missing_or_empty, write_dir_whole};
use host_tool::progress;
use host_tool::sim::world::{load_scenario, load_world};
use host_tool::wrap::folded;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Marks a directory the demo wrote: a later demo replaces it without `--force`.
const MARKER: &str = ".host-tool-demo";

/// `demo [--out DIR] [--world W.toml] [--scenario S.toml] [--runs N] [--seed N] [--speed K]`.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// Output directory (written whole or not at all; a previous demo's output is replaced,
    /// any other non-empty directory needs --force).
    #[arg(long, default_value = "demo-out")]
    out: PathBuf,
    /// Replace a non-empty output directory that a demo did not write.
    #[arg(long)]
    force: bool,
    /// World TOML (default: the built-in sand world, as in worlds/husky-sand.toml).
    #[arg(long)]
    world: Option<PathBuf>,
    /// Scenario TOML (default: the thesis' turn set once per run).
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Number of runs.
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// Noise seed of the first run (run k uses seed + k).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulated seconds per wall-clock second, at most (the simulated board waits for each of
    /// the recorder's commands, so a loaded machine or a huge factor slows the run down and
    /// leaves its data as it is) [default: 25; 1 with --serve, to watch it as it would happen].
    #[arg(long, value_parser = positive_factor)]
    speed: Option<f64>,
    // --serve: the runs are served live to Foxglove as they are recorded; the demo starts
    // when the first viewer subscribes.
    #[command(flatten)]
    serve: super::serve::ServeArgs,
    /// The simulated board's sample rate [Hz] (up to 2000), with the smoothest averaging it
    /// allows; default: the board's 200 Hz.
    #[arg(long = "rate-hz", value_parser = super::record::parse_rate_hz, value_name = "HZ")]
    rate_hz: Option<u32>,
    /// Also write each run's robot bag, `run-N-robot/` (ROS 2, MCAP storage): the commanded twist
    /// on /cmd_vel, the IMU on /imu/data, the tracker's pose on /tracker/pose, for `merge`.
    #[arg(long)]
    robot_bag: bool,
    /// With --robot-bag: the robot computer's clock runs this many seconds ahead of the board
    /// log's (`merge` measures it back).
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "S",
        requires = "robot_bag",
        allow_hyphen_values = true
    )]
    robot_clock_offset_s: f64,
}

impl DemoArgs {
    /// Runs the demo and prints its tables.
    pub fn run(self) -> Result<()> {
        let replace = self.force || self.out.join(MARKER).exists();
        if !replace && !is_missing_or_empty(&self.out) {
            bail!(
                "{}: the output directory exists and is not empty (pass --force to replace it, or --out DIR)",
                self.out.display()
            );
        }
        let mut options = DemoOptions::new(&self.out);
        if let Some(path) = &self.world {
            options.world = load_world(path)?;
        }
        if let Some(path) = &self.scenario {
            options.scenario = load_scenario(path)?;
        }
        options.runs = self.runs;
        if self.robot_bag {
            if !self.robot_clock_offset_s.is_finite() || self.robot_clock_offset_s.abs() > 3600.0 {
                bail!(
                    "--robot-clock-offset-s {} must be within ±3600",
                    self.robot_clock_offset_s
                );
            }
            options.robot_bag_clock_offset_s = Some(self.robot_clock_offset_s);
        }
        options.seed = self.seed;
        if let Some(period_us) = self.rate_hz {
            options.sampler = SamplerConfig::with_period(period_us).ok_or_else(|| {
                anyhow::anyhow!(
                    "--rate-hz: {:.1} Hz is above the board's {:.0} Hz (the I²C bus's limit) or below 1 Hz",
                    1e6 / f64::from(period_us.max(1)),
                    1e6 / f64::from(model_core::rate::MIN_SAMPLE_PERIOD_US)
                )
            })?;
        }
        let live = self.serve.start()?.map(Arc::new);
        options.speed = self
            .speed
            .unwrap_or(if live.is_some() { 1.0 } else { 25.0 });
        if let Some(server) = &live {
            eprintln_best_effort!("waiting for a viewer to subscribe (Ctrl-C to give up)");
            server.wait_for_subscriber(None, &AtomicBool::new(false));
            options.live = Some(server.clone());
        }
        let speed = options.speed;
        let started = std::time::Instant::now();
        let line = format!(
            "demo: a simulated rover (B = {} m, m = {} kg) {}: {} runs through a pty at {} Hz, \
             {}x real time",
            options.world.rover.track_width_m,
            options.world.rover.mass_kg,
            demo::describe_world(&options.world),
            self.runs,
            1e6 / f64::from(options.sampler.sample_period_us.max(1)),
            speed,
        );
        output::print(format_args!("{}\n", folded(&line)))?;
        let runs = self.runs;
        let outcome = write_dir_whole(&self.out, replace, |staging| {
            let mut staged = options.clone();
            staged.out_dir = staging.to_owned();
            let bar = progress::bar(1000, "recording");
            let mut outcome = demo::run(&staged, &mut |k, duration_s, status| {
                let done =
                    (f64::from(k) + (status.run_s / duration_s).clamp(0.0, 1.0)) / f64::from(runs);
                bar.set_position((1000.0 * done) as u64);
            })?;
            bar.finish_and_clear();
            std::fs::write(staging.join(MARKER), "written by host-tool demo\n").map_err(
                |source| demo::DemoError::Io {
                    what: "marking the output directory".into(),
                    source,
                },
            )?;
            outcome.files = output::rebased(std::mem::take(&mut outcome.files), staging, &self.out);
            Ok::<_, demo::DemoError>(outcome)
        });
        // The options' handle is gone with the runs: the server is ours again to stop.
        drop(options);
        super::serve::finish(
            live.and_then(Arc::into_inner),
            "rover-power: the demo has ended (every run was sent)",
        );
        let outcome = outcome?;
        output::print(printout(
            &outcome,
            &self.out,
            started.elapsed().as_secs_f64(),
        ))
    }
}

/// What the demo prints after its runs, the answer first in a screenful: per run the end-to-end
/// check, the validation and the diagnosis in a few lines each (their full tables are in
/// `report.txt` and `diagnosis/diagnosis.md`), the plans, where the files are.
fn printout(outcome: &DemoOutcome, out: &Path, elapsed_s: f64) -> String {
    let mut text = String::new();
    for run in &outcome.runs {
        let s = &run.summary;
        let j = |e: i64| s.scale.energy_j(e);
        let energy = s
            .segments
            .last()
            .map(|g| g.host_energy_lsb_us)
            .unwrap_or_default();
        // A run's first sample only starts the chips: it has no reading, and no row.
        let unread = match s.incomplete_samples {
            0 => String::new(),
            1 => " (and 1 without a reading: the first only starts the chips)".to_owned(),
            n => format!(" (and {n} without both chips' readings)"),
        };
        let line = format!(
            "{}: {} samples logged{unread}, {} lost, {} bad frames, {} of {} commands acked; \
             energy {:.1} J left / {:.1} J right, equal to the board's own total bit for bit",
            run.name,
            s.rows,
            s.stream.lost_samples,
            s.stream.bad_frames,
            s.commands_acked,
            s.commands_sent,
            j(energy[0]),
            j(energy[1]),
        );
        let _ = writeln!(text, "{}", folded(&line));
    }
    let report = &outcome.report;
    let line = format!("== validation (every table: {}/report.txt)", out.display());
    let _ = writeln!(text, "\n{}", folded(&line));
    let fit = report
        .fit
        .as_ref()
        .and_then(|f| f.r_squared)
        .map_or("not made".to_owned(), |r2| format!("r² = {r2:.3}"));
    // The regimes that depart, each once, in the order met.
    let mut departing: Vec<String> = Vec::new();
    for regime in report
        .flagged()
        .filter_map(|m| serde_json::to_value(m.regime).ok())
        .filter_map(|v| v.as_str().map(str::to_owned))
    {
        if !departing.contains(&regime) {
            departing.push(regime);
        }
    }
    let (frames, agree) = report
        .runs
        .iter()
        .filter_map(|r| r.cross_check.as_ref())
        .fold((0, true), |(n, all), c| {
            (n + c.model_frames, all && c.agrees())
        });
    let line = format!(
        "{} manoeuvres; ICR fit (Eq 2.12) {fit}; {} depart from it{}; the board's {frames} model \
         frames {} the host's recomputation",
        report.manoeuvres.len(),
        report.flagged().count(),
        if departing.is_empty() {
            String::new()
        } else {
            format!(" ({})", departing.join(", "))
        },
        if agree { "equal" } else { "DIFFER from" },
    );
    let _ = writeln!(text, "{}", folded(&format!("  {line}")));
    let line = format!(
        "== diagnosis (gaps, candidates, signatures: {}/diagnosis/diagnosis.md)",
        out.display()
    );
    let _ = writeln!(text, "\n{}", folded(&line));
    match &outcome.diagnosed {
        Ok(d) => diagnosed_printout(&mut text, d, out),
        Err(e) => {
            let line = format!(
                "not made: {e} (the runs alone cannot be diagnosed; a scenario of `diagnose \
                 --next-runs` adds to runs driven before: diagnose them together, e.g. \
                 `host-tool diagnose --rover rovers/husky-a200.toml --runs OLD.csv… {}/run-1.csv`)",
                out.display()
            );
            let _ = writeln!(text, "{}", folded(&line));
        }
    }
    let files = format!(
        "{} files in {} ({elapsed_s:.1} s): the runs (run-N.mcap, .csv, .commands.csv), \
         report.txt/.json, turns.csv, figures (.png, .svg), diagnosis/ (diagnosis.md, .json, \
         model.toml for `plan --model`, figures){}",
        outcome.files.len(),
        out.display(),
        if outcome
            .files
            .iter()
            .any(|f| f.to_string_lossy().ends_with("-robot"))
        {
            ", the robots' bags (run-N-robot/, for `merge`)"
        } else {
            ""
        },
    );
    let _ = writeln!(text, "\n{}", folded(&files));
    text
}

/// The diagnosis' conclusion, what to drive next, and the plans with the diagnosed model.
fn diagnosed_printout(text: &mut String, d: &demo::Diagnosed, out: &Path) {
    let _ = writeln!(text, "{}", report::conclusion(&d.diagnosis));
    for line in report::next_runs_lines(&d.diagnosis) {
        let _ = writeln!(text, "{}", folded(&format!("  next: {line}")));
    }
    let _ = writeln!(text);
    let (start_deg, end_deg, distance_m) = demo::PLAN_PATH;
    let line = format!(
        "== plan: {start_deg}° → {end_deg}° over {distance_m} m on this terrain (paper Eq 23–50; \
         model file {}/diagnosis/model.toml)",
        out.display()
    );
    let _ = writeln!(text, "{}", folded(&line));
    let effects = d.diagnosis.model_effects();
    let effects: Vec<&str> = effects.iter().map(|e| e.id()).collect();
    for (what, p) in [
        (
            "hard-ground model fitted to the runs".to_owned(),
            &d.plan_hard_ground,
        ),
        (
            format!("+ diagnosed {}", effects.join(" + ")),
            &d.plan_diagnosed,
        ),
    ] {
        let line = format!(
            "{what}: CLC R1 = {:.2} m ({:.2} R′), R2 = {:.2} m ({:.2} R′), {:.0} J vs PLP {:.0} J \
             ({:+.1} %)",
            p.clc.r1_m,
            p.clc.r1_m / p.setting.r_prime_m,
            p.clc.r2_m,
            p.clc.r2_m / p.setting.r_prime_m,
            p.clc.energy_j,
            p.plp.energy_j,
            -p.saving_pct
        );
        let _ = writeln!(text, "{}", folded(&format!("  {line}")));
    }
    // Issue 18: the diagnosed model's ΔE curve beside thesis Table 6.1 (45° – 10 m – 45°).
    let sweep = &d.sweep_diagnosed;
    let line = format!(
        "diagnosed model on thesis Table 6.1's path ({}° – {} m – {}°): least ΔE at {:.2} R′ \
         ({:+.1} %); slices of R/R′, model vs measured on sand:",
        sweep.setting.start_deg,
        sweep.setting.distance_m,
        sweep.setting.end_deg,
        sweep.optimum.r_over_r_prime,
        sweep.optimum.delta_e_pct
    );
    let _ = writeln!(text, "{}", folded(&format!("  {line}")));
    for sl in &sweep.slices {
        let seed = sl
            .thesis_delta_e_pct
            .map_or("-".to_owned(), |d| format!("{d:+.2} %"));
        let _ = writeln!(
            text,
            "    {:.1} – {:.1}: {:+6.2} % vs {seed}",
            sl.lo, sl.hi, sl.model_delta_e_pct
        );
    }
}
