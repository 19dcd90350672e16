"""Tolerances and tunables of the visibility pipeline, each in one place with the reason."""

# Frustum test: keep boxes within this (relative) distance outside a plane, so float32 AABBs
# and float64 planes never disagree in the culling direction.
FRUSTUM_SLACK = 1e-6

# Occlusion tests draw each AABB grown by this fraction of the scene's diagonal (plus an
# absolute floor) so that flat boxes get thickness and a box whose face coincides with an
# occluder surface is never hidden by rounding.
AABB_GROW_RELATIVE = 1e-6
AABB_GROW_ABSOLUTE = 1e-5

# Query boxes are pulled towards the camera by this much in normalized device depth (NDC z,
# range 2): coplanar occluder and box faces interpolate depth differently by a few ulps.
QUERY_DEPTH_BIAS_NDC = 2e-6

# The oracle draws only objects that may produce a pixel: it skips an object whose AABB lies
# outside one clip plane by more than this fraction of the magnitudes summed in the clip
# coordinates (GL 4.5 §2.3.4.1 asks floating-point results to about 1 part in 1e5; a clip
# coordinate and the clip test take about eight operations).
ORACLE_CLIP_MARGIN = 1e-4

# A box whose nearest corner is closer than near * (1 + this) to the eye plane is treated as
# straddling the near plane: clipping removes its cap, so it is kept without a query.
NEAR_PLANE_MARGIN = 1e-3

# Shading of every drawn frame (renderer, octree command buffers, two-phase culling): one
# directional light and a sky-coloured clear, so that pictures of all methods look alike.
LIGHT_DIR = (0.4, 0.8, 0.3)
SKY = (0.80, 0.86, 0.93)
