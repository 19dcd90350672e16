"""Gonakhchyan's performance model of forward rendering (seed 004, ``004_bba2ab22d18288ab.txt``,
section 2: formulas (1)-(4) and Table 1), with its per-material constants measured on our GL
context the way the paper measures them.

Memory (1)::

    M_scene = N_vert·M_vert + N_index·M_index + N_tc·M_tc + N_norm·M_norm
              + Σ M_tex + Σ M_buf + Σ M_desc

Frame time (2), S = the objects drawn, H = the hierarchy nodes tested::

    T(S, H) = T_buf(S) + max(T_state(S), T_vert(S), T_frag(S))
              + T_fc(H) + T_buf(H) + max(T_state(H), T_vert(H), T_frag(H), T_zbuffer(H))

with T_vert(O) = N_Δ(O)·T_Δ(m) (3) and T_frag(O) = f(O)·T_frag(m) (4).

"Command buffers" are indirect draw buffers here: recording one is building the
``(count, instances, first, base vertex, base instance)`` rows with numpy and uploading them.
Every constant is the slope of the typical time (minimum or median: :func:`typical_ms`)
between a small and a large batch of the same work (fixed costs cancel), timed with
``ctx.finish()`` and ``time.perf_counter()`` (GL timer queries read nonsense on llvmpipe),
all batches interleaved round by round so that load from other processes falls on every one
alike (:func:`run_interleaved`):

=========  ==========================================================================
T_frag     per fragment: full-screen triangles stacked nearer and nearer (the paper:
           "a triangle over the whole screen"); every fragment is shaded
T_Δ        per triangle: patches of sub-pixel triangles scattered over the screen
           (0.78 vertex per triangle, as in ordinary meshes; the paper: "many small
           triangles")
t(E)       our addition: per triangle, its fragments included, as a function of its
           footprint E = A + 4·(w + h) pixels (A its screen area, w × h its screen
           bounding box), from patches of equal right triangles (legs 1/16 … 128 px).
           llvmpipe bins triangles into 64×64 tiles and shades 4×4-pixel stamps, and a
           triangle touches about (A + 4·(w + h) + 16) / 16 stamps, so a fragment of a
           30-pixel triangle costs several times one of a full-screen triangle, and a
           thin triangle more than a compact one of the same area. T_vert(S) + T_frag(S)
           = Σ t(E_i); T_vert(S) = N_Δ·T_Δ, T_frag(S) the rest (t → T_Δ for sub-pixel
           triangles, → A·T_frag for large ones)
T_cmd      per indirect command, beyond its triangle and its T_buf: a multi-draw of one
           tiny triangle per command. Mesa splits a multi-draw-indirect into single
           draws on the CPU, so this is the per-object state cost of our MDI path
T_state    per state change: a uniform write (``light_dir``) then a separate draw of one
           tiny triangle, beyond that triangle (the paper: "one small triangle")
T_vis      per occlusion query on a BVH node of a random-box scene of 30,000 objects,
           issue and read-back (the paper: "queries of hierarchy nodes in a big scene")
T_buf      per command: gather the rows with numpy and upload them
T_fc       per box: numpy frustum test (:func:`soc.culling.frustum.aabbs_in_frustum`). Its
           matrix product runs on OpenBLAS threads, which fight llvmpipe's: measured
           between GL frames it is ~0.1 µs per box undisturbed, up to ~1 µs otherwise
T_frame    per frame (our addition, not in (2)): clear, program and uniforms, one
           multi-draw call of one sub-pixel triangle, ``finish``. The frame's one pipeline
           state is in it. The paper's Vulkan timings leave it out; on llvmpipe it is
           most of a small frame.
=========  ==========================================================================

On llvmpipe the "GPU" is the CPU: state setup and vertex work (Mesa's draw module, triangle
setup and binning) run on the calling thread, fragments on the rasterizer threads. The paper's
``max`` assumes pipelined GPU stages; :func:`frame_time` also offers ``"llvmpipe"`` (stages on
the calling thread add, the rasterizer threads overlap them) and ``"sum"`` (nothing overlaps).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from soc.errors import check_choice
from soc.gl.context import uses_gl
from soc.scenes.camera import Camera
from soc.scenes.scene import Scene

MATERIAL = ("mesh.vert", "shade.frag")  # the renderer's material: all our objects use it
OVERLAPS = ("max", "llvmpipe", "sum")
STATISTICS = ("median", "min")

# Memory per element of the layout of soc.gl.geometry.SceneGeometry, bytes.
M_VERT = 12  # position, 3 float32 (normals come from derivatives in shade.frag)
M_INDEX = 4  # uint32
M_TC = 8  # 2 float32 texture coordinates (none stored)
M_NORM = 12  # 3 float32 normal (none stored)
M_COMMAND = 20  # indirect command: 5 uint32
M_OBJECT = 4 + 12 + 24  # per object: id (uint32), colour (3 float32), query box (6 float32)
M_BOX_INDEX = (36 + 24) * 4  # the shared box triangle and edge index buffers


# -- formula (1): memory ----------------------------------------------------------------------


@dataclass(frozen=True)
class MemoryEstimate:
    """Bytes of formula (1), term by term.

    Attributes
    ----------
    terms : dict[str, int]
        ``"vertices"``, ``"indices"``, ``"tex_coords"``, ``"normals"``, ``"textures"``,
        ``"buffers"``, ``"descriptors"``: bytes.
    """

    terms: dict[str, int]

    @property
    def total(self) -> int:
        """Bytes, all terms."""
        return int(sum(self.terms.values()))


def _count(name: str, v) -> int:
    if isinstance(v, bool) or int(v) != v or v < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {v!r}")
    return int(v)


def scene_memory(
    n_vert: int,
    n_index: int,
    *,
    m_vert: int = M_VERT,
    m_index: int = M_INDEX,
    n_tc: int = 0,
    m_tc: int = M_TC,
    n_norm: int = 0,
    m_norm: int = M_NORM,
    textures: tuple[int, ...] | list[int] = (),
    buffers: tuple[int, ...] | list[int] = (),
    descriptors: tuple[int, ...] | list[int] = (),
) -> MemoryEstimate:
    """Formula (1): the memory a scene needs on the GPU, bytes.

    Parameters
    ----------
    n_vert, n_index, n_tc, n_norm : int
        Number of vertices, vertex indices, texture coordinates and normals.
    m_vert, m_index, m_tc, m_norm : int
        Bytes per vertex, index, texture coordinate, normal.
    textures, buffers, descriptors : sequence of int
        Bytes of each texture, each command / per-object buffer, each API descriptor.
    """
    counts = {"n_vert": n_vert, "n_index": n_index, "n_tc": n_tc, "n_norm": n_norm}
    sizes = {"m_vert": m_vert, "m_index": m_index, "m_tc": m_tc, "m_norm": m_norm}
    c = {k: _count(k, v) for k, v in {**counts, **sizes}.items()}
    seqs = {"textures": textures, "buffers": buffers, "descriptors": descriptors}
    b = {k: sum(_count(f"each of {k}", x) for x in seq) for k, seq in seqs.items()}
    return MemoryEstimate(
        {
            "vertices": c["n_vert"] * c["m_vert"],
            "indices": c["n_index"] * c["m_index"],
            "tex_coords": c["n_tc"] * c["m_tc"],
            "normals": c["n_norm"] * c["m_norm"],
            "textures": b["textures"],
            "buffers": b["buffers"],
            "descriptors": b["descriptors"],
        }
    )


def geometry_memory(scene: Scene, resolution: tuple[int, int] | None = None) -> MemoryEstimate:
    """Formula (1) for ``scene`` in the layout of :class:`soc.gl.geometry.SceneGeometry`
    (and, with ``resolution``, the RGBA8 colour and float32 depth targets of a
    :class:`soc.rendering.renderer.Renderer`), from the scene's counts alone.

    Descriptors (GL object names) have no size we can read on llvmpipe: counted as 0 bytes.
    """
    n = len(scene)
    textures: list[int] = []
    if resolution is not None:
        w, h = (_count("resolution", v) for v in resolution)
        textures = [w * h * 4, w * h * 4]
    return scene_memory(
        len(scene.vertices),
        3 * len(scene.faces),
        buffers=[n * M_COMMAND, n * M_OBJECT, M_BOX_INDEX],
        textures=textures,
    )


def allocated_memory(geometry, renderer=None) -> dict[str, int]:
    """Bytes of the GL buffers (and render targets) actually allocated for a scene.

    Parameters
    ----------
    geometry : SceneGeometry
    renderer : Renderer, optional

    Returns
    -------
    dict[str, int]
        ``"vertices"`` (vbo), ``"indices"`` (ibo), ``"buffers"`` (indirect, ids, colours,
        boxes, box index buffers), ``"textures"`` (colour + depth; 0 without a renderer).
    """
    g = geometry
    buffers = (g.indirect, g.ids, g.colors, g.boxes, g.box_ibo, g.box_edges)
    out = {
        "vertices": g.vbo.size,
        "indices": g.ibo.size,
        "buffers": sum(b.size for b in buffers),
        "textures": 0,
    }
    if renderer is not None:
        targets = (renderer.color, renderer.depth)
        out["textures"] = sum(t.width * t.height * t.components * int(t.dtype[1:]) for t in targets)
    return {k: int(v) for k, v in out.items()}


# -- the constants ------------------------------------------------------------------------------

# Legs of the equal right triangles of the t(E) patches, pixels (area leg² / 2, footprint
# leg² / 2 + 8·leg). The first is sub-pixel: almost no triangle covers a pixel centre, which
# measures T_Δ.
CURVE_LEGS_PX = (1 / 16, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0)
# llvmpipe's fragment stamp, pixels: the footprint of a triangle is A + STAMP_PX·(w + h).
STAMP_PX = 4.0


def footprint(area: ArrayLike, width: ArrayLike, height: ArrayLike) -> np.ndarray:
    """Footprint of triangles, pixels: ``area + STAMP_PX·(width + height)`` (16 times the 4×4
    stamps a triangle of that area and screen bounding box touches, less one stamp)."""
    return np.asarray(area, np.float64) + STAMP_PX * (
        np.asarray(width, np.float64) + np.asarray(height, np.float64)
    )


@dataclass(frozen=True)
class PerfConstants:
    """Per-material constants of formulas (2)-(4), measured on one GL context.

    Attributes
    ----------
    resolution : (width, height)
        Pixels of the frames they were measured at (T_frame depends on it).
    material : str
        Vertex + fragment shader the drawing constants belong to.
    threads : int
        llvmpipe rasterizer threads of the process.
    t_frame_ms : float
        Fixed cost of a frame (clear, uniforms, finish), ms.
    t_frag_ns, t_tri_ns, t_cmd_ns, t_state_ns, t_vis_ns, t_buf_ns, t_fc_ns : float
        Per shaded fragment (full-screen), sub-pixel triangle (T_Δ), indirect command, state
        change, node query, recorded command, frustum-tested box; nanoseconds.
    curve_footprint_px : tuple of float
        Triangle footprints of the t(E) curve (:func:`footprint`), pixels, increasing; the
        first is a sub-pixel triangle's.
    curve_ns : tuple of float
        t(E): nanoseconds per triangle of that footprint, its fragments included.
    """

    resolution: tuple[int, int]
    material: str
    threads: int
    t_frame_ms: float
    t_frag_ns: float
    t_tri_ns: float
    t_cmd_ns: float
    t_state_ns: float
    t_vis_ns: float
    t_buf_ns: float
    t_fc_ns: float
    curve_footprint_px: tuple[float, ...] = ()
    curve_ns: tuple[float, ...] = ()

    def __post_init__(self):
        if len(self.curve_footprint_px) != len(self.curve_ns):
            raise ValueError(
                f"curve_footprint_px and curve_ns differ in length: "
                f"{len(self.curve_footprint_px)} vs {len(self.curve_ns)}"
            )
        if np.any(np.diff(self.curve_footprint_px) <= 0):
            raise ValueError(f"curve_footprint_px must increase, got {self.curve_footprint_px}")

    def triangle_ns(self, footprints: np.ndarray) -> np.ndarray:
        """t(E): ns per triangle of footprint ``footprints`` (M,) pixels, fragments included.

        Linear between the measured points; below the first, its value; past the last, the
        last value plus T_frag per extra pixel.
        """
        if not self.curve_ns:
            raise ValueError("these constants have no t(E) curve (paper_only)")
        e = np.asarray(footprints, np.float64)
        xs, ys = np.asarray(self.curve_footprint_px), np.asarray(self.curve_ns)
        t = np.interp(e, xs, ys)
        return np.where(e > xs[-1], ys[-1] + (e - xs[-1]) * self.t_frag_ns, t)

    def paper_only(self) -> PerfConstants:
        """The same constants without t(E): T_vert = N_Δ·T_Δ and T_frag = f·T_frag, the
        paper's (3) and (4) with the full-screen T_frag."""
        return PerfConstants(**{**asdict(self), "curve_footprint_px": (), "curve_ns": ()})

    def as_dict(self) -> dict:
        d = asdict(self)
        d["resolution"] = list(self.resolution)
        d["curve_footprint_px"] = list(self.curve_footprint_px)
        d["curve_ns"] = list(self.curve_ns)
        return d

    @classmethod
    def from_dict(cls, d: Mapping) -> PerfConstants:
        d = dict(d)
        d["resolution"] = tuple(d["resolution"])
        d["curve_footprint_px"] = tuple(d.get("curve_footprint_px", ()))
        d["curve_ns"] = tuple(d.get("curve_ns", ()))
        return cls(**d)


@dataclass(frozen=True)
class Workload:
    """The counts of one frame that formula (2) prices.

    Attributes
    ----------
    commands : int
        Draw commands recorded for S (one per object drawn with multi-draw indirect).
    triangles : int
        N_Δ(S), triangles drawn.
    fragments : float
        f(S), pixels the triangles cover (rasterized fragments).
    state_changes : int
        Pipeline state changes beyond the frame's first, which T_frame holds (0 for one
        material drawn with one multi-draw).
    tested_boxes : int
        Boxes frustum-tested (objects or hierarchy nodes): T_fc.
    node_commands : int
        Commands recorded into the hierarchy's buffers this frame: T_buf(H).
    queries : int
        Occlusion queries on hierarchy nodes: T_zbuffer(H) (their state, vertex and
        fragment costs are inside T_vis, measured as a whole per query).
    triangle_footprints : (triangles,) float64, optional
        :func:`footprint` of every triangle, pixels; without it every triangle counts as a
        right triangle of the mean area ``fragments / triangles``.
    """

    commands: int
    triangles: int
    fragments: float
    state_changes: int = 0
    tested_boxes: int = 0
    node_commands: int = 0
    queries: int = 0
    triangle_footprints: np.ndarray | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        for name in (
            "commands", "triangles", "fragments", "state_changes", "tested_boxes",
            "node_commands", "queries",
        ):  # fmt: skip
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"workload {name} must be finite and >= 0, got {v!r}")
        fp = self.triangle_footprints
        if fp is not None and len(fp) != self.triangles:
            raise ValueError(
                f"triangle_footprints has {len(fp)} entries for {self.triangles} triangles"
            )


@dataclass(frozen=True)
class FrameTime:
    """A prediction of formula (2).

    Attributes
    ----------
    total_ms : float
    terms_ms : dict[str, float]
        ``T_frame``, ``T_buf(S)``, ``T_state(S)``, ``T_vert(S)``, ``T_frag(S)``, ``T_fc(H)``,
        ``T_buf(H)``, ``T_zbuffer(H)``, ms.
    overlap : str
        How the pipeline stages were combined (see :func:`frame_time`).
    """

    total_ms: float
    terms_ms: dict[str, float]
    overlap: str


def frame_time(constants: PerfConstants, work: Workload, overlap: str = "sum") -> FrameTime:
    """Formula (2): the predicted time of a frame doing ``work``, ms.

    Parameters
    ----------
    overlap : {"sum", "llvmpipe", "max"}
        How T_state(S), T_vert(S), T_frag(S) combine. ``"max"``: the paper's form, the
        slowest of the pipelined GPU stages counts. ``"llvmpipe"``: state and vertex work
        share the calling thread and add, fragments run on the rasterizer threads alongside:
        ``max(T_state + T_vert, T_frag)``. ``"sum"``: nothing overlaps. T_frame is added in
        every form.
    """
    check_choice("overlap", overlap, OVERLAPS)
    c, w = constants, work
    ns = 1e-6  # ms per ns
    vert_ns = w.triangles * c.t_tri_ns
    if not c.curve_ns:  # the paper's (3) and (4)
        tri_ns = vert_ns + w.fragments * c.t_frag_ns
    elif w.triangle_footprints is not None:
        tri_ns = float(c.triangle_ns(w.triangle_footprints).sum())
    elif w.triangles:
        leg = math.sqrt(2.0 * w.fragments / w.triangles)
        mean = footprint(leg * leg / 2, leg, leg)
        tri_ns = w.triangles * float(c.triangle_ns(np.array([mean]))[0])
    else:
        tri_ns = 0.0
    terms = {
        "T_frame": c.t_frame_ms,
        "T_buf(S)": w.commands * c.t_buf_ns * ns,
        "T_state(S)": (w.commands * c.t_cmd_ns + w.state_changes * c.t_state_ns) * ns,
        "T_vert(S)": vert_ns * ns,
        "T_frag(S)": max(tri_ns - vert_ns, 0.0) * ns,
        "T_fc(H)": w.tested_boxes * c.t_fc_ns * ns,
        "T_buf(H)": w.node_commands * c.t_buf_ns * ns,
        "T_zbuffer(H)": w.queries * c.t_vis_ns * ns,
    }
    state, vert, frag = terms["T_state(S)"], terms["T_vert(S)"], terms["T_frag(S)"]
    if overlap == "max":
        gpu = max(state, vert, frag)
    elif overlap == "llvmpipe":
        gpu = max(state + vert, frag)
    else:
        gpu = state + vert + frag
    rest = ("T_frame", "T_buf(S)", "T_fc(H)", "T_buf(H)", "T_zbuffer(H)")
    total = gpu + sum(terms[k] for k in rest)
    return FrameTime(float(total), {k: float(v) for k, v in terms.items()}, overlap)


# -- the work of a frame ------------------------------------------------------------------------


def _face_rows(scene: Scene, ids: np.ndarray | None) -> np.ndarray:
    """Rows of ``scene.faces`` belonging to objects ``ids`` (all when None), object order."""
    if ids is None:
        return np.arange(len(scene.faces))
    starts = scene.face_offsets[:-1][ids]
    counts = scene.triangle_counts[ids]
    return np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())


@dataclass(frozen=True)
class ScreenTriangles:
    """Triangles of a draw projected to the screen (:func:`screen_triangles`).

    Attributes
    ----------
    area : (M,) float64
        Screen area of each triangle, pixels.
    width, height : (M,) float64
        Its screen bounding box, pixels, cut to the viewport.
    """

    area: np.ndarray
    width: np.ndarray
    height: np.ndarray

    @property
    def footprint(self) -> np.ndarray:
        """(M,) float64 :func:`footprint` of each triangle, pixels."""
        return footprint(self.area, self.width, self.height)


def screen_triangles(
    scene: Scene, camera: Camera, ids: np.ndarray | None = None, *, chunk: int = 1 << 20
) -> ScreenTriangles:
    """Project the triangles of objects ``ids`` (all when None) with ``camera``, in draw
    order (object after object).

    The area is the projected triangle's times the fraction of its bounding rectangle inside
    the viewport (exact for triangles wholly on screen, an estimate for those cut by its
    edges). A triangle with a vertex closer than the near plane counts as the whole viewport
    (an upper bound; clipping is not modelled).
    """
    if ids is not None:
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        if len(ids) and (ids.min() < 0 or ids.max() >= len(scene)):
            raise ValueError(f"ids must lie in [0, {len(scene)}), got {ids.min()}..{ids.max()}")
    rows = _face_rows(scene, ids)
    owner = np.searchsorted(scene.face_offsets, rows, side="right") - 1
    w_px, h_px = float(camera.width), float(camera.height)
    m = camera.view_proj
    area, width, height = (np.empty(len(rows)) for _ in range(3))
    for s in range(0, len(rows), chunk):  # bounded memory: a loop over chunks, not triangles
        r = rows[s : s + chunk]
        v = scene.vertices[scene.faces[r] + scene.vertex_offsets[owner[s : s + chunk], None]]
        clip = v.astype(np.float64) @ m[[0, 1, 3], :3].T + m[[0, 1, 3], 3]  # (k, 3, 3): x, y, w
        clip_w = clip[..., 2]
        behind = (clip_w < camera.near * (1.0 - 1e-6)).any(axis=1)
        wdiv = np.where(clip_w > 0, clip_w, 1.0)
        px = (clip[..., 0] / wdiv * 0.5 + 0.5) * w_px
        py = (clip[..., 1] / wdiv * 0.5 + 0.5) * h_px
        a = 0.5 * np.abs(
            (px[:, 1] - px[:, 0]) * (py[:, 2] - py[:, 0])
            - (px[:, 2] - px[:, 0]) * (py[:, 1] - py[:, 0])
        )
        x0, x1, y0, y1 = px.min(1), px.max(1), py.min(1), py.max(1)
        bw = np.clip(np.minimum(x1, w_px) - np.maximum(x0, 0.0), 0.0, None)
        bh = np.clip(np.minimum(y1, h_px) - np.maximum(y0, 0.0), 0.0, None)
        box = (x1 - x0) * (y1 - y0)
        frac = np.where(box > 0, bw * bh / np.where(box > 0, box, 1.0), 1.0)
        area[s : s + chunk] = np.where(behind, w_px * h_px, a * frac)
        width[s : s + chunk] = np.where(behind, w_px, bw)
        height[s : s + chunk] = np.where(behind, h_px, bh)
    return ScreenTriangles(area, width, height)


def triangle_areas(scene: Scene, camera: Camera, ids: np.ndarray | None = None) -> np.ndarray:
    """(M,) float64 screen areas of the triangles of objects ``ids`` (all when None), pixels,
    in draw order (see :func:`screen_triangles`). Their sum estimates the fragments the
    rasterizer produces, f(S)."""
    return screen_triangles(scene, camera, ids).area


def scene_workload(scene: Scene, camera: Camera, ids: np.ndarray | None = None) -> Workload:
    """The :class:`Workload` of drawing objects ``ids`` (all when None) of ``scene`` from
    ``camera`` with one multi-draw: one command per object, its triangles with their screen
    areas and footprints (:func:`screen_triangles`), no state change beyond the frame's."""
    ids = np.arange(len(scene)) if ids is None else np.asarray(ids, np.int64).reshape(-1)
    tri = screen_triangles(scene, camera, ids)
    return Workload(
        commands=len(ids),
        triangles=len(tri.area),
        fragments=float(tri.area.sum()),
        triangle_footprints=tri.footprint,
    )


@dataclass(frozen=True)
class FragmentCounts:
    """Fragments of one draw, counted by ``GL_SAMPLES_PASSED`` queries (counts, not times).

    Attributes
    ----------
    rasterized : int
        Fragments the rasterizer produces (depth test off).
    shaded : int
        Fragments that pass the depth test as the objects are drawn (cleared depth, ``<``,
        in draw order): what the fragment shader runs on after early depth testing.
    """

    rasterized: int
    shaded: int


@uses_gl
def count_fragments(renderer, camera: Camera, ids: np.ndarray) -> FragmentCounts:
    """Count the fragments of objects ``ids`` (K,) drawn by ``renderer`` from ``camera`` (see
    :class:`FragmentCounts`): two extra draws, outside any timed frame."""
    import ctypes

    import moderngl

    from soc.gl import raw as glraw

    gl = renderer.glctx.raw
    ctx = renderer.glctx.ctx
    qid = (ctypes.c_uint * 1)()
    gl.glGenQueries(1, qid)  # raw GL: moderngl's Query cannot be released

    def counted(draw: Callable[[], object]) -> int:
        gl.glBeginQuery(glraw.GL_SAMPLES_PASSED, qid[0])
        draw()
        gl.glEndQuery(glraw.GL_SAMPLES_PASSED)
        count = ctypes.c_uint(0)
        gl.glGetQueryObjectuiv(qid[0], glraw.GL_QUERY_RESULT, ctypes.addressof(count))
        return int(count.value)

    def without_depth_test() -> None:
        renderer.fbo.use()
        ctx.enable_only(moderngl.NOTHING)
        renderer.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        renderer.geometry.draw_objects(renderer.program, ids)

    try:
        shaded = counted(lambda: renderer.draw(camera, ids))
        rasterized = counted(without_depth_test)
        return FragmentCounts(rasterized, shaded)
    finally:
        gl.glDeleteQueries(1, qid)


def record_commands(geometry, ids: np.ndarray) -> int:
    """Record and upload the indirect commands of objects ``ids`` (K,): what
    :meth:`SceneGeometry.draw_objects` does before it draws (T_buf). Returns K."""
    ids = np.asarray(ids, dtype=np.int64)
    cmds = np.ascontiguousarray(geometry.commands[ids])
    if cmds.nbytes > geometry.indirect.size:
        geometry.indirect.orphan(cmds.nbytes)
    if len(ids):
        geometry.indirect.write(cmds)
    return len(ids)


# -- timing ---------------------------------------------------------------------------------


def run_interleaved(
    tasks: Mapping[str, Callable[[], float]], rounds: int, *, seed: int = 0, bar=None
) -> dict[str, list[float]]:
    """Time every task ``rounds`` times, one of each per round in a shuffled order, so load
    from other processes falls on every task alike. Each task returns its own time in ms.

    One untimed call of each comes first (shader compilation, buffer growth). ``bar``: a
    tqdm bar advanced once per call. Returns the ``rounds`` times of each task.
    """
    if rounds < 1:
        raise ValueError(f"rounds must be >= 1, got {rounds}")
    names = list(tasks)
    for name in names:
        tasks[name]()
        if bar is not None:
            bar.update(1)
    rng = np.random.default_rng(seed)
    out: dict[str, list[float]] = {name: [] for name in names}
    for _ in range(rounds):
        for k in rng.permutation(len(names)):
            out[names[k]].append(float(tasks[names[k]]()))
            if bar is not None:
                bar.update(1)
    return out


def typical_ms(times: ArrayLike, statistic: str = "min") -> float:
    """The time that stands for repeated timings ``times`` (ms): their minimum (the default),
    the run least disturbed by other processes, or their median.

    Other processes only ever add time, and more of it to long batches than to short ones, so
    under load medians bend the slopes; measured on this shared two-core machine, Table 1's
    held-back error was 5-8 % (median over sizes) with minima in every run against 5-29 %
    with medians. On a quiet machine the two agree.
    """
    check_choice("statistic", statistic, STATISTICS)
    t = np.asarray(times, np.float64)
    if t.size == 0:
        raise ValueError("no timings")
    return float(np.median(t) if statistic == "median" else t.min())


def slope_ns(
    samples: Mapping[str, list[float]],
    name: str,
    items: tuple[float, float],
    statistic: str = "min",
) -> float:
    """ns per item of the pair ``name + ":small"`` / ``name + ":large"`` doing ``items``:
    the difference of their typical times (:func:`typical_ms`) over the difference of the
    items."""
    small, large = items
    if not small < large:
        raise ValueError(f"{name}: need fewer items in the small batch, got {items}")
    t_small = typical_ms(samples[f"{name}:small"], statistic)
    t_large = typical_ms(samples[f"{name}:large"], statistic)
    return 1e6 * (t_large - t_small) / (large - small)


# -- measuring the constants --------------------------------------------------------------------

# Batch sizes (small, large) at scale 1. A large batch takes ~10-30 ms on llvmpipe with two
# cores: long against perf_counter and the fixed costs, short enough to repeat many times.
FRAG_LAYERS = (1, 8)  # full-screen triangles
CURVE_SCREENS = 2.0  # the large batch of a t(E) point covers the screen this many times
CURVE_MAX_TRIANGLES = 100_000  # ... and holds at most this many triangles
CURVE_CHUNKS = 10  # the small batch is one tenth of the large one
TINY_COMMANDS = (2_000, 30_000)  # commands of one tiny triangle each
STATE_CHANGES = (100, 1_500)  # separate draws after a uniform write
NODE_QUERIES = (100, 600)  # occlusion queries on BVH nodes
RECORDED_COMMANDS = (20_000, 400_000)  # indirect commands built and uploaded
TESTED_BOXES = (20_000, 200_000)  # boxes frustum-tested
VIS_SCENE_OBJECTS = 30_000  # the "big scene" of T_vis
TINY_PX = 1 / 16  # edge of a tiny triangle, pixels


@dataclass(frozen=True)
class CalibrationSetup:
    """How the constants are measured.

    Attributes
    ----------
    resolution : (width, height)
        Pixels of the calibration frames; use the resolution the model will predict for.
    repeats : int
        Rounds of :func:`run_interleaved`, ``>= 3``.
    scale : float
        Multiplies every batch size (quick runs: < 1), ``> 0``.
    seed : int
        Placement of the calibration triangles, the T_vis scene, the round order.
    statistic : {"median", "min"}
        What stands for a batch's repeated times (:func:`typical_ms`).
    """

    resolution: tuple[int, int] = (1280, 720)
    repeats: int = 9
    scale: float = 1.0
    seed: int = 0
    statistic: str = "min"

    def __post_init__(self):
        w, h = self.resolution
        if int(w) < 8 or int(h) < 8:
            raise ValueError(f"resolution must be at least 8x8, got {self.resolution}")
        if self.repeats < 3:
            raise ValueError(f"repeats must be >= 3, got {self.repeats}")
        if not (self.scale > 0 and math.isfinite(self.scale)):
            raise ValueError(f"scale must be positive and finite, got {self.scale}")
        check_choice("statistic", self.statistic, STATISTICS)

    def batch(self, pair: tuple[int, int]) -> tuple[int, int]:
        small, large = (max(1, round(v * self.scale)) for v in pair)
        return small, max(large, small + 1)


def calibration_camera(resolution: tuple[int, int]) -> Camera:
    """Looking down -z at the plane z = 0 from z = 10, 60° vertical field of view."""
    w, h = resolution
    return Camera.look_at((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), width=w, height=h, near=1.0, far=50.0)


def _world_per_pixel(resolution: tuple[int, int]) -> float:
    """World units per pixel on the plane z = 0 seen by :func:`calibration_camera`."""
    return 2.0 * 10.0 * math.tan(math.radians(30.0)) / resolution[1]


PATCH_SQUARES = 4  # a calibration patch is PATCH_SQUARES² squares, two triangles each
# World units (at distance 10) over which calibration layers come nearer: small enough that
# the triangles keep their size within 0.5 % (their area within 1 %), large enough that the
# float32 depth of two consecutive layers differs by several steps.
CALIBRATION_DEPTH_RANGE = 0.05


def triangle_grid_scene(
    leg_px: float,
    triangles: int,
    resolution: tuple[int, int],
    chunks: int = CURVE_CHUNKS,
    seed: int = 0,
) -> Scene:
    """``chunks`` objects holding together at least ``triangles`` equal right triangles with
    legs of ``leg_px`` pixels, seen by :func:`calibration_camera` at ``resolution``.

    The triangles come in patches of up to 4×4 squares (two triangles per square, vertices
    shared: 0.78 vertex per triangle, like ordinary meshes) scattered over the whole screen on a
    jittered lattice: llvmpipe bins triangles into 64×64-pixel tiles, and triangles spread over
    many tiles cost up to twice what the same triangles packed into one tile cost (measured),
    even sub-pixel ones. When the screen is full the next layer starts a little nearer, and
    every object is nearer than the objects drawn before it, so every fragment passes ``<``.
    Each object gets every ``chunks``-th patch, so each is spread over the screen too.
    """
    wpp = _world_per_pixel(resolution)
    # 2 % of the screen stays free at its edges: nearer layers project a little larger.
    w, h = 0.98 * resolution[0], 0.98 * resolution[1]
    side_sq = max(1, min(PATCH_SQUARES, int(min(w, h) / leg_px)))  # a patch fits the screen
    per_patch = 2 * side_sq * side_sq
    patches = max(chunks, math.ceil(triangles / per_patch))
    side = side_sq * leg_px  # pixels
    cols_max, rows_max = max(1, int(w / side)), max(1, int(h / side))
    per_layer = min(patches, cols_max * rows_max)
    cols = min(cols_max, max(1, math.ceil(math.sqrt(per_layer * w / h))))
    rows = min(rows_max, math.ceil(per_layer / cols))
    cols = max(cols, math.ceil(per_layer / rows))
    rng = np.random.default_rng(seed)
    k = np.arange(patches)
    cell, layer = k % per_layer, k // per_layer
    # Lower-left corner of each patch, pixels from the screen centre: its lattice cell, jittered
    # inside the room the cell leaves around the patch.
    cw, ch = w / cols, h / rows
    px = (cell % cols) * cw + rng.uniform(0, 1, patches) * max(cw - side, 0.0) - w / 2
    py = (cell // cols) * ch + rng.uniform(0, 1, patches) * max(ch - side, 0.0) - h / 2
    n_layers = int(layer.max()) + 1
    dz = CALIBRATION_DEPTH_RANGE / (chunks * n_layers)  # ≥ several depth-buffer steps
    j, i = np.meshgrid(np.arange(side_sq + 1), np.arange(side_sq + 1), indexing="ij")
    grid = np.stack([i.ravel(), j.ravel()], axis=1) * leg_px  # (V, 2) pixels in a patch
    a = (j[:-1, :-1] * (side_sq + 1) + i[:-1, :-1]).ravel()
    faces = np.concatenate([np.stack([a, a + 1, a + side_sq + 2], 1),
                            np.stack([a, a + side_sq + 2, a + side_sq + 1], 1)])  # fmt: skip
    n_vert = len(grid)
    meshes = []
    for c in range(chunks):  # a loop over the few objects, not over triangles
        mine = k[c::chunks]
        z = dz * (c * n_layers + layer[mine])  # increases along the draw order
        xy = (np.stack([px[mine], py[mine]], 1)[:, None, :] + grid) * wpp
        v = np.concatenate([xy, np.broadcast_to(z[:, None, None], (len(mine), n_vert, 1))], -1)
        f = faces[None] + n_vert * np.arange(len(mine))[:, None, None]
        meshes.append((v.reshape(-1, 3).astype(np.float32), f.reshape(-1, 3).astype(np.int32)))
    return Scene.from_meshes(meshes)


def tiny_triangle_scene(n: int, resolution: tuple[int, int], seed: int = 0) -> Scene:
    """``n`` objects of one sub-pixel triangle each, scattered over the calibration view."""
    rng = np.random.default_rng(seed)
    leg = TINY_PX * _world_per_pixel(resolution)
    corner = np.c_[rng.uniform(-4.0, 4.0, (n, 2)), np.zeros(n)]
    offsets = np.array([[0.0, 0.0, 0.0], [leg, 0.0, 0.0], [0.0, leg, 0.0]])
    v = (corner[:, None, :] + offsets).reshape(-1, 3).astype(np.float32)
    f = np.zeros((n, 3), np.int32) + np.arange(3, dtype=np.int32)
    return Scene(v, f, np.full(n, 3), np.ones(n, np.int64), np.zeros(n, bool))


def layer_scene(layers: int) -> Scene:
    """``layers`` objects, each one triangle covering the whole calibration view, object
    ``i`` nearer to the camera than object ``i - 1`` (so every layer passes ``<``)."""
    base = np.array([[-200.0, -200.0, 0.0], [600.0, -200.0, 0.0], [-200.0, 600.0, 0.0]])
    z = 0.01 * np.arange(layers)
    v = (base[None] + np.c_[np.zeros((layers, 2)), z][:, None, :]).reshape(-1, 3)
    f = np.zeros((layers, 3), np.int32) + np.arange(3, dtype=np.int32)
    return Scene(v.astype(np.float32), f, np.full(layers, 3), np.ones(layers, np.int64),
                 np.zeros(layers, bool))  # fmt: skip


@uses_gl
class Calibration:
    """The calibration batches of one :class:`CalibrationSetup`, ready to be timed.

    ``tasks`` maps names to functions that do one batch and return its time in ms (a pair
    ``<constant>:small`` / ``<constant>:large`` per constant, ``t_frame`` alone); time them
    with :func:`run_interleaved` (alone or among other tasks) and turn the times into
    :class:`PerfConstants` with :meth:`constants`. Owns GL resources: call :meth:`close`.
    """

    def __init__(self, setup: CalibrationSetup | None = None, glctx=None):
        from soc.gl.context import default_context

        self.setup = setup or CalibrationSetup()
        self.glctx = glctx or default_context()
        self.resolution = (int(self.setup.resolution[0]), int(self.setup.resolution[1]))
        self.camera = calibration_camera(self.resolution)
        self.tasks: dict[str, Callable[[], float]] = {}
        self.items: dict[str, tuple[float, float]] = {}
        self._owned: list = []
        try:
            self._frame()
            self._frag()
            self._curve()
            self._commands()
            self._state()
            self._vis()
            self._buf()
            self._fc()
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Release every GL resource the calibration allocated."""
        for thing in reversed(self._owned):
            thing.release()
        self._owned.clear()

    # -- resources ----------------------------------------------------------------------------

    def _geometry(self, scene: Scene):
        # Uploaded here and released in close(), not through glctx.geometry(): the context's
        # cache keeps every scene it uploaded alive for the life of the process.
        from soc.gl.geometry import SceneGeometry

        g = SceneGeometry(self.glctx, scene)
        self._owned.append(g)
        return g

    def _renderer(self, scene: Scene):
        from soc.rendering.renderer import Renderer

        r = Renderer(self._geometry(scene), self.resolution)
        self._owned.append(r)
        return r

    def _pair(self, name: str, run: Callable[[int], float], items: tuple[int, int]) -> None:
        glctx = self.glctx

        def task(k: int) -> Callable[[], float]:
            def timed() -> float:  # run later, from anyone's code: makes the context current
                with glctx.current():
                    return run(k)

            return timed

        self.tasks[f"{name}:small"] = task(items[0])
        self.tasks[f"{name}:large"] = task(items[1])
        self.items[name] = (float(items[0]), float(items[1]))

    def _draws(self, renderer) -> Callable[[int], float]:
        """``run(k)``: a timed frame drawing the first ``k`` objects of ``renderer``."""
        ids = np.arange(len(renderer.geometry.scene))
        return lambda k: renderer.draw(self.camera, ids[:k])

    # -- one batch pair per constant ----------------------------------------------------------

    def _frame(self) -> None:
        r = self._renderer(tiny_triangle_scene(1, self.resolution))
        one = np.zeros(1, np.int64)  # its own T_cmd + T_Δ (< 1 µs) stay in T_frame
        self.tasks["t_frame"] = lambda: r.draw(self.camera, one)

    def _frag(self) -> None:
        # Never fewer layers than at scale 1: at scale 0.25 the pair was 1 and 2 full-screen
        # layers, whose difference (one layer, 0.01-0.05 ms at 320×180) is within the timing
        # noise, and t_frag came out negative in a CI run. Extra layers cost little.
        small, large = self.setup.batch(FRAG_LAYERS)
        layers = (small, max(large, FRAG_LAYERS[1]))
        r = self._renderer(layer_scene(layers[1]))
        self._pair("t_frag", self._draws(r), layers)

    def _curve(self) -> None:
        w, h = self.resolution
        self.curve_footprint_px: list[float] = []
        for i, leg in enumerate(CURVE_LEGS_PX):
            area = leg * leg / 2
            budget = CURVE_SCREENS * w * h / area * self.setup.scale
            n = max(2 * CURVE_CHUNKS, int(min(budget, CURVE_MAX_TRIANGLES * self.setup.scale)))
            scene = triangle_grid_scene(leg, n, self.resolution, seed=self.setup.seed)
            per_chunk = int(scene.triangle_counts[0])
            self._pair(f"curve{i}", self._draws(self._renderer(scene)), (1, CURVE_CHUNKS))
            self.items[f"curve{i}"] = (float(per_chunk), float(CURVE_CHUNKS * per_chunk))
            self.curve_footprint_px.append(float(footprint(area, leg, leg)))

    def _commands(self) -> None:
        n = self.setup.batch(TINY_COMMANDS)
        r = self._renderer(tiny_triangle_scene(n[1], self.resolution, self.setup.seed))
        self._pair("t_cmd", self._draws(r), n)

    def _state(self) -> None:
        import moderngl

        n = self.setup.batch(STATE_CHANGES)
        r = self._renderer(tiny_triangle_scene(n[1], self.resolution, self.setup.seed))
        ctx, program, camera = self.glctx.ctx, r.program, self.camera
        vao = r.geometry.mesh_vao(program)
        light = program["light_dir"]
        directions = [(0.4, 0.8, 0.3), (0.3, 0.8, 0.4)]

        def run(k: int) -> float:
            t0 = time.perf_counter()
            r.fbo.use()
            r.fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            ctx.enable_only(moderngl.DEPTH_TEST)
            program["view_proj"].write(camera.gl_bytes(camera.view_proj))
            for i in range(k):  # the state change under test: a uniform between two draws
                light.value = directions[i & 1]
                vao.render(moderngl.TRIANGLES, vertices=3, first=3 * i)
            ctx.finish()
            return 1e3 * (time.perf_counter() - t0)

        self._pair("t_state", run, n)

    def _vis(self) -> None:
        from soc.culling.box_queries import BoxQueries
        from soc.culling.bvh import build
        from soc.scenes.random_boxes import overview_camera, random_boxes

        objects = max(1000, int(VIS_SCENE_OBJECTS * self.setup.scale))
        scene = random_boxes(objects, self.setup.seed)
        camera = overview_camera(scene, *self.resolution)
        r = self._renderer(scene)
        nodes = build(scene.aabbs).boxes
        small, large = self.setup.batch(NODE_QUERIES)
        large = min(large, len(nodes))
        pick = np.random.default_rng(self.setup.seed).permutation(len(nodes))[:large]
        diagonal = scene.diagonal
        queries = BoxQueries(self.glctx, diagonal)
        self._owned.append(queries)
        r.draw(camera, np.arange(len(scene)))  # the depth buffer the nodes are tested against

        def run(k: int) -> float:
            t0 = time.perf_counter()
            queries.issue(r, camera, nodes[pick[:k]]).results()
            self.glctx.finish()
            return 1e3 * (time.perf_counter() - t0)

        self._pair("t_vis", run, (min(small, large - 1), large))

    def _buf(self) -> None:
        n = self.setup.batch(RECORDED_COMMANDS)
        geometry = self._geometry(tiny_triangle_scene(n[1], self.resolution, self.setup.seed))
        ids = np.arange(n[1])

        def run(k: int) -> float:
            t0 = time.perf_counter()
            record_commands(geometry, ids[:k])
            self.glctx.finish()
            return 1e3 * (time.perf_counter() - t0)

        self._pair("t_buf", run, n)

    def _fc(self) -> None:
        from soc.culling.frustum import aabbs_in_frustum

        n = self.setup.batch(TESTED_BOXES)
        rng = np.random.default_rng(self.setup.seed)
        lo = rng.uniform(-20.0, 20.0, (n[1], 3))
        boxes = np.stack([lo, lo + rng.uniform(0.1, 2.0, (n[1], 3))], axis=1).astype(np.float32)
        camera = self.camera

        def run(k: int) -> float:
            t0 = time.perf_counter()
            aabbs_in_frustum(boxes[:k], camera)
            return 1e3 * (time.perf_counter() - t0)

        self._pair("t_fc", run, n)

    # -- times → constants ----------------------------------------------------------------

    def constants(self, samples: Mapping[str, list[float]]) -> PerfConstants:
        """:class:`PerfConstants` from the times of :attr:`tasks` (as :func:`run_interleaved`
        returns them)."""
        missing = [k for k in self.tasks if not samples.get(k)]
        if missing:
            raise ValueError(f"no times for calibration tasks {missing}")
        stat = self.setup.statistic
        s = {name: slope_ns(samples, name, items, stat) for name, items in self.items.items()}
        pixels = self.resolution[0] * self.resolution[1]
        # A larger footprint never costs less: noise that says otherwise is flattened.
        curve = np.maximum.accumulate([s[f"curve{i}"] for i in range(len(CURVE_LEGS_PX))])
        t_tri = float(curve[0])
        t_buf = s["t_buf"]
        return PerfConstants(
            resolution=self.resolution,
            material=" + ".join(MATERIAL),
            threads=int(self.glctx.threads),
            t_frame_ms=typical_ms(samples["t_frame"], stat),
            t_frag_ns=s["t_frag"] / pixels,
            t_tri_ns=t_tri,
            t_cmd_ns=s["t_cmd"] - t_tri - t_buf,  # beyond its one triangle and its recording
            t_state_ns=s["t_state"] - t_tri,  # beyond its one triangle
            t_vis_ns=s["t_vis"],
            t_buf_ns=t_buf,
            t_fc_ns=s["t_fc"],
            curve_footprint_px=tuple(self.curve_footprint_px),
            curve_ns=tuple(float(t) for t in curve),
        )


@uses_gl
def measure_constants(
    setup: CalibrationSetup | None = None, *, glctx=None, progress: bool = False
) -> PerfConstants:
    """Measure every constant of :class:`PerfConstants` on the GL context (see the module
    docstring for how each is measured); a few seconds at scale 1.

    Parameters
    ----------
    setup : CalibrationSetup, optional
        Resolution, repeats and batch scale (default: 1280x720, 9 rounds, scale 1).
    glctx : GLContext, optional
        Default: the process-wide context.
    progress : bool
        Show a tqdm bar over the timed batches.
    """
    cal = Calibration(setup, glctx)
    bar = None
    try:
        if progress:
            from tqdm import tqdm

            total = len(cal.tasks) * (cal.setup.repeats + 1)
            bar = tqdm(total=total, desc="perf-model constants", unit="batch")
        samples = run_interleaved(cal.tasks, cal.setup.repeats, seed=cal.setup.seed, bar=bar)
        return cal.constants(samples)
    finally:
        if bar is not None:
            bar.close()
        cal.close()
