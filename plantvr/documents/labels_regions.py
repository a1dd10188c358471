"""Region commands of the ViNE labels document over the mesh graph: flood fill, split into connected parts, merge,
and per-label statistics and colour smoothing (spec 000_vine §2.7, §6; issue 15).

:class:`LabelRegions` is a base class of :class:`~plantvr.documents.labels.Segmentation`; it uses the document's
labels, colour table, mesh graph, history, log and lock. Each command is one undo item (an
:class:`~plantvr.history.ArrayEdit` of the changed vertices) and publishes a ``"labels"`` change.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_int, check_range
from plantvr.history import ArrayEdit
from plantvr.vine.colors import distinct_color

__all__ = ["LabelRegions"]


class LabelRegions:
    """Fill, split and merge of label regions, label statistics and smoothing (a base of ``Segmentation``)."""

    def _commit(self, idx: np.ndarray, new, command: str) -> ArrayEdit | None:
        """Write ``labels[idx] = new`` as one undo item (outside strokes) and publish the change."""
        if self._stroke is not None:
            raise ValueError("a stroke is open; end_stroke() before fill, split or merge")
        idx = np.asarray(idx, np.int64)
        new = np.broadcast_to(np.asarray(new, self.labels.dtype), idx.shape)
        changed = self.labels[idx] != new
        idx, new = idx[changed], new[changed]
        if idx.size == 0:
            return None
        itype = np.int32 if self.n_vertices < 2 ** 31 else np.int64
        order = np.argsort(idx, kind="stable")
        idx, new = idx[order], np.ascontiguousarray(new[order])
        edit = ArrayEdit(idx.astype(itype), self.labels[idx].copy(), new.copy())
        self.labels[idx] = new
        self.history.push(edit)
        self.changed("labels", idx, command=command)
        return edit

    def _check_fill(self, vertex, label, radius=None) -> tuple[int, int, float | None]:
        vertex = check_int("vertex", vertex, 0, self.n_vertices - 1)
        label = self._check_target("label", label)
        if radius is not None:
            radius = check_range("radius", radius, 0.0, self.max_radius)
        cur = int(self.labels[vertex])
        if not self.colors.visible[cur]:
            raise ValueError(f"vertex {vertex} has hidden label {cur}; show it before filling")
        if self._stroke is not None:
            raise ValueError("a stroke is open; end_stroke() before fill")
        return vertex, label, radius

    def fill(self, vertex: int, label: int, radius: float | None = None) -> int:
        """Flood-fill from a picked vertex over mesh connectivity with ``label`` (one undo step).

        The region is every vertex reachable from ``vertex`` through vertices of ``vertex``'s current label
        (napari's fill, on the mesh graph), optionally limited to a geodesic distance along mesh edges.

        Parameters
        ----------
        vertex : int
            Picked vertex id, in [0, V - 1]; its colour must be visible.
        label : int
            Colour-table index to write, visible.
        radius : float, optional
            Geodesic radius in model units, in [0, max_radius]; None = the whole connected region.

        Returns
        -------
        int
            Number of vertices changed.

        References
        ----------
        .. [1] Spec 000_vine §6 "connectivity-aware brush (geodesic flood fill)"; issue 15.
        """
        from plantvr.vine.fill import flood_region
        vertex, label, radius = self._check_fill(vertex, label, radius)
        with self._lock:
            self.log.record("fill", vertex=vertex, label=label, radius=radius)
            if int(self.labels[vertex]) == label:
                return 0
            ids = flood_region(self.graph, self.labels, vertex, radius=radius)
            e = self._commit(ids, label, "fill")
        return 0 if e is None else len(e)

    def label_components(self, label: int) -> tuple[np.ndarray, int]:
        """Connected components of one label over mesh edges: ((V,) int64 component id or -1, count)."""
        from plantvr.vine.fill import label_components
        label = self.colors.check_label("label", label)
        return label_components(self.graph, self.labels, label=label)

    def _check_split_label(self, label, min_vertices=1) -> tuple[int, int]:
        label = self._check_target("label", label)
        min_vertices = check_int("min_vertices", min_vertices, 1, self.n_vertices)
        if self._stroke is not None:
            raise ValueError("a stroke is open; end_stroke() before split_label")
        return label, min_vertices

    def split_label(self, label: int, min_vertices: int = 1) -> list[int]:
        """Give each connected component of ``label`` its own new colour (one undo step).

        The largest component keeps ``label``; every other component with at least ``min_vertices``
        vertices gets a new, distinct colour appended to the table (the colours stay on undo). Components
        smaller than ``min_vertices`` keep ``label``.

        Parameters
        ----------
        label : int
            Visible colour-table index, in [0, len(colors) - 1].
        min_vertices : int
            Smallest component that becomes its own label, in [1, V].

        Returns
        -------
        list of int
            The labels now held by the split parts, ``label`` first (largest part).
        """
        label, min_vertices = self._check_split_label(label, min_vertices)
        comp, n = self.label_components(label)
        sizes = np.bincount(comp[comp >= 0], minlength=n)
        order = np.argsort(-sizes, kind="stable")               # largest first, ties by smallest vertex id
        movers = [int(c) for c in order[1:] if sizes[c] >= min_vertices]
        room = self.colors.capacity - len(self.colors)
        if len(movers) > room:
            raise ValueError(f"label {label} has {len(movers) + 1} parts of >= {min_vertices} vertices, but the "
                             f"colour table has room for {room} more colours; raise min_vertices"
                             + ("" if self._wide else " or add_color() past 256 entries (uint16 labels)"))
        with self._lock:
            self.log.record("split_label", label=label, min_vertices=min_vertices)
            if not movers:
                return [label]
            with self.held():                     # one autosave for the new colours and the relabelling
                new_labels = [self.colors.add_color(distinct_color(len(self.colors))) for _ in movers]
                self.changed("colors", command="split_label")
                lut = np.full(n, -1, np.int64)
                lut[movers] = new_labels
                ids = np.flatnonzero((comp >= 0) & (lut[np.maximum(comp, 0)] >= 0))
                self._commit(ids, lut[comp[ids]].astype(self.labels.dtype), "split_label")
        return [label, *new_labels]

    def _check_merge_labels(self, keep, other) -> tuple[int, int]:
        keep = self._check_target("keep", keep)
        other = self._check_target("other", other)
        if keep == other:
            raise ValueError(f"other must differ from keep, got keep={keep}, other={other}")
        if self._stroke is not None:
            raise ValueError("a stroke is open; end_stroke() before merge_labels")
        return keep, other

    def merge_labels(self, keep: int, other: int) -> int:
        """Relabel every vertex of ``other`` as ``keep`` (one undo step); returns the number changed."""
        keep, other = self._check_merge_labels(keep, other)
        with self._lock:
            self.log.record("merge_labels", keep=keep, other=other)
            e = self._commit(np.flatnonzero(self.labels == other), keep, "merge_labels")
        return 0 if e is None else len(e)

    def label_table(self, names: dict | None = None):
        """Per-label statistics (pandas DataFrame): see :func:`plantvr.vine.labelstats.label_table`."""
        from plantvr.vine.labelstats import label_table
        return label_table(self.vertices, self.faces, self.labels, colors=self.colors, names=names,
                           graph=self.graph)

    def smoothed_colors(self, iterations: int = 1) -> np.ndarray:
        """Laplacian vertex-colour smoothing: ``c_v ← mean({c_v} ∪ {c_u : u ∈ N(v)})`` (spec §2.7).

        Returns (V, 4) uint8; the labels are not changed.
        """
        import scipy.sparse as sp
        iterations = check_int("iterations", iterations, 0, 1000)
        n = self.n_vertices
        f = self.faces.astype(np.int64)
        i = np.concatenate([f[:, 0], f[:, 1], f[:, 2], f[:, 1], f[:, 2], f[:, 0], np.arange(n)])
        j = np.concatenate([f[:, 1], f[:, 2], f[:, 0], f[:, 0], f[:, 1], f[:, 2], np.arange(n)])
        A = sp.csr_matrix((np.ones(len(i), np.float32), (i, j)), shape=(n, n))
        A.data[:] = 1.0                                  # de-duplicate shared edges
        A.sum_duplicates()
        A.data[:] = 1.0
        deg = np.asarray(A.sum(axis=1)).ravel()
        c = self.vertex_colors().astype(np.float32)
        for _ in range(iterations):
            c = (A @ c) / deg[:, None]
        return np.clip(np.rint(c), 0, 255).astype(np.uint8)
