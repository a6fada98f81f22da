#!/usr/bin/env python3
"""Sums `host-tool diagnose-bench` over many seeds, per part, with issue 35's bars.

    python3 bench/diagnose_seeds.py --tool target/release/host-tool --seeds 1-27 [--part both]

For each seed it runs `diagnose-bench --seed S --part P --json -` (100 datasets per part) and
prints, per part: datasets, wrong names (an effect other than the true one, or any on a dataset
without one; bar ≤ 2 %), effects named on controls and on structure-only datasets (bar 0),
effects the data can show (the twin ceiling ≥ 50 %) named right (bar ≥ 80 %), and all effects
named right; and the closed loop (issue 36): of the open verdicts on effects the data can
show, how many the suggested manoeuvres settled right, wrong (bar 0), as none, or left open, with
the extra manoeuvres; and effects named after the loop on controls and structure-only datasets
(bar 0). Python standard library only.
"""

import argparse
import json
import subprocess
import sys

SHOWN_CEILING_PCT = 50.0
EFFECTS = {
    "inner-drag", "sinkage-bulldozing", "angular-slip", "slip-track", "braked-inner",
    "current-offset", "motor-heating", "slope",
}


def seeds_of(text):
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def true_class(r):
    c = r["spec"]["class"]
    if isinstance(c, dict):  # {"effect": "inner-drag"}
        return next(iter(c.values()))
    return {"control": "none", "structure-only": "structure-only"}.get(c, c)


def tally(datasets):
    t = dict(n=0, wrong=0, control_named=0, structure_named=0, effects=0, right=0, shown=0,
             shown_right=0, errors=0)
    wrong = {}
    for r in datasets:
        cls, got = true_class(r), r["diagnosed"]
        t["n"] += 1
        if r.get("error"):
            t["errors"] += 1
        named = got in EFFECTS
        if cls in EFFECTS:
            t["effects"] += 1
            right = got == cls
            t["right"] += right
            t["wrong"] += named and not right
            if named and not right:
                wrong[f"{cls} → {got}"] = wrong.get(f"{cls} → {got}", 0) + 1
            ceiling = r.get("ceiling_shrink_pct")
            if ceiling is not None and ceiling >= SHOWN_CEILING_PCT:
                t["shown"] += 1
                t["shown_right"] += right
        else:
            t["wrong"] += named
            if named:
                wrong[f"{cls} → {got}"] = wrong.get(f"{cls} → {got}", 0) + 1
            if cls == "none":
                t["control_named"] += named
            else:
                t["structure_named"] += named
    return t, wrong


LOOP_KEYS = ("open_shown", "open_shown_driven", "settled_right", "settled_wrong", "settled_none",
             "still_open", "extra_manoeuvres", "open_without_effect", "became_effect",
             "new_wrong_names")


def pct(a, b):
    return f"{100.0 * a / b:.1f} %" if b else "–"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tool", required=True)
    ap.add_argument("--seeds", required=True, help="e.g. 1-27 or 1-9,12")
    ap.add_argument("--part", default="both", choices=["tuning", "held-out", "both"])
    ap.add_argument("--json", help="write every seed's per-part tallies here")
    args = ap.parse_args()
    parts = {}
    wrong_pairs = {}
    per_seed = []
    for seed in seeds_of(args.seeds):
        out = subprocess.run(
            [args.tool, "diagnose-bench", "--seed", str(seed), "--part", args.part, "--json", "-"],
            capture_output=True, text=True, check=False)
        try:
            report = json.loads(out.stdout)
        except json.JSONDecodeError:
            sys.exit(f"seed {seed}: no JSON (exit {out.returncode}): {out.stderr[-400:]}")
        for part in ("tuning", "held-out"):
            ds = [r for r in report["datasets"] if r["spec"]["part"] == part]
            if not ds:
                continue
            t, wrong = tally(ds)
            loop = next(p["closed_loop"] for p in report["parts"] if p["part"] == part)
            t.update({f"loop_{k}": loop[k] for k in LOOP_KEYS})
            per_seed.append(dict(seed=seed, part=part, wrong_names=wrong, **t))
            acc = parts.setdefault(part, dict.fromkeys(t, 0))
            for k, v in t.items():
                acc[k] += v
            pairs = wrong_pairs.setdefault(part, {})
            for k, v in wrong.items():
                pairs[k] = pairs.get(k, 0) + v
        print(f"seed {seed} done", file=sys.stderr)
    for part, t in parts.items():
        print(f"{part} part, seeds {args.seeds}: {t['n']} datasets"
              + (f", {t['errors']} errors" if t["errors"] else ""))
        pairs = ", ".join(f"{k} {v}" for k, v in sorted(wrong_pairs.get(part, {}).items()))
        print(f"  wrong names: {t['wrong']} = {pct(t['wrong'], t['n'])} (bar ≤ 2 %)"
              + (f": {pairs}" if pairs else ""))
        print(f"  effects named on controls: {t['control_named']}; on structure-only: "
              f"{t['structure_named']} (bar 0)")
        print(f"  effects the data can show (twin ceiling ≥ {SHOWN_CEILING_PCT:.0f} %) named right: "
              f"{t['shown_right']}/{t['shown']} = {pct(t['shown_right'], t['shown'])} (bar ≥ 80 %)")
        print(f"  all effects named right: {t['right']}/{t['effects']} = "
              f"{pct(t['right'], t['effects'])}")
        print(f"  closed loop: {t['loop_open_shown']} open verdicts on effects the data can show, "
              f"{t['loop_open_shown_driven']} with something to drive; settled right "
              f"{t['loop_settled_right']} = {pct(t['loop_settled_right'], t['loop_open_shown'])} "
              f"(bar ≥ 60 %), wrong {t['loop_settled_wrong']} (bar 0), as none "
              f"{t['loop_settled_none']}, still open {t['loop_still_open']}; "
              f"{t['loop_extra_manoeuvres']} extra manoeuvres; controls and structure-only: "
              f"{t['loop_open_without_effect']} open, {t['loop_became_effect']} became an effect "
              f"(bar 0); new wrong names {t['loop_new_wrong_names']}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(dict(parts=parts, per_seed=per_seed), f, indent=1)


if __name__ == "__main__":
    main()
