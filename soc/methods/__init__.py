"""Culling methods, one module each, registered by name for :class:`soc.Culler`.

Every module in this package is imported here, so a new method is a new file whose class is
decorated with :func:`register`; nothing else needs to change.
"""

import importlib
import pkgutil

from soc.methods.base import METHODS, CullConfig, CullMethod, MethodOutput, register

for _info in pkgutil.iter_modules(__path__):
    if _info.name != "base":
        importlib.import_module(f"{__name__}.{_info.name}")

__all__ = ["METHODS", "CullConfig", "CullMethod", "MethodOutput", "register"]
