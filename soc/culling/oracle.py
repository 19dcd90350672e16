"""The exact per-object visibility oracle that every culling method is tested against.

Every object's full mesh is rendered with its id into a 32-bit integer colour buffer, with a
depth test and without back-face culling; an object is visible when at least one pixel holds
its id. Visibility is therefore defined at pixel-centre samples of the given resolution: an
object smaller than a pixel that covers no sample centre is invisible, as on screen.

Only the objects that may produce a pixel are drawn (:func:`may_draw`): an object whose AABB
lies entirely outside one of the six clip planes is skipped. **The id buffer is that of
drawing every object, bit for bit:**

* a triangle whose three vertices lie outside one clip plane (say ``x > w`` in clip space)
  produces no fragment: clipping keeps convex combinations of its vertices, which stay in that
  half-space, and with a guard band instead of clipping its window positions lie beyond the
  viewport's edge, past every pixel centre; so a skipped object would have written nothing;
* the GPU computes ``gl_Position = view_proj · (p, 1)`` in float32 from the float32 matrix
  (:meth:`soc.Camera.gl_bytes`) and compares the results: each clip coordinate is off by at
  most a small multiple of the sum of its terms' magnitudes ``Σ |m_ri p_i|``. The test uses
  that same float32 matrix (exactly, in float64) and skips an object only when the largest
  value of ``w ± x_k`` over its box's corners (a linear function: largest at a corner) is
  below ``-ORACLE_CLIP_MARGIN`` times the largest such sum over the corners (a convex
  function: largest at a corner) — so the GPU puts every vertex of the object outside too;
* drawing a subset in the same order leaves every other object's fragments and the depth
  test's outcomes (``<``, first drawn wins ties) unchanged.

``tests/soc/test_oracle.py`` compares both id buffers on random scenes and cameras and the hard
cases. ``Oracle(scene, frustum=False)`` draws every object (the reference).
"""

from __future__ import annotations

import numba
import numpy as np

from soc.constants import ORACLE_CLIP_MARGIN
from soc.gl.context import uses_gl
from soc.scenes.camera import Camera, _resolution

NO_OBJECT = 0xFFFFFFFF


def _is_instanced(scene) -> bool:
    """Whether ``scene`` is an :class:`~soc.scenes.instanced.InstancedScene` (drawn by
    :class:`~soc.gl.geometry.InstancedGeometry`: its instances are the objects)."""
    from soc.scenes.instanced import InstancedScene

    return isinstance(scene, InstancedScene)


@uses_gl
class Oracle:
    """Reusable exact-visibility renderer for one scene on one GL context.

    Parameters
    ----------
    scene : Scene
    glctx : GLContext, optional
        Default: the process's context.
    frustum : bool
        Draw only the objects that may produce a pixel (default True; :func:`may_draw`, the
        same id buffer) or every object (False: the reference).

    Notes
    -----
    Every call runs with vislod's GL context current and leaves the caller's current again.
    """

    def __init__(self, scene, glctx=None, *, frustum: bool = True):
        from soc.gl.context import default_context

        self.scene = scene
        self.glctx = glctx or default_context()
        self._instanced = _is_instanced(scene)
        if self._instanced:  # instances are the objects: meshes once, a transform each
            from soc.gl.geometry import InstancedGeometry

            self.geometry = InstancedGeometry(self.glctx, scene)
            self.program = self.glctx.program("instanced.vert", "object_id.frag")
        else:
            self.geometry = self.glctx.geometry(scene)
            self.program = self.glctx.program("mesh.vert", "object_id.frag")
        self._fbo = None
        self._size: tuple[int, int] | None = None
        self._all = np.arange(len(scene))
        self.frustum = bool(frustum)

    def close(self) -> None:
        if self._fbo is not None:
            fbo = self._fbo
            self.glctx.release_framebuffer(fbo, *fbo.color_attachments, fbo.depth_attachment)
            self._fbo, self._size = None, None

    def __enter__(self) -> Oracle:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
        if self._instanced:
            self.geometry.release()

    def _target(self, size: tuple[int, int]):
        if self._size != size:
            self.glctx.check_size(size, "oracle resolution")
            self.close()
            ctx = self.glctx.ctx
            self._fbo = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer(size, components=1, dtype="u4")],
                depth_attachment=ctx.depth_renderbuffer(size),
            )
            self._size = size
        return self._fbo

    def id_buffer(self, camera: Camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(H, W) uint32 id of the nearest object per pixel (``NO_OBJECT`` where empty).

        Row 0 is the bottom of the image (OpenGL order).
        """
        import moderngl

        w, h = _resolution(*(resolution or camera.resolution))
        ctx = self.glctx.ctx
        fbo = self._target((w, h))
        fbo.use()
        fbo.depth_mask = True
        self.glctx.raw.clear_uint_color(NO_OBJECT)
        self.glctx.raw.clear_depth(1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        ids = self.drawn_ids(camera) if self.frustum else self._all
        self.geometry.draw_objects(self.program, ids)
        data = fbo.read(components=1, dtype="u4", attachment=0)
        self.glctx.check("oracle render")
        return np.frombuffer(data, np.uint32).reshape(h, w)

    def drawn_ids(self, camera: Camera) -> np.ndarray:
        """(K,) int64 ids, ascending, of the objects the id render draws from ``camera``
        (:func:`may_draw`; every object with ``frustum=False``)."""
        if not self.frustum:
            return self._all
        return np.flatnonzero(may_draw(self.scene.aabbs, camera.view_proj))

    def visible(self, camera: Camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(N,) bool: objects with at least one pixel at ``resolution`` (default the camera's)."""
        ids = self.id_buffer(camera, resolution).reshape(-1)
        ids = ids[ids != NO_OBJECT]
        return np.bincount(ids, minlength=len(self.scene)) > 0


@uses_gl
def exact_visibility(
    scene, camera: Camera, resolution: tuple[int, int] | None = None
) -> np.ndarray:
    """Exact per-object visibility of ``scene`` from ``camera``.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    resolution : (width, height), optional
        Pixels of the id buffer; default ``camera.resolution``. The camera's projection (and so
        its aspect ratio) is kept; only the sampling density changes.

    Returns
    -------
    visible : (N,) bool
        True where at least one pixel centre shows the object.
    """
    with Oracle(scene) as oracle:
        return oracle.visible(camera, resolution)


def may_draw(aabbs: np.ndarray, view_proj: np.ndarray) -> np.ndarray:
    """Which objects may produce a pixel when drawn with ``view_proj`` as a float32 uniform.

    Parameters
    ----------
    aabbs : (N, 2, 3) float32
        The objects' AABBs (of the vertices their faces reference, :attr:`soc.Scene.aabbs`).
    view_proj : (4, 4) float
        World → clip space (:attr:`soc.Camera.view_proj`); rounded to float32 as the GL
        uniform is.

    Returns
    -------
    keep : (N,) bool
        False only where no vertex of the object can be inside one clip plane even with the
        GPU's float32 rounding (module docstring): such an object draws no pixel.
    """
    a = np.asarray(aabbs)
    if a.ndim != 3 or a.shape[1:] != (2, 3):
        raise ValueError(f"aabbs must have shape (N, 2, 3), got {a.shape}")
    m = np.asarray(view_proj, np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"view_proj must have shape (4, 4), got {m.shape}")
    m = m.astype(np.float32).astype(np.float64)  # the uniform the GPU multiplies by
    keep = np.empty(len(a), np.bool_)
    _may_draw(np.ascontiguousarray(a, np.float32), m, ORACLE_CLIP_MARGIN, keep)
    return keep


@numba.njit(cache=True)
def _may_draw(aabbs, m, margin, out):  # pragma: no cover - compiled
    """:func:`may_draw`'s loop: per box, per clip plane ``w + s x_k >= 0`` (s = ±1, k = 0..2),
    the plane's largest value over the box against the margin times the largest sum of the
    magnitudes of the terms of ``w`` and ``x_k``."""
    am = np.abs(m)
    for k in range(len(aabbs)):
        c0 = 0.5 * (np.float64(aabbs[k, 0, 0]) + np.float64(aabbs[k, 1, 0]))
        c1 = 0.5 * (np.float64(aabbs[k, 0, 1]) + np.float64(aabbs[k, 1, 1]))
        c2 = 0.5 * (np.float64(aabbs[k, 0, 2]) + np.float64(aabbs[k, 1, 2]))
        h0 = 0.5 * (np.float64(aabbs[k, 1, 0]) - np.float64(aabbs[k, 0, 0]))
        h1 = 0.5 * (np.float64(aabbs[k, 1, 1]) - np.float64(aabbs[k, 0, 1]))
        h2 = 0.5 * (np.float64(aabbs[k, 1, 2]) - np.float64(aabbs[k, 0, 2]))
        a0 = max(abs(np.float64(aabbs[k, 0, 0])), abs(np.float64(aabbs[k, 1, 0])))
        a1 = max(abs(np.float64(aabbs[k, 0, 1])), abs(np.float64(aabbs[k, 1, 1])))
        a2 = max(abs(np.float64(aabbs[k, 0, 2])), abs(np.float64(aabbs[k, 1, 2])))
        mag_w = am[3, 0] * a0 + am[3, 1] * a1 + am[3, 2] * a2 + am[3, 3]
        keep = True
        for r in range(3):
            mag = mag_w + am[r, 0] * a0 + am[r, 1] * a1 + am[r, 2] * a2 + am[r, 3]
            for s in (-1.0, 1.0):
                l0 = m[3, 0] + s * m[r, 0]
                l1 = m[3, 1] + s * m[r, 1]
                l2 = m[3, 2] + s * m[r, 2]
                l3 = m[3, 3] + s * m[r, 3]
                top = l0 * c0 + l1 * c1 + l2 * c2 + l3 + abs(l0) * h0 + abs(l1) * h1 + abs(l2) * h2
                if top < -margin * mag:
                    keep = False
        out[k] = keep
