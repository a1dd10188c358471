"""Mesh-connectivity label tools: flood fill, geodesic fill, same-label components (spec 000_vine §6
"connectivity-aware brush"; issue 15).

The vertex graph of a triangle mesh is held as CSR arrays (``indptr``, ``indices``, edge lengths). Every
search is a numba kernel with a scipy ``csgraph`` twin used as the oracle in the tests:

* :func:`flood_region`  — vertices reachable from a seed through vertices of the seed's label
  (twin: ``breadth_first_order`` on the same-label subgraph), optionally within a geodesic radius along mesh
  edges (twin: ``dijkstra(..., limit=radius)``);
* :func:`label_components` — connected components of the graph restricted to edges whose two ends carry
  the same label (twin: ``connected_components``).
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass, field
from functools import cached_property

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from plantvr._validation import MAX_COORD, check_int, check_range

__all__ = ["MeshGraph", "flood_region", "label_components", "mesh_graph"]


@dataclass(frozen=True)
class MeshGraph:
    """Undirected vertex adjacency of a triangle mesh in CSR form.

    Attributes
    ----------
    indptr : (V + 1,) int64 ndarray
    indices : (2E,) int32 ndarray
        Neighbour ids, sorted within each row, no duplicates, no self loops.
    vertices : (V, 3) ndarray
        The mesh's vertex positions (a reference, for :attr:`weights`).
    """

    indptr: np.ndarray
    indices: np.ndarray
    vertices: np.ndarray = field(repr=False)

    @cached_property
    def weights(self) -> np.ndarray:
        """(2E,) float64 Euclidean edge lengths in model units (computed on first use: geodesic fill)."""
        return _edge_lengths_numba(self.indptr, self.indices, self.vertices)

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.indptr.size - 1)

    @property
    def nbytes(self) -> int:
        """Memory held by the CSR arrays (and the edge lengths once computed)."""
        w = self.__dict__.get("weights")
        return int(self.indptr.nbytes + self.indices.nbytes + (0 if w is None else w.nbytes))

    def to_scipy(self, weighted: bool = True) -> sp.csr_matrix:
        """The graph as a scipy CSR matrix (edge lengths, or ones)."""
        data = self.weights if weighted else np.ones(self.indices.size)
        n = self.n_vertices
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(n, n))


@numba.njit(cache=True, nogil=True)
def _edge_lengths_numba(indptr, indices, vertices):  # pragma: no cover - numba kernel, twin: _edge_lengths
    w = np.empty(indices.size, np.float64)
    for u in range(indptr.size - 1):
        for e in range(indptr[u], indptr[u + 1]):
            t = indices[e]
            dx = np.float64(vertices[u, 0]) - np.float64(vertices[t, 0])
            dy = np.float64(vertices[u, 1]) - np.float64(vertices[t, 1])
            dz = np.float64(vertices[u, 2]) - np.float64(vertices[t, 2])
            w[e] = np.sqrt(dx * dx + dy * dy + dz * dz)
    return w


def _edge_lengths(indptr, indices, vertices) -> np.ndarray:
    """Numpy twin of :func:`_edge_lengths_numba`."""
    n = indptr.size - 1
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
    d = vertices[rows].astype(np.float64) - vertices[indices].astype(np.float64)
    return np.sqrt(np.einsum("ij,ij->i", d, d))


@numba.njit(cache=True, nogil=True)
def _csr_numba(faces, n):  # pragma: no cover - numba kernel, twin: _csr_scipy
    """Vertex adjacency from triangles: count, scatter, then sort and de-duplicate each row in place."""
    start = np.zeros(n + 1, np.int64)
    for t in range(faces.shape[0]):
        for k in range(3):
            a, b = faces[t, k], faces[t, (k + 1) % 3]
            if a != b:
                start[a + 1] += 1
                start[b + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    buf = np.empty(start[n], np.int32)
    pos = start[:n].copy()
    for t in range(faces.shape[0]):
        for k in range(3):
            a, b = faces[t, k], faces[t, (k + 1) % 3]
            if a != b:
                buf[pos[a]] = b
                pos[a] += 1
                buf[pos[b]] = a
                pos[b] += 1
    indptr = np.zeros(n + 1, np.int64)
    m = 0
    for v in range(n):
        lo, hi = start[v], start[v + 1]
        for j in range(lo + 1, hi):                        # insertion sort: rows are short (~12)
            x = buf[j]
            i = j - 1
            while i >= lo and buf[i] > x:
                buf[i + 1] = buf[i]
                i -= 1
            buf[i + 1] = x
        for j in range(lo, hi):                            # compact unique ids (m <= lo: safe in place)
            if j == lo or buf[j] != buf[j - 1]:
                buf[m] = buf[j]
                m += 1
        indptr[v + 1] = m
    return indptr, buf[:m].copy()


def _csr_scipy(faces: np.ndarray, n: int):
    """scipy twin of :func:`_csr_numba` (COO → CSR with duplicates summed)."""
    f = faces.astype(np.int64, copy=False)
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    keep = a != b                                            # degenerate faces give no self loops
    a, b = a[keep], b[keep]
    m = sp.csr_matrix((np.ones(2 * a.size, np.int8), (np.concatenate([a, b]), np.concatenate([b, a]))),
                      shape=(n, n))
    m.sum_duplicates()
    m.sort_indices()
    return m.indptr.astype(np.int64), m.indices.astype(np.int32)


def _check_mesh_arrays(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) as arrays, checked: (V, 3) with V >= 1, and (F, 3) integer ids in [0, V - 1]."""
    try:
        v = np.asarray(vertices)
        f = np.asarray(faces)
    except (TypeError, ValueError):
        raise ValueError("vertices and faces must be numeric arrays of shape (V, 3) and (F, 3)") from None
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 1 or v.dtype.kind not in "fiu":
        raise ValueError(f"vertices must be a numeric array of shape (V, 3) with V >= 1, got {v.dtype} {v.shape}")
    if v.dtype.kind == "f" and not np.all(np.isfinite(v)):
        raise ValueError("vertices must contain only finite values (no NaN or inf)")
    if float(np.abs(v).max()) > MAX_COORD:
        raise ValueError(f"vertices must lie in [-{MAX_COORD:g}, {MAX_COORD:g}], got magnitude {float(np.abs(v).max()):g}")
    if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu":
        raise ValueError(f"faces must be an integer array of shape (F, 3), got {f.dtype} {f.shape}")
    if f.size and (int(f.min()) < 0 or int(f.max()) >= len(v)):
        raise ValueError(f"faces must index vertices in [0, {len(v) - 1}], got range [{f.min()}, {f.max()}]")
    return v, f


def mesh_graph(vertices: np.ndarray, faces: np.ndarray) -> MeshGraph:
    """Build the vertex adjacency (CSR) of a triangle mesh; edge lengths follow on first use.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
        Vertex positions.
    faces : (F, 3) integer ndarray
        Triangles, ids in [0, V - 1].

    Returns
    -------
    MeshGraph
        Each undirected mesh edge appears in both rows; shared edges appear once. About 32 B per vertex
        (+48 B once edge lengths are needed) for a closed triangle mesh.
    """
    v, f = _check_mesh_arrays(vertices, faces)
    n = v.shape[0]
    if n >= 2 ** 31:
        raise ValueError(f"vertices must number fewer than 2**31 (int32 neighbour ids), got {n}")
    indptr, indices = _csr_numba(np.ascontiguousarray(f), n)
    return MeshGraph(indptr, indices, v)


# ---------------------------------------------------------------------------------------------- kernels
@numba.njit(cache=True, nogil=True)
def _bfs_fill(indptr, indices, labels, seed, mark, unset, value, queue):  # pragma: no cover - numba kernel
    """Breadth-first fill from ``seed`` through vertices with the seed's label whose ``mark`` is still
    ``unset``: sets their ``mark`` to ``value`` and lists them in ``queue`` (seed first, in visit order);
    returns how many."""
    target = labels[seed]
    mark[seed] = value
    queue[0] = seed
    head, tail = 0, 1
    while head < tail:
        u = queue[head]
        head += 1
        for e in range(indptr[u], indptr[u + 1]):
            w = indices[e]
            if mark[w] == unset and labels[w] == target:
                mark[w] = value
                queue[tail] = w
                tail += 1
    return tail


@numba.njit(cache=True, nogil=True)
def _flood_numba(indptr, indices, labels, seed):  # pragma: no cover - numba kernel, twin: _flood_numpy
    """BFS from ``seed`` through vertices with the seed's label; returns the visited ids, sorted."""
    n = indptr.size - 1
    seen = np.zeros(n, np.bool_)
    queue = np.empty(n, np.int64)
    tail = _bfs_fill(indptr, indices, labels, seed, seen, False, True, queue)
    if tail * 16 > n:                                   # big region: a pass over the mask beats a sort
        k = 0
        for v in range(n):
            if seen[v]:
                queue[k] = v
                k += 1
        return queue[:tail].copy()
    return np.sort(queue[:tail])


@numba.njit(cache=True, nogil=True)
def _geodesic_numba(indptr, indices, weights, labels, seed, radius):  # pragma: no cover - numba kernel
    """Dijkstra from ``seed`` through same-label vertices, stopping at ``radius``; returns (ids, distances)."""
    n = indptr.size - 1
    target = labels[seed]
    dist = np.full(n, np.inf)
    done = np.zeros(n, np.bool_)
    dist[seed] = 0.0
    heap = [(0.0, np.int64(seed))]
    out = np.empty(n, np.int64)
    k = 0
    while len(heap) > 0:
        d, u = heapq.heappop(heap)
        if done[u]:
            continue
        done[u] = True
        out[k] = u
        k += 1
        for e in range(indptr[u], indptr[u + 1]):
            w = indices[e]
            if done[w] or labels[w] != target:
                continue
            nd = d + weights[e]
            if nd <= radius and nd < dist[w]:
                dist[w] = nd
                heapq.heappush(heap, (nd, np.int64(w)))
    ids = out[:k].copy()
    return ids, dist[ids]


@numba.njit(cache=True, nogil=True)
def _components_numba(indptr, indices, labels, only):  # pragma: no cover - numba kernel
    """Component id per vertex over same-label edges (-1 where ``only >= 0`` and the label differs).

    Components are numbered in order of their smallest vertex id.
    """
    n = indptr.size - 1
    comp = np.full(n, -1, np.int64)
    queue = np.empty(n, np.int64)
    c = 0
    for s in range(n):
        if comp[s] >= 0 or (only >= 0 and labels[s] != only):
            continue
        _bfs_fill(indptr, indices, labels, s, comp, -1, c, queue)
        c += 1
    return comp, c


# ---------------------------------------------------------------------------------------------- numpy twins
def _same_label_graph(graph: MeshGraph, labels: np.ndarray, weighted: bool = False) -> sp.csr_matrix:
    """The mesh graph keeping only edges whose two ends carry the same label."""
    n = graph.n_vertices
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(graph.indptr))
    keep = labels[rows] == labels[graph.indices]
    data = graph.weights[keep] if weighted else np.ones(int(keep.sum()), np.float64)
    return sp.csr_matrix((data, (rows[keep], graph.indices[keep])), shape=(n, n))


def _flood_numpy(graph: MeshGraph, labels: np.ndarray, seed: int) -> np.ndarray:
    """scipy twin of :func:`_flood_numba` (sorted ids)."""
    order = csgraph.breadth_first_order(_same_label_graph(graph, labels), seed, directed=False,
                                        return_predecessors=False)
    return np.sort(order.astype(np.int64))


def _geodesic_numpy(graph: MeshGraph, labels: np.ndarray, seed: int, radius: float):
    """scipy twin of :func:`_geodesic_numba`: (sorted ids, their distances)."""
    d = csgraph.dijkstra(_same_label_graph(graph, labels, weighted=True), directed=False, indices=seed,
                         limit=radius)
    ids = np.flatnonzero(np.isfinite(d))
    return ids, d[ids]


def _components_numpy(graph: MeshGraph, labels: np.ndarray, only: int = -1):
    """scipy twin of :func:`_components_numba` (same numbering: by smallest vertex id)."""
    n_comp, comp = csgraph.connected_components(_same_label_graph(graph, labels), directed=False)
    comp = comp.astype(np.int64)
    if only >= 0:
        comp[labels != only] = -1
    first = np.full(n_comp, np.iinfo(np.int64).max)
    sel = comp >= 0
    np.minimum.at(first, comp[sel], np.flatnonzero(sel))
    used = np.flatnonzero(first < np.iinfo(np.int64).max)
    remap = np.full(n_comp, -1, np.int64)
    remap[used[np.argsort(first[used])]] = np.arange(used.size)
    out = np.where(sel, remap[np.maximum(comp, 0)], -1)
    return out, int(used.size)


# ---------------------------------------------------------------------------------------------- public
def _check_labels(graph: MeshGraph, labels) -> np.ndarray:
    if not isinstance(graph, MeshGraph):
        raise ValueError(f"graph must be a MeshGraph, got {type(graph).__name__}")  # noqa: TRY004
    lab = np.asarray(labels)
    if lab.shape != (graph.n_vertices,) or lab.dtype.kind not in "iu":
        raise ValueError(f"labels must be an integer array of shape ({graph.n_vertices},), "
                         f"got {lab.dtype} {lab.shape}")
    return lab


def flood_region(graph: MeshGraph, labels: np.ndarray, seed: int, *, radius: float | None = None,
                 return_distances: bool = False):
    """Vertices connected to ``seed`` through vertices of the seed's current label.

    Parameters
    ----------
    graph : MeshGraph
        From :func:`mesh_graph`.
    labels : (V,) integer ndarray
        Current labels.
    seed : int
        Picked vertex, in [0, V - 1].
    radius : float, optional
        Geodesic limit along mesh edges (model units, in [0, inf)); ``None`` = the whole connected region.
    return_distances : bool
        Also return the geodesic distances (only with ``radius``).

    Returns
    -------
    ids : (K,) int64 ndarray
        Sorted vertex ids, ``seed`` included.
    dist : (K,) float64 ndarray
        Only with ``return_distances``.

    References
    ----------
    .. [1] Spec 000_vine §6 "connectivity-aware brush (geodesic flood fill)"; Dijkstra over edge lengths.
    """
    lab = _check_labels(graph, labels)
    seed = check_int("seed", seed, 0, graph.n_vertices - 1)
    if radius is None:
        if return_distances:
            raise ValueError("return_distances needs a radius, got radius=None")
        return _flood_numba(graph.indptr, graph.indices, lab, seed)
    radius = check_range("radius", radius, 0.0, np.inf, high_open=True)
    ids, dist = _geodesic_numba(graph.indptr, graph.indices, graph.weights, lab, seed, radius)
    order = np.argsort(ids)
    return (ids[order], dist[order]) if return_distances else ids[order]


def label_components(graph: MeshGraph, labels: np.ndarray, *, label: int | None = None):
    """Connected components over edges whose two ends carry the same label.

    Parameters
    ----------
    graph : MeshGraph
    labels : (V,) integer ndarray
    label : int, optional
        Only label the vertices of this label (others get -1); default all vertices.

    Returns
    -------
    comp : (V,) int64 ndarray
        Component id per vertex, numbered by each component's smallest vertex id (-1 = not labelled).
    n : int
        Number of components.
    """
    lab = _check_labels(graph, labels)
    only = -1 if label is None else check_int("label", label, 0, 2 ** 31 - 1)
    comp, n = _components_numba(graph.indptr, graph.indices, lab, only)
    return comp, int(n)
