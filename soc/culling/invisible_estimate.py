"""A conservative estimate of the number of invisible objects, in bounded time, from occlusion
queries on the octree's "expensive" nodes, visited top-down.

Gonakhchyan, "Adaptive rendering of dynamic 3D scenes" (seed 004, section 3): "nodes holding
many more objects than the average are expensive, and the status propagates bottom-up (a
parent is expensive if any child is). To estimate the number of invisible objects it suffices
to test the visibility of expensive nodes, top-down. The method has two parameters: the
minimum number of objects of an expensive node and the number of nodes checked." Table 2
times it on a 70,000-object scene for 10 … 10,000 nodes checked.

Stages of :meth:`InvisibleEstimator.estimate`, top-down:

1. ``prepass`` — the alive occluders in the view frustum rendered into a depth target (the
   depth the queries test against; timed apart, as the paper's time excludes rendering).
2. ``traverse`` — rounds over the octree, one level per round: the frontier (the root, then
   the expensive children of nodes found visible) minus nodes whose subtree box is outside
   the frustum (they are frustum-culled anyway; not counted), the biggest subtrees first, cut
   to the nodes-checked budget left.
3. ``queries`` — one ``GL_ANY_SAMPLES_PASSED`` query per frontier node on its subtree box
   (:class:`soc.culling.box_queries.BoxQueries`: grown, depth-biased, near-plane boxes reported
   visible), read at the end of the round (one GL stall per round).
4. The estimate is the number of objects in the subtrees of the nodes found occluded.

**Conservative**: a subtree box contains every object of the subtree, so a box with no sample
in front of the occluders' depth means none of those objects has one; an object the exact
oracle sees (at the depth target's resolution, full scene drawn) is nearer than every
occluder at some pixel centre, where its box passes. The estimate never exceeds the number
of objects the oracle does not see. Time is bounded by the budget: at most ``nodes_checked``
queries in at most ``max_depth + 1`` rounds.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from soc.culling.box_queries import BoxQueries
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.culling.frustum import aabbs_in_frustum
from soc.gl.context import ReleasedOnExit, uses_gl

# Table 2's budgets (nodes checked), also the default sweep.
TABLE2_NODES_CHECKED = (10, 20, 30, 100, 300, 1000, 2000, 10000)


@dataclass(frozen=True)
class InvisibleEstimate:
    """One estimate (:meth:`InvisibleEstimator.estimate`).

    Attributes
    ----------
    invisible : int
        Objects in the subtrees of the nodes found occluded; never more than the objects the
        oracle does not see.
    occluded_nodes : (K,) int64
        The nodes found occluded (none inside another's subtree).
    nodes_checked : int
        Nodes tested (at most the budget); ``queries`` of them were issued as GL queries (the
        others reach the near plane and count as visible).
    rounds : int
        Query rounds (GL stalls), one per octree level reached.
    min_objects : int
        The expensive-node threshold used.
    ms : float
        Traversal and queries, finished (the paper's "time of the method"), ms.
    ms_prepass : float
        Rendering the occluders' depth, ms (0 when the caller provided the depth).
    """

    invisible: int
    occluded_nodes: np.ndarray
    nodes_checked: int
    queries: int
    rounds: int
    min_objects: int
    ms: float
    ms_prepass: float


@uses_gl
class InvisibleEstimator(ReleasedOnExit):
    """Estimates invisible objects of an :class:`~soc.culling.octree.Octree` over an uploaded scene.

    Parameters
    ----------
    octree : Octree
        Indexes the alive objects of ``geometry``'s scene (a pool scene: only objects in the
        octree count as alive, and only alive occluders are rendered).
    geometry : SceneGeometry
    resolution : (width, height)
        Depth target pixels (use the oracle's resolution for the conservative comparison).
    min_objects : int, optional
        Expensive-node threshold; default ``octree.default_min_objects()`` at each call.
    nodes_checked : int
        Default budget of node queries per estimate.
    """

    def __init__(
        self,
        octree,
        geometry,
        resolution: tuple[int, int],
        *,
        min_objects: int | None = None,
        nodes_checked: int = 1000,
    ):
        self.octree = octree
        self.geometry = geometry
        self.glctx = geometry.glctx
        self.min_objects = None if min_objects is None else _positive(min_objects, "min_objects")
        self.nodes_checked = _positive(nodes_checked, "nodes_checked")
        self.target = DepthTarget(self.glctx, resolution)
        scene = geometry.scene
        diagonal = scene.diagonal
        self.queries = BoxQueries(self.glctx, diagonal)

    def release(self) -> None:
        self.queries.release()
        self.target.release()

    def render_depth(self, camera) -> float:
        """Render the alive occluders in the frustum into the depth target; returns ms."""
        t0 = time.perf_counter()
        scene = self.geometry.scene
        alive_occ = np.flatnonzero(self.octree.alive & scene.occluder)
        inside = aabbs_in_frustum(scene.aabbs[alive_occ], camera.planes)
        render_occluders(self.geometry, self.target, camera, alive_occ[inside])
        self.glctx.finish()
        return 1e3 * (time.perf_counter() - t0)

    def estimate(
        self,
        camera,
        *,
        nodes_checked: int | None = None,
        min_objects: int | None = None,
        prepass: bool = True,
        target=None,
    ) -> InvisibleEstimate:
        """Estimate the objects invisible from ``camera`` (module docstring, stages 1–4).

        ``prepass=False`` reuses the depth already in the target (several budgets from one
        camera); the caller must have rendered it for this camera. ``target``: test against
        another depth instead (anything with an ``fbo`` holding depth, e.g. the frame a
        renderer just drew from ``camera``, as a renderer's queries test its own depth buffer);
        no prepass is rendered then. Conservative as long as that depth holds only surfaces of
        the scene seen from ``camera``.
        """
        budget = self.nodes_checked if nodes_checked is None else int(nodes_checked)
        if budget < 0:
            raise ValueError(f"nodes_checked must be >= 0, got {nodes_checked}")
        k = min_objects if min_objects is not None else self.min_objects
        octree = self.octree  # dirty nodes need no re-recording: bounds are grown on insertion
        ms_prepass = self.render_depth(camera) if prepass and target is None else 0.0
        depth = self.target if target is None else target

        t0 = time.perf_counter()
        k = octree.default_min_objects() if k is None else int(k)
        expensive = octree.expensive(k)
        counts, boxes = octree.subtree_counts, octree.subtree_bounds
        children = octree.children
        frontier = np.array([0], np.int64) if expensive[0] and counts[0] > 0 else np.zeros(0, int)
        occluded: list[np.ndarray] = []
        checked = issued = rounds = 0
        while len(frontier) and checked < budget:
            frontier = frontier[aabbs_in_frustum(boxes[frontier], camera.planes)]
            frontier = frontier[np.argsort(-counts[frontier], kind="stable")][: budget - checked]
            if len(frontier) == 0:
                break
            batch = self.queries.issue(depth, camera, boxes[frontier])
            issued += batch.issued
            visible = batch.results()
            checked += len(frontier)
            rounds += 1
            occluded.append(frontier[~visible])
            kids = children[frontier[visible]].reshape(-1)
            kids = kids[kids >= 0]
            frontier = kids[expensive[kids] & (counts[kids] > 0)]
        self.glctx.finish()
        ms = 1e3 * (time.perf_counter() - t0)
        nodes = np.concatenate(occluded) if occluded else np.zeros(0, np.int64)
        return InvisibleEstimate(
            int(counts[nodes].sum()), nodes, checked, issued, rounds, k, ms, ms_prepass
        )


def _positive(value, name: str) -> int:
    v = int(value)
    if v < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    return v
