"""breakdown.py LOG: breakdown.sh's lines as a table, per renderer (mean over seeds).

chain rate: mutations per CPU second of the chains alone, (timed mutations − set-up mutations) over
(timed CPU − set-up CPU); set-up share: set-up CPU over timed CPU; relMSE x CPU s of the timed run;
relMSE at MPP mutations per pixel (error per mutation).
"""
import collections
import sys

runs = collections.defaultdict(dict)  # (name, seed) -> kind -> (cpu, mutations, relmse)
for line in open(sys.argv[1]):
    f = line.split()
    if len(f) < 11 or f[4] != "wall_cpu":
        continue
    runs[(f[1], f[3])][f[2]] = (float(f[6]), float(f[8]), float(f[10]))

by_name = collections.defaultdict(list)
for (name, seed), k in sorted(runs.items()):
    if not all(x in k for x in ("setup", "timed", "mpp")):
        continue
    (sc, sm, _), (tc, tm, te), (_, _, me) = k["setup"], k["timed"], k["mpp"]
    rate = (tm - sm) / (tc - sc) / 1e6
    by_name[name].append((rate, 1e6 / rate / 1e6, sc, sc / tc, tc, te, te * tc, me))

cols = ["M mut/CPU s", "us/mutation", "set-up CPU s", "set-up share", "timed CPU s", "relMSE",
        "relMSE x CPU s", "relMSE @MPP"]
print("| renderer | " + " | ".join(cols) + " |")
print("|---" * (len(cols) + 1) + "|")
for name, rows in by_name.items():
    mean = [sum(r[i] for r in rows) / len(rows) for i in range(len(cols))]
    print("| %s (%d seeds) | %s |" % (name, len(rows), " | ".join("%.3g" % v for v in mean)))
