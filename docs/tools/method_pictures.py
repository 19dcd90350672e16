"""Draw one frame per registered culling method into ``docs/gallery/methods/<name>.png``.

Each picture is :func:`soc.viz.plot_cull` of one frame of the seed-000 flight over the
generated market (the ``portals`` method: a walk through :func:`soc.scenes.rooms`), at
640×360 for the depth buffer and for the oracle, seen from above and behind the camera.
The methods that reuse last frame's results (``temporal``) are warmed up first: every method
culls the same :data:`WARMUP` frames before the pictured one, so the picture shows the
method's steady state rather than its first frame (which, for two-phase methods, keeps
everything in the frustum).

Each picture is cut to what it shows (:func:`crop`). Run
``python docs/tools/method_pictures.py [NAME ...]`` (``make docs-pictures``); the quick
documentation build reuses the stored pictures and only draws the missing ones.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "gallery" / "methods"
RESOLUTION = (640, 360)
FRAME = 30  # of the 100-frame flight: the castle wall hides most of the market
WARMUP = 8  # frames culled before the pictured one


def _frames(name: str):
    import soc

    if name == "portals":
        scene = soc.scenes.rooms(seed=0)
        cams = soc.scenes.rooms_walk(scene, frames=40, width=RESOLUTION[0], height=RESOLUTION[1])
        return scene, cams[20 - WARMUP : 21], cams
    scene = soc.scenes.market(seed=0)
    cams = [
        c.replace(width=RESOLUTION[0], height=RESOLUTION[1])
        for c in soc.scenes.paths.flight(scene, frames=100)
    ]
    return scene, cams[FRAME - WARMUP : FRAME + 1], cams


def draw(name: str) -> dict:
    """Cull the warm-up frames and the pictured one with method ``name``; write its PNG and
    return the pictured frame's counts (kept, visible, false keeps, false culls)."""
    import soc
    import soc.viz

    scene, frames, path = _frames(name)
    with soc.Culler(scene, name, resolution=RESOLUTION) as culler:
        for cam in frames[:-1]:
            culler.cull(cam)
        cam = frames[-1]
        truth = soc.exact_visibility(scene, cam)
        result = culler.cull(cam, truth=truth)
    OUT.mkdir(parents=True, exist_ok=True)
    soc.viz.plot_cull(
        scene,
        cam,
        result,
        truth,
        path=path,
        screenshot=OUT / f"{name}.png",
        window_size=(1200, 750),
    )
    crop(OUT / f"{name}.png")
    stats = result.stats
    return {
        "kept": int(stats.models_visible),
        "visible": int(np.count_nonzero(truth)),
        "false_keeps": int(stats.false_keeps),
        "false_culls": int(stats.false_culls),
        "objects": len(scene),
        "scene": "rooms" if name == "portals" else "market",
        "frame": 20 if name == "portals" else FRAME,
        "warmup": WARMUP,
    }


def crop(path: Path, margin: int = 12) -> None:
    """Cut the white border off the PNG at ``path`` (the overview leaves much of it), keeping
    ``margin`` pixels around the picture and its legend."""
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    dark = (img[..., :3] < 0.97).any(axis=2)
    rows, cols = np.flatnonzero(dark.any(axis=1)), np.flatnonzero(dark.any(axis=0))
    if rows.size == 0:
        return
    top, bottom = max(rows[0] - margin, 0), min(rows[-1] + margin + 1, img.shape[0])
    left, right = max(cols[0] - margin, 0), min(cols[-1] + margin + 1, img.shape[1])
    from PIL import Image

    rgb = np.round(img[top:bottom, left:right, :3] * 255).astype(np.uint8)
    Image.fromarray(rgb).save(path, optimize=True)


def main(names: list[str]) -> None:
    from soc.methods import METHODS

    names = names or sorted(METHODS)
    index_path = OUT / "frames.json"
    index = json.loads(index_path.read_text()) if index_path.exists() else {}
    for name in names:
        index[name] = draw(name)
        print(name, index[name], flush=True)
        index_path.write_text(json.dumps(index, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
