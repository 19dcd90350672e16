"""GPU hierarchical-z occlusion tests: a max-depth pyramid built by fragment shaders, and one
compute dispatch that tests many AABBs against the frustum and the pyramid.

Greene, Kass & Miller, "Hierarchical Z-buffer visibility" (SIGGRAPH 1993): a pyramid whose
texels hold the farthest depth of the pixels below them answers "is this box behind the
occluders?" with a few texel reads at the level where the box's screen rectangle spans about
one texel. As GPU culling (D. Rákos, "Hierarchical-Z map based occlusion culling", 2010;
A. Kapoulkine's niagara, ``drawcull.comp.glsl``) every box is tested by one shader invocation
and the whole answer is read back once: no per-object draw, query or GL call.

Stages, in the order a frame runs them:

1. :meth:`DepthPyramid.build` — level 0 is the occluder depth texture itself; level k+1 has
   ``ceil(size_k / 2)`` texels per axis and each texel is the max of its 2×2 texels of level k,
   with the odd last row/column clamped away (``hiz_reduce*.frag.glsl``, one full-viewport
   triangle a level, levels 2 and 3 in one pass; level 1 is not stored, the test reads it
   with one ``textureGather`` of level 0: llvmpipe writes render targets faster than
   SSBOs or images, and its cost is mostly per fragment; the small top levels in one pass
   from the first level of at most :data:`TOP_SOURCE_TEXELS` texels, each texel the max of
   its block of that level: a pass has a fixed cost on llvmpipe however small).
   By induction texel ``x`` of level k stands for exactly the level-0 columns
   ``[x·2^k, min((x+1)·2^k, W))`` (likewise rows), so the levels cover every pixel at every
   resolution, powers of two or not. Levels 2–3 are packed in one RGBA texture and levels
   >= 4 are rectangles right of them in the same texture (:func:`atlas_layout`), so the test
   shader can pick any level per box and read it with one gather of the depth (levels 0-1) or
   one fetch of that texture (levels 2..).
2. :meth:`HizTest.classify` — one invocation per candidate box (``hiz_test.comp.glsl``):
   outside the frustum (the p-vertex test of :mod:`soc.culling.frustum` on the grown box, with a
   slack
   for float32 rounding), else occluded or visible; results in a uint SSBO read back once
   after ``memory_barrier()``.

Why the test is conservative (an object the exact id render sees is never reported hidden):

* The object's mesh lies inside its AABB, and the tested box is that AABB grown by
  :func:`soc.gl.geometry.grown_aabbs`. When every corner has clip ``w >= near·(1 + margin)``
  (all corners in front of the near plane), the perspective map is a projective map that is
  finite on the whole box, so the image of the box is the convex hull of its 8 projected
  corners: every mesh point projects inside the corners' screen rectangle and has a window
  depth >= the smallest corner depth. Boxes with a corner closer than that are not tested but
  kept (a clipped box says nothing about what lies between the eye and its far faces).
* The oracle samples pixel centres ``((i + 0.5) / W, (j + 0.5) / H)``: a mesh sample at pixel
  ``(i, j)`` means the centre lies in the mesh's projection, hence in the rectangle. The test
  reads exactly the pixels whose centres lie in the rectangle widened by
  :data:`HIZ_PIXEL_MARGIN` (float rounding of the projection, llvmpipe's 1/256-pixel vertex
  snapping); a rectangle holding no pixel centre holds no sample, and the box is hidden.
* Fragment depth is interpolated linearly in screen space between vertices inside the box,
  so a visible sample has depth ``d`` with ``nearest corner depth <= d`` (up to float
  rounding, which the NDC depth bias ``QUERY_DEPTH_BIAS_NDC`` of the queries absorbs, as it
  absorbs the 24-bit quantisation of the depth buffer). Being visible, ``d`` is not behind
  the occluder depth at its pixel, which is <= the max over the pyramid texels covering the
  pixel range. So ``nearest - bias <= max`` whenever a sample is visible: the box is kept.
* Judged at another (display) resolution than the pyramid's (``display`` of
  :meth:`HizTest.classify`): the test reads the level-0 texels holding the display pixel
  centres inside the rectangle. That is conservative when every texel holds a depth >= the
  occluder depth at every point of its square, which the inner-conservative raster of
  :class:`soc.culling.depth_prepass.ConservativeOccluders` guarantees at any pair of resolutions.
* Refinement (``refine``) re-reads a box that is not occluded one level finer: those texels
  stand for the same pixels and each is <= the coarser texel holding it, so the answer only
  tightens, with the same argument.
"""

from __future__ import annotations

import numpy as np

from soc.constants import FRUSTUM_SLACK, NEAR_PLANE_MARGIN, QUERY_DEPTH_BIAS_NDC
from soc.culling.hiz_options import MAX_REFINE, check_test_options
from soc.gl.context import uses_gl
from soc.gl.geometry import grown_aabbs
from soc.gl.shader_defines import (
    BOX_OCCLUDED,
    BOX_OUTSIDE,
    BOX_VISIBLE,
    COMPUTE_GROUP,
    MAX_DISPLAYS,
    MAX_LEVELS,
    TEST_BOXES_BINDING,
    TEST_IDS_BINDING,
    TEST_RESULT_BINDING,
    WALK_HEADER,
    WALK_NODES,
    WALK_OBJECTS,
    WALK_OUTSIDE,
    WALK_RESULT_BINDING,
    WALK_VISITS,
)
from soc.scenes.camera import Camera, _resolution

# Pixels added on every side of a box's projected rectangle before choosing the pixel centres
# it may cover: float32 rounding of the corner projection is ~1e-4 px at 4K, llvmpipe snaps
# vertices to 1/256 px; 1/32 px covers both with room to spare and costs nothing measurable.
HIZ_PIXEL_MARGIN = 1.0 / 32.0


# Compute work-group size of hiz_test.comp (its ``local_size``), and the most work groups one
# test dispatches: beyond TEST_GROUP * TEST_GROUPS candidates each invocation
# tests several boxes (27,025 market boxes: 9.1 ms against 11.1 with one invocation per box,
# interleaved; starting an invocation of this shader costs llvmpipe about as much as a test).
TEST_GROUP = COMPUTE_GROUP  # boxes
TEST_GROUPS = 32

# Results of :meth:`HizTest.classify` (``MaskedOcclusionCulling``'s OCCLUDED / VISIBLE /
# VIEW_CULLED), as hiz_test.comp writes them.
OCCLUDED, VISIBLE, OUTSIDE = BOX_OCCLUDED, BOX_VISIBLE, BOX_OUTSIDE

# Relative allowance for float32 rounding in the shader's frustum-plane test (a few ulps of
# the magnitudes summed, 1.2e-7 each, with a wide margin): a box is reported outside only
# when it is outside by more than this and FRUSTUM_SLACK; nearer boxes go to the HiZ test.
PLANE_ROUNDING = 1e-5

# The pyramid's top levels are written in one pass from the first level with at most this many
# texels (level 5, 60×34, at 1080p), each texel reading its whole block of it: the top 1×1
# texel reads them all, about as long as the ~0.07 ms a pass of its own costs on llvmpipe.
TOP_SOURCE_TEXELS = 2048

# Texture units the shaders sample the depth texture, the quads and the atlas from.
_DEPTH_UNIT = 0
_QUADS_UNIT = 1
_ATLAS_UNIT = 2


def _displays(display, own: tuple[int, int]) -> list[tuple[int, int]]:
    """``display`` of :meth:`HizTest.classify` as exactly :data:`MAX_DISPLAYS` resolutions
    (padded with ``own``)."""
    if display is None:
        items: list = []
    elif len(display) == 2 and all(np.isscalar(v) for v in display):
        items = [display]
    else:
        items = list(display)
    if len(items) > MAX_DISPLAYS:
        raise ValueError(f"at most {MAX_DISPLAYS} display resolutions, got {display!r}")
    out = [_resolution(*d) for d in items]
    return out + [tuple(own)] * (MAX_DISPLAYS - len(out))


def pyramid_sizes(resolution: tuple[int, int]) -> list[tuple[int, int]]:
    """(width, height) of every level, level 0 = ``resolution``, halving with ceil to 1×1."""
    w, h = int(resolution[0]), int(resolution[1])
    sizes = [(w, h)]
    while (w, h) != (1, 1):
        w, h = (w + 1) // 2, (h + 1) // 2
        sizes.append((w, h))
    return sizes


def reference_pyramid(depth: np.ndarray) -> list[np.ndarray]:
    """The pyramid computed with numpy: level k texel = max over the level-0 texels it stands
    for (``[x·2^k, min((x+1)·2^k, W))`` per axis). ``depth`` is (H, W) float; for tests."""
    depth = np.asarray(depth, np.float32)
    h, w = depth.shape
    out = []
    for k, (lw, lh) in enumerate(pyramid_sizes((w, h))):
        s = 1 << k
        padded = np.full((lh * s, lw * s), -np.inf, np.float32)
        padded[:h, :w] = depth
        out.append(padded.reshape(lh, s, lw, s).max(axis=(1, 3)))
    return out


def atlas_layout(sizes: list[tuple[int, int]]) -> tuple[list[tuple[int, int]], tuple[int, int]]:
    """Corners of the levels 3.. of ``sizes`` (as :func:`pyramid_sizes`) in one 2D atlas, and
    its (width, height): level 3 at the origin, levels 4.. stacked upwards in the column to its
    right; levels 0–2 (not in the atlas) get ``(-1, -1)``. Levels never overlap."""
    corners = [(-1, -1)] * min(len(sizes), 3)
    if len(sizes) <= 3:
        return corners, (1, 1)
    x, y = sizes[3][0], 0
    corners.append((0, 0))
    for _w, h in sizes[4:]:
        corners.append((x, y))
        y += h
    width = x + (sizes[4][0] if len(sizes) > 4 else 0)
    return corners, (width, max(y, sizes[3][1]))


@uses_gl
class DepthPyramid:
    """Max-depth pyramid of a ``resolution = (W, H)`` depth texture, built on the GPU.

    Level 0 is the depth texture given to :meth:`build` (not copied); level 1 is not stored
    (the test gathers it from level 0). Levels 2 and 3 are packed in one RGBA32F texture
    (:attr:`quads`), level 3's size in level 3's rectangle of :func:`atlas_layout` (the
    origin): texel ``e`` holds the level-2 texels ``2e + (0, 0), (1, 0), (0, 1), (1, 1)`` and
    level-3 texel ``e`` is their max. Levels 4.. are disjoint rectangles of the same texture
    right of it (in ``.x``; :attr:`atlas` is :attr:`quads`), level k with its lower-left texel
    at :attr:`corners` ``[k]``. Level k has :attr:`sizes` ``[k]`` texels (row 0 is the bottom
    row, as in the depth texture), and each texel is >= every level-0 depth it stands for.
    Float32 window depths throughout.
    """

    def __init__(self, glctx, resolution: tuple[int, int]):
        import moderngl

        self.glctx = glctx
        self.resolution = (int(resolution[0]), int(resolution[1]))
        self.sizes = pyramid_sizes(self.resolution)
        if len(self.sizes) > MAX_LEVELS:
            raise ValueError(f"resolution {self.resolution} needs more than {MAX_LEVELS} levels")
        self.corners, atlas_size = atlas_layout(self.sizes)
        ctx = glctx.ctx
        # Level 3's size, also when the pyramid stops before it (its 1×1 quad then holds them).
        w1, h1 = self.sizes[min(1, len(self.sizes) - 1)]
        self.quads_size = (((w1 + 1) // 2 + 1) // 2, ((h1 + 1) // 2 + 1) // 2)
        # One RGBA32F texture: the quads in level 3's rectangle of the atlas, levels >= 4 in
        # .x of theirs: the test then reads levels 2.. with one fetch of one texture.
        size = (max(self.quads_size[0], atlas_size[0]), max(self.quads_size[1], atlas_size[1]))
        self.quads = self.atlas = ctx.texture(size, 4, dtype="f4")
        self.quads.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.quads_fbo = self.atlas_fbo = ctx.framebuffer(color_attachments=[self.quads])
        self.programs = [
            glctx.program("hiz_reduce.vert", f"{name}.frag")
            for name in ("hiz_reduce_depth", "hiz_reduce_quad", "hiz_reduce", "hiz_reduce_levels")
        ]
        self.vaos = [ctx.vertex_array(p, []) for p in self.programs]
        info = np.zeros((MAX_LEVELS, 4), np.int32)
        info[: len(self.sizes), 0:2] = self.corners
        info[: len(self.sizes), 2:4] = self.sizes
        self.level_info = info.tobytes()  # the shaders' ivec4 level_info[MAX_LEVELS]
        self.depth = None

    def __len__(self) -> int:
        return len(self.sizes)

    def release(self) -> None:
        for vao in self.vaos:
            vao.release()
        self.glctx.release_framebuffer(self.quads_fbo, self.quads)

    def bind(self, program) -> None:
        """Bind the depth texture, quads and atlas to the texture units of the samplers
        ``depth``, ``quads`` and ``atlas`` that ``program`` uses."""
        for name, texture, unit in (
            ("depth", self.depth, _DEPTH_UNIT),
            ("quads", self.quads, _QUADS_UNIT),
            ("atlas", self.atlas, _ATLAS_UNIT),
        ):
            if name in program:
                texture.use(location=unit)
                program[name].value = unit

    def build(self, depth_texture) -> None:
        """Reduce ``depth_texture`` (moderngl depth or R32F texture of :attr:`resolution`) into the
        levels 2..: one full-viewport triangle per level (levels 2 and 3 together), with a
        texture barrier between the atlas levels (the next one reads what this one wrote),
        until the level read has at most :data:`TOP_SOURCE_TEXELS` texels: the levels above
        it are then written at once, each texel the max of its block of that level.

        The texture's compare mode is switched off (the shaders need raw depths) and its
        wrap mode set to clamp-to-edge. Leaves the depth test off.
        """
        import moderngl

        if tuple(depth_texture.size) != self.resolution:
            raise ValueError(
                f"depth texture is {depth_texture.size}, the pyramid {self.resolution}"
            )
        if depth_texture.depth:  # an R32F texture has no compare mode
            depth_texture.compare_func = ""
        depth_texture.repeat_x = depth_texture.repeat_y = False  # textureGather clamps
        depth_texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.depth = depth_texture
        if len(self.sizes) == 1:
            return
        self.glctx.ctx.enable_only(moderngl.NOTHING)
        depth_prog, quad_prog, level_prog, top_prog = self.programs
        depth_vao, quad_vao, level_vao, top_vao = self.vaos

        fbo = self.quads_fbo
        fbo.viewport = fbo.scissor = (0, 0, *self.quads_size)  # levels 2 and 3
        fbo.use()
        self.bind(depth_prog)
        depth_vao.render(moderngl.TRIANGLES, vertices=3)
        for k in range(4, len(self.sizes)):
            self.glctx.raw.glTextureBarrier()  # level k-1 was rendered, now it is read
            w, h = self.sizes[k - 1]
            if k > 4 and w * h <= TOP_SOURCE_TEXELS:  # the rest at once from level k-1
                self.bind(top_prog)
                top_prog["src"].value = k - 1
                top_prog["first"].value = k
                top_prog["count"].value = len(self.sizes) - k
                top_prog["level_info"].write(self.level_info)
                x, y = self.corners[k]
                fbo.viewport = fbo.scissor = (x, y, self.sizes[k][0], self.atlas.size[1] - y)
                top_vao.render(moderngl.TRIANGLES, vertices=3)
                break
            prog, vao = (quad_prog, quad_vao) if k == 4 else (level_prog, level_vao)
            if k > 4:
                prog["src_offset"].value = self.corners[k - 1]
            prog["src_size"].value = self.sizes[k - 1]
            self.bind(prog)
            prog["dst_offset"].value = self.corners[k]
            fbo.viewport = fbo.scissor = (*self.corners[k], *self.sizes[k])
            vao.render(moderngl.TRIANGLES, vertices=3)
        fbo.scissor = None

    def level(self, k: int) -> np.ndarray:
        """(H_k, W_k) float32 copy of level ``k`` (level 0: the depth texture; level 1, not
        stored: computed from it with numpy); for tests."""
        w, h = self.sizes[k]
        if k == 0:
            return np.frombuffer(self.depth.read(), np.float32).reshape(h, w).copy()
        if k == 1:  # not stored: the test reads it with a textureGather of level 0
            return reference_pyramid(self.level(0))[1]
        tw, th = self.quads.size
        texels = np.frombuffer(self.quads.read(), np.float32).reshape(th, tw, 4)
        if k <= 3:
            qw, qh = self.quads_size
            q = texels[:qh, :qw].reshape(qh, qw, 2, 2)  # y, x, j, i
            if k == 3:
                return q.max(axis=(2, 3))[:h, :w].copy()
            return q.transpose(0, 2, 1, 3).reshape(2 * qh, 2 * qw)[:h, :w].copy()
        x, y = self.corners[k]
        return texels[y : y + h, x : x + w, 0].copy()


def set_frustum_uniforms(program, camera: Camera) -> None:
    """Set the uniforms that ``outside_frustum`` of ``hiz_test.common.glsl`` reads in
    ``program``: ``camera``'s planes and the slack of the test (none where the program does not
    read them: compiled without the frustum test)."""
    if "planes" not in program:
        return
    program["planes"].write(np.ascontiguousarray(camera.planes, np.float32).tobytes())
    program["plane_slack"].value = FRUSTUM_SLACK
    program["plane_rounding"].value = PLANE_ROUNDING


def set_test_uniforms(
    program, pyramid: DepthPyramid, camera: Camera, footprint: int, refine: int, display=None
) -> None:
    """Set the uniforms of ``hiz_test.common.glsl`` in ``program`` (a compute shader that
    includes it) and bind ``pyramid``'s textures: the box tests of that file then judge boxes
    from ``camera`` against ``pyramid`` (built for it) with ``footprint`` and ``refine`` (see
    :class:`HizTest`), at ``display`` resolutions besides the pyramid's own (see
    :meth:`HizTest.classify`)."""
    prog = program
    set_frustum_uniforms(prog, camera)
    prog["level_info"].write(pyramid.level_info)
    prog["levels"].value = len(pyramid)
    prog["size"].value = pyramid.resolution
    own = tuple(pyramid.resolution)
    others = [d for d in _displays(display, own) if tuple(d) != own]
    displays = others + [own] * (MAX_DISPLAYS - len(others))
    prog["displays"].write(np.array(displays, np.int32).tobytes())
    prog["display_count"].value = len(others)
    prog["view_proj"].write(camera.gl_bytes(camera.view_proj))
    prog["min_w"].value = camera.near * (1.0 + NEAR_PLANE_MARGIN)
    prog["depth_bias"].value = QUERY_DEPTH_BIAS_NDC
    prog["pixel_margin"].value = HIZ_PIXEL_MARGIN
    prog["footprint"].value = footprint
    prog["refine"].value = refine
    pyramid.bind(prog)


@uses_gl
class HizTest:
    """Test many world-space boxes against a :class:`DepthPyramid` in one compute dispatch.

    Parameters
    ----------
    glctx : GLContext
    footprint : int
        Texels per axis read at the chosen level, one of :data:`soc.culling.hiz_options.FOOTPRINTS`.
    refine : int
        Levels finer than its own a box that is not occluded at its level is judged at
        (clamped at level 0); 0 (default) is the classic single read. The shader descends
        depth first, only into texels the box is not behind, and stops at the first finest
        texel it is not behind: the answer of reading every texel ``refine`` levels finer,
        tighter (a finer level's maxima are no larger), never looser, equally conservative.
    """

    def __init__(self, glctx, footprint: int = 2, refine: int = 0):
        self.footprint, refine = check_test_options(footprint, refine)
        self.refine = min(refine, MAX_REFINE)  # the same reads: no pyramid is deeper
        self.glctx = glctx
        self.program = glctx.compute("hiz_test.comp")
        self._walk_program = None  # hiz_walk.comp, compiled on the first walk()
        self._walk_out = None  # counters + one bit per object of walk()
        self.last_walk: tuple[int, int, int] | None = None  # walk()'s nodes, node and box tests
        self._ids = None  # (K,) uint32 candidate ids, grown on demand
        self._out = None  # (K,) uint32 results
        self._boxes = None  # uploaded boxes of test_boxes()
        self._capacity = 0

    def release(self) -> None:
        for b in (self._ids, self._out, self._boxes, self._walk_out):
            if b is not None:
                b.release()
        self._ids = self._out = self._boxes = self._walk_out = None
        self._capacity = 0

    def _reserve(self, n: int) -> None:
        if n > self._capacity:
            for b in (self._ids, self._out):
                if b is not None:
                    b.release()
            self._capacity = max(n, 2 * self._capacity, 1024)
            self._ids = self.glctx.ctx.buffer(reserve=4 * self._capacity, dynamic=True)
            self._out = self.glctx.ctx.buffer(reserve=4 * self._capacity, dynamic=True)

    def classify(
        self,
        pyramid: DepthPyramid,
        camera: Camera,
        boxes,
        ids: np.ndarray,
        frustum: bool = True,
        display=None,
    ) -> np.ndarray:
        """Frustum and occlusion test of the boxes ``ids`` in one dispatch.

        Parameters
        ----------
        pyramid : DepthPyramid
            Built for this frame (same camera, any resolution).
        camera : Camera
            Its ``view_proj`` projects the boxes and gives the frustum planes; its own
            resolution is not used.
        boxes : moderngl.Buffer
            (N, 6) float32 world-space boxes ``lo, hi``, already grown by the conservative
            margin (e.g. ``SceneGeometry.boxes``).
        ids : (K,) int
            Rows of ``boxes`` to test.
        frustum : bool
            Report boxes entirely outside one frustum plane as :data:`OUTSIDE`.
        display : (int, int) or list of up to two of them, optional
            Resolutions (width, height) visibility is judged at, besides the pyramid's own
            (the default, alone). For a display other than its own the pyramid must hold, in
            each texel, a depth >= the occluder depth at every point inside it (as
            :class:`soc.culling.depth_prepass.ConservativeOccluders` writes); the test then reads
            the
            texels holding the pixel centres the box may cover at every one of these
            resolutions.

        Returns
        -------
        result : (K,) uint32
            :data:`OUTSIDE` (only with ``frustum``), else :data:`OCCLUDED` only where the box
            covers no pixel centre of the display resolution or lies behind the occluder
            depth at all of them (conservative, see the module), else :data:`VISIBLE`.
        """
        ids = np.ascontiguousarray(ids, np.uint32)
        k = len(ids)
        if k == 0:
            return np.zeros(0, np.uint32)
        self._reserve(k)
        self._ids.write(ids)
        prog = self.program
        set_test_uniforms(prog, pyramid, camera, self.footprint, self.refine, display)
        prog["frustum"].value = bool(frustum)
        prog["count"].value = k
        boxes.bind_to_storage_buffer(TEST_BOXES_BINDING)
        self._ids.bind_to_storage_buffer(TEST_IDS_BINDING)
        self._out.bind_to_storage_buffer(TEST_RESULT_BINDING)
        prog.run(min(-(-k // TEST_GROUP), TEST_GROUPS))
        self.glctx.ctx.memory_barrier()  # llvmpipe returns stale data without it
        return np.frombuffer(self._out.read(size=4 * k), np.uint32).copy()

    def test(
        self,
        pyramid: DepthPyramid,
        camera: Camera,
        boxes,
        ids: np.ndarray,
        display=None,
    ) -> np.ndarray:
        """Which of the boxes ``ids`` may be visible: (K,) bool, :meth:`classify` without the
        frustum test (False only for :data:`OCCLUDED`)."""
        codes = self.classify(pyramid, camera, boxes, ids, frustum=False, display=display)
        return codes == VISIBLE

    def test_boxes(
        self,
        pyramid: DepthPyramid,
        camera: Camera,
        boxes: np.ndarray,
        diagonal: float,
        display=None,
    ) -> np.ndarray:
        """Like :meth:`test` for arbitrary boxes (packets, nodes, cells).

        ``boxes`` (K, 2, 3) world units are grown by the conservative margin of a scene with
        this ``diagonal`` (world units), uploaded and tested; returns (K,) bool.
        """
        grown = grown_aabbs(np.asarray(boxes, np.float32).reshape(-1, 2, 3), diagonal)
        data = np.ascontiguousarray(grown.reshape(-1, 6))
        if self._boxes is None or self._boxes.size < max(data.nbytes, 24):
            if self._boxes is not None:
                self._boxes.release()
            self._boxes = self.glctx.ctx.buffer(reserve=max(data.nbytes, 24), dynamic=True)
        if len(data):
            self._boxes.write(data)
        return self.test(pyramid, camera, self._boxes, np.arange(len(data)), display)

    def walk(
        self,
        pyramid: DepthPyramid,
        camera: Camera,
        boxes,
        tree,
        frustum: bool = True,
        display=None,
        node_refine: int | None = None,
        mode: str = "levels",
        exact_outside: bool = True,
    ) -> tuple[np.ndarray, int, int]:
        """:meth:`classify` of every object by a walk of the object hierarchy in one dispatch
        (``hiz_walk.comp.glsl``): the same kept set and the same count outside the frustum,
        testing only the nodes and objects the walk reaches.

        Parameters
        ----------
        pyramid, camera, boxes, frustum, display
            As for :meth:`classify` (``boxes`` (N, 6): every object's grown box).
        tree : soc.culling.bvh_gpu.GpuHierarchy
            The hierarchy of the same boxes (:func:`soc.culling.bvh_gpu.gpu_hierarchy`).
        node_refine : int, optional
            Levels finer than its own a node box is judged at (at most :attr:`refine`;
            default :data:`soc.culling.bvh_gpu.NODE_REFINE`): any value gives the same
            result.
        mode : str
            How the dispatch walks (:data:`soc.culling.bvh_gpu.WALK_MODES`): level by level
            (default) or whole subtrees per invocation; the same result.
        exact_outside : bool
            Walk a hidden subtree that crosses the frustum on with frustum tests only, so that
            ``outside`` is exact (default); False drops it (``outside`` then counts only the
            objects outside the frustum that are not under a hidden node).

        Returns
        -------
        visible : (N,) bool
            Where :meth:`classify` gives :data:`VISIBLE` (objects of nodes emptied by
            :meth:`~soc.culling.bvh_gpu.GpuHierarchy.refit`: unspecified).
        outside : int
            Objects :meth:`classify` reports :data:`OUTSIDE` (with ``frustum``).
        tests : int
            Node and object boxes judged against the pyramid.
        """
        from soc.culling.bvh_gpu import NODE_REFINE

        n = len(tree.hierarchy.order)
        words = WALK_HEADER + (n + 31) // 32
        if self._walk_program is None:
            self._walk_program = self.glctx.compute("hiz_walk.comp")
        if self._walk_out is None or self._walk_out.size < 4 * words:
            if self._walk_out is not None:
                self._walk_out.release()
            self._walk_out = self.glctx.ctx.buffer(reserve=4 * words)
        out = self._walk_out
        out.clear(4 * words)
        prog = self._walk_program
        set_test_uniforms(prog, pyramid, camera, self.footprint, self.refine, display)
        prog["frustum"].value = bool(frustum)
        refine = NODE_REFINE if node_refine is None else int(node_refine)
        tree.bind(prog, min(refine, self.refine), exact_outside)
        boxes.bind_to_storage_buffer(TEST_BOXES_BINDING)
        out.bind_to_storage_buffer(WALK_RESULT_BINDING)
        tree.run(prog, mode, TEST_GROUPS)
        data = np.frombuffer(out.read(size=4 * words), np.uint32)
        bits = np.unpackbits(data[WALK_HEADER:].view(np.uint8), bitorder="little")
        # Nodes visited, node boxes judged, object boxes judged.
        self.last_walk = (int(data[WALK_VISITS]), int(data[WALK_NODES]), int(data[WALK_OBJECTS]))
        judged = int(data[WALK_NODES]) + int(data[WALK_OBJECTS])
        return bits[:n].astype(bool), int(data[WALK_OUTSIDE]), judged
