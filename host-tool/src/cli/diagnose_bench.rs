//! `host-tool diagnose-bench`: `diagnose` checked blind on datasets from the world family.

use super::output::{self, JsonOut};
use anyhow::Context;
use anyhow::Result;
use host_tool::diagnose::bench::{
    dump::dump_dataset, generate_all, run::explain, run_bench, BenchOptions, PartChoice,
};
use host_tool::diagnose::report;
use host_tool::log::run_csv::CURRENT_A_MAX;
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
    /// Overwrite an existing --json file.
    #[arg(long)]
    force: bool,
    /// Keep the simulated tracker's position fixes (5 Hz prism): the diagnosis then places
    /// turns by their measured R_ACT and sees a measured slip track.
    #[arg(long)]
    poses: bool,
    /// Instead of running the bench, write each dataset (or only `--only`'s) to
    /// DIR/<part>-<index>/ as run CSVs, rover.toml and dataset.json (spec, truth and the
    /// `diagnose` command the bench runs), to read a miss with the ordinary commands.
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
        };
        if let Some(dir) = &self.dump {
            return dump(&options, dir, self.only);
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

/// `--dump DIR [--only INDEX]`: each chosen dataset into its own directory under `dir`.
fn dump(options: &BenchOptions, dir: &Path, only: Option<usize>) -> Result<()> {
    let specs: Vec<_> = generate_all(options)
        .into_iter()
        .filter(|s| only.is_none_or(|i| s.index == i))
        .collect();
    anyhow::ensure!(
        !specs.is_empty(),
        "no dataset has index {}",
        only.unwrap_or(0)
    );
    for spec in &specs {
        let sub = dir.join(format!("{}-{}", spec.part.id(), spec.index));
        std::fs::create_dir_all(&sub).with_context(|| format!("creating {}", sub.display()))?;
        let dumped = dump_dataset(spec, &sub, options.poses)
            .with_context(|| format!("dataset {}", sub.display()))?;
        println!(
            "{}: {} ({})",
            sub.display(),
            spec.class.label(),
            spec.structure_label
        );
        println!("  cd {} && {}", sub.display(), dumped.diagnose);
        if let Some(peak) = dumped.over_range_a {
            println!(
                "  note: its currents reach {peak:.1} A, beyond the INA226 board's ±{CURRENT_A_MAX} A: \
                 `diagnose` refuses these files (the bench hands its samples to the diagnosis directly)"
            );
        }
    }
    Ok(())
}
