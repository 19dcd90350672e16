"""Frames of the two-phase methods recorded on small generated scenes, for
tests/soc/test_two_phase_frames.py: every frame's kept set, counters, next frame's set and the
clusters drawn, under every option set in use, over a few cameras (a flight, camera cuts, a
reset). ``python tests/soc/two_phase_record.py`` rewrites ``data/two_phase_frames.npz``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import soc
from soc.methods import CullConfig
from soc.scenes.paths import flight, random_cameras

DATA = Path(__file__).parent / "data" / "two_phase_frames.npz"
RES = (192, 112)

# (key, method, options, config): the option sets the methods' tests, the benchmarks and the
# experiments set, in today's spelling.
RUNS = [
    ("2p", "hiz-2phase", {}, {}),
    ("2p-gpu", "hiz-2phase", {"test": "gpu"}, {}),
    ("2p-final", "hiz-2phase", {"next_from": "final"}, {}),
    ("2p-gpu-final", "hiz-2phase", {"test": "gpu", "next_from": "final"}, {}),
    ("2p-first", "hiz-2phase", {"occluders_first": True}, {}),
    ("2p-first-late", "hiz-2phase", {"occluders_first": True, "next_from": "late"}, {}),
    ("2p-gpu-first-late", "hiz-2phase", {"test": "gpu", "occluders_first": True,
                                          "next_from": "late"}, {}),
    ("2p-id", "hiz-2phase", {"order": "id"}, {}),
    ("2p-flat", "hiz-2phase", {"hierarchy": False}, {}),
    ("2p-cl", "hiz-2phase", {"granularity": "cluster"}, {}),
    ("2p-cl4-id", "hiz-2phase", {"granularity": "cluster", "cluster_triangles": 4,
                                  "order": "id"}, {}),
    ("2p-nodepth", "hiz-2phase", {}, {"depth_test": False}),
    ("2p-nofrustum", "hiz-2phase", {}, {"frustum": False}),
    ("2p-cl-nofrustum", "hiz-2phase", {"granularity": "cluster"}, {"frustum": False}),
    ("gd", "gpu-driven", {}, {}),
    ("gd-obj", "gpu-driven", {"granularity": "object"}, {}),
    ("gd-8", "gpu-driven", {"cluster_triangles": 8}, {}),
    ("gd-8-final", "gpu-driven", {"cluster_triangles": 8, "next_from": "final"}, {}),
    ("gd-8-unsorted", "gpu-driven", {"cluster_triangles": 8, "order": "unsorted"}, {}),
    ("gd-8-flat", "gpu-driven", {"cluster_triangles": 8, "hierarchy": False}, {}),
    ("gd-8-read", "gpu-driven", {"cluster_triangles": 8, "count": "read"}, {}),
    ("gd-obj-final", "gpu-driven", {"granularity": "object", "next_from": "final"}, {}),
    ("gd-nodepth", "gpu-driven", {"cluster_triangles": 8}, {"depth_test": False}),
    ("gd-nofrustum", "gpu-driven", {"cluster_triangles": 8}, {"frustum": False}),
]  # fmt: skip


def scenes() -> dict[str, soc.Scene]:
    """The recorded scenes: the market with few occludees and a clutter scene."""
    return {
        "market": soc.scenes.market(seed=0, occludees=300),
        "clutter": soc.scenes.clutter(1),
    }


def cameras(scene: soc.Scene) -> list[soc.Camera]:
    """A flight cut twice to random views and back (a reset before frame 8)."""
    w, h = RES
    path = flight(scene, frames=10, width=w, height=h)
    cuts = random_cameras(scene, 2, seed=5, width=w, height=h)
    return path[:5] + cuts + path[5:]


RESET_AT = 8


def record_run(scene, method: str, options: dict, config: dict) -> dict[str, np.ndarray]:
    """Every frame of one culler over :func:`cameras`: the kept set, frustum-culled and judged
    counts, triangles drawn, next frame's set (hiz-2phase), the clusters drawn, the kept
    objects in drawing order (hiz-2phase) and the commands drawn (gpu-driven)."""
    cams = cameras(scene)
    out: dict[str, list] = {k: [] for k in ("visible", "counts", "next", "clusters", "order")}
    with soc.Culler(scene, method, RES, config=CullConfig(**config), **options) as c:
        m = c.method
        for i, cam in enumerate(cams):
            if i == RESET_AT:
                c.reset()
            r = c.cull(cam, draw=i % 4 == 0)
            s = r.stats
            counts = [s.frustum_culled, s.queries, s.triangles_drawn]
            out["visible"].append(np.packbits(r.visible))
            if method == "hiz-2phase":
                out["next"].append(np.packbits(m.next_set))
                order = np.asarray(m.last_order, np.int64)
                out["order"].append(order)
                if m.clusters is not None:
                    out["clusters"].append(np.packbits(m.last_clusters))
            else:
                counts += list(m.last_commands)
                out["clusters"].append(np.packbits(m.drawn_clusters()))
            out["counts"].append(np.asarray(counts, np.int64))
    rec = {}
    for k, v in out.items():
        if not v:
            continue
        if k == "order":  # ragged: concatenated with offsets
            rec["order"] = np.concatenate(v)
            rec["order_at"] = np.cumsum([0] + [len(a) for a in v])
        else:
            rec[k] = np.stack(v)
    return rec


def patch_retest(monkeypatch) -> None:
    """occluders_first tests the late set again only from RETEST_MIN objects on (a cost
    threshold); the small scenes here would never reach it, so it is 1 while recording."""
    from soc.methods import hiz_2phase

    monkeypatch.setattr(hiz_2phase, "RETEST_MIN", 1)


def record_all() -> dict[str, np.ndarray]:
    """Every run on every scene, keyed ``scene/run/field``."""
    import pytest

    with pytest.MonkeyPatch.context() as mp:
        patch_retest(mp)
        data = {}
        for name, scene in scenes().items():
            for key, method, options, config in RUNS:
                for field, arr in record_run(scene, method, options, config).items():
                    data[f"{name}/{key}/{field}"] = arr
    return data


if __name__ == "__main__":
    rec = record_all()
    np.savez_compressed(DATA, **rec)
    print(DATA, DATA.stat().st_size, "bytes,", len(rec), "arrays")
