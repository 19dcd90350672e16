"""Writes the thin notebooks that call the experiments and show their tables and pictures:
``notebooks/seed000_soc.ipynb`` (seed 000), ``notebooks/seed000_methods.ipynb`` (seed 000
with every culling method), ``notebooks/seed001_rendering.ipynb`` (seed 001's portal
culling, state sorting and image-based techniques) and ``notebooks/seed002_grid.ipynb`` (seed
002's grid experiment).
Quick mode when ``VISLOD_QUICK`` is set.

The notebooks are generated without outputs, so that they stay a view of the experiments
rather than a second copy of them: ``python -m experiments.notebooks``. Needs ``nbformat``
(the ``notebooks`` extra).
"""

from __future__ import annotations

import os
from pathlib import Path

FOLDER = Path(__file__).resolve().parents[1] / "notebooks"

# -- seed 000 ----------------------------------------------------------------------------------

SOC_INTRO = """\
# Seed 000 — OpenGL occlusion culling on Mesa (llvmpipe) in Intel's SOC framework

This notebook computes seed 000's experiment into DataFrames (one row per frame × culling
configuration, the oracle's exact visible set beside every frame), draws Abb. 1, 4, 6–10 from
them, and sets our claims beside the document's numbers. `VISLOD_QUICK=1`: 6 frames at a
quarter of the resolution on the small market (seconds); the full run (100 frames at 1080p,
six depth resolutions, 27,025 objects) takes about a quarter of an hour on two CPU cores."""

METHODS_INTRO = """\
# Seed 000 — the five culling methods, and every other method we have

Seed 000 compares five culling methods on Intel's castle flight: % of triangles culled per
frame at a 1920×1080 depth buffer (Abb. 8 left) and frames per second per method (Abb. 10).
Here every registered culling method (`soc.method_names()`, `methods=("all",)`) flies the same
flight; each is drawn at the display resolution, its frame time = cull + draw is measured on
this machine, and its false culls are counted against an exact per-object id render (the
oracle). `VISLOD_QUICK=1`: 6 frames at a quarter of the resolution on the small market; the
full run takes about half an hour on two CPU cores."""


def scene_view_cells(method: str = "hiz-gpu") -> list:
    """One frame of the flight seen from outside in 3D (:func:`soc.viz.plot_cull`, the
    ``viz`` extra): kept and visible, false keeps, occlusion- and frustum-culled objects, false
    culls in red, the camera's frustum and the flight path."""
    from nbformat import v4

    return [
        v4.new_markdown_cell(
            f"## One frame in 3D: what `{method}` kept (`soc.viz.plot_cull`)\n\n"
            "Green: visible and kept; orange: hidden but kept (false keeps); blue: culled by "
            "occlusion; grey: culled by the frustum; red: a visible object culled (none for a "
            "conservative method). Occluders outlined; the camera's frustum and the flight "
            "path drawn. Off-screen (EGL) here; `off_screen=False` gives an interactive view."
        ),
        v4.new_code_cell(
            "import tempfile\n\n"
            "from matplotlib.figure import Figure\n\n"
            "import soc\n"
            "import soc.viz\n"
            "from experiments.common import load_scene\n\n"
            'scene = load_scene("market", quick=quick)\n'
            "cams = soc.scenes.paths.flight(scene, frames=12, width=480, height=270)\n"
            f'with soc.Culler(scene, "{method}", (480, 270)) as culler:\n'
            "    result = culler.cull(cams[6])\n"
            'png = tempfile.NamedTemporaryFile(suffix=".png").name\n'
            "image = soc.viz.plot_cull(\n"
            '    scene, cams[6], result, truth="oracle", path=cams, screenshot=png, '
            "window_size=(960, 600)\n"
            ")\n"
            "fig = Figure(figsize=(9.6, 6))\n"
            "ax = fig.add_axes((0, 0, 1, 1))\n"
            "ax.imshow(image)\n"
            'ax.axis("off")\n'
            "fig"
        ),
    ]


def build_soc():
    """``seed000_soc.ipynb`` as an ``nbformat`` node (no outputs)."""
    from nbformat import v4

    cells = [v4.new_markdown_cell(SOC_INTRO), *experiment_cells("seed000"), *scene_view_cells()]
    return notebook(cells, "seed000")


def build_methods():
    """``seed000_methods.ipynb`` as an ``nbformat`` node (no outputs)."""
    from nbformat import v4

    cells = experiment_cells("seed000", overrides={"methods": ("all",)})
    cells += scene_view_cells("masked")
    return notebook([v4.new_markdown_cell(METHODS_INTRO), *cells], "seed000-methods")


# -- seed 002: grid ----------------------------------------------------------------------------

GRID_INTRO = """\
# Seed 002 — occlusion queries on a uniform grid

**Seed 002** (a thesis on hardware occlusion queries with grid traversal) visits the grid
cells the view frustum touches front to back, queries each non-empty cell, and uses the
results one frame later (no stalls, but popping). It shows frame rate and drawn nodes per
frame with occlusion culling off and with query caps 4000/3000/2000, on three grid sizes,
indoors and outdoors, and claims: caps 4000 and 3000 look alike, 3000 pops more, 2000 pops
unacceptably; without culling the frame rate fluctuates and dips when many nodes are drawn;
a sparser grid is better outdoors, a tighter one indoors, the one in between is the most even;
culling sometimes makes a frame slower. We measure each claim on an outdoor segment (the
market flight) and an indoor one (a walk through generated rooms). The document's caps never
bind on our scenes (at most about a thousand non-empty cells), so caps scaled to our mean
queries per frame are run as well.

Below, the experiment (`experiments/seed002_grid.py`, `vislod seed002` or `vislod grid`) is
computed into DataFrames, its pictures are drawn from them and its claims set beside the
thesis's words. `VISLOD_QUICK=1`: a few frames at a quarter of the resolution (seconds); the
full run takes a few minutes on two CPU cores."""


def notebook(cells, prefix: str):
    """Cells → a validated notebook with stable cell ids (``prefix-NN``) and no outputs."""
    import nbformat
    from nbformat import v4

    for i, cell in enumerate(cells):  # stable ids: regenerating gives the same file
        cell["id"] = f"{prefix}-{i:02d}"
    nb = v4.new_notebook(
        cells=cells,
        metadata={
            "kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"},
            "language_info": {"name": "python"},
        },
    )
    nbformat.validate(nb)
    return nb


def experiment_cells(key: str, overrides: dict | None = None) -> list:
    """The cells that show one harness experiment: its introduction, parameters at the top
    (quick with ``VISLOD_QUICK``; ``overrides``: parameters the notebook sets), the
    computation, every DataFrame, every picture drawn inline
    from the frames by the experiment's importable plotting functions (caption above), and
    the claims beside the document's numbers."""
    from nbformat import v4

    from experiments import harness

    exp = harness.get(key)
    mod = exp.module.rsplit(".", 1)[-1]
    given = "".join(f", {k}={v!r}" for k, v in (overrides or {}).items())
    cells = [
        v4.new_markdown_cell(f"## Seed {exp.seed} — {exp.title}\n\n{exp.intro}"),
        v4.new_code_cell(
            "%matplotlib inline\n"
            f"from experiments import harness, {mod}\n"
            "from experiments.common import env_quick\n\n"
            f'exp = harness.get("{exp.key}")\n'
            "quick = env_quick()  # VISLOD_QUICK=1: small and fast\n"
            "# Change any parameter here, e.g. exp.make_params(quick, frames=30):\n"
            f"params = exp.make_params(quick{given})\n"
            "params"
        ),
        v4.new_code_cell("frames = exp.compute(params, progress=True)\nlist(frames)"),
    ]
    cells += [v4.new_code_cell(f'frames["{name}"]') for name in _frame_names(exp)]
    for plot in exp.plots:
        cells.append(v4.new_markdown_cell(f"### {exp.caption(plot)}"))
        cells.append(v4.new_code_cell(f"{mod}.{plot.__name__}(frames, params)"))
    cells.append(v4.new_markdown_cell("### The claims, beside the document"))
    cells.append(v4.new_code_cell("exp.claims(frames, params)"))
    return cells


def _frame_names(exp) -> list[str]:
    """The frames an experiment returns, from ``FRAMES`` in its module (``[]`` if absent)."""
    import importlib

    return list(getattr(importlib.import_module(exp.module), "FRAMES", ()))


def image_cell(names) -> str:
    """Code that displays the PNGs ``names`` from the notebook's ``out`` folder."""
    return "\n".join(f'display(Image(filename=str(out / "{name}")))' for name in names)


def build_grid():
    """``seed002_grid.ipynb``: the introduction, then the experiment's cells."""
    from nbformat import v4

    cells = [v4.new_markdown_cell(GRID_INTRO), *experiment_cells("seed002")]
    return notebook(cells, "seed002-grid")


# -- seed 001: portals, state sorting, image-based techniques ----------------------------------

RENDERING_INTRO = """\
# Seed 001 — portal culling, state sorting, image-based techniques

Zachmann's VR lecture on real-time rendering (seed 001) covers, besides levels of detail
(`seed001_lod.ipynb`), portal culling in buildings, state sorting with a sorting buffer, and
image-based techniques (stereo by warping, the decoupled warping renderer, z-compositing).
Each section below computes one experiment into tidy DataFrames, draws its pictures from them
and lists its claims beside the lecture's words. `VISLOD_QUICK=1`: small scenes, few frames
(about a minute in all); the full runs take a few minutes each on two CPU cores."""


def build_rendering():
    """``seed001_rendering.ipynb``: the introduction, then each seed-001 rendering experiment's
    cells (:func:`experiment_cells`)."""
    from nbformat import v4

    cells = [v4.new_markdown_cell(RENDERING_INTRO)]
    for key in ("seed001-portals", "seed001-state-sorting", "seed001-image-based"):
        cells += experiment_cells(key)
    return notebook(cells, "seed001-rendering")


# -- seed 001: levels of detail ----------------------------------------------------------------

LOD_INTRO = """\
# Seed 001 — levels of detail

Zachmann's VR lecture (seed 001) on LOD: chains of reduced meshes built offline by edge
collapses (the quadric error of Garland & Heckbert as the reference, Melax's simple cost
‖U−V‖·curv(U) as the lecture's own), the object's size on screen (naive: the 2D box of the
8 projected corners; exact: the silhouette polygon from a 27-region lookup table), and the
selection of a level per object under a frame-time budget: static distance bands, reactive
(frame-time history → coarser/finer: overshoots), and predictive (Funkhouser & Séquin 1993:
benefit/cost, greedy multiple-choice knapsack; and the incremental variant). The lecture's
picture pair: *no detail elision, 19,821 polygons* vs *optimization, 1,389 polygons at a
0.1 s/frame target*, and a picture where darker grey means a more detailed level.

The cost model `max(C1·Poly + C2·Vert, C3·Pixels)` is measured on this GL context, as
Funkhouser and Séquin did, by drawing every level of every object at several sizes.

All the work is done by `experiments/seed001_lod_budget.py` (`vislod seed001-lod`, or
`vislod lod`) and `experiments/seed001_lod_quality.py` (`vislod seed001-lod-quality`, or
`vislod lod-quality`; its meshes from `VISLOD_DATA` in full runs). `VISLOD_QUICK=1`:
small scenes and meshes (seconds); the full runs take a few minutes each."""


def build_lod():
    """``seed001_lod.ipynb``: the introduction, then the budget and the quality experiments'
    cells (:func:`experiment_cells`)."""
    from nbformat import v4

    cells = [v4.new_markdown_cell(LOD_INTRO)]
    for key in ("seed001-lod", "seed001-lod-quality"):
        cells += experiment_cells(key)
    return notebook(cells, "seed001-lod")


SEED003_INTRO = """\
# Seed 003 — forward vs deferred shading: complexity in V, VP and L

The lecture bounds forward rasterization by O(V · VP · L) in the worst case (every fragment
lit by every light before the depth test) and deferred shading by O(V · VP + L · VP) (the
depth test first, into a g-buffer; then the lights over pixels), with a g-buffer of depth
24 bit, normal 2 × 32 bit, diffuse 3 × 32 bit and material 16 bit: ≈ 25 MB at 1024 × 1024.
Below, both paths (`soc.rendering.shading`) render a stack of spheres on this machine's GL
context (Mesa llvmpipe); the sweeps are computed into DataFrames, the pictures drawn from them
and the claims judged on CPU time (the work), as slopes and ratios: llvmpipe's absolute times
are compared with nothing. `VISLOD_QUICK=1`: the quick sweep (about a minute); the full one
takes a few minutes on two cores."""


def build_seed003():
    """``seed003_complexity.ipynb``: the introduction, then the experiment's cells."""
    from nbformat import v4

    cells = [v4.new_markdown_cell(SEED003_INTRO), *experiment_cells("seed003")]
    return notebook(cells, "seed003-complexity")


# -- seed 004: performance model, octree, adaptive method ----------------------------------------

SEED004_INTRO = """\
# Seed 004 — Gonakhchyan's performance model, invisible-object estimate and adaptive method

Seed 004 (adaptive rendering of dynamic 3D scenes) models a frame's memory (1) and time (2)
with per-material constants measured by drawing, and checks the model on random-box scenes
(**Table 1**). A single-reference octree keeps one command buffer (here: indirect draw buffer)
per node; querying only "expensive" nodes top-down gives a conservative estimate of the
invisible objects in bounded time (**Table 2**). The adaptive method switches between (1)
per-frame rebuild + per-object frustum culling, (2) the octree's node buffers + node frustum
culling and (3) occlusion queries, by conditions (5) and (6), with the number of queries q*
from formula (11) fitted while rendering (**Figs. 3–5**).

Our scenes are scaled to what llvmpipe on two cores draws in reasonable time (¼ of the
paper's objects, 1/20 of its triangles); times are this machine's, so model errors, ratios and
slopes are what compare. Each section below computes one experiment (`vislod seed004-model`,
`seed004-octree`, `seed004-adaptive`) into DataFrames, draws its pictures from them and judges
its claims beside the paper's numbers. `VISLOD_QUICK=1`: small scenes, few frames (about a
minute in all); the full runs take a few minutes each."""


def build_seed004():
    """``seed004_adaptive.ipynb`` as an ``nbformat`` node (no outputs)."""
    from nbformat import v4

    cells = [v4.new_markdown_cell(SEED004_INTRO)]
    for key in ("seed004-model", "seed004-octree", "seed004-adaptive"):
        cells += experiment_cells(key)
    return notebook(cells, "seed004-adaptive")


NOTEBOOKS = {
    "seed000_methods.ipynb": build_methods,
    "seed000_soc.ipynb": build_soc,
    "seed001_lod.ipynb": build_lod,
    "seed001_rendering.ipynb": build_rendering,
    "seed002_grid.ipynb": build_grid,
    "seed003_complexity.ipynb": build_seed003,
    "seed004_adaptive.ipynb": build_seed004,
}


def write(folder: str | os.PathLike = FOLDER) -> list[Path]:
    """Write every notebook of :data:`NOTEBOOKS` into ``folder`` (atomically)."""
    import nbformat

    from experiments.common import atomic_write

    paths = []
    for name, build in NOTEBOOKS.items():
        nb = build()
        paths.append(atomic_write(Path(folder) / name, lambda p, nb=nb: nbformat.write(nb, str(p))))
    return paths


def code(name: str) -> str:
    """The code cells of notebook ``name`` joined into one script (to check them without
    Jupyter)."""
    nb = NOTEBOOKS[name]()
    return "\n\n".join(c["source"] for c in nb.cells if c["cell_type"] == "code")


if __name__ == "__main__":
    for p in write():
        print(p)
