"""equal_time.py LOG: equal_time.sh's lines as tables, mean over seeds per budget and renderer.

First relMSE x CPU seconds (the figure the machine's load changes least), then plain relMSE, then the
CPU seconds each run got; a last line per budget gives each renderer's relMSE x CPU s over the first
BINS renderer's (below 1 = less error than it for the same CPU).
"""
import collections
import sys

rows = collections.defaultdict(list)  # (budget, name) -> [(relmse, cpu)]
for line in open(sys.argv[1]):
    f = line.split()
    if len(f) < 10 or f[4] != "load" or "relMSE" not in f:
        continue
    name, budget = f[1], int(f[2])
    cpu = float(f[8]) + float(f[9])
    rows[(budget, name)].append((float(f[f.index("relMSE") + 1]), cpu))

budgets = sorted({b for b, _ in rows})
names = []
for _, n in rows:
    if n not in names:
        names.append(n)


def mean(xs):
    return sum(xs) / len(xs)


for title, fn in (("relMSE x CPU s", lambda r: r[0] * r[1]), ("relMSE", lambda r: r[0]),
                  ("CPU s", lambda r: r[1])):
    print("\n%s\n| budget | %s |" % (title, " | ".join(names)))
    print("|---" * (len(names) + 1) + "|")
    for b in budgets:
        cells = []
        for n in names:
            r = rows.get((b, n))
            cells.append("%.3g (%d)" % (mean([fn(x) for x in r]), len(r)) if r else "—")
        print("| %d s | %s |" % (b, " | ".join(cells)))
mlts = [n for n in names if n.startswith("mlt-")]
if mlts:
    ref = mlts[0]
    print("\nrelMSE x CPU s over %s's" % ref)
    for b in budgets:
        if (b, ref) not in rows:
            continue
        base = mean([x[0] * x[1] for x in rows[(b, ref)]])
        print("%d s: %s" % (b, ", ".join("%s %.2f" % (n, mean([x[0] * x[1] for x in rows[(b, n)]]) / base)
                                        for n in names if (b, n) in rows)))
