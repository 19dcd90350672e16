"""The numbers GLSL and Python share — storage-buffer binding points, work-group sizes, the
layout of the buffers both sides read — in one place: every shader is compiled with each of
them as a ``#define`` (:func:`soc.gl.context.shader_source` puts them after the ``#version``
line), and the Python that binds, sizes and reads the buffers imports them from here. A shader
names them (``layout(std430, binding = FRAME_BINDING)``); none is written twice
(``tests/soc/test_shader_defines.py`` checks the shaders hold no binding number or size of
their own).

Every module-level ``int`` whose name is in capitals is a define (:func:`defines`).
"""

from __future__ import annotations

import sys

# -- compute work groups -------------------------------------------------------------------------
# Invocations per work group (``local_size_x``) of the box tests and the walks: hiz_test.comp,
# hiz_walk.comp, gpu_driven*.comp (8 of llvmpipe's SIMD lanes, 1-2 warps of a GPU).
COMPUTE_GROUP = 64

# -- hiz_test.comp and hiz_walk.comp (soc/culling/hiz_gpu.py) ------------------------------------
TEST_BOXES_BINDING = 0  # (N, 6) float32 grown boxes, lo then hi
TEST_IDS_BINDING = 1  # hiz_test: (K,) uint32 the boxes to test
TEST_RESULT_BINDING = 2  # hiz_test: (K,) uint32 codes
WALK_RESULT_BINDING = 1  # hiz_walk: the counters (WALK_HEADER words), then a bit per object
# hiz_walk.comp's counters at the start of its result.
WALK_OUTSIDE = 0  # objects outside the frustum
WALK_NODES = 1  # node boxes judged
WALK_OBJECTS = 2  # object boxes judged
WALK_VISITS = 3  # nodes visited
WALK_HEADER = 4
# hiz_test.comp's code per box (soc.culling.hiz_gpu's OCCLUDED / VISIBLE / OUTSIDE).
BOX_OCCLUDED = 0
BOX_VISIBLE = 1
BOX_OUTSIDE = 2  # entirely outside one frustum plane
# Pyramid levels in the uniform ``level_info[MAX_LEVELS]`` of the test and reduce shaders (24
# levels reach 2^23 px), and display resolutions one box test judges at besides the pyramid's
# own (``displays[MAX_DISPLAYS]``).
MAX_LEVELS = 24
MAX_DISPLAYS = 2

# -- bvh_walk.common.glsl (soc/culling/bvh_gpu.py) -----------------------------------------------
WALK_NODES_BINDING = 8  # (M, 4) uint32 per node: skip, start, size, counted
WALK_BOXES_BINDING = 9  # (M, 6) float32 node boxes
WALK_ORDER_BINDING = 10  # (N,) uint32 object ids in tree order
WALK_ROOTS_BINDING = 11  # (R,) uint32 the cut's subtree roots
WALK_QUEUE_BINDING = 12  # the level walk's queue
# The level walk's queue: its first QUEUE_HEADER words count the entries each level appended
# (from word 0) and hold each level's indirect dispatch (x, 1, 1) from word QUEUE_ARGS.
QUEUE_ARGS = 64
QUEUE_HEADER = 256

# -- gpu_driven*.glsl (soc/methods/gpu_driven.py) ------------------------------------------------
OBJECTS_BINDING = 0  # (N, 4) uint32 per object: first cluster, clusters, base vertex, 0
OBJECT_BOXES_BINDING = 1  # (N, 6) float32 grown object boxes
CLUSTERS_BINDING = 2  # (C, 4) uint32 per cluster: first index, index count, object, 0
CLUSTER_BOXES_BINDING = 3  # (C, 6) float32 grown cluster boxes
OBJECT_STATE_BINDING = 4  # (2N,) uint32: frame last drawn early, runs that passed
CLUSTER_STATE_BINDING = 5  # (C,) uint32 per cluster: passed, to be drawn late
COMMANDS_BINDING = 6  # (2, C, 5) uint32 the passes' draw commands, as appended
FRAME_BINDING = 7  # the frame's counters, then the drawn objects' and clusters' bits
PASSED_BINDING = 13  # the passed lists and the split lists (8-12: the walk's)
RUNS_BINDING = 14  # (C, 4) uint32 the runs of clusters that passed
SORTED_BINDING = 15  # (2, C, 5) uint32 the commands drawn, nearest first
# The passes, as the counters and commands index them.
EARLY_PASS = 0
LATE_PASS = 1
# Depth buckets of the draw order, log-spaced from the near plane to the far plane: about 4-5
# a doubling of the distance at near/far = 10^4.
ORDER_BUCKETS = 64
# Counters at the start of the frame buffer: per pass the commands written and the triangles
# drawn, the objects outside the frustum, the boxes judged; then per pass the commands of each
# depth bucket (FRAME_BUCKETS) and the order pass's cursors (FRAME_CURSORS); then the bits.
FRAME_COMMANDS = 0  # + pass
FRAME_TRIANGLES = 2  # + pass
FRAME_OUTSIDE = 4
FRAME_JUDGED = 5
FRAME_CLUSTERS = 6  # + pass: clusters drawn
FRAME_BUCKETS = 8
FRAME_CURSORS = FRAME_BUCKETS + 2 * ORDER_BUCKETS
FRAME_HEADER = FRAME_CURSORS + 2 * ORDER_BUCKETS

# -- the rendering techniques' passes (soc/rendering) ---------------------------------------------
# Invocations per side of the square work groups (``local_size_x`` = ``local_size_y``) of the
# per-pixel compute passes: composite_z.comp, warp_scatter.comp, warp_resolve.comp.
PIXEL_GROUP = 8
# composite_z.comp (compositing.py): the accumulated image's units.
ACC_COLOR_IMAGE = 0  # rgba8
ACC_DEPTH_IMAGE = 1  # r32f window depth
ACC_IDS_IMAGE = 2  # r32ui object ids
# warp_*.glsl (warping.py).
MODELS_BINDING = 0  # warp_gbuffer.vert: (N,) mat4 world <- object
WARPS_BINDING = 0  # warp_map.common: mat4 the static warp, the background's, each moved object's
WARP_ROWS_BINDING = 3  # warp_map.common: (N,) uint32 each object's row of the warps
SPLATS_BINDING = 4  # warp_scatter: (H * W, 3) uint32 per source pixel its footprint and depth
NEAREST_BINDING = 1  # warp_scatter/resolve: (H * W,) uint32 nearest depth bits per pixel
WINNER_BINDING = 2  # warp_scatter/resolve: (H * W,) uint32 winning source pixel, y << 16 | x
OUT_COLOR_IMAGE = 0  # warp_resolve: rgba8 target colour
OUT_IDS_IMAGE = 1  # warp_resolve: r32ui target object ids
OUT_DEPTH_IMAGE = 2  # warp_resolve: r32f target window depth
# warp_map.common: the rows of the warps every static object and the background use.
STATIC_WARP_ROW = 0
BACKGROUND_WARP_ROW = 1
# forward_lighting.common, gbuffer_fill and deferred_*.glsl (shading.py).
LIGHTS_BINDING = 0  # (L,) lights, two vec4 each
MATERIAL_COUNT = 8  # material id = object id mod MATERIAL_COUNT
SKY_MATERIAL = 0xFFFF  # material id of g-buffer pixels where nothing was drawn (R16UI)


def defines() -> dict[str, int]:
    """Every define, by name: the module's ``int`` constants named in capitals."""
    return {
        k: v
        for k, v in vars(sys.modules[__name__]).items()
        if k.isupper() and isinstance(v, int) and not isinstance(v, bool)
    }


def preamble() -> str:
    """The ``#define`` lines every shader is compiled with (after its ``#version``)."""
    return "".join(f"#define {k} {v}\n" for k, v in defines().items())
