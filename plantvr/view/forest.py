"""Forest view with LOD by distance: each tree drawn at the LOD level its on-screen height asks for (issue 16).

Every tree's LOD chain (:func:`plantvr.geometry.lod.lod_chain`) is meshed once, one actor per level, plus a
cross-quad billboard (:func:`plantvr.view.billboard.make_billboard`) for the farthest; only the actor of the level
chosen by :func:`plantvr.view.billboard.lod_by_distance` is visible. The levels follow the camera: an observer
on the plotter's camera calls :meth:`ForestView.update` whenever the camera is modified (or call it yourself).
"""
from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np
import pyvista as pv

from .._validation import check_array, check_int
from ..geometry.lod import lod_chain
from . import _check_window_size
from .billboard import BARK_RGB, BILLBOARD_LEVEL, LOD_SCREEN_PX, lod_by_distance, make_billboard

__all__ = ["ForestView", "tree_arrays"]


def _poly(vertices, faces) -> pv.PolyData:
    f = np.asarray(faces, np.int64)
    return pv.PolyData(np.asarray(vertices, float), np.column_stack([np.full(len(f), 3), f]).ravel())


def tree_arrays(tree) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(pos, parent, radius, alive, main_child)`` of a tree dict (``plantvr.landscape.Forest.trees``), a Snapshot
    or a ``(pos, parent, radius[, main_child])`` tuple."""
    if isinstance(tree, dict):
        alive = np.asarray(tree.get("alive", np.ones(len(tree["pos"]), bool)), bool)
        if "main_child" in tree:
            main = np.asarray(tree["main_child"], np.int64)
        else:
            main = np.where(tree["child"][:, 0] >= 0, tree["child"][:, 0], -1).astype(np.int64)
        radius = np.where(alive, np.maximum(tree["radius"], 1e-6), tree["radius"])
        return np.asarray(tree["pos"], float), np.asarray(tree["parent"], np.int64), radius, alive, main
    if hasattr(tree, "pos") and hasattr(tree, "parent"):
        n = len(tree.pos)
        return (np.asarray(tree.pos, float), np.asarray(tree.parent, np.int64), np.asarray(tree.radius, float),
                np.ones(n, bool), np.asarray(tree.main_child, np.int64))
    pos, parent, radius, *rest = tree
    return (np.asarray(pos, float), np.asarray(parent, np.int64), np.asarray(radius, float),
            np.ones(len(pos), bool), np.asarray(rest[0], np.int64) if rest else None)


class ForestView:
    """Trees of a forest in a pyvista plotter, each at the LOD level of its camera distance.

    Parameters
    ----------
    trees : list
        Tree dicts (``Forest.trees``), Snapshots or ``(pos, parent, radius[, main_child])`` tuples, world
        coordinates, y up.
    plotter : pyvista.Plotter, optional
        Default a new offscreen plotter of ``window_size``.
    levels : int
        LOD levels per tree, in [1, 4].
    billboard : bool
        Add a billboard impostor (level :data:`BILLBOARD_LEVEL`) for the farthest trees; without it the last
        mesh level is used beyond.
    billboard_px : int
        Atlas tile side of each billboard.
    thresholds : sequence of float
        Screen heights at which levels switch (:func:`lod_by_distance`).
    observe : bool
        Update the levels whenever the plotter's camera is modified.

    Attributes
    ----------
    levels : (T,) int64 ndarray
        Current level of each tree (``BILLBOARD_LEVEL`` for the billboard).
    switches : int
        Number of level changes since construction.
    """

    def __init__(self, trees, plotter=None, *, levels: int = 4, billboard: bool = True, billboard_px: int = 128,
                 thresholds=LOD_SCREEN_PX, window_size=(800, 600), observe: bool = True):
        if isinstance(trees, (str, bytes, dict)) or not hasattr(trees, "__len__") or not len(trees):
            raise ValueError("trees must be a non-empty list of trees")
        levels = check_int("levels", levels, 1, 4)
        billboard_px = check_int("billboard_px", billboard_px, 8, 4096)
        th = check_array("thresholds", thresholds, shape=(None,), min_rows=1)
        if np.any(th <= 0) or np.any(th > 1e6):
            raise ValueError(f"thresholds must be screen heights in (0, 1e6] px, got {th.tolist()}")
        window_size = _check_window_size(window_size)
        self.plotter = plotter if plotter is not None else pv.Plotter(off_screen=True, window_size=window_size)
        self.thresholds = tuple(float(t) for t in th)
        self.chains, self.actors, self.tris = [], [], []
        centers, heights = [], []
        for tree in trees:
            pos, parent, radius, alive, main = tree_arrays(tree)
            chain = lod_chain(pos, parent, radius, alive=alive, main_child=main, levels=levels)
            acts, tris = [], []
            for lv in chain:
                a = self.plotter.add_mesh(_poly(lv.mesh.vertices, lv.mesh.faces), color=BARK_RGB)
                a.SetVisibility(False)
                acts.append(a)
                tris.append(lv.triangles)
            v = chain[0].mesh.vertices
            lo, hi = v.min(0), v.max(0)
            centers.append((lo + hi) / 2)
            heights.append(max(float(hi[1] - lo[1]), 1e-6))
            if billboard:
                bb = make_billboard(chain[0].mesh, views=2, resolution=billboard_px)
                tex = pv.Texture(bb.atlas)
                quad = _poly(bb.vertices, bb.faces)
                quad.active_texture_coordinates = bb.uv.astype(np.float32)
                a = self.plotter.add_mesh(quad, texture=tex, lighting=False)
                a.SetVisibility(False)
                acts.append(a)
                tris.append(len(bb.faces))
            self.chains.append(chain)
            self.actors.append(acts)
            self.tris.append(tris)
        self.centers = np.array(centers)
        self.heights = np.array(heights)
        self.billboard = billboard
        self.levels = np.full(len(self.chains), -1, np.int64)
        self.switches = 0
        self._observer = None
        self.update()
        if observe:
            self._observer = self.plotter.camera.AddObserver("ModifiedEvent", lambda *_: self.update())

    def _actor_index(self, level: int, k: int) -> int:
        """Index into ``self.actors[k]`` of a level (the billboard is the last actor)."""
        n_mesh = len(self.chains[k])
        if level >= BILLBOARD_LEVEL or level >= n_mesh:
            return n_mesh if (self.billboard and level >= BILLBOARD_LEVEL) else n_mesh - 1
        return level

    def target_levels(self) -> np.ndarray:
        """Levels :func:`lod_by_distance` picks for the current camera (position, view angle, window height)."""
        cam = self.plotter.camera
        d = np.linalg.norm(self.centers - np.asarray(cam.position, float), axis=1)
        h = int(self.plotter.window_size[1])
        return lod_by_distance(self.heights, np.maximum(d, 1e-9), fov_deg=float(cam.view_angle), viewport_px=h,
                               thresholds=self.thresholds)

    def update(self) -> int:
        """Switch each tree to the level of its current camera distance; returns the number of trees switched."""
        new = self.target_levels()
        changed = 0
        for k, lv in enumerate(new):
            if lv == self.levels[k]:
                continue
            shown = self._actor_index(int(lv), k)
            for i, a in enumerate(self.actors[k]):
                a.SetVisibility(i == shown)
            self.levels[k] = lv
            changed += 1
        self.switches += changed
        return changed

    @property
    def triangles(self) -> int:
        """Triangles of the actors now visible."""
        return int(sum(self.tris[k][self._actor_index(int(lv), k)] for k, lv in enumerate(self.levels)))

    def close(self) -> None:
        if self._observer is not None:
            self.plotter.camera.RemoveObserver(self._observer)
            self._observer = None
