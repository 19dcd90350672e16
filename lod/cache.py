"""On-disk cache of LOD chains, keyed by a hash of the mesh arrays and the parameters.

Where: :func:`cache_root` — ``$VISLOD_CACHE`` when set, else the user's cache folder
(``platformdirs.user_cache_dir("vislod")``, e.g. ``~/.cache/vislod`` on Linux); never inside
the installed package. LOD chains go to ``<root>/lod`` (:func:`default_dir`), the cost-model
calibrations of :mod:`lod.calibration` to ``<root>/calibration``.

One ``.npz`` file per chain, named by the SHA-256 of (format version, simplifier version,
vertex and face bytes with their dtypes and shapes, parameters). Files are written to a
temporary name in the same folder and renamed (``os.replace``, atomic on POSIX), so a reader
never sees a half-written file and concurrent writers simply race to the same content.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from soc import user_cache as _user_cache
from soc.user_cache import load, store  # noqa: F401  (the npz files, written atomically)

ENV = _user_cache.ENV  # VISLOD_CACHE
cache_root = _user_cache.cache_root  # $VISLOD_CACHE, else the user's cache folder
# Bump when the stored layout or the chain algorithm changes: old entries are then ignored.
FORMAT_VERSION = "lod-chain-1"


def default_dir(kind: str = "lod") -> Path:
    """The cache folder of one kind of entry (``"lod"``, ``"calibration"``) under
    :func:`cache_root`."""
    return cache_root() / kind


def key(vertices: np.ndarray, faces: np.ndarray, params: dict) -> str:
    """Hex SHA-256 of the arrays (dtype, shape, bytes) and the sorted parameters."""
    import fast_simplification

    h = hashlib.sha256()
    h.update(FORMAT_VERSION.encode())
    h.update(str(getattr(fast_simplification, "__version__", "?")).encode())
    for a in (vertices, faces):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    h.update(repr(sorted(params.items())).encode())
    return h.hexdigest()
