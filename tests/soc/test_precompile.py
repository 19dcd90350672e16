"""soc.precompile: kernels compile in child processes that leave numba's cache filled and
change nothing else; a child that fails is reported, never raised."""

from __future__ import annotations

from soc import precompile


def test_children_only_for_methods_that_compile_kernels():
    with precompile.start(["none", "frustum", "queries", "hiz-2phase", "hiz-2phase"]) as p:
        assert [c.args[-1] for c in p.procs] == ["hiz-2phase"]  # once, and only it
        assert p.wait() is True  # the child culled without an error
    assert p.procs == [] and p.wait() is True  # waiting again is free


def test_a_failing_child_is_reported_not_raised(monkeypatch):
    monkeypatch.setattr(precompile, "_CHILD", "import sys; sys.exit(3)")
    assert precompile.start(["masked"]).wait() is False
    monkeypatch.setattr(precompile, "_CHILD", "import time; time.sleep(60)")
    assert precompile.start(["masked"]).wait(timeout=0.5) is False  # stopped, not waited out
