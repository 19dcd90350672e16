"""Batched box queries: results equal per-object queries, polling never blocks, ids recycle."""

from __future__ import annotations

import numpy as np

import soc
from soc.culling.box_queries import BoxQueries
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.gl.context import default_context
from soc.scenes.clutter import box_mesh


def test_box_queries_match_the_oracle_on_a_wall_scene():
    wall = box_mesh((-5, -5, -0.5), (5, 5, 0.5))
    s = soc.Scene.from_meshes([wall], occluder=[True])
    cam = soc.Camera.look_at((0, 8, 20), (0, 0, 0), width=320, height=240, near=0.5, far=100)
    boxes = np.array(
        [
            [[-1, -1, -6], [1, 1, -5]],  # hidden behind the wall
            [[7, -1, -6], [8, 1, -5]],  # beside the wall: visible
            [[-1, -1, 1], [1, 1, 2]],  # in front of the wall: visible
            [[-1, 7, 19.8], [1, 9, 25]],  # reaches the near plane: kept without a query
            [[-4, 5, -0.5], [-3, 5, 0.5]],  # flat, on the wall top, seen from above
        ],
        np.float32,
    )
    ctx = default_context()
    target = DepthTarget(ctx, (320, 240))
    bq = BoxQueries(ctx, diagonal=20.0)
    try:
        render_occluders(ctx.geometry(s), target, cam, np.array([0]))
        batch = bq.issue(target, cam, boxes)
        assert batch.issued == 4 and len(batch) == 5
        for _ in range(1000):  # polling returns without blocking; eventually ready
            if batch.ready():
                break
        np.testing.assert_array_equal(batch.results(), [False, True, True, True, True])
        again = bq.issue(target, cam, boxes)  # ids were returned to the pool and reused
        np.testing.assert_array_equal(again.results(), batch.results())
        assert len(bq._all) == len(set(bq._all))
    finally:
        bq.release()
        target.release()
