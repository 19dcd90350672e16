"""Culling building blocks: the pieces culling methods are made of.

Frustum tests (:mod:`~soc.culling.frustum`), the exact visibility oracle
(:mod:`~soc.culling.oracle`), the occluder depth prepass, hardware occlusion queries on
objects and on boxes, GPU and CPU hierarchical-z, the software raster and masked occlusion
buffer, and the spatial structures traversals walk (BVH, grid, octree, portal cells), with
the invisible-pixel estimate of the adaptive method. :mod:`~soc.culling.hierarchy` walks the
scene's BVH with the frustum, HiZ and masked tests, so that a frame costs what is in view. A
method in :mod:`soc.methods` combines them; nothing here imports a method.
"""
