"""Dynamic phyllotaxis on a growing receptacle (spec 002 §4.3, §4.5; checklist C18, C19; tests V29–V31).

The reproductive meristem is divided into a naked inner region (around the apex), a primordium-carrying
intermediate region and a naked outer region (T §5.3, Fig. 5.1). Three production modes:

* centripetal fractionation (Fig. 5.2a): the outer region is absent; primordia are produced at fixed
  intervals from the rim inward, at the expense of the inner region, until its area falls below one
  primordium;
* divergent fractionation (Fig. 5.2b): production starts at the boundary between the inner and outer
  regions and proceeds inward and outward at the same time;
* segregation (Fig. 5.2c): a small inner region grows; whenever its area exceeds a threshold a primordium
  is produced and the inner area is reduced by the primordium's area.

Every step the supporting surface (a profile interpolated between key profiles by meristem age) is scaled
uniformly so that its area equals A_in + sum(A_i) + A_out, and all primordia are laid out again along the
profile from their current areas (Eq. 5.1), keeping their angles and order.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from plantvr._validation import check_choice, check_int, check_range
from plantvr.flowers.phyllotaxis import (
    GOLDEN_ANGLE_DEG,
    Receptacle,
    _band_integral,
    _invert_F,
    disc_receptacle,
    place_on_receptacle,
    receptacle_from_profile,
)

__all__ = ["FRONT_IN", "FRONT_OUT", "MODES", "DynamicFrame", "DynamicPhyllotaxis"]

#: Production modes of T §5.3.
MODES = ("centripetal", "divergent", "segregation")
#: Front of a primordium: produced moving toward the apex (inner front) or toward the rim (outer front).
FRONT_IN, FRONT_OUT = 0, 1

Rate = float | Callable[[float], float]
#: Fractionation production rounds one step may take (dt / dt_prod); bounds the time a step can take.
MAX_ROUNDS = 10_000_000


@dataclass(frozen=True)
class DynamicFrame:
    """State of a dynamic pattern after one step (one RBA file's worth, spec 002 §3.8, §4.3).

    Attributes
    ----------
    t : float
        Meristem age at the end of the step.
    receptacle : Receptacle
        Supporting surface scaled so its area is ``inner_area + area.sum() + outer_area``.
    inner_area, outer_area : float
        Areas of the naked inner and outer regions.
    ids : (n,) int64 ndarray
        Production index of each primordium (0 = first produced); rows are in production order.
    s : (n,) float64 ndarray
        Arc-length position along the scaled profile.
    alpha : (n,) float64 ndarray
        Angle of each primordium in radians.
    birth : (n,) float64 ndarray
        Production time.
    area : (n,) float64 ndarray
        Current primordium areas.
    front : (n,) int8 ndarray
        :data:`FRONT_IN` or :data:`FRONT_OUT`.
    position, up, right : (n, 3) float64 ndarray
        Placement frame on the scaled receptacle (the SCN/RBA fields).
    """

    t: float
    receptacle: Receptacle
    inner_area: float
    outer_area: float
    ids: np.ndarray
    s: np.ndarray
    alpha: np.ndarray
    birth: np.ndarray
    area: np.ndarray
    front: np.ndarray
    position: np.ndarray
    up: np.ndarray
    right: np.ndarray

    @property
    def age(self) -> np.ndarray:
        """(n,) float64 age of each primordium (``t - birth``)."""
        return self.t - self.birth

    @property
    def total_area(self) -> float:
        """A_in + sum(A_i) + A_out, the area the supporting surface is scaled to (V30)."""
        return float(self.inner_area + self.area.sum() + self.outer_area)

    @property
    def n(self) -> int:
        """Number of primordia."""
        return int(self.ids.size)


def _check_rate(name: str, value: Rate, *, positive: bool = False) -> Rate:
    if callable(value):
        return value
    return check_range(name, value, 0.0, 1e12, low_open=positive)


def _eval(name: str, fn: Rate, x: float, *, positive: bool = False) -> float:
    try:
        v = float(fn(x)) if callable(fn) else float(fn)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name}({x!r}) must return a number: {exc}") from None
    if not np.isfinite(v) or v < 0 or (positive and v == 0):
        raise ValueError(f"{name}({x!r}) must return a finite {'positive' if positive else 'non-negative'} "
                         f"number, got {v!r}")
    return v


class _ProfileTrack:
    """Key profiles at meristem ages, blended in shape and normalised to unit area (spec 002 §4.3)."""

    def __init__(self, profiles, nodes: int):
        if profiles is None:
            profiles = disc_receptacle(1.0)
        if isinstance(profiles, Receptacle):
            profiles = [(0.0, profiles)]
        keys = list(profiles)
        if not keys:
            raise ValueError("profiles must hold at least one (time, Receptacle) key")
        times = []
        for k, item in enumerate(keys):
            if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], Receptacle)):
                raise ValueError(f"profiles[{k}] must be a (time, Receptacle) pair, got {item!r}")
            times.append(check_range(f"profiles[{k}] time", item[0], -1e12, 1e12))
        if np.any(np.diff(times) <= 0):
            raise ValueError(f"profile key times must be strictly increasing, got {times}")
        self.times = np.array(times)
        if len(keys) == 1:
            rec = keys[0][1]
            self.shapes = [(rec.r / np.sqrt(rec.area), rec.z / np.sqrt(rec.area))]
            self.single = True
            self._unit = None
        else:
            u = np.linspace(0.0, 1.0, nodes)
            self.shapes = []
            for _, rec in keys:
                s = u * rec.length
                k = 1.0 / np.sqrt(rec.area)
                self.shapes.append((np.interp(s, rec.s, rec.r) * k, np.interp(s, rec.s, rec.z) * k))
            self.single = False

    def unit_shape(self, t: float) -> Receptacle:
        if self.single:
            if self._unit is None:
                self._unit = receptacle_from_profile(*self.shapes[0])
            return self._unit
        else:
            j = int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, self.times.size - 2))
            f = float(np.clip((t - self.times[j]) / (self.times[j + 1] - self.times[j]), 0.0, 1.0))
            r = (1 - f) * self.shapes[j][0] + f * self.shapes[j + 1][0]
            z = (1 - f) * self.shapes[j][1] + f * self.shapes[j + 1][1]
        return receptacle_from_profile(r, z)


class DynamicPhyllotaxis:
    """A meristem producing primordia by fractionation or segregation while it grows (spec 002 §4.3).

    Parameters
    ----------
    profiles : Receptacle or sequence of (float, Receptacle), optional
        Shape of the supporting surface, or key shapes at meristem ages (1 or 2 curves in the thesis),
        blended linearly in normalised arc length. Only the shape matters: every step the surface is
        scaled uniformly to the summed region areas. Default: a flat disc.
    mode : {"centripetal", "divergent", "segregation"}
        Production mode.
    inner_area : float
        Initial area of the naked inner region (the whole meristem for centripetal fractionation;
        "commensurate with a primordium" for segregation).
    outer_area : float
        Initial area of the naked outer region (0 for centripetal fractionation and segregation).
    inner_rate, outer_rate : float or callable(age) -> float
        Growth rate dA/dt (area per unit time, >= 0) of the inner and outer regions as functions of the
        meristem age, integrated over each step by the trapezoidal rule.
    primordium_area : float or callable(age) -> float
        Area of a primordium as a function of its age; its value at age 0 is the area A_new taken from
        the producing region.
    dt_prod : float
        Production interval of fractionation (first production at age 0).
    threshold : float, optional
        Segregation threshold A_thr of the inner region (default ``primordium_area(0)``).
    divergence_deg : float
        Divergence angle between consecutive primordia of the same front (default 137.5).
    alpha0_deg : float
        Angle of the first primordium of each front (reference direction).
    anchor : {"start", "centre"}
        Where a primordium sits in its band: at the band start in its front's direction of production
        (outer edge for the inner front, inner edge for the outer front; spec §4.3 layout) or at the band's
        area midpoint.
    max_primordia : int
        Production stops after this many primordia, and from the next step on the inner and outer regions
        stop growing (the meristem is used up [INFERRED]); primordia keep growing with age.
    profile_nodes : int
        Nodes per key profile when two or more keys are blended.

    References
    ----------
    .. [1] Owens 2016, §5.3, Figs. 5.1–5.2; Eqs. 5.1–5.2 for the layout. Per-step ordering, region layout
       and rate integration are [INFERRED] in spec 002 §4.3.
    """

    def __init__(self, profiles=None, *, mode: str = "centripetal", inner_area: float = 1.0,
                 outer_area: float = 0.0, inner_rate: Rate = 0.0, outer_rate: Rate = 0.0,
                 primordium_area: Rate = 0.05, dt_prod: float = 1.0, threshold: float | None = None,
                 divergence_deg: float = GOLDEN_ANGLE_DEG, alpha0_deg: float = 0.0, anchor: str = "start",
                 max_primordia: int = 1_000_000, profile_nodes: int = 513):
        mode = check_choice("mode", mode, MODES)
        inner_area = check_range("inner_area", inner_area, 0.0, 1e12, low_open=True)
        outer_area = check_range("outer_area", outer_area, 0.0, 1e12)
        inner_rate = _check_rate("inner_rate", inner_rate)
        outer_rate = _check_rate("outer_rate", outer_rate)
        primordium_area = _check_rate("primordium_area", primordium_area, positive=True)
        a_new = _eval("primordium_area", primordium_area, 0.0, positive=True)
        dt_prod = check_range("dt_prod", dt_prod, 0.0, 1e12, low_open=True)
        if threshold is None:
            threshold = a_new
        threshold = check_range("threshold", threshold, 0.0, 1e12, low_open=True)
        divergence_deg = check_range("divergence_deg", divergence_deg, -360.0, 360.0)
        alpha0_deg = check_range("alpha0_deg", alpha0_deg, -360.0, 360.0)
        anchor = check_choice("anchor", anchor, ("start", "centre"))
        max_primordia = check_int("max_primordia", max_primordia, 0, 100_000_000)
        profile_nodes = check_int("profile_nodes", profile_nodes, 3, 1_000_000)
        if mode == "divergent" and outer_area == 0 and not (callable(outer_rate) or outer_rate > 0):
            raise ValueError("divergent fractionation needs an outer region: outer_area or outer_rate must "
                             "be > 0")
        track = _ProfileTrack(profiles, profile_nodes)          # validates the profiles
        self.mode, self.anchor = mode, anchor
        self.inner_rate, self.outer_rate, self.primordium_area = inner_rate, outer_rate, primordium_area
        self.a_new, self.dt_prod, self.threshold = a_new, dt_prod, threshold
        self.divergence = np.deg2rad(divergence_deg)
        self.alpha0 = np.deg2rad(alpha0_deg)
        self.max_primordia = max_primordia
        self._track = track
        self.t = 0.0
        self.inner_area, self.outer_area = inner_area, outer_area
        self._n = 0                                        # primordia in the growable buffers below
        self._birth = np.empty(64)
        self._front = np.empty(64, np.int8)
        self._alpha = np.empty(64)
        self._override: dict[int, float] = {}
        self._last_alpha: dict[int, float] = {}
        self._next_prod = 0.0
        self._stopped = [False, False]                        # per front, fractionation only
        self.frame = self._layout()

    # -- production ------------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of primordia produced so far."""
        return self._n

    def _add(self, front: int, birth: float) -> None:
        n = self._n
        if n == self._birth.size:                          # amortised O(1) append
            self._birth, self._front, self._alpha = (np.concatenate([a, np.empty_like(a)])
                                                     for a in (self._birth, self._front, self._alpha))
        prev = self._last_alpha.get(front)
        self._alpha[n] = self.alpha0 if prev is None else prev + self.divergence
        self._last_alpha[front] = float(self._alpha[n])
        self._front[n] = front
        self._birth[n] = birth
        self._n = n + 1

    def _produce_fractionation(self, t1: float) -> None:
        fronts = (FRONT_IN,) if self.mode == "centripetal" else (FRONT_IN, FRONT_OUT)
        rounds = 0
        while self._next_prod <= t1 + 1e-12 * max(1.0, abs(t1)) and not all(self._stopped[f] for f in fronts):
            if self.n >= self.max_primordia:               # used up: no round can produce any more
                break
            rounds += 1
            if rounds > MAX_ROUNDS or self._next_prod + self.dt_prod == self._next_prod:
                raise ValueError(f"dt / dt_prod must be at most {MAX_ROUNDS} production rounds per step "
                                 f"(dt_prod={self.dt_prod!r} at t={self._next_prod!r})")
            for f in fronts:
                if self._stopped[f] or self.n >= self.max_primordia:
                    continue
                region = self.inner_area if f == FRONT_IN else self.outer_area
                if region >= self.a_new:
                    self._add(f, self._next_prod)
                    if f == FRONT_IN:
                        self.inner_area -= self.a_new
                    else:
                        self.outer_area -= self.a_new
                elif self.mode == "centripetal" or f == FRONT_IN:
                    # "This process terminates when the area of the inner region falls below that of a
                    # single primordium" (T §5.3); the outer region may still grow into production.
                    self._stopped[f] = True
            self._next_prod += self.dt_prod

    def _produce_segregation(self, t0: float, dt: float, a_before: float) -> None:
        grown = self.inner_area - a_before + 0.0
        k = 0
        while self.inner_area > self.threshold and self.n < self.max_primordia:
            # birth at the moment the inner area crossed the threshold (rate uniform within the step)
            tau = (self.threshold + k * self.a_new - a_before) / grown if grown > 0 else 0.0
            self._add(FRONT_IN, t0 + dt * float(np.clip(tau, 0.0, 1.0)))
            self.inner_area -= self.a_new
            k += 1

    def override_areas(self, ids: Sequence[int], areas: Sequence[float]) -> None:
        """Replace the areas of primordia ``ids`` by ``areas`` from now on (next-level meristems, §4.4).

        Parameters
        ----------
        ids : sequence of int
            Production indices of existing primordia.
        areas : sequence of float
            Positive areas, one per id.
        """
        try:
            ids, areas = list(ids), list(areas)
        except TypeError:
            raise ValueError(f"ids and areas must be sequences, got {type(ids).__name__}, "
                             f"{type(areas).__name__}") from None
        ids = [check_int("ids", i, 0, max(self.n - 1, 0)) for i in ids]
        areas = [check_range("areas", a, 0.0, 1e12, low_open=True) for a in areas]
        if len(ids) != len(areas) or (ids and self.n == 0):
            raise ValueError(f"ids and areas must have the same length and name existing primordia, got "
                             f"{len(ids)} ids, {len(areas)} areas for {self.n} primordia")
        self._override.update(zip(ids, areas))

    def step(self, dt: float) -> DynamicFrame:
        """Advance the meristem by ``dt``: grow the regions, produce primordia, lay out again.

        Parameters
        ----------
        dt : float
            Time step (> 0).

        Returns
        -------
        DynamicFrame
            The new state (also stored as :attr:`frame`).
        """
        dt = check_range("dt", dt, 0.0, 1e12, low_open=True)
        t0, t1 = self.t, self.t + dt
        fronts = (FRONT_IN,) if self.mode == "centripetal" else (FRONT_IN, FRONT_OUT)
        if (self.mode != "segregation" and self.n < self.max_primordia
                and not all(self._stopped[f] for f in fronts)
                and (t1 - self._next_prod) / self.dt_prod > MAX_ROUNDS):
            raise ValueError(f"dt must be at most {MAX_ROUNDS} production intervals "
                             f"(dt_prod={self.dt_prod!r}), "
                             f"got {dt!r}")
        done = self.n >= self.max_primordia     # a used-up meristem stops growing its regions
        g_in = 0.0 if done else 0.5 * (_eval("inner_rate", self.inner_rate, t0)
                                       + _eval("inner_rate", self.inner_rate, t1)) * dt
        g_out = 0.0 if done else 0.5 * (_eval("outer_rate", self.outer_rate, t0)
                                        + _eval("outer_rate", self.outer_rate, t1)) * dt
        saved = (self.t, self.inner_area, self.outer_area, self.n, self._next_prod, list(self._stopped),
                 dict(self._last_alpha), self._birth.copy(), self._front.copy(), self._alpha.copy())
        try:
            a_before = self.inner_area
            self.inner_area += g_in
            self.outer_area += g_out
            if self.mode == "segregation":
                self._produce_segregation(t0, dt, a_before)
            else:
                self._produce_fractionation(t1)
            self.t = t1
            frame = self._layout()                 # may call user functions that reject their input
        except Exception:                          # noqa: BLE001 - any failure leaves the head unchanged
            (self.t, self.inner_area, self.outer_area, self._n, self._next_prod, self._stopped,
             self._last_alpha, self._birth, self._front, self._alpha) = saved
            raise
        self.frame = frame
        return frame

    def run(self, steps: int, dt: float) -> list[DynamicFrame]:
        """Run ``steps`` steps of length ``dt`` and return every frame (the RBA series of §3.8)."""
        steps = check_int("steps", steps, 0, 100_000_000)
        dt = check_range("dt", dt, 0.0, 1e12, low_open=True)
        return [self.step(dt) for _ in range(steps)]

    # -- layout ----------------------------------------------------------------------------------------
    def _areas(self) -> np.ndarray:
        birth = self._birth[:self._n]
        if callable(self.primordium_area):
            a = None
            try:                                   # one vectorised call when the function takes arrays
                with np.errstate(all="ignore"):
                    v = np.asarray(self.primordium_area(self.t - birth), dtype=np.float64)
                if v.shape == birth.shape:
                    a = v.copy()
            except (TypeError, ValueError):
                a = None
            if a is None:
                a = np.array([_eval("primordium_area", self.primordium_area, self.t - b, positive=True)
                              for b in birth], dtype=np.float64).reshape(birth.shape)
            bad = ~(np.isfinite(a) & (a > 0))
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                age = float(self.t - birth[k])
                raise ValueError(f"primordium_area({age!r}) must return a finite positive "
                                 f"number, got {a[k]!r}")
        else:
            a = np.full(birth.size, float(self.primordium_area))
        for i, v in self._override.items():
            a[i] = v
        return a

    def _layout(self) -> DynamicFrame:
        n = self.n
        birth = self._birth[:n].copy()                     # frames own their arrays
        front = self._front[:n].copy()
        alpha = self._alpha[:n].copy()
        area = self._areas().reshape(n)
        total = self.inner_area + area.sum() + self.outer_area
        unit = self._track.unit_shape(self.t)
        lam = np.sqrt(total / unit.area)
        rec = Receptacle(s=unit.s * lam, r=unit.r * lam, z=unit.z * lam)
        # Cumulative area from the apex: [inner][front in, youngest first][front out, oldest first][outer]
        ids = np.arange(n, dtype=np.int64)
        order = np.concatenate([ids[front == FRONT_IN][::-1], ids[front == FRONT_OUT]])
        hi = self.inner_area + np.cumsum(area[order])
        lo = hi - area[order]
        if self.anchor == "centre":
            c = 0.5 * (lo + hi)
        else:
            c = np.where(front[order] == FRONT_IN, hi, lo)
        sn, g, F = _band_integral(rec, 1.0, 1)                  # F(s) = area between apex and s
        s = np.empty(n)
        s[order] = _invert_F(sn, g, F, np.minimum(c, F[-1]))
        pos, up, right = place_on_receptacle(rec, s, alpha)
        return DynamicFrame(t=self.t, receptacle=rec, inner_area=self.inner_area, outer_area=self.outer_area,
                            ids=ids, s=s, alpha=alpha, birth=birth, area=area, front=front,
                            position=pos, up=up, right=right)
