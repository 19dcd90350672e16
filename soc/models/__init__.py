"""Cost models: the per-frame performance model (draw cost of triangles, pixels and state
changes), the occlusion-query cost model of seed 004 and the adaptive method's mode
decisions. They predict times from measured counts; they draw nothing.
"""
