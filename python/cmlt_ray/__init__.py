"""cmlt on Ray: one image rendered as N independent parts on a Ray cluster.

Each part is a Ray task that runs the ``cmlt`` binary with ``--part I/N
--state FILE`` and returns the state file's bytes; the driver gathers them
and runs ``cmlt merge``, which checks that the parts belong together and
combines them into the image one machine would render with all the parts'
budgets together. See ``python -m cmlt_ray render --help``.
"""

from .driver import PartFailed, RenderJob, main, render

__all__ = ["PartFailed", "RenderJob", "main", "render"]
