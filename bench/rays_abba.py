#!/usr/bin/env python3
"""Time two builds of `cmlt-bench` against each other on `cmlt-bench rays`.

    python3 bench/rays_abba.py OLD NEW CYCLES SCENES SETS KERNELS [THREADS] [SECONDS] [BASE] [ROUNDS]
    python3 bench/rays_abba.py /tmp/cmlt-old target/release/cmlt-bench 2 mesh,veach-mis \\
        primary,mtm8,mtm16,shadow,diffuse ours-packet8,ours-packet16

The two binaries run in turns, A B B A then B A A B, CYCLES times, so a
drift of the shared machine falls on both alike. Every run also times
Embree's `rtcIntersect1` (`embree-1`, so both binaries must be built with
`--features embree`), and each figure is divided by that run's `embree-1`
figure of the same cell: the ratio cancels most of the machine's
run-to-run swing. BASE names another baseline kernel (e.g. `embree-8`
when comparing packets of 8: measured next to them, it tracks the same
cache state). ROUNDS > 1 has each run measure every kernel ROUNDS times
in turn and report its best (interference only ever slows a run down).
Prints per cell the median of those ratios for each binary and NEW ÷ OLD.

Run from the repository root (the shared scenes are read from
`tests/scenes`).
"""
import collections
import re
import statistics
import subprocess
import sys


def main():
    if len(sys.argv) < 7:
        sys.exit(__doc__)
    old, new, cycles, scenes, sets, kernels = sys.argv[1:7]
    threads = sys.argv[7] if len(sys.argv) > 7 else "1"
    seconds = sys.argv[8] if len(sys.argv) > 8 else "0.15"
    base_kernel = sys.argv[9] if len(sys.argv) > 9 else "embree-1"
    rounds = sys.argv[10] if len(sys.argv) > 10 else "1"
    res = [collections.defaultdict(list), collections.defaultdict(list)]

    def run(which):
        binary = (old, new)[which]
        out = subprocess.run(
            [binary, "rays", "--scenes", scenes, "--sets", sets,
             "--kernels", kernels + "," + base_kernel, "--threads", threads,
             "--time", seconds, "--rounds", rounds, "--clock", "cpu"],
            capture_output=True, text=True, check=True).stdout
        for line in out.splitlines():
            # "        mesh     mtm8 1T  ours-packet8 9.39  embree-1 7.30  | best ..."
            m = re.match(r"\s*(\S+)\s+(\S+)\s+(\d+)T\s+(.*?)\s*\|", line)
            if not m:
                continue
            figures = dict(re.findall(r"(\S+) ([0-9.]+)", m.group(4)))
            base = float(figures.pop(base_kernel))
            for kernel, v in figures.items():
                res[which][(m.group(1), m.group(2), m.group(3), kernel)].append(float(v) / base)

    for c in range(int(cycles)):
        for which in ([0, 1, 1, 0] if c % 2 == 0 else [1, 0, 0, 1]):
            run(which)
    for cell in sorted(res[0]):
        a = statistics.median(res[0][cell])
        b = statistics.median(res[1][cell])
        scene, ray_set, t, kernel = cell
        print(f"{scene:12} {ray_set:8} {t}T {kernel:14} old {a:6.3f} new {b:6.3f}  new/old {b / a:6.3f}")


if __name__ == "__main__":
    main()
