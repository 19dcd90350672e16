"""Seed 000, Abb. 9: what each stage of the query method contributes — MT alone, MT + frustum
culling, MT + frustum culling + depth-test (occlusion) culling — at the display resolution.

"MT" is llvmpipe's multithreaded rasterizer, on in every run here (one thread per core); the
switches are :class:`soc.CullConfig` ``(frustum, depth_test)`` = (off, off), (on, off),
(on, on). Expected trend: each stage culls at least as many models as the one before.
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path
from typing import Any

from experiments import seed000_document as doc
from experiments.common import Setup, fmt, format_table, mean, res_str, save_figure, write_csv
from experiments.seed000_flight import FlightRuns, RunSpec

QUERY_METHOD = "queries"
SWITCHES: dict[str, tuple[bool, bool]] = {
    "MT": (False, False),
    "MT+Frustum": (True, False),
    "MT+Frustum+Depth test": (True, True),
}
QUANTITIES = (
    "triangles_culled_pct",
    "draw_calls",
    "models_culled",
    "models_visible",
    "frustum_culled",
    "occlusion_culled",
    "false_culls",
)


def specs(setup: Setup) -> list[RunSpec]:
    """The three switch settings of the query method at the display resolution (not drawn)."""
    return [
        RunSpec(QUERY_METHOD, setup.display, frustum=f, depth_test=d) for f, d in SWITCHES.values()
    ]


def summarize(runs: FlightRuns, setup: Setup) -> list[dict[str, Any]]:
    """Per switch setting: our means over the flight and the document's (``doc_<quantity>``)."""
    out = []
    for name, (f, d) in SWITCHES.items():
        rows = runs.get(QUERY_METHOD, setup.display, frustum=f, depth_test=d)
        row: dict[str, Any] = {"switches": name, "frustum": f, "depth_test": d}
        row.update({q: mean(rows, q) for q in QUANTITIES})
        row.update({f"doc_{q}": doc.ABB9[name][q] for q in doc.QUANTITIES})
        out.append(row)
    return out


def trend_holds(summary: list[dict[str, Any]]) -> bool:
    """Each stage culls at least as many models (mean) as the stage before."""
    culled = [s["models_culled"] for s in summary]
    return all(a <= b for a, b in itertools.pairwise(culled))


def format_summary(summary: list[dict[str, Any]], runs: FlightRuns) -> str:
    """The Abb. 9 table as text, ``ours (document)``."""
    labels = {
        **doc.QUANTITIES,
        "frustum_culled": "frustum culled (ours only)",
        "occlusion_culled": "occlusion culled (ours only)",
        "false_culls": "false culls (ours only)",
    }
    rows = []
    for q, label in labels.items():
        cells = []
        for s in summary:
            d = s.get(f"doc_{q}")
            cells.append(f"{fmt(s[q])} ({fmt(d)})" if d is not None else fmt(s[q]))
        rows.append([label, *cells])
    title = (
        f"Abb. 9 — stage switches, '{QUERY_METHOD}' at {res_str(runs.display)}, averages "
        f"over {runs.frames} frames; ours (document). Trend (each stage culls at least as "
        f"many models): {'holds' if trend_holds(summary) else 'DOES NOT HOLD'}"
    )
    return format_table(["", *SWITCHES], rows, title)


def plot(summary: list[dict[str, Any]], runs: FlightRuns):
    """Grouped bars, ours beside the document's, one panel per quantity."""
    import numpy as np
    from matplotlib.figure import Figure

    fig = Figure(figsize=(16, 4.8), layout="constrained")
    axes = fig.subplots(1, 4)
    x = np.arange(len(summary))
    for ax, (q, label) in zip(axes, doc.QUANTITIES.items(), strict=True):
        ours = [s[q] for s in summary]
        theirs = [s[f"doc_{q}"] for s in summary]
        b1 = ax.bar(x - 0.2, ours, 0.4, color="tab:blue", label="ours")
        b2 = ax.bar(x + 0.2, theirs, 0.4, color="tab:red", alpha=0.75, label="document")
        digits = 1 if q == "triangles_culled_pct" else 0
        ax.bar_label(b1, [f"{v:,.{digits}f}" for v in ours], fontsize=7, padding=2)
        ax.bar_label(b2, [f"{v:,.{digits}f}" for v in theirs], fontsize=7, padding=2)
        ax.set_xticks(x, ["MT", "MT+FC", "MT+FC+DTC"], fontsize=9)
        ax.set_title(label)
        ax.set_ylabel("%" if q == "triangles_culled_pct" else "per frame (mean)")
        ax.margins(y=0.15)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=9, loc="upper left")
    fig.suptitle(
        f"Seed 000 Abb. 9 — stage switches at {res_str(runs.display)}, means over "
        f"{runs.frames} frames — {runs.scene['label']} "
        f"({runs.scene['objects']:,} objects; document: {doc.SCENE['objects']:,})"
    )
    return fig


def write(runs: FlightRuns, setup: Setup, out: str | os.PathLike) -> dict[str, Any]:
    """Write Abb. 9's CSVs and PNG into ``out``; returns ``{"summary", "files"}``."""
    out = Path(out)
    summary = summarize(runs, setup)
    frames = [
        r
        for f, d in SWITCHES.values()
        for r in runs.get(QUERY_METHOD, setup.display, frustum=f, depth_test=d)
    ]
    files = [
        write_csv(out / "seed000_abb9_frames.csv", frames),
        write_csv(out / "seed000_abb9_table.csv", summary),
        save_figure(plot(summary, runs), out / "seed000_abb9.png"),
    ]
    return {"summary": summary, "files": files, "trend_holds": trend_holds(summary)}
