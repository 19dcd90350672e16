"""Scene sources: the generated default town (``market``), Intel's castle (``castle``), mesh
files through trimesh (``load``), and small generated scenes for tests (``boxes``)."""

from soc.scenes.castle import castle
from soc.scenes.clutter import clutter
from soc.scenes.files import load
from soc.scenes.market import market

__all__ = ["castle", "clutter", "load", "market"]
