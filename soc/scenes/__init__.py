"""Scenes and cameras: :class:`~soc.scenes.scene.Scene` (objects, occluder flags, AABBs),
:class:`~soc.scenes.camera.Camera`, camera paths (:mod:`~soc.scenes.paths`: flights, random
and inside cameras), and the scene sources: the generated default town (``market``), Intel's castle
(``castle``), mesh
files through trimesh (``load``), indoor rooms joined by portals (``rooms``) and a small scene
of culling's hard cases for tests (``clutter``), scenes that change over time
(``dynamic_scene``: seed 004's growing scenes), a stack of spheres of constant depth
complexity (``sphere_stack``: seed 003's), a city of a million objects (``city``:
market streets between blocks of buildings, seed 000's object mix at scale), and instanced
scenes (``InstancedScene``: a mesh once, a transform per instance; ``rock_field``)."""

from soc.scenes.castle import castle
from soc.scenes.city import city
from soc.scenes.clutter import clutter
from soc.scenes.dynamic import DynamicScene, dynamic_scene
from soc.scenes.files import load
from soc.scenes.instanced import InstancedScene, rock_field
from soc.scenes.market import market
from soc.scenes.random_boxes import random_boxes
from soc.scenes.rooms import rooms, rooms_walk
from soc.scenes.sphere_stack import sphere_stack, sphere_stack_camera

__all__ = [
    "DynamicScene",
    "InstancedScene",
    "castle",
    "city",
    "clutter",
    "dynamic_scene",
    "load",
    "market",
    "random_boxes",
    "rock_field",
    "rooms",
    "rooms_walk",
    "sphere_stack",
    "sphere_stack_camera",
]
