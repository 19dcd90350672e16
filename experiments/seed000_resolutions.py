"""Seed 000, Abb. 8: triangles culled per frame — by the query method at six depth-buffer
resolutions (right, and the table of averages), and by every culling method at 1920×1080
(left, with the oracle's ideal).

Beyond the document: every frame's false culls (objects visible in the exact id render at the
display resolution but culled) and false keeps (hidden but kept). A depth buffer coarser than
the display closes small gaps between occluders, which culls more — and culls visible objects.
A second curve beside the document's method: ``hiz-gpu`` on an inner-conservative occluder
depth at the same resolutions (Hasselgren, Akenine-Möller & Ohlsson, GPU Gems 2 ch. 42;
:class:`soc.culling.depth_prepass.ConservativeOccluders`), which culls less at coarse resolutions
but
never a visible object.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from experiments import seed000_document as doc
from experiments.common import (
    Setup,
    fmt,
    format_table,
    mean,
    res_str,
    save_figure,
    write_csv,
)
from experiments.seed000_flight import FlightRuns, RunSpec

QUERY_METHOD = "queries"  # seed 000's "OGL" method
# The second curve: conservative at the display whatever the depth resolution.
CONSERVATIVE_METHOD = "hiz-gpu"
CONSERVATIVE_OPTIONS = (("conservative", True),)
CONSERVATIVE_COLUMNS = ("triangles_culled_pct", "false_culls", "false_keeps", "ms_cull")
COLUMNS = (
    "triangles_culled_pct",
    "draw_calls",
    "models_culled",
    "models_visible",
    "false_culls",
    "false_keeps",
    "ms_cull",
    "ms_draw",
)


def specs(setup: Setup, methods: list[str] | None = None) -> list[RunSpec]:
    """Runs Abb. 8 needs: the query method at every depth resolution (right) and every method
    at the display resolution (left; default :func:`soc.method_names`). All drawn (the table
    reports draw time)."""
    import soc

    methods = soc.method_names() if methods is None else list(methods)
    right = [RunSpec(QUERY_METHOD, r, draw=True) for r in setup.resolutions]
    right += [
        RunSpec(CONSERVATIVE_METHOD, r, draw=True, options=CONSERVATIVE_OPTIONS)
        for r in setup.resolutions
    ]
    left = [RunSpec(m, setup.display, draw=True) for m in methods]
    return right + left


def _conservative_rows(runs: FlightRuns, r) -> list[dict[str, Any]]:
    return runs.get(CONSERVATIVE_METHOD, r, options=CONSERVATIVE_OPTIONS)


def summarize(runs: FlightRuns, setup: Setup) -> list[dict[str, Any]]:
    """Abb. 8 table: per depth resolution, our averages over the flight beside the document's.

    Returns one dict per resolution with ``depth_resolution``, ``document_resolution`` (the
    document's column it lines up with, or ``""``), ``<quantity>`` (ours, mean) and
    ``doc_<quantity>`` for the four quantities of the document, plus our ``false_culls``,
    ``false_keeps`` (means), ``frames_with_false_culls``, ``ms_cull`` and ``ms_draw`` (means),
    and the conservative curve's ``conservative_<quantity>`` (means of
    :data:`CONSERVATIVE_COLUMNS`).
    """
    out = []
    for r in setup.resolutions:
        rows = runs.get(QUERY_METHOD, r)
        col = doc.document_column(r, setup.display)
        d = doc.ABB8.get(col, {}) if col else {}
        row: dict[str, Any] = {
            "depth_resolution": res_str(r),
            "document_resolution": res_str(col) if col else "",
        }
        for q in COLUMNS:
            row[q] = mean(rows, q)
        for q in doc.QUANTITIES:
            row[f"doc_{q}"] = d.get(q)
        row["frames_with_false_culls"] = sum(1 for x in rows if (x.get("false_culls") or 0) > 0)
        row["frames"] = len(rows)
        cons = _conservative_rows(runs, r)
        for q in CONSERVATIVE_COLUMNS:
            row[f"conservative_{q}"] = mean(cons, q)
        out.append(row)
    return out


def methods_summary(runs: FlightRuns, setup: Setup, methods: list[str]) -> list[dict[str, Any]]:
    """Abb. 8 left in numbers: per method at the display resolution, mean % triangles culled,
    models visible, false culls; the oracle's ideal last."""
    out = []
    for m in methods:
        rows = runs.get(m, setup.display)
        out.append(
            {
                "method": m,
                "triangles_culled_pct": mean(rows, "triangles_culled_pct"),
                "models_visible": mean(rows, "models_visible"),
                "false_culls": mean(rows, "false_culls"),
                "false_keeps": mean(rows, "false_keeps"),
            }
        )
    out.append(
        {
            "method": "oracle (ideal)",
            "triangles_culled_pct": mean(runs.oracle, "triangles_culled_pct"),
            "models_visible": mean(runs.oracle, "models_visible"),
            "false_culls": 0.0,
            "false_keeps": 0.0,
        }
    )
    return out


def _pair(ours: Any, theirs: Any, digits: int = 2) -> str:
    if theirs is None:
        return fmt(ours, digits)
    return f"{fmt(ours, digits)} ({fmt(theirs, digits)})"


def format_summary(summary: list[dict[str, Any]], runs: FlightRuns) -> str:
    """The Abb. 8 table as text: quantities down, depth resolutions across, ``ours (document)``."""
    header = ["depth buffer", *(s["depth_resolution"] for s in summary)]
    rows = []
    if any(s["document_resolution"] != s["depth_resolution"] for s in summary):
        rows.append(["document's column", *(s["document_resolution"] or "—" for s in summary)])
    labels = {
        **doc.QUANTITIES,
        "false_culls": "false culls (ours only)",
        "false_keeps": "false keeps (ours only)",
        "ms_cull": "cull ms",
        "ms_draw": "draw ms",
    }
    for q, label in labels.items():
        rows.append([label] + [_pair(s[q], s.get(f"doc_{q}")) for s in summary])
    for q in CONSERVATIVE_COLUMNS:
        label = f"{CONSERVATIVE_METHOD} conservative: {labels.get(q, q)}"
        rows.append([label] + [fmt(s[f"conservative_{q}"], 2) for s in summary])
    info = runs.scene
    title = (
        f"Abb. 8 — '{QUERY_METHOD}' method, averages over {runs.frames} frames, display "
        f"{res_str(runs.display)}; ours (document)\n"
        f"scene: {info['label']}: {info['objects']:,} objects, {info['triangles']:,} triangles "
        f"(document: {doc.SCENE['objects']:,} objects, {doc.SCENE['triangles']:,} triangles)"
    )
    return format_table(header, rows, title)


def format_methods(msum: list[dict[str, Any]], runs: FlightRuns) -> str:
    """Abb. 8 left as text."""
    rows = [
        [
            m["method"],
            m["triangles_culled_pct"],
            m["models_visible"],
            m["false_culls"],
            m["false_keeps"],
        ]
        for m in msum
    ]
    return format_table(
        ["method", "triangles culled %", "models visible", "false culls", "false keeps"],
        rows,
        f"Abb. 8 left — every method at {res_str(runs.display)}, "
        f"averages over {runs.frames} frames",
    )


# -- plots ------------------------------------------------------------------------------------


def plot_right(runs: FlightRuns, setup: Setup, summary: list[dict[str, Any]]):
    """Abb. 8 right: per-frame % triangles culled per depth resolution; the averages beside the
    document's; the false culls per frame. Returns a matplotlib ``Figure``."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(18, 6.4), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1.35, 1, 1]})
    cmap = _colors(len(setup.resolutions))
    for k, r in enumerate(setup.resolutions):
        rows = runs.get(QUERY_METHOD, r)
        f = [x["frame"] for x in rows]
        ax1.plot(
            f, [x["triangles_culled_pct"] for x in rows], color=cmap[k], lw=1.6, label=res_str(r)
        )
        fc = [x["false_culls"] for x in rows]
        ax3.plot(f, fc, color=cmap[k], lw=1.4, label=f"{res_str(r)} ({np.mean(fc):,.1f})")
    ax1.plot(
        [x["frame"] for x in runs.oracle],
        [x["triangles_culled_pct"] for x in runs.oracle],
        "k--",
        lw=1.4,
        label=f"oracle (exact, {res_str(runs.display)})",
    )
    ax1.set(
        title=f"% triangles culled per frame, '{QUERY_METHOD}' method",
        xlabel="frame",
        ylabel="triangles culled (%)",
        ylim=(0, 100),
    )
    ax1.legend(
        title="depth buffer", fontsize=8, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.13)
    )
    ax1.grid(alpha=0.3)

    x = range(len(summary))
    ax2.plot(
        x,
        [s["triangles_culled_pct"] for s in summary],
        "o-",
        color="tab:blue",
        label="ours (mean over flight)",
    )
    docx = [i for i, s in enumerate(summary) if s["doc_triangles_culled_pct"] is not None]
    ax2.plot(
        docx,
        [summary[i]["doc_triangles_culled_pct"] for i in docx],
        "s--",
        color="tab:red",
        label="document (Abb. 8 table)",
    )
    for i in docx:
        ax2.annotate(
            f"{summary[i]['doc_triangles_culled_pct']:.2f}",
            (i, summary[i]["doc_triangles_culled_pct"]),
            textcoords="offset points",
            xytext=(12, -14),
            ha="center",
            fontsize=8,
            color="tab:red",
        )
    for i, s in enumerate(summary):
        ax2.annotate(
            f"{s['triangles_culled_pct']:.2f}",
            (i, s["triangles_culled_pct"]),
            textcoords="offset points",
            xytext=(-12, 8),
            ha="center",
            fontsize=8,
            color="tab:blue",
        )
    ax2.plot(
        x,
        [s["conservative_triangles_culled_pct"] for s in summary],
        "^-",
        color="tab:green",
        label=f"{CONSERVATIVE_METHOD}, conservative occluder depth (0 false culls)",
    )
    ideal = mean(runs.oracle, "triangles_culled_pct")
    ax2.axhline(ideal, color="k", ls="--", lw=1.2, label=f"oracle, ours (ideal): {ideal:.2f}")
    ax2.set_xticks(list(x), [s["depth_resolution"] for s in summary], rotation=30, fontsize=8)
    ax2.set(
        title="average % triangles culled vs depth resolution",
        xlabel="depth buffer",
        ylabel="triangles culled (%)",
        ylim=(0, 100),
    )
    ax2.legend(fontsize=8, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.22))
    ax2.grid(alpha=0.3)

    cons = [_conservative_rows(runs, r) for r in setup.resolutions]
    worst = [max((x["false_culls"] or 0) for x in frame) for frame in zip(*cons, strict=True)]
    ax3.plot(
        [x["frame"] for x in cons[0]],
        worst,
        color="tab:green",
        ls="--",
        lw=1.6,
        label=f"{CONSERVATIVE_METHOD} conservative, worst resolution ({max(worst, default=0)})",
    )
    ax3.set(
        title=f"false culls per frame (visible at {res_str(runs.display)} but culled)",
        xlabel="frame",
        ylabel="objects",
    )
    ax3.set_yscale("symlog", linthresh=1)
    ax3.set_ylim(bottom=0)
    ax3.legend(
        title="depth buffer (mean false culls per frame)",
        fontsize=8,
        ncol=3,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.13),
    )
    ax3.grid(alpha=0.3)
    fig.suptitle(f"Seed 000 Abb. 8 (right) — {runs.scene['label']}, {runs.frames} frames")
    return fig


def plot_left(runs: FlightRuns, setup: Setup, methods: list[str]):
    """Abb. 8 left: per-frame % triangles culled of every method at the display resolution,
    the oracle's ideal dashed, the document's OGL average dotted."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 6.2), layout="constrained")
    ax = fig.subplots()
    cmap = [f"C{k}" for k in range(len(methods))]
    for k, m in enumerate(methods):
        rows = runs.get(m, setup.display)
        ax.plot(
            [x["frame"] for x in rows],
            [x["triangles_culled_pct"] for x in rows],
            color=cmap[k],
            lw=1.8,
            label=m,
        )
    ax.plot(
        [x["frame"] for x in runs.oracle],
        [x["triangles_culled_pct"] for x in runs.oracle],
        "k--",
        lw=1.6,
        label="oracle (ideal: exactly the visible set)",
    )
    d = doc.ABB8[doc.DISPLAY]["triangles_culled_pct"]
    ax.axhline(
        d,
        color="tab:red",
        ls=":",
        lw=1.4,
        label=f"document, OGL method at 1920x1080: mean {d:.2f} %",
    )
    ax.set(
        title=f"Seed 000 Abb. 8 (left) — % triangles culled per frame, depth buffer "
        f"{res_str(setup.display)}\n{runs.scene['label']}",
        xlabel="frame",
        ylabel="triangles culled (%)",
        ylim=(-2, 100),
    )
    ax.legend(fontsize=9, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    ax.grid(alpha=0.3)
    return fig


def _colors(n: int) -> list:
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    return [cmap(0.05 + 0.85 * k / max(n - 1, 1)) for k in range(n)]


# -- files ------------------------------------------------------------------------------------


def write(
    runs: FlightRuns, setup: Setup, out: str | os.PathLike, methods: list[str]
) -> dict[str, Any]:
    """Write Abb. 8's CSVs and PNGs into ``out``; returns ``{"summary", "methods", "files"}``."""
    out = Path(out)
    summary = summarize(runs, setup)
    msum = methods_summary(runs, setup, methods)
    frames = [row for r in setup.resolutions for row in runs.get(QUERY_METHOD, r)]
    frames += [row for r in setup.resolutions for row in _conservative_rows(runs, r)]
    frames += [row for m in methods for row in runs.get(m, setup.display)]
    files = [
        write_csv(out / "seed000_abb8_frames.csv", _unique_rows(frames) + runs.oracle),
        write_csv(out / "seed000_abb8_table.csv", summary),
        write_csv(out / "seed000_abb8_methods.csv", msum),
    ]
    for name, fig in (
        ("seed000_abb8_right.png", plot_right(runs, setup, summary)),
        ("seed000_abb8_left.png", plot_left(runs, setup, methods)),
    ):
        files.append(save_figure(fig, out / name))
    return {"summary": summary, "methods": msum, "files": files}


def _unique_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Drop rows repeated because one run serves both panels (queries at the display size)."""
    seen, out = set(), []
    for r in rows:
        k = (r["run"], r["frame"])
        if k not in seen:
            seen.add(k)
            out.append(r)
    return out
