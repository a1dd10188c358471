"""Hierarchical and recursive phyllotactic patterns (spec 002 §4.4; checklist C19; test V32).

A pattern element created by a level-n meristem becomes a meristem of level n + 1 once its area reaches a
threshold, and then produces its own elements (T §5.4). Only last-level meristems produce florets. The
first element of a child meristem lies as far as possible from the centre of its grandparent meristem
(Hofmeister's rule, T §5.4 after [11]): its reference direction is the parent-to-child centre direction,
projected into the child's tangent plane.

Each meristem is a :class:`~plantvr.flowers.dynamic.DynamicPhyllotaxis`. An element that became a
meristem occupies, in its parent's layout, the area of its own supporting surface (inner + elements +
outer, divided by the level's packing fraction), so growing sub-heads push their neighbours apart and the
bookkeeping of V30 holds at every level.
"""
from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from plantvr._validation import check_array, check_choice, check_int, check_range
from plantvr.flowers.dynamic import MODES, DynamicFrame, DynamicPhyllotaxis, Rate, _check_rate, _eval
from plantvr.flowers.phyllotaxis import GOLDEN_ANGLE_DEG, Receptacle

__all__ = ["HierarchicalPhyllotaxis", "LevelSpec", "Meristem", "hofmeister_angles"]


@dataclass(frozen=True)
class LevelSpec:
    """Parameters of the meristems of one hierarchy level (spec 002 §4.4: levels may differ).

    Attributes
    ----------
    mode : {"centripetal", "divergent", "segregation"}
        Production mode of the meristems of this level.
    primordium_area : float or callable(age) -> float
        Area of the elements these meristems produce, vs element age.
    inner_rate, outer_rate : float or callable(age) -> float
        Growth rates of the inner and outer regions vs meristem age (the outer region starts empty; divergent
        fractionation needs ``outer_rate > 0``).
    threshold : float, optional
        Segregation threshold (default: ``primordium_area(0)``).
    meristem_area : float, optional
        Area at which an element of this level becomes a meristem of the next level (ignored on the last
        level; required on the others).
    dt_prod : float
        Fractionation production interval.
    max_elements : int
        Elements per meristem at most.
    profile : Receptacle, optional
        Shape of these meristems' supporting surface (flat disc by default; cones as in Fig. 5.4).
    packing : float
        In (0, 1]: an element that became a meristem occupies ``total area / packing`` in this level's
        layout [INFERRED]. Discs cannot tile a disc, so 1 lets neighbouring sub-heads overlap a little;
        smaller values leave gaps between them.
    """

    mode: str = "segregation"
    primordium_area: Rate = 0.05
    inner_rate: Rate = 0.05
    outer_rate: Rate = 0.0
    threshold: float | None = None
    meristem_area: float | None = None
    dt_prod: float = 1.0
    max_elements: int = 1000
    profile: Receptacle | None = None
    packing: float = 1.0

    def __post_init__(self):
        check_choice("mode", self.mode, MODES)
        if self.mode == "divergent" and not callable(self.outer_rate) and \
                check_range("outer_rate", self.outer_rate, 0.0, 1e12) == 0:
            raise ValueError("divergent fractionation needs outer_rate > 0 (child meristems start without an "
                             "outer region)")
        # every value a child meristem will take is checked here, not when it first grows (mid-step)
        _check_rate("primordium_area", self.primordium_area, positive=True)
        _eval("primordium_area", self.primordium_area, 0.0, positive=True)
        _check_rate("inner_rate", self.inner_rate)
        _check_rate("outer_rate", self.outer_rate)
        if self.threshold is not None:
            check_range("threshold", self.threshold, 0.0, 1e12, low_open=True)
        check_range("dt_prod", self.dt_prod, 0.0, 1e12, low_open=True)
        if self.meristem_area is not None:
            check_range("meristem_area", self.meristem_area, 0.0, 1e12, low_open=True)
        check_int("max_elements", self.max_elements, 0, 100_000_000)
        check_range("packing", self.packing, 0.0, 1.0, low_open=True)
        if self.profile is not None and not isinstance(self.profile, Receptacle):
            raise ValueError(f"profile must be a Receptacle or None, got {type(self.profile).__name__}")


@dataclass
class Meristem:
    """One node of the meristem tree.

    Attributes
    ----------
    level : int
        0 for the main meristem.
    parent : int
        Index of the parent meristem in :attr:`HierarchicalPhyllotaxis.meristems` (-1 for the root).
    element : int
        Production index of the element of the parent this meristem grew from (-1 for the root).
    t0 : float
        Time at which it became a meristem.
    pattern : DynamicPhyllotaxis
        Its production and layout.
    centre, up, e1 : (3,) float64 ndarray
        World apex position, axis and reference direction (alpha = 0) after the last step.
    children : dict of int to int
        Element production index -> child meristem index.
    """

    level: int
    parent: int
    element: int
    t0: float
    pattern: DynamicPhyllotaxis
    centre: np.ndarray = field(default_factory=lambda: np.zeros(3))
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    e1: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    children: dict = field(default_factory=dict)

    def to_world(self, local: np.ndarray) -> np.ndarray:
        """Map (n, 3) local receptacle coordinates (apex at the origin) to world coordinates."""
        e2 = np.cross(self.up, self.e1)
        z0 = self.pattern.frame.receptacle.z[0]
        return self.centre + local[:, :1] * self.e1 + local[:, 1:2] * e2 + (local[:, 2:] - z0) * self.up

    def rotate(self, v: np.ndarray) -> np.ndarray:
        """Map (n, 3) local directions to world directions."""
        e2 = np.cross(self.up, self.e1)
        return v[:, :1] * self.e1 + v[:, 1:2] * e2 + v[:, 2:] * self.up


#: Hierarchy levels at most (the thesis shows 2 or 3; each level multiplies the meristem count).
MAX_LEVELS = 16


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else None


class HierarchicalPhyllotaxis:
    """Recursively compounded pattern: meristems whose elements become meristems (spec 002 §4.4).

    Parameters
    ----------
    levels : sequence of LevelSpec
        One spec per hierarchy level m (``levels[0]`` for the main meristem). Elements of level-k meristems
        become level-(k + 1) meristems at ``levels[k].meristem_area``; elements of the last level are florets.
    inner_area : float
        Initial inner-region area of the main meristem.
    divergence_deg : float
        Divergence angle at every level (default 137.5).
    alpha0_deg : float
        Reference direction of the main meristem's first element.

    References
    ----------
    .. [1] Owens 2016, §5.4, Figs. 5.3–5.4 (Hofmeister's rule after [11]); spec 002 §4.4 data model
       [INFERRED].
    """

    def __init__(self, levels: Sequence[LevelSpec], *, inner_area: float = 0.05,
                 divergence_deg: float = GOLDEN_ANGLE_DEG, alpha0_deg: float = 0.0):
        try:
            levels = list(levels)
        except TypeError:
            raise ValueError(f"levels must be a non-empty sequence of LevelSpec, "
                             f"got {type(levels).__name__}") from None
        if len(levels) > MAX_LEVELS:
            raise ValueError(f"levels must hold at most {MAX_LEVELS} LevelSpec, got {len(levels)}")
        if not levels or not all(isinstance(L, LevelSpec) for L in levels):
            raise ValueError(f"levels must be a non-empty sequence of LevelSpec, got {levels!r}")
        for k, L in enumerate(levels[:-1]):
            if L.meristem_area is None:
                raise ValueError(f"levels[{k}].meristem_area must be set: its elements become level-{k + 1} "
                                 "meristems")
        inner_area = check_range("inner_area", inner_area, 0.0, 1e12, low_open=True)
        self.divergence_deg = check_range("divergence_deg", divergence_deg, -360.0, 360.0)
        alpha0_deg = check_range("alpha0_deg", alpha0_deg, -360.0, 360.0)
        self.levels = levels
        self.t = 0.0
        self.meristems = [Meristem(0, -1, -1, 0.0, self._pattern(0, inner_area, alpha0_deg))]

    def _pattern(self, level: int, inner_area: float, alpha0_deg: float = 0.0) -> DynamicPhyllotaxis:
        L = self.levels[level]
        return DynamicPhyllotaxis(L.profile, mode=L.mode, inner_area=inner_area, outer_area=0.0,
                                  inner_rate=L.inner_rate, outer_rate=L.outer_rate,
                                  primordium_area=L.primordium_area, dt_prod=L.dt_prod, threshold=L.threshold,
                                  divergence_deg=self.divergence_deg, alpha0_deg=alpha0_deg,
                                  max_primordia=L.max_elements)

    @property
    def depth(self) -> int:
        """Number of hierarchy levels m."""
        return len(self.levels)

    def _advance(self, i: int, dt: float) -> None:
        m = self.meristems[i]
        for c in m.children.values():
            self._advance(c, dt)
        if m.children:
            ids = list(m.children)
            k = self.levels[m.level].packing
            areas = [self.meristems[m.children[e]].pattern.frame.total_area / k for e in ids]
            m.pattern.override_areas(ids, areas)
        m.pattern.step(dt)

    def _convert(self) -> None:
        for i in range(len(self.meristems)):
            m = self.meristems[i]
            if m.level >= self.depth - 1:
                continue
            fr = m.pattern.frame
            ready = np.flatnonzero(fr.area >= self.levels[m.level].meristem_area)
            for e in ready:
                if int(e) in m.children:
                    continue
                pattern = self._pattern(m.level + 1, float(fr.area[e]))
                child = Meristem(m.level + 1, i, int(e), self.t, pattern)
                m.children[int(e)] = len(self.meristems)
                self.meristems.append(child)

    def _place(self, i: int) -> None:
        m = self.meristems[i]
        fr = m.pattern.frame
        pos, up = m.to_world(fr.position), m.rotate(fr.up)
        for e, c in m.children.items():
            ch = self.meristems[c]
            ch.centre, ch.up = pos[e], up[e]
            # Hofmeister: first element as far as possible from the grandparent centre (T §5.4)
            d = ch.centre - m.centre
            d1 = _unit(d - d.dot(ch.up) * ch.up)
            if d1 is None:                                       # child at the parent's apex
                d1 = _unit(m.e1 - m.e1.dot(ch.up) * ch.up)
            if d1 is None:
                d1 = _unit(np.cross(ch.up, [1.0, 0.0, 0.0]))
            if d1 is None:
                d1 = _unit(np.cross(ch.up, [0.0, 1.0, 0.0]))
            ch.e1 = d1
            self._place(c)

    def step(self, dt: float) -> None:
        """Advance every meristem by ``dt``, convert grown elements into meristems, place the tree.

        Parameters
        ----------
        dt : float
            Time step (> 0).
        """
        dt = check_range("dt", dt, 0.0, 1e12, low_open=True)
        saved, t0 = copy.deepcopy(self.meristems), self.t     # a user function may fail mid-tree
        try:
            self._advance(0, dt)
            self.t += dt
            self._convert()
            self._place(0)
        except Exception:                                      # noqa: BLE001 - any failure: state unchanged
            self.meristems, self.t = saved, t0
            raise

    def run(self, steps: int, dt: float) -> None:
        """Run ``steps`` steps of length ``dt``."""
        steps = check_int("steps", steps, 0, 100_000_000)
        dt = check_range("dt", dt, 0.0, 1e12, low_open=True)
        for _ in range(steps):
            self.step(dt)

    def frame(self, i: int) -> DynamicFrame:
        """Latest layout of meristem ``i`` in its local coordinates."""
        i = check_int("i", i, 0, len(self.meristems) - 1)
        return self.meristems[i].pattern.frame

    def element_positions(self, i: int) -> np.ndarray:
        """(n, 3) world positions of the elements of meristem ``i`` in production order."""
        i = check_int("i", i, 0, len(self.meristems) - 1)
        m = self.meristems[i]
        return m.to_world(m.pattern.frame.position)

    def florets(self) -> dict[str, np.ndarray]:
        """Florets: elements of the last-level meristems, with their head centres (fate's O, §4.6).

        Returns
        -------
        dict
            ``position``, ``up``, ``right`` (n, 3) float64; ``area``, ``birth`` (absolute time) (n,) float64;
            ``head`` (n,) int64 meristem index; ``centre`` (n, 3) float64 apex of that head.
        """
        out = {k: [] for k in ("position", "up", "right", "area", "birth", "head", "centre")}
        for i, m in enumerate(self.meristems):
            if m.level != self.depth - 1:
                continue
            fr = m.pattern.frame
            out["position"].append(m.to_world(fr.position))
            out["up"].append(m.rotate(fr.up))
            out["right"].append(m.rotate(fr.right))
            out["area"].append(fr.area)
            out["birth"].append(fr.birth + m.t0)
            out["head"].append(np.full(fr.n, i, np.int64))
            out["centre"].append(np.broadcast_to(m.centre, (fr.n, 3)))
        shapes = {"position": (0, 3), "up": (0, 3), "right": (0, 3), "centre": (0, 3)}
        return {k: (np.concatenate(v) if v else np.zeros(shapes.get(k, (0,)),
                                                         np.int64 if k == "head" else np.float64))
                for k, v in out.items()}


def hofmeister_angles(pattern: HierarchicalPhyllotaxis) -> np.ndarray:
    """Angle (radians) between each child meristem's first element and its Hofmeister direction (V32).

    For every meristem of level >= 1 with at least one element: the angle between
    (first element - child centre) and (child centre - parent centre), both projected into the child's
    tangent plane.
    """
    if not isinstance(pattern, HierarchicalPhyllotaxis):
        raise ValueError(f"pattern must be a HierarchicalPhyllotaxis, got {type(pattern).__name__}")  # noqa: TRY004
    out = []
    for i, m in enumerate(pattern.meristems):
        if m.parent < 0 or m.pattern.n == 0:
            continue
        p = pattern.element_positions(i)[0] - m.centre
        d = m.centre - pattern.meristems[m.parent].centre
        p = p - p.dot(m.up) * m.up
        d = d - d.dot(m.up) * m.up
        c = np.cross(p, d)
        out.append(np.arctan2(np.linalg.norm(c), p.dot(d)))
    return check_array("angles", np.array(out, dtype=np.float64), shape=(None,))
