"""Display proxy of a ViNE segmentation: a decimated copy whose vertices stand for full-resolution vertex sets
(issue 14; spec 000_vine §4.4, §6 "level of detail ... with colour indices carried per vertex").

The proxy is what a browser or a CPU renderer draws; painting, hiding and undo always act on the full-resolution
labels of the labels document (:class:`plantvr.documents.labels.Segmentation`). The proxy observes the
document's ``change`` trait and publishes its own ``change`` the same way, with proxy vertex ids, so a view
observes a proxy exactly as it observes the document: ``proxy.observe(fn, names="change")``. Each full-resolution vertex belongs to exactly one proxy
vertex (``owner``); the members of a proxy vertex are stored once as a CSR list (``members``, ``starts``), so
the memory is 8 bytes per full-resolution vertex. A proxy vertex's label is the most frequent label among its
visible members (among all members when none is visible; ties go to the smaller label). After a paint or an
undo only the proxy vertices that own a changed vertex are recomputed (cost ∝ the change, not the mesh).

Building: coincident points are merged first (decimators stop early on them), then fast-simplification's
quadric decimation runs to a triangle budget and returns its collapse history; following that history gives
each merged vertex the surviving vertex it was collapsed into. The few vertices whose survivor vanished (a tiny
component decimated away) are assigned to their nearest proxy vertex (``scipy.spatial.cKDTree``).

Memory: fast-simplification holds ~170 bytes per triangle and ~120 per vertex in vectors grown by doubling, so
one call on a 36 M-face gerbera-class mesh peaks near 14 GiB. Meshes above ``chunk_faces`` (6 M) are therefore
decimated in two stages (:func:`decimate_with_owner`): equal-count slabs with their cut borders locked, then the
union of the slabs to the budget; the owner map is the composition of the two collapse histories. Merging and
mapping use int32 ids throughout. Measured at 36 M faces on 2 cores (``benchmarks/vine_proxy.py``): 85 s and
3.65 GiB peak RSS (mesh included) against 94 s and 14.4 GiB for the one-pass build.
"""
from __future__ import annotations

import dataclasses
import time

import numba
import numpy as np
from scipy.spatial import cKDTree
from traitlets import Any, HasTraits

from plantvr._sorting import counting_sort
from plantvr._validation import check_choice, check_int, check_range

__all__ = ["DisplayProxy", "decimate_with_owner", "merge_coincident", "proxy_labels"]


# ---------------------------------------------------------------------------------------------- merging
@numba.njit(cache=True, nogil=True)
def _merge_hash(keys):  # pragma: no cover - numba kernel, twin: _merge_numpy
    """First-occurrence unique rows of (V, 3) uint32 keys (V < 2**30) through an open-addressing hash table."""
    n = keys.shape[0]
    size = 1
    while size < 2 * n:
        size *= 2
    table = np.full(size, -1, np.int32)                      # int32: 18 M vertices -> 256 MiB, not 512
    inverse = np.empty(n, np.int32)
    first = np.empty(n, np.int32)
    m = 0
    mask = size - 1
    for v in range(n):
        a, b, c = np.uint64(keys[v, 0]), np.uint64(keys[v, 1]), np.uint64(keys[v, 2])
        h = (a << np.uint64(32)) ^ b ^ (c * np.uint64(0x9E3779B97F4A7C15))
        h ^= h >> np.uint64(30)                               # splitmix64 finaliser: float bit patterns of
        h *= np.uint64(0xBF58476D1CE4E5B9)                    # grid-aligned vertices share low bits
        h ^= h >> np.uint64(27)
        h *= np.uint64(0x94D049BB133111EB)
        h ^= h >> np.uint64(31)
        s = np.int64(h & np.uint64(mask))
        while True:
            u = table[s]
            if u < 0:
                table[s] = np.int32(m)
                first[m] = np.int32(v)
                inverse[v] = np.int32(m)
                m += 1
                break
            w = first[u]
            if keys[w, 0] == keys[v, 0] and keys[w, 1] == keys[v, 1] and keys[w, 2] == keys[v, 2]:
                inverse[v] = u
                break
            s = (s + 1) & mask
    return first[:m], inverse


def _merge_numpy(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Numpy twin of ``_merge_hash``: (first-occurrence ids of unique rows, inverse), first-occurrence order."""
    _, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return first[order].astype(np.int32), rank[inv.ravel()].astype(np.int32)


def merge_coincident(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge vertices with bit-identical coordinates (``+0.0`` and ``-0.0`` are merged too).

    Parameters
    ----------
    vertices : (V, 3) float32 ndarray
    faces : (F, 3) integer ndarray

    Returns
    -------
    unique : (U,) int32 ndarray
        Id of the first vertex of each merged group, in first-occurrence order.
    inverse : (V,) int32 ndarray
        Merged id of every input vertex (``vertices[unique][inverse]`` equals ``vertices``).
    faces : (F', 3) int32 ndarray
        Faces over merged ids, with faces that became degenerate removed.

    Notes
    -----
    Everything is int32 (V < 2**30) and the faces are renumbered in place, so the extra memory is about
    ``V * 26 + F * 13`` bytes (18 M vertices, 36 M faces: ~0.9 GiB) where int64 needed ~2.9 GiB.
    """
    v = np.asarray(vertices, np.float32)
    if len(v) >= 2 ** 30:
        raise ValueError(f"vertices must be fewer than 2**30, got {len(v)}")
    v = v + np.float32(0.0)                                   # -0.0 -> +0.0 (also the contiguous copy)
    keys = v.view(np.uint32).reshape(-1, 3)
    first, inverse = _merge_hash(keys)
    del v, keys
    f = np.asarray(faces)
    out = np.empty(f.shape, np.int32)
    np.take(inverse, f, out=out)                              # no int64 copy of the faces
    keep = out[:, 0] != out[:, 1]
    keep &= out[:, 1] != out[:, 2]
    keep &= out[:, 0] != out[:, 2]
    return first, inverse, out if keep.all() else out[keep]


# ---------------------------------------------------------------------------------------------- mapping
@numba.njit(cache=True, nogil=True)
def _collapse_roots(n, collapses):  # pragma: no cover - numba kernel, twin: _collapse_roots_numpy
    parent = np.arange(n)
    for i in range(collapses.shape[0]):
        parent[collapses[i, 1]] = collapses[i, 0]
    for v in range(n):                                        # path compression
        r = v
        while parent[r] != r:
            r = parent[r]
        x = v
        while parent[x] != r:
            nx = parent[x]
            parent[x] = r
            x = nx
    return parent


def _collapse_roots_numpy(n: int, collapses: np.ndarray) -> np.ndarray:
    """Numpy twin of ``_collapse_roots``: one scatter, then pointer jumping to the roots."""
    parent = np.arange(n)
    parent[collapses[:, 1]] = collapses[:, 0]                 # each vertex is collapsed at most once
    while True:
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            return parent
        parent = nxt


def _collapse_owner(n: int, faces: np.ndarray, collapses: np.ndarray, n_out: int
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Owner of each of ``n`` input vertices among fast-simplification's ``n_out`` output vertices.

    Follows the collapse history to each vertex's surviving root; survivors are the roots still referenced by a
    non-degenerate face, output in id order. Returns ``(owner, survivors)`` with ``owner`` (n,) int32 (-1 where
    the root was decimated away: a tiny component) and ``survivors`` (n_out,) int64 input ids, or None when the
    survivors cannot be matched to the output.
    """
    root = _collapse_roots(n, collapses) if len(collapses) else np.arange(n)
    ref = np.zeros(n, bool)
    for lo in range(0, len(faces), 1 << 22):                  # in blocks: no (F, 3) int64 temporaries
        rf = root[faces[lo:lo + (1 << 22)]]
        nd = (rf[:, 0] != rf[:, 1]) & (rf[:, 1] != rf[:, 2]) & (rf[:, 0] != rf[:, 2])
        ref[rf[nd].ravel()] = True
    survivors = np.flatnonzero(ref)
    if len(survivors) != n_out:
        return None
    rank = np.full(n, -1, np.int32)
    rank[survivors] = np.arange(n_out, dtype=np.int32)       # fast-simplification keeps survivors in id order
    return rank[root], survivors


def _simplify(points: np.ndarray, faces: np.ndarray, target: int, agg: float, preserve_border: bool
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """fast-simplification to ``target`` faces: (points float64, faces int32, owner or None, survivors or None)."""
    import fast_simplification
    if target >= len(faces):
        n = len(points)
        return np.asarray(points, np.float64), faces, np.arange(n, dtype=np.int32), np.arange(n)
    pts, pf, col = fast_simplification.simplify(np.asarray(points, np.float64), faces, target_count=int(target),
                                                agg=agg, return_collapses=True, preserve_border=preserve_border)
    pf = np.ascontiguousarray(pf, np.int32)
    m = _collapse_owner(len(points), faces, np.asarray(col, np.int64), len(pts))
    del col
    return pts, pf, *(m if m is not None else (None, None))


def _chunk_of_faces(vertices: np.ndarray, faces: np.ndarray, n_chunks: int) -> np.ndarray:
    """(F,) uint8 chunk of each face: equal-count slabs along the longest axis, by the face's first vertex."""
    ax = int(np.argmax(vertices.max(0) - vertices.min(0)))
    x = vertices[:, ax][faces[:, 0]]
    edges = np.quantile(x[:: max(1, len(x) // 1_000_000)], np.linspace(0, 1, n_chunks + 1)[1:-1])
    return np.searchsorted(edges, x, side="right").astype(np.uint8)


def decimate_with_owner(vertices: np.ndarray, faces: np.ndarray, target_faces: int, *, agg: float = 7.0,
                        chunk_faces: int = 6_000_000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quadric decimation (fast-simplification) with the proxy vertex owning every input vertex.

    Meshes above ``chunk_faces`` are decimated in two stages so that fast-simplification, which holds ~170 bytes
    per triangle and ~120 per vertex and grows them by doubling (36 M faces: ~11 GiB at its peak), only ever
    sees a bounded mesh: stage 1 decimates equal-count slabs of faces separately with their cut borders locked
    (``preserve_border``; shared vertices stay identical), stage 2 decimates their union to the budget.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
        Vertices without coincident duplicates (see :func:`merge_coincident`).
    faces : (F, 3) int32 ndarray
    target_faces : int
        Triangle budget, in [4, 2**31 - 1].
    agg : float
        fast-simplification aggressiveness, in [0, 10].
    chunk_faces : int
        Most faces handed to one fast-simplification call, in [1000, 2**31 - 1].

    Returns
    -------
    points : (P, 3) float32 ndarray
    faces : (Fp, 3) uint32 ndarray
    owner : (V,) int32 ndarray
        Proxy vertex of every input vertex: its collapse survivor; the nearest proxy vertex where the survivor
        was decimated away, the vertex is in no face, or the survivor lies more than 3 median proxy edge lengths
        away (long collapse chains; every proxy vertex keeps at least one member).
    """
    target_faces = check_int("target_faces", target_faces, 4, 2 ** 31 - 1)
    agg = check_range("agg", agg, 0.0, 10.0)
    chunk_faces = check_int("chunk_faces", chunk_faces, 1000, 2 ** 31 - 1)
    faces = np.ascontiguousarray(faces, np.int32)
    n, nf = len(vertices), len(faces)
    n_chunks = min(255, -(-nf // chunk_faces))
    stage1 = min(nf, max(3 * target_faces, chunk_faces // 2))   # faces left after stage 1, all chunks together
    if n_chunks <= 1 or stage1 >= nf:
        pts, pf, owner, _ = _simplify(vertices, faces, target_faces, agg, False)
        if owner is None:
            owner = np.full(n, -1, np.int32)
    else:
        chunk = _chunk_of_faces(vertices, faces, n_chunks)
        owner1 = np.full(n, -1, np.int32)                     # stage-1 owner of each input vertex (chunk-local)
        owner1_chunk = np.zeros(n, np.uint8)
        parts = []
        used = np.zeros(n, bool)                              # O(V) relabelling per chunk instead of a sort
        local = np.empty(n, np.int32)
        for c in range(n_chunks):
            fc = faces[chunk == c]
            if not len(fc):
                continue
            used[fc.ravel()] = True
            glob = np.flatnonzero(used)                       # == np.unique(fc)
            used[glob] = False
            local[glob] = np.arange(len(glob), dtype=np.int32)
            loc = local[fc]                                   # == np.unique(fc, return_inverse=True)[1]
            del fc
            tc = max(4, round(len(loc) * stage1 / nf))
            pts, pf, own, surv = _simplify(vertices[glob], loc, tc, agg, True)
            if own is None:                                   # unmatched history: keep this chunk undecimated
                pts, pf, own, surv = _simplify(vertices[glob], loc, len(loc), agg, True)
            del loc
            hit = own >= 0
            owner1[glob[hit]] = own[hit]
            owner1_chunk[glob[hit]] = c
            parts.append((c, glob[surv], pts, pf))
            del glob, own, surv, hit
        del chunk, used, local
        # union of the chunk meshes: locked cut vertices are survivors of both chunks with the same input id
        gid = np.concatenate([p[1] for p in parts])
        uniq, first, inv = np.unique(gid, return_index=True, return_inverse=True)
        inv = inv.astype(np.int32)
        pts1 = np.concatenate([p[2] for p in parts])[first]
        offs = np.cumsum([0] + [len(p[1]) for p in parts])
        f1 = np.concatenate([inv[o + p[3]] for o, p in zip(offs, parts)])
        base = np.zeros(256, np.int64)
        for o, p in zip(offs, parts):
            base[p[0]] = o
        del parts, gid, uniq, first
        hit = owner1 >= 0
        owner1[hit] = inv[base[owner1_chunk[hit]] + owner1[hit]]
        del owner1_chunk, inv, base
        pts, pf, owner2, _ = _simplify(pts1, f1, target_faces, agg, False)
        if owner2 is None:
            owner2 = np.full(len(pts1), -1, np.int32)
        owner = np.where(hit, owner2[np.maximum(owner1, 0)], -1).astype(np.int32)
        del owner1, hit
    pts = np.ascontiguousarray(pts, np.float32)
    pf = np.ascontiguousarray(pf, np.uint32)
    tree = None
    lost = np.flatnonzero(owner < 0)
    if lost.size:                                             # decimated-away components, or in no face
        tree = cKDTree(pts)
        _, near = tree.query(np.asarray(vertices[lost], np.float64), workers=-1)
        owner[lost] = near
    _pull_far_members(vertices, pts, pf, owner, tree)
    return pts, pf, owner


def _pull_far_members(vertices: np.ndarray, pts: np.ndarray, pf: np.ndarray, owner: np.ndarray,
                      tree: cKDTree | None = None, factor: float = 3.0) -> None:
    """Give a vertex further than ``factor`` median proxy edges from its collapse survivor to the nearest proxy
    vertex instead (long collapse chains on flat parts), in place; every proxy vertex keeps at least one member."""
    if not len(pf):
        return
    e = pts[pf[:, 0].astype(np.int64)] - pts[pf[:, 1].astype(np.int64)]
    lim2 = float(np.median(np.einsum("ij,ij->i", e, e))) * factor ** 2
    far = []
    for lo in range(0, len(owner), 1 << 22):                  # in blocks: no (V, 3) temporaries
        d = pts[owner[lo:lo + (1 << 22)]] - vertices[lo:lo + (1 << 22)]
        far.append(lo + np.flatnonzero(np.einsum("ij,ij->i", d, d) > lim2))
    far = np.concatenate(far)
    if not far.size:
        return
    tree = tree if tree is not None else cKDTree(pts)
    _, near = tree.query(np.asarray(vertices[far], np.float64), workers=-1)
    old = owner[far].copy()
    owner[far] = near
    for _ in range(4):                                        # undo moves that left a proxy vertex memberless
        empty = np.bincount(owner, minlength=len(pts)) == 0
        if not empty.any():
            return
        back = empty[old]
        owner[far[back]] = old[back]
    owner[far] = old                                          # give up: the plain collapse map


# ---------------------------------------------------------------------------------------------- labels
@numba.njit(cache=True, nogil=True)
def _proxy_labels_kernel(members, starts, labels, visible, pids, out):  # pragma: no cover - twin below
    # one count per possible label: visible has 256 entries for uint8 labels, up to 65536 for uint16 ones
    counts = np.zeros(visible.shape[0], np.int64)
    seen = np.empty(visible.shape[0], np.int64)
    for t in range(pids.shape[0]):
        p = pids[t]
        k = 0
        for s in range(starts[p], starts[p + 1]):
            lab = labels[members[s]]
            if counts[lab] == 0:
                seen[k] = lab
                k += 1
            counts[lab] += 1
        best = -1
        best_n = -1
        best_vis = False
        for i in range(k):
            lab = seen[i]
            c = counts[lab]
            vis = visible[lab]
            if (vis and not best_vis) or (vis == best_vis and (c > best_n or (c == best_n and lab < best))):
                best, best_n, best_vis = lab, c, vis
            counts[lab] = 0
        out[p] = max(best, 0)


def _proxy_labels_numpy(owner: np.ndarray, n_proxy: int, labels: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """Numpy twin: rank (visible, count, -label) per proxy vertex with one lexsort (uint8 or uint16 labels)."""
    labels = np.asarray(labels)
    base = 256 if labels.dtype == np.uint8 else 65536          # one key slot per possible label
    key = owner.astype(np.int64) * base + labels
    uk, cnt = np.unique(key, return_counts=True)
    p, lab = uk // base, (uk % base).astype(labels.dtype)
    vis = _lut(visible, labels.dtype)[lab].astype(np.int64)
    order = np.lexsort((lab, -cnt, -vis, p))                  # per p: visible first, most frequent, smallest
    p_sorted = p[order]
    first = np.ones(len(order), bool)
    first[1:] = p_sorted[1:] != p_sorted[:-1]
    out = np.zeros(n_proxy, labels.dtype)
    out[p_sorted[first]] = lab[order][first]
    return out


def proxy_labels(owner: np.ndarray, n_proxy: int, labels: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """Label of each proxy vertex from the full-resolution labels of its members.

    Parameters
    ----------
    owner : (V,) integer ndarray
        Proxy vertex of every full-resolution vertex, in [0, n_proxy).
    n_proxy : int
        Number of proxy vertices.
    labels : (V,) uint8 or uint16 ndarray
        Full-resolution labels (any other integer dtype is taken as uint8, as before).
    visible : (N,) bool ndarray
        Visibility per label (missing entries are hidden).

    Returns
    -------
    (n_proxy,) ndarray of the labels' dtype (uint8 or uint16)
        Most frequent visible member label (all members when none is visible; ties to the smaller label).
    """
    own = np.asarray(owner)
    n_proxy = check_int("n_proxy", n_proxy, 1, 2 ** 31 - 1)
    if own.shape != np.asarray(labels).shape:
        raise ValueError(f"owner and labels must have the same shape, got {own.shape} and {np.shape(labels)}")
    lab = np.asarray(labels)
    lab = lab if lab.dtype == np.uint16 else np.asarray(lab, np.uint8)
    members, starts = counting_sort(own, n_proxy, np.int32)
    out = np.zeros(n_proxy, lab.dtype)
    _proxy_labels_kernel(members, starts, lab, _lut(visible, lab.dtype), np.arange(n_proxy), out)
    return out


def _lut(visible, dtype=np.uint8) -> np.ndarray:
    """Visibility padded to one entry per possible label of ``dtype`` (256 for uint8, 65536 for uint16)."""
    vis = np.asarray(visible, bool)
    lut = np.zeros(max(256 if np.dtype(dtype) == np.uint8 else 65536, len(vis)), np.bool_)
    lut[:len(vis)] = vis
    return lut


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    fn = np.cross(b - a, c - a)                               # area-weighted
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return (n / np.where(norm > 0, norm, 1)).astype(np.float32)


# ---------------------------------------------------------------------------------------------- the proxy
class DisplayProxy(HasTraits):
    """A decimated, label-following copy of a segmentation's mesh for display (issue 14).

    Parameters
    ----------
    seg : Segmentation
        The full-resolution labels document (its labels stay the only truth); anything with ``vertices``,
        ``faces``, ``normals``, ``labels``, ``colors`` and a ``change`` trait.
    target_faces : int
        Triangle budget of the proxy, in [4, 2**31 - 1]; a mesh already within it is used as is (identity map).
    method : {"collapse", "nearest"}
        ``collapse``: each vertex belongs to the survivor of its decimation collapse chain (topological;
        default). ``nearest``: each vertex belongs to its nearest proxy vertex (cKDTree).
    agg : float
        fast-simplification aggressiveness, in [0, 10].
    chunk_faces : int
        Most faces one fast-simplification call sees (bigger meshes are decimated in two stages, see
        :func:`decimate_with_owner`), in [1000, 2**31 - 1]. Bounds the build's peak memory.
    observe : bool
        Follow the segmentation's changes (paint, undo, hide, colours) automatically, republishing each as
        this proxy's :attr:`change`.
    base : DisplayProxy or None
        Decimate this proxy's display mesh of the same ``seg`` instead of the full-resolution mesh and compose
        the owner maps (a coarser level of detail without decimating the full mesh again); see :meth:`coarser`.

    Attributes
    ----------
    vertices : (P, 3) float32 ndarray
    faces : (Fp, 3) uint32 ndarray
    normals : (P, 3) float32 ndarray
    owner : (V,) int32 ndarray
        Proxy vertex of every full-resolution vertex.
    members, starts : (V,) int32 and (P + 1,) int32 ndarrays
        Members of proxy vertex ``p``: ``members[starts[p]:starts[p + 1]]``.
    labels : (P,) uint8 or uint16 ndarray
        Proxy labels (see module docstring), in the document's label dtype (uint16 past 256 colours).
    timings : dict
        Seconds spent in each build step.
    change : plantvr.document.Change
        The latest change of the proxy: the document's change, with ``ids`` the proxy vertices whose label
        changed for ``"labels"`` (observe ``names="change"``).
    """

    change = Any(None, allow_none=True, help="The latest Change, in proxy vertex ids (observe names='change').")

    def __init__(self, seg, *, target_faces: int = 1_500_000, method: str = "collapse",
                 agg: float = 7.0, chunk_faces: int = 6_000_000, observe: bool = True,
                 base: "DisplayProxy | None" = None):
        if not all(hasattr(seg, k) for k in ("vertices", "faces", "labels", "colors", "n_vertices")) \
                or not isinstance(seg, HasTraits) or not seg.has_trait("change"):
            raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")
        if base is not None and (not isinstance(base, DisplayProxy) or base.seg is not seg):
            raise ValueError("base must be a DisplayProxy of the same segmentation")
        target_faces = check_int("target_faces", target_faces, 4, 2 ** 31 - 1)
        method = check_choice("method", method, ("collapse", "nearest"))
        agg = check_range("agg", agg, 0.0, 10.0)
        chunk_faces = check_int("chunk_faces", chunk_faces, 1000, 2 ** 31 - 1)
        self.seg = seg
        self.colors = seg.colors                              # shared table: recolouring edits it once
        super().__init__()
        self.timings: dict[str, float] = {}
        t0 = time.perf_counter()
        src_v, src_f = (seg.vertices, seg.faces) if base is None else (base.vertices, base.faces)
        if len(src_f) <= target_faces:
            self.vertices = src_v
            self.faces = src_f
            owner = np.arange(seg.n_vertices, dtype=np.int32) if base is None else base.owner.copy()
            self.timings["merge"] = self.timings["decimate"] = 0.0
        else:
            first, inverse, mf = merge_coincident(src_v, src_f)
            t1 = time.perf_counter()
            self.timings["merge"] = t1 - t0
            merged = src_v[first]
            del first
            pts, pf, owner_m = decimate_with_owner(merged, mf, target_faces, agg=agg, chunk_faces=chunk_faces)
            del mf
            t2 = time.perf_counter()
            self.timings["decimate"] = t2 - t1
            self.vertices, self.faces = pts, pf
            if method == "nearest":
                _, near = cKDTree(self.vertices).query(merged, workers=-1)
                owner_m = near.astype(np.int32)
                del near
            del merged
            owner = owner_m[inverse]                          # int32 (V,) (of the base's vertices with a base)
            del owner_m, inverse
            if base is not None:
                owner = owner[base.owner]
            self.timings["map"] = time.perf_counter() - t2
        self.method = method
        t3 = time.perf_counter()
        self.owner = owner
        self.members, self.starts = counting_sort(owner, len(self.vertices), np.int32)
        del owner
        self.normals = seg.normals if self.vertices is seg.vertices and seg.normals is not None \
            else _vertex_normals(self.vertices, self.faces.astype(np.int64))
        self.labels = np.zeros(len(self.vertices), seg.labels.dtype)
        self.recompute()
        self.timings["labels"] = time.perf_counter() - t3
        self.timings["total"] = time.perf_counter() - t0
        self._observing = False
        if observe:
            seg.observe(self._on_change, names="change")
            self._observing = True

    def coarser(self, target_faces: int, **kwargs) -> "DisplayProxy":
        """A coarser proxy of the same segmentation, decimated from this one's display mesh.

        Its owner map is this proxy's composed with the new decimation, so every full-resolution vertex still
        belongs to exactly one vertex of it; cheap next to decimating the full-resolution mesh again (the level
        of detail the browser draws while a stroke runs). ``kwargs`` as for :class:`DisplayProxy`.
        """
        return DisplayProxy(self.seg, target_faces=target_faces, base=self, **kwargs)

    # ------------------------------------------------------------------ sizes
    @property
    def n_vertices(self) -> int:
        """Number of proxy vertices."""
        return int(self.vertices.shape[0])

    @property
    def nbytes(self) -> int:
        """Memory of the mapping (owner + members + starts) and the proxy labels."""
        return int(self.owner.nbytes + self.members.nbytes + self.starts.nbytes + self.labels.nbytes)

    def members_of(self, p: int) -> np.ndarray:
        """Full-resolution vertex ids that proxy vertex ``p`` stands for ((K,) int32, ascending)."""
        p = check_int("p", p, 0, self.n_vertices - 1)
        return self.members[self.starts[p]:self.starts[p + 1]]

    # ------------------------------------------------------------------ labels
    def recompute(self) -> None:
        """Recompute every proxy label from the full-resolution labels (O(V)); proxy labels follow the
        document's dtype (uint8, or uint16 once its labels widened)."""
        lab = self.seg.labels
        if self.labels.dtype != lab.dtype:
            self.labels = np.zeros(self.n_vertices, lab.dtype)
        _proxy_labels_kernel(self.members, self.starts, lab, self.colors.paintable_lut(),
                             np.arange(self.n_vertices), self.labels)

    def labels_from(self, labels: np.ndarray) -> np.ndarray:
        """Proxy labels for another full-resolution label array (e.g. a triple-buffer snapshot), uint8 or
        uint16 (the result has its dtype)."""
        lab = np.asarray(labels)
        if lab.dtype not in (np.uint8, np.uint16) or lab.shape != (self.seg.n_vertices,):
            raise ValueError(f"labels must be uint8 or uint16 of shape ({self.seg.n_vertices},), got {lab.dtype} "
                             f"{lab.shape}")
        if lab.dtype == np.uint16 and not self.colors.wide:
            raise ValueError("labels must be uint8 for a segmentation with uint8 labels, got uint16")
        out = np.empty(self.n_vertices, lab.dtype)
        _proxy_labels_kernel(self.members, self.starts, lab, self.colors.paintable_lut(),
                             np.arange(self.n_vertices), out)
        return out

    def update(self, ids: np.ndarray) -> np.ndarray:
        """Recompute the proxy vertices owning the changed full-resolution ``ids``.

        Parameters
        ----------
        ids : (K,) integer ndarray
            Full-resolution vertex ids whose labels changed.

        Returns
        -------
        (M,) int64 ndarray
            Proxy vertex ids whose label changed (sorted); their new labels are ``self.labels[...]``.
        """
        ids = np.asarray(ids)
        if ids.size == 0:
            return np.zeros(0, np.int64)
        if ids.dtype.kind not in "iu" or ids.ndim != 1:
            raise ValueError(f"ids must be a 1-D integer array, got {ids.dtype} {ids.shape}")
        lab = self.seg.labels
        if self.labels.dtype != lab.dtype:                    # the document widened to uint16 labels
            self.labels = self.labels.astype(lab.dtype)
        pids = np.unique(self.owner[ids]).astype(np.int64)
        old = self.labels[pids]
        _proxy_labels_kernel(self.members, self.starts, lab, self.colors.paintable_lut(), pids, self.labels)
        return pids[self.labels[pids] != old]

    # ------------------------------------------------------------------ what a view draws
    def vertex_visible(self) -> np.ndarray:
        """(P,) bool: proxy vertices whose label is visible."""
        return self.colors.visible[self.labels]

    def visible_faces(self) -> np.ndarray:
        """(F', 3) uint32 proxy triangles whose three vertices are visible."""
        vis = self.vertex_visible()
        f = self.faces
        return f[vis[f[:, 0]] & vis[f[:, 1]] & vis[f[:, 2]]]

    def vertex_colors(self) -> np.ndarray:
        """(P, 4) uint8 RGBA through the shared colour table."""
        return self.colors.rgba[self.labels]

    # ------------------------------------------------------------------ following the document
    def _on_change(self, event) -> None:
        c = event["new"]
        if c.kind == "labels" and c.ids is not None:
            changed = self.update(c.ids)
            if changed.size:
                self.change = dataclasses.replace(c, ids=changed)
            return
        if c.kind in ("visibility", "all"):
            self.recompute()
        self.change = dataclasses.replace(c, ids=None)

    def close(self) -> None:
        """Stop following the segmentation."""
        if self._observing:
            self.seg.unobserve(self._on_change, names="change")
            self._observing = False
