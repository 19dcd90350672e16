"""The numbers seed 000 (OpenGL occlusion culling on Mesa in Intel's SOC framework) reports, as
data to put beside ours: ``seeds/000_6ce7f5d2788bd2fd.txt`` as digested in ``SPEC.md`` (Abb. 8
and Abb. 9 tables, the claims in the text). Its scene: Intel's castle + marketplace, a 100-frame
flight at 1920×1080."""

from __future__ import annotations

SCENE = {"objects": 27025, "occluders": 115, "occluder_triangles": 48700, "triangles": 1923000}
FRAMES = 100
DISPLAY = (1920, 1080)

# Abb. 8 (right) and its table: the OGL (query) method per depth resolution, 100-frame means.
ABB8: dict[tuple[int, int], dict[str, float]] = {
    (320, 192): {"triangles_culled_pct": 51.88, "draw_calls": 3640,
                 "models_culled": 23795.46, "models_visible": 3229.54},
    (640, 360): {"triangles_culled_pct": 47.65, "draw_calls": 5759,
                 "models_culled": 21996.8, "models_visible": 5028.2},
    (1280, 720): {"triangles_culled_pct": 44.69, "draw_calls": 7725,
                  "models_culled": 20346.68, "models_visible": 6678.32},
    (1920, 1080): {"triangles_culled_pct": 43.81, "draw_calls": 8515,
                   "models_culled": 19683.44, "models_visible": 7341.56},
    (2432, 1440): {"triangles_culled_pct": 48.55, "draw_calls": 7920,
                   "models_culled": 20196.8, "models_visible": 6828.2},
    (3840, 2160): {"triangles_culled_pct": 75.03, "draw_calls": 2602,
                   "models_culled": 24718.0, "models_visible": 2307.0},
}  # fmt: skip
DEPTH_RESOLUTIONS: tuple[tuple[int, int], ...] = tuple(ABB8)

# Abb. 9: the stage switches at 1920×1080 (MT = llvmpipe multithreading, always on here).
# The last column's values in brackets in the document are the Abb. 8 run (43.81 %, …).
SWITCHES: tuple[str, ...] = ("MT", "MT+Frustum", "MT+Frustum+Depth test")
ABB9: dict[str, dict[str, float]] = {
    "MT": {"triangles_culled_pct": 11.13, "draw_calls": 19219,
           "models_culled": 10180.34, "models_visible": 16844.66},
    "MT+Frustum": {"triangles_culled_pct": 11.13, "draw_calls": 14318,
                   "models_culled": 14532.39, "models_visible": 12492.61},
    "MT+Frustum+Depth test": {"triangles_culled_pct": 43.88, "draw_calls": 8442,
                              "models_culled": 19728.07, "models_visible": 7296.93},
}  # fmt: skip

# The quantities of both tables, with the document's labels.
QUANTITIES: dict[str, str] = {
    "triangles_culled_pct": "triangles culled %",
    "draw_calls": "draw calls",
    "models_culled": "models culled",
    "models_visible": "models visible",
}

# Its own comparison with MOC is a placeholder (after Abb. 8/9): our masked row goes beyond it.
MOC_COMPARISON_MISSING = "VERGLEICH MIT MOC FEHLT NOCH"
MOC_FEWER_PCT = 2.0  # Hasselgren et al. as cited: MOC culls 2 % fewer triangles than HiZ
# Its OGL method at 1920×1080 ran twice (Abb. 9: 43.88 %, Abb. 8: 43.81 %): its own repeat
# spread of % triangles culled, percentage points.
REPEAT_PP = round(abs(ABB9["MT+Frustum+Depth test"]["triangles_culled_pct"]
                      - ABB8[(1920, 1080)]["triangles_culled_pct"]), 2)  # fmt: skip
# «Leistungssteigerung von teilweise über 200%» by frustum culling: three times the frame rate.
FRUSTUM_GAIN = 3.0
PACKETS = (  # its future work
    "Occludee zu Paketen schnüren und als Paket hochladen. Ziel ist es, weniger Occlusion "
    "Queries bei gleichem Ergebnis zu generieren und dadurch an Performance zu gewinnen."
)


def document_column(
    resolution: tuple[int, int], display: tuple[int, int], tolerance: float = 0.05
) -> tuple[int, int] | None:
    """The document's depth resolution whose ratio to 1920×1080 matches ``resolution``'s to
    ``display`` (within ``tolerance``), or None: a quick run's columns line up with its own."""
    sx = resolution[0] / display[0] * DISPLAY[0]
    sy = resolution[1] / display[1] * DISPLAY[1]
    for r in DEPTH_RESOLUTIONS:
        if abs(sx / r[0] - 1) <= tolerance and abs(sy / r[1] - 1) <= tolerance:
            return r
    return None
