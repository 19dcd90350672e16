"""The README's gallery: a handful of key figures from ``results/``, shrunk into
``docs/gallery/`` (tracked, small), each with one line on what it shows and the command that
made it. ``python -m experiments.gallery`` after ``make figures``.

A figure missing from ``results/`` is skipped with a message (run its command first).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from experiments.common import atomic_write, default_results_dir

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "docs" / "gallery"
README_BEGIN, README_END = "<!-- begin gallery -->", "<!-- end gallery -->"
WIDTH = 900  # pixels: small in git, still readable on GitHub


@dataclass(frozen=True)
class Shot:
    source: str  # relative to the results folder
    name: str  # file name in docs/gallery
    caption: str
    command: str


SHOTS = (
    Shot(
        "seed000/seed000_abb1.png",
        "seed000_abb1.png",
        "Seed 000, Abb. 1: the frame with the kept objects outlined, and what occlusion culling "
        "removed",
        "vislod figures --only seed000",
    ),
    Shot(
        "seed001-lod/seed001_lod_pictures.png",
        "seed001_lod_pictures.png",
        "Seed 001: no detail elision vs Funkhouser–Séquin at a target frame time (changed "
        "pixels in magenta); the chosen levels, darker grey = more detail, with a key",
        "vislod lod",
    ),
    Shot(
        "seed001-lod/seed001_lod_flight.png",
        "seed001_lod_flight.png",
        "Seed 001: frame time per frame against the budget for five LOD strategies, and the "
        "share of frames over it (measured and by the cost model)",
        "vislod lod",
    ),
    Shot(
        "seed001-image-based/seed001_image_based_stereo_images.png",
        "seed001_stereo.png",
        "Seed 001: stereo by warping — the true right eye, the warped one, and its holes",
        "vislod image-based",
    ),
    Shot(
        "seed002/seed002_frametime.png",
        "seed002_frametime.png",
        "Seed 002: frame time with grid occlusion queries against frustum culling alone, and "
        "under query caps scaled to our queries per frame (the thesis's caps never bind here)",
        "vislod seed002",
    ),
    Shot(
        "seed003/seed003_lights.png",
        "seed003_lights.png",
        "Seed 003: forward vs deferred shading, CPU time and their ratio against the number of "
        "lights, drawn back to front and front to back",
        "vislod seed003",
    ),
    Shot(
        "seed004-adaptive/seed004_adaptive_frametimes.png",
        "seed004_adaptive.png",
        "Seed 004, Figs. 3–5: frustum culling vs queries vs the adaptive method on three "
        "growing scenes, the adaptive method's mode as background colour (legend below)",
        "vislod seed004-adaptive",
    ),
)


def shrink(source: Path, target: Path, width: int = WIDTH) -> Path:
    """Write ``source`` scaled to ``width`` pixels wide (never enlarged) as PNG at ``target``."""
    from PIL import Image

    with Image.open(source) as im:
        im = im.convert("RGB")
        if im.width > width:
            im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
        return atomic_write(target, lambda p: im.save(p, format="PNG", optimize=True))


def markdown(shots=SHOTS, folder: Path = FOLDER) -> str:
    """The README section listing the shots present in ``folder``."""
    lines = []
    for s in shots:
        if (folder / s.name).is_file():
            lines += [
                f"![{Path(s.name).stem}](docs/gallery/{s.name})",
                f"*{s.caption}* — `{s.command}`",
                "",
            ]
    return "\n".join(lines)


def write(results: Path | None = None, folder: Path = FOLDER) -> list[Path]:
    results = Path(results) if results is not None else default_results_dir()
    written = []
    for s in SHOTS:
        src = results / s.source
        if not src.is_file():
            print(f"skipped {s.source}: not in {results} (run `{s.command}`)", file=sys.stderr)
            continue
        written.append(shrink(src, folder / s.name))
    return written


def update_readme(readme: Path = ROOT / "README.md", folder: Path = FOLDER) -> Path:
    """Replace the text between the README's gallery markers with :func:`markdown`."""
    text = readme.read_text()
    if README_BEGIN not in text or README_END not in text:
        raise ValueError(f"{readme} has no {README_BEGIN} … {README_END} markers")
    head, rest = text.split(README_BEGIN, 1)
    _, tail = rest.split(README_END, 1)
    body = markdown(folder=folder)
    return atomic_write(
        readme, lambda p: p.write_text(f"{head}{README_BEGIN}\n{body}{README_END}{tail}")
    )


def main() -> int:
    """Refresh ``docs/gallery/`` and the README's gallery; only in a checkout (an installed
    package has no README or docs folder to update, and must not write into site-packages)."""
    if not (ROOT / "pyproject.toml").is_file():
        print(
            "gallery: error: the gallery lives in a vislod checkout (docs/gallery, README.md); "
            f"{ROOT} is an installed package — run it in a clone of the repository",
            file=sys.stderr,
        )
        return 2
    for p in write():
        print(p)
    print(update_readme())
    return 0


if __name__ == "__main__":
    sys.exit(main())
