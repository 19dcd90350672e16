"""A LOD chain seen level by level: the discrete levels of a simplified mesh
(Garland & Heckbert 1997 quadric simplification, seed 001) side by side, each coloured by its
error — the accumulated symmetric Hausdorff distance to the full mesh, on one shared scale.

Stages: one pyvista subplot per level (linked cameras), its mesh with the level's error as a
scalar on a common colour range, its triangle count and error as the title; a PNG off-screen.
pyvista is the optional ``viz`` extra (see :mod:`soc.viz`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from soc.viz import _pyvista, _window

# Each panel's pixels when no window size is given: small, so an off-screen render is fast.
PANEL_SIZE = (240, 240)
# The error's colour bar, inside the last panel (fractions of it) with short labels: pyvista's
# default place (from 0.35 to 0.95 of the panel) lets its last label run out of the picture.
SCALAR_BAR = {
    "title": "error",
    "color": "black",
    "n_labels": 3,
    "fmt": "%.2g",
    "position_x": 0.12,
    "position_y": 0.03,
    "width": 0.76,
    "height": 0.1,
    "title_font_size": 12,
    "label_font_size": 11,
}


def plot_chain(
    chain,
    *,
    off_screen: bool | None = None,
    screenshot: str | Path | None = None,
    window_size: tuple[int, int] | None = None,
    cmap: str = "viridis",
    show_edges: bool = True,
):
    """The levels of ``chain`` side by side, finest left, coloured by their error.

    Parameters
    ----------
    chain : lod.LodChain
    off_screen : bool, optional
        Default True when ``screenshot`` is given, else pyvista's.
    screenshot : path, optional
        Write a PNG there, close the plotter and return the image.
    window_size : (width, height), optional
        Default :data:`PANEL_SIZE` per level.
    cmap : str
        Colour map of the error (object units, 0 at the full mesh).
    show_edges : bool
        Draw the triangles' edges (how coarse each level is).

    Returns
    -------
    pyvista.Plotter, or (H, W, 3) uint8 image when ``screenshot`` was given.
    """
    pv = _pyvista()
    levels = tuple(getattr(chain, "levels", ()))
    if not levels:
        raise ValueError(f"chain must be a lod.LodChain with levels, got {chain!r}")
    n = len(levels)
    size = _window(window_size or (PANEL_SIZE[0] * n, PANEL_SIZE[1]))
    if screenshot is not None and off_screen is None:
        off_screen = True
    errors = np.array([lv.error for lv in levels], np.float64)
    clim = (0.0, float(errors.max()) if errors.max() > 0 else 1.0)
    pl = pv.Plotter(shape=(1, n), off_screen=off_screen, window_size=size, border=False)
    pl.set_background("white")
    for k, lv in enumerate(levels):
        pl.subplot(0, k)
        faces = np.asarray(lv.faces, np.int64)
        cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
        mesh = pv.PolyData(np.asarray(lv.vertices, np.float64), faces=cells)
        mesh.cell_data["error"] = np.full(len(faces), lv.error)
        pl.add_mesh(
            mesh,
            scalars="error",
            cmap=cmap,
            clim=clim,
            show_edges=show_edges,
            edge_color="black",
            show_scalar_bar=k == n - 1,
            scalar_bar_args=SCALAR_BAR,
        )
        pl.add_text(f"L{k}: {lv.triangles} tris\nerr {lv.error:.3g}", font_size=8, color="black")
        pl.view_isometric()
    pl.link_views()
    if screenshot is None:
        return pl
    img = pl.screenshot(str(screenshot), return_img=True)
    pl.close()
    return img
