#!/usr/bin/env python3
"""Score `host-tool diagnose` on World N datasets and their twins (Python 3 standard library only).

    python3 score.py --tool PATH --dir DIR [--dir DIR2 ...] [--json OUT.json]
                     [--reliability REL.json] [--workers 2] [--quiet]

For every DIR/<class>-<seed>-<k>/ holding truth.json it runs the tool on the dataset and, when
there is one, on its twin DIR/<...>/twin/ (same world, effect or cause off). Outcomes:

* control: `none` right, a catalogued id wrong, any other word not named;
* catalogued effect: its id right, another catalogued id wrong, any other word not named;
* out-of-catalogue (`outside-*`): any catalogued id wrong, any other word right.

Twin ceiling (per effect dataset) = 1 - twin.heldout.error_before / dataset.heldout.error_before:
the share of the dataset's held-out error that the effect itself accounts for; an effect is
"visible" when its ceiling is >= 50 %. The exit code of the tool is not used.
"""
import argparse
import collections
import concurrent.futures
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen import CATALOGUE, CLASSES, DIMS  # noqa: E402 (World N's gen.py beside this script)

BINS = [(0, 25), (25, 50), (50, 75), (75, 100)]


def diagnose(tool, d, timeout=600.0):
    """Runs the tool on dataset directory d; returns the parsed JSON (or None) and a summary
    (verdict, timing in ms, exit code, error)."""
    f = lambda name: os.path.join(d, name)  # noqa: E731
    argv = [tool, "diagnose", "--rover", f("rover.toml"), "--calibration", f("cal_0.csv"),
            f("cal_1.csv"), "--runs", f("run_0.csv"), f("run_1.csv"), f("run_2.csv"), "--json", "-"]
    start = time.perf_counter()
    elapsed = lambda: round((time.perf_counter() - start) * 1000.0, 1)  # noqa: E731
    try:
        proc = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=timeout,
                              text=True)
    except subprocess.TimeoutExpired:
        return None, {"error": f"no answer within {timeout} s", "ms": elapsed()}
    summary = {"exit": proc.returncode, "ms": elapsed()}
    try:
        out = json.loads(proc.stdout)
    except ValueError as err:
        out, why = None, f"stdout is not JSON ({err})"
    else:
        why = None if isinstance(out, dict) and isinstance(out.get("effect"), str) else "no string key 'effect'"
    if why is not None:
        summary["error"] = f"{why}; exit {proc.returncode}; stderr tail: {proc.stderr.strip()[-300:]}"
        return None, summary
    summary.update(summarise(out))
    return out, summary


def summarise(out):
    """Verdict, held-out error and, for a named verdict, its strength."""
    r = dict(verdict=out["effect"], regime=out.get("regime"))
    ho = out.get("heldout") or {}
    r["error_before"] = ho.get("error_before")
    r["shrink_pct"] = ho.get("shrink_pct") if ho.get("effect") == out["effect"] else None
    for sig in out.get("signatures") or []:
        if sig.get("effect") == out["effect"] and isinstance(sig.get("test"), dict):
            r["sig_p"] = sig["test"].get("p")
            r["sig_statistic"] = sig["test"].get("statistic")
            r["sig_sized"] = sig["test"].get("sized")
    return r


def judge(cls, verdict):
    if verdict is None:
        return "error"
    if cls == "control":
        return "right" if verdict == "none" else "wrong" if verdict in CATALOGUE else "not named"
    if cls.startswith("outside-"):
        return "wrong" if verdict in CATALOGUE else "right"
    if verdict == cls:
        return "right"
    return "wrong" if verdict in CATALOGUE else "not named"


def ceiling(ds_err, twin_err):
    if not isinstance(ds_err, (int, float)) or not isinstance(twin_err, (int, float)) or ds_err <= 0:
        return None
    return 1.0 - twin_err / ds_err


def pct(x, y):
    return f"{100.0 * x / y:.1f} %" if y else "-"


def score_dirs(tool, dirs, workers=2, timeout=600.0):
    """Runs the tool on every dataset and twin under dirs; returns the per-dataset rows."""
    dsets = []
    for top in dirs:
        dsets += sorted(os.path.join(top, n) for n in os.listdir(top)
                        if os.path.isfile(os.path.join(top, n, "truth.json")))
    targets = []
    for d in dsets:
        targets.append(d)
        if os.path.isfile(os.path.join(d, "twin", "rover.toml")):
            targets.append(os.path.join(d, "twin"))
    res = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=workers) as ex:
        futs = {ex.submit(diagnose, tool, t, timeout): t for t in targets}
        for f in concurrent.futures.as_completed(futs):
            res[futs[f]] = f.result()[1]
    rows = []
    for d in dsets:
        with open(os.path.join(d, "truth.json")) as f:
            t = json.load(f)
        r, tw = res[d], res.get(os.path.join(d, "twin"))
        cls = t["cls"]
        row = dict(dataset=os.path.basename(d), dir=d, cls=cls, truth=t["effect"],
                   truth_regime=t.get("regime"), rover=t.get("rover"), hz=t.get("sample_rate_hz"),
                   nuisance_mode=t.get("nuisance_mode"), nuisance_dims=t.get("nuisance_dims", []),
                   visible_d_rule=t.get("visible"), twin_rms_w=t.get("twin_rms_w"),
                   outcome=judge(cls, r.get("verdict")), **r)
        if tw is not None:
            row["twin_verdict"] = tw.get("verdict")
            row["twin_error_before"] = tw.get("error_before")
            row["twin_ms"] = tw.get("ms")
            row["twin_shrink_pct"] = tw.get("shrink_pct")
            row["twin_named"] = tw.get("verdict") in CATALOGUE
            c = ceiling(r.get("error_before"), tw.get("error_before"))
            row["ceiling"] = None if c is None else round(c, 4)
            row["visible"] = c is not None and c >= 0.5
        rows.append(row)
    return rows


def report(rows, quiet=False):
    """Prints the tables; returns the totals."""
    if not quiet:
        print(f"{'dataset':34} {'rover':5} {'Hz':>5} {'ceil':>6} {'verdict':20} {'twin':16} outcome  nuisance")
        for r in rows:
            c = "-" if r.get("ceiling") is None else f"{100 * r['ceiling']:.0f}%"
            print(f"{r['dataset']:34} {r['rover'] or '':5} {r['hz'] or 0:5} {c:>6} {str(r.get('verdict')):20} "
                  f"{str(r.get('twin_verdict', '-')):16} {r['outcome']:8} {','.join(r['nuisance_dims']) or '-'}")
        print()
    print(f"{'class':26} {'n':>4} {'right':>5} {'wrong':>5} {'not nm':>6} {'err':>3} {'vis':>4} {'vis ok':>6}"
          f" {'twin nm':>7}  verdicts")
    per_class = {}
    groups = {}
    for r in rows:
        groups.setdefault(r["cls"], []).append(r)
    for cls in sorted(groups, key=lambda c: (CLASSES.index(c) if c in CLASSES else len(CLASSES), c)):
        sel = groups[cls]
        outcomes = collections.Counter(r["outcome"] for r in sel)
        cnt = {k: outcomes.get(k, 0) for k in ("right", "wrong", "not named", "error")}
        vis = [r for r in sel if r.get("visible")]
        verdicts = dict(collections.Counter(r.get("verdict") or "ERROR" for r in sel))
        twin_nm = sum(1 for r in sel if r.get("twin_named"))
        per_class[cls] = dict(n=len(sel), **cnt, visible=len(vis),
                              visible_right=sum(1 for r in vis if r["outcome"] == "right"),
                              twins_named=twin_nm, verdicts=verdicts)
        vs = ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items(), key=lambda kv: (-kv[1], kv[0])))
        print(f"{cls:26} {len(sel):4} {cnt['right']:5} {cnt['wrong']:5} {cnt['not named']:6} {cnt['error']:3} "
              f"{len(vis):4} {per_class[cls]['visible_right']:6} {twin_nm:7}  {vs}")

    null = [r for r in rows if r["cls"] == "control" or r["cls"].startswith("outside-")]
    null_named = [r for r in null if r.get("verdict") in CATALOGUE]
    ctrl = [r for r in rows if r["cls"] == "control"]
    outside = [r for r in rows if r["cls"].startswith("outside-")]
    eff = [r for r in rows if r["cls"] in CATALOGUE]
    eff_wrong = [r for r in eff if r["outcome"] == "wrong"]
    vis = [r for r in eff if r.get("visible")]
    vis_right = [r for r in vis if r["outcome"] == "right"]
    twins = [r for r in rows if "twin_verdict" in r]
    twins_named = [r for r in twins if r.get("twin_named")]
    errors = [r for r in rows if r["outcome"] == "error"]
    ms = [r["ms"] for r in rows if r.get("ms") is not None]
    tot = dict(n=len(rows), controls=len(ctrl), outside=len(outside),
               controls_named=sum(1 for r in ctrl if r.get("verdict") in CATALOGUE),
               outside_named=sum(1 for r in outside if r.get("verdict") in CATALOGUE),
               null_named=len(null_named), null=len(null), effects=len(eff), effects_wrong=len(eff_wrong),
               effects_right=sum(1 for r in eff if r["outcome"] == "right"),
               visible=len(vis), visible_right=len(vis_right), twins=len(twins),
               twins_named=len(twins_named), errors=len(errors),
               median_ms=round(statistics.median(ms), 1) if ms else None)
    print()
    print(f"controls + out-of-catalogue named a catalogued effect: {len(null_named)} of {len(null)} "
          f"({pct(len(null_named), len(null))}); controls {tot['controls_named']} of {len(ctrl)}, "
          f"out-of-catalogue {tot['outside_named']} of {len(outside)}")
    print(f"wrong names on effect datasets: {len(eff_wrong)} of {len(eff)} ({pct(len(eff_wrong), len(eff))})")
    print(f"visible effects (twin ceiling >= 50 %) named right: {len(vis_right)} of {len(vis)} "
          f"({pct(len(vis_right), len(vis))}); all effects named right: {tot['effects_right']} of {len(eff)}")
    print(f"twins (effect/cause off: nuisance-only worlds) named a catalogued effect: {len(twins_named)} of "
          f"{len(twins)} ({pct(len(twins_named), len(twins))})")
    print(f"median diagnose time per dataset: {tot['median_ms']} ms; errors (no valid JSON): {len(errors)}")
    for r in errors:
        print(f"  {r['dataset']}: {r.get('error')}")

    # every wrong name (datasets and twins) by the nuisance dimensions that were on
    wrongs = [(r, r["cls"], r.get("verdict")) for r in rows if r["outcome"] == "wrong"]
    wrongs += [(r, r["cls"] + " (twin)", r["twin_verdict"]) for r in twins_named]
    pool = rows + twins
    print()
    print(f"wrong names by nuisance dimension on (datasets + twins: {len(wrongs)} wrong of {len(pool)} scored)")
    print(f"{'dimension':14} {'wrong':>5} {'of on':>6} {'rate':>7} {'rate off':>8} {'alone':>9}")
    by_dim = {}
    for dim in DIMS:
        on = [r for r in pool if dim in r["nuisance_dims"]]
        w_on = sum(1 for r, _, _ in wrongs if dim in r["nuisance_dims"])
        off_n = len(pool) - len(on)
        w_off = len(wrongs) - w_on
        alone = [r for r in pool if r["nuisance_dims"] == [dim]]
        w_alone = sum(1 for r, _, _ in wrongs if r["nuisance_dims"] == [dim])
        by_dim[dim] = dict(wrong=w_on, on=len(on), wrong_off=w_off, off=off_n, wrong_alone=w_alone,
                           alone=len(alone))
        print(f"{dim:14} {w_on:5} {len(on):6} {pct(w_on, len(on)):>7} {pct(w_off, off_n):>8} "
              f"{w_alone:4}/{len(alone):<4}")
    by_mode = {}
    for r in pool:
        m = by_mode.setdefault(r["nuisance_mode"], [0, 0])
        m[1] += 1
    for r, _, _ in wrongs:
        by_mode[r["nuisance_mode"]][0] += 1
    print("by nuisance mode: " + ", ".join(f"{k} {v[0]}/{v[1]}" for k, v in sorted(by_mode.items())))
    print("single-dimension wrong names: " + (", ".join(
        f"{r['dataset']}{' twin' if c.endswith('(twin)') else ''}:{r['nuisance_dims'][0]}->{v}"
        for r, c, v in wrongs if len(r["nuisance_dims"]) == 1) or "none"))
    print()
    print("wrong names by class -> verdict")
    by_pair = {}
    for _, c, v in wrongs:
        by_pair[(c, v)] = by_pair.get((c, v), 0) + 1
    for (c, v), n in sorted(by_pair.items(), key=lambda kv: (-kv[1], kv[0])):
        print(f"  {c:34} -> {v:20} {n}")
    tot["by_dimension"] = by_dim
    tot["by_mode"] = by_mode
    tot["by_class_verdict"] = [dict(cls=c, verdict=v, n=n) for (c, v), n in sorted(by_pair.items())]
    return per_class, tot


def reliability(rows):
    """For each named effect and held-out shrink bin: how often named, how often right (datasets
    and twins; a twin's truth is `none`)."""
    table = {}
    items = [(r.get("verdict"), r.get("shrink_pct"), r["outcome"] == "right") for r in rows]
    for r in rows:
        if "twin_verdict" in r:
            items.append((r["twin_verdict"], r.get("twin_shrink_pct"), False))
    for verdict, shrink, right in items:
        if verdict not in CATALOGUE:
            continue
        if shrink is None:
            b = "unknown"
        else:
            lo = next((lo for lo, hi in BINS if shrink < hi), 75)
            b = f"{max(lo, 0)}-{lo + 25}"
        cell = table.setdefault(verdict, {}).setdefault(b, dict(named=0, right=0))
        cell["named"] += 1
        cell["right"] += int(right)
    return table


def main():
    ap = argparse.ArgumentParser(description="Score host-tool diagnose on World N datasets")
    ap.add_argument("--tool", required=True)
    ap.add_argument("--dir", required=True, action="append")
    ap.add_argument("--json")
    ap.add_argument("--reliability")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--timeout-s", type=float, default=600.0)
    ap.add_argument("--quiet", action="store_true", help="no per-dataset lines")
    a = ap.parse_args()
    t0 = time.time()
    rows = score_dirs(a.tool, a.dir, a.workers, a.timeout_s)
    if not rows:
        sys.exit(f"no datasets (directories with truth.json) in {a.dir}")
    per_class, tot = report(rows, a.quiet)
    tot["seconds"] = round(time.time() - t0, 1)
    print(f"scored {len(rows)} datasets (+{tot['twins']} twins) in {tot['seconds']} s")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(dict(tool=a.tool, dirs=a.dir, datasets=rows, per_class=per_class, totals=tot), f, indent=1)
    if a.reliability:
        with open(a.reliability, "w") as f:
            json.dump(dict(bins="heldout.shrink_pct: 0-25, 25-50, 50-75, 75-100 (below 0 -> 0-25, "
                                "100 and above -> 75-100)", table=reliability(rows)), f, indent=1, sort_keys=True)


if __name__ == "__main__":
    main()
