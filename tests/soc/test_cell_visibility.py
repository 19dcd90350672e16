"""soc.culling.cell_visibility: each cell sees itself and every cell its sample views reach;
culling by it keeps only objects in the frustum, culls some of them inside the building, and
is frustum culling from outside."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.cell_visibility import cell_visibility, kept_by_cell_visibility
from soc.culling.frustum import aabbs_in_frustum
from soc.culling.portals import cell_graph
from soc.scenes.rooms import rooms, rooms_walk


@pytest.fixture(scope="module")
def building():
    scene = rooms(1, rooms=(6, 4))
    graph = cell_graph(scene)
    return scene, graph, cell_visibility(graph, samples=2)


def test_cells_see_themselves_and_what_their_sample_views_reach(building):
    _, graph, vis = building
    assert len(vis) == len(graph.cells)
    for c, seen in enumerate(vis):
        assert seen.dtype == np.int64 and np.all(np.diff(seen) > 0) and c in seen
    lo, hi = graph.cells[5]
    eye = lo + (hi - lo) * 0.75  # a sample eye (samples=2: at 1/4 and 3/4), looking along -z
    cam = soc.Camera(tuple(eye), tuple(eye - (0, 0, 1)), (0, 1, 0), 90.0, 64, 64, 1e-3, 1e3)
    assert set(graph.traverse(cam)) <= set(vis[5].tolist())
    assert min(len(s) for s in vis) < len(graph.cells)  # walls hide some cells


def test_culling_keeps_a_subset_of_the_frustum(building):
    scene, graph, vis = building
    culled = 0
    for cam in rooms_walk(scene, 12, seed=0, width=160, height=96):
        kept = kept_by_cell_visibility(graph, vis, cam)
        in_frustum = aabbs_in_frustum(scene.aabbs, cam.planes)
        assert kept.shape == (len(scene),) and not (kept & ~in_frustum).any()
        culled += int((in_frustum & ~kept).sum())
    assert culled > 0
    outside = soc.Camera.look_at((24, 2, -30), (24, 1.5, 16), width=320, height=192, far=200)
    kept = kept_by_cell_visibility(graph, vis, outside)
    assert np.array_equal(kept, aabbs_in_frustum(scene.aabbs, outside.planes))
