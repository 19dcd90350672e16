"""The GPU's clock: GL timestamp queries around every stage of a frame, read when it ends.

:func:`soc.metrics.stage` times each stage on the wall clock (``time.perf_counter`` around
the work and a ``ctx.finish()``); inside a :class:`TimedFrame` it also marks the stage's first
and last GL command with a ``GL_TIMESTAMP`` query (``glQueryCounter``). Timestamps, not
``GL_TIME_ELAPSED`` brackets, because GL allows only one active query per target, and stages
nest (a method's stage around a helper's stage). The stage's GPU time is the difference of its
two marks: the GPU's time from the stage's first command to its last. Nothing waits for the
results during the frame; :meth:`TimedFrame.__exit__` reads them (by then the stages' own
``finish()`` calls have executed everything, so reading costs no extra synchronisation) and the
query objects go back to a pool for the next frame.

The GL's clock is only worth reading on a GPU: llvmpipe's timer queries read part of the work
(about half a draw's wall time, the first read far off; docs/findings.md, "Benchmarks"), so a
context on llvmpipe times nothing unless told to (:attr:`soc.gl.context.GLContext.gpu_clock`).
"""

from __future__ import annotations

import ctypes

from soc.errors import GLUnavailableError
from soc.gl.raw import GL_QUERY_COUNTER_BITS, GL_QUERY_RESULT, GL_TIMESTAMP
from soc.metrics import clocked

_POOL_BATCH = 64  # query objects generated at a time


class GpuTimer:
    """The timestamp queries of one GL context: a pool reused frame after frame.

    Make and use it only while its context is current (vislod's entries are).
    """

    def __init__(self, glctx):
        self.glctx = glctx
        raw = glctx.raw
        bits = ctypes.c_int()
        raw.glGetQueryiv(GL_TIMESTAMP, GL_QUERY_COUNTER_BITS, ctypes.byref(bits))
        if bits.value <= 0:
            raise GLUnavailableError(
                f"{glctx.renderer} has no GL_TIMESTAMP counter (GL_QUERY_COUNTER_BITS = 0)"
            )
        self._free: list[int] = []
        self._all: list[int] = []

    def frame(self) -> TimedFrame:
        """A frame to time: ``with timer.frame() as f: ...``, then ``f.gpu_ms``."""
        return TimedFrame(self)

    def _take(self) -> int:
        if not self._free:
            ids = (ctypes.c_uint * _POOL_BATCH)()
            self.glctx.raw.glGenQueries(_POOL_BATCH, ids)
            self._all += list(ids)
            self._free = list(ids)
        return self._free.pop()

    def release(self) -> None:
        """Delete every query object (the context must be current)."""
        if self._all:
            ids = (ctypes.c_uint * len(self._all))(*self._all)
            self.glctx.raw.glDeleteQueries(len(self._all), ids)
        self._all, self._free = [], []


class TimedFrame:
    """One frame timed on the GL's clock: a :class:`soc.metrics.StageClock` that every
    :func:`soc.metrics.stage` inside ``with`` uses.

    Attributes
    ----------
    gpu_ms : dict[str, float]
        After the ``with``: GPU ms per stage name, summed over the stage's occurrences (a
        stage nested in one of the same name is not counted twice).
    """

    def __init__(self, timer: GpuTimer | None):
        self.timer = timer
        self.gpu_ms: dict[str, float] = {}
        self._marks: list[list] = []  # [name, begin query, end query or None]
        self._open: set[str] = set()
        self._scope = None

    def __enter__(self) -> TimedFrame:
        self._scope = clocked(self if self.timer is not None else None)
        self._scope.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self._scope.__exit__(*exc)
        if self.timer is None:
            return
        marks, self._marks = self._marks, []
        ok = exc[0] is None
        result = ctypes.c_uint64()
        glctx = self.timer.glctx
        with glctx.current():
            for name, q0, q1 in marks:
                if ok and q1 is not None:
                    glctx.raw.glGetQueryObjectui64v(q0, GL_QUERY_RESULT, ctypes.byref(result))
                    t0 = result.value
                    glctx.raw.glGetQueryObjectui64v(q1, GL_QUERY_RESULT, ctypes.byref(result))
                    # ns -> ms; a software renderer's clock need not even be monotone
                    ms = max(0, result.value - t0) * 1e-6
                    self.gpu_ms[name] = self.gpu_ms.get(name, 0.0) + ms
                self.timer._free += [q for q in (q0, q1) if q is not None]

    def begin(self, name: str) -> int | None:
        glctx = self.timer.glctx
        if name in self._open or glctx._egl.eglGetCurrentContext() != glctx._handle:
            return None  # nested in itself, or another context is current: not timed
        q = self.timer._take()
        glctx.raw.glQueryCounter(q, GL_TIMESTAMP)
        self._open.add(name)
        self._marks.append([name, q, None])
        return len(self._marks) - 1

    def end(self, token: int) -> None:
        mark = self._marks[token]
        q = self.timer._take()
        self.timer.glctx.raw.glQueryCounter(q, GL_TIMESTAMP)
        mark[2] = q
        self._open.discard(mark[0])
