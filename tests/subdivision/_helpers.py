"""Helpers for the Yggdrasil tests (spec 001_subdivision)."""
import numpy as np

from plantvr.subdivision import BranchGraph

SAMPLE_LST = """LST 0.1
RotRel3f(0.3, 0, 0, 1) Cylinder(1, 1, 10) MovRel3f(0, 10, 0) SB() RotRel3f(-1.0, 0, 0, 1)
Cylinder(1, 1, 5) MovRel3f(0, 5, 0)
RotRel3f(-0.6, 0, 0, 1) Cylinder(1, 1, 5)
EB() SB()
RotRel3f(1.0, 0, 0, 1) Cylinder(1, 1, 5)
MovRel3f(0, 5, 0) RotRel3f(0.6, 0, 0, 1)
Cylinder(1, 1, 5) MovRel3f(0, 5, 0)
EB()
MovRel3f(0, 5, 0)
RotRel3f(0.6, 0, 0, 1)
Cylinder(1, 1, 10)
MovRel3f(0, 10, 0)
"""


def star_graph(k: int, *, radius: float = 0.05, length: float = 2.0) -> BranchGraph:
    """A trunk ending in one joint with ``k - 1`` children spread over the upper hemisphere."""
    m = k - 1
    i = np.arange(m) + 0.5
    z = 1.0 - i / m * 0.9                      # cos of the polar angle, away from the trunk direction
    phi = np.pi * (1 + 5 ** 0.5) * i
    s = np.sqrt(1 - z * z)
    dirs = np.stack([s * np.cos(phi), z, s * np.sin(phi)], 1)
    J = np.array([0.0, length, 0.0])
    start = np.vstack([[0.0, 0, 0], np.repeat(J[None], m, 0)])
    end = np.vstack([J, J + length * dirs])
    r = np.full(k, radius)
    return BranchGraph(start, end, r * 1.0, r * 1.0, np.r_[-1, np.zeros(m, np.int64)])


def mesh_invariants(V: np.ndarray, F: np.ndarray) -> dict:
    """Edge-incidence counts, directed-edge duplicates and Euler characteristic, fast for big meshes."""
    he = F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    n = len(V)
    und = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    _, cnt = np.unique(und, return_counts=True)
    directed = he[:, 0] * n + he[:, 1]
    dup = len(directed) - len(np.unique(directed))
    used = np.unique(F)
    return {"max_edge_faces": int(cnt.max()), "boundary_edges": int((cnt == 1).sum()),
            "duplicate_directed": int(dup), "euler": int(len(used) - len(cnt) + len(F)),
            "unused_vertices": int(n - len(used)),
            "degenerate": int(((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])).sum())}
