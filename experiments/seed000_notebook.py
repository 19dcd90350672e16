"""Writes ``notebooks/seed000_soc.ipynb``: a thin notebook that calls the seed-000 experiments
(quick mode when ``VISLOD_QUICK`` is set) and shows their tables and pictures.

The notebook is generated, without outputs, so that it stays a view of the experiments
rather than a second copy of them: ``python -m experiments.seed000_notebook``.
Needs ``nbformat`` (the ``notebooks`` extra).
"""

from __future__ import annotations

import os
from pathlib import Path

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "seed000_soc.ipynb"

INTRO = """\
# Seed 000 — OpenGL occlusion culling on Mesa (llvmpipe) in Intel's SOC framework

Every frame of a 100-frame flight over the castle and its market: frustum-cull all AABBs,
render the occluders into a depth buffer, test every surviving object's AABB with an OpenGL
occlusion query, draw what passed. This notebook reproduces the document's figures and
tables — Abb. 1, 4, 6, 7 (pictures), Abb. 8 (triangles culled per depth resolution and per
method), Abb. 9 (stage switches) and Abb. 10 (frame time) — with the document's numbers
beside ours, and adds what the document could not measure: false culls against an exact
per-object id render.

All the work is done by `experiments/` (the same code as `vislod demo`); this notebook only
calls it and shows the results. Set `VISLOD_QUICK=1` for a quick run (6 frames, a quarter
of the resolution, the small market: seconds); the full run (100 frames at 1080p, six depth
resolutions, 27,025 objects) takes about ten minutes on two CPU cores."""

SETUP = """\
from IPython.display import Image, display

from experiments.common import default_out, env_quick, make_setup
from experiments.seed000_demo import demo

quick = env_quick()
setup = make_setup(quick=quick)
out = default_out(quick)
print(f"quick={quick}: {setup.frames} frames, display {setup.display}, "
      f"depth resolutions {setup.resolutions}; results in {out}")"""

RUN = """\
# Culls the flight once per configuration (shared by Abb. 8, 9, 10), renders the pictures,
# and writes CSV/JSON/PNG into `out`; the tables are printed below.
result = demo(setup, scene_name="market", out=out, verbose=False)"""

SECTIONS = [
    (
        "## Abb. 8 — triangles culled per frame\n\nLeft: every method at the display "
        "resolution, with the oracle's ideal (dashed). Right: the query method at six depth "
        "resolutions; averages beside the document's table; false culls per frame.",
        ["seed000_abb8_left.png", "seed000_abb8_right.png"],
    ),
    ("## Abb. 9 — stage switches (MT, +frustum, +depth test)", ["seed000_abb9.png"]),
    ("## Abb. 10 — frame time and FPS on this machine", ["seed000_abb10.png"]),
    (
        "## Abb. 1 — kept objects (red AABBs) and the objects classified occluded",
        ["seed000_abb1.png"],
    ),
    ("## Abb. 4 — occluders only, occludees only", ["seed000_abb4.png"]),
    ("## Abb. 6 — a frame and its occluder depth buffer", ["seed000_abb6.png"]),
    ("## Abb. 7 — the flight over a top view", ["seed000_abb7.png"]),
]

TABLES = """\
from experiments import seed000_frametimes, seed000_resolutions, seed000_switches

runs = result["runs"]
print(seed000_resolutions.format_summary(result["abb8"]["summary"], runs))
print()
print(seed000_resolutions.format_methods(result["abb8"]["methods"], runs))
print()
print(seed000_switches.format_summary(result["abb9"]["summary"], runs))
print()
print(seed000_frametimes.format_summary(result["abb10"]["summary"], runs))"""


def build():
    """The notebook as an ``nbformat`` node (no outputs)."""
    from nbformat import v4

    from experiments.notebooks import image_cell, notebook

    cells = [
        v4.new_markdown_cell(INTRO),
        v4.new_code_cell(SETUP),
        v4.new_code_cell(RUN),
        v4.new_markdown_cell("## The tables, ours (document)"),
        v4.new_code_cell(TABLES),
    ]
    for text, images in SECTIONS:
        cells += [v4.new_markdown_cell(text), v4.new_code_cell(image_cell(images))]
    return notebook(cells, "seed000")


def write(path: str | os.PathLike = NOTEBOOK) -> Path:
    """Write the notebook (atomically) and return its path."""
    import nbformat

    from experiments.common import atomic_write

    nb = build()
    return atomic_write(path, lambda p: nbformat.write(nb, str(p)))


if __name__ == "__main__":
    print(write())
