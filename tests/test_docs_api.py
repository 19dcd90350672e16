"""What a new user meets first, outside the pages: every public name documented and in the
reference, names that tab-complete, short reprs, pictures whose legend fits."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))


def test_every_public_name_is_documented_and_in_the_reference():
    vislod_docs = pytest.importorskip("vislod_docs", reason="the 'docs' extra holds sphinx")
    import lod
    import soc

    assert vislod_docs.undocumented() == []
    listed = {f"{m}.{n}" for m, _, names in vislod_docs.api_entries() for n in names}
    for n in soc.__all__:
        if n not in ("scenes", "paths"):  # modules: their names are listed one by one
            assert f"soc.{n}" in listed
    assert {f"lod.{n}" for n in lod.__all__} <= listed
    assert {f"soc.scenes.{n}" for n in soc.scenes.__all__} <= listed


def test_method_pages_follow_the_registry():
    vislod_docs = pytest.importorskip("vislod_docs", reason="the 'docs' extra holds sphinx")
    import soc.methods

    for name, cls in soc.methods.METHODS.items():
        page = vislod_docs.method_page(name, cls, "", {})
        assert page.startswith(f"# ``{name}``")
        assert (vislod_docs.PICTURES / f"{name}.png").exists(), f"{name} has no picture"
        for option, *_ in vislod_docs.option_table(cls):
            assert f"`{option}`" in page


def test_lod_names_tab_complete():
    import lod

    assert set(lod.__all__) <= set(dir(lod))


def test_lod_scene_repr_is_one_short_line():
    from lod import lod_scene

    config = lod_scene.LodSceneConfig(instances=4, detail=1, area=20.0)
    scenery = lod_scene.build(config, cache_dir=False)
    text = repr(scenery)
    assert "\n" not in text and len(text) < 200, text
    assert text.startswith("LodScene(4 instances")


def test_plot_cull_legend_stays_in_the_picture():
    """The legend's longest label ends inside the picture, at any window size: no text pixels
    in the picture's right-most columns (VTK let a narrow box's labels run out of it)."""
    pytest.importorskip("pyvista")
    import soc
    import soc.viz

    scene = soc.scenes.random_boxes(12_000)  # five-digit counts: the longest labels
    cam = soc.Camera.look_at((0, 3, 12), (0, 0, 0), width=320, height=240)
    # every class in the legend, with long counts: the widest labels it can have
    classes = np.arange(len(scene)) % 5
    for window in ((320, 240), (800, 500)):
        size = soc.viz._legend_size(
            [f"{soc.viz.LEGEND_LABELS[k]} 123456" for k in range(5)], window
        )
        assert 0 < size[0] <= soc.viz.LEGEND_MAX_WIDTH
        truth = classes != soc.viz.FRUSTUM_CULLED
        kept = np.isin(classes, (soc.viz.VISIBLE, soc.viz.FALSE_KEEP))
        img = soc.viz.plot_cull(
            scene, cam, kept, truth, screenshot=None, off_screen=True, window_size=window, view="xy"
        ).screenshot(return_img=True)
        edge = img[: img.shape[0] // 3, -3:, :3].astype(int)
        assert (edge.min(axis=2) > 200).all(), f"legend text at the right edge at {window}"


def test_plot_chain_colour_bar_stays_in_the_picture():
    """The error bar's last label ends inside the picture (pyvista's default place cut it)."""
    pytest.importorskip("pyvista")
    import trimesh

    import lod
    import lod.viz

    mesh = trimesh.creation.icosphere(3)
    chain = lod.build_chain(mesh.vertices, mesh.faces, ratios=(1.0, 0.25, 0.0625), cache_dir=False)
    img = lod.viz.plot_chain(chain, screenshot=None, off_screen=True).screenshot(return_img=True)
    bottom_right = img[-img.shape[0] // 4 :, -4:, :3].astype(int)
    assert (bottom_right.min(axis=2) > 200).all(), "the colour bar's labels reach the edge"
