"""The Floral Canopy Composer loop: constraint-based growth with collisions (spec 002 §3.4–§3.5, Alg. 1; C8–C10).

Florets are instances of per-type animations (:class:`~plantvr.flowers.floret.FloretMesh`) placed by
(position, up, right, scale). Each step sets every instance's rest lengths and signed dihedral angles to
those of its animation at its own stage (phase effect), drives the attachment vertices (w = 0) to the
placed stage geometry, projects internal constraints, then runs CCD and collision constraints with
retries so every step ends collision-free.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from plantvr._validation import MAX_COORD, MAX_COUNT, check_array, check_choice, check_int, check_range
from plantvr.flowers import ccd, pbd
from plantvr.params import Param, ParamTable

__all__ = ["SOLVER", "Canopy", "FloretType", "SolverParams", "grow", "step"]


def _row(name, kind, default, ref, doc, **kw) -> Param:
    return Param(name=name, kind=kind, default=default, window="solver", ref=ref, doc=doc, **kw)


#: The Algorithm 1 settings, declared once; defaults are the App. C.1 example file values (spec 002 §3.7).
SOLVER = ParamTable("solver", (
    _row("solver_iterations", int, 50, "§3.5 Alg. 1", "Internal-constraint (stretch, bend) iterations per step.",
         range=(0, 100_000)),
    _row("collision_iterations", int, 10, "§3.5 Alg. 1", "Collision-constraint iterations per detect pass.",
         range=(0, 100_000)),
    _row("max_collision_retries", int, 20, "§3.5 Alg. 1", "Detect passes before the roll-back fallback.",
         range=(0, 100_000)),
    _row("k_stretch", float, 0.99, "§3.3", "Stiffness of the distance constraints.", range=(0.0, 1.0)),
    _row("k_bend", float, 0.99, "§3.3", "Stiffness of the signed dihedral bending constraints.", range=(0.0, 1.0)),
    _row("k_collision", float, 1.0, "§3.4", "Stiffness of the collision constraints.", range=(0.0, 1.0)),
    _row("spacing", float, 0.005, "§3.4", "Collision thickness h (also the spatial-hash cell).", range=(0.0, 1e6)),
    _row("method", str, "gauss-seidel", "§3.3 (V26)", "Internal-constraint solver.",
         choices=("gauss-seidel", "jacobi")),
    _row("omega", float, 1.0, "§3.3 (V26)", "Over-relaxation of the Jacobi solver.", range=(0.0, 2.0),
         low_open=True, high_open=True),
), {"solver": ("Solver (Algorithm 1)", "#777777")})
_DEFAULT = SOLVER.defaults()


@dataclass(frozen=True)
class SolverParams:
    """Algorithm 1 settings, the rows of :data:`SOLVER` (defaults and ranges come from the table).

    ``method`` picks the internal-constraint solver: ``"gauss-seidel"`` (the thesis) or ``"jacobi"``
    (order-independent, averaged per vertex, over-relaxed by ``omega`` in (0, 2); V26).
    """

    solver_iterations: int = _DEFAULT["solver_iterations"]
    collision_iterations: int = _DEFAULT["collision_iterations"]
    max_collision_retries: int = _DEFAULT["max_collision_retries"]
    k_stretch: float = _DEFAULT["k_stretch"]
    k_bend: float = _DEFAULT["k_bend"]
    k_collision: float = _DEFAULT["k_collision"]
    spacing: float = _DEFAULT["spacing"]
    method: str = _DEFAULT["method"]
    omega: float = _DEFAULT["omega"]

    def __post_init__(self):
        SOLVER.validate(asdict(self))


@dataclass
class FloretType:
    """Per-type rest tables precomputed from an animation (spec 002 §2.4 container, C4)."""

    faces: np.ndarray
    frames: np.ndarray
    fixed: np.ndarray
    edges: np.ndarray = field(init=False)
    quads: np.ndarray = field(init=False)
    rest_len: np.ndarray = field(init=False)
    rest_phi: np.ndarray = field(init=False)

    def __post_init__(self):
        faces = _int_table("faces", self.faces, (None, 3))
        frames = check_array("frames", self.frames, shape=(None, None, 3), min_rows=1, max_abs=MAX_COORD)
        fixed = _int_table("fixed", self.fixed, (None,))
        V = frames.shape[1]
        if faces.shape[0] == 0:
            raise ValueError("faces must hold at least one triangle (the settings gave an empty floret mesh)")
        if faces.size and (faces.min() < 0 or faces.max() >= V):
            raise ValueError(f"faces must index the {V} vertices of frames, got values in "
                             f"[{faces.min()}, {faces.max()}]")
        if fixed.size and (fixed.min() < 0 or fixed.max() >= V):
            raise ValueError(f"fixed must index the {V} vertices of frames, got values in "
                             f"[{fixed.min()}, {fixed.max()}]")
        self.faces, self.frames, self.fixed = faces, frames, fixed
        self.edges = pbd.mesh_edges(self.faces)
        self.quads = pbd.bend_quads(self.faces)
        self.rest_len = np.stack([pbd.edge_lengths(X, self.edges) for X in self.frames])
        self.rest_phi = np.stack([pbd.signed_dihedrals(X, self.quads) for X in self.frames])

    def at(self, stage: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rest lengths, rest angles and geometry at a stage in [0, 1] (linear between frames; clipped)."""
        stage = check_range("stage", stage, -1e12, 1e12)
        K = self.frames.shape[0]
        x = np.clip(stage, 0, 1) * (K - 1)
        i = min(int(np.floor(x)), K - 2) if K > 1 else 0
        f = x - i if K > 1 else 0.0
        j = min(i + 1, K - 1)
        d = (self.rest_phi[j] - self.rest_phi[i] + np.pi) % (2 * np.pi) - np.pi
        return ((1 - f) * self.rest_len[i] + f * self.rest_len[j], self.rest_phi[i] + f * d,
                (1 - f) * self.frames[i] + f * self.frames[j])


class Canopy:
    """Union of placed floret instances as one struct-of-arrays mesh (spec 002 §3.4, §3.8 placement).

    Parameters
    ----------
    types : list of FloretType
    kind : (n,) int array_like
        Type index of each instance.
    position, up, right : (n, 3) float64 array_like
        Placement frame of each instance (floret axis = up).
    scale : (n,) float64 array_like
        Uniform placement scale.
    """

    def __init__(self, types, kind, position, up, right, scale):
        try:
            types = list(types)
        except TypeError:
            raise ValueError(f"types must be a sequence of FloretType, got {type(types).__name__}") from None
        if not types or not all(isinstance(t, FloretType) for t in types):
            raise ValueError(f"types must be a non-empty sequence of FloretType, got {types!r:.200}")
        kind = _int_table("kind", kind, (None,))
        n = kind.size
        if n == 0:
            raise ValueError("kind must name at least one floret instance, got none")
        if kind.min() < 0 or kind.max() >= len(types):
            raise ValueError(f"kind must be in [0, {len(types) - 1}], got values in "
                             f"[{kind.min()}, {kind.max()}]")
        position = check_array("position", position, shape=(n, 3), max_abs=MAX_COORD)
        up = check_array("up", up, shape=(n, 3), max_abs=MAX_COORD)
        right = check_array("right", right, shape=(n, 3), max_abs=MAX_COORD)
        scale = check_array("scale", scale, shape=(n,), max_abs=MAX_COORD)
        if np.any(scale <= 0):
            raise ValueError(f"scale must be > 0, got {scale.min()!r}")
        total = int(sum(types[k].frames.shape[1] for k in kind))
        if total > MAX_COUNT:
            raise ValueError(f"the canopy must have at most {MAX_COUNT} vertices, got {total} (kind)")
        nu = np.linalg.norm(up, axis=1, keepdims=True)
        if np.any(nu < 1e-12):
            raise ValueError(f"up must be non-zero vectors, got {up[int(np.argmin(nu[:, 0]))].tolist()}")
        up = up / nu
        n0 = np.linalg.norm(right, axis=1, keepdims=True)
        right = right - np.einsum("ij,ij->i", right, up)[:, None] * up
        nr = np.linalg.norm(right, axis=1, keepdims=True)
        if np.any(nr <= 1e-9 * n0) or np.any(n0 == 0):
            raise ValueError("right must be non-zero and not parallel to up")
        right /= nr
        self.types, self.position, self.scale = types, position, scale
        self.rot = np.stack([right, np.cross(up, right), up], axis=2)     # columns: local x, y, z
        self.kind = kind
        nv = np.array([self.types[k].frames.shape[1] for k in kind], np.int64)
        self.voff = np.concatenate([[0], np.cumsum(nv)])
        self.faces = np.concatenate([self.types[k].faces + o for k, o in zip(kind, self.voff)])
        self.edges = np.concatenate([self.types[k].edges + o for k, o in zip(kind, self.voff)])
        self.quads = np.concatenate([self.types[k].quads + o for k, o in zip(kind, self.voff)])
        self.fixed = np.concatenate([self.types[k].fixed + o for k, o in zip(kind, self.voff)])
        self.w = np.ones(self.voff[-1])
        self.w[self.fixed] = 0.0
        self.face_instance = np.concatenate([np.full(len(self.types[k].faces), i) for i, k in enumerate(kind)])

    def detector(self, h: float) -> ccd.CollisionDetector:
        """The canopy's collision detector (grids and incidence reused across steps)."""
        det = getattr(self, "_detector", None)
        if det is None or det.h != h:
            det = self._detector = ccd.CollisionDetector(self.faces, int(self.voff[-1]), h=h, edges=self.edges)
        return det

    @property
    def n_instances(self) -> int:
        """Number of floret instances."""
        return int(self.kind.size)

    def targets(self, stages: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rest lengths, rest angles and placed stage geometry for per-instance stages (C8, C9, V13)."""
        stages = check_array("stages", stages, shape=(self.n_instances,), max_abs=1e12)
        L, P, X = [], [], []
        for i, k in enumerate(self.kind):
            rl, rp, g = self.types[k].at(stages[i])
            L.append(rl * self.scale[i])                 # lengths scale, angles do not (V13)
            P.append(rp)
            X.append(self.position[i] + self.scale[i] * g @ self.rot[i].T)
        return np.concatenate(L), np.concatenate(P), np.concatenate(X)

    def initial_positions(self, stages: np.ndarray) -> np.ndarray:
        """Placed geometry of every instance at its stage (M_0 of the canopy)."""
        return np.ascontiguousarray(self.targets(stages)[2])


def step(canopy: Canopy, x: np.ndarray, stages: np.ndarray, params: SolverParams = SolverParams(), *,
         collisions: bool = True, backend: str = "numba", prev_stages: np.ndarray | None = None
         ) -> tuple[np.ndarray, dict]:
    """One simulation step of Algorithm 1 (spec 002 §3.5) from collision-free ``x``.

    With ``prev_stages`` (the stages of ``x``), the prediction starts from ``x`` plus the kinematic
    displacement of the placed animation between the two stages ("applyAnimation", Alg. 1 lines 2–4,
    [INFERRED] reading); the constraints then only correct deviations caused by contacts. Without it the
    prediction starts at ``x`` and the new rest values alone drive the growth.

    Returns
    -------
    x_new : (V, 3) float64 ndarray
    stats : dict
        ``solver``, ``broad``, ``narrow`` seconds, ``constraints`` created, ``passes`` (detect passes),
        ``rolled_back`` vertices of the fallback.
    """
    canopy, params = _check_run(canopy, params)
    backend = check_choice("backend", backend, ("numba", "numpy"))
    x = check_array("x", x, shape=(canopy.voff[-1], 3), max_abs=MAX_COORD)
    stats = {"solver": 0.0, "broad": 0.0, "narrow": 0.0, "constraints": 0, "passes": 0, "rolled_back": 0}
    rest_len, rest_phi, target = canopy.targets(stages)
    if prev_stages is not None:
        prev = check_array("prev_stages", prev_stages, shape=(canopy.n_instances,), max_abs=1e12)
        p = x + (target - canopy.targets(prev)[2])
    else:
        p = x.copy()
    p[canopy.fixed] = target[canopy.fixed]                 # attachments from M_i (C8)
    t0 = time.perf_counter()
    pbd.solve_internal(p, canopy.w, canopy.edges, rest_len, canopy.quads, rest_phi,
                       k_stretch=params.k_stretch, k_bend=params.k_bend,
                       iterations=params.solver_iterations, backend=backend, method=params.method,
                       omega=params.omega)
    stats["solver"] = time.perf_counter() - t0
    if not collisions:
        return p, stats
    w_col = np.ones_like(canopy.w)
    w_col[canopy.fixed] = 0.0
    if backend == "numba":
        det = canopy.detector(params.spacing)
        first = [True]

        def detect(p):
            if first[0]:
                first[0] = False
                return det.detect(x, p, timings=stats)
            return det.redetect(p, timings=stats)           # only elements touching moved vertices
    else:
        def detect(p):
            return ccd.detect_collisions_numpy(x, p, canopy.faces, h=params.spacing, edges=canopy.edges,
                                               timings=stats)
    clean = False
    active = np.zeros((0, 4), np.int64)
    active_sides = np.zeros(0)
    for _ in range(params.max_collision_retries):
        cons, sides, _ = detect(p)
        stats["passes"] += 1
        if len(cons) == 0:
            clean = True
            break
        stats["constraints"] += len(cons)
        # [INFERRED] constraints found in earlier passes of this step stay in the set (unilateral, so an
        # inactive one costs nothing); solving only the newest ones lets contacts ping-pong between passes
        active, first = np.unique(np.concatenate([active, cons]), axis=0, return_index=True)
        active_sides = np.concatenate([active_sides, sides])[first]
        ccd.solve_collisions(p, w_col, active, active_sides, h=params.spacing, k_collision=params.k_collision,
                             iterations=params.collision_iterations)
    if not clean:                                          # fallback (I): roll back colliding vertices
        for _ in range(100):
            cons, _, _ = detect(p)
            stats["passes"] += 1
            if len(cons) == 0:
                clean = True
                break
            v = np.unique(cons)
            v = v[w_col[v] > 0]                          # attachments keep their prescribed positions (C8)
            if v.size == 0:
                break
            stats["rolled_back"] += len(v)
            p[v] = x[v]
        if not clean:
            p = x.copy()
    return p, stats


def grow(canopy: Canopy, stages_per_step: np.ndarray, params: SolverParams = SolverParams(), *,
         collisions: bool = True, sanity_every: int = 0, x0: np.ndarray | None = None,
         callback=None, prediction: str = "kinematic") -> tuple[np.ndarray, list[dict]]:
    """Run :func:`step` over a (T, n) schedule of per-instance stages; return final positions and stats.

    ``sanity_every > 0`` runs the static intersection check every that many steps and stores the count
    under ``intersections`` (must be 0). ``callback(t, x)`` is called after each step (e.g. OBJ export).
    ``prediction``: "kinematic" starts each step from the animation's displacement (see :func:`step`),
    "rest" from the previous positions with only the rest values changed (the App. B.5 prototype).
    """
    canopy, params = _check_run(canopy, params)
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable or None, got {type(callback).__name__}")
    S = check_array("stages_per_step", stages_per_step, shape=(None, canopy.n_instances), min_rows=1,
                    max_abs=1e12)
    prediction = check_choice("prediction", prediction, ("kinematic", "rest"))
    sanity_every = check_int("sanity_every", sanity_every, 0, 1_000_000)
    x = (canopy.initial_positions(S[0]) if x0 is None
         else check_array("x0", x0, shape=(canopy.voff[-1], 3), max_abs=MAX_COORD))
    log = []
    for t in range(1, S.shape[0]):
        x, st = step(canopy, x, S[t], params, collisions=collisions,
                     prev_stages=S[t - 1] if prediction == "kinematic" else None)
        if sanity_every and t % sanity_every == 0:
            st["intersections"] = ccd.count_static_intersections(x, canopy.faces, edges=canopy.edges)
        log.append(st)
        if callback is not None:
            callback(t, x)
    return x, log


def _int_table(name: str, value, shape: tuple) -> np.ndarray:
    """An int64 array of ``shape``; NaN, inf and huge or fractional values are refused (not truncated)."""
    try:
        arr = np.asarray(value) if not isinstance(value, np.ndarray) else value
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be an integer array of shape {shape}, "
                         f"got {type(value).__name__}") from None
    if arr.dtype.kind == "f" or arr.dtype == object:
        try:
            f = np.asarray(arr, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be an integer array, got {type(value).__name__}") from None
        if not np.all(np.isfinite(f)) or np.any(f != np.round(f)) or (f.size and np.abs(f).max() > 2.0 ** 62):
            raise ValueError(f"{name} must hold finite integer values")
    elif arr.dtype.kind not in "iub":
        raise ValueError(f"{name} must be an integer array, got dtype {arr.dtype}")
    return check_array(name, arr, shape=shape, dtype=np.int64)


def _check_run(canopy, params):
    if not isinstance(canopy, Canopy):
        raise ValueError(f"canopy must be a Canopy, got {type(canopy).__name__}")
    if not isinstance(params, SolverParams):
        raise ValueError(f"params must be a SolverParams, got {type(params).__name__}")
    return canopy, params
