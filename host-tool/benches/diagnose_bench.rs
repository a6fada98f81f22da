//! The diagnose-bench of issue 10: datasets from the simulator's world family, each with one
//! withheld effect, none, or only a non-default structure, diagnosed blind; prints, per part
//! (tuning, held-out), the confusion matrix, the accuracy, the controls, the structure-only
//! datasets, the median held-out shrink, per structure and per class, and the diagnosis time
//! (see `host_tool::diagnose_bench`).
//!
//! `cargo bench -p host-tool --bench diagnose_bench -- [--datasets N] [--seed S] [--threads T]
//! [--part tuning|held-out|both] [--json OUT.json]` (defaults: 100 datasets per part, seed 1, 2
//! threads, both parts). Under `cargo test --benches` (no `--bench` argument) it runs 10
//! datasets per part, one per class.

use anyhow::{bail, Context};
use host_tool::diagnose_bench::{run_bench, BenchOptions, PartChoice};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let mut opts = BenchOptions::default();
    let mut json: Option<PathBuf> = None;
    let mut bench_mode = false;
    let mut datasets_given = false;
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().with_context(|| format!("{name} needs a value"));
        match arg.as_str() {
            "--bench" => bench_mode = true,
            "--datasets" => {
                opts.datasets = value("--datasets")?.parse().context("--datasets")?;
                datasets_given = true;
            }
            "--seed" => opts.seed = value("--seed")?.parse().context("--seed")?,
            "--threads" => opts.threads = value("--threads")?.parse().context("--threads")?,
            "--part" => {
                opts.part = match value("--part")?.as_str() {
                    "tuning" => PartChoice::Tuning,
                    "held-out" => PartChoice::HeldOut,
                    "both" => PartChoice::Both,
                    other => bail!("--part {other}: expected tuning, held-out or both"),
                }
            }
            "--json" => json = Some(PathBuf::from(value("--json")?)),
            // libtest-style flags cargo may pass.
            "--test" | "--nocapture" | "--quiet" | "-q" => {}
            other => bail!(
                "unknown argument `{other}` (expected --datasets N, --seed S, --threads T, --part P, --json OUT)"
            ),
        }
    }
    if opts.datasets == 0 || opts.threads == 0 {
        bail!("--datasets and --threads must be ≥ 1");
    }
    if opts.seed >= 1000 {
        bail!("--seed must be below 1000 (the held-out part uses 1000 + seed)");
    }
    if !bench_mode && !datasets_given {
        opts.datasets = 10;
    }
    let report = run_bench(&opts);
    print!("{report}");
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&report)?;
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
        println!("JSON: {}", path.display());
    }
    Ok(())
}
