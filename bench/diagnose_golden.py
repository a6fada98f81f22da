#!/usr/bin/env python3
"""Byte-for-byte record of what `host-tool diagnose` answers on a fixed corpus, so that a change
meant to keep every verdict (a redesign, a speed-up) can prove it did.

    python3 bench/diagnose_golden.py --tool target/release/host-tool --out DIR [--set ci|full]
        [--demo-out demo-out] [--foreign ../shared/foreign-datasets]
    python3 bench/diagnose_golden.py --compare DIR_A DIR_B
    python3 bench/diagnose_golden.py --tool ... --out DIR --check bench/diagnose-golden.sha256
    python3 bench/diagnose_golden.py --tool ... --out DIR --bless bench/diagnose-golden.sha256

The corpus (each case is `diagnose --json -`, or `diagnose-bench --json -`, written to DIR):
- the thesis' tables shipped in `examples/` (Argo J5 Table 4.1, also with `--out`: diagnosis.md
  and model.toml; Husky sand Table 6.1);
- the demo's runs (`--demo-out`, when given), also with `--out`;
- the three foreign datasets (`--foreign`, when the directory exists);
- World D and World E (bench/independent): dev seed 1 (`ci`) or dev seeds 1-3 (`full`);
- the bench's datasets as `diagnose-bench --dump` writes them: seed 1, tuning, the first 12
  (`ci`) or seeds 1-3, both parts, all 100 (`full`), each diagnosed by the command its
  dataset.json names;
- `diagnose-bench --json -` (closed loop included; its timing figures left out): seed 1, 20
  datasets per part (`ci`) or seeds 1-3, 100 per part (`full`).

`--check` compares every written file with a manifest of sha256 sums (files the manifest does not
list are reported, not failed; a listed file missing or different fails). `--bless` writes the
manifest. `--compare` lists the files that differ between two output directories. Datasets are
generated into a temporary directory; nothing is written into the tree but DIR and the manifest.
Python standard library only.
"""

import argparse
import concurrent.futures
import hashlib
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WORLDS = {
    "world-d": os.path.join(ROOT, "bench/independent/world_d/gen.py"),
    "world-e": os.path.join(ROOT, "bench/independent/world_e/gen.py"),
}


# The bench report's timing figures differ from run to run; everything else must not.
TIMING_KEYS = {"wall_s", "simulate_s", "validate_s", "diagnose_s", "median_diagnose_s",
               "max_diagnose_s", "median_diagnose_layout_s", "median_diagnose_long_s", "over_goal",
               "one_hour_log"}


def without_timing(value):
    if isinstance(value, dict):
        return {k: without_timing(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [without_timing(v) for v in value]
    return value


def run(cmd, cwd=None):
    out = subprocess.run(cmd, cwd=cwd, capture_output=True)
    return out.returncode, out.stdout, out.stderr


class Corpus:
    def __init__(self, tool, out):
        self.tool = os.path.abspath(tool)
        self.out = out
        self.jobs = []  # (name, argv, cwd)

    def diagnose(self, name, args, cwd=None, with_out=False):
        self.jobs.append((name + ".json", [self.tool, "diagnose"] + args + ["--json", "-"], cwd))
        if with_out:
            self.jobs.append((name + ".out", [self.tool, "diagnose"] + args, cwd))

    def bench(self, name, args):
        self.jobs.append((name + ".json", [self.tool, "diagnose-bench"] + args + ["--json", "-"], None))

    def run_all(self, workers):
        def one(job):
            name, argv, cwd = job
            if name.endswith(".out"):
                # `--out`: the report and the model file, not the figures.
                with tempfile.TemporaryDirectory() as tmp:
                    code, _, err = run(argv + ["--out", os.path.join(tmp, "d")], cwd)
                    files = {}
                    for f in ("diagnosis.md", "model.toml"):
                        p = os.path.join(tmp, "d", f)
                        if os.path.exists(p):
                            with open(p, "rb") as fh:
                                files[f] = fh.read()
                return name, code, files, err
            code, stdout, err = run(argv, cwd)
            if argv[1] == "diagnose-bench" and code == 0:
                stdout = json.dumps(without_timing(json.loads(stdout)), indent=1).encode()
            return name, code, {"": stdout}, err

        failures = []
        with concurrent.futures.ThreadPoolExecutor(workers) as pool:
            for name, code, files, err in pool.map(one, self.jobs):
                base = name[: -len(".out")] if name.endswith(".out") else name
                for suffix, data in files.items():
                    path = os.path.join(self.out, base + ("." + suffix if suffix else ""))
                    with open(path, "wb") as fh:
                        fh.write(data)
                with open(os.path.join(self.out, base + ".exit"), "w") as fh:
                    fh.write(f"{code}\n")
                # diagnose exits 0 on a diagnosis; anything else is recorded and reported.
                if code not in (0,):
                    failures.append((name, code, err.decode(errors="replace")[-300:]))
        return failures


def world_cases(corpus, tmp, seeds):
    for world, gen in WORLDS.items():
        for seed in seeds:
            d = os.path.join(tmp, f"{world}-{seed}")
            code, _, err = run([sys.executable, gen, "--seed", str(seed), "--out", d])
            if code != 0:
                sys.exit(f"{gen} --seed {seed}: {err.decode(errors='replace')}")
            for ds in sorted(os.listdir(d)):
                p = os.path.join(d, ds)
                if not os.path.exists(os.path.join(p, "rover.toml")):
                    continue
                cal = sorted(f for f in os.listdir(p) if f.startswith("cal_"))
                runs = sorted(f for f in os.listdir(p) if f.startswith("run_"))
                corpus.diagnose(f"{world}-{seed}-{ds}",
                                ["--rover", "rover.toml", "--calibration"] + cal + ["--runs"] + runs,
                                cwd=p)


def bench_dump_cases(corpus, tmp, seeds, parts, limit):
    for seed in seeds:
        for part in parts:
            d = os.path.join(tmp, f"bench-{seed}-{part}")
            code, _, err = run([corpus.tool, "diagnose-bench", "--seed", str(seed), "--part", part,
                                "--datasets", str(limit), "--dump", d])
            if code != 0:
                sys.exit(f"diagnose-bench --dump: {err.decode(errors='replace')}")
            for ds in sorted(os.listdir(d)):
                p = os.path.join(d, ds)
                with open(os.path.join(p, "dataset.json")) as fh:
                    cmd = shlex.split(json.load(fh)["diagnose"])
                assert cmd[:2] == ["host-tool", "diagnose"], cmd
                corpus.diagnose(f"bench-{seed}-{ds}", cmd[2:], cwd=p)


def build(args):
    os.makedirs(args.out, exist_ok=True)
    corpus = Corpus(args.tool, args.out)
    full = args.set == "full"
    for name, rover, csv in [
        ("argo-j5-table-4.1", "rovers/argo-j5.toml", "examples/argo-j5-table-4.1.csv"),
        ("husky-sand-table-6.1", "rovers/husky-a200.toml", "examples/husky-sand-table-6.1.csv"),
    ]:
        # Relative paths: the report names its inputs, and a clone may live anywhere. A path
        # table (Table 6.1) takes no --out.
        corpus.diagnose(name, ["--rover", rover, "--runs", csv], cwd=ROOT,
                        with_out=name.startswith("argo"))
    if args.demo_out:
        runs = sorted(os.path.join(os.path.abspath(args.demo_out), f)
                      for f in os.listdir(args.demo_out)
                      if re.fullmatch(r"run-[0-9]+\.csv", f))
        corpus.diagnose("demo", ["--rover", os.path.join(ROOT, "rovers/husky-a200.toml"), "--runs"] + runs,
                        with_out=True)
    if args.foreign and os.path.isdir(args.foreign):
        for ds in sorted(os.listdir(args.foreign)):
            p = os.path.join(args.foreign, ds)
            if os.path.exists(os.path.join(p, "rover.toml")):
                corpus.diagnose(f"foreign-{ds}", ["--rover", "rover.toml", "--calibration", "cal_0.csv",
                                                  "cal_1.csv", "--runs", "run_0.csv", "run_1.csv", "run_2.csv"],
                                cwd=p)
    with tempfile.TemporaryDirectory() as tmp:
        world_cases(corpus, tmp, [1, 2, 3] if full else [1])
        if full:
            bench_dump_cases(corpus, tmp, [1, 2, 3], ["tuning", "held-out"], 100)
        else:
            bench_dump_cases(corpus, tmp, [1], ["tuning"], 12)
        for seed in ([1, 2, 3] if full else [1]):
            corpus.bench(f"bench-report-{seed}",
                         ["--seed", str(seed), "--datasets", "100" if full else "20", "--threads", "1"])
        failures = corpus.run_all(args.workers)
    for name, code, err in failures:
        print(f"note: {name} exited {code}: {err.strip()}", file=sys.stderr)
    return manifest_of(args.out)


def manifest_of(out):
    sums = {}
    for f in sorted(os.listdir(out)):
        with open(os.path.join(out, f), "rb") as fh:
            sums[f] = hashlib.sha256(fh.read()).hexdigest()
    return sums


def read_manifest(path):
    sums = {}
    with open(path) as fh:
        for line in fh:
            if line.strip() and not line.startswith("#"):
                digest, name = line.split()
                sums[name] = digest
    return sums


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tool")
    ap.add_argument("--out")
    ap.add_argument("--set", choices=["ci", "full"], default="ci")
    ap.add_argument("--demo-out")
    ap.add_argument("--foreign", help="a directory of foreign datasets (../shared/foreign-datasets)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--check", metavar="MANIFEST")
    ap.add_argument("--bless", metavar="MANIFEST")
    ap.add_argument("--compare", nargs=2, metavar=("DIR_A", "DIR_B"))
    args = ap.parse_args()
    if args.compare:
        a, b = (manifest_of(d) for d in args.compare)
        differ = sorted(n for n in a.keys() | b.keys() if a.get(n) != b.get(n))
        for n in differ:
            print(f"differs: {n}" if n in a and n in b else f"only in one: {n}")
        print(f"{len(a.keys() & b.keys()) - len([n for n in differ if n in a and n in b])} identical, "
              f"{len(differ)} differ")
        return 1 if differ else 0
    if not (args.tool and args.out):
        ap.error("--tool and --out are needed (or --compare)")
    sums = build(args)
    print(f"{len(sums)} files in {args.out}")
    if args.bless:
        with open(args.bless, "w") as fh:
            fh.write("# sha256 of `bench/diagnose_golden.py --set ci` outputs (--bless rewrites it)\n")
            for name, digest in sorted(sums.items()):
                fh.write(f"{digest}  {name}\n")
        print(f"wrote {args.bless}")
    if args.check:
        want = read_manifest(args.check)
        bad = [n for n, d in want.items() if sums.get(n) != d]
        extra = [n for n in sums if n not in want]
        for n in extra:
            print(f"not in the manifest: {n}")
        for n in bad:
            print(f"{'MISSING' if n not in sums else 'DIFFERS'}: {n}")
        print(f"{len(want) - len(bad)} of {len(want)} as in {args.check}")
        return 1 if bad else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
