"""Compile culling methods' numba kernels ahead, side by side, in processes of their own.

In a fresh checkout numba compiles the CPU kernels the first time a method runs, one method
after another in the process that needs them: ``masked`` takes about 22 s of CPU and
``hiz-2phase``'s CPU test about 16 s on this machine (2 cores), before the first frame.
:func:`start` culls a tiny scene once per such method in a child process, so the kernels
compile in parallel (and beside the caller's own start-up: loading a scene, warming GL) into
numba's on-disk cache (:mod:`soc.user_cache`), from which the caller then loads them. With a
warm cache a child only loads them, about a second of CPU. Nothing here changes a result: a
child that fails costs nothing but its time, and the caller compiles as it would have.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterable

# Methods whose first cull compiles numba kernels for seconds (the rest: milliseconds).
JIT_METHODS = ("masked", "hiz-2phase", "hiz-cpu")

# A child: the culler's constructor and first cull compile (or load) every kernel it uses,
# with the argument types any scene gives them.
_CHILD = """
import sys
import soc
scene = soc.scenes.clutter(0)
cam = soc.scenes.paths.flight(scene, 2, width=320, height=180)[0]
with soc.Culler(scene, sys.argv[1], (320, 180)) as culler:
    culler.cull(cam, draw=True)
"""


class Precompile:
    """Child processes compiling kernels; :meth:`wait` before the methods' first use."""

    def __init__(self, procs: list[subprocess.Popen]):
        self.procs = procs

    def wait(self, timeout: float = 600.0) -> bool:
        """Wait for every child (at most ``timeout`` seconds each, then stop it); True when
        all compiled without error."""
        ok = True
        for p in self.procs:
            try:
                ok &= p.wait(timeout) == 0
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
                ok = False
        self.procs = []
        return ok

    def __enter__(self) -> Precompile:
        return self

    def __exit__(self, *exc) -> None:
        self.wait()


def start(methods: Iterable[str]) -> Precompile:
    """One child per method of ``methods`` in :data:`JIT_METHODS` (names as
    :class:`soc.Culler` takes them; others are ignored), started now, output discarded."""
    import soc  # noqa: F401  (sets NUMBA_CACHE_DIR in os.environ: the children inherit it)

    names = [m for m in dict.fromkeys(methods) if m in JIT_METHODS]
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _CHILD, m],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for m in names
    ]
    return Precompile(procs)
