"""The figures of docs/cluster.md: parts per second on a local Ray instance
with 1 and 2 workers (alternating runs), bytes per part, seconds to merge,
and the bootstrap's cost and b's spread across parts.

    CMLT_BIN=target/release/cmlt PYTHONPATH=python python3 python/bench_cluster.py \
        [--res 128] [--parts 4] [--spp 16] [--rounds 2]
"""

import argparse
import os
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import ray

from cmlt_ray import RenderJob, render

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "tests" / "scenes" / "cornell-box" / "scene.xml"


def header(path: Path) -> dict:
    """The counters of a part state (the format in cli/src/state.rs)."""
    data = path.read_bytes()
    off = 20
    part, parts, frame, w, h, seed, pseed, scene = struct.unpack_from("<IIQIIQQQ", data, off)
    off += struct.calcsize("<IIQIIQQQ")
    strings = []
    for _ in range(2):
        (n,) = struct.unpack_from("<I", data, off)
        strings.append(data[off + 4: off + 4 + n].decode())
        off += 4 + n
    passes, mutations, records, nonfinite, b, tally, depths = struct.unpack_from("<QQQQdQI", data, off)
    off += struct.calcsize("<QQQQdQI") + 8 * depths
    seconds, boot = struct.unpack_from("<dd", data, off)
    return dict(part=part, b=b, mutations=mutations, seconds=seconds, bootstrap=boot,
                bytes=len(data), width=w, height=h)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--parts", type=int, default=4)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--method", default="cmlt")
    a = p.parse_args()
    cmlt = os.path.abspath(os.environ.get("CMLT_BIN", ROOT / "target" / "release" / "cmlt"))
    tmp = Path(tempfile.mkdtemp(prefix="cmlt-bench-"))
    rates = {1: [], 2: []}
    last = None
    for r in range(a.rounds):
        for workers in (1, 2):
            ray.init(num_cpus=workers, log_to_driver=False)
            states = tmp / f"states-{workers}-{r}"
            job = RenderJob(scene=str(SCENE), parts=a.parts, output=str(tmp / "m.exr"),
                            method=a.method, spp=a.spp, seed=r, cmlt=cmlt,
                            defines=[f"resx={a.res}", f"resy={a.res}"], states_dir=str(states))
            info = render(job, progress=None)
            ray.shutdown()
            rate = a.parts / info["parts_seconds"]
            rates[workers].append(rate)
            print(f"round {r}, {workers} worker(s): {a.parts} parts in {info['parts_seconds']:.2f} s "
                  f"= {rate:.3f} parts/s; merge {info['merge_seconds']:.3f} s", flush=True)
            last = (states, info)
    for w in (1, 2):
        print(f"{w} worker(s): {statistics.mean(rates[w]):.3f} parts/s (runs {['%.3f' % x for x in rates[w]]})")
    print(f"speed-up 2 vs 1: {statistics.mean(rates[2]) / statistics.mean(rates[1]):.2f}")
    states, info = last
    hs = [header(f) for f in sorted(states.glob("*.state"))]
    bs = [h["b"] for h in hs]
    print(f"state: {hs[0]['bytes']} bytes per part at {hs[0]['width']}x{hs[0]['height']} "
          f"({hs[0]['bytes'] / (hs[0]['width'] * hs[0]['height']):.1f} bytes/pixel)")
    print(f"per part: render {statistics.mean(h['seconds'] for h in hs):.2f} s, of which bootstrap "
          f"{statistics.mean(h['bootstrap'] for h in hs):.2f} s; "
          f"{statistics.mean(h['mutations'] for h in hs) / (a.res * a.res):.1f} mutations/pixel")
    if len(bs) > 1 and statistics.mean(bs) > 0:
        print(f"b across parts: mean {statistics.mean(bs):.5f}, relative sd "
              f"{statistics.stdev(bs) / statistics.mean(bs) * 100:.2f}%")
    # Merge time against the part count: the same states repeated under
    # new indices would be refused, so time cmlt merge on k real parts.
    files = sorted(states.glob("*.state"))
    t0 = time.monotonic()
    subprocess.run([cmlt, "merge", *map(str, files), "-o", str(tmp / "m.exr")], check=True,
                   capture_output=True)
    print(f"cmlt merge of {len(files)} parts: {time.monotonic() - t0:.3f} s wall (process included)")


if __name__ == "__main__":
    sys.exit(main())
