"""soc — scenes, cameras and visibility (occlusion culling) on a headless OpenGL context.

Importing ``soc`` does not touch OpenGL: the EGL context is created by the first
:class:`Culler` or :func:`exact_visibility` call.
"""

# isort: off
from soc import user_cache  # noqa: F401  (first: numba's kernel cache folder, before any kernel)

# isort: on
from soc import scenes
from soc.culler import Culler, method_names
from soc.culling.frustum import aabbs_in_frustum
from soc.culling.oracle import Oracle, exact_visibility
from soc.errors import GLError, GLUnavailableError, SceneError, SceneFormatError
from soc.fly import fly
from soc.methods import CullConfig
from soc.metrics import CullResult, FrameStats
from soc.scenes import paths
from soc.scenes.camera import Camera
from soc.scenes.scene import MeshView, Scene

__all__ = [
    "Camera",
    "CullConfig",
    "CullResult",
    "Culler",
    "FrameStats",
    "GLError",
    "GLUnavailableError",
    "MeshView",
    "Oracle",
    "Scene",
    "SceneError",
    "SceneFormatError",
    "aabbs_in_frustum",
    "exact_visibility",
    "fly",
    "method_names",
    "paths",
    "scenes",
]
