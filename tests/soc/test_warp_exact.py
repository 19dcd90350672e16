"""The warp engines give exactly the frames of their first, plain implementation.

Oracle: the first version of the warping server's shaders, kept here verbatim but for
comments — one matrix per object uploaded every warp (:func:`warp_matrices`), the stereo shift
or the matrices chosen by a uniform, the compute scatter's two stages re-deriving each splat
from the source frame, its buffers cleared before each warp, the winner stored as
``y * width + x``. The engines of :class:`soc.rendering.warping.Warper` have since been made
cheaper (shared matrix rows, per-stage programs, the splats kept between the stages, the
buffers cleared by the resolve); their colour, depth and ids must not change by one bit.
"""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.oracle import NO_OBJECT
from soc.gl.shader_defines import (
    NEAREST_BINDING,
    OUT_COLOR_IMAGE,
    OUT_DEPTH_IMAGE,
    OUT_IDS_IMAGE,
    PIXEL_GROUP,
    WARPS_BINDING,
    WINNER_BINDING,
    preamble,
)
from soc.rendering.warping import (
    BACKGROUND_NDC_Z,
    HOLE,
    HOLE_COLOR,
    Frame,
    FrameRenderer,
    Warper,
    _Target,
    focal_length_px,
    warp_matrices,
)

RES = (96, 72)

_MAP = """
uniform sampler2D depth;
uniform usampler2D ids;
layout(std430, binding = WARPS_BINDING) readonly buffer Warps { mat4 warps[]; };
uniform ivec2 size;
uniform uint objects;
uniform uint no_object;
uniform bool parallel;
uniform float focal_baseline;
uniform float near;
uniform float far;
uniform float background_z;

vec4 warp_clip(ivec2 p) {
    uint obj = texelFetch(ids, p, 0).r;
    bool sky = obj == no_object;
    float z_ndc = 2.0 * texelFetch(depth, p, 0).r - 1.0;
    vec2 xy = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
    if (parallel) {
        float z_eye = 2.0 * near * far / ((far + near) - z_ndc * (far - near));
        float disparity = sky ? 0.0 : focal_baseline / z_eye;
        return vec4(xy.x - 2.0 * disparity / float(size.x), xy.y, sky ? background_z : z_ndc, 1.0);
    }
    vec4 clip = warps[sky ? objects : min(obj, objects)] * vec4(xy, z_ndc, 1.0);
    if (sky) clip.z = background_z * clip.w;
    return clip;
}
"""

_SCATTER = """
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;
MAP
layout(std430, binding = NEAREST_BINDING) buffer Nearest { uint nearest[]; };
layout(std430, binding = WINNER_BINDING) buffer Winner { uint winner[]; };
uniform int stage;
uniform float splat_size;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    vec4 clip = warp_clip(p);
    if (!(clip.w > 0.0)) return;
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc), vec3(1.0)))) return;
    vec2 centre = (ndc.xy * 0.5 + 0.5) * vec2(size);
    uint bits = floatBitsToUint(ndc.z * 0.5 + 0.5);
    uint source = uint(p.y * size.x + p.x);
    ivec2 lo = max(ivec2(ceil(centre - 0.5 * splat_size - 0.5)), ivec2(0));
    ivec2 hi = min(ivec2(ceil(centre + 0.5 * splat_size - 0.5)), size);
    for (int y = lo.y; y < hi.y; ++y) {
        for (int x = lo.x; x < hi.x; ++x) {
            uint q = uint(y * size.x + x);
            if (stage == 0) {
                atomicMin(nearest[q], bits);
            } else if (nearest[q] == bits) {
                atomicMin(winner[q], source);
            }
        }
    }
}
"""

_RESOLVE = """
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;
uniform sampler2D color;
uniform usampler2D ids;
layout(std430, binding = NEAREST_BINDING) readonly buffer Nearest { uint nearest[]; };
layout(std430, binding = WINNER_BINDING) readonly buffer Winner { uint winner[]; };
layout(rgba8, binding = OUT_COLOR_IMAGE) uniform writeonly image2D out_color;
layout(r32ui, binding = OUT_IDS_IMAGE) uniform writeonly uimage2D out_ids;
layout(r32f, binding = OUT_DEPTH_IMAGE) uniform writeonly image2D out_depth;
uniform ivec2 size;
uniform vec4 hole_color;
uniform uint hole;

void main() {
    ivec2 q = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(q, size))) return;
    uint i = uint(q.y * size.x + q.x);
    uint s = winner[i];
    if (s == 0xFFFFFFFFu) {
        imageStore(out_color, q, hole_color);
        imageStore(out_ids, q, uvec4(hole));
        imageStore(out_depth, q, vec4(1.0));
        return;
    }
    ivec2 p = ivec2(int(s % uint(size.x)), int(s / uint(size.x)));
    imageStore(out_color, q, texelFetch(color, p, 0));
    imageStore(out_ids, q, uvec4(texelFetch(ids, p, 0).r));
    imageStore(out_depth, q, vec4(uintBitsToFloat(nearest[i])));
}
"""

_SPLAT_VERT = """
MAP
uniform sampler2D color;
uniform float splat_size;
flat out vec4 v_color;
flat out uint v_object;

void main() {
    ivec2 p = ivec2(gl_VertexID % size.x, gl_VertexID / size.x);
    gl_Position = warp_clip(p);
    gl_PointSize = splat_size;
    v_color = texelFetch(color, p, 0);
    v_object = texelFetch(ids, p, 0).r;
}
"""

_SPLAT_FRAG = """
flat in vec4 v_color;
flat in uint v_object;
layout(location = 0) out vec4 f_color;
layout(location = 1) out uint f_object;

void main() {
    f_color = v_color;
    f_object = v_object;
}
"""


def _src(body: str) -> str:
    return "#version 450\n" + preamble() + body.replace("MAP", _MAP)


class _Oracle:
    """The first implementation of both engines, run on the same GL."""

    def __init__(self, glctx):
        ctx = glctx.ctx
        self.glctx = glctx
        self.scatter = ctx.compute_shader(_src(_SCATTER))
        self.resolve = ctx.compute_shader(_src(_RESOLVE))
        self.points = ctx.program(
            vertex_shader=_src(_SPLAT_VERT), fragment_shader=_src(_SPLAT_FRAG)
        )
        self.vao = ctx.vertex_array(self.points, [])
        w, h = RES
        self.warps = ctx.buffer(reserve=64)
        self.nearest = ctx.buffer(reserve=4 * w * h)
        self.winner = ctx.buffer(reserve=4 * w * h)
        self.point_target = _Target(glctx, RES)
        self.scatter_target = _Target(glctx, RES, depth_attachment=False)

    def release(self):
        for o in (self.scatter, self.resolve, self.vao, self.points, self.warps, self.nearest,
                  self.winner, self.point_target, self.scatter_target):  # fmt: skip
            o.release()

    def warp(self, engine, source, uniforms, splat_size) -> Frame:
        import moderngl

        ctx = self.glctx.ctx
        w, h = RES
        uniforms = {**uniforms, "size": RES, "no_object": NO_OBJECT,
                    "background_z": BACKGROUND_NDC_Z, "splat_size": float(splat_size)}  # fmt: skip
        self.warps.bind_to_storage_buffer(WARPS_BINDING)

        def setup(program):
            for name, value in uniforms.items():
                if name in program:
                    program[name].value = value
            for unit, (name, tex) in enumerate(
                (("color", source.color), ("depth", source.depth), ("ids", source.ids))
            ):
                if name in program:
                    tex.use(location=unit)
                    program[name].value = unit

        if engine == "points":
            self.point_target.clear(HOLE_COLOR, HOLE)
            ctx.enable_only(moderngl.DEPTH_TEST | moderngl.PROGRAM_POINT_SIZE)
            ctx.depth_func = "<"
            setup(self.points)
            self.vao.render(moderngl.POINTS, vertices=w * h)
            ctx.finish()
            return self.point_target.read()
        groups = (-(-w // PIXEL_GROUP), -(-h // PIXEL_GROUP))
        self.nearest.clear(chunk=b"\xff" * 4)
        self.winner.clear(chunk=b"\xff" * 4)
        self.nearest.bind_to_storage_buffer(NEAREST_BINDING)
        self.winner.bind_to_storage_buffer(WINNER_BINDING)
        setup(self.scatter)
        for stage in (0, 1):
            self.scatter["stage"].value = stage
            self.scatter.run(*groups)
            ctx.memory_barrier()
        uniforms = {"size": RES, "hole_color": HOLE_COLOR, "hole": HOLE}
        setup(self.resolve)
        t = self.scatter_target
        t.color.bind_to_image(OUT_COLOR_IMAGE, read=False, write=True)
        t.ids.bind_to_image(OUT_IDS_IMAGE, read=False, write=True)
        t.depth.bind_to_image(OUT_DEPTH_IMAGE, read=False, write=True)
        self.resolve.run(*groups)
        ctx.memory_barrier()
        ctx.finish()
        return t.read()

    def reproject(self, engine, source, camera, transforms, splat_size) -> Frame:
        m = warp_matrices(source.camera, camera, source.transforms, transforms)
        data = np.ascontiguousarray(m.transpose(0, 2, 1), dtype=np.float32)
        if data.nbytes > self.warps.size:
            self.warps.orphan(data.nbytes)
        self.warps.write(data)
        u = {"parallel": False, "objects": len(source.scene)}
        return self.warp(engine, source, u, splat_size)

    def stereo(self, engine, source, separation, splat_size) -> Frame:
        cam = source.camera
        u = {"parallel": True, "objects": 0, "near": cam.near, "far": cam.far,
             "focal_baseline": focal_length_px(cam) * float(separation)}  # fmt: skip
        return self.warp(engine, source, u, splat_size)


@pytest.fixture(scope="module")
def setup():
    scene = soc.scenes.clutter(1)
    warpers = {e: Warper(RES, engine=e) for e in Warper.ENGINES}
    source = FrameRenderer(scene, RES)
    oracle = _Oracle(source.glctx)
    yield scene, warpers, source, oracle
    for w in warpers.values():
        w.release()
    source.release()
    oracle.release()


def _cameras(n: int, seed: int):
    rng = np.random.default_rng(seed)
    out = []
    for a in rng.uniform(0, 2 * np.pi, n):
        eye = (40 * np.cos(a), rng.uniform(3, 12), 40 * np.sin(a))
        target = (*rng.uniform(-6, 6, 1), rng.uniform(0, 3), *rng.uniform(-6, 6, 1))
        out.append(soc.Camera.look_at(eye, target, width=RES[0], height=RES[1], far=300.0))
    return out


def _assert_same(a: Frame, b: Frame, what: str) -> None:
    for field in ("color", "depth", "ids"):
        x, y = getattr(a, field), getattr(b, field)
        assert np.array_equal(x, y), f"{what}: {field} differs at {int((x != y).sum())} values"


@pytest.mark.parametrize("engine", Warper.ENGINES)
def test_reproject_and_stereo_are_bit_identical_to_the_first_implementation(setup, engine):
    """Several views, a few objects moved (others still: shared and own matrix rows), the
    camera moved and turned (border holes, background), splats of 1, 2 and 2.5 px, and the
    stereo shift; warps one after another (the buffers the resolve clears are reused)."""
    scene, warpers, source, oracle = setup
    n = len(scene)
    moved = np.arange(1, n, 4)
    t_old = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    t_new = t_old.copy()
    t_new[moved, :3, 3] = (0.6, 0.1, -0.4)
    c, s = np.cos(0.2), np.sin(0.2)
    t_new[moved[::2], :3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    cams = _cameras(3, seed=5)
    w = warpers[engine]
    covered = 0
    for k, cam in enumerate(cams):
        source.render(cam, t_old)
        new_cam = cams[(k + 1) % len(cams)] if k == 2 else cam.replace(
            eye=tuple(np.add(cam.eye, (1.2, 0.4, -0.8))))  # fmt: skip
        for splat in (1.0, 2.0, 2.5):
            w.reproject(source, new_cam, t_new, splat_size=splat)
            got = w.frame()
            covered += int((got.ids != HOLE).sum())
            want = oracle.reproject(engine, source, new_cam, t_new, splat)
            _assert_same(got, want, f"{engine} view {k} splat {splat}")
        for b, splat in ((0.8, 1.0), (-1.5, 2.0)):
            w.stereo(source, b, splat_size=splat)
            _assert_same(w.frame(), oracle.stereo(engine, source, b, splat), f"stereo {b}")
    assert covered > 0.3 * 9 * RES[0] * RES[1]  # the views show something


def test_a_scatter_stopped_before_its_resolve_does_not_leak_into_the_next(setup):
    """The scatter's buffers are cleared by each resolve; a warp that never reached it (an
    exception between the stages) leaves them dirty, and the next warp must clear them."""
    _, warpers, source, oracle = setup
    w = warpers["scatter"]
    cam = _cameras(1, seed=9)[0]
    source.render(cam)
    w.nearest.write(np.zeros(RES[0] * RES[1], np.uint32))  # every pixel "won" at depth 0
    w.winner.write(np.zeros(RES[0] * RES[1], np.uint32))
    w._cleared = False
    w.reproject(source, cam, splat_size=1.0)
    _assert_same(w.frame(), oracle.reproject("scatter", source, cam, None, 1.0), "after a stop")


def test_warp_table_holds_the_shared_rows_and_one_per_moved_object():
    """Still objects share row 0, the background is row 1, moved objects get a row each in
    ascending id; expanded by the rows it is warp_matrices, to the bit."""
    from soc.gl.shader_defines import BACKGROUND_WARP_ROW, STATIC_WARP_ROW
    from soc.rendering.warping import warp_table

    cam = _cameras(2, seed=3)
    n = 7
    t_old = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    t_new = t_old.copy()
    t_new[[5, 2], :3, 3] = (0.5, 0.0, 1.0)
    table, rows = warp_table(cam[0], cam[1], t_old, t_new)
    assert (STATIC_WARP_ROW, BACKGROUND_WARP_ROW) == (0, 1)
    assert table.shape == (4, 4, 4) and rows.dtype == np.uint32
    assert rows.tolist() == [0, 0, 2, 0, 0, 3, 0]
    dense = warp_matrices(cam[0], cam[1], t_old, t_new)
    assert np.array_equal(dense[:n], table[rows]) and np.array_equal(dense[n], table[1])
    assert warp_table(cam[0], cam[1])[0].shape == (2, 4, 4)  # no objects: the shared rows
