"""A pinhole camera: view and projection matrices (OpenGL conventions) and its frustum planes.

World space is right-handed with y up; the camera looks down its local -z axis; clip space
z runs from -w (near) to +w (far) as in ``glFrustum``. Matrices act on column vectors
(``p_clip = projection @ view @ p_world``) and are uploaded transposed (column-major).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np


def _resolution(width: int, height: int) -> tuple[int, int]:
    w, h = int(width), int(height)
    if w != width or h != height or w <= 0 or h <= 0:
        raise ValueError(f"resolution must be two positive integers, got {width}×{height}")
    return w, h


@dataclass(frozen=True)
class Camera:
    """Camera pose, field of view, viewport and clip range. Immutable; use :meth:`replace`.

    Parameters
    ----------
    eye, target : (3,) float
        Position and look-at point, world units.
    up : (3,) float
        Approximate up direction; must not be parallel to ``target - eye``.
    fov_y : float
        Vertical field of view, degrees, in (0, 180).
    width, height : int
        Viewport in pixels; also fixes the aspect ratio.
    near, far : float
        Clip distances, world units, ``0 < near < far``.
    """

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_y: float = 60.0
    width: int = 1920
    height: int = 1080
    near: float = 0.1
    far: float = 1000.0

    def __post_init__(self):
        for name in ("eye", "target", "up"):
            v = np.asarray(getattr(self, name), dtype=np.float64).reshape(-1)
            if v.shape != (3,) or not np.isfinite(v).all():
                raise ValueError(f"{name} must be 3 finite numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(float(x) for x in v))
        _resolution(self.width, self.height)
        if not (0.0 < self.fov_y < 180.0):
            raise ValueError(f"fov_y must be in (0, 180) degrees, got {self.fov_y}")
        if not (0.0 < self.near < self.far) or not math.isfinite(self.far):
            raise ValueError(f"need 0 < near < far (finite), got near={self.near}, far={self.far}")
        fwd = np.subtract(self.target, self.eye)
        if np.linalg.norm(fwd) < 1e-12:
            raise ValueError(f"eye and target coincide at {self.eye}")
        if np.linalg.norm(np.cross(fwd, self.up)) < 1e-9 * np.linalg.norm(fwd):
            raise ValueError(f"up {self.up} is parallel to the view direction {tuple(fwd)}")

    @classmethod
    def look_at(
        cls,
        eye,
        target,
        up=(0.0, 1.0, 0.0),
        fov_y: float = 60.0,
        width: int = 1920,
        height: int = 1080,
        near: float = 0.1,
        far: float = 1000.0,
    ) -> Camera:
        """A camera at ``eye`` looking at ``target`` (see the class docstring for units)."""
        return cls(tuple(eye), tuple(target), tuple(up), fov_y, width, height, near, far)

    def replace(self, **changes) -> Camera:
        """A copy with some fields changed (e.g. ``width=640, height=360``)."""
        return replace(self, **changes)

    def with_resolution(self, resolution: tuple[int, int]) -> Camera:
        """A copy rendering at ``resolution = (width, height)`` pixels."""
        w, h = _resolution(*resolution)
        return self if (w, h) == (self.width, self.height) else replace(self, width=w, height=h)

    # -- derived matrices (cached: the dataclass is frozen) ---------------------------------

    @property
    def aspect(self) -> float:
        return self.width / self.height

    @property
    def resolution(self) -> tuple[int, int]:
        return (self.width, self.height)

    @cached_property
    def basis(self) -> np.ndarray:
        """(3, 3) float64 rows: right, up, backward (camera axes in world space)."""
        back = np.subtract(self.eye, self.target)
        back /= np.linalg.norm(back)
        right = np.cross(self.up, back)
        right /= np.linalg.norm(right)
        return np.stack([right, np.cross(back, right), back])

    @property
    def forward(self) -> np.ndarray:
        """(3,) float64 unit view direction."""
        return -self.basis[2]

    @cached_property
    def view(self) -> np.ndarray:
        """(4, 4) float64 world → camera (eye) space."""
        m = np.eye(4)
        m[:3, :3] = self.basis
        m[:3, 3] = -self.basis @ np.asarray(self.eye)
        return m

    @cached_property
    def projection(self) -> np.ndarray:
        """(4, 4) float64 camera → clip space (OpenGL, z in [-w, w])."""
        f = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
        n, fa = self.near, self.far
        m = np.zeros((4, 4))
        m[0, 0] = f / self.aspect
        m[1, 1] = f
        m[2, 2] = (fa + n) / (n - fa)
        m[2, 3] = 2.0 * fa * n / (n - fa)
        m[3, 2] = -1.0
        return m

    @cached_property
    def view_proj(self) -> np.ndarray:
        """(4, 4) float64 world → clip space."""
        return self.projection @ self.view

    @cached_property
    def planes(self) -> np.ndarray:
        """(6, 4) float64 frustum planes ``(a, b, c, d)``, normals pointing inward and unit length.

        A world point ``p`` is inside when ``a·x + b·y + c·z + d >= 0`` for all six, in the
        order left, right, bottom, top, near, far (Gribb–Hartmann extraction).
        """
        m = self.view_proj
        planes = np.stack(
            [m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]]
        )
        return planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)

    def gl_bytes(self, matrix: np.ndarray) -> bytes:
        """``matrix`` (4, 4) as column-major float32 bytes for a GLSL ``mat4`` uniform."""
        return np.ascontiguousarray(matrix.T, dtype=np.float32).tobytes()
