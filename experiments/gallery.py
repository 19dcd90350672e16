"""``docs/gallery/``: every picture of every experiment, tracked in git so that
``results/REPORT.md`` and the README show them in a fresh clone. Each is drawn again from the
experiment's stored frames (nothing is recomputed) as a small palette PNG. ``make figures``
refreshes it after the experiments it ran; ``python -m experiments.gallery [RESULTS]`` redraws
it from a results folder. The README's gallery section (:data:`SHOTS`) picks a few pictures.
"""

from __future__ import annotations

import io
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiments import terminal
from experiments.common import ROOT, atomic_write, default_results_dir, gallery_path, in_checkout

README_BEGIN, README_END = "<!-- begin gallery -->", "<!-- end gallery -->"
WIDTH = 1600  # pixels: readable on a code host's page at full width
MAX_BYTES = 200_000  # per picture, so that the gallery stays small in git
COLORS = (256, 128, 64, 32)  # palette sizes tried in turn until a picture fits MAX_BYTES


@dataclass(frozen=True)
class Shot:
    """A picture the README shows: ``name`` is its file stem (``<key>_<plot>``)."""

    name: str
    caption: str
    command: str


SHOTS = (
    Shot(
        "seed000_abb1",
        "Seed 000, Abb. 1: the frame with the kept objects outlined, and what occlusion culling "
        "removed",
        "vislod figures --only seed000",
    ),
    Shot(
        "seed001_lod_pictures",
        "Seed 001: no detail elision vs Funkhouser–Séquin at a target frame time (changed "
        "pixels in magenta); the chosen levels, darker grey = more detail, with a key",
        "vislod lod",
    ),
    Shot(
        "seed001_lod_flight",
        "Seed 001: frame time per frame against the budget for five LOD strategies, and the "
        "share of frames over it (measured and by the cost model)",
        "vislod lod",
    ),
    Shot(
        "seed001_image_based_stereo_images",
        "Seed 001: stereo by warping — the true right eye, the warped one, and its holes",
        "vislod image-based",
    ),
    Shot(
        "seed002_frametime",
        "Seed 002: frame time with grid occlusion queries against frustum culling alone, and "
        "under query caps scaled to our queries per frame (the thesis's caps never bind here)",
        "vislod seed002",
    ),
    Shot(
        "seed003_lights",
        "Seed 003: forward vs deferred shading, CPU time and their ratio against the number of "
        "lights, drawn back to front and front to back",
        "vislod seed003",
    ),
    Shot(
        "seed004_adaptive_frametimes",
        "Seed 004, Figs. 3–5: frustum culling vs queries vs the adaptive method on three "
        "growing scenes, the adaptive method's mode as background colour (legend below)",
        "vislod seed004-adaptive",
    ),
)


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


def markdown(shots: Sequence[Shot] = SHOTS, folder: Path | None = None) -> str:
    """The README section listing the shots present in ``folder``."""
    return "\n".join(
        f"![{s.name}](docs/gallery/{s.name}.png)\n*{s.caption}* — `{s.command}`\n"
        for s in shots
        if path(s.name, folder).is_file()
    )


def update_readme(readme: Path | None = None, folder: Path | None = None) -> Path:
    """Replace the text between the README's gallery markers with :func:`markdown`."""
    readme = Path(readme) if readme is not None else ROOT / "README.md"
    text = readme.read_text()
    if README_BEGIN not in text or README_END not in text:
        raise ValueError(f"{readme} has no {README_BEGIN} … {README_END} markers")
    head, rest = text.split(README_BEGIN, 1)
    _, tail = rest.split(README_END, 1)
    body = markdown(folder=folder)
    return atomic_write(
        readme, lambda p: p.write_text(f"{head}{README_BEGIN}\n{body}{README_END}{tail}")
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Redraw ``docs/gallery/`` from a results folder (default ``results/``), then the
    README's gallery and ``results/REPORT.md``; only in a checkout."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not in_checkout():
        print(
            "gallery: error: the gallery lives in a vislod checkout (docs/gallery, README.md); "
            f"{ROOT} is an installed package — run it in a clone of the repository",
            file=sys.stderr,
        )
        return 2
    from experiments.report import write_report

    results = Path(argv[0]) if argv else default_results_dir()
    for p in write(results):
        print(p)
    print(update_readme())
    print(write_report(results, to=default_results_dir()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
