"""Seed 001 reproduced (trend): portal culling in a building (``vislod portals``).

Seed 001 (Zachmann's VR lecture) sketches portal culling: split the building into cells
(rooms), precompute which cells see which through the portals (doors), and from a viewpoint
even less is visible. It gives no numbers. We walk a camera through ``soc.scenes.rooms`` and
measure, per frame, the fraction of objects culled by ``portals`` (frustum + cell/portal
traversal with screen-space portal narrowing, :mod:`soc.culling.portals`) and by ``frustum`` alone,
their cull time, and false culls against the oracle (an exact per-object id render at the
display resolution): portal culling is conservative, so there must be none.

Stages: :func:`walk` (scene and cameras) → :func:`run_walk` (both methods per frame, the oracle
once per frame) → :func:`summarize` (per room the camera stands in, and overall) →
:func:`write` (CSV, JSON, PNG). Nothing is written before the walk is done.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    DISPLAY,
    QUICK_SCALE,
    UsageError,
    format_table,
    res_str,
    save_figure,
    scaled,
    write_csv,
    write_json,
)

FRAMES = 200  # cameras on the full walk (culling here is cheap: no drawing)
QUICK_FRAMES = 12
METHODS = ("frustum", "portals")
ROOMS = (6, 4)

DOCUMENT = {
    "source": "seed 001 (001_2d1336254317ef40.txt), Zachmann, VR lecture: culling",
    "claim": "Portal culling in buildings: split space into cells, precompute cell-to-cell "
    "visibility through portals; from a viewpoint even less is visible.",
    "numbers": "none",
}


@dataclass(frozen=True)
class PortalSetup:
    """One portal-culling run: ``frames`` cameras at ``display`` pixels through a building of
    ``rooms`` rooms per storey and ``floors`` storeys, generated and walked with ``seed``."""

    frames: int
    display: tuple[int, int]
    rooms: tuple[int, int] = ROOMS
    floors: int = 1
    quick: bool = False
    seed: int = 0


def make_setup(
    quick: bool = False,
    frames: int | None = None,
    display: tuple[int, int] | None = None,
    rooms: tuple[int, int] | None = None,
    floors: int = 1,
    seed: int = 0,
) -> PortalSetup:
    """The full setup (200 frames at 1080p, 6x4 rooms) or the quick one (12 frames at
    480x270); :class:`UsageError` for bad values."""
    frames = frames if frames is not None else (QUICK_FRAMES if quick else FRAMES)
    if frames < 2:
        raise UsageError(f"--frames must be at least 2, got {frames}")
    rooms = tuple(int(r) for r in (rooms or ROOMS))
    if len(rooms) != 2 or min(rooms) < 1:
        raise UsageError(f"--rooms must be two positive integers NXxNZ, got {rooms}")
    if floors < 1:
        raise UsageError(f"--floors must be at least 1, got {floors}")
    if seed < 0:
        raise UsageError(f"--seed must be >= 0, got {seed}")
    display = tuple(display) if display else scaled(DISPLAY, QUICK_SCALE if quick else 1.0)
    return PortalSetup(int(frames), display, rooms, int(floors), bool(quick), int(seed))  # type: ignore[arg-type]


def walk(setup: PortalSetup):
    """The building and the camera walk through it (``soc.scenes.rooms_walk``)."""
    import soc

    scene = soc.scenes.rooms(setup.seed, rooms=setup.rooms, floors=setup.floors)
    cams = soc.scenes.rooms_walk(
        scene, setup.frames, seed=setup.seed, width=setup.display[0], height=setup.display[1]
    )
    return scene, cams


def camera_room(scene, eye) -> int:
    """The cell (room) holding ``eye`` (the first when it lies on a shared wall), -1 if none."""
    cells = np.asarray(scene.meta["cells"], np.float64)
    inside = np.all((eye >= cells[:, 0]) & (eye <= cells[:, 1]), axis=1)
    hit = np.flatnonzero(inside)
    return int(hit[0]) if len(hit) else -1


def run_walk(scene, cams, setup: PortalSetup, *, bar=None) -> list[dict[str, Any]]:
    """Per frame and method: objects kept and culled, % culled, false culls, cull time (ms);
    the oracle's visible count beside them (``run = "oracle"``: the ideal % culled)."""
    import soc

    n = len(scene)
    rows: list[dict[str, Any]] = []
    oracle = soc.Oracle(scene)
    cullers = {}
    try:
        for m in METHODS:
            cullers[m] = soc.Culler(scene, m, setup.display)
            cullers[m].cull(cams[0])  # warm-up, untimed
        for i, cam in enumerate(cams):
            room = camera_room(scene, np.asarray(cam.eye, np.float64))
            truth = oracle.visible(cam)
            base = {"frame": i, "room": room}
            rows.append(
                {
                    **base,
                    "method": "oracle",
                    "kept": int(truth.sum()),
                    "culled": int(n - truth.sum()),
                    "culled_pct": 100.0 * (n - truth.sum()) / n,
                    "false_culls": 0,
                    "ms_cull": None,
                    "cells_reached": None,
                }
            )
            for k in np.roll(np.arange(len(METHODS)), -i).tolist():
                m = METHODS[k]
                s = cullers[m].cull(cam, truth=truth).stats
                rows.append(
                    {
                        **base,
                        "method": m,
                        "kept": s.models_visible,
                        "culled": s.models_culled,
                        "culled_pct": 100.0 * s.models_culled / n,
                        "false_culls": s.false_culls,
                        "ms_cull": s.cull_ms,
                        "cells_reached": getattr(cullers[m].method, "last_cells", None),
                    }
                )
            if bar is not None:
                bar.update(1)
    finally:
        for c in cullers.values():
            c.close()
        oracle.close()
    return rows


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per room the camera stood in (in walk order) and ``"all"``: frames, mean % of objects
    culled per method (and the oracle's ideal), mean cull ms, false culls in total."""
    rooms = list(dict.fromkeys(r["room"] for r in rows))
    out = []
    for room in [*rooms, "all"]:
        sel = [r for r in rows if room == "all" or r["room"] == room]
        entry: dict[str, Any] = {"room": room, "frames": len({r["frame"] for r in sel})}
        for m in ("oracle", *METHODS):
            ms = [r for r in sel if r["method"] == m]
            entry[f"{m}_culled_pct"] = float(np.mean([r["culled_pct"] for r in ms]))
            if m != "oracle":
                entry[f"{m}_ms_cull"] = float(np.mean([r["ms_cull"] for r in ms]))
                entry[f"{m}_false_culls"] = int(sum(r["false_culls"] for r in ms))
        out.append(entry)
    return out


def format_summary(summary: list[dict[str, Any]], setup: PortalSetup, n_objects: int) -> str:
    """The per-room table and the false-cull check as text."""
    rows = [
        [
            "all" if s["room"] == "all" else ("outside" if s["room"] < 0 else f"room {s['room']}"),
            str(s["frames"]),
            s["frustum_culled_pct"],
            s["portals_culled_pct"],
            s["oracle_culled_pct"],
            s["frustum_ms_cull"],
            s["portals_ms_cull"],
            str(s["portals_false_culls"]),
        ]
        for s in summary
    ]
    text = format_table(
        [
            "camera in",
            "frames",
            "frustum % culled",
            "portals % culled",
            "oracle % hidden",
            "frustum ms",
            "portals ms",
            "portals false culls",
        ],
        rows,
        f"seed 001 — portal culling on a walk through {setup.rooms[0]}x{setup.rooms[1]} rooms "
        f"x {setup.floors} floor(s) ({n_objects:,} objects), {setup.frames} frames at "
        f"{res_str(setup.display)} (document: no numbers)",
    )
    total = summary[-1]
    fc = total["portals_false_culls"]
    more = total["portals_culled_pct"] > total["frustum_culled_pct"]
    lines = [
        text,
        f"false culls against the oracle: portals {fc}, frustum {total['frustum_false_culls']}"
        f" — {'OK (conservative)' if fc == 0 else 'FAILED: portal culling culled visible objects'}",
        f"{'agrees' if more else 'differs'}  portals culls more than frustum alone overall "
        f"({total['portals_culled_pct']:.1f} % vs {total['frustum_culled_pct']:.1f} %): "
        f"{DOCUMENT['claim']}",
    ]
    return "\n".join(lines)


def plot(summary: list[dict[str, Any]], rows: list[dict[str, Any]], setup: PortalSetup):
    """Left: % of objects culled per room (and overall), frustum vs portals vs the oracle's
    ideal. Right: cull time per frame."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(14, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    labels = [
        "all" if s["room"] == "all" else ("outside" if s["room"] < 0 else str(s["room"]))
        for s in summary
    ]
    x = np.arange(len(summary))
    w = 0.27
    for k, (m, color, name) in enumerate(
        (
            ("frustum", "tab:grey", "frustum only"),
            ("portals", "tab:blue", "portals"),
            ("oracle", "tab:green", "oracle (ideal: all hidden culled)"),
        )
    ):
        ax.bar(x + (k - 1) * w, [s[f"{m}_culled_pct"] for s in summary], w, color=color, label=name)
    ax.set_xticks(x, labels)
    ax.set_xlabel("room the camera stands in (walk order), and overall")
    ax.set_ylabel("objects culled (%)")
    ax.set_ylim(0, 100)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3, axis="y")
    ax.set_title("objects culled per room", fontsize=10)
    for m, color in (("frustum", "tab:grey"), ("portals", "tab:blue")):
        rs = [r for r in rows if r["method"] == m]
        bx.plot([r["frame"] for r in rs], [r["ms_cull"] for r in rs], color=color, label=m)
    bx.set_xlabel("frame")
    bx.set_ylabel("cull time (ms)")
    bx.grid(alpha=0.3)
    bx.legend(fontsize=8)
    bx.set_title("cull time per frame (no drawing)", fontsize=10)
    fig.suptitle(
        f"Seed 001 — portal culling, {setup.frames} frames at {res_str(setup.display)}; "
        f"false culls: portals {summary[-1]['portals_false_culls']}",
        fontsize=11,
    )
    fig.tight_layout()
    return fig


@dataclass
class PortalResult:
    """What :func:`portal_experiment` measured and wrote."""

    rows: list[dict[str, Any]]
    summary: list[dict[str, Any]]
    objects: int
    files: list[Path] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def write(result: PortalResult, setup: PortalSetup, out) -> list[Path]:
    """Per-frame CSV, per-room CSV, JSON summary and the PNG."""
    import matplotlib.pyplot as plt

    out = Path(out)
    fig = plot(result.summary, result.rows, setup)
    files = [
        write_csv(out / "seed001_portals_frames.csv", result.rows),
        write_csv(out / "seed001_portals_rooms.csv", result.summary),
        save_figure(fig, out / "seed001_portals.png"),
    ]
    plt.close(fig)
    total = result.summary[-1]
    files.append(
        write_json(
            out / "seed001_portals_summary.json",
            {
                "setup": {
                    "frames": setup.frames,
                    "display": res_str(setup.display),
                    "rooms": list(setup.rooms),
                    "floors": setup.floors,
                    "quick": setup.quick,
                    "seed": setup.seed,
                },
                "objects": result.objects,
                "summary": result.summary,
                "false_culls": {m: total[f"{m}_false_culls"] for m in METHODS},
                "portals_culls_more": total["portals_culled_pct"] > total["frustum_culled_pct"],
                "document": DOCUMENT,
                "seconds": result.seconds,
            },
        )
    )
    return files


def portal_experiment(
    setup: PortalSetup,
    out: str | os.PathLike = "results",
    *,
    progress: bool = True,
    verbose: bool = True,
) -> PortalResult:
    """Walk, cull, write the results into ``out`` and print the table."""
    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    scene, cams = walk(setup)
    with tqdm(total=len(cams), unit="frame", desc="seed 001 portals", disable=not progress) as bar:
        rows = run_walk(scene, cams, setup, bar=bar)
    seconds = {"walk": time.perf_counter() - t0}
    result = PortalResult(rows, summarize(rows), len(scene), seconds=seconds)
    result.files = write(result, setup, out)
    seconds["total"] = time.perf_counter() - t0
    if verbose:
        print()
        print(format_summary(result.summary, setup, result.objects))
        print(f"{len(result.files)} files written to {out}/ in {seconds['total']:.0f} s")
    return result
