"""What every experiment shares: where results go, writing them atomically, choosing a scene,
parsing resolutions and quick mode.

Experiments take every setting as an argument; only the entry points (the CLI, notebooks)
read the environment (``VISLOD_QUICK``, ``VISLOD_DATA``) and say so when they do.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

SCENES = ("market", "castle", "clutter")
DISPLAY = (1920, 1080)  # seed 000's display (and default depth) resolution
FRAMES = 100  # seed 000's flight length
MAX_RESOLUTION = 16384  # llvmpipe's largest render target side

# Quick mode (notebooks, CI): a few frames, everything at a quarter of the resolution, and the
# small market. Depth resolutions keep their ratio to the display, so the table still lines up
# with the document's columns.
QUICK_FRAMES = 6
QUICK_SCALE = 0.25
QUICK_OCCLUDEES = 2000


class UsageError(ValueError):
    """A user-facing mistake (unknown name, bad resolution, missing data): one line, exit 2."""


# -- where results go -------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]  # the checkout, when the package runs from one
GALLERY = ROOT / "docs" / "gallery"  # the tracked pictures (:mod:`experiments.gallery`)


def in_checkout() -> bool:
    """The package runs from a vislod checkout (README.md and docs/ beside it), not from an
    installed wheel, whose site-packages must stay as pip left it."""
    return (ROOT / "pyproject.toml").is_file()


def gallery_path(stem: str, folder: Path | None = None) -> Path:
    """Where the picture ``stem`` (``<key>_<plot>``) lives in the tracked gallery (``folder``,
    default :data:`GALLERY`)."""
    return Path(folder if folder is not None else GALLERY) / f"{stem}.png"


def default_results_dir() -> Path:
    """``results/`` at the repository root (the current directory when not run from a checkout),
    or ``$VISLOD_RESULTS`` when set (tests and CI keep their results out of the checkout)."""
    if os.environ.get("VISLOD_RESULTS"):
        return Path(os.environ["VISLOD_RESULTS"])
    if in_checkout():
        return ROOT / "results"
    return Path.cwd() / "results"


def default_out(quick: bool) -> Path:
    """Where a run writes by default: ``results/``, quick runs ``results/quick/`` (so that a
    quick run never overwrites the full run's files)."""
    return default_results_dir() / "quick" if quick else default_results_dir()


def env_quick() -> bool:
    """True when ``VISLOD_QUICK`` is set to something other than ``""``/``0``/``false``/``no``."""
    return os.environ.get("VISLOD_QUICK", "").strip().lower() not in ("", "0", "false", "no")


# -- atomic writing: a file is either complete or absent ---------------------------------------


def atomic_write(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file next to ``path``, then rename it to ``path``.

    Nothing is left at ``path`` (nor a temporary file) when ``write`` raises.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, float) and not math.isfinite(x):
        return None
    raise TypeError(f"cannot write {type(x).__name__} to JSON")


def write_json(path: str | os.PathLike, data: Any) -> Path:
    """Write ``data`` as indented JSON (numpy scalars and arrays allowed), atomically."""
    text = json.dumps(data, indent=2, default=_jsonable, allow_nan=False)
    return atomic_write(path, lambda p: p.write_text(text + "\n"))


# -- parameters ---------------------------------------------------------------------------------


def require(params: Any, *, distinct: Sequence[str] = (), **at_least: float) -> None:
    """:class:`UsageError` unless each named field of ``params`` is at least its bound (every
    element of a sequence, both sides of a resolution; an empty sequence fails) and the
    ``distinct`` fields repeat no value: ``require(p, distinct=["sizes"], frames=2, sizes=1)``.
    """
    for name, bound in at_least.items():
        value = getattr(params, name)
        values = list(value) if isinstance(value, Sequence) else [value]
        if not values or min(values) < bound:
            shown = list(value) if isinstance(value, Sequence) else value
            raise UsageError(f"{name} must be at least {bound:g}, got {shown!r}")
    for name in distinct:
        values = list(getattr(params, name))
        if len(set(values)) != len(values):
            raise UsageError(f"{name} must not repeat a value, got {values}")


# -- resolutions -------------------------------------------------------------------------------

_RES = re.compile(r"^\s*(\d+)\s*[x×X]\s*(\d+)\s*$")


def parse_resolution(text: str) -> tuple[int, int]:
    """``"1920x1080"`` (or ``1920×1080``) → ``(1920, 1080)``; :class:`UsageError` otherwise."""
    m = _RES.match(str(text))
    if not m:
        raise UsageError(f"bad resolution {text!r}: expected WIDTHxHEIGHT, e.g. 1920x1080")
    w, h = int(m.group(1)), int(m.group(2))
    if not (0 < w <= MAX_RESOLUTION and 0 < h <= MAX_RESOLUTION):
        raise UsageError(
            f"bad resolution {text!r}: width and height must be in 1..{MAX_RESOLUTION}"
        )
    return w, h


def res_str(resolution: Sequence[int]) -> str:
    """``(1920, 1080)`` → ``"1920x1080"`` (ASCII, for file names and CSV cells)."""
    return f"{int(resolution[0])}x{int(resolution[1])}"


def scaled(resolution: Sequence[int], scale: float) -> tuple[int, int]:
    """``resolution`` times ``scale``, each side rounded to a multiple of 2 and at least 8."""
    return tuple(max(8, 2 * round(v * scale / 2)) for v in resolution)  # type: ignore[return-value]


# -- scenes ------------------------------------------------------------------------------------


# Where the castle's scene files may sit under a data folder: ``<data>/intel_castle/Asset``,
# ``<data>/Asset`` or ``<data>`` itself (what :func:`soc.scenes.castle` accepts).
CASTLE_LAYOUTS = (("intel_castle", "Asset"), ("Asset",), ())


def castle_path(data: str | os.PathLike | None) -> Path:
    """The castle data folder from ``data`` or ``VISLOD_DATA``; :class:`UsageError` when neither
    is set, or the path is missing, is a file, or holds no castle (no ``.set`` scene file in
    ``intel_castle/Asset/``, ``Asset/`` or the folder itself) — checked before any work, so a
    wrong path is an error, never a silent fallback to the generated market.

    :func:`soc.scenes.castle` accepts the folder holding ``intel_castle/``, ``intel_castle/``
    itself or its ``Asset/`` folder.
    """
    env = os.environ.get("VISLOD_DATA")
    source = "VISLOD_DATA" if not data or str(data) == env else "--data"
    data = data or env
    if not data:
        raise UsageError(
            "scene 'castle' needs the Intel castle files: pass --data PATH or set VISLOD_DATA "
            "(see data/README.md)"
        )
    root = Path(data).expanduser()
    if not root.exists():
        raise UsageError(f"castle data folder {str(root)!r} ({source}) does not exist")
    if not root.is_dir():
        raise UsageError(f"castle data folder {str(root)!r} ({source}) is a file, not a folder")
    for parts in CASTLE_LAYOUTS:
        folder = root.joinpath(*parts)
        if folder.is_dir() and any(folder.glob("*.set")):
            return root
    raise UsageError(
        f"no Intel castle in {str(root)!r} ({source}): no .set scene files in intel_castle/Asset/, "
        "Asset/ or the folder itself (see data/README.md)"
    )


def check_writable(folder: str | os.PathLike) -> Path:
    """Create ``folder`` (with its parents) and write and delete a probe file in it, so that a
    results folder that cannot be written fails in a second, before the work, not minutes
    later when the first file is saved; :class:`UsageError` (one line) otherwise. The folders
    it created are removed again, so that a mistake found after this check leaves nothing
    behind (the command creates them when it writes)."""
    folder = Path(folder).expanduser()
    created = []
    missing = folder
    while not missing.exists() and missing.parent != missing:
        created.append(missing)
        missing = missing.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".vislod-probe-", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        reason = e.strerror or type(e).__name__
        raise UsageError(f"cannot write to output folder {str(folder)!r}: {reason}") from None
    finally:
        for d in created:  # deepest first
            try:
                d.rmdir()
            except OSError:
                break
    return folder


def load_scene(
    name: str = "market",
    *,
    seed: int = 0,
    quick: bool = False,
    data: str | os.PathLike | None = None,
):
    """A scene by name.

    Parameters
    ----------
    name : {"market", "castle", "clutter"}
        ``market``: the generated town with seed 000's counts (the small version in quick
        mode); ``castle``: Intel's castle from ``data`` / ``VISLOD_DATA``, its marketplace
        refilled to seed 000's counts (so partly synthetic); ``clutter``: a small test scene.
    seed : int
        Generator seed (market, clutter).
    """
    import soc
    from soc.errors import SceneError

    if name not in SCENES:
        raise UsageError(f"unknown scene {name!r}; available: {', '.join(SCENES)}")
    try:
        if name == "market":
            if quick:
                return soc.scenes.market(seed=seed, occludees=QUICK_OCCLUDEES)
            return soc.scenes.market(seed=seed)
        if name == "castle":
            return soc.scenes.castle(castle_path(data), refill_market=True, seed=seed)
        return soc.scenes.clutter(seed)
    except (SceneError, FileNotFoundError, NotADirectoryError) as e:
        raise UsageError(f"cannot load scene {name!r}: {e}") from e


def scene_info(scene, name: str | None = None) -> dict[str, Any]:
    """Counts and provenance of ``scene`` for result files and plot titles."""
    meta = dict(scene.meta)
    source = str(meta.get("source", name or "scene"))
    synthetic = meta.get("synthetic")
    if name == "castle" or source.startswith("castle"):
        label = f"{source} (partly synthetic: marketplace refilled to seed-000 counts)"
    else:
        label = source + (" (synthetic)" if synthetic else "")
    return {
        "name": name or source,
        "label": label,
        "objects": len(scene),
        "occluders": int(scene.occluder.sum()),
        "triangles": int(scene.triangle_counts.sum()),
        "occluder_triangles": int(scene.triangle_counts[scene.occluder].sum()),
        "meta": {k: v for k, v in meta.items() if isinstance(v, (str, int, float, bool))},
    }


# -- numbers and small tables -------------------------------------------------------------------
