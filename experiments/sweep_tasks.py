"""One task of a ``vislod sweep`` (:class:`SweepTask`: one chunk of the seed-000 flight over
one scene, method, depth and display resolution) and how a worker runs it (:func:`run_task`).
Its key hashes its parameters and the code version, the same in every process and on every
machine, so a stored result can be reused. A worker caches its EGL context and last scenes.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import signal
import socket
import time
from collections import OrderedDict
from dataclasses import asdict, dataclass
from typing import Any

import pandas as pd

from experiments.common import QUICK_OCCLUDEES, SCENES, UsageError, castle_path, res_str

ROW_FORMAT = 1  # bump when the columns a task returns change meaning: every key changes
SCENE_CACHE = 2  # scenes (with their GL upload and oracle) a worker keeps between tasks

_SceneValue = int | float | bool | str


# -- what a task is ----------------------------------------------------------------------------


def _parse_value(text: str) -> _SceneValue:
    low = text.strip().lower()
    if low in ("true", "false"):
        return low == "true"
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text.strip()


def _loader(name: str):
    import soc

    return getattr(soc.scenes, name)  # market, clutter, castle


@dataclass(frozen=True)
class SceneSpec:
    """A scene: ``name`` (market, castle, clutter), generator ``seed`` and the keyword
    arguments of ``soc.scenes.<name>``, sorted (``(("occludees", 2000),)``)."""

    name: str
    seed: int = 0
    params: tuple[tuple[str, _SceneValue], ...] = ()

    @classmethod
    def parse(cls, text: str, seed: int = 0, *, quick: bool = False) -> SceneSpec:
        """``"market"``, ``"clutter:objects=80,walls=6"`` → a checked spec (:class:`UsageError`
        for an unknown scene or parameter); ``quick`` gives the market fewer objects."""
        name, _, rest = str(text).partition(":")
        name = name.strip()
        if name not in SCENES:
            raise UsageError(f"unknown scene {name!r}; available: {', '.join(SCENES)}")
        params: dict[str, _SceneValue] = {}
        for item in filter(None, (t.strip() for t in rest.split(","))):
            k, eq, v = item.partition("=")
            if not eq or not k.strip():
                raise UsageError(f"bad scene parameter {item!r} in {text!r}: expected NAME=VALUE")
            params[k.strip()] = _parse_value(v)
        if quick and name == "market":
            params.setdefault("occludees", QUICK_OCCLUDEES)
        if name == "castle":  # as everywhere else: the marketplace refilled to seed 000's counts
            params.setdefault("refill_market", True)
        accepted = [
            p.name
            for p in inspect.signature(_loader(name)).parameters.values()
            if p.kind is p.KEYWORD_ONLY and p.name != "seed"
        ]
        unknown = sorted(set(params) - set(accepted))
        if unknown:
            raise UsageError(
                f"scene {name!r} has no parameter {', '.join(map(repr, unknown))}; "
                f"it takes: {', '.join(accepted)} (and --seeds)"
            )
        if int(seed) < 0:
            raise UsageError(f"scene seed must be >= 0, got {seed}")
        return cls(name, int(seed), tuple(sorted(params.items())))

    def __str__(self) -> str:
        extra = ",".join(f"{k}={v}" for k, v in self.params)
        return f"{self.name}:{extra}" if extra else self.name

    def load(self, data: str | os.PathLike | None = None):
        """Generate (market, clutter) or read (castle, from ``data`` / ``VISLOD_DATA``) it."""
        kwargs = dict(self.params)
        if self.name == "castle":
            return _loader("castle")(castle_path(data), seed=self.seed, **kwargs)
        return _loader(self.name)(self.seed, **kwargs)


@dataclass(frozen=True)
class SweepTask:
    """Frames ``start``..``stop - 1`` of a ``frames``-camera flight (the cameras depend on
    ``frames``), culled by ``method`` at depth ``resolution`` with cameras of ``display``
    pixels; ``oracle`` counts false culls, ``draw`` draws the kept set and times it."""

    scene: SceneSpec
    method: str
    resolution: tuple[int, int]
    display: tuple[int, int]
    frames: int
    start: int
    stop: int
    oracle: bool = False
    draw: bool = False

    def __post_init__(self) -> None:
        if self.frames < 2:
            raise ValueError(f"a flight needs at least 2 frames, got {self.frames}")
        if not 0 <= self.start < self.stop <= self.frames:
            raise ValueError(
                f"bad chunk {self.start}..{self.stop} of a {self.frames}-frame flight: "
                "need 0 <= start < stop <= frames"
            )

    def params(self) -> dict[str, Any]:
        """Everything that defines the result, plus the code version (what the key hashes)."""
        p = asdict(self)
        p["scene"] = {"name": self.scene.name, "seed": self.scene.seed, **dict(self.scene.params)}
        p["resolution"], p["display"] = list(self.resolution), list(self.display)
        p["version"] = code_version()
        return p

    @property
    def key(self) -> str:
        """20 hex digits of SHA-256 over :meth:`params` as canonical JSON."""
        text = json.dumps(self.params(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    @property
    def label(self) -> str:
        return (
            f"{self.scene} seed {self.scene.seed} {self.method} {res_str(self.resolution)} "
            f"on {res_str(self.display)} frames {self.start}-{self.stop - 1}/{self.frames}"
        )

    def columns(self) -> dict[str, Any]:
        """The task's columns in every row it returns."""
        return {
            "key": self.key,
            "version": code_version(),
            "scene": str(self.scene),
            "seed": self.scene.seed,
            "method": self.method,
            "depth_resolution": res_str(self.resolution),
            "display": res_str(self.display),
            "flight_frames": self.frames,
            "chunk": f"{self.start}-{self.stop - 1}",
        }


def code_version() -> str:
    """The installed vislod version and the row format, e.g. ``"0.1.0/rows1"``."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        v = version("vislod")
    except PackageNotFoundError:  # run from a checkout that is not installed
        v = "unknown"
    return f"{v}/rows{ROW_FORMAT}"


def frame_chunks(frames: int, chunk: int) -> list[tuple[int, int]]:
    """``[(0, chunk), (chunk, 2 chunk), …]`` covering ``range(frames)``; the last may be short."""
    if chunk < 1:
        raise UsageError(f"--chunk must be at least 1, got {chunk}")
    return [(s, min(s + chunk, frames)) for s in range(0, frames, chunk)]


# -- running one task in a worker process ------------------------------------------------------


@dataclass(frozen=True)
class TaskResult:
    """What a worker sends back: the key, the rows, where and how long (s) it ran."""

    key: str
    frame: pd.DataFrame
    worker: str
    seconds: float


@dataclass
class _Loaded:
    scene: Any
    oracle: Any = None


# Per worker process: the last SCENE_CACHE scenes, their GL upload and oracle. Caches only.
_scenes: OrderedDict[tuple[SceneSpec, str | None], _Loaded] = OrderedDict()


def _scene(spec: SceneSpec, data: str | None) -> _Loaded:
    key = (spec, data)
    if key in _scenes:
        _scenes.move_to_end(key)
        return _scenes[key]
    while len(_scenes) >= SCENE_CACHE:
        _, old = _scenes.popitem(last=False)
        if old.oracle is not None:
            old.oracle.close()
    _scenes[key] = _Loaded(spec.load(data))
    return _scenes[key]


def _crash_once(marker: str | os.PathLike) -> None:
    """Tests: SIGKILL this process unless ``marker`` exists (created first: once in all)."""
    try:
        fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return
    os.close(fd)
    os.kill(os.getpid(), signal.SIGKILL)


def run_task(
    task: SweepTask,
    *,
    data: str | None = None,
    gl_threads: int | None = None,
    crash_marker: str | None = None,
) -> TaskResult:
    """Cull (and optionally draw and check) the task's frames, flown by :func:`soc.fly`: one
    row per frame, the task's columns beside :meth:`soc.FrameStats.as_row`. The culler warms
    up, untimed, on the frame before the chunk, so temporal methods start each chunk from one
    frame of history."""
    import soc
    from soc.gl.context import default_context

    t0 = time.perf_counter()
    glctx = default_context(gl_threads)
    if gl_threads:  # the CPU rasterizers (masked, hiz-cpu) get the same share of the cores
        import numba

        numba.set_num_threads(min(gl_threads, numba.config.NUMBA_NUM_THREADS))
    loaded = _scene(task.scene, data)
    scene = loaded.scene
    if task.oracle and loaded.oracle is None:
        loaded.oracle = soc.Oracle(scene, glctx)
    cams = soc.scenes.paths.flight(
        scene, frames=task.frames, width=task.display[0], height=task.display[1]
    )
    common = {
        **task.columns(),
        "gl_threads": glctx.threads,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
    }
    halfway = (task.start + task.stop) // 2

    def before_frame(i: int, _camera) -> None:
        if crash_marker is not None and task.start + i == halfway:
            _crash_once(crash_marker)

    truth = (lambda cam: loaded.oracle.visible(cam)) if task.oracle else None
    with soc.Culler(scene, method=task.method, resolution=task.resolution, glctx=glctx) as culler:
        flown = soc.fly(culler, cams[task.start : task.stop], truth=truth, draw=task.draw,
                        warmup=[cams[max(task.start - 1, 0)]], before_frame=before_frame,
                        progress=False)  # fmt: skip
    flown = flown.drop(columns=["frame", "method", "width", "height", "oracle_visible"],
                       errors="ignore")  # fmt: skip
    columns = {**common, "frame": range(task.start, task.stop)}
    frame = pd.concat([pd.DataFrame(columns), flown], axis=1)
    return TaskResult(task.key, frame, common["worker"], time.perf_counter() - t0)
