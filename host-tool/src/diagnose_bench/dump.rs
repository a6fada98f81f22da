//! `diagnose-bench --dump DIR`: one dataset as the files a user would hand to `diagnose`, so
//! a bench miss can be read with the ordinary commands rather than a debugger:
//! `cal-K.csv` and `run-K.csv` (run CSVs; position fixes only with `--poses`, as the bench
//! diagnoses them), `rover.toml` (the dataset's rover
//! file, the geometry the bench diagnoses with) and `dataset.json` (its spec and its truth,
//! which `diagnose` is never shown).

use super::family::{DatasetSpec, RoverKind};
use super::run::{simulate, DatasetError};
use super::truth::Truth;
use crate::log::run_csv::{write_run_csv_atomically, RunCsvFileError, CURRENT_A_MAX};
use crate::validate::pose::without_positions;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The rover files of the family, as shipped in `rovers/`.
fn rover_file(rover: RoverKind) -> &'static str {
    match rover {
        RoverKind::HuskyA200 => include_str!("../../../rovers/husky-a200.toml"),
        RoverKind::ArgoJ5 => include_str!("../../../rovers/argo-j5.toml"),
    }
}

/// Why a dataset could not be written.
#[derive(Debug, thiserror::Error)]
pub enum DumpError {
    /// The dataset did not simulate.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A run CSV was not written.
    #[error(transparent)]
    RunCsv(#[from] RunCsvFileError),
    /// Another file was not written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

#[derive(Serialize)]
struct DatasetFile<'a> {
    spec: &'a DatasetSpec,
    truth: &'a Truth,
    /// The command that diagnoses it as the bench does.
    diagnose: String,
}

/// What [`dump_dataset`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Dumped {
    /// The command line that diagnoses the files as the bench does.
    pub diagnose: String,
    /// The largest side current of the runs when beyond the board's range [A]: `diagnose`
    /// reads such files as another rig's, but not with `--rig-range board`, and `replay` and
    /// `convert` to MCAP refuse them (the board's registers cannot hold them).
    pub over_range_a: Option<f64>,
}

/// Writes dataset `spec` into the existing directory `dir` (with its tracker's fixes when
/// `poses`).
pub fn dump_dataset(spec: &DatasetSpec, dir: &Path, poses: bool) -> Result<Dumped, DumpError> {
    let data = simulate(spec)?;
    let peak_a = data
        .calibration
        .iter()
        .chain(&data.runs)
        .flatten()
        .flat_map(|s| [s.current_a.left.abs(), s.current_a.right.abs()])
        .fold(0.0, f64::max);
    let write_runs = |prefix: &str, runs: &[Vec<_>]| -> Result<Vec<String>, DumpError> {
        let mut names = Vec::new();
        for (k, samples) in runs.iter().enumerate() {
            let name = format!("{prefix}-{k}.csv");
            if poses {
                write_run_csv_atomically(&dir.join(&name), crate::log::Existing::Replace, samples)?;
            } else {
                write_run_csv_atomically(
                    &dir.join(&name),
                    crate::log::Existing::Replace,
                    &without_positions(samples),
                )?;
            }
            names.push(name);
        }
        Ok(names)
    };
    let cal_files = write_runs("cal", &data.calibration)?;
    let run_files = write_runs("run", &data.runs)?;
    let write = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|source| DumpError::Io { path, source })
    };
    write("rover.toml", rover_file(spec.rover))?;
    let diagnose = format!(
        "host-tool diagnose --rover rover.toml --calibration {} --runs {}",
        cal_files.join(" "),
        run_files.join(" ")
    );
    let file = DatasetFile {
        spec,
        truth: &data.truth,
        diagnose: diagnose.clone(),
    };
    let json = serde_json::to_string_pretty(&file).map_err(|e| DumpError::Io {
        path: dir.join("dataset.json"),
        source: e.into(),
    })?;
    write("dataset.json", &json)?;
    Ok(Dumped {
        diagnose,
        over_range_a: (peak_a > CURRENT_A_MAX).then_some(peak_a),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose_bench::{generate, Part};
    use crate::rover::parse_rover_file;

    #[test]
    fn the_shipped_rover_files_are_the_family_geometry() {
        for kind in [RoverKind::HuskyA200, RoverKind::ArgoJ5] {
            let file = parse_rover_file(rover_file(kind)).expect("shipped rover file parses");
            assert_eq!(file.rover, kind.rover(), "{}", kind.id());
        }
    }

    #[test]
    fn a_dumped_dataset_reads_back_as_its_runs() {
        let specs = generate(Part::Tuning, 10, 7);
        let spec = specs
            .iter()
            .find(|s| s.rover == RoverKind::HuskyA200 && s.effect().is_none())
            .expect("a Husky dataset without effect");
        let dir = crate::log::tests_support::TempDir::new("bench-dump");
        let dumped = dump_dataset(spec, dir.path(), false).expect("dumps");
        assert_eq!(
            dumped.over_range_a, None,
            "the Husky stays in the board's range"
        );
        let cmd = dumped.diagnose;
        assert!(cmd.contains("--calibration cal-0.csv cal-1.csv"), "{cmd}");
        let data = simulate(spec).expect("simulates");
        let back =
            crate::log::run_csv::read_run_csv(&dir.path().join("run-0.csv")).expect("reads back");
        assert_eq!(back.len(), data.runs[0].len());
        assert!(
            back.iter().all(|s| s.x_m.is_none()),
            "positions only with poses"
        );
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("dataset.json")).expect("dataset.json"),
        )
        .expect("JSON");
        assert_eq!(json["truth"]["effect"], "none");
    }

    /// Issue 34 item 6: the Argo J5 draws beyond the INA226 board's ±16.384 A, and the run CSV
    /// reader refused the files `--dump` wrote for it.
    #[test]
    fn a_dumped_argo_dataset_beyond_the_boards_range_reads_back_as_another_rigs() {
        use crate::log::run_csv::{read_run_csv, read_run_csv_salvaging, RigRange};
        let spec = generate(Part::HeldOut, 1, 7).remove(0);
        assert_eq!(spec.rover, RoverKind::ArgoJ5);
        let dir = crate::log::tests_support::TempDir::new("bench-dump-argo");
        let dumped = dump_dataset(&spec, dir.path(), false).expect("dumps");
        let peak = dumped.over_range_a.expect("beyond the board's range");
        assert!(peak > CURRENT_A_MAX, "{peak}");
        let data = simulate(&spec).expect("simulates");
        let files = [("cal", &data.calibration), ("run", &data.runs)];
        let mut beyond = Vec::new();
        for (prefix, runs) in files {
            for (k, samples) in runs.iter().enumerate() {
                let path = dir.path().join(format!("{prefix}-{k}.csv"));
                let back = read_run_csv(&path).expect("another rig's run CSV reads");
                assert_eq!(back, without_positions(samples), "{}", path.display());
                if back
                    .iter()
                    .any(|s| s.current_a.left.abs().max(s.current_a.right.abs()) > CURRENT_A_MAX)
                {
                    beyond.push(path);
                }
            }
        }
        // The board's range still refuses them, naming the file and the way out.
        assert!(!beyond.is_empty());
        for path in beyond {
            let e = read_run_csv_salvaging(&path, false, RigRange::Board).expect_err("board");
            let text = e.to_string();
            assert!(
                text.starts_with(&format!("{}: line ", path.display())),
                "{text}"
            );
            assert!(text.contains("--rig-range board"), "{text}");
        }
    }
}
