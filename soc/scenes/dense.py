"""Dense meshes that need no data: closed, displaced cube-spheres ("rocks" and "statues") at any
triangle count, whose surfaces at different counts sample the same shape (so that a denser mesh
of one seed is the same object in more detail).

A cube's six faces are split into an ``n × n`` grid each (``12 n²`` triangles), welded along the
cube's edges by integer lattice position, pushed onto the unit sphere and displaced along
the normal by a sum of sinusoids of random directions (octaves of halving amplitude and
doubling frequency): smooth at every scale, deterministic for a seed.
"""

from __future__ import annotations

import numpy as np

# Octaves of the displacement and the amplitude of the first, relative to the radius.
OCTAVES = 6
AMPLITUDE = 0.18
# Sinusoids per octave.
WAVES = 5


def cube_sphere(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed unit sphere of ``12 n²`` triangles (outward winding): vertices (V, 3) float64,
    faces (12 n², 3) int64."""
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    i, j = i.reshape(-1), j.reshape(-1)
    q = np.arange(n).repeat(n), np.tile(np.arange(n), n)
    a = q[0] * (n + 1) + q[1]
    quads = np.stack([a, a + n + 1, a + n + 2, a + 1], 1)  # (n², 4) corner ids, one winding
    lattice, faces = [], []
    for axis in range(3):
        for side in (0, n):
            p = np.empty((len(i), 3), np.int64)
            u, v = (axis + 1) % 3, (axis + 2) % 3
            p[:, axis], p[:, u], p[:, v] = side, i, j
            base = sum(len(x) for x in lattice)
            lattice.append(p)
            tri = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]) + base
            if side == 0:
                tri = tri[:, ::-1]
            faces.append(tri)
    lattice = np.concatenate(lattice)
    faces = np.concatenate(faces)
    key = (lattice[:, 0] * (n + 1) + lattice[:, 1]) * (n + 1) + lattice[:, 2]
    uniq, inv = np.unique(key, return_inverse=True)
    faces = inv.reshape(-1)[faces]
    p = np.stack([uniq // (n + 1) ** 2, uniq // (n + 1) % (n + 1), uniq % (n + 1)], 1)
    p = p.astype(np.float64) / n * 2.0 - 1.0
    return p / np.linalg.norm(p, axis=1, keepdims=True), faces


def _displacement(dirs: np.ndarray, seed: int, octaves: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = np.zeros(len(dirs))
    for o in range(octaves):
        k = rng.normal(size=(WAVES, 3))
        k /= np.linalg.norm(k, axis=1, keepdims=True)
        phase = rng.uniform(0, 2 * np.pi, WAVES)
        freq = 1.5 * 2.0**o
        out += (AMPLITUDE * 0.5**o / np.sqrt(WAVES)) * np.sin(
            freq * dirs @ k.T * np.pi + phase
        ).sum(1)
    return out


def rock(triangles: int = 20_000, seed: int = 0, *, octaves: int = OCTAVES):
    """A closed displaced sphere ("rock") of about ``triangles`` triangles, radius about 1.

    Parameters
    ----------
    triangles : int
        Triangle count aimed for (the mesh has ``12 n²``, n the nearest integer).
    seed : int
        Shape (the same seed at any count is the same surface, sampled more finely).
    octaves : int
        Displacement octaves.

    Returns
    -------
    vertices : (V, 3) float32
    faces : (F, 3) int32
    """
    n = max(1, round(float(np.sqrt(max(int(triangles), 12) / 12.0))))
    dirs, faces = cube_sphere(n)
    r = 1.0 + _displacement(dirs, seed, octaves)
    rng = np.random.default_rng(seed + 7919)
    stretch = rng.uniform(0.7, 1.3, 3)
    return (dirs * r[:, None] * stretch).astype(np.float32), faces.astype(np.int32)


def statue(triangles: int = 20_000, seed: int = 0):
    """A closed upright figure: a displaced sphere stretched along y into a pillar with a
    waist, about 1 wide and 3 tall (same arguments and returns as :func:`rock`)."""
    v, f = rock(triangles, seed, octaves=OCTAVES)
    v = v.astype(np.float64)
    y = v[:, 1].copy()
    waist = 1.0 - 0.35 * np.exp(-((y - 0.2) ** 2) / 0.08)
    v[:, 0] *= waist
    v[:, 2] *= waist
    v[:, 1] = 1.5 * y
    return v.astype(np.float32), f
