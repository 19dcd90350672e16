"""The README gallery: shrinks what exists, skips what does not, and rewrites only the text
between its markers."""

from __future__ import annotations

import numpy as np
import pytest

from experiments import gallery


def test_shrinks_present_figures_and_rewrites_only_the_marked_section(tmp_path):
    pil = pytest.importorskip("PIL.Image")
    results, folder = tmp_path / "results", tmp_path / "gallery"
    shot = gallery.SHOTS[1]
    (results / shot.source).parent.mkdir(parents=True)
    pil.fromarray(np.zeros((300, 2000, 3), np.uint8)).save(results / shot.source)

    written = gallery.write(results, folder)
    assert written == [folder / shot.name]
    with pil.open(written[0]) as im:
        assert im.size == (gallery.WIDTH, 135)

    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\n{gallery.README_BEGIN}\nold\n{gallery.README_END}\n\ntail\n")
    gallery.update_readme(readme, folder)
    text = readme.read_text()
    assert "old" not in text and text.startswith("# x\n") and text.endswith("tail\n")
    assert f"docs/gallery/{shot.name}" in text and shot.command in text
    assert all(s.name not in text for s in gallery.SHOTS if s is not shot)
    gallery.update_readme(readme, folder)
    assert readme.read_text() == text  # idempotent


def test_readme_without_markers_is_an_error(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# no markers\n")
    with pytest.raises(ValueError, match="markers"):
        gallery.update_readme(readme, tmp_path)


def test_outside_a_checkout_it_refuses_with_one_line(monkeypatch, tmp_path, capsys):
    """Installed from a wheel, ROOT is site-packages: nothing is written there."""
    from experiments import gallery

    monkeypatch.setattr(gallery, "ROOT", tmp_path)
    monkeypatch.setattr(gallery, "FOLDER", tmp_path / "docs" / "gallery")
    assert gallery.main() == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "checkout" in err[0]
    assert list(tmp_path.iterdir()) == []
