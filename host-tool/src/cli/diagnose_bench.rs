//! `host-tool diagnose-bench`: `diagnose` checked blind on datasets from the world family.

use super::output::{self, JsonOut};
use anyhow::Context;
use anyhow::Result;
use host_tool::diagnose::report;
use host_tool::diagnose_bench::{
    dump::dump_dataset, generate_all, run::explain, run_bench, BenchOptions, PartChoice,
};
use host_tool::log::run_csv::CURRENT_A_MAX;
use host_tool::out_dir::{write_dir_whole, OutDirError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `diagnose-bench [--datasets N] [--seed S] [--part P] [--threads T] [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct DiagnoseBenchArgs {
    /// Datasets per part (one in ten a control, one in ten a structure without effect).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    datasets: u64,
    /// Bench seed: the same seed gives the same datasets (the held-out part uses 1000 + seed).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(0..1000))]
    seed: u64,
    /// Part of the world family: `tuning`, `held-out` (structures, geometry and seeds no
    /// tuning decision looks at) or `both`, reported separately.
    #[arg(long, value_enum, default_value = "both")]
    part: BenchPartArg,
    /// Worker threads.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=256))]
    threads: u64,
    #[command(flatten)]
    json: JsonOut,
    /// Overwrite an existing --json file, or replace a non-empty --dump directory.
    #[arg(long)]
    force: bool,
    /// Keep the simulated tracker's position fixes (5 Hz prism): the diagnosis then places
    /// turns by their measured R_ACT and sees a measured slip track.
    #[arg(long)]
    poses: bool,
    /// Rounds of the closed loop: while a verdict is open, drive what the diagnosis suggests
    /// next (`diagnose --next-runs`) as one more run in the same world and diagnose again.
    /// 0 turns it off.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=5))]
    rounds: u32,
    /// Instead of running the bench, write each dataset (or only `--only`'s) to
    /// DIR/<part>-<index>/ as run CSVs, rover.toml and dataset.json (spec, truth and the
    /// `diagnose` command the bench runs), to read a miss with the ordinary commands. DIR is
    /// written whole or not at all; a non-empty one needs --force.
    #[arg(long, value_name = "DIR")]
    dump: Option<PathBuf>,
    /// With --dump: only the dataset of this index (the `index` of the --json report).
    #[arg(long, value_name = "INDEX", requires = "dump")]
    only: Option<usize>,
    /// Instead of running the bench, diagnose the dataset of this index (of `--part`, which
    /// must then be `tuning` or `held-out`) as the bench does and print its spec, its truth and
    /// the whole report `diagnose` would print (also for datasets `--dump` cannot hand to
    /// `diagnose`: the Argo J5's currents beyond the board's range).
    #[arg(long, value_name = "INDEX", conflicts_with_all = ["dump", "json"])]
    explain: Option<usize>,
}

/// `--part` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum BenchPartArg {
    Tuning,
    HeldOut,
    Both,
}

impl DiagnoseBenchArgs {
    /// Runs the bench and prints (or writes) its report.
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        let options = BenchOptions {
            datasets: self.datasets as usize,
            seed: self.seed,
            threads: self.threads as usize,
            part: match self.part {
                BenchPartArg::Tuning => PartChoice::Tuning,
                BenchPartArg::HeldOut => PartChoice::HeldOut,
                BenchPartArg::Both => PartChoice::Both,
            },
            poses: self.poses,
            rounds: self.rounds,
        };
        if let Some(dir) = &self.dump {
            return output::print(dump(&options, dir, self.only, self.force)?);
        }
        if let Some(index) = self.explain {
            return explain_one(&options, index);
        }
        let report = run_bench(&options);
        if !self.json.emit(&report, "bench", self.force)? {
            output::print(&report)?;
        }
        Ok(())
    }
}

/// `--explain INDEX`: one dataset's spec, truth and diagnosis report.
fn explain_one(options: &BenchOptions, index: usize) -> Result<()> {
    anyhow::ensure!(
        !matches!(options.part, PartChoice::Both),
        "--explain needs --part tuning or --part held-out (each part has its own indices)"
    );
    let spec = generate_all(options)
        .into_iter()
        .find(|s| s.index == index)
        .with_context(|| format!("no dataset has index {index}"))?;
    let (truth, diagnosis) =
        explain(&spec, options.poses).with_context(|| format!("dataset {index}"))?;
    let mut text = format!(
        "dataset {}-{}: {} ({})\nspec: {}\ntruth: {}\n\n",
        spec.part.id(),
        spec.index,
        spec.class.label(),
        spec.structure_label,
        serde_json::to_string(&spec)?,
        serde_json::to_string(&truth)?,
    );
    text.push_str(&report::table(&diagnosis).to_string());
    output::print(text)
}

/// `--dump DIR [--only INDEX]`: each chosen dataset into its own directory under `dir`,
/// written whole or not at all; a non-empty `dir` is replaced only with `force`. Returns what to
/// print: per dataset its directory and the `diagnose` command to run there.
fn dump(options: &BenchOptions, dir: &Path, only: Option<usize>, force: bool) -> Result<String> {
    let specs: Vec<_> = generate_all(options)
        .into_iter()
        .filter(|s| only.is_none_or(|i| s.index == i))
        .collect();
    anyhow::ensure!(
        !specs.is_empty(),
        "no dataset has index {}",
        only.unwrap_or(0)
    );
    write_dir_whole(dir, force, |staging| {
        let mut text = String::new();
        for spec in &specs {
            let name = format!("{}-{}", spec.part.id(), spec.index);
            let staged = staging.join(&name);
            std::fs::create_dir(&staged)
                .with_context(|| format!("creating {}", staged.display()))?;
            let dumped = dump_dataset(spec, &staged, options.poses)
                .with_context(|| format!("dataset {name}"))?;
            let sub = dir.join(&name);
            let _ = writeln!(
                text,
                "{}: {} ({})",
                sub.display(),
                spec.class.label(),
                spec.structure_label
            );
            let _ = writeln!(text, "  cd {} && {}", sub.display(), dumped.diagnose);
            if let Some(peak) = dumped.over_range_a {
                let _ = writeln!(
                    text,
                    "  note: its currents reach {peak:.1} A, beyond the INA226 board's ±{CURRENT_A_MAX} A: \
                     read as another rig's files (not with `--rig-range board`; `replay` and \
                     `convert` to MCAP refuse them)"
                );
            }
        }
        Ok::<_, anyhow::Error>(text)
    })
    .map_err(|e| match e {
        OutDirError::Content(e) => e,
        // The other variants hold no `e`; their message says it all (path, --force, cause).
        other => anyhow::anyhow!("{other}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    #[test]
    fn dump_replaces_a_non_empty_directory_only_with_force() {
        // Issue 34, item 9b: --dump wrote into a non-empty directory without --force.
        let dir = std::env::temp_dir().join(format!("bench-dump-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("dir");
        fs::write(dir.join("notes.txt"), "mine").expect("file");
        let options = BenchOptions {
            datasets: 1,
            seed: 1,
            threads: 1,
            part: PartChoice::Tuning,
            poses: false,
            rounds: 0,
        };
        let refused = dump(&options, &dir, None, false).expect_err("not empty, no --force");
        assert!(refused.to_string().contains("--force"), "{refused:#}");
        let names: Vec<_> = fs::read_dir(&dir)
            .expect("still there")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names, ["notes.txt"], "nothing written");
        let text = dump(&options, &dir, None, true).expect("replaced with --force");
        assert!(
            text.contains("host-tool diagnose --rover rover.toml"),
            "{text}"
        );
        assert!(!dir.join("notes.txt").exists(), "replaced whole");
        let datasets: Vec<_> = fs::read_dir(&dir)
            .expect("dumped")
            .map(|e| e.expect("entry").path())
            .collect();
        assert_eq!(datasets.len(), 1);
        assert!(datasets[0].join("dataset.json").is_file());
        let _ = fs::remove_dir_all(&dir);
    }
}
