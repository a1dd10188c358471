"""Loop-subdivision post-process with collision resolution (spec 002 §3.9, Figs. 4.7–4.8; C14, V25).

Each iteration quadrisects the (collision-free) canopy mesh at its edge midpoints (M_s: the same surface,
so still collision-free), moves the vertices to their Loop positions (M_f, the project's
:func:`plantvr.subdivision.loop.subdivide_loop`, same faces and vertex order as M_s), then runs the CCD and
collision-constraint rounds of Algorithm 1 from M_s to M_f (no internal constraints). Vertices that
still collide after the retries are rolled back to their M_s positions, which are collision-free, so
every iteration ends with 0 static intersections.

No second Loop scheme lives here: the midpoint mesh reuses the Loop step's face array and edge table.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import MAX_COORD, MAX_COUNT, check_array, check_choice, check_int
from plantvr.flowers import ccd
from plantvr.flowers.composer import SolverParams
from plantvr.subdivision.loop import edge_table, subdivide_loop

__all__ = ["loop_smooth", "midpoint_subdivide", "resolve_collisions"]


#: Faces :func:`loop_smooth` may produce (each iteration quadruples them).
MAX_SMOOTH_FACES = 50_000_000


def _faces(faces, n: int) -> np.ndarray:
    try:
        F = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
    except OverflowError:
        raise ValueError("faces must hold vertex indices, got huge values") from None
    if F.size and (F.min() < 0 or F.max() >= n):
        raise ValueError(f"faces must index vertices in [0, {n - 1}], got values in [{F.min()}, {F.max()}]")
    if len(F) > MAX_COUNT:
        raise ValueError(f"faces must have at most {MAX_COUNT} rows, got {len(F)}")
    return F


def _params(params) -> SolverParams:
    if params is None:
        return SolverParams()
    if not isinstance(params, SolverParams):
        raise ValueError(f"params must be a SolverParams or None, got {type(params).__name__}")
    return params


def midpoint_subdivide(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M_s of spec §3.9: one quadrisection with new vertices at edge midpoints (Fig. 4.7b).

    Vertex order and faces equal those of ``subdivide_loop(vertices, faces, 1)``: the old vertices first,
    then one vertex per edge of :func:`plantvr.subdivision.loop.edge_table` (asserted in V25).
    """
    V = check_array("vertices", vertices, shape=(None, 3), max_abs=MAX_COORD)
    F = _faces(faces, len(V))
    E, _ = edge_table(F, len(V))
    _, F2 = subdivide_loop(V, F, 1)
    return np.vstack([V, 0.5 * (V[E[:, 0]] + V[E[:, 1]])]), F2


def resolve_collisions(x0: np.ndarray, p: np.ndarray, faces: np.ndarray, w: np.ndarray,
                       params: SolverParams | None = None, *, edges: np.ndarray | None = None,
                       stats: dict | None = None) -> np.ndarray:
    """CCD + collision constraints with retries from collision-free ``x0`` to ``p`` (Alg. 1 lines 10–22).

    Vertices with ``w == 0`` never move. If contacts remain after ``params.max_collision_retries`` passes,
    the colliding free vertices are rolled back to ``x0`` (fallback (I) of spec §3.5).

    Returns
    -------
    (V, 3) float64 ndarray
        Collision-free end positions.
    """
    params = _params(params)
    x0 = check_array("x0", x0, shape=(None, 3), max_abs=MAX_COORD)
    p = check_array("p", p, shape=x0.shape, max_abs=MAX_COORD).copy()
    w = check_array("w", w, shape=(x0.shape[0],), max_abs=1e12)
    if w.size and w.min() < 0:
        raise ValueError(f"w (inverse masses) must be >= 0, got {w.min()!r}")
    if stats is not None and not isinstance(stats, dict):
        raise ValueError(f"stats must be a dict or None, got {type(stats).__name__}")
    det = ccd.CollisionDetector(faces, x0.shape[0], h=params.spacing, edges=edges)
    st = stats if stats is not None else {}
    for key in ("passes", "constraints", "rolled_back"):
        st.setdefault(key, 0)
    first = [True]

    def detect(q):
        if first[0]:
            first[0] = False
            return det.detect(x0, q, timings=st)
        return det.redetect(q, timings=st)

    active, active_sides = np.zeros((0, 4), np.int64), np.zeros(0)
    for _ in range(params.max_collision_retries):
        cons, sides, _ = detect(p)
        st["passes"] += 1
        if len(cons) == 0:
            return p
        st["constraints"] += len(cons)
        active, idx = np.unique(np.concatenate([active, cons]), axis=0, return_index=True)
        active_sides = np.concatenate([active_sides, sides])[idx]
        ccd.solve_collisions(p, w, active, active_sides, h=params.spacing, k_collision=params.k_collision,
                             iterations=params.collision_iterations)
    for _ in range(1000):                                   # fallback: roll back colliding free vertices
        cons, _, _ = detect(p)
        st["passes"] += 1
        if len(cons) == 0:
            return p
        v = np.unique(cons)
        v = v[w[v] > 0]
        if v.size == 0:
            break
        st["rolled_back"] += len(v)
        p[v] = x0[v]
    return x0.copy()


def loop_smooth(vertices: np.ndarray, faces: np.ndarray, n_iter: int = 2, *, fixed: np.ndarray | None = None,
                pin: str = "attachments", collisions: bool = True, boundary_rule: str = "loop_cubic",
                params: SolverParams | None = None, stats: list | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Loop smoothing with collision resolution after each iteration (spec 002 §3.9; Fig. 4.8 uses 2).

    Parameters
    ----------
    vertices : (V, 3) float64 array_like
        Collision-free canopy positions (e.g. the last frame of :func:`~plantvr.flowers.composer.grow`).
    faces : (F, 3) int64 array_like
        Manifold triangles (each edge in one or two faces), e.g. ``Canopy.faces``.
    n_iter : int
        Loop iterations, each followed by collision resolution.
    fixed : (K,) int array_like, optional
        Attachment vertices (``Canopy.fixed``). Old vertices keep their indices through every level, so
        these stay valid; they keep their positions (w = 0, [INFERRED] "if the base must stay put").
    pin : {"attachments", "coarse"}
        ``"attachments"``: only ``fixed`` is pinned during collision resolution. ``"coarse"``: every vertex
        that existed before the iteration (the even vertices) is treated as attached and only the new,
        subdivided vertices move to resolve contacts.
    collisions : bool
        ``False`` reproduces Fig. 4.8b (smoothing with no collision handling).
    boundary_rule : {"loop_cubic", "fixed"}
        Boundary rule of :func:`plantvr.subdivision.loop.subdivide_loop`; the default smooths petal outlines
        like trimesh does.
    params : SolverParams, optional
        Collision iterations, retries, stiffness and thickness ``spacing``.
    stats : list, optional
        Receives one dict per iteration (``passes``, ``constraints``, ``rolled_back``, ``broad``, ``narrow``).

    Returns
    -------
    vertices : (V', 3) float64 ndarray
    faces : (4**n_iter F, 3) int64 ndarray
    """
    params = _params(params)
    V = check_array("vertices", vertices, shape=(None, 3), max_abs=MAX_COORD)
    F = _faces(faces, len(V))
    n_iter = check_int("n_iter", n_iter, 0, 6)
    pin = check_choice("pin", pin, ("attachments", "coarse"))
    boundary_rule = check_choice("boundary_rule", boundary_rule, ("loop_cubic", "fixed"))
    if len(F) * 4 ** n_iter > MAX_SMOOTH_FACES:
        raise ValueError(f"n_iter={n_iter} would make {len(F) * 4 ** n_iter} faces from {len(F)}; at most "
                         f"{MAX_SMOOTH_FACES} (lower n_iter)")
    if stats is not None and not isinstance(stats, list):
        raise ValueError(f"stats must be a list or None, got {type(stats).__name__}")
    fx = np.zeros(0, np.int64) if fixed is None else check_array("fixed", fixed, shape=(None,), dtype=np.int64)
    if fx.size and (fx.min() < 0 or fx.max() >= len(V)):
        raise ValueError(f"fixed must index vertices in [0, {len(V) - 1}]")
    for _ in range(n_iter):
        n_old = len(V)
        Ms, F2 = midpoint_subdivide(V, F)
        Mf, F3 = subdivide_loop(V, F, 1, boundary_rule=boundary_rule)
        if not np.array_equal(F2, F3):                      # pragma: no cover - guarded by V25
            raise RuntimeError("midpoint and Loop faces differ")
        Mf[fx] = Ms[fx]
        if collisions:
            w = np.ones(len(Ms))
            w[fx] = 0.0
            if pin == "coarse":
                w[:n_old] = 0.0
            st = {}
            Mf = resolve_collisions(Ms, Mf, F2, w, params, stats=st)
            if stats is not None:
                stats.append(st)
        V, F = Mf, F2
    return V, F
