"""The forest document: a landscape of trees grown on dask, on the document base (spec 004_treesketch §3.5–3.8;
issue 11, issue 21).

:class:`ForestDocument` holds what :class:`plantvr.landscape.forest.Forest` describes (terrain, tree bases, every
tree, crown voxels, seed states) as its state, the plot settings as parameters (:data:`plantvr.landscape.FOREST`,
one trait each), and changes them only through commands: ``grow`` (the whole forest from its settings, Tree Wand
growth overrides and TreeSketch options), ``regrow_tree`` (one tree with new parameters, every other tree carried
over, spec §3.8), ``set_params``, ``undo`` and ``redo``. Every command is logged, so a session replays; growth is
undoable as whole-state atoms (a forest is immutable once grown: the atoms share its arrays). The dask tasks stay
in the core (:func:`plantvr.landscape.grow_forest`); ``client`` picks where they run and never changes the bytes.
:meth:`ForestDocument.scene` gives the terrain as a :class:`~plantvr.types.TriMesh` and every tree as
:class:`~plantvr.types.TreeArrays` in world coordinates.
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from .._validation import check_int
from ..document import Document, serialise
from ..landscape.forest import (
    FOREST,
    Forest,
    check_client,
    check_sketch,
    grow_forest,
    regrow_tree,
    terrain_mesh,
)
from ..params import check_params
from ..types import TreeArrays, TriMesh

__all__ = ["ForestDocument"]


def _check_overrides(params: dict[str, Any] | None) -> dict[str, Any] | None:
    """A checked copy of Tree Wand growth-parameter overrides (None stays None)."""
    if params is None:
        return None
    if not isinstance(params, dict):
        raise ValueError(f"params must be a dict of growth parameters or None, got {type(params).__name__}")
    return dict(check_params(params, partial=True))


class ForestDocument(Document):
    """A forest on the document base.

    Parameters
    ----------
    client : None, "sync", a scheduler address (``"tcp://host:port"``) or a dask ``Client``
        Where ``grow`` runs its tasks (:func:`~plantvr.landscape.grow_forest`); default ``"sync"`` (this thread).
        The result does not depend on it, so it is not part of the state or the log.
    max_undo, max_undo_bytes : int
        Undo depth and byte budget (:class:`~plantvr.document.Document`).
    **params
        Initial forest settings (:data:`~plantvr.landscape.FOREST`): ``n_trees``, ``width``, ``depth``,
        ``min_dist``, ``rounds``, ``steps_per_round``, ``crown_height``, ``crown_radius``, ``n_darts``,
        ``terrain_amplitude``, ``seed``, ``compete``, ``regions``, ``geometry``.

    Attributes
    ----------
    forest : Forest or None
        The grown forest (None before the first ``grow``); replaced, never changed in place, by commands.
    """

    KIND = "forest"
    COMMANDS = ("grow", "regrow_tree", "set_params", "undo", "redo")
    EVENTS = ("forest",)
    PARAMS = FOREST

    def __init__(self, *, client: Any = "sync", max_undo: int = 20, max_undo_bytes: int = 512 * 2 ** 20,
                 **params: Any):
        client = check_client(client)
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes, **params)
        self.client = client
        self.forest: Forest | None = None

    # -- commands ---------------------------------------------------------------------------------------
    def _check_grow(self, params: dict[str, Any] | None = None, sketch: dict[str, Any] | None = None
                    ) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
        return _check_overrides(params), check_sketch(sketch)

    def grow(self, params: dict[str, Any] | None = None, sketch: dict[str, Any] | None = None) -> Forest:
        """Grow the whole forest from the current settings (:func:`~plantvr.landscape.grow_forest`); undoable.

        ``params`` overrides Tree Wand growth parameters of every tree; ``sketch`` (TreeSketch options) grows
        every tree autonomously in its crown space. Both are checked before anything is grown."""
        params, sketch = self._check_grow(params, sketch)
        with self._lock, self.undoable("forest"):
            p = self.params
            self.forest = grow_forest(p["n_trees"], size=(p["width"], p["depth"]), min_dist=p["min_dist"],
                                      rounds=p["rounds"], steps_per_round=p["steps_per_round"],
                                      crown_height=p["crown_height"], crown_radius=p["crown_radius"],
                                      n_darts=p["n_darts"], terrain_amplitude=p["terrain_amplitude"], params=params,
                                      seed=p["seed"], client=self.client, compete=p["compete"],
                                      geometry=p["geometry"], sketch=sketch, regions=p["regions"])
            self.log.record("grow", params=params, sketch=sketch)
        self.changed("forest", command="grow")
        return self.forest

    def _check_regrow_tree(self, tree: int, params: dict[str, Any] | None = None,
                           sketch: dict[str, Any] | None = None) -> tuple[int, dict | None, dict | None]:
        tree = check_int("tree", tree, 0, int(FOREST["n_trees"].range[1]) - 1)
        params = _check_overrides(params)
        if sketch is not None and not isinstance(sketch, dict):
            raise ValueError(f"sketch must be a dict of SketchEngine options or None, got {type(sketch).__name__}")
        return tree, params, None if sketch is None else dict(sketch)

    def regrow_tree(self, tree: int, params: dict[str, Any] | None = None, sketch: dict[str, Any] | None = None
                    ) -> Forest:
        """Regrow one tree with new growth parameters or TreeSketch options, every other tree carried over
        unchanged (:func:`~plantvr.landscape.regrow_tree`, spec §3.8, V26); undoable. Needs a grown forest of
        independent trees (``compete=False`` or TreeSketch)."""
        tree, params, sketch = self._check_regrow_tree(tree, params, sketch)
        with self._lock:
            if self.forest is None:
                raise ValueError("regrow_tree needs a grown forest; call grow() first")
            new = regrow_tree(self.forest, tree, params=params, sketch=sketch)  # checked before growth
            with self.undoable("forest"):
                self.forest = new
            self.log.record("regrow_tree", tree=tree, params=params, sketch=sketch)
        self.changed("forest", np.array([tree]), command="regrow_tree")
        return self.forest

    # -- state ------------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        """The settings and the forest record, with the arrays it holds (what an undo atom keeps alive, for the
        byte budget)."""
        with self._lock:
            f = self.forest
            arrays: list[np.ndarray] = []
            if f is not None:
                arrays = [f.bases, f.heights, *(a for t in f.trees for a in t.values())]
                arrays += [a for m in f.meshes or () for a in m]
            return {"params": self.params, "forest": f, "arrays": tuple(arrays)}

    def set_state(self, state: dict[str, Any]) -> None:
        with self._lock:
            self.restore_params(state["params"])
            self.forest = state["forest"]

    def state_bytes(self) -> bytes:
        """Parameters and the forest (terrain, bases, trees, meshes, voxels, seed states, growth settings) as
        deterministic bytes; round timings are not state."""
        with self._lock:
            f = self.forest
            body = None if f is None else {
                "bases": f.bases, "trees": f.trees, "heights": f.heights, "size": f.size, "meshes": f.meshes,
                "voxels": None if f.voxels is None else vars(f.voxels), "seeds": f.seeds, "config": f.config}
            return serialise({"params": self.params, "forest": body})

    def make_snapshot(self) -> Forest | None:
        """The forest itself: commands replace it, never change it, so render threads read it as it is."""
        return self.forest

    # -- views ------------------------------------------------------------------------------------------
    @property
    def trees(self) -> tuple[TreeArrays, ...]:
        """Every tree's live nodes as :class:`~plantvr.types.TreeArrays`, in world coordinates."""
        f = self.forest
        return () if f is None else tuple(TreeArrays.from_tree(SimpleNamespace(**t)) for t in f.trees)

    def scene(self) -> dict[str, Any]:
        """``{"terrain": TriMesh, "tree 0": TreeArrays, ...}`` of the grown forest (empty before ``grow``)."""
        f = self.forest
        if f is None:
            return {}
        v, faces = terrain_mesh(f.heights, f.size)
        return {"terrain": TriMesh(v, faces), **{f"tree {i}": t for i, t in enumerate(self.trees)}}
