"""``queries-batched``: seed 000's future work ("pack occludees into packets to need fewer
queries") done conservatively — hierarchical occlusion queries on spatially coherent packets.

Packets are the nodes of a BVH over the object AABBs (:mod:`soc.culling.bvh`) holding about
``packet_size`` objects. Per frame:

1. frustum: per-object AABB test (as ``queries``);
2. prepass: the frustum-surviving occluders into the depth target (as ``queries``);
3. queries: the BVH is refitted to the frustum survivors, so each node's box is the exact
   union of its *surviving* members' AABBs; one query per non-empty packet; then rounds of
   refinement: the children of every packet/node found visible are queried in the next round,
   and visible leaves are resolved by per-object queries (issued in the same batch as the next
   round's node queries, so each round costs one read-back stall). A node left with a single
   surviving member has that member's AABB as its box, so its result is the object's result
   and needs no second query. Packets enter nearest first, ``wave_size`` per round, and the
   meshes of the objects found visible are rendered into the depth before the next round:
   later, farther queries are then tested against occludees too, not only against the
   occluders.

Conservative, by this argument. Let object O have a pixel p in the exact id render, and let O be
a frustum survivor in node P (objects outside the frustum are culled by the conservative
frustum test alone). Then O's surface at p is no farther than the depth buffer at p: it holds only
real scene meshes (occluders, and objects found visible earlier) drawn with the oracle's
camera, resolution and vertex shader — a subset of what the oracle draws, and O wins the depth
test there against all of it.
P's refitted box contains O's AABB, which contains O; so the box covers p and its nearest face
along the ray through p is no farther than O's surface there. ``BoxQueries`` grows boxes and
biases them towards the camera, so that face passes the LEQUAL test at p: P is visible. By
induction every node on the path from the packet to O is found visible and O is queried (or is
the single member of a visible node) with its own AABB — the ``queries`` test, which passes.
Near plane: a box reaching the near plane would be clipped open, so ``BoxQueries`` reports it
visible without drawing it; a union box straddles the near plane whenever a member's does,
so straddlers always reach refinement and are kept, as in ``queries``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soc.culling.bvh import box_distance, build
from soc.methods.base import MethodOutput, register, stage
from soc.methods.options import MethodOptions, option
from soc.methods.prepass_queries import PrepassQueryMethod

# Objects per packet (the first query level). Larger packets: fewer top-level queries but
# more refinement rounds; 32-64 balances both on the market at 1080p.
DEFAULT_PACKET_SIZE = 64

# Objects per BVH leaf: a visible leaf is resolved by per-object queries. Smaller leaves mean
# more node queries but fewer wasted object queries next to the visible ones.
DEFAULT_LEAF_SIZE = 4


# Packets joining the refinement per round, nearest first: each round's queries then test
# against the depth of everything found visible in earlier (nearer) rounds.
DEFAULT_WAVE_SIZE = 32


@dataclass(frozen=True)
class BatchedQueryOptions(MethodOptions):
    """Options of ``queries-batched`` (:class:`BatchedQueryCulling`).

    Attributes
    ----------
    packet_size : int
        Objects per top-level packet (a BVH cut), default :data:`DEFAULT_PACKET_SIZE`.
    leaf_size : int
        Objects per BVH leaf, default :data:`DEFAULT_LEAF_SIZE`.
    wave_size : int
        Packets entering per round, nearest first, default :data:`DEFAULT_WAVE_SIZE`.
    compiled : bool
        Issue and read each round's queries from numba loops over the GL entry points
        (default); False: one Python call chain per query (the tested reference). Python runs
        once per round either way.
    """

    packet_size: int = option(DEFAULT_PACKET_SIZE, low=1)
    leaf_size: int = option(DEFAULT_LEAF_SIZE, low=1)
    wave_size: int = option(DEFAULT_WAVE_SIZE, low=1)
    compiled: bool = True


@register
class BatchedQueryCulling(PrepassQueryMethod):
    """Frustum + occluder prepass + hierarchical queries: packets, their sub-nodes, objects.

    Options: :class:`BatchedQueryOptions`. The meshes of the objects found visible are drawn
    into the depth before the next round.

    Conservative at the depth resolution it runs at (see the module docstring). ``queries``
    in the output counts every query issued (packets, nodes and objects).
    """

    name = "queries-batched"
    conservative = True
    Options = BatchedQueryOptions

    def __init__(self, geometry, resolution, config, options: BatchedQueryOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        options = self.options
        self.bvh = build(self.scene.aabbs, options.leaf_size)
        self.packets = self.bvh.cut(options.packet_size)
        self.wave_size = options.wave_size

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        in_frustum, frustum_culled, test = self.start_frame(camera, timings)
        if not test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)
        with stage(timings, "queries", self.glctx.finish):
            visible, queries = self._refine(camera, in_frustum)
        return MethodOutput(visible, frustum_culled, queries, timings)

    # -- stage 3: packets, then refinement rounds --------------------------------------------

    def _refine(self, camera, in_frustum: np.ndarray) -> tuple[np.ndarray, int]:
        """(N,) bool visible and the number of queries issued."""
        bvh = self.bvh
        boxes, counts = bvh.refit(in_frustum)
        selected = in_frustum[bvh.order]  # frustum survivors in BVH order
        visible = np.zeros(len(self.scene), bool)
        packets = self.packets[counts[self.packets] > 0]
        packets = packets[np.argsort(box_distance(boxes[packets], camera.eye), kind="stable")]
        waves = np.array_split(packets, max(1, -(-len(packets) // self.wave_size)))
        nodes, objects, found = np.zeros(0, np.int64), np.zeros(0, np.int64), []
        queries, round_ = 0, 0
        while len(nodes) or len(objects) or round_ < len(waves):
            if round_ < len(waves):  # the next-nearest packets join this round
                nodes = np.concatenate([nodes, waves[round_]])
            round_ += 1
            if found:
                # Objects found visible so far write depth: real meshes only, so later
                # queries stay conservative (module docstring) and cull much more.
                self._render(camera, np.concatenate(found))
            found = []
            # One batch per round: node boxes, then object boxes.
            batch_boxes = np.concatenate([boxes[nodes], self.scene.aabbs[objects]])
            batch = self.box_queries.issue(self.target, camera, batch_boxes)
            queries += batch.issued
            passed = batch.results()
            found.append(objects[passed[len(nodes) :]])
            hit = nodes[passed[: len(nodes)]]
            # Leaves and single-member nodes are resolved by their members' own boxes.
            resolve = bvh.is_leaf[hit] | (counts[hit] == 1)
            members = _selected_members(bvh, selected, hit[resolve])
            singles = np.repeat(counts[hit[resolve]] == 1, counts[hit[resolve]])
            found.append(members[singles])  # box == the member's AABB: already tested
            objects = members[~singles]
            inner = hit[~resolve]
            children = np.stack([bvh.left[inner], bvh.right[inner]], axis=1).ravel()
            nodes = children[counts[children] > 0]
            for f in found:
                visible[f] = True
        return visible, queries

    def _render(self, camera, ids: np.ndarray) -> None:
        """Draw the meshes of ``ids`` depth-only (LESS) into the depth target."""
        import moderngl

        program = self.glctx.program("mesh.vert", "depth_only.frag")
        self.target.fbo.use()
        self.target.fbo.depth_mask = True
        self.glctx.ctx.enable_only(moderngl.DEPTH_TEST)
        self.glctx.ctx.depth_func = "<"
        program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self.geometry.draw_objects(program, ids)


def _selected_members(bvh, selected: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Object ids of the selected members of ``nodes`` (K,), grouped by node in order."""
    if len(nodes) == 0:
        return np.zeros(0, np.int64)
    s, c = bvh.start[nodes], bvh.count[nodes]
    pos = np.repeat(s - np.cumsum(c) + c, c) + np.arange(c.sum())
    return bvh.order[pos[selected[pos]]]
