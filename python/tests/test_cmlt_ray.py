"""The Ray driver on a local Ray instance (2 CPUs): two parts of the
Cornell box merged against a single-process render of the same total
budget, a part killed mid-render retried, and a refused part failing the
render without an image.

Needs the ``cmlt`` binary: ``$CMLT_BIN``, else the repository's
target/release/cmlt. Run from the repository root:
``PYTHONPATH=python python3 -m unittest discover -s python/tests``.
"""

import os
import re
import stat
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))

import ray  # noqa: E402

from cmlt_ray import PartFailed, RenderJob, render  # noqa: E402

SCENE = ROOT / "tests" / "scenes" / "cornell-box" / "scene.xml"
REFERENCE = ROOT / "tests" / "scenes" / "cornell-box" / "reference.exr"
DEFINES = ["resx=32", "resy=32"]


def cmlt_binary() -> str:
    path = os.path.abspath(os.environ.get("CMLT_BIN") or ROOT / "target" / "release" / "cmlt")
    if not os.access(path, os.X_OK):
        raise RuntimeError(f"no cmlt binary at {path}: build it or set CMLT_BIN")
    return path


def scores(output: str):
    """relMSE and the mean ratios from cmlt's 'vs reference:' line."""
    m = re.search(
        r"vs reference: relMSE ([0-9.eE+-]+), RMSE [0-9.eE+-]+; "
        r"mean ratio \(([0-9.]+), ([0-9.]+), ([0-9.]+)\)",
        output,
    )
    if not m:
        raise AssertionError(f"no comparison in: {output}")
    return float(m.group(1)), [float(m.group(i)) for i in (2, 3, 4)]


class DriverOnLocalRay(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.cmlt = cmlt_binary()
        ray.init(num_cpus=2, log_to_driver=False)
        cls.tmp = tempfile.TemporaryDirectory(prefix="cmlt-ray-test-")
        cls.dir = Path(cls.tmp.name)

    @classmethod
    def tearDownClass(cls):
        ray.shutdown()
        cls.tmp.cleanup()

    def job(self, **kw) -> RenderJob:
        base = dict(
            scene=str(SCENE),
            parts=2,
            output=str(self.dir / "merged.exr"),
            method="cmlt",
            spp=8,
            seed=3,
            defines=DEFINES,
            cmlt=self.cmlt,
            reference=str(REFERENCE),
            extra=["--chains", "64", "--b-passes", "16"],
        )
        base.update(kw)
        return RenderJob(**base)

    def cmlt_run(self, *args) -> str:
        p = subprocess.run([self.cmlt, *args], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        return p.stdout

    def test_two_parts_merge_like_one_render_of_twice_the_budget(self):
        states = self.dir / "states"
        info = render(self.job(states_dir=str(states)), progress=None)
        self.assertTrue(Path(self.dir / "merged.exr").is_file())
        self.assertIn("merged 2 of 2 parts (cmlt)", info["merge_output"])
        self.assertEqual(len(info["state_bytes"]), 2)
        # 48 bytes per pixel of film plus the header.
        self.assertGreater(info["state_bytes"][0], 48 * 32 * 32)
        merged_err, merged_mean = scores(info["merge_output"])
        # One part alone, and one process at the total budget (16 per pixel).
        part0 = sorted(states.glob("part-00000-*"))[0]
        part_err, _ = scores(
            self.cmlt_run("merge", str(part0), "-o", str(self.dir / "p0.exr"),
                          "--reference", str(REFERENCE))
        )
        single_err, single_mean = scores(
            self.cmlt_run("render", str(SCENE), "--method", "cmlt", "--spp", "16",
                          "--chains", "64", "--b-passes", "16", "--threads", "2", "--seed", "11", "--quiet",
                          *sum((["-D", d] for d in DEFINES), []),
                          "-o", str(self.dir / "single.exr"), "--reference", str(REFERENCE))
        )
        print(f"relMSE: part {part_err:.4f}, merged {merged_err:.4f}, single at 2x {single_err:.4f}; "
              f"mean ratios merged {merged_mean}, single {single_mean}", file=sys.stderr)
        # Means: within the spread of b at this size (a few percent; b from
        # 16 passes of 32x32 pixels).
        for r in merged_mean:
            self.assertAlmostEqual(r, 1.0, delta=0.08)
        # Two parts halve one part's error (a merge counting one part twice,
        # or only one, would not), and match the single render of 2x.
        self.assertLess(merged_err, 0.75 * part_err)
        self.assertTrue(0.4 <= merged_err / single_err <= 1.6,
                        f"merged {merged_err}, single {single_err}")

    def test_a_killed_part_is_retried(self):
        # A cmlt whose first render is killed (as by the OOM killer).
        marker = self.dir / "killed-once"
        flaky = self.dir / "flaky-cmlt"
        flaky.write_text(
            "#!/bin/sh\n"
            f'if [ "$1" = render ] && [ ! -e {marker} ]; then touch {marker}; kill -9 $$; fi\n'
            f'exec {self.cmlt} "$@"\n'
        )
        flaky.chmod(flaky.stat().st_mode | stat.S_IXUSR)
        out = self.dir / "retried.exr"
        info = render(self.job(cmlt=str(flaky), output=str(out), method="pt", spp=2,
                               reference=None, extra=[]), progress=None)
        self.assertTrue(marker.exists())
        self.assertTrue(out.is_file())
        self.assertIn("merged 2 of 2 parts (pt)", info["merge_output"])

    def test_a_refused_part_fails_the_render_and_writes_nothing(self):
        out = self.dir / "refused.exr"
        with self.assertRaises(PartFailed) as e:
            render(self.job(output=str(out), extra=["--sigma", "5"]), progress=None)
        self.assertIn("sigma", str(e.exception))
        self.assertFalse(out.exists())

    def test_frames_are_split_into_parts_and_merged_per_frame(self):
        # Two frames of an orbit, two parts each, merged per frame and
        # compared with one process's render of the sequence at the same
        # budget per frame: each merged frame is closer to its own frame
        # than to the other one, and has its mean.
        out = self.dir / "seq.exr"
        states = self.dir / "frame-states"
        job = self.job(output=str(out), method="bdpt", spp=4, reference=None, frames=2,
                       extra=["--orbit", "--orbit-degrees", "60"], states_dir=str(states))
        info = render(job, progress=None)
        self.assertEqual(len(info["state_bytes"]), 4)
        whole = self.dir / "whole.exr"
        self.cmlt_run("render", str(SCENE), "--method", "bdpt", "--spp", "8", "--quiet",
                      "--frames", "2", "--orbit", "--orbit-degrees", "60", "--threads", "1",
                      *sum((["-D", d] for d in DEFINES), []), "-o", str(whole))
        for f in range(2):
            self.assertTrue((self.dir / f"seq-{f:04}.exr").is_file())
            parts = sorted(str(p) for p in states.glob(f"frame-{f:05}-*"))
            self.assertEqual(len(parts), 2)
            err = {}
            for g in range(2):
                err[g], mean = scores(self.cmlt_run(
                    "merge", *parts, "-o", str(self.dir / "check.exr"),
                    "--reference", str(self.dir / f"whole-{g:04}.exr")))
                if g == f:
                    for r in mean:
                        self.assertAlmostEqual(r, 1.0, delta=0.1)
            self.assertLess(err[f], err[1 - f], f"frame {f}: {err}")

if __name__ == "__main__":
    unittest.main()
