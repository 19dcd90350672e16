"""Benefit and cost of drawing an object at a level of detail, as (N, L) arrays for
:func:`lod.select`.

Implements the terms of Zachmann's lecture (seed 001, "Prädiktive LOD-Selektion" and
"Psychophysiologische LOD-Selektion") after

    T. A. Funkhouser, C. H. Séquin: Adaptive display algorithm for interactive frame rates
    during visualization of complex virtual environments. SIGGRAPH 1993.
    M. Reddy: Perceptually modulated level of detail for virtual environments. PhD thesis,
    University of Edinburgh, 1997 (the acuity model the lecture's k-factors come from).

Cost (Funkhouser–Séquin): ``Cost(O, L) = max(C1·Poly + C2·Vert, C3·Pixels)`` — geometry-bound
or fill-bound, whichever is slower; :class:`CostModel` holds the constants (ms per polygon,
per vertex, per pixel), which are measured by rendering, not guessed (:meth:`CostModel.fit`).

Benefit (Funkhouser–Séquin): ``Size(O) · Rendering(O, L) · Importance(O) · OffCenter(O) ·
Vel(O) · Hysteresis(O, L)`` with ``Rendering = 1 − c/pgons`` and ``Hysteresis = c1/(1 + |L −
L'|) + c2/(1 + |R − R'|)`` (one rendering algorithm here, so R = R').

Psychophysical factors (lecture): acuity falls with eccentricity θ,
``k1 = exp(−(θ − b1)/c1)`` for θ > b1 else 1, b1 = 15° when head direction stands in for gaze;
likewise with angular velocity (k2) and with distance from the focal depth (k3); combined as
``k = k0 · min(k_i)`` or ``k0 · Π k_i``. The smallest feature still seen is ``r_min = 1/k``
(in units of the foveal resolution), and the level to draw is the finest whose features are
all at least that large (:func:`psychophysical_levels`).

All functions are vectorized over objects; units are stated per argument.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from soc.scenes.camera import Camera

# -- constants ------------------------------------------------------------------------------

# Rendering accuracy 1 − c/polygons: c is the polygon count at which a level is worth nothing
# (our choice; the lecture leaves c open). 4 ≈ a bounding-box-like impostor.
RENDERING_C = 4.0
# error_accuracy: projected geometric error (pixels) at which a level's accuracy is 1/2.
ERROR_TOLERANCE_PX = 1.0
# Hysteresis c1/(1 + |L − L'|) + c2: c1 + c2 = 1 makes the factor 1 at last frame's level and
# c2 + c1/2 one level away. Funkhouser–Séquin give no values; these keep a level change cheap
# but not free.
HYSTERESIS_C1 = 0.2
HYSTERESIS_C2 = 0.8
# Acuity against eccentricity: full acuity inside b1 (the lecture: 15°, eyes rarely turn
# further from the head direction), then e-folding every c1 degrees (our choice: 20°).
ACUITY_B1_DEG = 15.0
ACUITY_C1_DEG = 20.0
# Acuity against angular velocity (deg/s): full below b2, e-folding every c2 (our choice).
VELOCITY_B2_DEG_S = 5.0
VELOCITY_C2_DEG_S = 60.0
# Acuity against defocus, |1/depth − 1/focus| in dioptres: full below b3, e-folding every c3
# (our choice; about the eye's depth of field).
DEFOCUS_B3_DIOPTRE = 0.3
DEFOCUS_C3_DIOPTRE = 1.0


# -- cost -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CostModel:
    """Funkhouser–Séquin cost: ``max(per_polygon·Poly + per_vertex·Vert, per_pixel·Pixels)``
    plus an optional fixed ``per_draw`` (0 reproduces the lecture's formula).

    Attributes are ms per polygon, per vertex, per pixel and per draw. The defaults are
    order-of-magnitude values for llvmpipe at 1080p, to be replaced by :meth:`fit` or
    :func:`lod.calibration.calibrate` on measured draw times. ``combine`` is ``"max"`` (the
    lecture: geometry and fill overlap, the slower one counts) or ``"sum"`` (they do not
    overlap — e.g. one CPU doing both, as llvmpipe largely does). ``per_edge`` (ms per
    ``sqrt(Poly · Pixels)``, default 0 = the lecture's formula) adds to the fill side the
    rasterizer's work along triangle edges: P triangles covering A pixels have a total
    perimeter ∝ sqrt(A · P) pixels, and a tiled rasterizer (llvmpipe: 4×4 blocks) pays for
    every partially covered block along them — measured on llvmpipe, a close object costs
    several times more per pixel at 20k triangles than at 640 (``lod.calibration``).
    """

    per_polygon: float = 2e-5
    per_vertex: float = 1e-5
    per_pixel: float = 2e-6
    per_draw: float = 0.0
    per_edge: float = 0.0
    combine: str = "max"

    def __post_init__(self):
        for name in ("per_polygon", "per_vertex", "per_pixel", "per_draw", "per_edge"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"CostModel.{name} must be finite and >= 0, got {v!r}")
        if self.combine not in ("max", "sum"):
            raise ValueError(f"CostModel.combine must be 'max' or 'sum', got {self.combine!r}")

    def cost(self, polygons, vertices, pixels) -> np.ndarray:
        """(N, L) float64 ms.

        Parameters
        ----------
        polygons, vertices : (N, L) or (L,) array_like
            Triangles and vertices of each level (a shared chain may be given as (L,)).
        pixels : (N,) array_like
            Projected area of each object, pixels (:func:`lod.projected_area`).
        """
        p, v, a = _geometry_and_pixels(polygons, vertices, pixels)
        geometry = self.per_polygon * p + self.per_vertex * v
        fill = self.per_pixel * a[:, None]
        if self.per_edge:
            fill = fill + self.per_edge * np.sqrt(p * a[:, None])
        both = np.maximum(geometry, fill) if self.combine == "max" else geometry + fill
        return both + self.per_draw

    def scaled(self, factor: float) -> CostModel:
        """The same model with every constant times ``factor`` (> 0): a whole-frame
        correction of constants measured on isolated draws (:mod:`lod.calibration`)."""
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"factor must be finite and > 0, got {factor!r}")
        f = float(factor)
        return replace(
            self,
            per_polygon=self.per_polygon * f,
            per_vertex=self.per_vertex * f,
            per_pixel=self.per_pixel * f,
            per_draw=self.per_draw * f,
            per_edge=self.per_edge * f,
        )

    @classmethod
    def fit(cls, polygons, vertices, pixels, ms, iterations: int = 20) -> CostModel:
        """Fit the constants to measured draw times (least squares, non-negative).

        ``polygons, vertices, pixels, ms`` are (S,) samples (one draw each). The max() is
        fitted by alternation: assign each sample to the branch that predicts more, fit each
        branch by linear least squares (``per_draw`` shared), clip negatives, repeat.
        """
        p, v, a, t = (np.asarray(x, dtype=np.float64).reshape(-1) for x in
                      (polygons, vertices, pixels, ms))  # fmt: skip
        if not (p.shape == v.shape == a.shape == t.shape) or p.size < 4:
            raise ValueError(
                "fit needs >= 4 samples of equal length, got "
                f"{p.shape}, {v.shape}, {a.shape}, {t.shape}"
            )
        if not all(np.isfinite(x).all() and (x >= 0).all() for x in (p, v, a, t)):
            raise ValueError("fit needs finite, non-negative samples")
        ones = np.ones(p.size)
        geo = np.linalg.lstsq(np.stack([p, v, ones], 1), t, rcond=None)[0]
        fill = np.linalg.lstsq(np.stack([a, ones], 1), t, rcond=None)[0]
        # start: each sample in the branch that explains it better on its own
        geometry_bound = np.abs(np.stack([p, v, ones], 1) @ geo - t) <= np.abs(
            np.stack([a, ones], 1) @ fill - t
        )
        model = cls()
        for _ in range(iterations):
            # columns: polygon, vertex (geometry rows), pixel (fill rows), draw (all rows)
            design = np.zeros((p.size, 4))
            design[geometry_bound, 0] = p[geometry_bound]
            design[geometry_bound, 1] = v[geometry_bound]
            design[~geometry_bound, 2] = a[~geometry_bound]
            design[:, 3] = 1.0
            coef = np.maximum(np.linalg.lstsq(design, t, rcond=None)[0], 0.0)
            model = cls(*(float(c) for c in coef))
            new = model.per_polygon * p + model.per_vertex * v >= model.per_pixel * a
            if (new == geometry_bound).all():
                break
            geometry_bound = new
        return model


# -- benefit --------------------------------------------------------------------------------


def rendering_accuracy(polygons, c: float = RENDERING_C) -> np.ndarray:
    """``Rendering = 1 − c/polygons`` clipped to [0, 1]: (N, L) or (L,) → same shape.

    Polygons may be vertices instead (Gouraud/Phong shading in the lecture's table).
    """
    p = np.asarray(polygons, dtype=np.float64)
    if np.isnan(p).any() or (p < 0).any():
        raise ValueError(f"polygon counts must be >= 0, got {p.reshape(-1)[:5].tolist()}")
    with np.errstate(divide="ignore"):
        return np.clip(1.0 - c / p, 0.0, 1.0)


def error_accuracy(error_px, tolerance_px: float = ERROR_TOLERANCE_PX) -> np.ndarray:
    """Rendering accuracy from a level's geometric error projected to the screen:
    ``1 / (1 + error_px / tolerance_px)`` in (0, 1]: (N, L) → (N, L).

    The lecture's ``1 − c/pgons`` with one constant c barely separates levels of 10³–10⁵
    polygons (0.9997 vs 0.997 for c = 4), so the hysteresis factor (0.9 one level away)
    would freeze every object at its first level; the projected error separates them where
    it shows — near objects — and not where it does not (far objects: every level ≈ 1).
    """
    e = np.asarray(error_px, dtype=np.float64)
    if np.isnan(e).any() or (e < 0).any():
        raise ValueError(f"projected errors must be >= 0, got {e.reshape(-1)[:5].tolist()}")
    if not tolerance_px > 0:
        raise ValueError(f"tolerance_px must be > 0, got {tolerance_px!r}")
    return 1.0 / (1.0 + e / tolerance_px)


def hysteresis(
    n_levels: int, previous, c1: float = HYSTERESIS_C1, c2: float = HYSTERESIS_C2
) -> np.ndarray:
    """``c1/(1 + |L − L'|) + c2`` for every object and level: (N, L) float64.

    ``previous`` (N,) int are last frame's levels; -1 (not drawn last frame) gives 1 for
    every level (no level to stay close to). ``c2`` stands for the rendering-algorithm term
    ``c2/(1 + |R − R'|)`` with R = R' (one algorithm).
    """
    prev = np.asarray(previous)
    if prev.ndim != 1 or not np.issubdtype(prev.dtype, np.integer):
        raise ValueError(f"previous must be (N,) integers, got {prev.shape} {prev.dtype}")
    if ((prev < -1) | (prev >= n_levels)).any():
        raise ValueError(f"previous levels must be in -1..{n_levels - 1}, got {prev.max()}")
    dist = np.abs(np.arange(n_levels)[None, :] - prev[:, None])
    return np.where(prev[:, None] >= 0, c1 / (1.0 + dist) + c2, 1.0)


def funkhouser_sequin_benefit(
    size, accuracy, importance=1.0, off_center=1.0, velocity=1.0, hysteresis=1.0
) -> np.ndarray:
    """``Size · Rendering · Importance · OffCenter · Vel · Hysteresis``: (N, L) float64.

    Parameters
    ----------
    size : (N,) float
        Screen size of the object, pixels (:func:`lod.projected_area`).
    accuracy : (N, L) or (L,) float
        :func:`rendering_accuracy` of each level.
    importance, off_center, velocity : (N,) float or scalar
        Per-object factors (:func:`acuity_factor` and :func:`velocity_factor` serve as
        off-centre and velocity terms).
    hysteresis : (N, L) float or scalar
        :func:`hysteresis`.
    """
    s = np.asarray(size, dtype=np.float64)
    if s.ndim != 1:
        raise ValueError(f"size must be (N,), got shape {s.shape}")
    acc = np.broadcast_to(np.asarray(accuracy, dtype=np.float64), (len(s), np.shape(accuracy)[-1]))
    per_object = s * np.asarray(importance) * np.asarray(off_center) * np.asarray(velocity)
    out = per_object[:, None] * acc * np.asarray(hysteresis, dtype=np.float64)
    if out.shape != acc.shape or not np.isfinite(out).all():
        raise ValueError(f"benefit terms must broadcast to {acc.shape} and be finite")
    return out


# -- psychophysical factors -----------------------------------------------------------------


def eccentricity(centers, camera: Camera) -> np.ndarray:
    """Angle between the view direction and the direction to each point: (N, 3) → (N,) deg."""
    c = np.asarray(centers, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 3:
        raise ValueError(f"centers must be (N, 3), got {c.shape}")
    d = c - np.asarray(camera.eye)
    norm = np.linalg.norm(d, axis=1)
    cos = np.divide(d @ camera.forward, norm, out=np.ones(len(c)), where=norm > 0)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _falloff(x, b: float, c: float, name: str) -> np.ndarray:
    """``exp(−(x − b)/c)`` for x > b, else 1."""
    x = np.asarray(x, dtype=np.float64)
    if np.isnan(x).any() or (x < 0).any():
        raise ValueError(f"{name} must be >= 0, got {x.reshape(-1)[:5].tolist()}")
    return np.where(x > b, np.exp(-(x - b) / c), 1.0)


def acuity_factor(theta_deg, b1: float = ACUITY_B1_DEG, c1: float = ACUITY_C1_DEG):
    """k1 against eccentricity θ in degrees (the lecture's formula): (N,) → (N,) in (0, 1]."""
    return _falloff(theta_deg, b1, c1, "eccentricity")


def velocity_factor(speed_deg_s, b2: float = VELOCITY_B2_DEG_S, c2: float = VELOCITY_C2_DEG_S):
    """k2 against angular velocity across the view, deg/s: (N,) → (N,) in (0, 1]."""
    return _falloff(speed_deg_s, b2, c2, "angular velocity")


def defocus_factor(defocus_dioptre, b3: float = DEFOCUS_B3_DIOPTRE, c3: float = DEFOCUS_C3_DIOPTRE):
    """k3 against ``|1/depth − 1/focus|`` in dioptres: (N,) → (N,) in (0, 1]."""
    return _falloff(defocus_dioptre, b3, c3, "defocus")


def psychophysical_factor(
    theta_deg, speed_deg_s=None, defocus_dioptre=None, combine: str = "min", k0: float = 1.0
) -> np.ndarray:
    """Relative acuity ``k = k0 · min(k_i)`` (``combine="min"``) or ``k0 · Π k_i``
    (``"product"``) over the factors given: (N,) float64 in (0, k0]."""
    factors = [acuity_factor(theta_deg)]
    if speed_deg_s is not None:
        factors.append(velocity_factor(speed_deg_s))
    if defocus_dioptre is not None:
        factors.append(defocus_factor(defocus_dioptre))
    stacked = np.stack(np.broadcast_arrays(*factors))
    if combine == "min":
        return k0 * stacked.min(axis=0)
    if combine == "product":
        return k0 * stacked.prod(axis=0)
    raise ValueError(f"combine must be 'min' or 'product', got {combine!r}")


def psychophysical_levels(feature_px, k, foveal_px: float = 1.0) -> np.ndarray:
    """The finest level whose features are all seen: (N,) int64.

    Parameters
    ----------
    feature_px : (N, L) or (L,) float
        Smallest feature of each level on screen, pixels (e.g. the level's geometric error
        projected at the object's distance); grows with the level index.
    k : (N,) float
        Relative acuity (:func:`psychophysical_factor`).
    foveal_px : float
        Smallest feature resolved at full acuity, pixels.

    The lecture: choose l with ``r(p) >= r_min = 1/k`` for every feature p of level l. Finer
    levels than that hold features nobody can see; so the answer is the first level (from
    fine to coarse) that satisfies it, or the coarsest when none does.
    """
    k = np.asarray(k, dtype=np.float64)
    if k.ndim != 1 or not ((k > 0) & np.isfinite(k)).all():
        raise ValueError(f"k must be (N,) positive finite, got shape {k.shape}")
    f = np.broadcast_to(
        np.asarray(feature_px, dtype=np.float64), (len(k), np.shape(feature_px)[-1])
    )
    if np.isnan(f).any():
        raise ValueError("feature_px must not be NaN")
    seen = f >= (foveal_px / k)[:, None]
    return np.where(seen.any(axis=1), seen.argmax(axis=1), f.shape[1] - 1).astype(np.int64)


def _geometry_and_pixels(polygons, vertices, pixels):
    a = np.asarray(pixels, dtype=np.float64)
    if a.ndim != 1:
        raise ValueError(f"pixels must be (N,), got shape {a.shape}")
    shape = (len(a), np.shape(polygons)[-1])
    try:
        p = np.broadcast_to(np.asarray(polygons, dtype=np.float64), shape)
        v = np.broadcast_to(np.asarray(vertices, dtype=np.float64), shape)
    except ValueError:
        raise ValueError(
            f"polygons {np.shape(polygons)} and vertices {np.shape(vertices)} must be (N, L) "
            f"or (L,) with N = {len(a)}"
        ) from None
    if not all(np.isfinite(x).all() and (x >= 0).all() for x in (p, v, a)):
        raise ValueError("polygons, vertices and pixels must be finite and >= 0")
    return p, v, a
