"""Seed 000's own per-frame evaluation runs, read from ``$VISLOD_DATA/seed000_evaluation``.

The thesis' fork of Intel's sample (``UniStuttgart-VISUS/OcclusionCulling``) wrote one file per
run: two header lines, then per recorded frame ``frame FPS models_culled models_visible
draw_calls culling_time rasterize_time depth_test_time culled_tris visible_tris
depth_rasterized_models`` (times in seconds). The runs the document uses, all on camera tour 1
at the defaults (occluder size threshold 1.5, occludee 0.01, 20 depth-test tasks):

* Evaluation 1 — the five methods at 1920×1080 (Abb. 8 left): SCALAR, SSE, AVX (per-pixel box
  tests of the framework's software rasterizers), MASK_AVX (MOC: a rectangle per box), OGL;
* Evaluation 4 — OGL at depth resolutions 0–5 = 320×192 … 3840×2160 (Abb. 8 right, table);
* Evaluation 7 — OGL with MT only / + frustum culling / + depth test culling (Abb. 9);
* Evaluation 2 — the five methods on camera tour 2 (not in the document: our held-out tour).

Evaluations 1 and 4 are read from the backup copy (``Evaluation_N/``); 2 and 7 from the fork's
``Evaluation Final Results/`` (``final_results/Evaluation_N/``), because the backup's
Evaluation 7 files are three copies of the full run and its Evaluation 2 holds no runs.
This module only reads; it holds no numbers.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

FOLDER = "seed000_evaluation"
COLUMNS = (
    "frame", "fps", "models_culled", "models_visible", "draw_calls", "culling_s",
    "rasterize_s", "depth_test_s", "triangles_culled", "triangles_visible",
    "depth_rasterized",
)  # fmt: skip
#: Evaluation 4's resolutions, index = the ``-DBResolution`` argument.
RESOLUTIONS = ((320, 192), (640, 360), (1280, 720), (1920, 1080), (2432, 1440), (3840, 2160))
#: Evaluation 1's methods: the framework's name → what it is.
METHODS = {
    "SCALAR": "scalar per-pixel box test",
    "SSE": "SSE per-pixel box test",
    "AVX": "AVX per-pixel box test",
    "MASK_AVX": "MOC (masked, rectangle test)",
    "OGL": "OGL (GL occlusion queries on Mesa)",
}
#: Evaluation 7's runs (OGL_0..2): the Abb. 9 columns.
SWITCHES = ("MT", "MT+Frustum", "MT+Frustum+Depth test")


def folder(data: str | os.PathLike | None = None) -> Path | None:
    """The evaluation folder under ``data`` or ``$VISLOD_DATA``; None where there is none."""
    root = data or os.environ.get("VISLOD_DATA")
    if not root:
        return None
    path = Path(root).expanduser() / FOLDER
    return path if path.is_dir() else None


def read_run(path: str | os.PathLike) -> pd.DataFrame:
    """One raw run as a DataFrame: :data:`COLUMNS`, plus ``triangles_culled_pct`` (culled over
    culled + visible, as the document's tables compute it) and the times in ms."""
    df = pd.read_csv(path, sep=r"\s+", skiprows=2, names=list(COLUMNS), engine="python")
    if df.isna().any().any() or len(df) == 0:
        raise ValueError(f"{path}: not a seed-000 evaluation file ({len(COLUMNS)} columns)")
    tri = df.triangles_culled + df.triangles_visible
    df["triangles_culled_pct"] = 100.0 * df.triangles_culled / tri
    for k in ("culling", "rasterize", "depth_test"):
        df[f"ms_{k}"] = 1e3 * df.pop(f"{k}_s")
    return df


def runs(data: str | os.PathLike | None = None) -> pd.DataFrame:
    """Every run the document uses, and tour 2's, one row per frame: ``evaluation`` (1, 2, 4,
    7), ``tour``, ``run`` (the file's name), ``method`` (SCALAR … OGL), ``depth_resolution``
    (e.g. ``"1920x1080"``), ``stages`` (Abb. 9's column name), then :func:`read_run`'s
    columns. Empty where the data is not there."""
    root = folder(data)
    if root is None:
        return pd.DataFrame()
    display = "1920x1080"
    plan: list[tuple[int, int, Path, str, str, str]] = []
    for m in METHODS:
        plan.append((1, 1, root / "Evaluation_1" / m, m, display, SWITCHES[-1]))
        plan.append((2, 2, root / "final_results" / "Evaluation_2" / m, m, display, SWITCHES[-1]))
    for i, (w, h) in enumerate(RESOLUTIONS):
        plan.append((4, 1, root / "Evaluation_4" / f"OGL_{i}", "OGL", f"{w}x{h}", SWITCHES[-1]))
    for i, s in enumerate(SWITCHES):
        plan.append((7, 1, root / "final_results" / "Evaluation_7" / f"OGL_{i}", "OGL", display, s))
    parts = []
    for ev, tour, path, method, res, stages in plan:
        if path.is_file():
            df = read_run(path)
            df.insert(0, "stages", stages)
            df.insert(0, "depth_resolution", res)
            df.insert(0, "method", method)
            df.insert(0, "run", f"Evaluation_{ev}/{path.name}")
            df.insert(0, "tour", tour)
            df.insert(0, "evaluation", ev)
            parts.append(df)
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


def select(df: pd.DataFrame, evaluation: int, **eq) -> pd.DataFrame:
    """The frames of one run of :func:`runs`, by evaluation and column values, frame order."""
    if df.empty:
        return df
    m = df.evaluation == evaluation
    for k, v in eq.items():
        m &= df[k] == v
    return df[m].sort_values("frame")
