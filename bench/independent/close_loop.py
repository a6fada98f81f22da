#!/usr/bin/env python3
"""Close the loop of `host-tool diagnose --next-runs` on an independent generator's datasets
(Python 3 standard library only).

    python3 bench/independent/close_loop.py --tool target/release/host-tool \
        --gen bench/independent/world_d/gen.py --dir /tmp/wd1 [--rounds 2] [--json out.json]

For every DIR/<class>-<seed>-<k>/ (a directory holding truth.json), on a copy of it:
diagnose the calibration and test runs with `--next-runs next.toml --json -`; while the verdict
leaves rivals in play (`in_play`) and a scenario was written, drive it in the dataset's own world
(`GEN --drive next.toml --dataset COPY`, one more run_<n>.csv) and diagnose again with every run,
at most --rounds times. Then, as the issue asks: of the open first verdicts on datasets whose
effect is visible (truth.json's `visible`), how many were settled right, settled wrong (another
effect named), settled as none, or are still open, with the extra manoeuvres; and whether any
control became an effect. The generator's datasets are left as they are.
"""
import argparse
import concurrent.futures
import json
import os
import shutil
import subprocess
import sys
import tempfile

EFFECTS = {"inner-drag", "sinkage-bulldozing", "angular-slip", "slip-track", "braked-inner",
           "current-offset", "motor-heating", "slope"}


def diagnose(tool, d, next_toml):
    runs = sorted((f for f in os.listdir(d) if f.startswith("run_") and f.endswith(".csv")),
                  key=lambda f: int(f[4:-4]))
    cmd = [tool, "diagnose", "--rover", os.path.join(d, "rover.toml"),
           "--calibration", os.path.join(d, "cal_0.csv"), os.path.join(d, "cal_1.csv"),
           "--runs"] + [os.path.join(d, f) for f in runs] + \
          ["--next-runs", next_toml, "--force", "--json", "-"]
    p = subprocess.run(cmd, capture_output=True, text=True, check=False)
    try:
        return json.loads(p.stdout)
    except json.JSONDecodeError:
        return {"effect": "error", "error": p.stderr[-400:]}


def close_one(tool, gen, src, rounds):
    with tempfile.TemporaryDirectory() as tmp:
        d = os.path.join(tmp, os.path.basename(src))
        shutil.copytree(src, d)
        next_toml = os.path.join(tmp, "next.toml")
        first = diagnose(tool, d, next_toml)
        verdicts, manoeuvres = [first["effect"]], []
        opened = bool(first.get("in_play"))
        cur = first
        for _ in range(rounds):
            if not cur.get("in_play") or not cur.get("next_runs"):
                break
            p = subprocess.run([sys.executable, gen, "--drive", next_toml, "--dataset", d],
                               capture_output=True, text=True, check=False)
            if p.returncode != 0:
                verdicts.append("error")
                manoeuvres.append(0)
                break
            manoeuvres.append(sum(r["repeats"] for r in cur["next_runs"]))
            cur = diagnose(tool, d, next_toml)
            verdicts.append(cur["effect"])
        return dict(dataset=os.path.basename(src), opened=opened, verdicts=verdicts,
                    manoeuvres=manoeuvres, still_open=bool(cur.get("in_play")))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tool", required=True)
    ap.add_argument("--gen", required=True, help="the generator's gen.py (it must have --drive)")
    ap.add_argument("--dir", required=True)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json")
    a = ap.parse_args()
    dsets = sorted(os.path.join(a.dir, n) for n in os.listdir(a.dir)
                   if os.path.isfile(os.path.join(a.dir, n, "truth.json")))
    if not dsets:
        sys.exit(f"no datasets (directories with truth.json) in {a.dir}")
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.workers) as ex:
        results = list(ex.map(lambda d: close_one(a.tool, a.gen, d, a.rounds), dsets))
    tally = dict(open_visible=0, driven=0, settled_right=0, settled_wrong=0, settled_none=0,
                 still_open=0, manoeuvres=0, max_manoeuvres=0, open_controls=0,
                 controls_became_effect=0, new_wrong=0)
    for d, r in zip(dsets, results):
        truth = json.load(open(os.path.join(d, "truth.json")))
        effect, last = truth["effect"], r["verdicts"][-1]
        r["truth"], r["visible"] = effect, truth.get("visible")
        first_wrong = r["verdicts"][0] in EFFECTS and r["verdicts"][0] != effect
        last_wrong = last in EFFECTS and last != effect
        tally["new_wrong"] += last_wrong and not first_wrong
        if not r["opened"]:
            continue
        if effect == "none":
            tally["open_controls"] += 1
            tally["controls_became_effect"] += last in EFFECTS
            continue
        if not truth.get("visible"):
            continue
        tally["open_visible"] += 1
        tally["driven"] += bool(r["manoeuvres"])
        tally["manoeuvres"] += sum(r["manoeuvres"])
        tally["max_manoeuvres"] = max(tally["max_manoeuvres"], sum(r["manoeuvres"]))
        if r["still_open"]:
            tally["still_open"] += 1
        elif last == effect:
            tally["settled_right"] += 1
        elif last in EFFECTS:
            tally["settled_wrong"] += 1
        elif last == "none":
            tally["settled_none"] += 1
        else:
            tally["still_open"] += 1
    for r in results:
        if r["opened"]:
            print(f"{r['dataset']:30} visible={r['visible']!s:5} {' → '.join(r['verdicts']):60} "
                  f"manoeuvres {r['manoeuvres']} {'open' if r['still_open'] else 'settled'}")
    t = tally
    print(f"\nof {t['open_visible']} open verdicts on visible effects: {t['driven']} had something "
          f"to drive; settled right {t['settled_right']}, wrong {t['settled_wrong']} (bar 0), as "
          f"none {t['settled_none']}, still open {t['still_open']}; {t['manoeuvres']} extra "
          f"manoeuvres (most {t['max_manoeuvres']}); controls: {t['open_controls']} open, "
          f"{t['controls_became_effect']} became an effect (bar 0); new wrong names "
          f"{t['new_wrong']}")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(dict(tally=tally, datasets=results), f, indent=1)


if __name__ == "__main__":
    main()
