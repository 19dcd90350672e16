"""``docs/gallery/``: every picture of every experiment, tracked in git so that
``results/REPORT.md`` and the documentation site show them in a fresh clone. Each is drawn
again from the experiment's stored frames (nothing is recomputed) as a small palette PNG.
``make figures`` refreshes it after the experiments it ran; ``python -m experiments.gallery
[RESULTS]`` redraws it from a results folder.
"""

from __future__ import annotations

import io
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from experiments import terminal
from experiments.common import ROOT, atomic_write, default_results_dir, gallery_path, in_checkout

WIDTH = 1600  # pixels: readable on a code host's page at full width
MAX_BYTES = 200_000  # per picture, so that the gallery stays small in git
COLORS = (256, 128, 64, 32)  # palette sizes tried in turn until a picture fits MAX_BYTES


path = gallery_path  # where a picture lives in the gallery (``<key>_<plot>``)


def save(fig: Any, target: Path, width: int = WIDTH, max_bytes: int = MAX_BYTES) -> Path:
    """Write ``fig`` as a PNG ``width`` pixels wide with the largest palette of :data:`COLORS`
    that keeps it within ``max_bytes`` (the smallest when none does), atomically."""
    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=width / fig.get_size_inches()[0])
    with Image.open(buf) as im:
        rgb = im.convert("RGB")
    data = b""
    for colors in COLORS:
        q = rgb.quantize(colors, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
        out = io.BytesIO()
        q.save(out, format="PNG", optimize=True)
        data = out.getvalue()
        if len(data) <= max_bytes:
            break
    return atomic_write(Path(target), lambda p: p.write_bytes(data))


def draw(exp, results: Path, folder: Path | None = None) -> list[Path]:
    """Every picture of ``exp`` drawn again from its stored frames under ``results`` into
    ``folder``; [] when it has not run there."""
    from experiments import harness

    res = harness.load(exp, results)
    return [] if res is None else [save(fig, path(s, folder)) for s, fig in res.draw().items()]


def write(
    results: Path | None = None, folder: Path | None = None, only: Iterable[str] | None = None
) -> list[Path]:
    """Redraw the gallery from ``results`` (default: the checkout's ``results/``): every
    experiment there, or ``only`` those keys; returns the files written."""
    from experiments import harness

    results = Path(results) if results is not None else default_results_dir()
    keys = set(only) if only is not None else None
    written: list[Path] = []
    for exp in harness.experiments():
        if keys is not None and exp.key not in keys:
            continue
        paths = draw(exp, results, folder)
        if not paths:
            skip = f"skipped {exp.key}: not in {results} (`vislod figures --only {exp.key}`)"
            print(terminal.paragraph(skip, indent="  "))
        written += paths
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """Redraw ``docs/gallery/`` from a results folder (default ``results/``), then
    ``results/REPORT.md``; only in a checkout."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not in_checkout():
        print(
            "gallery: error: the gallery lives in a vislod checkout (docs/gallery); "
            f"{ROOT} is an installed package — run it in a clone of the repository",
            file=sys.stderr,
        )
        return 2
    from experiments.report import write_report

    results = Path(argv[0]) if argv else default_results_dir()
    for p in write(results):
        print(p)
    print(write_report(results, to=default_results_dir()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
