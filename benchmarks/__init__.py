"""The benchmarks (``make bench``, ``python -m benchmarks``): declared runs of the culling
methods, LOD and scale flown by :func:`soc.fly`, writing results/BENCHMARKS.md whole. Outside
the wheel: a checkout's tool, not part of vislod's API."""
