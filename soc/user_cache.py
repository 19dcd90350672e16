"""Where vislod keeps what it computes once and reuses: the user's cache folder, never the
installed package (an installed ``site-packages`` must stay as pip left it).

:func:`cache_root` is ``$VISLOD_CACHE`` when set, else ``platformdirs.user_cache_dir("vislod")``
(``~/.cache/vislod`` on Linux). It holds LOD chains and cost-model calibrations
(:mod:`lod.cache`) and mesh clusters (:mod:`soc.culling.clusters`), each entry a ``.npz``
file written atomically (:func:`store`, :func:`load`), and numba's compiled kernels
(:func:`point_numba_cache`: numba writes its ``cache=True`` files beside the source by
default, i.e. into ``site-packages/soc/__pycache__`` when installed). Importing this module
points numba there (``soc/__init__.py`` imports it before any module that defines a kernel).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

# Environment variable naming the cache root (where things are, never how they behave).
ENV = "VISLOD_CACHE"


def cache_root() -> Path:
    """The root of vislod's caches: ``$VISLOD_CACHE`` when set (and not empty), else
    ``platformdirs.user_cache_dir("vislod")``. Read at every call."""
    env = os.environ.get(ENV, "").strip()
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("vislod", appauthor=False))


def point_numba_cache() -> None:
    """Send numba's on-disk kernel cache to ``<cache_root>/numba`` unless the user chose a
    folder (``NUMBA_CACHE_DIR``). Must run before any ``@numba.njit(cache=True)`` function
    is defined (numba picks the folder at decoration): ``soc/__init__.py`` calls it first."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    folder = str(cache_root() / "numba")
    os.environ["NUMBA_CACHE_DIR"] = folder  # read by numba when it is first imported
    numba = sys.modules.get("numba")
    if numba is not None:  # imported already (by the caller): its config is read, set it
        numba.config.CACHE_DIR = folder


def load(folder: Path, name: str) -> dict[str, np.ndarray] | None:
    """The arrays stored under ``folder/name.npz``, or None when absent or unreadable."""
    path = Path(folder) / f"{name}.npz"
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, KeyError):
        return None  # a corrupt entry is recomputed and overwritten


def store(folder: Path, name: str, arrays: dict[str, np.ndarray]) -> Path:
    """Write ``arrays`` to ``folder/name.npz`` through a temporary name and ``os.replace``
    (atomic on POSIX: a reader never sees half a file, concurrent writers race to the same
    content); returns the path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
        path = folder / f"{name}.npz"
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


point_numba_cache()
