"""Forward and deferred shading of a scene's visible set under many point lights (seed 003).

Seed 003 (lecture "Drei Rendering Algorithmen", Zellmann) analyses rasterization: forward
shading lights every fragment with every light before the depth test, O(V · VP · L) work in
the worst case; deferred shading first lets the depth test decide and stores the survivors in a
g-buffer (depth 24 bit, normal 2 × 32 bit, diffuse 3 × 32 bit, material 16 bit: ≈ 25 MB at
1024 × 1024), then lights pixels, not fragments: O(V · VP + L · VP).

Both paths draw the visible set with one multi-draw-indirect call (``baseInstance`` = object
id, :meth:`soc.gl.geometry.SceneGeometry.draw_objects`) and share one lighting function
(``forward_lighting.common.glsl``: windowed inverse-square point lights, Lambert + Blinn–Phong
per material), so for the same scene, lights and camera they produce the same image up to the
24-bit depth from which the deferred path reconstructs positions. The stages of a frame:

``forward``          clear → shade (geometry, every fragment lit by all L lights)
``deferred-loop``    clear → gbuffer (geometry, attributes only) → lighting (one full-screen
                     pass looping over all L lights)
``deferred-passes``  clear → gbuffer → lighting (an ambient pass, then one additive
                     full-screen pass per light: the lecture's formulation)

each timed with ``ctx.finish()`` and ``time.perf_counter()`` (GL timer queries read nonsense on
llvmpipe), and in CPU time of the process (``time.process_time()``: llvmpipe's threads are this
process's, so that is the work, W(n) in the lecture's terms, robust to competing processes).
Colours accumulate in an RGBA32F target, so L additive passes round no more than one loop does.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from soc.gl.context import ReleasedOnExit, shader_source, uses_gl
from soc.gl.raw import GL_QUERY_RESULT, GL_SAMPLES_PASSED
from soc.gl.shader_defines import LIGHTS_BINDING, SKY_MATERIAL
from soc.rendering.renderer import SKY
from soc.scenes.camera import Camera, _resolution

PATHS = ("forward", "deferred-loop", "deferred-passes")

AMBIENT = 0.15  # fraction of the diffuse colour lit without any light

# Per material (material id = object id mod MATERIAL_COUNT): specular strength, Blinn–Phong
# shininess.
MATERIALS = np.array(
    [[0.0, 1.0], [0.15, 8.0], [0.3, 16.0], [0.5, 32.0],
     [0.1, 4.0], [0.25, 64.0], [0.4, 24.0], [0.6, 48.0]],
    dtype=np.float32,
)  # fmt: skip

LIGHT_STRIDE = 32  # bytes per light in the shaders' std430 buffer (two vec4)


# -- lights -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Lights:
    """Point lights, world space.

    Attributes
    ----------
    positions : (L, 3) float32
        World units.
    colors : (L, 3) float32
        Linear RGB intensity at the light (1 = a white light of unit strength).
    radii : (L,) float32
        World units: a light's contribution falls to exactly 0 at this distance.
    """

    positions: np.ndarray
    colors: np.ndarray
    radii: np.ndarray

    def __post_init__(self):
        pos = np.asarray(self.positions, dtype=np.float32)
        col = np.asarray(self.colors, dtype=np.float32)
        rad = np.asarray(self.radii, dtype=np.float32)
        if pos.size == 0:  # no lights: accept any empty shape
            pos, col, rad = np.zeros((0, 3), np.float32), col.reshape(0, 3), rad.reshape(0)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise ValueError(f"positions must have shape (L, 3), got {pos.shape}")
        if col.shape != pos.shape:
            raise ValueError(f"colors must have shape {pos.shape}, got {col.shape}")
        if rad.shape != (len(pos),):
            raise ValueError(f"radii must have shape ({len(pos)},), got {rad.shape}")
        if not (np.isfinite(pos).all() and np.isfinite(col).all() and np.isfinite(rad).all()):
            raise ValueError("light positions, colours and radii must be finite")
        if (rad <= 0).any():
            raise ValueError(f"light radii must be positive, got min {rad.min()}")
        for name, a in (("positions", pos), ("colors", col), ("radii", rad)):
            a = np.array(a)  # a private copy, read-only
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return len(self.radii)

    def packed(self) -> np.ndarray:
        """(L, 8) float32: ``position, radius, rgb, 0`` per light (the shaders' layout)."""
        out = np.zeros((len(self), 8), np.float32)
        out[:, :3] = self.positions
        out[:, 3] = self.radii
        out[:, 4:7] = self.colors
        return out

    @classmethod
    def none(cls) -> Lights:
        """No lights: ambient light only."""
        return cls(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


def random_lights(
    bounds: ArrayLike,
    count: int,
    *,
    seed: int = 0,
    radius: float | None = None,
    intensity: float = 1.0,
) -> Lights:
    """``count`` lights uniformly placed in the box ``bounds``, deterministic by ``seed``.

    Parameters
    ----------
    bounds : (2, 3) float
        Min and max corner, world units.
    radius : float, optional
        Reach of every light, world units (default: the box's diagonal, so every light reaches
        every point of the box — the lecture's worst case, no light can be skipped).
    intensity : float
        Total intensity: each light gets ``intensity / count`` in a random pastel colour, so
        images keep their brightness as ``count`` grows.
    """
    b = np.asarray(bounds, np.float64)
    if b.shape != (2, 3) or not np.isfinite(b).all() or (b[1] < b[0]).any():
        raise ValueError(f"bounds must be (2, 3) min/max corners, got {b.tolist()}")
    count = int(count)
    if count < 0:
        raise ValueError(f"count must be >= 0, got {count}")
    if count == 0:
        return Lights.none()
    rng = np.random.default_rng(seed)
    pos = b[0] + rng.random((count, 3)) * (b[1] - b[0])
    hue = rng.random(count)[:, None] * 2 * np.pi + np.array([0.0, 2.1, 4.2])
    col = (0.75 + 0.25 * np.cos(hue)) * (intensity / count)
    r = float(np.linalg.norm(b[1] - b[0])) if radius is None else float(radius)
    return Lights(pos, col, np.full(count, max(r, 1e-6)))


# -- the g-buffer layout and its memory ------------------------------------------------------


@dataclass(frozen=True)
class GBufferTarget:
    """One texture of the g-buffer: its GL internal format and the lecture's entry."""

    name: str
    internal_format: str
    gl_enum: int
    bits: int  # per texel, as the format defines it
    lecture: str


GBUFFER = (
    GBufferTarget("depth", "DEPTH_COMPONENT24", 0x81A6, 24, "DB: 24 bit"),
    GBufferTarget("normal", "RG32F", 0x8230, 64, "NB: 2 × 32 bit (polar coordinates)"),
    GBufferTarget("diffuse", "RGB32F", 0x8815, 96, "TB: 3 × 32 bit (RGB)"),
    GBufferTarget("material", "R16UI", 0x8234, 16, "MB: 16 bit"),
)
LECTURE_GBUFFER_MB = 25.0  # at 1024 × 1024 (25 bytes per pixel: 25 MiB = 26.2 · 10^6 bytes)
MIB = 1 << 20


def gbuffer_bytes(resolution: tuple[int, int]) -> dict[str, int]:
    """Bytes of each g-buffer texture at ``resolution`` pixels, computed from :data:`GBUFFER`
    (bits per texel × pixels / 8); key ``"total"`` holds the sum."""
    w, h = _resolution(*resolution)
    out = {t.name: t.bits * w * h // 8 for t in GBUFFER}
    out["total"] = sum(out.values())
    return out


_GL_TEXTURE_WIDTH = 0x1000
_GL_TEXTURE_HEIGHT = 0x1001
_GL_TEXTURE_INTERNAL_FORMAT = 0x1003
_GL_SIZE_PARAMS = {  # component sizes in bits: GL_TEXTURE_{RED..ALPHA,DEPTH,STENCIL}_SIZE
    "red": 0x805C,
    "green": 0x805D,
    "blue": 0x805E,
    "alpha": 0x805F,
    "depth": 0x884A,
    "stencil": 0x88F1,
}


@dataclass(frozen=True)
class TextureStorage:
    """What the GL reports about level 0 of an allocated texture.

    Attributes
    ----------
    internal_format : int
        GL enum (e.g. ``0x8815`` = ``GL_RGB32F``).
    width, height : int
        Pixels.
    component_bits : Mapping[str, int]
        Bits per component (``red`` … ``alpha``, ``depth``, ``stencil``; 0 = absent).
    """

    internal_format: int
    width: int
    height: int
    component_bits: Mapping[str, int]

    @property
    def bits_per_texel(self) -> int:
        return int(sum(self.component_bits.values()))

    @property
    def bytes(self) -> int:
        """Texel bits the GL reports × pixels / 8 (the driver may pad, e.g. depth 24 → 32)."""
        return self.bits_per_texel * self.width * self.height // 8


@cache
def _get_texture_level_parameteriv():
    """``glGetTextureLevelParameteriv`` (GL 4.5; moderngl does not expose it), via EGL."""
    egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
    get_proc = egl.eglGetProcAddress
    get_proc.restype = ctypes.c_void_p
    get_proc.argtypes = [ctypes.c_char_p]
    addr = get_proc(b"glGetTextureLevelParameteriv")
    if not addr:
        from soc.errors import GLUnavailableError

        raise GLUnavailableError("glGetTextureLevelParameteriv is not available")
    sig = ctypes.CFUNCTYPE(
        None, ctypes.c_uint, ctypes.c_int, ctypes.c_uint, ctypes.POINTER(ctypes.c_int)
    )
    return sig(addr)


@uses_gl
def texture_storage(texture) -> TextureStorage:
    """Read the internal format, size and component bits of ``texture`` (a moderngl texture or
    depth texture of the current context) back from the GL."""
    fn = _get_texture_level_parameteriv()

    def get(pname: int) -> int:
        v = ctypes.c_int(0)
        fn(texture.glo, 0, pname, ctypes.byref(v))
        return int(v.value)

    return TextureStorage(
        internal_format=get(_GL_TEXTURE_INTERNAL_FORMAT),
        width=get(_GL_TEXTURE_WIDTH),
        height=get(_GL_TEXTURE_HEIGHT),
        component_bits={k: get(p) for k, p in _GL_SIZE_PARAMS.items()},
    )


def oct_decode(encoded: ArrayLike) -> np.ndarray:
    """Unit normals ``(..., 3) float32`` from the g-buffer's octahedral encoding ``(..., 2)``
    (the inverse of ``oct_encode`` in ``gbuffer_fill.frag.glsl``)."""
    e = np.asarray(encoded, np.float32)
    if e.shape[-1:] != (2,):
        raise ValueError(f"encoded normals must have shape (..., 2), got {e.shape}")
    n = np.concatenate([e, 1.0 - np.abs(e).sum(axis=-1, keepdims=True)], axis=-1)
    folded = (1.0 - np.abs(e[..., ::-1])) * np.where(e >= 0, 1.0, -1.0)
    n[..., :2] = np.where(n[..., 2:] < 0, folded, e)
    return (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)


# -- results ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class ShadingStats:
    """Timings of one shaded frame.

    Attributes
    ----------
    path : str
        One of :data:`PATHS`.
    lights : int
        L.
    resolution : (width, height)
        Pixels (VP = width × height).
    drawn : int
        Objects drawn (draw commands of the multi-draw-indirect call).
    triangles : int
        Triangles submitted (V).
    timings_ms : Mapping[str, float]
        Stage → wall ms, each stage finished (``ctx.finish()``) before its clock stops.
    cpu_ms : Mapping[str, float]
        Stage → CPU ms of this process, all threads (llvmpipe rasterizes and shades on worker
        threads of this process): the work done, which unlike wall time hardly changes when
        other processes compete for the cores.
    """

    path: str
    lights: int
    resolution: tuple[int, int]
    drawn: int
    triangles: int
    timings_ms: Mapping[str, float] = field(default_factory=dict)
    cpu_ms: Mapping[str, float] = field(default_factory=dict)

    @property
    def total_ms(self) -> float:
        """Wall ms of the frame (sum of the stages)."""
        return float(sum(self.timings_ms.values()))

    @property
    def total_cpu_ms(self) -> float:
        """CPU ms of the frame, all threads (sum of the stages)."""
        return float(sum(self.cpu_ms.values()))


# -- the renderer -----------------------------------------------------------------------------


@uses_gl
class ShadingRenderer(ReleasedOnExit):
    """Forward and deferred shading of a scene at ``resolution`` pixels with point lights.

    Owns its targets: an RGBA32F colour (both paths' output), a 24-bit depth texture (the
    forward depth buffer and the g-buffer's depth) and the g-buffer's normal (RG32F), diffuse
    (RGB32F) and material (R16UI) textures. Release with :meth:`release` or ``with``.

    Parameters
    ----------
    scene : Scene
    resolution : (width, height)
        Pixels.
    glctx : GLContext, optional
        Default: the process's context.
    """

    def __init__(self, scene, resolution: tuple[int, int], *, glctx=None):
        import moderngl

        from soc.gl.context import default_context

        self.glctx = glctx or default_context()
        self.scene = scene
        self.geometry = self.glctx.geometry(scene)
        self.resolution = _resolution(*resolution)
        ctx = self.glctx.ctx
        size = self.resolution
        self.color = ctx.texture(size, 4, dtype="f4")
        self.depth = ctx.depth_texture(size)
        self.normal = ctx.texture(size, 2, dtype="f4")
        self.diffuse = ctx.texture(size, 3, dtype="f4")
        self.material = ctx.texture(size, 1, dtype="u2")
        self.depth.compare_func = ""  # the lighting passes read raw depths
        for t in (self.color, self.depth, self.normal, self.diffuse, self.material):
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.forward_fbo = ctx.framebuffer([self.color], self.depth)
        self.gbuffer_fbo = ctx.framebuffer([self.normal, self.diffuse, self.material], self.depth)
        self.light_fbo = ctx.framebuffer([self.color])
        self._programs = {
            key: ctx.program(vertex_shader=shader_source(vert), fragment_shader=shader_source(frag))
            for key, vert, frag in (
                ("forward", "mesh.vert", "forward_shade.frag"),
                ("gbuffer", "mesh.vert", "gbuffer_fill.frag"),
                ("ambient", "deferred_fullscreen.vert", "deferred_ambient.frag"),
                ("light", "deferred_fullscreen.vert", "deferred_light.frag"),
                ("loop", "deferred_fullscreen.vert", "deferred_loop.frag"),
            )
        }
        self._fullscreen = {
            k: ctx.vertex_array(self._programs[k], []) for k in ("ambient", "light", "loop")
        }
        self._depth_only = self.glctx.program("mesh.vert", "depth_only.frag")  # shared cache
        self.lights = Lights.none()
        self._light_buffer = ctx.buffer(reserve=LIGHT_STRIDE)
        self._released = False

    # -- lifetime ---------------------------------------------------------------------------

    def release(self) -> None:
        """Release every target, program and buffer this renderer allocated (idempotent)."""
        if self._released:
            return
        self._released = True
        for vao in self._fullscreen.values():
            vao.release()
        for p in self._programs.values():
            p.release()
        self._light_buffer.release()
        self.glctx.release_framebuffer(self.forward_fbo)
        self.glctx.release_framebuffer(self.gbuffer_fbo)
        self.glctx.release_framebuffer(
            self.light_fbo, self.color, self.depth, self.normal, self.diffuse, self.material
        )

    # -- inputs -----------------------------------------------------------------------------

    def set_lights(self, lights: Lights) -> None:
        """Upload ``lights`` (any number, including none) for the following frames."""
        if not isinstance(lights, Lights):
            raise ValueError(
                f"lights must be a soc.rendering.shading.Lights, got {type(lights).__name__}"
            )
        data = lights.packed()
        if data.nbytes > self._light_buffer.size:
            self._light_buffer.orphan(data.nbytes)
        if data.nbytes:
            self._light_buffer.write(data)
        self.lights = lights

    def _ids(self, ids: ArrayLike | None) -> np.ndarray:
        n = len(self.scene)
        if ids is None:
            return np.arange(n)
        ids = np.asarray(ids)
        if ids.ndim != 1 or not (np.issubdtype(ids.dtype, np.integer) or ids.size == 0):
            raise ValueError(f"ids must be a (K,) integer array, got shape {ids.shape} {ids.dtype}")
        ids = ids.astype(np.int64)
        if ids.size and (ids.min() < 0 or ids.max() >= n):
            raise ValueError(f"ids must lie in 0..{n - 1}, got {ids.min()}..{ids.max()}")
        return ids

    def _check_camera(self, camera: Camera) -> None:
        if not isinstance(camera, Camera):
            raise ValueError(f"camera must be a soc.Camera, got {type(camera).__name__}")
        w, h = self.resolution
        if abs(camera.aspect - w / h) > 1e-3 * (w / h):
            raise ValueError(
                f"camera aspect {camera.width}×{camera.height} does not match the renderer's "
                f"{w}×{h}; use camera.with_resolution({self.resolution})"
            )

    # -- drawing ----------------------------------------------------------------------------

    def render(self, camera: Camera, ids: ArrayLike | None = None, *, path: str) -> ShadingStats:
        """Shade objects ``ids`` (K,) (default all, drawn in the given order) from ``camera``
        with the current lights along ``path`` (one of :data:`PATHS`)."""
        if path == "forward":
            return self.forward(camera, ids)
        if path == "deferred-loop":
            return self.deferred(camera, ids, lighting="loop")
        if path == "deferred-passes":
            return self.deferred(camera, ids, lighting="passes")
        raise ValueError(f"unknown shading path {path!r}; available: {', '.join(PATHS)}")

    def forward(self, camera: Camera, ids: ArrayLike | None = None) -> ShadingStats:
        """Forward shading: stages ``clear``, ``shade``."""
        import moderngl

        self._check_camera(camera)
        ids = self._ids(ids)
        ctx = self.glctx.ctx
        clock = _Stopwatch(self.glctx)
        self.forward_fbo.use()
        self.forward_fbo.depth_mask = True
        self.forward_fbo.clear(*SKY, 1.0, depth=1.0)
        clock.lap("clear")
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        p = self._programs["forward"]
        self._uniforms(p, camera)
        self.geometry.draw_objects(p, ids)
        clock.lap("shade")
        return self._stats("forward", ids, clock)

    def deferred(
        self, camera: Camera, ids: ArrayLike | None = None, *, lighting: str = "loop"
    ) -> ShadingStats:
        """Deferred shading: stages ``clear``, ``gbuffer``, ``lighting``.

        Parameters
        ----------
        lighting : {"loop", "passes"}
            ``loop``: one full-screen pass looping over all lights; ``passes``: an ambient pass
            and then one additive full-screen pass per light.
        """
        import moderngl

        if lighting not in ("loop", "passes"):
            raise ValueError(f"lighting must be 'loop' or 'passes', got {lighting!r}")
        self._check_camera(camera)
        ids = self._ids(ids)
        ctx = self.glctx.ctx
        raw = self.glctx.raw
        clock = _Stopwatch(self.glctx)
        # Only depth and material need clearing: the material id marks the pixels drawn.
        self.gbuffer_fbo.use()
        self.gbuffer_fbo.depth_mask = True
        raw.clear_depth(1.0)
        raw.clear_uint_color(SKY_MATERIAL, draw_buffer=2)
        clock.lap("clear")
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        p = self._programs["gbuffer"]
        p["eye"].value = tuple(camera.eye)
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self.geometry.draw_objects(p, ids)
        clock.lap("gbuffer")

        self.light_fbo.use()
        ctx.enable_only(moderngl.NOTHING)
        if lighting == "loop":
            self._deferred_uniforms(self._programs["loop"], camera)
            self._fullscreen["loop"].render(moderngl.TRIANGLES, vertices=3)
        else:
            self._deferred_uniforms(self._programs["ambient"], camera)
            self._fullscreen["ambient"].render(moderngl.TRIANGLES, vertices=3)
            if len(self.lights):
                p = self._programs["light"]
                self._deferred_uniforms(p, camera)
                ctx.enable_only(moderngl.BLEND)
                ctx.blend_equation = moderngl.FUNC_ADD
                ctx.blend_func = moderngl.ONE, moderngl.ONE
                vao, index = self._fullscreen["light"], p["light"]
                for i in range(len(self.lights)):
                    index.value = i
                    vao.render(moderngl.TRIANGLES, vertices=3)
                ctx.blend_func = moderngl.DEFAULT_BLENDING
                ctx.enable_only(moderngl.NOTHING)
        clock.lap("lighting")
        return self._stats(f"deferred-{lighting}", ids, clock)

    def _uniforms(self, p, camera: Camera) -> None:
        """Uniforms of the lighting function (and the camera) that ``p`` uses."""
        values: dict[str, Any] = {
            "eye": tuple(camera.eye),
            "ambient": AMBIENT,
            "light_count": len(self.lights),
            "sky": tuple(SKY),
        }
        for name, v in values.items():
            if name in p:
                p[name].value = v
        if "view_proj" in p:
            p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        if "materials" in p:
            p["materials"].write(MATERIALS.tobytes())
        self._light_buffer.bind_to_storage_buffer(LIGHTS_BINDING)

    def _deferred_uniforms(self, p, camera: Camera) -> None:
        self._uniforms(p, camera)
        if "inv_view_proj" in p:
            p["inv_view_proj"].write(camera.gl_bytes(np.linalg.inv(camera.view_proj)))
        if "viewport" in p:
            p["viewport"].value = tuple(float(v) for v in self.resolution)
        for unit, (name, tex) in enumerate(
            (
                ("g_depth", self.depth),
                ("g_normal", self.normal),
                ("g_diffuse", self.diffuse),
                ("g_material", self.material),
            )
        ):
            if name in p:
                tex.use(location=unit)
                p[name].value = unit

    def _stats(self, path: str, ids: np.ndarray, clock: _Stopwatch) -> ShadingStats:
        return ShadingStats(
            path=path,
            lights=len(self.lights),
            resolution=self.resolution,
            drawn=len(ids),
            triangles=int(self.scene.triangle_counts[ids].sum()),
            timings_ms=clock.laps,
            cpu_ms=clock.cpu_laps,
        )

    # -- measurements and read-back ---------------------------------------------------------

    def count_fragments(self, camera: Camera, ids: ArrayLike | None = None) -> int:
        """Fragments that pass the depth test when ``ids`` are drawn in this order = the
        fragments forward shading lights (llvmpipe tests depth before shading when the shader
        neither discards nor writes depth). Draws depth only (overwrites the depth texture)."""
        import moderngl

        self._check_camera(camera)
        ids = self._ids(ids)
        ctx = self.glctx.ctx
        self.forward_fbo.use()
        self.forward_fbo.depth_mask = True
        self.glctx.raw.clear_depth(1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        p = self._depth_only
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        gl = self.glctx.raw
        qid, count = ctypes.c_uint(0), ctypes.c_uint(0)
        gl.glGenQueries(1, ctypes.byref(qid))
        try:
            gl.glBeginQuery(GL_SAMPLES_PASSED, qid.value)
            self.geometry.draw_objects(p, ids)
            gl.glEndQuery(GL_SAMPLES_PASSED)
            gl.glGetQueryObjectuiv(qid.value, GL_QUERY_RESULT, ctypes.addressof(count))
        finally:
            gl.glDeleteQueries(1, ctypes.byref(qid))
        return int(count.value)

    def hdr_image(self) -> np.ndarray:
        """(H, W, 3) float32 linear colour of the last frame (either path), top row first."""
        w, h = self.resolution
        rgba = np.frombuffer(self.color.read(), np.float32).reshape(h, w, 4)
        return rgba[::-1, :, :3].copy()

    def image(self) -> np.ndarray:
        """(H, W, 3) uint8 of the last frame: the linear colour clamped to [0, 1] and rounded."""
        return np.rint(np.clip(self.hdr_image(), 0.0, 1.0) * 255.0).astype(np.uint8)

    def gbuffer(self) -> dict[str, np.ndarray]:
        """The g-buffer of the last deferred frame, top row first: ``depth (H, W) float32``
        window depth, ``normal (H, W, 2) float32`` octahedral, ``diffuse (H, W, 3) float32``,
        ``material (H, W) uint16`` (:data:`SKY_MATERIAL` where nothing was drawn)."""
        w, h = self.resolution
        return {
            "depth": np.frombuffer(self.depth.read(), np.float32).reshape(h, w)[::-1].copy(),
            "normal": np.frombuffer(self.normal.read(), np.float32).reshape(h, w, 2)[::-1].copy(),
            "diffuse": np.frombuffer(self.diffuse.read(), np.float32).reshape(h, w, 3)[::-1].copy(),
            "material": np.frombuffer(self.material.read(), np.uint16).reshape(h, w)[::-1].copy(),
        }

    def gbuffer_storage(self) -> dict[str, TextureStorage]:
        """What the GL reports about each allocated g-buffer texture (keys as :data:`GBUFFER`)."""
        textures = {
            "depth": self.depth,
            "normal": self.normal,
            "diffuse": self.diffuse,
            "material": self.material,
        }
        return {t.name: texture_storage(textures[t.name]) for t in GBUFFER}


class _Stopwatch:
    """Stage laps in wall and process CPU time: each lap ends with ``ctx.finish()`` so the GL
    work it issued is counted (``finish`` sleeps on a fence, so waiting costs no CPU)."""

    def __init__(self, glctx):
        self.glctx = glctx
        glctx.finish()  # earlier work is not ours
        self.laps: dict[str, float] = {}
        self.cpu_laps: dict[str, float] = {}
        self._t, self._c = time.perf_counter(), time.process_time()

    def lap(self, stage: str) -> None:
        self.glctx.finish()
        t, c = time.perf_counter(), time.process_time()
        self.laps[stage] = 1e3 * (t - self._t)
        self.cpu_laps[stage] = 1e3 * (c - self._c)
        self._t, self._c = t, c
