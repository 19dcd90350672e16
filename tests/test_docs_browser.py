"""The built documentation site, seen in a real browser: headless Chromium screenshots the
index, a method page and an API page, and each must show the site's navigation and, where the
page has one, its picture.

Skipped where no ``chromium`` is installed (``make docs`` installs Debian's as root) or the
site is not built (``make docs``; CI builds it before this test). The screenshots are written
to ``docs/_build/screenshots/`` for a person to look at.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "docs" / "_build" / "html"
SHOTS = ROOT / "docs" / "_build" / "screenshots"
BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")
# The flags that run headless Chromium here: no sandbox (root), no GPU, and no background
# connections (the machine's network is closed).
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
]
PAGES = {
    "index": "index.html",
    "method": "generated/methods/hiz-2phase.html",
    "api": "generated/api/soc.Culler.html",
}

pytestmark = [
    pytest.mark.skipif(BROWSER is None, reason="no chromium (make docs installs it as root)"),
    pytest.mark.skipif(not (SITE / "index.html").exists(), reason="site not built: make docs"),
]


def screenshot(page: str, size=(1280, 1600)) -> np.ndarray:
    """A PNG of ``page`` of the built site as Chromium renders it: (H, W, 3) uint8."""
    import matplotlib.image as mpimg

    SHOTS.mkdir(parents=True, exist_ok=True)
    out = SHOTS / (Path(page).stem + ".png")
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run(
            [
                BROWSER,
                *FLAGS,
                f"--user-data-dir={profile}",
                f"--window-size={size[0]},{size[1]}",
                f"--screenshot={out}",
                (SITE / page).as_uri(),
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )
    img = mpimg.imread(out)
    return (img[..., :3] * 255).astype(np.uint8)


@pytest.mark.parametrize("kind", sorted(PAGES))
def test_page_renders_with_navigation_and_pictures(kind):
    page = PAGES[kind]
    html = (SITE / page).read_text()
    # the theme's navigation bar and sidebar, in the HTML the browser renders
    assert "bd-header" in html and "bd-sidebar" in html, f"{page}: no navigation"
    images = re.findall(r'<img[^>]+src="([^"]+)"', html)
    for src in images:
        if not src.startswith(("http", "data:")):
            assert (SITE / page).parent.joinpath(src).resolve().exists(), f"{page}: {src} missing"
    img = screenshot(page)
    h, w, _ = img.shape
    assert (h, w) == (1600, 1280)
    # not blank: a rendered page has text (dark pixels) on its light background
    dark = (img.max(axis=2) < 100).mean()
    assert dark > 0.005, f"{page} looks blank ({dark:.2%} dark pixels)"
    if kind in ("index", "method"):
        assert images, f"{page} has no picture"
        # the culling picture's classes: saturated green (visible) and blue (culled) pixels
        r, g, b = (img[..., k].astype(int) for k in range(3))
        green = ((g > 150) & (r < 110) & (b < 120)).sum()
        blue = ((b > 180) & (r < 110) & (g < 140)).sum()
        assert green > 500 and blue > 50, f"{page}: its picture did not render"
