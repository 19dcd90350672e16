"""Cases for checking screen-size estimates (:func:`lod.projected_area`) against the pixels a
rasterizer fills, as :mod:`soc.testing` has for culling methods: seeded random boxes, each seen
by cameras outside, close to and inside it (:func:`screen_size_cases`), where a box lies for
a camera (:func:`box_category`), the categories in which the estimates err differently, and
the estimates set beside the box's pixels in the oracle's id render
(:func:`measure_screen_size`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from soc.scenes.camera import Camera

CATEGORIES = ("on screen", "cut by viewport", "crossing near plane", "eye inside")


def screen_size_cases(
    boxes: int, cams_per_box: int, resolution: tuple[int, int], seed: int = 0
) -> list[tuple[np.ndarray, list[Camera]]]:
    """``[(aabb (2, 3), cameras)]``: random boxes (corners in [-3, 3]³, sides 0.05 … 4), each
    seen by cameras cycling through: outside (2 … 15 units away, looking near the box), close
    to it (often crossing the near plane), inside it; field of view 40 … 90°, near plane 0.05,
    0.3 or 1."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(boxes):
        lo = rng.uniform(-3, 3, 3)
        hi = lo + rng.uniform(0.05, 4, 3)
        cams = []
        for c in range(cams_per_box):
            if c % 3 == 0:
                d, centre = rng.normal(size=3), (lo + hi) / 2
                eye = centre + d / np.linalg.norm(d) * rng.uniform(2, 15)
                target = centre + rng.normal(size=3) * 1.5
            else:  # close to the box, or inside it
                eye = rng.uniform(lo - 0.5, hi + 0.5) if c % 3 == 1 else rng.uniform(lo, hi)
                target = eye + rng.normal(size=3)
            if np.linalg.norm(np.cross(target - eye, (0, 1, 0))) < 1e-6:
                target = eye + np.array([1.0, 0.0, 0.3])
            fov, near = float(rng.uniform(40, 90)), float(rng.choice([0.05, 0.3, 1.0]))
            w, h = resolution
            cams.append(
                Camera.look_at(eye, target, fov_y=fov, width=w, height=h, near=near, far=1e3)
            )
        out.append((np.stack([lo, hi]), cams))
    return out


def box_category(aabb: np.ndarray, camera: Camera) -> str:
    """Where box ``aabb`` (2, 3) lies for ``camera``: one of :data:`CATEGORIES`, or
    ``"behind"`` (entirely nearer than the near plane: nothing to draw)."""
    lo, hi = np.asarray(aabb, np.float64)
    eye = np.asarray(camera.eye)
    if np.all((lo <= eye) & (eye <= hi)):
        return "eye inside"
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
    corners = np.c_[np.where(bits == 1, hi, lo), np.ones(8)]
    depth = -(corners @ camera.view.T)[:, 2]
    if depth.max() <= camera.near:
        return "behind"
    if depth.min() < camera.near:
        return "crossing near plane"
    clip = corners @ camera.view_proj.T
    ndc = clip[:, :2] / clip[:, 3:]
    return "on screen" if np.all(np.abs(ndc) <= 1.0) else "cut by viewport"


def measure_screen_size(cases, *, min_pixels: int = 100, bar=None) -> list[dict[str, Any]]:
    """Per (box, camera) of ``cases``: category, ``pixels`` of the box in the oracle's id render
    (depth test on, no culling), the ``naive`` and ``exact`` estimates and their relative errors
    ``(estimate − pixels) / pixels`` (None below ``min_pixels``, where the boundary pixels of
    pixel-centre sampling dominate any estimate); ``bar`` (tqdm) advances per box."""
    import soc
    from lod.screen_size import projected_area
    from soc.scenes.clutter import box_mesh

    rows = []
    for b, (aabb, cams) in enumerate(cases):
        scene = soc.Scene.from_meshes([box_mesh(aabb[0], aabb[1])])
        with soc.Oracle(scene) as oracle:
            for c, cam in enumerate(cams):
                px = int(np.count_nonzero(oracle.id_buffer(cam) == 0))
                est = {e: float(projected_area(scene.aabbs, cam, exact=e == "exact")[0])
                       for e in ("naive", "exact")}  # fmt: skip
                rows.append({"box": b, "camera": c, "category": box_category(aabb, cam),
                             "pixels": px, **est,
                             **{f"{e}_rel_error": (a - px) / px if px >= min_pixels else None
                                for e, a in est.items()}})  # fmt: skip
        if bar is not None:
            bar.update(1)
    return rows
