"""docs/gallery/: every picture redrawn from stored frames at the reading size (1600 px wide,
a palette PNG of at most 200 KB), tracked in git; the report shows only pictures that are
there."""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from experiments import gallery, harness

ROOT = Path(__file__).resolve().parents[2]


def _figure(width_in: float = 10.0, noise: bool = False):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, width_in / 2))
    ax = fig.subplots()
    if noise:  # the worst case for PNG: every pixel different
        ax.imshow(np.random.default_rng(0).random((400, 800, 3)))
    else:
        ax.plot([0, 1, 2], [0, 1, 0], label="a line")
        ax.legend()
    return fig


@pytest.mark.parametrize("width_in", [6.0, 10.0, 18.0])
def test_save_writes_a_palette_png_of_the_gallery_width(tmp_path, width_in):
    from PIL import Image

    path = gallery.save(_figure(width_in), tmp_path / "x.png")
    with Image.open(path) as im:
        assert abs(im.width - gallery.WIDTH) <= 1 and im.mode == "P"
    assert path.stat().st_size <= gallery.MAX_BYTES


def test_a_picture_too_large_for_256_colours_gets_fewer(tmp_path):
    from PIL import Image

    big = gallery.save(_figure(noise=True), tmp_path / "big.png", max_bytes=10**9)
    small = gallery.save(_figure(noise=True), tmp_path / "small.png", max_bytes=1)
    assert small.stat().st_size < big.stat().st_size
    with Image.open(big) as b, Image.open(small) as s:
        assert len(b.getcolors(256)) > 128 and len(s.getcolors(256)) <= min(gallery.COLORS)


@dataclasses.dataclass(frozen=True)
class _Params:
    frames: int = 3
    size: tuple[int, int] = (4, 2)
    quick: bool = False


def plot_ms(frames, params):
    """Milliseconds per frame."""
    from matplotlib.figure import Figure

    assert isinstance(params.size, tuple)  # stored lists come back as tuples
    fig = Figure(figsize=params.size)
    fig.subplots().plot(frames["frames"].frame, frames["frames"].ms)
    return fig


@pytest.fixture
def stored(monkeypatch, tmp_path):
    """One fake experiment, run once into ``tmp_path/results``."""
    monkeypatch.setattr(harness, "MODULES", ())
    monkeypatch.setattr(harness, "_REGISTRY", {})
    computed = []

    def compute(params, progress=False):
        computed.append(1)
        return {"frames": pd.DataFrame({"frame": range(params.frames), "ms": 1.0})}

    exp = harness.experiment(
        "fake",
        seed="009",
        title="fake",
        params=_Params,
        compute=compute,
        plots=[plot_ms],
        claims=lambda f, p: harness.claims_frame([]),
    )
    results = tmp_path / "results"
    harness.run(exp, out=results, progress=False, frames=5)
    return exp, results, computed


def test_pictures_are_redrawn_from_the_stored_frames_without_computing(stored, tmp_path):
    from PIL import Image

    _, results, computed = stored
    folder = tmp_path / "gallery"
    written = gallery.write(results, folder)
    assert written == [folder / "fake_ms.png"] and computed == [1]
    with Image.open(written[0]) as im:
        assert abs(im.width - gallery.WIDTH) <= 1
    assert gallery.write(tmp_path / "nothing", folder) == []  # not run there: skipped


def test_outside_a_checkout_it_refuses_with_one_line(monkeypatch, tmp_path, capsys):
    """Installed from a wheel, ROOT is site-packages: nothing is written there."""
    from experiments import common

    monkeypatch.setattr(common, "ROOT", tmp_path)
    monkeypatch.setattr(gallery, "ROOT", tmp_path)
    monkeypatch.setattr(common, "GALLERY", tmp_path / "docs" / "gallery")
    assert gallery.main([]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "checkout" in err[0]
    assert list(tmp_path.iterdir()) == []


# -- what the checkout tracks -------------------------------------------------------------------


def _tracked() -> set[str]:
    try:
        out = subprocess.run(
            ["git", "ls-files", "docs/gallery", "README.md", "results/REPORT.md"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return set(out.split())


@pytest.mark.parametrize("page", ["results/REPORT.md", "README.md"])
def test_every_picture_a_page_names_is_shown_from_a_tracked_file(page):
    """The report named 36 pictures and showed 7; now a name is a picture. (The
    README's code examples name files a user writes, ``cull.png``: only its pictures count.)"""
    tracked = _tracked()
    text = (ROOT / page).read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)\s]+\.png)\)", text)
    assert links, f"{page} shows no picture"
    if page == "results/REPORT.md":
        named = re.findall(r"[\w./-]+\.png", text)
        assert len(named) == len(links), f"{page} names pictures it does not show: " + ", ".join(
            sorted(set(named) - set(links))
        )
    for link in links:
        target = ((ROOT / page).parent / link).resolve()
        rel = target.relative_to(ROOT).as_posix()
        assert rel.startswith("docs/gallery/"), link
        assert rel in tracked, f"{page} shows {link}, which git does not track"
        assert target.stat().st_size <= gallery.MAX_BYTES, (link, target.stat().st_size)


def test_the_gallery_holds_every_picture_of_every_experiment_at_the_reading_size():
    from PIL import Image

    tracked = _tracked()
    for exp in harness.experiments():
        for plot in exp.plots:
            path = gallery.path(exp.plot_name(plot))
            assert path.relative_to(ROOT).as_posix() in tracked, f"{path.name} is not tracked"
            with Image.open(path) as im:
                assert abs(im.width - gallery.WIDTH) <= 1, (path.name, im.size)
            assert path.stat().st_size <= gallery.MAX_BYTES, path.name
