"""The occluder depth prepass: occluder meshes rendered into a depth-only target.

The depth target has its own resolution (seed 000's "depth buffer resolution", 320×192 …
3840×2160) but uses the display camera's projection, so the frustum is the same at every
resolution and only the sampling density changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soc.camera import _resolution


class DepthTarget:
    """A depth-only framebuffer of ``resolution = (width, height)`` pixels on a GL context."""

    def __init__(self, glctx, resolution: tuple[int, int]):
        self.glctx = glctx
        self.resolution = _resolution(*resolution)
        self.texture = glctx.ctx.depth_texture(self.resolution)
        self.fbo = glctx.ctx.framebuffer(depth_attachment=self.texture)

    def release(self) -> None:
        self.glctx.release_framebuffer(self.fbo, self.texture)

    def clear(self) -> None:
        self.fbo.use()
        self.fbo.depth_mask = True
        self.glctx.raw.clear_depth(1.0)

    def read(self) -> np.ndarray:
        """(H, W) float32 window-space depth in [0, 1]; row 0 is the bottom row."""
        w, h = self.resolution
        return np.frombuffer(self.texture.read(), np.float32).reshape(h, w).copy()


def render_occluders(geometry, target: DepthTarget, camera, occluder_ids: np.ndarray) -> int:
    """Clear ``target`` and render the meshes of ``occluder_ids`` into its depth buffer.

    Returns the number of draw commands issued.
    """
    import moderngl

    glctx = geometry.glctx
    program = glctx.program("mesh.vert", "depth_only.frag")
    target.clear()
    glctx.ctx.enable_only(moderngl.DEPTH_TEST)
    glctx.ctx.depth_func = "<"
    program["view_proj"].write(camera.gl_bytes(camera.view_proj))
    return geometry.draw_objects(program, occluder_ids)


# -- the inner-conservative occluder raster ---------------------------------------------------

# Texels by which a texel's square must lie inside every edge of a primitive to be written.
# It absorbs what moves an edge between this raster and the display-resolution render it
# stands for: llvmpipe snaps vertices to 1/256 pixel (a display pixel is never larger than an
# occluder texel here), and float32 rounding of the edge functions within the guard band
# (~1e-3 texel). 1/32 texel is several times both and costs a texel only when an edge runs
# within 1/32 texel of it.
CONSERVATIVE_MARGIN = 1.0 / 32.0

# Guard band of the conservative raster, NDC units: polygons are clipped to |x|, |y| <= 8 w so
# window coordinates stay within 8 half-widths of the centre, where float32 edge functions are
# accurate to ~1e-3 texel (see CONSERVATIVE_MARGIN). Clipping outside the viewport removes no
# texel.
CONSERVATIVE_GUARD = 8.0

# Two triangles of one occluder sharing an edge are drawn as one quad when their normals'
# cosine is at least this (|cos|, any winding): flat pairs such as the halves of a wall
# rectangle. Soundness does not depend on it — the geometry shader draws a pair as one polygon
# only when its projection is strictly convex, with the max of both triangles' depth planes —
# it only picks the pairs worth merging.
QUAD_MERGE_COS = 0.999

# Rounds of the greedy matching of triangle pairs (each round takes every pair that is the
# best remaining choice of both its triangles; later rounds find little).
QUAD_MERGE_ROUNDS = 8


@dataclass(frozen=True)
class OccluderPrimitives:
    """Occluder meshes as the conservative raster draws them (see :func:`occluder_primitives`).

    Attributes
    ----------
    indices : (P, 4) uint32
        Vertex rows of ``scene.vertices`` (welded within each object): a quad ``v0 v1 v2 v3``
        made of triangles ``(v0, v1, v2)`` and ``(v0, v2, v3)``, or a triangle ``v0 v1 v2 v2``.
    first, count : (N,) int64
        Each object's primitives are ``indices[first[i] : first[i] + count[i]]`` (0 for
        non-occluders).
    quads, triangles : int
        How many primitives are quads (merged pairs) and single triangles.
    """

    indices: np.ndarray
    first: np.ndarray
    count: np.ndarray
    quads: int
    triangles: int


def _object_faces(scene, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T, 3) int64 global vertex rows of the triangles of objects ``ids`` and (T,) their
    object."""
    counts = scene.triangle_counts[ids].astype(np.int64)
    obj = np.repeat(ids, counts)
    before = np.cumsum(counts) - counts  # triangles of the earlier objects in ``ids``
    starts = np.repeat(scene.face_offsets[ids].astype(np.int64) - before, counts)
    rows = starts + np.arange(len(obj))
    faces = scene.faces[rows].astype(np.int64) + scene.vertex_offsets[obj].astype(np.int64)[:, None]
    return faces, obj


def _weld(scene, faces: np.ndarray, obj: np.ndarray) -> np.ndarray:
    """``faces`` with every vertex replaced by the first vertex of its object at the same
    position (meshes split vertices for normals and texture seams; adjacency needs one id)."""
    used = np.unique(faces)
    owner = np.searchsorted(scene.vertex_offsets, used, side="right") - 1
    pos = np.ascontiguousarray(scene.vertices[used], np.float32).view(np.int32)
    keys = np.column_stack([owner, pos])
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    rep = used[first][inverse.ravel()]
    return rep[np.searchsorted(used, faces)]


def _pair_candidates(scene, faces: np.ndarray) -> tuple[np.ndarray, ...]:
    """Triangle pairs sharing exactly one manifold edge and nearly coplanar: (K,) first
    face, second face, score (|cos| of the normals) and the quad loop (K, 4) ``u w2 v w1``."""
    p = scene.vertices[faces].astype(np.float64)  # (T, 3, 3)
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(normal, axis=1)
    normal /= np.maximum(length, 1e-300)[:, None]
    t = len(faces)
    a = faces[:, [0, 1, 2]].ravel()
    b = faces[:, [1, 2, 0]].ravel()
    c = faces[:, [2, 0, 1]].ravel()
    face = np.repeat(np.arange(t), 3)
    key = np.minimum(a, b) * (int(faces.max(initial=0)) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    k = key[order]
    if len(k) < 2:
        empty = np.zeros(0, np.int64)
        return empty, empty, np.zeros(0), np.zeros((0, 4), np.int64)
    same = k[:-1] == k[1:]
    before = np.r_[False, same[:-1]]  # the run started earlier
    after = np.r_[same[1:], False]  # the run goes on past i + 1
    i = np.flatnonzero(same & ~before & ~after)  # runs of exactly two half-edges
    e1, e2 = order[i], order[i + 1]
    f1, f2 = face[e1], face[e2]
    cos = np.abs(np.einsum("ij,ij->i", normal[f1], normal[f2]))
    ok = (f1 != f2) & (c[e1] != c[e2]) & (length[f1] > 0) & (length[f2] > 0)
    ok &= cos >= QUAD_MERGE_COS
    e1, e2, f1, f2, cos = e1[ok], e2[ok], f1[ok], f2[ok], cos[ok]
    loop = np.column_stack([a[e1], c[e2], b[e1], c[e1]])
    return f1, f2, cos, loop


def _match_pairs(t: int, f1: np.ndarray, f2: np.ndarray, score: np.ndarray) -> np.ndarray:
    """Indices of candidate pairs chosen so that no triangle is in two: greedy by score, in
    rounds (a pair is taken when it is the best remaining pair of both its triangles)."""
    order = np.argsort(-score, kind="stable")
    alive = order
    taken = []
    used = np.zeros(t, bool)
    for _ in range(QUAD_MERGE_ROUNDS):
        alive = alive[~used[f1[alive]] & ~used[f2[alive]]]
        if len(alive) == 0:
            break
        ends = np.concatenate([f1[alive], f2[alive]])
        pos = np.concatenate([np.arange(len(alive))] * 2)
        best = np.full(t, len(alive), np.int64)
        np.minimum.at(best, ends, pos)  # earliest (best) pair of each triangle
        mine = np.arange(len(alive))
        win = (best[f1[alive]] == mine) & (best[f2[alive]] == mine)
        taken.append(alive[win])
        used[f1[alive[win]]] = used[f2[alive[win]]] = True
    return np.concatenate(taken) if taken else np.zeros(0, np.int64)


def occluder_primitives(scene, ids: np.ndarray | None = None) -> OccluderPrimitives:
    """The occluders' triangles as conservative-raster primitives: flat pairs sharing an edge
    merged into quads (so the texels on a wall's diagonal are written), the rest as triangles.

    Parameters
    ----------
    scene : Scene
    ids : (K,) int, optional
        Objects to convert; default every occluder (``scene.occluder``).
    """
    n = len(scene)
    ids = np.flatnonzero(scene.occluder) if ids is None else np.asarray(ids, np.int64)
    faces, obj = _object_faces(scene, ids)
    faces = _weld(scene, faces, obj)
    keep = (faces != np.roll(faces, 1, axis=1)).all(axis=1)  # welding made some degenerate
    faces, obj = faces[keep], obj[keep]
    f1, f2, score, loop = _pair_candidates(scene, faces)
    chosen = _match_pairs(len(faces), f1, f2, score)
    single = np.ones(len(faces), bool)
    single[f1[chosen]] = single[f2[chosen]] = False
    tri = faces[single]
    prims = np.concatenate([loop[chosen], np.column_stack([tri, tri[:, 2]])])
    owner = np.concatenate([obj[f1[chosen]], obj[single]])
    order = np.argsort(owner, kind="stable")
    count = np.bincount(owner, minlength=n).astype(np.int64)
    first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    return OccluderPrimitives(
        indices=np.ascontiguousarray(prims[order], np.uint32),
        first=first,
        count=count,
        quads=len(chosen),
        triangles=len(tri),
    )


def _shader(name: str) -> str:
    """Source of ``soc/shaders/<name>.glsl`` (the context's program cache takes no geometry
    shaders, so this program is built and released here)."""
    from importlib import resources

    return resources.files("soc.shaders").joinpath(f"{name}.glsl").read_text()


class ConservativeOccluders:
    """Inner-conservative occluder raster at any resolution (Hasselgren, Akenine-Möller &
    Ohlsson, GPU Gems 2 ch. 42, the underestimating variant; one geometry shader).

    :meth:`render` writes a texel of the target only when one primitive (a triangle, or a flat
    quad of two, see :func:`occluder_primitives`) covers the texel's whole square, and writes
    a depth no nearer than that primitive's farthest point over the square. Hence every texel
    holds a depth >= the occluder depth that an ordinary render at *any* finer resolution has
    at every pixel centre inside the texel (1.0 where no primitive covers it), and a max
    pyramid built on it answers box tests conservatively for the display resolution
    (:meth:`soc.hiz_gpu.HizTest.classify` with ``display``). Triangles crossing the near plane
    are clipped to it first (the kept part's vertices bound the depth).
    """

    def __init__(self, geometry, ids: np.ndarray | None = None):
        import moderngl

        self.geometry = geometry
        self.glctx = geometry.glctx
        self.primitives = occluder_primitives(geometry.scene, ids)
        ctx = self.glctx.ctx
        self.program = ctx.program(
            vertex_shader=_shader("occluder_conservative.vert"),
            geometry_shader=_shader("occluder_conservative.geom"),
            fragment_shader=_shader("occluder_conservative.frag"),
        )
        self.program["margin"].value = CONSERVATIVE_MARGIN
        self.program["guard"].value = CONSERVATIVE_GUARD
        indices = self.primitives.indices
        self.ibo = ctx.buffer(indices if len(indices) else np.zeros((1, 4), np.uint32))
        self.vao = ctx.vertex_array(
            self.program,
            [(geometry.vbo, "3f", "in_position")],
            index_buffer=self.ibo,
            index_element_size=4,
        )
        self.indirect = ctx.buffer(reserve=20 * max(len(self.primitives.count), 1), dynamic=True)
        self._mode = moderngl.LINES_ADJACENCY

    def release(self) -> None:
        self.vao.release()
        self.program.release()
        self.ibo.release()
        self.indirect.release()

    def render(self, target: DepthTarget, camera, occluder_ids: np.ndarray) -> int:
        """Clear ``target`` and write the conservative depth of the occluders ``occluder_ids``
        (K,) seen by ``camera`` (its projection; ``target`` may have any resolution).
        Returns the number of draw commands issued."""
        import moderngl

        ids = np.asarray(occluder_ids, np.int64)
        ids = ids[self.primitives.count[ids] > 0]
        target.clear()
        if len(ids) == 0:
            return 0
        glctx = self.glctx
        glctx.ctx.enable_only(moderngl.DEPTH_TEST)
        glctx.ctx.depth_func = "<"
        w, h = target.resolution
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self.program["half_size"].value = (0.5 * w, 0.5 * h)
        cmds = np.zeros((len(ids), 5), np.uint32)
        cmds[:, 0] = 4 * self.primitives.count[ids]
        cmds[:, 1] = 1
        cmds[:, 2] = 4 * self.primitives.first[ids]
        self.indirect.write(cmds)
        self.vao.render_indirect(self.indirect, mode=self._mode, count=len(ids))
        return len(ids)
