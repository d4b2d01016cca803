#!/usr/bin/env python3
"""The two tables of docs/accuracy.md from twelve-scenes.sh's CSVs.

Issue 51: per scene, path-space MLT's and CMLT's channel means over the
reference's (mean of the seeds at the larger budget, each seed's worst
channel in brackets, primary-sample MLT's beside them: known unbiased),
the relMSE ratio of the chains alone between 16 and 64 mutations per
pixel (twelve-scenes-mpp-*: about 4 when the error falls as 1/N), and
the ratio between the two budgets T and 4T (mean of the seeds at T
over that at 4T, with the passes' image; the mutations/px ratio beside
it, since each render's set-up takes part of its budget).
Issue 53: per scene, relMSE of MLT and of path-space MLT over BDPT's at
equal time (above 1: BDPT better), at T and at 4T.
   python3 docs/accuracy/twelve-scenes-table.py [docs/accuracy] [name]
"""
import csv
import os
import sys

DIR = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__))
NAME = sys.argv[2] if len(sys.argv) > 2 else "twelve-scenes"
PATH_MLT, PATH_CMLT, MLT, BDPT = "mlt:level1=path", "cmlt:level1=path", "mlt", "bdpt"

refs = {}
with open(os.path.join(DIR, f"{NAME}-reference.csv")) as f:
    for r in csv.DictReader(f):
        refs[r["method"]] = [float(r[c]) for c in ("mean_r", "mean_g", "mean_b")]


def load(scene, name=NAME):
    rows = {}
    with open(os.path.join(DIR, f"{name}-{scene}.csv")) as f:
        for r in csv.DictReader(f):
            # --samples runs leave budget_s empty: their budget is samples.
            budget = float(r["budget_s"] or r["samples"])
            rows.setdefault((r["method"], budget), []).append(r)
    return rows


def mean(xs):
    return sum(xs) / len(xs)


def avg(rows, key):
    return mean([float(r[key]) for r in rows])


def dev(rows, ref):
    """Channel means over the reference's, and the largest |deviation|."""
    ratios = [avg(rows, c) / ref[i] for i, c in enumerate(("mean_r", "mean_g", "mean_b"))]
    return ratios, max(abs(x - 1) for x in ratios)


def spread(rows, ref):
    """Each seed's largest channel deviation, signed, in %."""
    out = []
    for r in rows:
        d = [float(r[c]) / ref[i] - 1 for i, c in enumerate(("mean_r", "mean_g", "mean_b"))]
        out.append(100 * max(d, key=abs))
    return "/".join(f"{x:+.1f}" for x in out)


t51 = ["| scene | path MLT mean/ref r g b (seeds' worst channel, %) | path CMLT mean/ref | primary MLT mean/ref "
       "| relMSE 16÷64 mutations/px, chains alone: path MLT / path CMLT / primary MLT "
       "| relMSE T÷4T path MLT (mutations ratio) | path CMLT | primary MLT |",
       "|---|---|---|---|---|---|---|---|"]
MPP = ("mlt:level1=path:pass_records=0", "cmlt:level1=path:pass_records=0", "mlt:pass_records=0")
t53 = ["| scene | MLT ÷ BDPT, T | path MLT ÷ BDPT, T | MLT ÷ BDPT, 4T | path MLT ÷ BDPT, 4T |",
       "|---|---|---|---|---|"]
for scene, ref in refs.items():
    try:
        rows = load(scene)
    except FileNotFoundError:
        continue
    budgets = sorted({b for (_, b) in rows})
    lo, hi = budgets[0], budgets[-1]
    cells = []
    for m in (PATH_MLT, PATH_CMLT, MLT):
        ratios, worst = dev(rows[(m, hi)], ref)
        mark = "" if worst <= 0.02 else " **✗**"
        extra = f" ({spread(rows[(m, hi)], ref)})" if m != MLT else ""
        cells.append(" ".join(f"{x:.3f}" for x in ratios) + extra + mark)
    try:
        mpp = load(scene, NAME + "-mpp")
        cells.append(" / ".join(f"{avg(mpp[(m, 16.0)], 'rel_mse') / avg(mpp[(m, 64.0)], 'rel_mse'):.2f}" for m in MPP))
    except (FileNotFoundError, KeyError):
        cells.append("—")
    for m in (PATH_MLT, PATH_CMLT, MLT):
        e = avg(rows[(m, lo)], "rel_mse") / avg(rows[(m, hi)], "rel_mse")
        n = avg(rows[(m, hi)], "samples") / avg(rows[(m, lo)], "samples")
        cells.append(f"{e:.2f} ({n:.2f})")
    t51.append(f"| {scene} | " + " | ".join(cells) + " |")
    r53 = []
    for b in (lo, hi):
        base = avg(rows[(BDPT, b)], "rel_mse")
        for m in (MLT, PATH_MLT):
            r53.append(avg(rows[(m, b)], "rel_mse") / base)
    t53.append(f"| {scene} | " + " | ".join(f"{x:.2f}" for x in (r53[0], r53[1], r53[2], r53[3])) + " |")
print(f"Budgets {lo:g} s and {hi:g} s.\n")
print("\n".join(t51))
print()
print("\n".join(t53))
