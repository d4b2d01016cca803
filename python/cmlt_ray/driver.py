"""The driver: submits the parts of one render as Ray tasks, gathers their
states and merges them with ``cmlt merge``.

Every part runs the same ``cmlt render`` command line with its own
``--part I/N``: the parts differ only by their random streams (the CLI
derives part I's seed from ``--seed`` and I), so the merged image is the
render of N times one part's budget. A task returns its state file's bytes
(about 48 bytes per pixel plus a header), so no shared file system is
needed for the results; the scene file and the ``cmlt`` binary must be
readable at the same paths on every node (built-in scene names work
anywhere).

Retries: a task whose worker or node dies is resubmitted by Ray
(``max_retries``); a ``cmlt`` process killed by a signal (the OOM killer,
a pre-empted node) raises in the task, which Ray retries too
(``retry_exceptions``); ``cmlt`` refusing its input (exit status 1 with a
message) is returned as an error and fails the render at once, since it
would fail again.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, List, Optional, Sequence

#: Tries per part beyond the first (Ray's ``max_retries``).
DEFAULT_RETRIES = 3


class PartFailed(RuntimeError):
    """A part's ``cmlt render`` or the ``cmlt merge`` failed."""


@dataclasses.dataclass
class RenderJob:
    """One distributed render: what every part runs and how it is merged."""

    #: Scene file (readable on every node) or built-in name (cornell-box).
    scene: str
    #: Number of parts N (one Ray task each).
    parts: int
    #: Output image of the merge (.exr or .png).
    output: str
    #: pt, bdpt, mlt or cmlt.
    method: str = "cmlt"
    #: Seconds per part (``--time``), or None for ``spp``.
    time: Optional[float] = None
    #: Samples or mutations per pixel per part (``--spp``).
    spp: Optional[int] = None
    #: Base seed (part I renders with a seed derived from it and I).
    seed: int = 0
    #: ``-D name=value`` overrides of the scene's defaults.
    defines: List[str] = dataclasses.field(default_factory=list)
    #: Threads per part (also the CPUs each Ray task reserves).
    threads: int = 1
    #: The cmlt binary on every node.
    cmlt: str = "cmlt"
    #: Further ``cmlt render`` options shared by all parts.
    extra: List[str] = dataclasses.field(default_factory=list)
    #: Also write an sRGB PNG of the merged image here.
    png: Optional[str] = None
    #: Compare the merged image with this reference (prints relMSE).
    reference: Optional[str] = None
    #: Keep the part states here (default: a temporary directory).
    states_dir: Optional[str] = None
    #: Ray's ``max_retries`` per part.
    retries: int = DEFAULT_RETRIES

    def part_command(self, part: int, state: str) -> List[str]:
        """The ``cmlt render`` command line of part ``part``."""
        # Parts run in temporary directories: paths relative to the
        # driver's directory are made absolute (the same on every node).
        cmlt = os.path.abspath(self.cmlt) if os.sep in self.cmlt else self.cmlt
        scene = os.path.abspath(self.scene) if os.path.exists(self.scene) else self.scene
        cmd = [cmlt, "render", scene, "--method", self.method, "--quiet"]
        cmd += ["--threads", str(self.threads), "--seed", str(self.seed)]
        if self.time is not None:
            cmd += ["--time", repr(float(self.time))]
        if self.spp is not None:
            cmd += ["--spp", str(self.spp)]
        for d in self.defines:
            cmd += ["-D", d]
        cmd += list(self.extra)
        cmd += ["--part", f"{part}/{self.parts}", "--state", state]
        return cmd


def run_part(cmd: Sequence[str]):
    """Runs one part's ``cmlt render`` (``cmd`` ends in ``--state FILE``,
    replaced by a file in a private temporary directory). Returns the
    state's bytes, or the error message (a ``str``) when ``cmlt`` refused;
    raises ``RuntimeError`` when the process was killed (Ray retries)."""
    cmd = list(cmd)
    with tempfile.TemporaryDirectory(prefix="cmlt-part-") as tmp:
        state = os.path.join(tmp, "part.state")
        cmd[-1] = state
        try:
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True)
        except OSError as e:
            # No binary there: a retry would not find one either.
            return f"{cmd[0]}: cannot run: {e}"
        if proc.returncode != 0:
            err = proc.stderr.strip().splitlines()
            msg = err[-1] if err else f"exit status {proc.returncode}"
            if proc.returncode < 0:
                raise RuntimeError(f"{cmd[0]} killed by signal {-proc.returncode}: {msg}")
            return f"{' '.join(cmd)}: {msg}"
        with open(state, "rb") as f:
            return f.read()


def _default_progress(done: int, total: int, seconds: float, nbytes: int) -> None:
    print(
        f"\r{done}/{total} parts in {seconds:.1f} s ({nbytes / 1e6:.2f} MB of state)",
        end="\n" if done == total else "",
        file=sys.stderr,
        flush=True,
    )


def render(
    job: RenderJob,
    address: Optional[str] = None,
    progress: Optional[Callable[[int, int, float, int], None]] = _default_progress,
    local_cpus: Optional[int] = None,
) -> dict:
    """Renders ``job`` on Ray: the cluster at ``address``, or a local Ray
    instance of ``local_cpus`` CPUs (default: all); one already initialised
    by the caller is used as it is.
    Returns timings and sizes: ``parts_seconds`` (submission to the last
    state), ``merge_seconds``, ``state_bytes`` (per part), ``merge_output``
    (what ``cmlt merge`` printed)."""
    import ray

    if job.parts < 1:
        raise ValueError("--parts must be at least 1")
    if not ray.is_initialized():
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=local_cpus, log_to_driver=False)
    # The task's code travels with it, so the nodes need the cmlt binary
    # but not this package.
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    task = ray.remote(run_part).options(
        num_cpus=job.threads,
        max_retries=job.retries,
        retry_exceptions=True,
    )
    own_dir = job.states_dir is None
    states_dir = Path(job.states_dir or tempfile.mkdtemp(prefix="cmlt-states-"))
    states_dir.mkdir(parents=True, exist_ok=True)
    try:
        t0 = time.monotonic()
        pending = {
            task.remote(job.part_command(i, "STATE")): i for i in range(job.parts)
        }
        paths: List[Optional[Path]] = [None] * job.parts
        sizes = [0] * job.parts
        done = 0
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                i = pending.pop(ref)
                data = ray.get(ref)
                if isinstance(data, str):
                    for other in pending:
                        ray.cancel(other)
                    raise PartFailed(f"part {i}: {data}")
                path = states_dir / f"part-{i:05}-of-{job.parts:05}.state"
                path.write_bytes(data)
                paths[i] = path
                sizes[i] = len(data)
                done += 1
                if progress:
                    progress(done, job.parts, time.monotonic() - t0, sum(sizes))
        parts_seconds = time.monotonic() - t0
        cmd = [job.part_command(0, "")[0], "merge", *[str(p) for p in paths], "-o", job.output]
        if job.png:
            cmd += ["--png", job.png]
        if job.reference:
            cmd += ["--reference", job.reference]
        t1 = time.monotonic()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        merge_seconds = time.monotonic() - t1
        if proc.returncode != 0:
            raise PartFailed(f"cmlt merge: {proc.stderr.strip()}")
        return {
            "parts_seconds": parts_seconds,
            "merge_seconds": merge_seconds,
            "state_bytes": sizes,
            "merge_output": proc.stdout,
            "states_dir": str(states_dir),
        }
    finally:
        if own_dir:
            shutil.rmtree(states_dir, ignore_errors=True)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m cmlt_ray",
        description="Render one image as N parts on Ray and merge them.",
    )
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render SCENE as --parts Ray tasks, then merge")
    r.add_argument("scene", help="Mitsuba 3 XML file (same path on every node) or built-in name")
    r.add_argument("--parts", type=int, required=True, help="number of parts N (Ray tasks)")
    r.add_argument("--method", default="cmlt", choices=["pt", "bdpt", "mlt", "cmlt"])
    budget = r.add_mutually_exclusive_group()
    budget.add_argument("--time", type=float, help="seconds per part")
    budget.add_argument("--spp", type=int, help="samples or mutations per pixel per part")
    r.add_argument("-o", "--output", required=True, help="merged image (.exr or .png)")
    r.add_argument("--png", help="also write an sRGB PNG of the merged image")
    r.add_argument("--reference", help="print relMSE of the merged image against this EXR")
    r.add_argument("--address", help="Ray cluster address (default: a local Ray instance)")
    r.add_argument("--local-cpus", type=int,
                   help="CPUs of the local Ray instance (default: all; ignored with --address)")
    r.add_argument("--cmlt", default=os.environ.get("CMLT_BIN", "cmlt"),
                   help="the cmlt binary on every node (default: $CMLT_BIN or cmlt on PATH)")
    r.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scene default, as cmlt render -D")
    r.add_argument("--seed", type=int, default=0, help="base seed")
    r.add_argument("--threads", type=int, default=1, help="threads (Ray CPUs) per part")
    r.add_argument("--retries", type=int, default=DEFAULT_RETRIES, help="Ray retries per part")
    r.add_argument("--states-dir", help="keep the part states in this directory")
    r.add_argument("--frames", type=int,
                   help="not supported: cmlt render's frame loop has no parts (see docs/cluster.md)")
    r.add_argument("--render-args", default="", metavar="'OPTIONS'",
                   help="further cmlt render options for every part, one quoted string "
                        "(e.g. '--b-passes 8 --chains 128')")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The command line; returns the exit status."""
    args = _parser().parse_args(argv)
    if args.frames is not None:
        print(
            "error: --frames is not supported: `cmlt render --frames` runs the core's frame loop "
            "in one process (frames may share chains and b) and cannot render one frame as parts",
            file=sys.stderr,
        )
        return 2
    extra = shlex.split(args.render_args)
    job = RenderJob(
        scene=args.scene,
        parts=args.parts,
        output=args.output,
        method=args.method,
        time=args.time,
        spp=args.spp,
        seed=args.seed,
        defines=args.defines,
        threads=args.threads,
        cmlt=args.cmlt,
        extra=extra,
        png=args.png,
        reference=args.reference,
        states_dir=args.states_dir,
        retries=args.retries,
    )
    try:
        info = render(job, address=args.address, local_cpus=args.local_cpus)
    except (PartFailed, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    sys.stdout.write(info["merge_output"])
    sizes = info["state_bytes"]
    print(
        f"{args.parts} parts in {info['parts_seconds']:.2f} s, {sizes[0]} bytes per part, "
        f"merged in {info['merge_seconds']:.2f} s"
    )
    return 0
