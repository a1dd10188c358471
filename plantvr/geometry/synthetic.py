"""Synthetic test trees: random binary trees with pipe-model radii, independent of the growth engine."""
import numpy as np

__all__ = ["leafy_tree", "random_tree"]


def random_tree(n_internodes: int, *, seed: int = 0, tip_radius: float = 0.01, exponent: float = 2.5,
                lateral_angle: float = 45.0):
    """Random binary tree grown by appending to random live buds; y is up.

    Returns pos (N,3), parent (N,), radius (N,), main_child (N,) with N = n_internodes + 1.
    """
    rng = np.random.default_rng(seed)
    n = n_internodes + 1
    pos = np.zeros((n, 3))
    head = np.zeros((n, 3))
    parent = np.full(n, -1, np.int64)
    main_child = np.full(n, -1, np.int64)
    nkids = np.zeros(n, np.int64)
    pos[1] = (0, 1.0, 0)
    head[1] = (0, 1.0, 0)
    parent[1] = 0
    main_child[0] = 1
    nkids[0] = 1
    buds = [1, 1]
    for i in range(2, n):
        k = rng.integers(len(buds))
        p = buds[k]
        buds[k] = buds[-1]
        buds.pop()
        h = head[p]
        a = rng.normal(size=3)
        a -= (a @ h) * h
        a /= np.linalg.norm(a)
        ang = np.deg2rad(lateral_angle if nkids[p] else rng.uniform(0, 15))
        d = np.cos(ang) * h + np.sin(ang) * a + np.array([0, 0.15, 0])
        d /= np.linalg.norm(d)
        length = 0.3 + 0.2 * rng.random()
        pos[i] = pos[p] + length * d
        head[i] = d
        parent[i] = p
        if nkids[p] == 0:
            main_child[p] = i
        nkids[p] += 1
        buds += [i, i]
    radius = np.zeros(n)
    radius_n = np.zeros(n)
    for i in range(n - 1, 0, -1):
        if radius_n[i] == 0:
            radius_n[i] = tip_radius ** exponent
        radius[i] = radius_n[i] ** (1 / exponent)
        if parent[i] > 0:
            radius_n[parent[i]] += radius_n[i]
    return pos, parent, radius, main_child


def leafy_tree(n_internodes: int, *, seed: int = 0, leaf_size: float = 0.2):
    """A :func:`random_tree` meshed: its branch mesh and one leaf at every tip, along the tip's internode.

    Returns pos, parent, radius, main_child, the :class:`~plantvr.geometry.mesh.BranchMesh`, the leaves'
    :class:`~plantvr.geometry.leaves.LeafMesh` and the tip node ids.
    """
    from .leaves import build_leaves
    from .mesh import build_branch_mesh
    pos, parent, radius, mc = random_tree(n_internodes, seed=seed)
    branches = build_branch_mesh(pos, parent, radius, main_child=mc)
    tips = np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)
    d = pos[tips] - pos[parent[tips]]
    leaves = build_leaves(pos[tips], d / np.linalg.norm(d, axis=1)[:, None], radius[tips], leaf_size=leaf_size,
                          rng=0)
    return pos, parent, radius, mc, branches, leaves, tips
