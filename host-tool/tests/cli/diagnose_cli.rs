//! `host-tool diagnose` from the command line: simulated run CSVs in (the world's timeline
//! sampled at 200 Hz), table, JSON, report, figures and a plan model out; clear errors on bad
//! input.

use crate::common;
use common::{host_tool, rover_toml, temp_dir};

use host_tool::log::run_csv::{write_run_csv_atomically, RunSample};
use host_tool::plan::load_model;
use host_tool::sim::world::{EffectId, Manoeuvre, Scenario, WorldConfig};
use model_core::Sides;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Output;

/// The seed's turn set with 4R′ in place of 4R′/3, so the runs hold wide calibration turns.
fn scenario() -> Scenario {
    let mut s = Scenario::seed_turns(0.3, 1);
    if let Some(Manoeuvre::Turn {
        r_over_r_prime: Some(k),
        ..
    }) = s.manoeuvres.get_mut(4)
    {
        *k = 4.0;
    }
    s
}

/// One run of `world` sampled at 200 Hz, written as a run CSV.
fn write_run(world: &WorldConfig, seed: u64, path: &Path) {
    let timeline = world.simulate(&scenario(), seed).expect("scenario runs");
    let samples = host_tool::diagnose_bench::sample_run(&timeline, 200);
    write_run_csv_atomically(path, host_tool::log::Existing::Replace, &samples).expect("write run");
}

/// Three runs of hard ground with the inner wheels dragged (`inner-drag` at its default
/// strength).
fn inner_drag_runs(dir: &Path) -> Vec<PathBuf> {
    let world = WorldConfig::hard_ground().with_effect(EffectId::InnerDrag, true);
    (0..3)
        .map(|k| {
            let path = dir.join(format!("run-{k}.csv"));
            write_run(&world, 10 + k, &path);
            path
        })
        .collect()
}

fn os(s: &str) -> &OsStr {
    OsStr::new(s)
}

fn diagnose(args: &[&OsStr]) -> Output {
    host_tool()
        .arg("diagnose")
        .arg("--rover")
        .arg(rover_toml())
        .args(args)
        .output()
        .expect("runs")
}

fn ok(out: &Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

fn failed(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn diagnose_names_inner_drag_and_writes_json_report_figures_and_a_plan_model() {
    let dir = temp_dir("diagnose-cli-ok");
    let runs = inner_drag_runs(&dir);
    let (json, out_dir) = (dir.join("diagnosis.json"), dir.join("out"));
    let mut args: Vec<&OsStr> = vec![os("--runs")];
    args.extend(runs.iter().map(|p| p.as_os_str()));
    args.extend([os("--json"), json.as_os_str()]);
    args.extend([os("--out"), out_dir.as_os_str()]);
    let stdout = ok(&diagnose(&args));
    eprintln!("{stdout}");
    assert!(
        stdout.contains("diagnosis: inner-drag @ dragged-inner: adding it closes"),
        "{stdout}"
    );
    assert!(
        stdout.contains("taken from the runs themselves"),
        "{stdout}"
    );
    assert!(stdout.contains("<- named"), "{stdout}");

    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("json");
    assert_eq!(j["effect"], "inner-drag");
    assert_eq!(j["regime"], "dragged-inner");
    assert_eq!(j["significant"], true);
    assert_eq!(j["metric"]["unit"], "W");
    assert!(j["metric"]["what"].as_str().is_some());
    for key in ["scheme", "error_before", "error_after", "shrink_pct"] {
        assert!(!j["heldout"][key].is_null(), "heldout.{key}: {j}");
    }
    assert_eq!(j["heldout"]["scheme"], "leave-one-run-out");
    let candidates = j["candidates"].as_array().expect("candidates");
    // The catalogue less motor-heating (one pass per run: run time is the turn order) and
    // current-offset (the standstill current is the drivers' quiescent draw).
    assert_eq!(candidates.len(), 6);
    for c in candidates {
        for key in [
            "effect",
            "heldout_error_before",
            "heldout_error_after",
            "shrink_pct",
        ] {
            assert!(!c[key].is_null(), "{key}: {c}");
        }
    }
    assert_eq!(j["calibration"]["source"], "runs");
    assert!(j["calibration"]["manoeuvres"]
        .as_u64()
        .is_some_and(|n| n >= 9));

    let md = std::fs::read_to_string(out_dir.join("diagnosis.md")).expect("report");
    assert!(
        md.contains("![") && md.contains("residuals-vs-radius.png"),
        "{md}"
    );
    assert!(md.contains("growth-vs-radius.png"), "{md}");
    for name in ["residuals-vs-radius", "growth-vs-radius"] {
        let png = std::fs::read(out_dir.join(format!("{name}.png"))).expect("png");
        assert_eq!(&png[1..4], b"PNG");
        let svg = std::fs::read_to_string(out_dir.join(format!("{name}.svg"))).expect("svg");
        assert!(svg.contains("<svg"));
    }

    let model_path = out_dir.join("model.toml");
    let model = load_model(&model_path).expect("model.toml loads");
    assert_eq!(model.effects.len(), 1);
    assert_eq!(model.effects[0].name, "inner-drag");
    assert!((model.v_c_mps - 0.3).abs() < 0.01, "{model:?}");
    // The term acts between B/2 and R′ only.
    let term = &model.effects[0];
    assert!(term.extra_power_w(0.75) > 2.0, "{term:?}");
    assert!(term.extra_power_w(0.2).abs() < 1e-9, "{term:?}");
    assert!(term.extra_power_w(2.0).abs() < 1e-9, "{term:?}");

    let plan = host_tool()
        .args([
            "plan",
            "--start-deg",
            "60",
            "--end-deg",
            "60",
            "--distance-m",
            "5",
        ])
        .arg("--model")
        .arg(&model_path)
        .args(["--json", "-"])
        .output()
        .expect("plan runs");
    let plan_out = ok(&plan);
    let p: serde_json::Value = serde_json::from_str(&plan_out).expect("plan JSON");
    assert!(
        p["clc"]["energy_j"].as_f64().is_some_and(|e| e > 0.0),
        "{p}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn diagnose_with_calibration_runs_says_so() {
    let dir = temp_dir("diagnose-cli-cal");
    let runs = inner_drag_runs(&dir);
    let cal = dir.join("cal.csv");
    write_run(
        &WorldConfig::hard_ground().with_effect(EffectId::InnerDrag, true),
        99,
        &cal,
    );
    let mut args: Vec<&OsStr> = vec![os("--calibration"), cal.as_os_str()];
    args.push(os("--runs"));
    args.extend(runs.iter().map(|p| p.as_os_str()));
    args.extend([os("--json"), os("-")]);
    let stdout = ok(&diagnose(&args));
    let j: serde_json::Value = serde_json::from_str(&stdout).expect("stdout is JSON only");
    assert_eq!(j["calibration"]["source"], "calibration-files");
    // Point turn, 2R′, 4R′, straight.
    assert_eq!(j["calibration"]["manoeuvres"], 4);
    assert_eq!(j["effect"], "inner-drag", "{j}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn diagnose_fails_clearly_on_bad_input() {
    let dir = temp_dir("diagnose-cli-bad");
    let missing = dir.join("nope.csv");
    let stderr = failed(&diagnose(&[os("--runs"), missing.as_os_str()]));
    assert!(stderr.contains("nope.csv"), "{stderr}");

    let malformed = dir.join("bad.csv");
    std::fs::write(&malformed, "t_s,bus_v_left\n0.0,abc\n").expect("write");
    let stderr = failed(&diagnose(&[os("--runs"), malformed.as_os_str()]));
    assert!(stderr.contains("bad.csv"), "{stderr}");

    let no_rover = dir.join("rover.toml");
    let run = dir.join("run.csv");
    write_run(&WorldConfig::hard_ground(), 1, &run);
    let out = host_tool()
        .arg("diagnose")
        .arg("--rover")
        .arg(&no_rover)
        .arg("--runs")
        .arg(&run)
        .output()
        .expect("runs");
    let stderr = failed(&out);
    assert!(stderr.contains("rover.toml"), "{stderr}");

    // One run of the control world: a diagnosis is possible (leave one radius out).
    let stdout = ok(&diagnose(&[os("--runs"), run.as_os_str()]));
    assert!(stdout.contains("diagnosis: none"), "{stdout}");

    // A calibration run without calibration manoeuvres: the baseline cannot be fitted.
    let still = dir.join("still.csv");
    let samples: Vec<RunSample> = (0..400)
        .map(|k| {
            RunSample::new(
                k as f64 * 0.01,
                Sides::new(24.0, 24.0),
                Sides::new(0.05, 0.05),
                Sides::new(0.0, 0.0),
            )
        })
        .collect();
    write_run_csv_atomically(&still, host_tool::log::Existing::Replace, &samples).expect("write");
    let stderr = failed(&diagnose(&[
        os("--calibration"),
        still.as_os_str(),
        os("--runs"),
        run.as_os_str(),
    ]));
    assert!(stderr.contains("calibration runs"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 18's check: thesis Table 6.1 as a path table departs at R' and angular slip explains it.
#[test]
fn diagnose_reads_table_6_1_as_a_path_table() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let table = root.join("examples/husky-sand-table-6.1.csv");
    // `diagnose` passes --rover rovers/husky-a200.toml.
    let out = diagnose(&[os("--runs"), table.as_os_str(), os("--json"), os("-")]);
    let v: serde_json::Value = serde_json::from_str(&ok(&out)).expect("JSON");
    assert_eq!(v["effect"], "angular-slip");
    assert_eq!(v["regime"], "at-r-prime");
    assert_eq!(v["significant"], true);
    assert_eq!(v["heldout"]["scheme"], "leave-one-slice-out");
    assert!(
        v["heldout"]["shrink_pct"].as_f64().expect("shrink") > 30.0,
        "{v}"
    );
}

/// `--out` on thesis Table 4.1's per-turn summary (total power only, no sides) panicked drawing
/// the residuals by side (bdbfc5c); it writes the report, the model file and the figures, whose
/// side panels draw no total-only row.
#[test]
fn diagnose_out_on_a_total_only_summary_writes_its_report() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = temp_dir("diagnose-cli-argo").join("out");
    let out = host_tool()
        .arg("diagnose")
        .arg("--rover")
        .arg(root.join("rovers/argo-j5.toml"))
        .arg("--runs")
        .arg(root.join("examples/argo-j5-table-4.1.csv"))
        .arg("--out")
        .arg(&dir)
        .output()
        .expect("runs");
    ok(&out);
    for file in ["diagnosis.md", "model.toml", "residuals-vs-radius.png"] {
        assert!(dir.join(file).is_file(), "{file}");
    }
}
