#!/usr/bin/env python3
"""Score a diagnosis tool on World D datasets (Python 3 standard library only).

    python3 score.py --tool PATH_TO_host-tool --dir DIR [--json out.json] [--workers 2]

For every DIR/<class>-<seed>-<k>/ (a directory holding truth.json) it runs

    TOOL diagnose --rover D/rover.toml --calibration D/cal_0.csv D/cal_1.csv
         --runs D/run_0.csv D/run_1.csv D/run_2.csv --json -

and reads the verdict from the key `effect` of the JSON on stdout. The exit code is not used
(exit 1 or 3 may just mean a departure was found); only a missing or invalid JSON object is an
error. A *wrong* name is a catalogued effect that is not the truth, or any catalogued effect on a
control; for a control, `none` is right; every other word (none, ambiguous, baseline-misfit, ...)
on an effect dataset is "not named".
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import time

# The catalogue's classes, as the generator writes them into truth.json (control first).
from gen import CLASSES  # noqa: E402 (gen.py sits beside this script)

EFFECTS = CLASSES[1:]


def run_one(tool, d, timeout):
    cmd = [tool, "diagnose", "--rover", os.path.join(d, "rover.toml"),
           "--calibration", os.path.join(d, "cal_0.csv"), os.path.join(d, "cal_1.csv"),
           "--runs"] + [os.path.join(d, f"run_{i}.csv") for i in range(3)] + ["--json", "-"]
    t0 = time.time()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return dict(error=f"timeout after {timeout} s", seconds=time.time() - t0)
    res = dict(exit=p.returncode, seconds=round(time.time() - t0, 2))
    try:
        out = json.loads(p.stdout)
        if not isinstance(out, dict) or not isinstance(out.get("effect"), str):
            raise ValueError("no string key 'effect'")
        res["verdict"] = out["effect"]
        res["regime"] = out.get("regime")
    except ValueError as err:   # json.JSONDecodeError is a ValueError
        res["error"] = f"invalid JSON ({err}); exit {p.returncode}; stderr: {p.stderr.strip()[-400:]}"
    return res


def judge(truth_effect, verdict):
    if verdict is None:
        return "error"
    if truth_effect == "none":
        return "wrong" if verdict in EFFECTS else "right" if verdict == "none" else "not named"
    if verdict == truth_effect:
        return "right"
    return "wrong" if verdict in EFFECTS else "not named"


def main():
    ap = argparse.ArgumentParser(description="Score host-tool diagnose on World D datasets")
    ap.add_argument("--tool", required=True)
    ap.add_argument("--dir", required=True)
    ap.add_argument("--json", help="write per-dataset results and totals here")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--timeout-s", type=float, default=600.0)
    a = ap.parse_args()

    dsets = sorted(os.path.join(a.dir, n) for n in os.listdir(a.dir)
                   if os.path.isfile(os.path.join(a.dir, n, "truth.json")))
    if not dsets:
        sys.exit(f"no datasets (directories with truth.json) in {a.dir}")
    truths = {d: json.load(open(os.path.join(d, "truth.json"))) for d in dsets}
    results = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.workers) as ex:
        futs = {ex.submit(run_one, a.tool, d, a.timeout_s): d for d in dsets}
        for f in concurrent.futures.as_completed(futs):
            results[futs[f]] = f.result()

    rows = []
    for d in dsets:
        t, r = truths[d], results[d]
        cls = "control" if t["effect"] == "none" else t["effect"]
        rows.append(dict(dataset=os.path.basename(d), cls=cls, truth=t["effect"],
                         truth_regime=t.get("regime"), visible=t.get("visible"),
                         twin_rms_w=t.get("twin_rms_w"), rover=t.get("rover"),
                         verdict=r.get("verdict"), regime=r.get("regime"), exit=r.get("exit"),
                         error=r.get("error"), outcome=judge(t["effect"], r.get("verdict"))))

    print(f"{'dataset':30} {'rover':5} {'vis':5} {'verdict':20} {'regime':16} outcome")
    for r in rows:
        vis = "-" if r["visible"] is None else ("yes" if r["visible"] else "no")
        print(f"{r['dataset']:30} {r['rover'] or '':5} {vis:5} {str(r['verdict']):20} "
              f"{str(r['regime']):16} {r['outcome']}")
    print()
    print(f"{'class':20} {'n':>3} {'right':>5} {'wrong':>5} {'not named':>9} {'error':>5}  verdicts")
    per_class = {}
    for cls in CLASSES + sorted({r["cls"] for r in rows} - set(CLASSES)):
        sel = [r for r in rows if r["cls"] == cls]
        if not sel:
            continue
        cnt = {k: sum(1 for r in sel if r["outcome"] == k) for k in ("right", "wrong", "not named", "error")}
        verdicts = {}
        for r in sel:
            v = r["verdict"] if r["verdict"] is not None else "ERROR"
            verdicts[v] = verdicts.get(v, 0) + 1
        per_class[cls] = dict(n=len(sel), **cnt, verdicts=verdicts)
        vs = ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items(), key=lambda kv: -kv[1]))
        print(f"{cls:20} {len(sel):3} {cnt['right']:5} {cnt['wrong']:5} {cnt['not named']:9} "
              f"{cnt['error']:5}  {vs}")

    n = len(rows)
    wrong = sum(1 for r in rows if r["outcome"] == "wrong")
    ctrl = [r for r in rows if r["cls"] == "control"]
    ctrl_named = sum(1 for r in ctrl if r["verdict"] in EFFECTS)
    vis = [r for r in rows if r["cls"] != "control" and r["visible"]]
    vis_right = sum(1 for r in vis if r["outcome"] == "right")
    errors = [r for r in rows if r["outcome"] == "error"]
    pct = lambda x, y: 100.0 * x / y if y else 0.0
    print()
    print(f"wrong names: {wrong} of {n} ({pct(wrong, n):.0f} %)")
    print(f"controls named an effect: {ctrl_named} of {len(ctrl)}")
    print(f"visible effects named right: {vis_right} of {len(vis)} ({pct(vis_right, len(vis)):.0f} %)")
    eff = [r for r in rows if r["cls"] != "control"]
    print(f"all effects named right: {sum(1 for r in eff if r['outcome'] == 'right')} of {len(eff)}")
    if errors:
        print(f"errors (no valid JSON): {len(errors)}")
        for r in errors:
            print(f"  {r['dataset']}: {r['error']}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(dict(datasets=rows, per_class=per_class,
                           totals=dict(n=n, wrong=wrong, controls=len(ctrl), controls_named=ctrl_named,
                                       visible=len(vis), visible_right=vis_right, errors=len(errors))),
                      f, indent=1)


if __name__ == "__main__":
    main()
