"""Octant boxes (:mod:`soc.culling.octant_boxes`): every point of every triangle lies in one
of its object's eight boxes, the boxes lie in the object's AABB, empty octants are marked, and
the HiZ test judging by them keeps a subset of what the box test keeps and every visible object
(hiz-2phase's ``octants`` option runs the temporal suite of tests/soc/test_hiz_2phase.py)."""

from __future__ import annotations

import numpy as np

import soc
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.culling.hiz_gpu import DepthPyramid, HizTest
from soc.culling.hiz_options import MAX_REFINE
from soc.culling.octant_boxes import EMPTY_HI, EMPTY_LO, grown_octant_aabbs, octant_aabbs
from soc.gl.context import default_context
from soc.scenes.clutter import box_mesh
from soc.scenes.paths import random_cameras


def _points_on_triangles(scene, per_triangle: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random points on every triangle (barycentric, corners and edge points included) and
    the object each belongs to."""
    rng = np.random.default_rng(seed)
    owner = np.repeat(np.arange(len(scene)), scene.triangle_counts)
    tri = scene.vertices[scene.faces + scene.vertex_offsets[owner][:, None]].astype(np.float64)
    w = rng.random((len(tri), per_triangle, 3))
    w[:, :3] = np.eye(3)  # the corners
    w[:, 3] = (0.5, 0.5, 0.0)  # an edge midpoint
    w /= w.sum(axis=2, keepdims=True)
    points = np.einsum("tkc,tcd->tkd", w, tri).reshape(-1, 3)
    return points, np.repeat(owner, per_triangle)


def test_every_triangle_point_lies_in_an_octant_box(clutter_scenes):
    for k, scene in enumerate(clutter_scenes[:2]):
        boxes = octant_aabbs(scene).astype(np.float64)
        points, owner = _points_on_triangles(scene, 8, seed=k)
        lo, hi = boxes[owner, :, 0], boxes[owner, :, 1]  # (P, 8, 3)
        inside = ((lo <= points[:, None]) & (points[:, None] <= hi)).all(axis=2).any(axis=1)
        assert inside.all(), f"scene {k}: {int((~inside).sum())} points outside every box"


def test_octant_boxes_lie_in_the_object_box_and_empty_ones_are_marked():
    # An L of two slabs: the octant away from both (upper x, upper y) holds no triangle.
    (va, fa), (vb, fb) = box_mesh((0, 0, 0), (4, 1, 1)), box_mesh((0, 0, 0), (1, 4, 1))
    merged = soc.Scene(np.concatenate([va, vb]), np.concatenate([fa, fb + 8]), [16], [24], [True])
    boxes = octant_aabbs(merged)[0]
    empty = boxes[:, 0, 0] > boxes[:, 1, 0]
    # Octant 3 = upper x and upper y: beyond both slabs (the slabs end at 1 there).
    assert empty.tolist() == [False, False, False, True, False, False, False, True]
    assert (boxes[empty, 0] == EMPTY_LO).all() and (boxes[empty, 1] == EMPTY_HI).all()
    lo, hi = merged.aabbs[0]
    full = boxes[~empty]
    assert (full[:, 0] >= np.nextafter(lo, -np.inf)).all()
    assert (full[:, 1] <= np.nextafter(hi, np.inf)).all()
    # Upper x, lower y, lower z: only the long x slab, 1 thick in y.
    assert np.allclose(boxes[1], [[2, 0, 0], [4, 1, 0.5]], atol=1e-5)
    grown = grown_octant_aabbs(merged, diagonal=6.0)
    assert (grown[0, empty] == boxes[empty]).all()  # empty stays empty (no nan, no inf)
    assert (grown[0, ~empty, 0] < boxes[~empty, 0]).all()


def test_octant_test_keeps_a_subset_of_the_box_test_and_every_visible_object(clutter_scenes):
    """The same occluder pyramid, boxes with and without their octant boxes: the octant test
    keeps only objects the box test keeps, fewer in total, and every object the oracle sees."""
    glctx = default_context()
    resolution = (333, 197)
    kept = {"boxes": 0, "octants": 0}
    target, pyramid, tester = (
        DepthTarget(glctx, resolution),
        DepthPyramid(glctx, resolution),
        HizTest(glctx, footprint=4, refine=MAX_REFINE),
    )
    try:
        for k, scene in enumerate(clutter_scenes[:3]):
            geometry = glctx.geometry(scene)
            octants = glctx.ctx.buffer(grown_octant_aabbs(scene, geometry.diagonal).reshape(-1, 48))
            ids = np.arange(len(scene))
            with soc.Oracle(scene) as oracle:
                for cam in random_cameras(scene, 12, seed=700 + k, width=333, height=197):
                    target.clear()
                    render_occluders(geometry, target, cam, np.flatnonzero(scene.occluder))
                    pyramid.build(target.texture)
                    boxes = tester.test(pyramid, cam, geometry.boxes, ids)
                    by_octants = tester.test(pyramid, cam, geometry.boxes, ids, octants=octants)
                    truth = oracle.visible(cam, resolution)
                    assert not (truth & ~by_octants).any(), f"scene {k} eye={cam.eye}"
                    assert not (by_octants & ~boxes).any()
                    kept["boxes"] += int(boxes.sum())
                    kept["octants"] += int(by_octants.sum())
            octants.release()
    finally:
        tester.release()
        pyramid.release()
        target.release()
    assert kept["octants"] < kept["boxes"], kept
