"""Top-down walks of an object hierarchy: frustum and occlusion tests that cost what is in
view, not what exists.

Hierarchical culling (Clark, "Hierarchical geometric models for visible surface algorithms",
CACM 1976): a bounding volume holding a whole subtree of objects is tested once, and its
subtree is dropped when the volume is outside the view frustum, accepted without per-object
frustum tests when it is wholly inside (Assarsson & Möller, "Optimized view frustum culling
algorithms for bounding boxes", JGT 2000), and dropped when it is hidden behind the occluder
depth (Greene, Kass & Miller's hierarchical z-buffer, SIGGRAPH 1993, tests octree nodes this
way; here the masked buffer of Hasselgren et al. 2016 too). The hierarchy is the scene's BVH
(:mod:`soc.culling.bvh`): a binary tree of tight boxes over contiguous ranges of object ids,
built once per scene and refitted to the objects alive in a dynamic scene.

Stages, top-down:

1. :class:`Hierarchy` — the BVH of a scene's AABBs with two boxes per node: the union of its
   objects' AABBs (frustum tests) and the union of their *grown* query boxes
   (:func:`soc.gl.geometry.grown_aabbs`; near-plane and depth tests), cached per scene
   (:meth:`Hierarchy.for_scene`); :meth:`Hierarchy.refit` restricts both to a mask.
2. Node tests (numba): :func:`node_frustum` (outside / inside / crossing),
   :func:`node_crosses_near` and :func:`node_rect` (a pixel rectangle and nearest depth that
   bound those of every box inside the node).
3. The walk (:func:`_walk`, numba, depth first with an explicit stack, on several threads
   over disjoint subtrees): per node, the frustum test unless an ancestor was inside; then,
   for the occlusion walks, the node's grown box against the depth — the HiZ pyramid
   (:func:`soc.culling.hiz_cpu._pyramid_test`) or the masked buffer
   (:func:`soc.culling.masked._test_rect`); at a leaf, the flat per-object tests.

**The walk gives the codes of the flat tests exactly** (``OCCLUDED``/``VISIBLE``/
``VIEW_CULLED`` of :func:`soc.culling.hiz_cpu.classify_objects` and
:meth:`soc.culling.masked.MaskedBuffer.classify_objects`, ``True``/``False`` of
:func:`soc.culling.frustum.aabbs_in_frustum`), object by object; ``tests/soc/test_hierarchy.py``
checks this on random scenes and cameras. Why: every node test decides only what the flat
test of every box inside the node would decide, with margins for float64 rounding —

* a node box contains its objects' boxes, and its frustum slack (relative to its size) is at
  least theirs, so a node outside a plane by more than its slack has every object outside;
  a node whose least-inside corner is inside every plane has every object inside;
* a node not crossing the near plane has no object crossing it; then every point of the node
  projects with ``w > 0``, so an object's pixel rectangle lies inside the node's (the image
  of a box is the convex hull of its corners' images) and its nearest depth, float32 error
  bound included, is no nearer than the node's (:func:`node_rect` bounds the error term of
  :func:`soc.culling.hiz_cpu.project_box` over the whole node);
* both depth tests are monotone: a rectangle inside a hidden rectangle, at a farther depth,
  is hidden (the pyramid: the object is judged at a level no coarser than the node, and a
  texel holds the max of the texels below it; the masked buffer: subtile by subtile).

So a hidden node's objects would all be ``OCCLUDED`` or ``VIEW_CULLED``; which of the two is
settled by a frustum-only walk of the hidden subtree (nodes wholly inside the frustum mark
their range at once). Conservativeness is therefore that of the flat tests.

The cost of a frame is the nodes the walk visits — those crossing the frustum's boundary or
in view and not hidden — plus their leaves' objects: with 1 % of a million random boxes in
view, a few thousand nodes (``make bench``'s scale section).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, replace

import numba
import numpy as np

from soc.constants import FRUSTUM_SLACK, NEAR_PLANE_MARGIN, QUERY_DEPTH_BIAS_NDC
from soc.culling.bvh import BVH, build
from soc.culling.frustum import outside_frustum
from soc.culling.hiz_cpu import (
    _U32,
    FLOAT32_TRANSFORM_ULPS,
    OCCLUDED,
    VIEW_CULLED,
    VISIBLE,
    WALK_STACK,
    _pyramid_test,
    crosses_near_plane,
    pixel_centres,
    project_box,
    project_corner,
)
from soc.culling.masked import _test_rect

# Objects per leaf (tested one by one after the leaf's box). Leaves of 2, 4 and 8 walked 12
# frames of the city's flight in the same time within this machine's noise (hiz-2phase's
# test, 6-10 CPU ms a frame under load, 2026-11-26); 4 has half the nodes of 2 and tests fewer
# objects one by one than 8.
LEAF_SIZE = 4

# Node test outcomes (:func:`node_frustum`).
OUTSIDE, INSIDE, CROSSING = 0, 1, 2

# What the walk tests besides the frustum.
TEST_NONE, TEST_PYRAMID, TEST_MASKED = 0, 1, 2

# Relative float64 rounding margin of the node tests (the sums they compare are computed to
# ~1e-15 of their magnitude; 1e-12 is ample and changes no decision a reader could see).
NODE_TOLERANCE = 1e-12

# Pyramid levels below its own that a node box is judged at, at most (objects: the caller's
# ``refine``). Any value gives the same codes (a node hidden at a coarser level hides its
# objects at theirs); fewer levels make node tests cheaper and prune a little later. On 8
# frames of the city's flight (hiz-2phase, footprint 4): walk CPU ms per frame 5.13 / 5.10 /
# 4.87 / 5.12 for 0 / 1 / 2 / 23 levels (node footprint 2, no levels: 6.07).
NODE_REFINE = 2

# Subtrees per thread in a parallel walk (each thread takes every ``threads``-th of them).
ROOTS_PER_THREAD = 16

# Stack entries of the depth-first numbering (:func:`_preorder`): one pending sibling per
# level of the tree (median splits: ~log2 N levels).
STACK = 256


@dataclass(frozen=True)
class WalkStats:
    """Work of one walk.

    Attributes
    ----------
    nodes : int
        Nodes visited (taken off the stack; empty nodes of a refitted tree included).
    node_tests : int
        Node boxes tested against the occluder depth.
    object_tests : int
        Object boxes tested against the occluder depth (the flat test's count for the same
        frame is every object in the frustum that does not cross the near plane).
    frustum_tests : int
        Object boxes frustum-tested one by one (in leaves crossing the frustum's boundary).
    """

    nodes: int
    node_tests: int
    object_tests: int
    frustum_tests: int

    @property
    def tests(self) -> int:
        """Boxes tested against the occluder depth, nodes and objects."""
        return self.node_tests + self.object_tests


@dataclass(frozen=True, eq=False)
class Hierarchy:
    """A scene's BVH laid out for walking, with the node boxes the walks test (module
    docstring).

    Nodes are stored in depth-first preorder with a *skip* index (the node after a node's
    subtree): a subtree is a contiguous range ``[i, skip[i])``, a node's left child is
    ``i + 1``, a leaf has ``skip[i] == i + 1``, and a walk is one forward loop that jumps to
    ``skip[i]`` to drop or accept a subtree (no stack; neighbouring nodes are neighbours in
    memory). Per-object boxes are kept in tree order too, so a leaf's objects are read in
    sequence.

    Attributes
    ----------
    tree : BVH
        The breadth-first BVH it was built from (:func:`soc.culling.bvh.build`).
    order : (N,) int64
        Object ids in tree order; node ``i`` holds ``order[start[i] : start[i] + size[i]]``.
    skip, start, size : (M,) int64
        Per node (depth-first ids): the node after its subtree, its range in ``order``.
    boxes, grown : (M, 2, 3) float32
        Per node, the union of its counted members' AABBs (frustum tests) and grown query
        boxes (near-plane and depth tests); min ``+inf`` / max ``-inf`` when it counts none.
    counts : (M,) int64
        Members counted per node (all, or those of :meth:`refit`'s mask); 0 = skipped.
    aabbs, query_boxes : (N, 2, 3) float32
        The objects' AABBs and grown query boxes (as
        :attr:`soc.gl.geometry.SceneGeometry.query_boxes`), by object id.
    tree_aabbs, tree_query_boxes : (N, 2, 3) float32
        The same in tree order (``aabbs[order]``).
    roots : (R,) int64
        Subtree roots of a parallel walk (depth-first ids): the nodes at depth
        ``log2(R)`` and the leaves above it.
    """

    tree: BVH
    order: np.ndarray
    skip: np.ndarray
    start: np.ndarray
    size: np.ndarray
    boxes: np.ndarray
    grown: np.ndarray
    counts: np.ndarray
    aabbs: np.ndarray
    query_boxes: np.ndarray
    tree_aabbs: np.ndarray
    tree_query_boxes: np.ndarray
    roots: np.ndarray

    def __len__(self) -> int:
        return len(self.skip)

    @classmethod
    def build(
        cls, aabbs: np.ndarray, query_boxes: np.ndarray, leaf_size: int = LEAF_SIZE
    ) -> Hierarchy:
        """The hierarchy of ``aabbs`` and ``query_boxes``, both (N, 2, 3) float32 (each
        query box containing its AABB), with leaves of at most ``leaf_size`` objects."""
        aabbs = np.asarray(aabbs, np.float32)
        query_boxes = np.asarray(query_boxes, np.float32)
        if aabbs.shape != query_boxes.shape:
            raise ValueError(
                f"aabbs {aabbs.shape} and query boxes {query_boxes.shape} must have one shape"
            )
        tree = build(aabbs, leaf_size)
        m = len(tree)
        dfs = np.empty(m, np.int64)  # depth-first id -> breadth-first id
        skip = np.empty(m, np.int64)
        _preorder(tree.left, dfs, skip)
        order = tree.order
        h = cls(
            tree=tree,
            order=order,
            skip=skip,
            start=np.ascontiguousarray(tree.start[dfs]),
            size=np.ascontiguousarray(tree.count[dfs]),
            boxes=np.empty((m, 2, 3), np.float32),
            grown=np.empty((m, 2, 3), np.float32),
            counts=np.empty(m, np.int64),
            aabbs=aabbs,
            query_boxes=query_boxes,
            tree_aabbs=np.ascontiguousarray(aabbs[order]),
            tree_query_boxes=np.ascontiguousarray(query_boxes[order]),
            roots=_roots(tree.depth[dfs], skip),
        )
        _refit(h.skip, h.start, h.size, h.order, h.tree_aabbs, h.tree_query_boxes, _ALL,
               h.boxes, h.grown, h.counts)  # fmt: skip
        for a in (h.skip, h.start, h.size, h.boxes, h.grown, h.counts, h.tree_aabbs,
                  h.tree_query_boxes, h.roots):  # fmt: skip
            a.flags.writeable = False
        return h

    @classmethod
    def for_scene(cls, scene) -> Hierarchy:
        """The hierarchy of ``scene`` (its AABBs and the query boxes that
        :class:`soc.gl.geometry.SceneGeometry` grows from them), built on first use and
        cached for as long as the scene lives."""
        h = _CACHE.get(scene)
        if h is None:
            from soc.gl.geometry import grown_aabbs

            h = cls.build(scene.aabbs, grown_aabbs(scene.aabbs, scene.diagonal))
            _CACHE[scene] = h
        return h

    def refit(self, mask: np.ndarray | None) -> Hierarchy:
        """The same tree with node boxes and counts over the objects where ``mask`` (N,) bool
        is True (the objects alive in a dynamic scene); None: every object. Walks skip empty
        nodes, so the codes of objects outside the mask are then unspecified: callers ``&``
        them with the mask, as the flat path's callers do. One pass over objects and nodes."""
        sel = _ALL
        if mask is not None:
            mask = np.asarray(mask)
            if mask.shape != self.order.shape or mask.dtype != bool:
                raise ValueError(
                    f"mask must be {self.order.shape} bool, got {mask.shape} {mask.dtype}"
                )
            sel = np.ascontiguousarray(mask[self.order])
        m = len(self)
        boxes, grown = np.empty((m, 2, 3), np.float32), np.empty((m, 2, 3), np.float32)
        counts = np.empty(m, np.int64)
        _refit(self.skip, self.start, self.size, self.order, self.tree_aabbs,
               self.tree_query_boxes, sel, boxes, grown, counts)  # fmt: skip
        for a in (boxes, grown, counts):
            a.flags.writeable = False
        return replace(self, boxes=boxes, grown=grown, counts=counts)

    # -- the walks ---------------------------------------------------------------------------

    def in_frustum(self, planes, threads: int = 1) -> tuple[np.ndarray, WalkStats]:
        """Which objects may intersect the frustum: the result of
        :func:`soc.culling.frustum.aabbs_in_frustum` on :attr:`aabbs`, object by object.

        Parameters
        ----------
        planes : (6, 4) float or Camera
            Inward unit-normal planes (:attr:`soc.Camera.planes`).
        threads : int
            numba threads sharing the subtrees (the result does not depend on it).

        Returns
        -------
        inside : (N,) bool
        stats : WalkStats
        """
        p = getattr(planes, "planes", planes)
        p = np.ascontiguousarray(p, np.float64)
        if p.shape != (6, 4):
            raise ValueError(f"planes must have shape (6, 4), got {p.shape}")
        out = np.zeros(len(self.aabbs), np.uint8)  # 0 = outside; the walk writes VISIBLE = 1
        stats = self._run(out, p, True, TEST_NONE, _NO_CAMERA, _NO_PYRAMID, _NO_MASKED, threads)
        return out.view(np.bool_), stats

    def classify_pyramid(
        self,
        pyramid,
        camera,
        frustum: bool = True,
        threads: int = 1,
        footprint: int = 2,
        refine: int = 0,
    ) -> tuple[np.ndarray, WalkStats]:
        """:func:`soc.culling.hiz_cpu.classify_objects` of every object, by the walk.

        Parameters
        ----------
        pyramid : soc.culling.hiz_cpu.Pyramid
            Of the frame's conservative occluder depth.
        camera : Camera
        frustum : bool
            Test the frustum (False: every object is tested against the depth).
        threads : int
            numba threads sharing the subtrees (the codes do not depend on it).
        footprint, refine : int
            How a box is read from the pyramid (:func:`soc.culling.hiz_cpu.boxes_visible`).

        Returns
        -------
        codes : (N,) uint8
            ``VIEW_CULLED``, ``VISIBLE`` or ``OCCLUDED``, as the flat test gives them.
        stats : WalkStats
        """
        from soc.culling.hiz_options import check_test_options

        footprint, refine = check_test_options(footprint, refine)
        depth = (
            pyramid.flat, pyramid.offsets, pyramid.widths, int(pyramid.levels), footprint, refine
        )  # fmt: skip
        width, height = int(pyramid.widths[0]), int(pyramid.heights[0])
        out = np.full(len(self.aabbs), VIEW_CULLED, np.uint8)
        stats = self._run(
            out, np.ascontiguousarray(camera.planes, np.float64), frustum, TEST_PYRAMID,
            _camera_args(camera, width, height), depth, _NO_MASKED, threads,
        )  # fmt: skip
        return out, stats

    def classify_masked(
        self, buffer, camera, frustum: bool = True, threads: int = 1
    ) -> tuple[np.ndarray, WalkStats]:
        """:meth:`soc.culling.masked.MaskedBuffer.classify_objects` of every object against
        ``buffer`` (a :class:`~soc.culling.masked.MaskedBuffer` after ``render``), by the
        walk; returns the codes (N,) uint8 and the walk's :class:`WalkStats`."""
        width, height = buffer.resolution
        out = np.full(len(self.aabbs), VIEW_CULLED, np.uint8)
        stats = self._run(
            out, np.ascontiguousarray(camera.planes, np.float64), frustum, TEST_MASKED,
            _camera_args(camera, width, height), _NO_PYRAMID,
            (buffer.mask, buffer.z0, buffer.z1), threads,
        )  # fmt: skip
        return out, stats

    def _run(self, out, planes, frustum, kind, cam, depth, masked, threads) -> WalkStats:
        forward, eye_depth, min_depth, m, width, height = cam
        flat, offsets, widths, levels, footprint, refine = depth
        node_refine = min(refine, NODE_REFINE)
        mask, z0, z1 = masked
        args = (
            self.skip, self.start, self.size, self.order, self.boxes, self.grown, self.counts,
            self.tree_aabbs, self.tree_query_boxes, planes, bool(frustum), kind, forward,
            eye_depth, min_depth, m, width, height, flat, offsets, widths, levels, footprint,
            refine, node_refine, mask, z0, z1, out,
        )  # fmt: skip
        if threads <= 1 or len(self.roots) == 1:
            stats = _walk(*args, _ROOT, 0, 1)
        else:
            stats = _walk_parallel(*args, self.roots, int(threads))
        return WalkStats(*(int(s) for s in stats))


_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_ROOT = np.zeros(1, np.int64)
_ALL = np.zeros(0, np.bool_)  # an empty mask: every object counts
# Placeholders of the arguments a walk without that test does not read.
_NO_CAMERA = (np.zeros(3), 0.0, 1.0, np.eye(4), 1, 1)
_NO_PYRAMID = (np.ones(1, np.float32), np.zeros(1, np.int64), np.ones(1, np.int64), 1, 2, 0)
_NO_MASKED = (np.zeros((1, 1, 8), np.uint32), np.ones((1, 1, 8)), np.zeros((1, 1, 8)))


def _camera_args(camera, width: int, height: int) -> tuple:
    """(forward, eye depth, near-plane test depth, view-projection, width, height), as
    :func:`soc.culling.hiz_cpu.classify_objects` derives them from ``camera``."""
    forward = -np.asarray(camera.view, np.float64)[2, :3]
    return (
        np.ascontiguousarray(forward),
        float(forward @ np.asarray(camera.eye, np.float64)),
        camera.near * (1.0 + NEAR_PLANE_MARGIN),
        np.ascontiguousarray(camera.view_proj, np.float64),
        int(width),
        int(height),
    )


def _roots(depth: np.ndarray, skip: np.ndarray, threads_hint: int = 8) -> np.ndarray:
    """Subtree roots for parallel walks (depth-first ids, in order): the nodes at depth ``d``
    (``2**d`` about :data:`ROOTS_PER_THREAD` times ``threads_hint``) and the leaves above."""
    d = max(0, math.ceil(math.log2(ROOTS_PER_THREAD * threads_hint)))
    leaf = skip == np.arange(1, len(skip) + 1)
    return np.flatnonzero((depth == d) | ((depth < d) & leaf)).astype(np.int64)


@numba.njit(cache=True)
def _preorder(left, dfs, skip):  # pragma: no cover - compiled
    """Depth-first preorder of a breadth-first tree (``left``; right = left + 1): ``dfs[i]``
    is the breadth-first id of depth-first node ``i``, ``skip[i]`` the depth-first id after
    its subtree."""
    size = np.ones(len(left), np.int64)  # subtree sizes, from the leaves up
    for node in range(len(left) - 1, -1, -1):
        if left[node] >= 0:
            size[node] = 1 + size[left[node]] + size[left[node] + 1]
    stack = np.empty(STACK, np.int64)
    stack[0] = 0
    top, i = 1, 0
    while top > 0:
        top -= 1
        node = stack[top]
        dfs[i], skip[i] = node, i + size[node]
        i += 1
        if left[node] >= 0:
            stack[top] = left[node] + 1
            stack[top + 1] = left[node]
            top += 2


@numba.njit(cache=True)
def _refit(
    skip, start, size, order, tree_aabbs, tree_qboxes, sel, boxes, grown, counts
):  # pragma: no cover - compiled
    """Union boxes (AABBs and query boxes) and counted members of every depth-first node from
    the leaves up; ``sel`` (N,) bool in tree order selects the members that count (empty:
    all). A node counting none gets min = +inf, max = -inf."""
    use_sel = len(sel) > 0
    for i in range(len(skip) - 1, -1, -1):
        for t in range(2):
            src = tree_aabbs if t == 0 else tree_qboxes
            dst = boxes if t == 0 else grown
            for a in range(3):
                dst[i, 0, a] = np.inf
                dst[i, 1, a] = -np.inf
            if skip[i] == i + 1:  # a leaf: its members
                k = 0
                for j in range(start[i], start[i] + size[i]):
                    if use_sel and not sel[j]:
                        continue
                    k += 1
                    for a in range(3):
                        dst[i, 0, a] = min(dst[i, 0, a], src[j, 0, a])
                        dst[i, 1, a] = max(dst[i, 1, a], src[j, 1, a])
                counts[i] = k
            else:  # its two children: i + 1 and the node after the left child's subtree
                lc, rc = i + 1, skip[i + 1]
                for a in range(3):
                    dst[i, 0, a] = min(dst[lc, 0, a], dst[rc, 0, a])
                    dst[i, 1, a] = max(dst[lc, 1, a], dst[rc, 1, a])
                counts[i] = counts[lc] + counts[rc]


# -- node tests ------------------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def node_frustum(box, planes):  # pragma: no cover - compiled
    """:data:`OUTSIDE`, :data:`INSIDE` or :data:`CROSSING` for a node box (2, 3) and the
    planes (6, 4) float64. OUTSIDE only when :func:`soc.culling.frustum.outside_frustum` is
    True for every box inside it; INSIDE only when it is False for every such box."""
    hx = 0.5 * (np.float64(box[1, 0]) - np.float64(box[0, 0]))
    hy = 0.5 * (np.float64(box[1, 1]) - np.float64(box[0, 1]))
    hz = 0.5 * (np.float64(box[1, 2]) - np.float64(box[0, 2]))
    cx = 0.5 * (np.float64(box[0, 0]) + np.float64(box[1, 0]))
    cy = 0.5 * (np.float64(box[0, 1]) + np.float64(box[1, 1]))
    cz = 0.5 * (np.float64(box[0, 2]) + np.float64(box[1, 2]))
    # A box inside has a smaller half-diagonal, so a smaller slack (outside_frustum's).
    slack = FRUSTUM_SLACK * (1.0 + math.sqrt(hx * hx + hy * hy + hz * hz))
    inside = True
    for p in range(6):
        nx, ny, nz, d = planes[p, 0], planes[p, 1], planes[p, 2], planes[p, 3]
        centre = cx * nx + cy * ny + cz * nz + d
        extent = hx * abs(nx) + hy * abs(ny) + hz * abs(nz)
        tol = NODE_TOLERANCE * (1.0 + abs(cx * nx) + abs(cy * ny) + abs(cz * nz) + abs(d) + extent)
        if centre + extent < -slack - tol:
            return OUTSIDE  # the most-inside corner is outside: so is every box inside
        if centre - extent < tol:
            inside = False  # the least-inside corner is not surely inside
    return INSIDE if inside else CROSSING


@numba.njit(cache=True, inline="always")
def node_crosses_near(box, forward, eye_depth, min_depth):  # pragma: no cover - compiled
    """True unless no box inside ``box`` (2, 3) crosses the near plane in
    :func:`soc.culling.hiz_cpu.crosses_near_plane`'s sense (a rounding margin added)."""
    nearest = 0.0
    size = abs(eye_depth) + abs(min_depth)
    for i in range(3):
        c = 0.5 * (np.float64(box[0, i]) + np.float64(box[1, i]))
        h = 0.5 * (np.float64(box[1, i]) - np.float64(box[0, i]))
        nearest += c * forward[i] - h * abs(forward[i])
        size += abs(c * forward[i]) + h * abs(forward[i])
    return nearest - eye_depth < min_depth + NODE_TOLERANCE * (1.0 + size)


@numba.njit(cache=True, inline="always")
def node_rect(box, m, am, width, height):  # pragma: no cover - compiled
    """``x0, y0, x1, y1, z_near`` of a node box (2, 3) wholly in front of the near plane
    (:func:`node_crosses_near` False): a pixel-centre rectangle containing, and a nearest
    depth no farther than, :func:`soc.culling.hiz_cpu.project_box`'s for every box inside it.

    The corners' window positions bound every inner point's (``w > 0`` over the box); the
    float32 error term that ``project_box`` subtracts per corner (``0.5 err / w``, ``err``
    growing with the point's magnitude and ``|nz|``) is bounded over the box by the largest
    magnitude, ``|nz|`` and ``1 / w`` of its corners; a relative margin covers float64
    rounding.
    """
    xlo, ylo, zlo = np.inf, np.inf, np.inf
    xhi, yhi = -np.inf, -np.inf
    nz_max, inv_max = 0.0, 0.0
    for corner in range(8):
        _, _, _, x, y, nz, inv = project_corner(box, m, corner, width, height)
        xlo, xhi = min(xlo, x), max(xhi, x)
        ylo, yhi = min(ylo, y), max(yhi, y)
        zlo = min(zlo, 0.5 * (nz + 1.0))
        nz_max = max(nz_max, abs(nz))
        inv_max = max(inv_max, inv)
    mag = am[2, 3] + am[3, 3]
    mag_x = am[0, 3] + am[3, 3]
    mag_y = am[1, 3] + am[3, 3]
    for i in range(3):
        a = max(abs(np.float64(box[0, i])), abs(np.float64(box[1, i])))
        mag += (am[2, i] + am[3, i]) * a
        mag_x += (am[0, i] + am[3, i]) * a
        mag_y += (am[1, i] + am[3, i]) * a
    pull = 0.5 * FLOAT32_TRANSFORM_ULPS * _U32 * mag * (1.0 + nz_max) * inv_max
    zlo -= pull + NODE_TOLERANCE * (1.0 + mag * inv_max)
    tx = NODE_TOLERANCE * (1.0 + width * mag_x * inv_max)
    ty = NODE_TOLERANCE * (1.0 + height * mag_y * inv_max)
    xlo, xhi, ylo, yhi = xlo - tx, xhi + tx, ylo - ty, yhi + ty
    x0, y0, x1, y1 = pixel_centres(xlo, ylo, xhi, yhi, width, height)  # as project_box
    return x0, y0, x1, y1, zlo - 0.5 * QUERY_DEPTH_BIAS_NDC


@numba.njit(cache=True, inline="always")
def _rect_visible(
    x0, y0, x1, y1, zn, kind, flat, offsets, widths, levels, footprint, refine, mask, z0, z1,
    stack,
):  # pragma: no cover - compiled  # fmt: skip
    """The depth test of one rectangle: the pyramid's or the masked buffer's."""
    if kind == TEST_PYRAMID:
        return _pyramid_test(
            x0, y0, x1, y1, zn, flat, offsets, widths, levels, footprint, refine, stack
        )
    return _test_rect(x0, y0, x1, y1, zn, mask, z0, z1) == VISIBLE


@numba.njit(cache=True, inline="always")
def _mark(out, order, start, count, code):  # pragma: no cover - compiled
    """Give every member of a node's range the same code."""
    for i in range(start, start + count):
        out[order[i]] = code


# -- the walk --------------------------------------------------------------------------------


@numba.njit(cache=True)
def _walk(
    skip, start, size, order, boxes, grown, counts, aabbs, qboxes, planes, frustum, kind,
    forward, eye_depth, min_depth, m, width, height, flat, offsets, widths, levels, footprint,
    refine, node_refine, mask, z0, z1, out, roots, band, bands,
):  # pragma: no cover - compiled  # fmt: skip
    """Walk the subtrees ``roots[band::bands]`` in depth-first order, writing the codes of
    their objects into ``out`` (by object id; prefilled with the code of objects outside the
    frustum); ``aabbs`` and ``qboxes`` are in tree order. Returns the counters of
    :class:`WalkStats`. A subtree is the range ``[i, skip[i])``, so what an ancestor decided
    holds while ``i`` is below a bound: ``inside_until`` (an ancestor wholly inside the
    frustum: no more frustum tests) and ``hidden_until`` (an ancestor hidden by the depth:
    only the frustum remains to tell OCCLUDED from VIEW_CULLED)."""
    am = np.abs(m)
    walk_stack = np.empty((WALK_STACK, 3), np.int64)
    nodes = node_tests = object_tests = frustum_tests = 0
    for r in range(band, len(roots), bands):
        i, end = roots[r], skip[roots[r]]
        inside_until = end if not frustum else i
        hidden_until = i
        while i < end:
            nodes += 1
            after = skip[i]
            if counts[i] == 0:
                i = after
                continue
            inside = i < inside_until
            hidden = i < hidden_until
            if not inside:
                f = node_frustum(boxes[i], planes)
                if f == OUTSIDE:
                    i = after
                    continue
                if f == INSIDE:
                    inside, inside_until = True, after
            s, c = start[i], size[i]
            if hidden:
                if inside:
                    _mark(out, order, s, c, OCCLUDED)
                    i = after
                    continue
            elif kind == TEST_NONE:
                if inside:
                    _mark(out, order, s, c, VISIBLE)
                    i = after
                    continue
            elif c > 1 and not node_crosses_near(grown[i], forward, eye_depth, min_depth):
                x0, y0, x1, y1, zn = node_rect(grown[i], m, am, width, height)
                node_tests += 1
                if not _rect_visible(
                    x0, y0, x1, y1, zn, kind, flat, offsets, widths, levels, footprint,
                    node_refine, mask, z0, z1, walk_stack,
                ):  # fmt: skip
                    if inside:
                        _mark(out, order, s, c, OCCLUDED)
                        i = after
                        continue
                    hidden, hidden_until = True, after
            if after != i + 1:  # an inner node: on to its left child
                i += 1
                continue
            # A leaf: the flat tests of its objects.
            for j in range(s, s + c):
                if not inside:
                    frustum_tests += 1
                    if outside_frustum(aabbs[j], planes):
                        continue
                if hidden:
                    out[order[j]] = OCCLUDED
                elif kind == TEST_NONE or crosses_near_plane(
                    qboxes[j], forward, eye_depth, min_depth
                ):
                    out[order[j]] = VISIBLE
                else:
                    x0, y0, x1, y1, zn = project_box(qboxes[j], m, am, width, height)
                    object_tests += 1
                    visible = _rect_visible(
                        x0, y0, x1, y1, zn, kind, flat, offsets, widths, levels, footprint,
                        refine, mask, z0, z1, walk_stack,
                    )  # fmt: skip
                    out[order[j]] = VISIBLE if visible else OCCLUDED
            i = after
    stats = np.empty(4, np.int64)
    stats[0], stats[1], stats[2], stats[3] = nodes, node_tests, object_tests, frustum_tests
    return stats


@numba.njit(cache=True, parallel=True)
def _walk_parallel(
    skip, start, size, order, boxes, grown, counts, aabbs, qboxes, planes, frustum, kind,
    forward, eye_depth, min_depth, m, width, height, flat, offsets, widths, levels, footprint,
    refine, node_refine, mask, z0, z1, out, roots, bands,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_walk` with the subtrees dealt to ``bands`` numba threads (the subtrees hold
    disjoint objects, so the codes are those of one walk)."""
    per_band = np.zeros((bands, 4), np.int64)
    for band in numba.prange(bands):
        per_band[band] = _walk(
            skip, start, size, order, boxes, grown, counts, aabbs, qboxes, planes, frustum,
            kind, forward, eye_depth, min_depth, m, width, height, flat, offsets, widths,
            levels, footprint, refine, node_refine, mask, z0, z1, out, roots, band, bands,
        )  # fmt: skip
    return per_band.sum(axis=0)
