"""Culling methods, one module each, registered by name for :class:`soc.Culler`."""

from soc.methods.base import METHODS, CullConfig, CullMethod, MethodOutput, register

# Importing the modules registers them.
from soc.methods import frustum_only, no_culling, occlusion_queries  # noqa: E402, F401

__all__ = ["METHODS", "CullConfig", "CullMethod", "MethodOutput", "register"]
