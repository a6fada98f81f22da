//! `host-tool diagnose-bench`: `diagnose` checked blind on datasets from the world family.

use super::output::{self, JsonOut};
use anyhow::Result;
use host_tool::diagnose::bench::{run_bench, BenchOptions, PartChoice};

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
        let report = run_bench(&options);
        if !self.json.emit(&report, "bench", self.force)? {
            output::print(&report)?;
        }
        Ok(())
    }
}
