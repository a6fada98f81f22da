//! `validate` on a one-hour run with a pose track: `cargo bench -p host-tool --bench
//! validate_poses`. The target: under 1 s.
//!
//! The run is an hour of the simulated Husky on sand (the seed's turn set at 0.3 m/s, repeated)
//! sampled at 200 Hz, with the world's total station (a 5 Hz prism 0.21 m right of the centre,
//! 2 mm noise, 5 % lost fixes) on the samples as a recorder places them. Timed, best of 5:
//! `validate` of those samples with the positions (R_ACT per turn, measured slip track) and of
//! the same samples without them (the run as before this feature). Under `cargo test --benches`
//! (no `--bench` argument) the run is two simulated minutes and each path runs once.

use host_tool::diagnose_bench::sample_run;
use host_tool::log::run_csv::RunSample;
use host_tool::sim::world::{Scenario, WorldConfig};
use host_tool::validate::pose::without_positions;
use host_tool::validate::{validate, RunInput, ValidateOptions, ValidationReport};
use std::time::{Duration, Instant};

/// The bound on `validate` of an hour with poses [s].
const GOAL_S: f64 = 1.0;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let test_mode = args.iter().any(|a| a == "--test") || !args.iter().any(|a| a == "--bench");
    let (seconds, repeats): (f64, usize) = if test_mode { (120.0, 1) } else { (3_600.0, 5) };
    let world = WorldConfig::sand();
    let t0 = Instant::now();
    // Enough passes of the turn set (with its pauses) for `seconds`.
    let duration = |repeats: u32| {
        world
            .simulate(&Scenario::seed_turns(0.3, repeats), 4)
            .expect("the seed turn set simulates")
            .duration_s()
    };
    let (one, two) = (duration(1), duration(2));
    let repeats_of_set = ((seconds - one) / (two - one)).ceil().max(0.0) as u32 + 1;
    let timeline = world
        .simulate(&Scenario::seed_turns(0.3, repeats_of_set), 4)
        .expect("the seed turn set simulates");
    let with: Vec<RunSample> = sample_run(&timeline, 200);
    let without: Vec<RunSample> = without_positions(&with);
    let fixes = with.iter().filter(|s| s.position_m().is_some()).count();
    println!(
        "run: {:.0} s simulated, {} samples, {fixes} position fixes (generated in {:.1} s)",
        timeline.duration_s(),
        with.len(),
        t0.elapsed().as_secs_f64()
    );
    let options = ValidateOptions {
        tracker_offset_m: world.tracker.offset_m,
        ..ValidateOptions::for_rover(&world.rover)
    };
    let time = |samples: &[RunSample]| -> (Duration, ValidationReport) {
        let mut best: Option<(Duration, ValidationReport)> = None;
        for _ in 0..repeats {
            let t = Instant::now();
            let report = validate(
                &world.rover,
                &[RunInput::from_samples("hour", samples)],
                &options,
            )
            .expect("validates");
            let elapsed = t.elapsed();
            if best.as_ref().is_none_or(|(b, _)| elapsed < *b) {
                best = Some((elapsed, report));
            }
        }
        best.expect("at least one repeat")
    };
    let (t_with, report) = time(&with);
    let (t_without, _) = time(&without);
    let turns = report
        .manoeuvres
        .iter()
        .filter(|m| m.track.is_some())
        .count();
    let measured = report
        .manoeuvres
        .iter()
        .filter(|m| m.r_act_m.is_some())
        .count();
    println!(
        "validate with poses:    {:.3} s ({turns} turns tracked, {measured} with R_ACT; measured slip track {:?} m)",
        t_with.as_secs_f64(),
        report.runs[0].slip_track_measured_m
    );
    println!("validate without poses: {:.3} s", t_without.as_secs_f64());
    let ok = t_with.as_secs_f64() < GOAL_S;
    println!(
        "goal: an hour with poses under {GOAL_S} s: {}",
        if ok { "met" } else { "NOT met" }
    );
    if !test_mode && !ok {
        std::process::exit(1);
    }
}
