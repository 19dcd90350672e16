"""meshoptimizer's simplifier called from numba: many small meshes (the groups of a DAG level)
simplified in one parallel loop, without a Python call or the GIL per mesh.

The ``meshoptimizer`` package wraps the C library with ctypes; :func:`simplify_function` takes
the library's ``meshopt_simplify`` and types its pointers as ``void *``, which numba can call
(the function is an argument of the kernel, so the kernel is cached like any other).
:func:`simplify_ranges` remaps each mesh to its own vertices exactly as
``lod.dag._simplify`` does, so the results are the same bit for bit.
"""

from __future__ import annotations

import ctypes

import numba
import numpy as np

# meshoptimizer's option bits (meshopt_SimplifyLockBorder, meshopt_SimplifyErrorAbsolute).
LOCK_BORDER = 1
ERROR_ABSOLUTE = 4


def simplify_function():
    """A ctypes function for meshoptimizer's ``meshopt_simplify`` whose pointer arguments are
    ``void *``, or None where the ``meshoptimizer`` package or its library is missing or its
    option bits differ from :data:`LOCK_BORDER` and :data:`ERROR_ABSOLUTE`."""
    try:
        import meshoptimizer
        from meshoptimizer._loader import lib
    except ImportError:
        return None
    if (meshoptimizer.SIMPLIFY_LOCK_BORDER, meshoptimizer.SIMPLIFY_ERROR_ABSOLUTE) != (
        LOCK_BORDER,
        ERROR_ABSOLUTE,
    ):  # pragma: no cover - a wrapper that renumbered the options
        return None
    p, size = ctypes.c_void_p, ctypes.c_size_t
    proto = ctypes.CFUNCTYPE(
        size, p, p, size, p, size, size, size, ctypes.c_float, ctypes.c_uint, p
    )
    return proto(ctypes.cast(lib.meshopt_simplify, p).value)


def simplify_ranges(
    fn,
    vertices: np.ndarray,
    tri: np.ndarray,
    offsets: np.ndarray,
    max_errors: np.ndarray,
    options: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simplify each mesh ``tri[offsets[g]:offsets[g + 1]]`` to half its triangles.

    Parameters
    ----------
    fn
        :func:`simplify_function`'s result.
    vertices : (V, 3) float32
    tri : (T, 3) int64
        The meshes' triangles, indices into ``vertices``, one mesh after another.
    offsets : (G + 1,) int64
        Mesh ``g`` is ``tri[offsets[g]:offsets[g + 1]]``.
    max_errors : (G,) float
        Each mesh's ``target_error`` (meshoptimizer stops before exceeding it).
    options : int
        meshoptimizer's option bits.

    Returns
    -------
    out : (T, 3) int64
        Mesh ``g``'s simplified triangles are ``out[offsets[g]:offsets[g] + counts[g]]``.
    counts : (G,) int64
    errors : (G,) float32
        meshoptimizer's ``result_error`` of each mesh.
    """
    return _simplify_kernel(
        fn,
        np.ascontiguousarray(vertices, np.float32),
        np.ascontiguousarray(tri, np.int64),
        np.asarray(offsets, np.int64),
        np.asarray(max_errors, np.float64),
        int(options),
    )


@numba.njit(cache=True, parallel=True)
def _simplify_kernel(fn, vertices, tri, offsets, max_errors, options):
    g_n = len(offsets) - 1
    out = np.empty_like(tri)
    counts = np.zeros(g_n, np.int64)
    errors = np.zeros(g_n, np.float32)
    for g in numba.prange(g_n):
        t0, t1 = offsets[g], offsets[g + 1]
        if t1 == t0:
            continue
        idx = tri[t0:t1].ravel()
        used = np.unique(idx)  # the mesh's own vertices, in increasing order
        local = np.searchsorted(used, idx).astype(np.uint32)
        pos = np.empty((len(used), 3), np.float32)
        for i in range(len(used)):
            for k in range(3):
                pos[i, k] = vertices[used[i], k]
        dest = np.empty(len(idx), np.uint32)
        err = np.zeros(1, np.float32)
        target = max(3 * ((t1 - t0) // 2), 3)
        n = fn(
            dest.ctypes, local.ctypes, len(idx), pos.ctypes, len(used), 12, target,
            max_errors[g], options, err.ctypes,
        )  # fmt: skip
        for i in range(n // 3):
            for k in range(3):
                out[t0 + i, k] = used[dest[3 * i + k]]
        counts[g] = n // 3
        errors[g] = err[0]
    return out, counts, errors
