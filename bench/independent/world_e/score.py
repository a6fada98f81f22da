#!/usr/bin/env python3
"""Score a diagnosis tool on World E datasets.

    python3 score.py --tool PATH --dir DIR [--json F] [--workers 2]

For every dataset DIR/<class>-<seed>-<k>/ it runs

    PATH diagnose --rover D/rover.toml --calibration D/cal_0.csv D/cal_1.csv
                  --runs D/run_0.csv D/run_1.csv D/run_2.csv --json -

(the tool never sees truth.json), reads the verdict from the key `effect` of the JSON on stdout
(an effect id, `none`, `ambiguous` or `baseline-misfit`; exit code 1 may still carry JSON) and
compares it with truth.json.

Outcomes per dataset:
  right      the verdict is the true effect (for a control: `none`)
  wrong      the verdict is a catalogued effect that is not the truth (any effect on a control)
  not-named  anything else: `none` on an effect, `ambiguous`, `baseline-misfit`, no JSON, or a
             verdict outside the catalogue
"""

import argparse
import concurrent.futures
import json
import os
import subprocess
import sys

# The catalogue's ids and classes, as the generator writes them into truth.json.
from gen import CLASSES, EFFECTS  # noqa: E402 (gen.py sits beside this script)


def run_tool(tool, d):
    cmd = [tool, "diagnose", "--rover", os.path.join(d, "rover.toml"),
           "--calibration", os.path.join(d, "cal_0.csv"), os.path.join(d, "cal_1.csv"),
           "--runs", os.path.join(d, "run_0.csv"), os.path.join(d, "run_1.csv"),
           os.path.join(d, "run_2.csv"), "--json", "-"]
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=600)
    except subprocess.TimeoutExpired:
        return None, None, "timeout", ""
    verdict, regime = None, None
    try:
        js = json.loads(p.stdout.decode("utf-8", "replace"))
        verdict = js.get("effect")
        regime = js.get("regime")
    except (ValueError, AttributeError):
        pass
    err = p.stderr.decode("utf-8", "replace").strip().splitlines()
    return verdict, regime, p.returncode, (err[-1] if err else "")


def outcome(truth_effect, verdict):
    if truth_effect == "none":
        if verdict in EFFECTS:
            return "wrong"
        return "right" if verdict == "none" else "not-named"
    if verdict == truth_effect:
        return "right"
    if verdict in EFFECTS:
        return "wrong"
    return "not-named"


def main():
    ap = argparse.ArgumentParser(description="Score a diagnosis tool on World E datasets.")
    ap.add_argument("--tool", required=True)
    ap.add_argument("--dir", required=True)
    ap.add_argument("--json", dest="json_out")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()

    datasets = []
    for name in sorted(os.listdir(args.dir)):
        d = os.path.join(args.dir, name)
        tp = os.path.join(d, "truth.json")
        if os.path.isdir(d) and os.path.exists(tp):
            with open(tp) as f:
                truth = json.load(f)
            cls = name.rsplit("-", 2)[0]
            datasets.append((name, d, cls, truth))
    if not datasets:
        sys.exit("no datasets under %s" % args.dir)

    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.workers)) as ex:
        results = list(ex.map(lambda t: run_tool(args.tool, t[1]), datasets))

    rows = []
    for (name, d, cls, truth), (verdict, regime, rc, err) in zip(datasets, results):
        v = verdict if verdict is not None else "(no json: exit %s%s)" % (rc, ": " + err if err else "")
        rows.append({
            "dataset": name,
            "cls": cls,
            "truth": truth["effect"],
            "verdict": v,
            "visible": bool(truth.get("visible", False)),
            "visible_local": bool(truth.get("visible_local", False)),
            "outcome": outcome(truth["effect"], verdict),
            "truth_regime": truth.get("regime"),
            "verdict_regime": regime,
            "rover": truth.get("rover"),
            "twin_rms_w": truth.get("twin_rms_w"),
            "exit_code": rc,
        })

    print("%-20s %3s %5s %5s %9s %4s  %s" % ("class", "n", "right", "wrong", "not-named",
                                            "vis", "verdicts"))
    classes = [c for c in CLASSES if any(r["cls"] == c for r in rows)]
    classes += sorted({r["cls"] for r in rows} - set(classes))
    for c in classes:
        rs = [r for r in rows if r["cls"] == c]
        counts = {}
        for r in rs:
            counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
        vc = ", ".join("%s %d" % (k, n) for k, n in sorted(counts.items(), key=lambda kv: -kv[1]))
        print("%-20s %3d %5d %5d %9d %4s  %s" % (
            c, len(rs), sum(r["outcome"] == "right" for r in rs),
            sum(r["outcome"] == "wrong" for r in rs),
            sum(r["outcome"] == "not-named" for r in rs),
            "-" if c == "control" else str(sum(r["visible"] for r in rs)), vc))

    n = len(rows)
    wrong = sum(r["outcome"] == "wrong" for r in rows)
    ctrl = [r for r in rows if r["truth"] == "none"]
    eff = [r for r in rows if r["truth"] != "none"]
    vis = [r for r in eff if r["visible"]]
    vis_right = sum(r["outcome"] == "right" for r in vis)
    eff_right = sum(r["outcome"] == "right" for r in eff)
    print()
    print("wrong names: %d of %d (%.1f %%)" % (wrong, n, 100.0 * wrong / n if n else 0.0))
    print("controls named an effect: %d of %d" % (sum(r["outcome"] == "wrong" for r in ctrl),
                                                   len(ctrl)))
    print("visible effects named right: %d of %d (%.1f %%)" % (
        vis_right, len(vis), 100.0 * vis_right / len(vis) if vis else 0.0))
    print("all effects named right: %d of %d" % (eff_right, len(eff)))

    if args.json_out:
        with open(args.json_out, "w") as f:
            json.dump({"tool": args.tool, "dir": args.dir, "rows": rows,
                       "totals": {"datasets": n, "wrong_names": wrong,
                                  "controls": len(ctrl),
                                  "controls_named_effect":
                                      sum(r["outcome"] == "wrong" for r in ctrl),
                                  "visible_effects": len(vis),
                                  "visible_effects_named_right": vis_right,
                                  "effects": len(eff), "effects_named_right": eff_right}},
                      f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
