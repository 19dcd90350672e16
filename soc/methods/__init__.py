"""Culling methods, one module each, registered by name for :class:`soc.Culler`."""

# Importing the modules registers them.
from soc.methods import frustum_only, no_culling, occlusion_queries  # noqa: F401
from soc.methods.base import METHODS, CullConfig, CullMethod, MethodOutput, register

__all__ = ["METHODS", "CullConfig", "CullMethod", "MethodOutput", "register"]
