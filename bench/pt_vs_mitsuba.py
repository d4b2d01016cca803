#!/usr/bin/env python3
"""PT paths/s of cmlt against Mitsuba 3 on the same scene, spp and threads.

Usage: bench/pt_vs_mitsuba.py [--scene tests/scenes/cornell-box/scene.xml] [--spp 64] [--threads 2]

Installs nothing itself; run bench/setup_mitsuba.sh first (creates
bench/.venv with `mitsuba`, and installs Debian's libllvm19 for llvm_ad_rgb).
Prints, per renderer, wall time, M paths/s (pixels x spp / render time; for
Mitsuba the time of a second, warm render so JIT compilation is excluded),
and the ratio cmlt / Mitsuba, all measured in this one run.
"""
import argparse
import glob
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_mitsuba(variant, scene, spp, threads):
    code = f"""
import time, mitsuba as mi
mi.set_variant({variant!r})
try:
    import drjit as dr
    dr.set_thread_count({threads})
except Exception:
    pass
s = mi.load_file({scene!r})
w, h = s.sensors()[0].film().size()
img = mi.render(s, spp={spp}, seed=0)
if hasattr(img, 'numpy'): img.numpy()
t = time.perf_counter()
img = mi.render(s, spp={spp}, seed=1)
if hasattr(img, 'numpy'): img.numpy()
dt = time.perf_counter() - t
print("RESULT", w * h * {spp} / dt / 1e6, dt)
"""
    env = dict(os.environ)
    libs = sorted(glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM-19.so*")) + sorted(glob.glob("/usr/lib/llvm-19/lib/libLLVM*.so*"))
    if libs and "DRJIT_LIBLLVM_PATH" not in env:
        env["DRJIT_LIBLLVM_PATH"] = libs[0]
    py = os.path.join(ROOT, "bench", ".venv", "bin", "python")
    out = subprocess.run([py, "-c", code], capture_output=True, text=True, env=env)
    m = re.search(r"RESULT (\S+) (\S+)", out.stdout)
    if not m:
        return None, out.stderr.strip().splitlines()[-1:] or ["failed"]
    return float(m.group(1)), float(m.group(2))


def run_cmlt(scene, spp, threads):
    exe = os.path.join(ROOT, "target", "release", "cmlt")
    subprocess.run(["cargo", "build", "--release", "-p", "cmlt-cli"], cwd=ROOT, check=True)
    out = subprocess.run(
        [exe, "render", scene, "--method", "pt", "--spp", str(spp), "--threads", str(threads),
         "--quiet", "-o", os.path.join(ROOT, "target", "bench-pt.exr")],
        capture_output=True, text=True, check=True)
    m = re.search(r"in (\S+) s: (\S+) M samples/s, (\S+) Mrays/s", out.stdout)
    return float(m.group(2)), float(m.group(1)), float(m.group(3))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default=os.path.join(ROOT, "tests/scenes/cornell-box/scene.xml"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    ours, wall, mrays = run_cmlt(a.scene, a.spp, a.threads)
    print(f"cmlt pt          : {ours:7.3f} M paths/s ({wall:.2f} s, {mrays:.1f} Mrays/s)")
    for variant in ["scalar_rgb", "llvm_ad_rgb"]:
        r, dt = run_mitsuba(variant, a.scene, a.spp, a.threads)
        if r is None:
            print(f"mitsuba {variant:11s}: unavailable ({dt[0] if dt else ''})")
        else:
            print(f"mitsuba {variant:11s}: {r:7.3f} M paths/s ({dt:.2f} s)  ratio cmlt/mitsuba = {ours / r:.2f}")


if __name__ == "__main__":
    sys.exit(main())
