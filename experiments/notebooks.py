"""Writes the notebooks under ``notebooks/``: a short introduction, then the cells of each harness
experiment the notebook shows (:func:`experiment_cells`). They are written without outputs, so
that they stay a view of the experiments rather than a second copy: ``python -m
experiments.notebooks`` (needs the ``notebooks`` extra). Quick mode when ``VISLOD_QUICK`` is set.
"""

from __future__ import annotations

import functools
import importlib
import os
from pathlib import Path

FOLDER = Path(__file__).resolve().parents[1] / "notebooks"


def scene_view_cells(method: str) -> list:
    """One frame of the flight seen from outside in 3D (:func:`soc.viz.plot_cull`)."""
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


def experiment_cells(key: str, overrides: dict | None = None) -> list:
    """The cells that show one harness experiment: its introduction, its parameters (quick
    with ``VISLOD_QUICK``, then the notebook's ``overrides``), the computation, every
    DataFrame, every picture under its caption, and the claims beside the document."""
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
    names = getattr(importlib.import_module(exp.module), "FRAMES", ())
    cells += [v4.new_code_cell(f'frames["{name}"]') for name in names]
    for plot in exp.plots:
        cells.append(v4.new_markdown_cell(f"### {exp.caption(plot)}"))
        cells.append(v4.new_code_cell(f"{mod}.{plot.__name__}(frames, params)"))
    cells.append(v4.new_markdown_cell("### The claims, beside the document"))
    cells.append(v4.new_code_cell("exp.claims(frames, params)"))
    return cells


def build(prefix: str, intro: str, keys: tuple[str, ...], overrides=None, view: str = ""):
    """A validated notebook (no outputs; stable cell ids ``prefix-NN``, so that regenerating
    gives the same file): ``intro``, each experiment's cells, then one frame in 3D (``view``:
    the culling method shown)."""
    import nbformat
    from nbformat import v4

    cells = [v4.new_markdown_cell(intro)]
    for key in keys:
        cells += experiment_cells(key, overrides)
    cells += scene_view_cells(view) if view else []
    for i, cell in enumerate(cells):
        cell["id"] = f"{prefix}-{i:02d}"
    kernel = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb = v4.new_notebook(
        cells=cells, metadata={"kernelspec": kernel, "language_info": {"name": "python"}}
    )
    nbformat.validate(nb)
    return nb


SOC_INTRO = """\
# Seed 000 — OpenGL occlusion culling on Mesa (llvmpipe) in Intel's SOC framework

Seed 000's experiment computed into DataFrames, Abb. 1, 4, 6–10 drawn from them and our claims
set beside the document's numbers; at the end, one frame seen in 3D. `VISLOD_QUICK=1`: 6 frames
at a quarter of the resolution on the small market (seconds); the full run takes about a
quarter of an hour on two CPU cores."""

METHODS_INTRO = """\
# Seed 000 — the five culling methods, and every other method we have

Seed 000's flight with every registered culling method (`methods=("all",)`): each drawn at the
display resolution, its frame time (cull + draw) measured and its false culls counted against
the exact oracle. `VISLOD_QUICK=1`: 6 frames at a quarter of the resolution on the small market;
the full run takes about half an hour on two CPU cores."""

LOD_INTRO = """\
# Seed 001 — levels of detail

Zachmann's VR lecture on LOD in two experiments: choosing a level per object under a frame-time
budget (`vislod lod`) and the quality of the reduced meshes (`vislod lod-quality`; its meshes
from `VISLOD_DATA` in full runs). `VISLOD_QUICK=1`: small scenes and meshes (seconds); the full
runs take a few minutes each."""

RENDERING_INTRO = """\
# Seed 001 — portal culling, state sorting, image-based techniques

Three more experiments on Zachmann's VR lecture (levels of detail: `seed001_lod.ipynb`), each
computed into DataFrames, drawn, and its claims set beside the lecture's words.
`VISLOD_QUICK=1`: small scenes, few frames (about a minute in all); the full runs take a few
minutes each."""

GRID_INTRO = """\
# Seed 002 — occlusion queries on a uniform grid

Seed 002's experiment (`vislod seed002`) computed into DataFrames, its pictures drawn from them
and its claims set beside the thesis's words. `VISLOD_QUICK=1`: a few frames at a quarter of
the resolution (seconds); the full run takes a few minutes on two CPU cores."""

SEED003_INTRO = """\
# Seed 003 — forward vs deferred shading: complexity in V, VP and L

Both shading paths (`soc.rendering.shading`) render a stack of spheres on this machine's GL
context; the claims are judged on CPU time, as slopes and ratios (llvmpipe's absolute times
compare with nothing). `VISLOD_QUICK=1`: the quick sweep (about a minute); the full one takes a
few minutes on two cores."""

SEED004_INTRO = """\
# Seed 004 — Gonakhchyan's performance model, invisible-object estimate and adaptive method

Three experiments: the performance model (**Table 1**, `vislod seed004-model`), the octree's
estimate of the invisible objects (**Table 2**, `seed004-octree`) and the adaptive method
(**Figs. 3–5**, `seed004-adaptive`), on scenes scaled to what llvmpipe draws on two cores:
model errors, ratios and slopes are what compare. `VISLOD_QUICK=1`: small scenes, few frames
(about a minute in all); the full runs take a few minutes each."""

DAG_INTRO = """\
# Cluster LOD DAG (Nanite's) on instanced scenes

A field of rocks and statues, each mesh held once and placed many times
(`soc.scenes.rock_field`), and a canyon of cliffs that each reach from beside the camera to the
horizon, seen from its floor and from above its far end; each mesh's cluster DAG (`lod.dag`:
clusters grouped, simplified with the group border locked, split again, level by level) and
its cut selected per instance on the GPU by error threshold in pixels
(`soc.Culler(scene, "gpu-driven", lod=pixels)`), then culled by frustum, normal cone and
two-phase hierarchical z and drawn in the same passes as any gpu-driven frame; against object
LOD at the same FLIP. `VISLOD_QUICK=1`: small scenes (about a minute); the full run takes
several minutes. The targets at 10⁸ source triangles are `python -m benchmarks --only dag`."""

NOTEBOOKS = {  # file name → its builder (no arguments)
    "seed000_methods.ipynb": functools.partial(
        build, "seed000-methods", METHODS_INTRO, ("seed000",), {"methods": ("all",)}, "masked"
    ),
    "seed000_soc.ipynb": functools.partial(
        build, "seed000", SOC_INTRO, ("seed000",), view="hiz-gpu"
    ),
    "seed001_lod.ipynb": functools.partial(
        build, "seed001-lod", LOD_INTRO, ("seed001-lod", "seed001-lod-quality")
    ),
    "seed001_rendering.ipynb": functools.partial(
        build,
        "seed001-rendering",
        RENDERING_INTRO,
        ("seed001-portals", "seed001-state-sorting", "seed001-image-based"),
    ),
    "seed002_grid.ipynb": functools.partial(build, "seed002-grid", GRID_INTRO, ("seed002",)),
    "seed003_complexity.ipynb": functools.partial(
        build, "seed003-complexity", SEED003_INTRO, ("seed003",)
    ),
    "seed004_adaptive.ipynb": functools.partial(
        build,
        "seed004-adaptive",
        SEED004_INTRO,
        ("seed004-model", "seed004-octree", "seed004-adaptive"),
    ),
    "dag_lod.ipynb": functools.partial(build, "dag-lod", DAG_INTRO, ("dag-lod",)),
}


def write(folder: str | os.PathLike = FOLDER) -> list[Path]:
    """Write every notebook of :data:`NOTEBOOKS` into ``folder`` (atomically)."""
    import nbformat

    from experiments.common import atomic_write

    paths = []
    for name, make in NOTEBOOKS.items():
        nb = make()
        paths.append(atomic_write(Path(folder) / name, lambda p, nb=nb: nbformat.write(nb, str(p))))
    return paths


if __name__ == "__main__":
    for p in write():
        print(p)
