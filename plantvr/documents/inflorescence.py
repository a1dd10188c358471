"""The inflorescence document: one floret's settings, key poses and animation (spec 002 §2.1–§2.4, C1–C4;
issue 21).

The state is the :data:`~plantvr.flowers.floret.FLORET` parameter table (petal net, corolla, the three key poses,
growth and polygonization, the growth time a view shows) and the last valid floret built from it
(:func:`~plantvr.flowers.floret.build_floret`). Every setting is a parameter, so one command, ``set_params``,
changes any of them (``set_pose`` and ``load_preset`` are spelled through it), every change is logged and
undoable, and presets are the one JSON preset format. A combination of valid values the core rejects (fused rows
with a 1-fold corolla, more fused rows than control rows, ...) is kept with a :attr:`message` saying why, and the
floret stays the last valid one, so :attr:`InflorescenceDocument.floret` is always a valid
:class:`~plantvr.flowers.floret.FloretMesh`. :class:`plantvr.ui.FloretEditor` is a view of this document.
"""
from __future__ import annotations

import os
import threading
from typing import Any

import numpy as np

from .._validation import check_int
from ..document import Document, serialise
from ..flowers.composer import FloretType
from ..flowers.floret import FLORET, POSE_KEYS, POSE_NAMES, Corolla, FloretMesh, build_floret, petal_net
from ..history import StateAtom
from ..types import TriMesh

__all__ = ["PRESETS", "InflorescenceDocument"]


def _poses(*poses: dict) -> dict:
    return {f"{name}_{k}": v for name, pose in zip(POSE_NAMES, poses) for k, v in pose.items()}


#: The table's defaults are the disc floret of the example models.
_DISC = {k: v for k, v in FLORET.defaults().items() if k != "time"}
_MESH = {k: _DISC[k] for k in ("lam", "eta", "weld", "weld_tol", "warp", "n_frames")}
#: Starting points matching the example models' florets (:mod:`plantvr.flowers.models`); every preset sets
#: every setting but the growth time shown.
PRESETS = {
    "disc floret": _DISC,
    "ray floret": {**_MESH, "nu": 5, "nv": 7, "base_radius": 0.03, "base_width": 0.3, "n_fold": 1, "fused_rows": 0,
                   "growth": "sinusoidal", "n_poses": 2, "lam": 0.12, "eta": 7.0,
                   **_poses({"length": 0.3, "width": 0.12, "opening_deg": 8.0, "curl_deg": 0.0, "roll_deg": 0.0},
                            {"length": 1.6, "width": 0.5, "opening_deg": 40.0, "curl_deg": 5.0, "roll_deg": 0.0},
                            {"length": 3.0, "width": 0.9, "opening_deg": 80.0, "curl_deg": 15.0,
                             "roll_deg": 0.0})},
    "dahlia ray": {**_MESH, "nu": 7, "nv": 7, "base_radius": 0.05, "base_width": 0.3, "n_fold": 1, "fused_rows": 0,
                   "growth": "sinusoidal", "n_poses": 2, "lam": 0.11, "eta": 7.0,
                   **_poses({"length": 1.26, "width": 1.2, "opening_deg": 5.0, "curl_deg": -4.0,
                             "roll_deg": 150.0},
                            {"length": 2.4, "width": 1.8, "opening_deg": 30.0, "curl_deg": -15.0,
                             "roll_deg": 110.0},
                            {"length": 3.6, "width": 2.2, "opening_deg": 60.0, "curl_deg": -30.0,
                             "roll_deg": 90.0})},
    "fused tube (3 poses)": {**_DISC, "n_fold": 6, "fused_rows": 4, "growth": "linear", "n_poses": 3},
}
#: Parameters that only change what a view shows (no rebuild).
_SHOWN = ("time",)


class InflorescenceDocument(Document):
    """One floret on the document base: the :data:`~plantvr.flowers.floret.FLORET` settings and the last valid
    floret built from them.

    Parameters
    ----------
    preset : str, optional
        Start from one of :data:`PRESETS` (default the table's defaults, which are ``"disc floret"``); not logged.
    max_undo, max_undo_bytes : int
        Undo depth and byte budget.
    **params
        Initial settings (over the preset), checked against the table.

    Attributes
    ----------
    floret : FloretMesh
        The last valid floret (faces, frames, attachment vertices).
    message : str
        Why the last change was not applied ("" after a successful build).
    """

    KIND = "inflorescence"
    COMMANDS = ("set_params", "undo", "redo")
    EVENTS = ("floret",)
    PARAMS = FLORET
    PARAMS_UNDO = False                      # every change commits its own item (:meth:`_commit`)

    def __init__(self, *, preset: str | None = None, max_undo: int = 20, max_undo_bytes: int = 512 * 2 ** 20,
                 **params: Any):
        start = {} if preset is None else dict(PRESETS[_check_preset_name(preset)])
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes, **{**start, **params})
        self.message = ""
        self._stale = False                  # a setting changed inside set_params: rebuild at its end
        self.floret = self.build()           # the table's defaults and every preset build
        self._committed = self.get_state()   # the state after the last operation: the next one's undo point

    # -- the core call -----------------------------------------------------------------------------------
    @property
    def poses(self) -> list[dict[str, float]]:
        """The three key poses (bud, middle, open) as ``{key: value}`` dicts."""
        return [{k: getattr(self, f"{name}_{k}") for k in POSE_KEYS} for name in POSE_NAMES]

    def corollas(self) -> list[Corolla]:
        """The key poses as core :class:`~plantvr.flowers.floret.Corolla` objects (2 or 3)."""
        keys = (0, 2) if self.n_poses == 2 else (0, 1, 2)
        poses = self.poses
        return [Corolla(petal_net(nu=self.nu, nv=self.nv, base_radius=self.base_radius, base_width=self.base_width,
                                  **poses[k]), n_fold=self.n_fold, fused_rows=self.fused_rows) for k in keys]

    def growth_knots(self) -> str | np.ndarray:
        """The growth argument of :func:`~plantvr.flowers.floret.build_floret` (a name or (K, 2) knots)."""
        if self.growth == "power":
            x = np.linspace(0.0, 1.0, 65)
            return np.column_stack([x, x ** self.warp])
        return self.growth

    def build(self) -> FloretMesh:
        """Build a floret from the current settings without storing it.

        Raises
        ------
        ValueError
            When the settings do not make a floret (the message says which settings clash).
        """
        if self.fused_rows and self.n_fold < 2:
            raise ValueError(f"fused rows need a corolla of at least 2 petals; n-fold is {self.n_fold} "
                             f"(set fused rows to 0 or n-fold to 2 or more)")
        if self.fused_rows > self.nv:
            raise ValueError(f"fused rows ({self.fused_rows}) must not exceed the control rows along the petal "
                             f"(nv = {self.nv})")
        fm = build_floret(self.corollas(), n_frames=self.n_frames, growth=self.growth_knots(), lam=self.lam,
                          eta=self.eta, weld=self.weld, weld_tol=self.weld_tol)
        if len(fm.faces) == 0 or not np.all(np.isfinite(fm.frames)):
            raise ValueError("the settings give an empty or non-finite mesh")
        return fm

    def floret_type(self) -> FloretType:
        """The floret as a :class:`~plantvr.flowers.composer.FloretType` for a :class:`Canopy`."""
        return FloretType(self.floret.faces, self.floret.frames, self.floret.fixed)

    def current_frame(self) -> np.ndarray:
        """(V, 3) vertices at the growth time :attr:`time`."""
        return self.floret.frame_at(self.time)

    def _rebuild(self) -> None:
        try:
            fm = self.build()
        except ValueError as e:
            self.message = f"Not applied: {e}. The preview keeps the last valid floret."
            return
        self.floret, self.message = fm, ""

    # -- commands ------------------------------------------------------------------------------------------
    def set_params(self, **params: Any) -> None:
        """Set several settings at once, with one rebuild and one undo step (logged as one command)."""
        with self._lock:
            super().set_params(**params)
            if self._stale:
                self._rebuild()
            self._commit()
        self.changed("floret", command="set_params")

    def apply_param(self, name: str, value: Any) -> None:
        if self._batch == threading.get_ident():      # inside set_params: one rebuild at its end
            self._stale = self._stale or name not in _SHOWN
            return
        if name not in _SHOWN:
            self._rebuild()
        self._commit()

    def _commit(self) -> None:
        before, after = self._committed, self.get_state()
        if (after["params"] != before["params"] or after["message"] != before["message"]
                or after["floret"][1] is not before["floret"][1]):
            self.history.push(StateAtom(before, after, "floret"))
        self._committed, self._stale = after, False

    def _check_set_pose(self, index: int, **values: float) -> dict[str, float]:
        index = check_int("index", index, 0, 2)
        bad = sorted(set(values) - set(POSE_KEYS))
        if bad:
            raise ValueError(f"pose settings must be among {list(POSE_KEYS)}, got {bad}")
        return self.PARAMS.validate({f"{POSE_NAMES[index]}_{k}": v for k, v in values.items()})

    def set_pose(self, index: int, **values: float) -> None:
        """Set settings of key pose ``index`` (0 bud, 1 middle, 2 open): ``set_params`` of its rows."""
        self.set_params(**self._check_set_pose(index, **values))

    def load_preset(self, preset: str | os.PathLike) -> dict[str, Any]:
        """Apply one of :data:`PRESETS` by name, or a ``.json`` preset file (every value checked first; a bad one
        changes nothing) with one rebuild; returns the values set."""
        if isinstance(preset, str) and preset in PRESETS:
            self.set_params(**PRESETS[preset])
            return dict(PRESETS[preset])
        if not isinstance(preset, (str, os.PathLike)) or not os.fspath(preset).endswith(".json"):
            raise ValueError(f"preset must be one of {list(PRESETS)} or a .json preset file, got {preset!r:.80}")
        return super().load_preset(preset)

    # -- state -----------------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        fm = self.floret
        return {"params": self.params, "floret": (fm.faces, fm.frames, fm.fixed), "message": self.message}

    def set_state(self, state: dict[str, Any]) -> None:
        self.restore_params(state["params"])
        faces, frames, fixed = state["floret"]
        if faces is not self.floret.faces or frames is not self.floret.frames:
            self.floret = FloretMesh(vertices=frames[-1], faces=faces, frames=frames, fixed=fixed)
        self.message = state["message"]
        self._committed = state

    def state_bytes(self) -> bytes:
        fm = self.floret
        return serialise({"params": self.params, "message": self.message, "faces": fm.faces, "frames": fm.frames,
                          "fixed": fm.fixed})

    def scene(self) -> dict[str, Any]:
        """The floret at the growth time :attr:`time`, as a :class:`~plantvr.types.TriMesh`."""
        return {"floret": TriMesh(self.current_frame(), self.floret.faces)}


def _check_preset_name(name) -> str:
    if not isinstance(name, str) or name not in PRESETS:
        raise ValueError(f"preset must be one of {list(PRESETS)}, got {name!r:.80}")
    return name
