"""Pictures of what a culling method decided: the scene coloured per object by its
class, the camera's frustum, the flight path; and a method's depth / HiZ pyramid levels.

Stages: :func:`classify` (pure numpy: the cull's mask against the frustum test and the exact
oracle of seed 000's correctness criterion — a conservative method never culls what the oracle
sees) → :func:`plot_cull` (pyvista: one mesh for the whole scene, per-cell class colours,
occluders outlined, frustum and path as lines) → a Plotter, or a PNG written off-screen.
:func:`plot_pyramid` draws the max-depth pyramid of the hierarchical Z-buffer (Greene, Kass &
Miller 1993) with matplotlib: its levels are 2D images, which matplotlib shows pixel for pixel.

pyvista is the optional ``viz`` extra and is imported on first use; off-screen it renders
through EGL (``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow``, set here when unset), beside
vislod's own EGL context.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from soc.culling.frustum import aabbs_in_frustum
from soc.scenes.camera import Camera

# Off-screen VTK must pick EGL on a machine without X; set before pyvista (VTK) is imported.
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

VISIBLE, FALSE_KEEP, OCCLUSION_CULLED, FRUSTUM_CULLED, FALSE_CULL = range(5)
CLASS_NAMES = (
    "visible and kept",
    "hidden but kept (false keep)",
    "culled by occlusion",
    "culled by the frustum",
    "false cull (visible but culled)",
)
# RGB per class, chosen so that each has a dominant channel a test can find after shading:
# green, orange, blue, light grey, red.
CLASS_COLORS = np.array(
    [(60, 190, 75), (245, 150, 20), (70, 110, 220), (200, 200, 200), (230, 20, 20)], np.uint8
)
# The "iso" overview's direction from the scene, in units of the camera's backward axis: this
# much world-up (looking down over the occluders at what they hide) and camera-right.
ISO_UP, ISO_RIGHT = 1.5, 0.6
# Legend labels (short: a 320-pixel-wide picture still shows them whole).
LEGEND_LABELS = ("visible", "false keep", "occlusion-culled", "frustum-culled", "FALSE CULL")
# The legend box: height per entry and widest box (fractions of the window), the width of a
# glyph per unit of entry height, and the box's margin and symbol column.
LEGEND_ENTRY_HEIGHT, LEGEND_MAX_WIDTH, LEGEND_GLYPH_ASPECT, LEGEND_MARGIN = 0.06, 0.9, 0.5, 0.07
LEGEND_BORDER = 0.02  # from the picture's top right corner
FRUSTUM_COLOR = (20, 20, 20)
PATH_COLOR = (150, 40, 200)
# Small windows keep off-screen llvmpipe renders fast; callers ask for more.
DEFAULT_WINDOW = (640, 480)
VIZ_EXTRA = "soc.viz needs pyvista: pip install 'vislod[viz]'"


def _pyvista():
    """pyvista, or ImportError naming the ``viz`` extra."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista
    except ImportError as exc:
        raise ImportError(VIZ_EXTRA) from exc
    return pyvista


def _truth(scene, camera: Camera, truth) -> np.ndarray | None:
    if truth is None:
        return None
    if isinstance(truth, str):
        if truth != "oracle":
            raise ValueError(f"truth must be a bool mask, 'oracle' or None, got {truth!r}")
        from soc.culling.oracle import exact_visibility

        return exact_visibility(scene, camera)
    t = np.asarray(truth)
    if t.shape != (len(scene),) or t.dtype != bool:
        raise ValueError(f"truth must be a ({len(scene)},) bool mask, got {t.dtype} {t.shape}")
    return t


def classify(scene, camera: Camera, result, truth=None) -> tuple[np.ndarray, tuple[str, ...]]:
    """Each object's class in a cull's picture.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    result : CullResult or (N,) bool
        The cull's kept mask (``result.visible``).
    truth : (N,) bool, ``"oracle"`` or None
        Exact visibility (``"oracle"`` computes :func:`soc.exact_visibility` at the camera's
        resolution). Without it every kept object is class 0 and nothing is a false cull.

    Returns
    -------
    classes : (N,) int8
        Index into ``names``: 0 visible and kept, 1 hidden but kept, 2 culled by occlusion
        (inside the frustum), 3 culled by the frustum, 4 false cull (culled, the truth sees it).
    names : tuple of 5 str
        :data:`CLASS_NAMES`; without truth name 0 is ``"kept"``.
    """
    kept = np.asarray(getattr(result, "visible", result))
    if kept.shape != (len(scene),) or kept.dtype != bool:
        raise ValueError(
            f"result must be a CullResult or a ({len(scene)},) bool mask, got {kept.dtype} "
            f"{kept.shape}"
        )
    truth = _truth(scene, camera, truth)
    inside = aabbs_in_frustum(scene.aabbs, camera)
    classes = np.where(inside, OCCLUSION_CULLED, FRUSTUM_CULLED).astype(np.int8)
    classes[kept] = VISIBLE
    names = CLASS_NAMES
    if truth is None:
        names = ("kept",) + CLASS_NAMES[1:]
    else:
        classes[kept & ~truth] = FALSE_KEEP
        classes[~kept & truth] = FALSE_CULL
    return classes, names


def class_counts(classes: np.ndarray) -> np.ndarray:
    """(5,) int64 objects per class of :func:`classify`."""
    return np.bincount(np.asarray(classes, np.int64), minlength=len(CLASS_NAMES))


_CORNER_SIGNS = ((-1, -1), (1, -1), (1, 1), (-1, 1))


def frustum_corners(camera: Camera, far: float | None = None) -> np.ndarray:
    """(2, 4, 3) float64 world corners of the near and far rectangles (bottom-left,
    bottom-right, top-right, top-left); ``far`` (world units) cuts the drawn frustum short of
    ``camera.far``."""
    far = camera.far if far is None else float(far)
    right, up, back = camera.basis
    t = np.tan(np.radians(camera.fov_y) / 2.0)
    out = np.empty((2, 4, 3))
    for i, d in enumerate((camera.near, far)):
        h, w = d * t, d * t * camera.aspect
        c = np.asarray(camera.eye) - back * d
        out[i] = [c + sx * w * right + sy * h * up for sx, sy in _CORNER_SIGNS]
    return out


def _lines(points: np.ndarray, segments: np.ndarray):
    pv = _pyvista()
    cells = np.hstack([np.full((len(segments), 1), 2), segments]).ravel()
    return pv.PolyData(np.asarray(points, np.float64), lines=cells)


def _frustum_mesh(camera: Camera, far: float):
    corners = frustum_corners(camera, far).reshape(8, 3)
    points = np.vstack([corners, np.asarray(camera.eye)[None]])
    ring = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    segments = np.vstack([ring, ring + 4, [[8, 4], [8, 5], [8, 6], [8, 7]]])
    return _lines(points, segments)


def scene_mesh(scene, cell_rgb: np.ndarray | None = None, mask: np.ndarray | None = None):
    """The scene (or the objects of ``mask``) as one pyvista PolyData; ``cell_rgb`` (N, 3)
    uint8 per object becomes the cell array ``"rgb"``."""
    pv = _pyvista()
    n = len(scene)
    owner = np.repeat(np.arange(n), scene.triangle_counts)
    faces = scene.faces.astype(np.int64) + scene.vertex_offsets[owner][:, None]
    if mask is not None:
        keep = np.asarray(mask, bool)[owner]
        faces, owner = faces[keep], owner[keep]
    cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
    mesh = pv.PolyData(np.asarray(scene.vertices, np.float64), faces=cells)
    mesh.cell_data["object"] = owner
    if cell_rgb is not None:
        mesh.cell_data["rgb"] = np.asarray(cell_rgb, np.uint8)[owner]
    return mesh


def _legend_size(labels: Sequence[str], window_size) -> tuple[float, float]:
    """(width, height) of the legend box as fractions of the window, wide enough for its
    longest label: VTK sizes the text by the box's height per entry and lets a label run out
    of a narrow box (and out of the picture at its right edge)."""
    width_px, height_px = (int(v) for v in window_size)
    entry = LEGEND_ENTRY_HEIGHT
    longest = max(len(label) for label in labels)
    # a glyph is about half as wide as the entry is tall; the box's margin and symbol column
    # take about 0.06 of the window on top of the text
    width = LEGEND_MARGIN + entry * LEGEND_GLYPH_ASPECT * longest * height_px / width_px
    if width > LEGEND_MAX_WIDTH:  # a narrow window: smaller text rather than a clipped label
        scale = (LEGEND_MAX_WIDTH - LEGEND_MARGIN) / (width - LEGEND_MARGIN)
        entry *= scale
        width = LEGEND_MAX_WIDTH
    return float(width), float(entry * len(labels))


def _window(window_size) -> tuple[int, int]:
    w, h = (int(v) for v in window_size)
    if w <= 0 or h <= 0:
        raise ValueError(f"window_size must be two positive integers, got {window_size!r}")
    return w, h


def plot_cull(
    scene,
    camera: Camera,
    result,
    truth=None,
    *,
    off_screen: bool | None = None,
    screenshot: str | Path | None = None,
    path: Sequence[Camera] | None = None,
    window_size: tuple[int, int] = DEFAULT_WINDOW,
    view: str | Any = "iso",
    legend: bool = True,
    plotter=None,
):
    """The scene coloured by what the cull decided, its occluders outlined, the camera's
    frustum (and optionally the flight path) drawn.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        The camera that was culled for.
    result : CullResult or (N,) bool
    truth : (N,) bool, ``"oracle"`` or None
        See :func:`classify`; with it, hidden kept objects (orange) and false culls (red) show.
    off_screen : bool, optional
        Render without a window; default True when ``screenshot`` is given, else pyvista's.
        Interactive (False) in Jupyter uses pyvista's notebook backend.
    screenshot : path, optional
        Write a PNG there, close the plotter and return the image.
    path : sequence of Camera, optional
        A flight path, drawn as a polyline through the eyes.
    window_size : (width, height)
        Pixels of the picture.
    view : ``"iso"``, ``"xy"``, ``"camera"`` or a pyvista camera position
        Where the picture is seen from; ``"camera"`` looks through ``camera`` itself.
    legend : bool
        A legend of the classes present, with their counts.
    plotter : pyvista.Plotter, optional
        Draw into it (e.g. a subplot) instead of a new one.

    Returns
    -------
    pyvista.Plotter, or (H, W, 3) uint8 image when ``screenshot`` was given.
    """
    pv = _pyvista()
    classes, names = classify(scene, camera, result, truth)
    if screenshot is not None and off_screen is None:
        off_screen = True
    own = plotter is None
    if own:
        pl = pv.Plotter(off_screen=off_screen, window_size=_window(window_size))
    else:
        pl = plotter
    pl.set_background("white")
    pl.add_mesh(scene_mesh(scene, CLASS_COLORS[classes]), scalars="rgb", rgb=True)
    if scene.occluder.any():
        edges = scene_mesh(scene, mask=scene.occluder).extract_feature_edges(
            feature_angle=30.0, boundary_edges=True, non_manifold_edges=False, manifold_edges=False
        )
        if edges.n_points:
            pl.add_mesh(edges, color="black", line_width=1)
    # Frustum drawn to the far side of the scene, not to ``camera.far`` (often 1000 units).
    corners = np.asarray(scene.bounds, np.float64).reshape(2, 3)
    box = np.array(np.meshgrid(*corners.T)).reshape(3, -1).T
    depth = (box - np.asarray(camera.eye)) @ camera.forward
    far = float(np.clip(depth.max(), camera.near * 2.0, camera.far))
    pl.add_mesh(_frustum_mesh(camera, far), color=FRUSTUM_COLOR, line_width=2)
    if path is not None and len(path) > 1:
        eyes = np.array([c.eye for c in path], np.float64)
        seg = np.stack([np.arange(len(eyes) - 1), np.arange(1, len(eyes))], axis=1)
        pl.add_mesh(_lines(eyes, seg), color=PATH_COLOR, line_width=2)
    if legend:
        counts = class_counts(classes)
        entries = [
            [
                f"{'kept' if names[k] == 'kept' else LEGEND_LABELS[k]} {counts[k]}",
                CLASS_COLORS[k] / 255.0,
            ]
            for k in range(len(names))
            if counts[k]
        ]
        if entries:
            size = _legend_size([e[0] for e in entries], pl.window_size)
            actor = pl.add_legend(entries, bcolor="white", size=size, face=None)
            # placed here: pyvista's loc="upper right" offsets the box by its height, not its
            # width, so a wide box would run out of the picture
            actor.SetPosition(1.0 - size[0] - LEGEND_BORDER, 1.0 - size[1] - LEGEND_BORDER)
            actor.SetPosition2(*size)
    if view == "camera":
        pl.camera_position = [camera.eye, camera.target, tuple(camera.basis[1])]
        pl.camera.view_angle = camera.fov_y
    elif view == "iso":  # behind, above and right of the camera, y up: what it culled shows
        right, _, back = camera.basis
        pl.camera_position = [
            tuple(back + ISO_UP * np.array([0, 1, 0]) + ISO_RIGHT * right),
            (0.0, 0.0, 0.0),
            (0.0, 1.0, 0.0),
        ]
        pl.reset_camera()
    elif view is not None:
        pl.camera_position = view
        pl.reset_camera()
    if screenshot is None:
        return pl
    img = pl.screenshot(str(screenshot), return_img=True)
    if own:
        pl.close()
    return img


def _levels(pyramid_or_depth) -> list[np.ndarray]:
    """The levels of a DepthPyramid, a hiz-cpu Pyramid, a list of arrays or one depth array."""
    p = pyramid_or_depth
    if hasattr(p, "level") and hasattr(p, "__len__"):  # soc.culling.hiz_gpu.DepthPyramid
        return [p.level(k) for k in range(len(p))]
    if hasattr(p, "level") and hasattr(p, "levels"):  # soc.culling.hiz_cpu.Pyramid
        return [p.level(k) for k in range(p.levels)]
    if isinstance(p, np.ndarray):
        if p.ndim != 2 or p.size == 0:
            raise ValueError(f"depth must be a non-empty (H, W) array, got shape {p.shape}")
        from soc.culling.hiz_gpu import reference_pyramid

        return reference_pyramid(p)
    levels = [np.asarray(a, np.float32) for a in p]
    if not levels or any(a.ndim != 2 or a.size == 0 for a in levels):
        raise ValueError(f"levels must be non-empty (H, W) arrays, got {[a.shape for a in levels]}")
    return levels


def plot_pyramid(pyramid_or_depth, levels: Sequence[int] | int | None = None, *, path=None):
    """A method's max-depth (HiZ) pyramid, one panel per level, sharing one depth colour scale.

    matplotlib, not pyvista: the levels are 2D images, and matplotlib shows each texel as one
    flat square with its value on a colour bar.

    Parameters
    ----------
    pyramid_or_depth : DepthPyramid, hiz-cpu Pyramid, list of (H_k, W_k) arrays or (H, W) depth
        A depth array (window depth in [0, 1], row 0 at the bottom as GL reads it) is reduced
        with :func:`soc.culling.hiz_gpu.reference_pyramid`.
    levels : int or sequence of int, optional
        Which levels (an int: the first that many); default up to 6 levels spread over all.
    path : path, optional
        Write the figure there (PNG).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    all_levels = _levels(pyramid_or_depth)
    n = len(all_levels)
    if levels is None:
        pick = sorted(set(np.linspace(0, n - 1, min(n, 6)).round().astype(int).tolist()))
    elif isinstance(levels, int | np.integer):
        if not 1 <= levels <= n:
            raise ValueError(f"levels must be in 1..{n}, got {levels}")
        pick = list(range(int(levels)))
    else:
        pick = [int(k) for k in levels]
        bad = [k for k in pick if not 0 <= k < n]
        if bad or not pick:
            raise ValueError(f"levels must be in 0..{n - 1}, got {list(levels)}")
    finite = np.concatenate([all_levels[k][np.isfinite(all_levels[k])] for k in pick])
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    fig = Figure(figsize=(2.6 * len(pick) + 0.8, 2.6), layout="constrained")
    axes = fig.subplots(1, len(pick), squeeze=False)[0]
    for ax, k in zip(axes, pick, strict=True):
        a = all_levels[k]
        im = ax.imshow(a, origin="lower", cmap="viridis", vmin=vmin, vmax=vmax)
        ax.set_title(f"level {k}: {a.shape[1]}×{a.shape[0]}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.colorbar(im, ax=list(axes), label="max window depth", shrink=0.8)
    if path is not None:
        fig.savefig(path, dpi=100)
    return fig
