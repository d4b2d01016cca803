#!/usr/bin/env python3
"""Time two builds of `cmlt` against each other on whole renders.

    python3 bench/estimators_abba.py OLD NEW CYCLES [SCENES] [METHODS] [THREADS] [RES]
    python3 bench/estimators_abba.py /tmp/cmlt-old target/release/cmlt 3 \\
        cornell-box,veach-mis,veach-bidir,veach-ajar pt,bdpt,mlt,cmlt 1 64

Each run renders a fixed budget (so both binaries do the same work when
their images agree: check with `--reference`) and reports its throughput:
M samples/s for PT and BDPT, M mutations/s for MLT and CMLT, as the render's
own closing line prints it (the render only; MLT's bootstrap is excluded).
The two binaries run in turns, A B B A then B A A B, CYCLES times, so a
drift of the shared machine falls on both alike. Prints per cell the median
throughput of each binary and NEW / OLD (> 1: NEW is faster).

Run from the repository root (scenes are read from `tests/scenes`).
"""
import collections
import re
import statistics
import subprocess
import sys

# A budget per method that takes one to a few seconds at 64x64 on one
# thread (MLT's bootstrap, excluded from its figure, takes about 0.5 s).
BUDGET = {
    "pt": ["--spp", "64"],
    "bdpt": ["--spp", "32"],
    "mlt": ["--mutations-per-pixel", "128"],
    "cmlt": ["--mutations-per-pixel", "64"],
}


def throughput(out):
    """The render's own figure: M samples/s or M mutations/s."""
    m = re.search(r"([0-9.]+) M (?:samples|mutations)/s", out)
    if not m:
        raise RuntimeError("no throughput in output:\n" + out)
    return float(m.group(1))


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    old, new, cycles = sys.argv[1:4]
    scenes = (sys.argv[4] if len(sys.argv) > 4 else
              "cornell-box,veach-mis,veach-bidir,veach-ajar").split(",")
    methods = (sys.argv[5] if len(sys.argv) > 5 else "pt,bdpt,mlt,cmlt").split(",")
    threads = sys.argv[6] if len(sys.argv) > 6 else "1"
    res = sys.argv[7] if len(sys.argv) > 7 else "64"
    figures = [collections.defaultdict(list), collections.defaultdict(list)]

    def run(which, scene, method):
        cmd = [(old, new)[which], "render", f"tests/scenes/{scene}/scene.xml",
               "--method", method, *BUDGET[method], "--threads", threads,
               "-D", f"resx={res}", "-D", f"resy={res}", "--seed", "1",
               "-o", "/tmp/estimators_abba.exr"]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        figures[which][(scene, method)].append(throughput(out.stdout + out.stderr))

    for c in range(int(cycles)):
        for scene in scenes:
            for method in methods:
                for which in ([0, 1, 1, 0] if c % 2 == 0 else [1, 0, 0, 1]):
                    run(which, scene, method)
    print(f"{'scene':>12} {'method':>6} {'old':>8} {'new':>8} {'new/old':>8}")
    for cell in sorted(figures[0]):
        a = statistics.median(figures[0][cell])
        b = statistics.median(figures[1][cell])
        print(f"{cell[0]:>12} {cell[1]:>6} {a:8.3f} {b:8.3f} {b / a:8.3f}")


if __name__ == "__main__":
    main()
