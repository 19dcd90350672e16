"""What every experiment shares: where results go, writing them atomically, checking
parameters, resolutions, scenes and quick mode. Experiments take every setting as an argument;
only the entry points (the CLI, notebooks) read the environment.
"""

from __future__ import annotations

import base64
import io
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

# Quick mode (notebooks, CI): a few frames at a quarter of the resolution on the small market.
QUICK_FRAMES = 6
QUICK_SCALE = 0.25
QUICK_OCCLUDEES = 2000


class UsageError(ValueError):
    """A user-facing mistake (unknown name, bad resolution, missing data): one line, exit 2."""


# -- where results go -------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]  # the checkout, when the package runs from one
GALLERY = ROOT / "docs" / "gallery"  # the tracked pictures (:mod:`experiments.gallery`)


def in_checkout() -> bool:
    """The package runs from a checkout, not from an installed wheel (whose site-packages must
    stay as pip left it)."""
    return (ROOT / "pyproject.toml").is_file()


def gallery_path(stem: str, folder: Path | None = None) -> Path:
    """Where the picture ``stem`` (``<key>_<plot>``) lives in the gallery ``folder``."""
    return Path(folder if folder is not None else GALLERY) / f"{stem}.png"


def default_results_dir() -> Path:
    """``$VISLOD_RESULTS`` when set (tests, CI), else ``results/`` in the checkout (or in the
    current folder when installed)."""
    if os.environ.get("VISLOD_RESULTS"):
        return Path(os.environ["VISLOD_RESULTS"])
    if in_checkout():
        return ROOT / "results"
    return Path.cwd() / "results"


def default_out(quick: bool) -> Path:
    """``results/``, or ``results/quick/`` for quick runs (never overwriting a full run's)."""
    return default_results_dir() / "quick" if quick else default_results_dir()


def env_quick() -> bool:
    """True when ``VISLOD_QUICK`` is set to something other than ``""``/``0``/``false``/``no``."""
    return os.environ.get("VISLOD_QUICK", "").strip().lower() not in ("", "0", "false", "no")


# -- atomic writing: a file is either complete or absent ---------------------------------------


def atomic_write(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file next to ``path``, then rename it to ``path``:
    nothing is left when ``write`` raises."""
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


# -- pictures as data and fits -------------------------------------------------------------------

STORED_WIDTH = 960  # px: a panel is ~880 px wide in the 16-inch, 110-dpi figures


def encode(img: np.ndarray) -> str:
    """(H, W[, 3]) uint8 image → base64 PNG text, averaged down to at most
    :data:`STORED_WIDTH` px wide."""
    from matplotlib.image import imsave

    k = -(-img.shape[1] // STORED_WIDTH)
    if k > 1:
        h, w = img.shape[0] // k * k, img.shape[1] // k * k
        blocks = img[:h, :w].reshape(h // k, k, w // k, k, *img.shape[2:]).astype(np.float32)
        img = blocks.mean(axis=(1, 3)).round().astype(np.uint8)
    buf = io.BytesIO()
    imsave(buf, img, format="png", cmap="gray" if img.ndim == 2 else None, vmin=0, vmax=255)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def decode(text: str) -> np.ndarray:
    """Base64 PNG text → (H, W, C) float image in [0, 1]."""
    from matplotlib.image import imread

    return imread(io.BytesIO(base64.b64decode(text)), format="png")


def loglog_slope(x: Sequence[float], y: Sequence[float]) -> float:
    """Least-squares slope of log y against log x (the exponent of a power law)."""
    return float(np.polyfit(np.log(np.asarray(x, float)), np.log(np.asarray(y, float)), 1)[0])


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


def resolution_arg(text: str) -> tuple[int, int]:
    """:func:`parse_resolution` as an ``argparse`` type (its message in the usage error)."""
    import argparse

    try:
        return parse_resolution(text)
    except UsageError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def res_str(resolution: Sequence[int]) -> str:
    """``(1920, 1080)`` → ``"1920x1080"`` (ASCII, for file names and CSV cells)."""
    return f"{int(resolution[0])}x{int(resolution[1])}"


def scaled(resolution: Sequence[int], scale: float) -> tuple[int, int]:
    """``resolution`` times ``scale``, each side rounded to a multiple of 2 and at least 8."""
    return tuple(max(8, 2 * round(v * scale / 2)) for v in resolution)  # type: ignore[return-value]


# -- scenes ------------------------------------------------------------------------------------


def castle_path(data: str | os.PathLike | None) -> Path:
    """The castle data folder from ``data`` or ``VISLOD_DATA``, checked before any work (a
    wrong path is an error, never a fallback to the generated market): :class:`UsageError`
    unless it holds ``.set`` scene files in ``intel_castle/Asset/``, ``Asset/`` or itself (the
    layouts :func:`soc.scenes.castle` reads)."""
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
    for folder in (root / "intel_castle" / "Asset", root / "Asset", root):
        if folder.is_dir() and any(folder.glob("*.set")):
            return root
    raise UsageError(
        f"no Intel castle in {str(root)!r} ({source}): no .set scene files in intel_castle/Asset/, "
        "Asset/ or the folder itself (see data/README.md)"
    )


def check_writable(folder: str | os.PathLike) -> Path:
    """Probe that ``folder`` can be written (:class:`UsageError` otherwise), before the work
    rather than when the first file is saved; the folders made for the probe are removed
    again, so that a mistake found later leaves nothing behind."""
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
    """A scene of :data:`SCENES`: the generated market with seed 000's counts (small when
    ``quick``), Intel's castle from ``data`` with its marketplace refilled to those counts, or
    the small clutter test scene."""
    import soc
    from soc.errors import SceneError

    if name not in SCENES:
        raise UsageError(f"unknown scene {name!r}; available: {', '.join(SCENES)}")
    try:
        if name == "market":
            small = {"occludees": QUICK_OCCLUDEES} if quick else {}
            return soc.scenes.market(seed=seed, **small)
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
