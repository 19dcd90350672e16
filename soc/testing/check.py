"""Check a culling method against the exact oracle: the conservativeness test as a function.

Seed 000's correctness criterion: a conservative method never culls an object that the oracle
(:class:`soc.Oracle`, every mesh rendered with its id) sees at the same resolution. The check
runs in three stages per :class:`~soc.testing.Case`:

1. the oracle's visible set of every camera (cached per case, shared between methods),
2. the method through :class:`soc.Culler` at the case's resolution, cameras in order — a
   temporal method carries its state from frame to frame, camera cut included,
3. per view: the false culls (seen, but culled: object ids), the hidden objects kept, and
   the visible count, gathered in a frozen :class:`ConservativeReport`.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from soc.testing.hard_cases import Case, hard_cases

# How many failing views an assertion message lists before "… and N more".
MESSAGE_VIEWS = 5
# How many object ids one view's line lists.
MESSAGE_IDS = 20


@dataclass(frozen=True)
class ViewCheck:
    """One camera of one case, checked.

    Attributes
    ----------
    case : str
    camera : int
        Index of the camera in the case's sequence.
    false_culls : tuple of int
        Object ids the oracle sees but the method culled (empty for a conservative method).
    hidden_kept : int
        Objects the method kept that the oracle does not see (false keeps: cost, not error).
    visible : int
        Objects the oracle sees.
    kept : int
        Objects the method kept.
    objects : int
        Objects in the scene.
    eye : (3,) tuple of float
        The camera's position, for the message.
    """

    case: str
    camera: int
    false_culls: tuple[int, ...]
    hidden_kept: int
    visible: int
    kept: int
    objects: int
    eye: tuple[float, float, float]

    @property
    def ok(self) -> bool:
        return not self.false_culls

    def describe(self) -> str:
        ids = list(self.false_culls[:MESSAGE_IDS])
        more = (
            f" (+{len(self.false_culls) - MESSAGE_IDS} more)"
            if len(self.false_culls) > MESSAGE_IDS
            else ""
        )
        eye = ", ".join(f"{x:.3g}" for x in self.eye)
        return (
            f"case {self.case!r} camera {self.camera} (eye=({eye})): culled visible object ids "
            f"{ids}{more} ({len(self.false_culls)} of {self.visible} visible)"
        )


@dataclass(frozen=True)
class ConservativeReport:
    """The result of :func:`check_conservative`: one :class:`ViewCheck` per case and camera.

    Attributes
    ----------
    method : str
        The method's registered name (or class name).
    conservative : bool
        Whether the method instance claims to be conservative (its ``conservative`` flag).
    views : tuple of ViewCheck
    whys : dict of str to str
        Each case's reason, for the message.
    skipped : tuple of str
        Cases whose scene the method cannot cull (its ``supports(scene)`` is False, e.g.
        portal culling on a scene without cells).
    """

    method: str
    conservative: bool
    views: tuple[ViewCheck, ...]
    whys: dict[str, str]
    skipped: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        """True when no view has a false cull (vacuously when every case was skipped)."""
        return all(v.ok for v in self.views)

    @property
    def failures(self) -> tuple[ViewCheck, ...]:
        return tuple(v for v in self.views if not v.ok)

    @property
    def culled_views(self) -> int:
        """Views in which the method culled at least one object (the check exercised it)."""
        return sum(v.kept < v.objects for v in self.views)

    def to_frame(self):
        """A pandas DataFrame, one row per view (false culls as a count and a list of ids)."""
        import pandas as pd

        rows = [
            {
                "method": self.method,
                "case": v.case,
                "camera": v.camera,
                "objects": v.objects,
                "visible": v.visible,
                "kept": v.kept,
                "hidden_kept": v.hidden_kept,
                "false_culls": len(v.false_culls),
                "false_cull_ids": list(v.false_culls),
            }
            for v in self.views
        ]
        return pd.DataFrame(rows)

    def summary(self) -> str:
        """One line per case: views, false culls, hidden kept per visible object."""
        lines = [
            f"{self.method}: {'ok' if self.ok else 'NOT CONSERVATIVE'} ({len(self.views)} views)"
        ]
        for case in dict.fromkeys(v.case for v in self.views):
            vs = [v for v in self.views if v.case == case]
            bad = sum(not v.ok for v in vs)
            fc = sum(len(v.false_culls) for v in vs)
            vis = sum(v.visible for v in vs)
            hk = sum(v.hidden_kept for v in vs)
            lines.append(
                f"  {case:<24} {len(vs):3d} views  {bad:3d} failing  {fc:4d} false culls  "
                f"{hk / max(vis, 1):6.2f} hidden kept per visible"
            )
        return "\n".join(lines)

    def message(self) -> str:
        """The assertion message: the first failing views, their object ids and why the case
        is hard (empty string when ok)."""
        bad = self.failures
        if not bad:
            return ""
        lines = [
            f"culling method {self.method!r} culled objects the oracle sees in {len(bad)} of "
            f"{len(self.views)} views"
        ]
        for v in bad[:MESSAGE_VIEWS]:
            lines.append(f"  {v.describe()}")
        if len(bad) > MESSAGE_VIEWS:
            lines.append(f"  … and {len(bad) - MESSAGE_VIEWS} more failing views")
        first = bad[0].case
        lines.append(f"first failing case {first!r}: {self.whys.get(first, '')}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary() if self.ok else self.message()


_TRUTH: weakref.WeakKeyDictionary[Case, tuple[np.ndarray, ...]] = weakref.WeakKeyDictionary()


def oracle_truth(case: Case) -> tuple[np.ndarray, ...]:
    """(N,) bool oracle visible sets of ``case``'s cameras at its resolution (cached per case)."""
    if case not in _TRUTH:
        from soc.culling.oracle import Oracle

        with Oracle(case.scene) as oracle:
            _TRUTH[case] = tuple(oracle.visible(c, case.resolution) for c in case.cameras)
    return _TRUTH[case]


def _as_cases(cases, scenes, cameras, resolution) -> list[Case]:
    if cases is not None:
        if scenes is not None or cameras is not None:
            raise ValueError("give either cases or scenes/cameras, not both")
        cases = [cases] if isinstance(cases, Case) else list(cases)
        if not all(isinstance(c, Case) for c in cases):
            raise ValueError(f"cases must be soc.testing.Case objects, got {cases!r}")
        return cases
    if scenes is None:
        if cameras is not None:
            raise ValueError("cameras given without scenes")
        return hard_cases()
    from soc.scenes.scene import Scene

    scenes = [scenes] if isinstance(scenes, Scene) else list(scenes)
    if cameras is None:
        raise ValueError("scenes given without cameras")
    cameras = list(cameras)
    per_scene = cameras if cameras and isinstance(cameras[0], Sequence) else [cameras] * len(scenes)
    if len(per_scene) != len(scenes):
        raise ValueError(f"{len(scenes)} scenes but {len(per_scene)} camera lists")
    out = []
    for k, (s, cams) in enumerate(zip(scenes, per_scene, strict=True)):
        if len(cams) == 0:
            raise ValueError(f"scene {k} has no cameras")
        res = tuple(resolution) if resolution is not None else tuple(cams[0].resolution)
        out.append(Case(f"scene-{k}", s, tuple(cams), res, "given by the caller"))
    return out


def _method_name(method) -> str:
    if isinstance(method, str):
        return method
    return getattr(method, "name", "") or getattr(method, "__name__", repr(method))


def check_conservative(
    method,
    cases: Case | Sequence[Case] | None = None,
    *,
    scenes=None,
    cameras=None,
    resolution: tuple[int, int] | None = None,
    reset: bool = False,
    config=None,
    **options,
) -> ConservativeReport:
    """Run ``method`` over ``cases`` and compare every frame with the exact oracle.

    Parameters
    ----------
    method : str or type
        A registered method name (:func:`soc.method_names`) or a :class:`soc.methods.CullMethod`
        subclass (registered or not).
    cases : Case or sequence of Case, optional
        Default :func:`soc.testing.hard_cases`.
    scenes, cameras, resolution : optional
        Instead of ``cases``: a Scene (or a list), its cameras (one list for all scenes, or one
        list per scene) and the resolution (default the first camera's).
    reset : bool
        Call ``reset()`` before every camera (no temporal reuse at all). Default False: the
        cameras of a case run in order as frames, which is what a temporal method must survive.
    config : CullConfig, optional
    **options
        The method's own options (``temporal=False``, ``grid_size=…``).

    Returns
    -------
    ConservativeReport
        ``.ok``, ``.failures``, ``.summary()``, ``.to_frame()``.
    """
    from soc.culler import Culler, method_names
    from soc.methods import METHODS

    cases = _as_cases(cases, scenes, cameras, resolution)
    cls = METHODS.get(method) if isinstance(method, str) and method in method_names() else method
    views: list[ViewCheck] = []
    skipped: list[str] = []
    conservative = True
    for case in cases:
        if hasattr(cls, "supports") and not cls.supports(case.scene):
            skipped.append(case.name)
            continue
        truths = oracle_truth(case)
        with Culler(
            case.scene, method=method, resolution=case.resolution, config=config, **options
        ) as c:
            conservative = conservative and bool(c.conservative)
            for i, (cam, truth) in enumerate(zip(case.cameras, truths, strict=True)):
                if reset:
                    c.reset()
                kept = np.asarray(c.cull(cam).visible, bool)
                views.append(
                    ViewCheck(
                        case=case.name,
                        camera=i,
                        false_culls=tuple(int(k) for k in np.flatnonzero(truth & ~kept)),
                        hidden_kept=int(np.count_nonzero(kept & ~truth)),
                        visible=int(np.count_nonzero(truth)),
                        kept=int(np.count_nonzero(kept)),
                        objects=len(case.scene),
                        eye=tuple(float(x) for x in cam.eye),
                    )
                )
    whys = {c.name: c.why for c in cases}
    return ConservativeReport(
        _method_name(method), conservative, tuple(views), whys, tuple(skipped)
    )


def assert_conservative(method, cases=None, **kwargs) -> ConservativeReport:
    """:func:`check_conservative`, raising ``AssertionError`` with a readable message naming
    the first failing case, camera and object ids. Returns the report when it passes."""
    report = check_conservative(method, cases, **kwargs)
    if not report.views:
        raise AssertionError(
            f"culling method {report.method!r} supports none of the cases {list(report.skipped)}"
        )
    if not report.ok:
        raise AssertionError(report.message())
    return report
