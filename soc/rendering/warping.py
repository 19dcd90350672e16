"""Image warping: stereo from one rendered eye, and the decoupled warping renderer in miniature.

G. Zachmann, VR lecture, real-time rendering (seed 001, "Stereo ohne 2x rendern" and
"Entkopple Simulation, Rendering und Geräte-Abfrage" [2009]): render one frame with colour,
depth and a per-pixel object id; later frames (the other eye, or a newer camera and newer
object transforms) are produced by moving every pixel, not by rendering the polygons again.
The lecture's server draws one ``GL_POINT`` per pixel of the application frame from a vertex
shader ("geht nicht im Fragment-Shader, da dort Output-Pos. festgelegt ist"), which is what
happens here too; the depth test decides which of several pixels landing on one target pixel
is seen. Pixels nothing lands on are holes ("Löcher!").

Stages, in the order a frame runs them:

1. :meth:`FrameRenderer.render` — the application frame (client): every object's mesh moved
   by its world <- object transform, shaded as :class:`soc.rendering.renderer.Renderer` shades,
   into a
   colour, a depth and an object-id texture (``warp_gbuffer.*.glsl``). It remembers the camera
   and transforms, as the lecture's client stores ``T_{t1,cam<-img}``, ``T_{t1,wld<-cam}``
   and every ``T^i_{t1,wld<-obj}``.
2. :func:`warp_matrices` — per object one 4x4 matrix from the old image to the new clip
   space, ``T_{t2,img<-cam} T_{t2,cam<-wld} T^i_{t2,wld<-obj} (T^i_{t1,wld<-obj})^-1
   T_{t1,wld<-cam} T_{t1,cam<-img}``, precomputed once per server frame as the lecture says;
   the background (sky) warps as a direction (a point at infinity).
3. :meth:`Warper.reproject` (general 3D warp) or :meth:`Warper.stereo` (the parallel stereo
   rig: a shift along the scanline by the disparity ``f·b/z``) — one splat of a chosen size
   per source pixel, both maps in ``warp_map.common.glsl``; drawn as ``GL_POINTS``
   (``warp_splat.*.glsl``, the lecture's way) or scattered by compute shaders
   (``warp_scatter.comp.glsl``, ``warp_resolve.comp.glsl``; no point rasterization, the
   slow part on llvmpipe).
4. :func:`compare` — holes, pixels showing the wrong object (by id) and the colour error
   against a true render of the new view; :func:`outside_source_view` tells border holes
   (never in the old view) from disoccluded or undersampled ones.

The lecture's stereo formula ``x'_k = x_k + (i/Δ)·z_k/(z_k + z0)`` (eye distance i, pixel
width Δ, screen at distance z0, z_k behind the screen) is the disparity of a rig converged
at the screen: ``i/Δ - f·i/(z_k + z0)`` with f = z0/Δ, i.e. the parallel rig's disparity
``f·b/z`` (b = i, z = z_k + z0) up to its sign convention and the constant ``i/Δ``, a fixed
horizontal image shift; holes and errors are the same.
"""

from __future__ import annotations

import ctypes
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from soc.culling.oracle import NO_OBJECT
from soc.errors import check_choice
from soc.gl.context import ReleasedOnExit, shader_source, uses_gl
from soc.gl.raw import GL_COLOR
from soc.gl.shader_defines import (
    BACKGROUND_WARP_ROW,
    MODELS_BINDING,
    NEAREST_BINDING,
    OUT_COLOR_IMAGE,
    OUT_DEPTH_IMAGE,
    OUT_IDS_IMAGE,
    PIXEL_GROUP,
    SPLATS_BINDING,
    STATIC_WARP_ROW,
    WARP_ROWS_BINDING,
    WARPS_BINDING,
    WINNER_BINDING,
)
from soc.rendering.renderer import LIGHT_DIR, SKY
from soc.scenes.camera import Camera, _resolution

# Object id of a warped pixel that no splat reached (the id texture is cleared to it).
HOLE = 0xFFFFFFFE

# Normalized device depth of background splats: behind every object that the depth buffer can
# hold, yet in front of the far plane after the perspective divide's rounding and the 24-bit
# depth buffer's quantization (8 steps of 2^-24 in window depth before the clear value 1.0).
BACKGROUND_NDC_Z = 1.0 - 2.0**-20

# Colour of holes in warped images (the target is cleared to it).
HOLE_COLOR = (0.0, 0.0, 0.0, 1.0)

# Row of :func:`warp_table` holding the first moved object's matrix (after the shared ones).
_FIRST_MOVED_ROW = max(STATIC_WARP_ROW, BACKGROUND_WARP_ROW) + 1


# -- results ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Frame:
    """A frame read back from the GL: colour, depth and object id per pixel, top row first.

    Attributes
    ----------
    color : (H, W, 3) uint8
    depth : (H, W) float32
        Window depth in [0, 1]: 1.0 for background in renders and for holes; warped
        background splats lie just in front of it (``BACKGROUND_NDC_Z``).
    ids : (H, W) uint32
        Object id per pixel; ``NO_OBJECT`` for background, ``HOLE`` where no splat landed
        (warped frames only).
    """

    color: np.ndarray
    depth: np.ndarray
    ids: np.ndarray

    @property
    def resolution(self) -> tuple[int, int]:
        """(width, height) pixels."""
        return (self.ids.shape[1], self.ids.shape[0])

    @classmethod
    def read(cls, color, depth, ids) -> Frame:
        """Read back the GL textures ``color`` (RGBA8), ``depth`` (R32F) and ``ids`` (R32UI)
        of one size, flipped to top row first."""
        w, h = color.size
        rgba = np.frombuffer(color.read(), np.uint8).reshape(h, w, 4)
        z = np.frombuffer(depth.read(), np.float32).reshape(h, w)
        i = np.frombuffer(ids.read(), np.uint32).reshape(h, w)
        return cls(rgba[::-1, :, :3].copy(), z[::-1].copy(), i[::-1].copy())


@dataclass(frozen=True)
class WarpError:
    """How far a warped frame is from the true render of its view (:func:`compare`).

    Attributes
    ----------
    pixels : int
        Pixels of the frame.
    holes : int
        Pixels no splat landed on.
    wrong_objects : int
        Covered pixels whose object id differs from the true render's (background counts as
        an object: sky where an object should be, or the reverse, is wrong too).
    color_mae : float
        Mean absolute colour difference over covered pixels and the three channels, in 8-bit
        units (0-255); NaN when every pixel is a hole.
    """

    pixels: int
    holes: int
    wrong_objects: int
    color_mae: float

    @property
    def hole_pct(self) -> float:
        """Holes in percent of all pixels."""
        return 100.0 * self.holes / self.pixels

    @property
    def wrong_object_pct(self) -> float:
        """Wrong-object pixels in percent of all pixels (so holes + wrong + right = 100 %)."""
        return 100.0 * self.wrong_objects / self.pixels

    def as_row(self) -> dict[str, Any]:
        """Flat dict for CSV rows."""
        return {
            "pixels": self.pixels,
            "holes": self.holes,
            "hole_pct": self.hole_pct,
            "wrong_objects": self.wrong_objects,
            "wrong_object_pct": self.wrong_object_pct,
            "color_mae": self.color_mae,
        }


def compare(warped: Frame, truth: Frame) -> WarpError:
    """Holes, wrong-object pixels and colour error of ``warped`` against ``truth``.

    Parameters
    ----------
    warped : Frame
        Output of :class:`Warper` (holes marked ``HOLE``).
    truth : Frame
        A render of the same view (:class:`FrameRenderer`), same resolution.
    """
    if warped.ids.shape != truth.ids.shape:
        raise ValueError(
            f"frames differ in size: warped {warped.resolution}, truth {truth.resolution}"
        )
    covered = warped.ids != HOLE
    wrong = covered & (warped.ids != truth.ids)
    diff = np.abs(warped.color.astype(np.int16) - truth.color.astype(np.int16))
    n = int(covered.sum())
    mae = float(diff[covered].mean()) if n else float("nan")
    return WarpError(int(warped.ids.size), int(warped.ids.size - n), int(wrong.sum()), mae)


# -- cameras and matrices -----------------------------------------------------------------------


def focal_length_px(camera: Camera) -> float:
    """The camera's focal length in pixels, ``(height / 2) / tan(fov_y / 2)``."""
    return 0.5 * camera.height / math.tan(math.radians(camera.fov_y) / 2.0)


def stereo_camera(camera: Camera, separation: float) -> Camera:
    """The other eye of a parallel stereo rig: ``camera`` moved by ``separation`` world units
    along its image x axis (right for positive values), same orientation and projection."""
    if not math.isfinite(separation):
        raise ValueError(f"separation must be finite, got {separation}")
    shift = float(separation) * camera.basis[0]
    return camera.replace(
        eye=tuple(np.add(camera.eye, shift)), target=tuple(np.add(camera.target, shift))
    )


def identity_transforms(n: int) -> np.ndarray:
    """(n, 4, 4) float64 identity matrices: every object where the scene has it."""
    return np.broadcast_to(np.eye(4), (n, 4, 4)).copy()


def _transforms(transforms: Any, n: int) -> np.ndarray:
    if transforms is None:
        return identity_transforms(n)
    t = np.asarray(transforms, dtype=np.float64)
    if t.shape != (n, 4, 4):
        raise ValueError(f"transforms must have shape ({n}, 4, 4), got {t.shape}")
    if not np.isfinite(t).all():
        raise ValueError("transforms must be finite")
    return t


def _changed(t_old: np.ndarray, t_new: np.ndarray) -> np.ndarray:
    """Ids of the objects whose (N, 4, 4) transforms differ, compared as floats."""
    neq = np.not_equal(t_old, t_new).reshape(len(t_old), 16).view(np.uint64)  # 16 bools: 2 words
    return np.flatnonzero(neq[:, 0] | neq[:, 1])


def warp_matrices(
    old_camera: Camera,
    new_camera: Camera,
    old_transforms: np.ndarray | None = None,
    new_transforms: np.ndarray | None = None,
) -> np.ndarray:
    """Per-object matrices from the old frame's normalized device coordinates to the new
    camera's clip space, plus one for the background.

    Parameters
    ----------
    old_camera, new_camera : Camera
    old_transforms, new_transforms : (N, 4, 4) float, optional
        World <- object transforms of every object when the old frame was rendered and now;
        default identity (a static scene). N is taken from whichever is given.

    Returns
    -------
    (N + 1, 4, 4) float64
        Row i < N: ``VP_new · T_new[i] · T_old[i]^-1 · VP_old^-1`` (objects whose transform
        did not change share ``VP_new · VP_old^-1``). Row N, the background: the old pixel's
        direction rotated into the new camera (translation ignored: the sky is at infinity),
        ``P_new · [R_new R_old^T, 0; 0, 0] · P_old^-1``; its clip z is meaningless and is
        replaced by the shader.
    """
    table, rows = warp_table(old_camera, new_camera, old_transforms, new_transforms)
    return np.concatenate([table[rows], table[BACKGROUND_WARP_ROW : BACKGROUND_WARP_ROW + 1]])


def warp_table(
    old_camera: Camera,
    new_camera: Camera,
    old_transforms: np.ndarray | None = None,
    new_transforms: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`warp_matrices` without repeats: the distinct matrices and each object's row.

    Returns
    -------
    table : (2 + M, 4, 4) float64
        Row ``STATIC_WARP_ROW`` (0): ``VP_new · VP_old^-1``, shared by every object whose
        transform did not change; row ``BACKGROUND_WARP_ROW`` (1): the background's; then
        one row per object whose transform changed (M of them, ascending id).
    rows : (N,) uint32
        Each object's row of ``table``.
    """
    given = [t for t in (old_transforms, new_transforms) if t is not None]
    n = len(np.asarray(given[0])) if given else 0
    t_old, t_new = _transforms(old_transforms, n), _transforms(new_transforms, n)
    back = np.linalg.inv(old_camera.view_proj)
    moved = _changed(t_old, t_new)
    table = np.empty((_FIRST_MOVED_ROW + len(moved), 4, 4))
    table[STATIC_WARP_ROW] = new_camera.view_proj @ back
    rotate = np.zeros((4, 4))
    rotate[:3, :3] = new_camera.basis @ old_camera.basis.T
    table[BACKGROUND_WARP_ROW] = (
        new_camera.projection @ rotate @ np.linalg.inv(old_camera.projection)
    )
    rows = np.full(n, STATIC_WARP_ROW, np.uint32)
    if len(moved):
        if (np.abs(np.linalg.det(t_old[moved])) < 1e-12).any():
            bad = int(moved[np.abs(np.linalg.det(t_old[moved])) < 1e-12][0])
            raise ValueError(f"old transform of object {bad} is singular: {t_old[bad].tolist()}")
        delta = t_new[moved] @ np.linalg.inv(t_old[moved])
        table[_FIRST_MOVED_ROW:] = new_camera.view_proj @ delta @ back
        rows[moved] = _FIRST_MOVED_ROW + np.arange(len(moved), dtype=np.uint32)
    return table, rows


def _with_defines(source: str, defines: dict[str, int]) -> str:
    """``source`` with a ``#define`` line for each of ``defines`` after its ``#version``."""
    head, rest = source.split("\n", 1)
    return "\n".join([head, *(f"#define {k} {v}" for k, v in defines.items()), rest])


def _upload(buffer, array: np.ndarray, dtype) -> None:
    """Write ``array`` as ``dtype`` to the start of ``buffer``, growing it when too small."""
    data = np.ascontiguousarray(array, dtype=dtype)
    if data.nbytes > buffer.size:
        buffer.orphan(data.nbytes)
    if data.nbytes:
        buffer.write(data)


def outside_source_view(
    truth: Frame,
    old_camera: Camera,
    new_camera: Camera,
    old_transforms: np.ndarray | None = None,
    new_transforms: np.ndarray | None = None,
) -> np.ndarray:
    """(H, W) bool: pixels of the new view whose surface point lay outside the old camera's
    view volume, so no warp of the old frame can fill them (the lecture's "leere Stellen an
    den Rändern"; its remedy: a wider client frustum).

    The point of each pixel is taken from ``truth`` (a render of the new view: depth and
    object id), carried back by the inverse warp (:func:`warp_matrices` from the new camera
    and transforms to the old ones) and tested against the old clip volume; background pixels
    only by direction.
    """
    h, w = truth.ids.shape
    given = [t for t in (old_transforms, new_transforms) if t is not None]
    if given:
        n = len(given[0])
    else:  # a static scene: enough (identity) rows for the ids present
        objects = truth.ids[truth.ids != NO_OBJECT]
        n = int(objects.max()) + 1 if objects.size else 0
    back = warp_matrices(
        new_camera,
        old_camera,
        _transforms(new_transforms, n),
        _transforms(old_transforms, n),
    )
    ys, xs = np.mgrid[0:h, 0:w]
    ndc = np.stack(
        [
            (xs + 0.5) / w * 2.0 - 1.0,
            1.0 - (ys + 0.5) / h * 2.0,  # frames are top row first
            2.0 * truth.depth.astype(np.float64) - 1.0,
            np.ones((h, w)),
        ],
        axis=-1,
    )
    sky = truth.ids == NO_OBJECT
    clip = np.einsum("hwij,hwj->hwi", back[np.where(sky, n, truth.ids)], ndc)
    cw = clip[..., 3]
    inside = (cw > 0) & (np.abs(clip[..., 0]) <= cw) & (np.abs(clip[..., 1]) <= cw)
    inside &= sky | (np.abs(clip[..., 2]) <= cw)
    return ~inside


# -- GL frames ----------------------------------------------------------------------------------


class _Target:
    """Colour (RGBA8), object id (R32UI) and depth textures of one frame: a framebuffer with a
    depth attachment, or (``depth_attachment=False``, written by compute shaders) an R32F
    depth texture and no framebuffer."""

    def __init__(self, glctx, resolution: tuple[int, int], depth_attachment: bool = True):
        import moderngl

        self.glctx = glctx
        self.resolution = _resolution(*resolution)
        ctx = glctx.ctx
        self.color = ctx.texture(self.resolution, 4)
        self.ids = ctx.texture(self.resolution, 1, dtype="u4")
        if depth_attachment:
            self.depth = ctx.depth_texture(self.resolution)
            self.depth.compare_func = ""  # sampled as raw depth by warping and compositing
        else:
            self.depth = ctx.texture(self.resolution, 1, dtype="f4")
        for t in (self.color, self.ids, self.depth):
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = None
        if depth_attachment:
            self.fbo = ctx.framebuffer(
                color_attachments=[self.color, self.ids], depth_attachment=self.depth
            )

    def release(self) -> None:
        if self.fbo is not None:
            self.glctx.release_framebuffer(self.fbo, self.color, self.ids, self.depth)
        else:
            for t in (self.color, self.ids, self.depth):
                t.release()

    def clear(self, color: tuple[float, ...], object_id: int) -> None:
        """Bind the framebuffer and clear colour, ids and depth (1.0)."""
        self.fbo.use()
        self.fbo.depth_mask = True
        raw = self.glctx.raw
        raw.glClearBufferfv(GL_COLOR, 0, (ctypes.c_float * 4)(*color))
        raw.clear_uint_color(object_id, draw_buffer=1)
        raw.clear_depth(1.0)

    def read(self) -> Frame:
        """The three textures as a :class:`Frame` (top row first)."""
        return Frame.read(self.color, self.depth, self.ids)


@uses_gl
class FrameRenderer(ReleasedOnExit):
    """The application frame of the warping renderer: colour, depth and object id of a scene.

    Objects are drawn in ascending id order with depth test LESS (the first fragment at the
    nearest depth wins), shaded like :class:`soc.rendering.renderer.Renderer`, each moved by its
    world
    <- object transform.

    Parameters
    ----------
    scene : Scene
    resolution : (width, height)
        Pixels; cameras given to :meth:`render` must have this resolution.
    glctx : GLContext, optional
        Default: the process's context.

    Attributes
    ----------
    camera : Camera or None
        The camera of the last :meth:`render`.
    transforms : (N, 4, 4) float64 or None
        The transforms of the last :meth:`render`.
    color, depth, ids : moderngl textures
        The last frame on the GL (RGBA8, depth, R32UI; row 0 at the bottom).
    """

    def __init__(self, scene, resolution: tuple[int, int], glctx=None):
        from soc.gl.context import default_context

        self.scene = scene
        self.glctx = glctx or default_context()
        self.geometry = self.glctx.geometry(scene)
        self.target = _Target(self.glctx, resolution)
        self.resolution = self.target.resolution
        self.program = self.glctx.program("warp_gbuffer.vert", "warp_gbuffer.frag")
        self.models = self.glctx.ctx.buffer(reserve=64 * len(scene), dynamic=True)
        self._all = np.arange(len(scene))
        self.camera: Camera | None = None
        self.transforms: np.ndarray | None = None

    color = property(lambda self: self.target.color)
    depth = property(lambda self: self.target.depth)
    ids = property(lambda self: self.target.ids)

    def release(self) -> None:
        self.target.release()
        self.models.release()

    def render(
        self,
        camera: Camera,
        transforms: np.ndarray | None = None,
        objects: np.ndarray | None = None,
    ) -> float:
        """Render ``objects`` (default all) from ``camera``; returns the wall time in ms
        (transforms uploaded, drawn and finished).

        Parameters
        ----------
        camera : Camera
            Must have :attr:`resolution`.
        transforms : (N, 4, 4) float, optional
            World <- object transform per object; default identity.
        objects : (K,) int, optional
            A subset of object ids (drawn in ascending order); default every object.
        """
        import moderngl

        if camera.resolution != self.resolution:
            raise ValueError(
                f"camera resolution {camera.resolution} differs from the renderer's "
                f"{self.resolution}"
            )
        n = len(self.scene)
        t = _transforms(transforms, n)
        if objects is None:
            ids = self._all
        else:
            ids = np.unique(np.asarray(objects, dtype=np.int64).reshape(-1))
            if len(ids) and (ids[0] < 0 or ids[-1] >= n):
                raise ValueError(f"object ids must be in [0, {n}), got {ids[0]}..{ids[-1]}")
        ctx = self.glctx.ctx
        t0 = time.perf_counter()
        # GLSL mat4 is column-major: the transposed matrices, as float32 bytes.
        self.models.write(np.ascontiguousarray(t.transpose(0, 2, 1), dtype=np.float32))
        self.target.clear((*SKY, 1.0), NO_OBJECT)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        p = self.program
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        p["light_dir"].value = LIGHT_DIR
        p["eye"].value = tuple(camera.eye)
        self.models.bind_to_storage_buffer(MODELS_BINDING)
        self.geometry.draw_objects(p, ids)
        ctx.finish()
        ms = 1e3 * (time.perf_counter() - t0)
        self.glctx.check("frame render")
        self.camera, self.transforms = camera, t
        return ms

    def frame(self) -> Frame:
        """The last render read back (top row first)."""
        return self.target.read()


@uses_gl
class Warper(ReleasedOnExit):
    """The warping server: one splat per pixel of a :class:`FrameRenderer`'s last frame,
    moved to a newer camera (:meth:`reproject`) or to the other eye (:meth:`stereo`).

    Parameters
    ----------
    resolution : (width, height)
        Pixels of the warped frame; equal to the source frame's.
    engine : {"points", "scatter"}
        ``"points"``: the lecture's implementation, one ``GL_POINT`` per source pixel drawn
        with a depth test. ``"scatter"``: the same splats written by compute shaders (the
        nearest depth per target pixel by ``atomicMin``, then the smallest source index at
        that depth, then a gather), which skips point rasterization, the slow part on a CPU
        rasterizer. Both keep, per target pixel, the nearest splat and on equal depth the
        smallest source index; the point engine compares the 24-bit depth buffer's values,
        the scatter engine float32 depths, so they can differ where two splats' depths round
        to one 24-bit value.
    glctx : GLContext, optional
        Default: the process's context.

    Attributes
    ----------
    color, depth, ids : moderngl textures
        The last warped frame: RGBA8, window depth (a depth texture for ``points``, R32F for
        ``scatter``), R32UI ids (``HOLE`` where no splat landed, ``NO_OBJECT`` for background
        splats); row 0 at the bottom.
    """

    ENGINES = ("points", "scatter")

    def __init__(self, resolution: tuple[int, int], engine: str = "points", glctx=None):
        import moderngl

        from soc.gl.context import default_context

        check_choice("engine", engine, self.ENGINES)
        self.engine = engine
        self.glctx = glctx or default_context()
        self.resolution = _resolution(*resolution)
        ctx = self.glctx.ctx
        self.warps = ctx.buffer(reserve=64 * _FIRST_MOVED_ROW, dynamic=True)
        self.warp_rows = ctx.buffer(reserve=4, dynamic=True)
        # (kind, parallel) -> program (and its vertex array for points), compiled on first use
        self._programs: dict[tuple[str, bool], Any] = {}
        self._vaos: dict[bool, Any] = {}
        if engine == "points":
            self.target = _Target(self.glctx, resolution)
        else:
            self.target = _Target(self.glctx, resolution, depth_attachment=False)
            w, h = self.resolution
            self.nearest = ctx.buffer(reserve=4 * w * h)
            self.winner = ctx.buffer(reserve=4 * w * h)
            self.splats = ctx.buffer(reserve=12 * w * h)
            self._clear_scatter()
        self._point_size_flag = moderngl.PROGRAM_POINT_SIZE

    color = property(lambda self: self.target.color)
    depth = property(lambda self: self.target.depth)
    ids = property(lambda self: self.target.ids)

    def release(self) -> None:
        if self.engine == "scatter":
            for b in (self.nearest, self.winner, self.splats):
                b.release()
        for v in self._vaos.values():
            v.release()
        for p in self._programs.values():
            p.release()
        self.warps.release()
        self.warp_rows.release()
        self.target.release()

    # -- the two warps ------------------------------------------------------------------------

    def reproject(
        self,
        source: FrameRenderer,
        camera: Camera,
        transforms: np.ndarray | None = None,
        *,
        splat_size: float = 1.0,
    ) -> float:
        """Warp ``source``'s last frame to ``camera`` with objects at ``transforms``.

        Parameters
        ----------
        source : FrameRenderer
            Its last frame, camera and transforms are the old state (t1).
        camera : Camera
            The new camera (t2), resolution :attr:`resolution`.
        transforms : (N, 4, 4) float, optional
            World <- object transforms at t2; default identity.
        splat_size : float
            Splat side in pixels (>= 1): larger splats close holes and blur.

        Returns
        -------
        float
            Wall time in ms: per-object matrices computed and uploaded, splats drawn, finished.
        """
        self._check_source(source)
        if camera.resolution != self.resolution:
            raise ValueError(f"camera resolution {camera.resolution} != {self.resolution}")
        n = len(source.scene)
        t0 = time.perf_counter()
        table, rows = warp_table(source.camera, camera, source.transforms, transforms)
        _upload(self.warps, table.transpose(0, 2, 1), np.float32)  # column-major
        _upload(self.warp_rows, rows, np.uint32)
        self._run(source, splat_size, {"objects": n}, parallel=False)
        ms = 1e3 * (time.perf_counter() - t0)
        self.glctx.check("warp")
        return ms

    def stereo(self, source: FrameRenderer, separation: float, *, splat_size: float = 1.0) -> float:
        """Warp ``source``'s last frame to the other eye of a parallel stereo rig,
        :func:`stereo_camera` ``(source.camera, separation)``, by horizontal disparity.

        Objects are taken as static (both eyes see the same instant). Returns the wall time
        in ms (splats drawn, finished).
        """
        self._check_source(source)
        if not math.isfinite(separation):
            raise ValueError(f"separation must be finite, got {separation}")
        cam = source.camera
        t0 = time.perf_counter()
        uniforms = {
            "objects": 0,
            "focal_baseline": focal_length_px(cam) * float(separation),
            "near": cam.near,
            "far": cam.far,
        }
        self._run(source, splat_size, uniforms, parallel=True)
        ms = 1e3 * (time.perf_counter() - t0)
        self.glctx.check("stereo warp")
        return ms

    def frame(self) -> Frame:
        """The last warped frame read back (top row first)."""
        return self.target.read()

    # -- engines ------------------------------------------------------------------------------

    def _check_source(self, source: FrameRenderer) -> None:
        if source.camera is None:
            raise ValueError("the source has not rendered a frame yet")
        if source.resolution != self.resolution:
            raise ValueError(
                f"source frame is {source.resolution}, the warper {self.resolution}: "
                "warp between equal resolutions"
            )

    def _set(self, program, uniforms: dict[str, Any]) -> None:
        for name, value in uniforms.items():
            if name in program:
                program[name].value = value

    def _bind_source(self, program, source: FrameRenderer) -> None:
        for unit, (name, tex) in enumerate(
            (("color", source.color), ("depth", source.depth), ("ids", source.ids))
        ):
            if name in program:
                tex.use(location=unit)
                program[name].value = unit

    def _program(self, kind: str, parallel: bool = False):
        """The program ``kind`` ("points", "scatter0", "scatter1" or "resolve") for the
        stereo shift (``parallel``) or the matrices, compiled on first use: which warp and
        which scatter stage are fixed at compile time (``WARP_PARALLEL``, ``WARP_STAGE``)
        because llvmpipe runs both sides of a branch on a uniform."""
        key = (kind, parallel and kind != "resolve")
        if key not in self._programs:
            defines = {"WARP_PARALLEL": int(key[1])}
            ctx = self.glctx.ctx
            if kind == "points":
                prog = ctx.program(
                    vertex_shader=_with_defines(shader_source("warp_splat.vert"), defines),
                    fragment_shader=shader_source("warp_splat.frag"),
                )
                self._vaos[key[1]] = ctx.vertex_array(prog, [])
            elif kind == "resolve":
                prog = ctx.compute_shader(shader_source("warp_resolve.comp"))
            else:
                defines["WARP_STAGE"] = int(kind[-1])
                prog = ctx.compute_shader(
                    _with_defines(shader_source("warp_scatter.comp"), defines)
                )
            self._programs[key] = prog
        return self._programs[key]

    def _run(
        self,
        source: FrameRenderer,
        splat_size: float,
        uniforms: dict[str, Any],
        parallel: bool,
    ) -> None:
        import moderngl

        if not (splat_size >= 1.0 and math.isfinite(splat_size)):
            raise ValueError(f"splat_size must be a finite number >= 1 pixel, got {splat_size}")
        w, h = self.resolution
        uniforms = {
            **uniforms,
            "size": (w, h),
            "no_object": NO_OBJECT,
            "background_z": BACKGROUND_NDC_Z,
            "splat_size": float(splat_size),
        }
        ctx = self.glctx.ctx
        self.warps.bind_to_storage_buffer(WARPS_BINDING)
        self.warp_rows.bind_to_storage_buffer(WARP_ROWS_BINDING)
        if self.engine == "points":
            program = self._program("points", parallel)
            self.target.clear(HOLE_COLOR, HOLE)
            ctx.enable_only(moderngl.DEPTH_TEST | self._point_size_flag)
            ctx.depth_func = "<"
            self._set(program, uniforms)
            self._bind_source(program, source)
            self._vaos[parallel].render(moderngl.POINTS, vertices=w, instances=h)  # a row each
            ctx.finish()
            return
        stages = [self._program(f"scatter{k}", parallel) for k in (0, 1)]
        resolve = self._program("resolve")
        groups = (-(-w // PIXEL_GROUP), -(-h // PIXEL_GROUP))
        if not self._cleared:  # a warp stopped before its resolve
            self._clear_scatter()
        self.nearest.bind_to_storage_buffer(NEAREST_BINDING)
        self.winner.bind_to_storage_buffer(WINNER_BINDING)
        self.splats.bind_to_storage_buffer(SPLATS_BINDING)
        self._cleared = False
        for stage in stages:
            self._set(stage, uniforms)
            self._bind_source(stage, source)
            stage.run(*groups)
            ctx.memory_barrier()
        self._set(resolve, {"size": (w, h), "hole_color": HOLE_COLOR, "hole": HOLE})
        self._bind_source(resolve, source)
        self.target.color.bind_to_image(OUT_COLOR_IMAGE, read=False, write=True)
        self.target.ids.bind_to_image(OUT_IDS_IMAGE, read=False, write=True)
        self.target.depth.bind_to_image(OUT_DEPTH_IMAGE, read=False, write=True)
        resolve.run(*groups)  # also clears nearest and winner for the next warp
        ctx.memory_barrier()
        self._cleared = True
        ctx.finish()

    def _clear_scatter(self) -> None:
        """Every pixel's nearest depth and winner to ~0 (no splat)."""
        self.nearest.clear(chunk=b"\xff" * 4)
        self.winner.clear(chunk=b"\xff" * 4)
        self._cleared = True
