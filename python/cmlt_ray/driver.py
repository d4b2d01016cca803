"""The driver: submits the parts of one render (or of every frame of a
sequence) as Ray tasks, gathers their states and merges them with
``cmlt merge``.

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
    #: A sequence of this many frames (``cmlt render --frames``), each
    #: rendered as ``parts`` parts and written as ``out-0007.exr``, …;
    #: orbit options go in ``extra``.
    frames: Optional[int] = None

    def part_command(self, part: int, state: str, frame: Optional[int] = None) -> List[str]:
        """The ``cmlt render`` command line of part ``part`` (of frame
        ``frame`` of ``frames``)."""
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
        if frame is not None:
            cmd += ["--frames", str(self.frames), "--frame", str(frame)]
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
    state, merges excluded), ``merge_seconds``, ``state_bytes`` (per part,
    in completion order), ``merge_output`` (what ``cmlt merge`` printed)."""
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
    frames = list(range(job.frames)) if job.frames else [None]
    total = len(frames) * job.parts
    try:
        t0 = time.monotonic()
        pending = {
            task.remote(job.part_command(i, "STATE", frame=f)): (f, i)
            for f in frames
            for i in range(job.parts)
        }
        paths = {f: [None] * job.parts for f in frames}
        sizes: List[int] = []
        outputs: List[str] = []
        merge_seconds = 0.0
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                f, i = pending.pop(ref)
                data = ray.get(ref)
                if isinstance(data, str):
                    for other in pending:
                        ray.cancel(other)
                    where = f"part {i}" if f is None else f"frame {f}, part {i}"
                    raise PartFailed(f"{where}: {data}")
                tag = "" if f is None else f"frame-{f:05}-"
                path = states_dir / f"{tag}part-{i:05}-of-{job.parts:05}.state"
                path.write_bytes(data)
                paths[f][i] = path
                sizes.append(len(data))
                if progress:
                    progress(len(sizes), total, time.monotonic() - t0, sum(sizes))
                # A frame is merged as soon as its parts are in.
                if all(p is not None for p in paths[f]):
                    t1 = time.monotonic()
                    outputs.append(_merge(job, paths[f], f))
                    merge_seconds += time.monotonic() - t1
        return {
            "parts_seconds": time.monotonic() - t0 - merge_seconds,
            "merge_seconds": merge_seconds,
            "state_bytes": sizes,
            "merge_output": "".join(outputs),
            "states_dir": str(states_dir),
        }
    finally:
        if own_dir:
            shutil.rmtree(states_dir, ignore_errors=True)


def frame_path(output: str, frame: Optional[int]) -> str:
    """``out.exr`` for a single image, ``out-0007.exr`` for frame 7 (the
    names ``cmlt render --frames`` writes)."""
    if frame is None:
        return output
    root, ext = os.path.splitext(output)
    return f"{root}-{frame:04}{ext}"


def _merge(job: RenderJob, paths: Sequence[Path], frame: Optional[int]) -> str:
    """Runs ``cmlt merge`` on one image's parts; returns what it printed."""
    output = frame_path(job.output, frame)
    cmd = [job.part_command(0, "")[0], "merge", *[str(p) for p in paths], "-o", output]
    if job.png:
        cmd += ["--png", frame_path(job.png, frame)]
    if job.reference:
        cmd += ["--reference", job.reference]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise PartFailed(f"cmlt merge: {proc.stderr.strip()}")
    return proc.stdout


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
                   help="render a sequence of this many independent frames, each as --parts tasks "
                        "(out-0000.exr, ...; --render-args '--orbit' for an orbit)")
    r.add_argument("--render-args", default="", metavar="'OPTIONS'",
                   help="further cmlt render options for every part, one quoted string "
                        "(e.g. '--b-passes 8 --chains 128')")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The command line; returns the exit status."""
    args = _parser().parse_args(argv)
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
        frames=args.frames,
    )
    try:
        info = render(job, address=args.address, local_cpus=args.local_cpus)
    except (PartFailed, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    sys.stdout.write(info["merge_output"])
    sizes = info["state_bytes"]
    print(
        f"{len(sizes)} parts in {info['parts_seconds']:.2f} s, {sizes[0]} bytes per part, "
        f"merged in {info['merge_seconds']:.2f} s"
    )
    return 0
