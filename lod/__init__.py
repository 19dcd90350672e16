"""lod — level-of-detail chains, progressive meshes, screen-size estimates and LOD selection
under a frame-time budget (seed 001).

Names are loaded on first use, so ``import lod`` stays light (no simplifier, no GL); ``dir(lod)``
lists them all. A budgeted selection in a few lines: ``docs/getting-started.md``.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "build_chain": "lod.chain",
    "load_mesh": "lod.chain",
    "LodChain": "lod.chain",
    "Level": "lod.chain",
    "ProgressiveMesh": "lod.progressive",
    "melax_simplify": "lod.melax",
    "projected_area": "lod.screen_size",
    "select": "lod.selection",
    "LodScene": "lod.lod_scene",
    "LodSceneConfig": "lod.lod_scene",
    "CostModel": "lod.benefit",
    "calibrate": "lod.calibration",
    "Calibration": "lod.calibration",
    "melax_levels": "lod.melax",
    "quadric_simplify": "lod.chain",
    # a budgeted selection's other terms (the quick start: docs/getting-started.md)
    "funkhouser_sequin_benefit": "lod.benefit",
    "rendering_accuracy": "lod.benefit",
    "total_cost": "lod.selection",
    "build_scene": "lod.lod_scene",
    # the cluster LOD DAG (Nanite's) of a mesh
    "ClusterDag": "lod.dag",
    "build_dag": "lod.dag",
    "mesh_dag": "lod.dag",
}

__all__ = sorted(_EXPORTS)


def __dir__() -> list[str]:
    """The lazy names too, so that ``dir(lod)`` and tab completion show them."""
    return sorted(set(globals()) | set(_EXPORTS))


# Exported under another name than their module's.
_RENAMED = {"build_scene": "build"}


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), _RENAMED.get(name, name))
    raise AttributeError(f"module 'lod' has no attribute {name!r}")
