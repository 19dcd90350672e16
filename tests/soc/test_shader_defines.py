"""The numbers GLSL and Python share live once, in :mod:`soc.gl.shader_defines`: every shader
is compiled with them as ``#define`` lines after its ``#version``; no shader file writes a
binding point, a work-group size or one of those constants itself, and the Python that binds
the shaders' buffers and images names the constants instead of numbers."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from soc.gl import shader_defines
from soc.gl.context import shader_source

ROOT = Path(__file__).resolve().parents[2]
SHADERS = sorted((ROOT / "soc" / "shaders").glob("*.glsl"))
# The cluster DAG's shaders (dag_*) get their numbers from soc/culling/dag_select.py's own
# defines for now; every other shader's shared numbers are soc.gl.shader_defines'.
CHECKED = [p for p in SHADERS if not p.name.startswith("dag")]
# Every module of the package that binds buffers or images, but the DAG's (as above).
BINDERS = sorted(
    str(p.relative_to(ROOT))
    for p in (ROOT / "soc").rglob("*.py")
    if p.name != "dag_select.py" and re.search(r"bind_to_(storage_buffer|image)\(", p.read_text())
)


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


@pytest.mark.parametrize("path", CHECKED, ids=lambda p: p.name)
def test_no_shader_writes_a_shared_number_itself(path):
    """No literal binding point (buffer or image), work-group size or uniform array size that
    Python fills."""
    text = path.read_text()
    code = "\n".join(line.split("//")[0] for line in text.splitlines())
    assert not re.search(r"\bbinding\s*=\s*\d", code), "a literal binding point"
    assert not re.search(r"\blocal_size_[xyz]\s*=\s*\d", code), "a literal work-group size"
    sized = re.findall(r"\buniform\s+\w+\s+(\w+)\s*\[\s*(\d+)\s*\]", code)
    assert set(sized) <= {("planes", "6")}, "a uniform array sized by a number (but 6 planes)"


def test_the_checks_see_the_shaders_and_binders_they_should():
    """The lists above are not empty by accident (a renamed folder would pass everything)."""
    names = {p.name for p in CHECKED}
    assert {"composite_z.comp.glsl", "warp_resolve.comp.glsl", "hiz_test.comp.glsl"} <= names
    assert {"soc/rendering/warping.py", "soc/rendering/shading.py"} <= set(BINDERS)
    assert "soc/rendering/compositing.py" in BINDERS and "soc/culling/hiz_gpu.py" in BINDERS


def test_the_material_table_has_a_row_per_material_the_shaders_index():
    """``materials[MATERIAL_COUNT]`` in GLSL is written from shading.MATERIALS."""
    from soc.rendering import shading

    assert shading.MATERIALS.shape == (shader_defines.MATERIAL_COUNT, 2)
    assert shading.SKY_MATERIAL == shader_defines.SKY_MATERIAL >= shader_defines.MATERIAL_COUNT


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
    """Buffers and images are bound to the defines' binding points, never to a number."""
    text = (ROOT / path).read_text()
    assert not re.search(r"bind_to_(storage_buffer|image)\(\s*\d", text)
