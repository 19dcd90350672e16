"""The numbers GLSL and Python share live once, in :mod:`soc.gl.shader_defines`: every shader
is compiled with them as ``#define`` lines after its ``#version``; no shader file writes a
binding point, a work-group size or one of those constants itself, and the Python that binds
the shaders' buffers names the constants instead of numbers."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from soc.gl import shader_defines
from soc.gl.context import shader_source

ROOT = Path(__file__).resolve().parents[2]
SHADERS = sorted((ROOT / "soc" / "shaders").glob("*.glsl"))
# The shaders of the culling passes, whose numbers are all defines (the rendering techniques'
# shaders, warp_* and the like, still bind by number in their own files and code).
CULLING = [p for p in SHADERS if p.name.startswith(("gpu_driven", "hiz_", "bvh_walk"))]
# Python that binds the buffers of the shaders that use the defines.
BINDERS = ["soc/methods/gpu_driven.py", "soc/culling/bvh_gpu.py", "soc/culling/hiz_gpu.py"]


def test_the_defines_are_the_modules_capital_ints():
    d = shader_defines.defines()
    assert d["FRAME_HEADER"] == d["FRAME_CURSORS"] + 2 * d["ORDER_BUCKETS"]
    assert d["SORTED_BINDING"] == 15 and "preamble" not in d and "sys" not in d
    assert all(isinstance(v, int) and not isinstance(v, bool) for v in d.values())


@pytest.mark.parametrize("path", [p for p in SHADERS if not p.name.endswith(".common.glsl")],
                         ids=lambda p: p.name)  # fmt: skip
def test_every_shader_is_compiled_with_every_define_after_its_version(path):
    """The source handed to the GL: ``#version`` first, then each define with Python's value."""
    src = shader_source(path.name.removesuffix(".glsl"))
    lines = src.split("\n")
    assert lines[0].startswith("#version")
    found = dict(re.findall(r"^#define (\w+) (\S+)$", src, re.M))
    assert found == {k: str(v) for k, v in shader_defines.defines().items()}
    assert src.index("#define") > src.index("#version")


@pytest.mark.parametrize("path", CULLING, ids=lambda p: p.name)
def test_no_culling_shader_writes_a_shared_number_itself(path):
    """No literal binding point or work-group size."""
    text = path.read_text()
    code = "\n".join(line.split("//")[0] for line in text.splitlines())
    assert not re.search(r"\bbinding\s*=\s*\d", code), "a literal binding point"
    assert not re.search(r"\blocal_size_x\s*=\s*\d", code), "a literal work-group size"


def test_no_shader_declares_a_define_again():
    """In every shader: a ``const`` or ``#define`` of a define's name would be a second source
    that can drift."""
    for path in SHADERS:
        code = "\n".join(line.split("//")[0] for line in path.read_text().splitlines())
        for name in shader_defines.defines():
            assert not re.search(rf"(const\s+\w+\s+{name}\b|#define\s+{name}\b)", code), (
                path.name,
                name,
            )


@pytest.mark.parametrize("path", BINDERS)
def test_the_python_binds_by_name(path):
    """Buffers are bound to the defines' binding points, never to a number."""
    text = (ROOT / path).read_text()
    assert not re.search(r"bind_to_storage_buffer\(\s*\d", text)
