"""Scripted wand sessions: the built-in demo and the thesis scenarios of Figs. 12.1–12.7 (spec 000_treewand §6.1, TW-V23).

A scenario is a function of the step index that paints with the wand; it drives anything with
``paint(center, radius, n_darts)`` and ``step()`` — a :class:`~plantvr.growth.engine.GrowthEngine`
or a :class:`plantvr.Model` — so scripts, tests and notebooks replay the same strokes.
"""
from __future__ import annotations

from typing import Callable, Iterable

import numpy as np

__all__ = ["demo_session", "vertical_stroke", "sweep_session", "run"]

Session = Callable[[object, int], None]


def vertical_stroke(top: float = 14.0, speed: float = 0.35, radius: float = 2.5, darts: int = 150) -> Session:
    """A wand moved straight up above the root at ``speed`` per step (Fig. 12.7: "the same location")."""
    def paint(target, s: int) -> None:
        target.paint(np.array([0.0, min(2.0 + speed * s, top), 0.0]), radius, darts)
    return paint


def sweep_session(sweep_start: int, sweep_steps: int, top: float = 14.0, darts: int = 120) -> Session:
    """Fig. 12.1: the trunk stroke, then the brush swept up the trunk over ``sweep_steps`` steps."""
    trunk = vertical_stroke(top)

    def paint(target, s: int) -> None:
        trunk(target, s)
        k = s - sweep_start
        if 0 <= k < sweep_steps:
            y = 3.0 + (top - 4.0) * k / max(sweep_steps - 1, 1)
            for ang in (0.0, 2.1, 4.2):
                target.paint(np.array([4.0 * np.cos(ang + 0.4 * k), y, 4.0 * np.sin(ang + 0.4 * k)]), 2.0, darts)
    return paint


def demo_session(darts: int = 150) -> Session:
    """The built-in demo: a trunk stroke, then a broad crown painted around the top (Fig. 12.4 style)."""
    trunk = vertical_stroke(top=11.0, darts=darts)

    def paint(target, s: int) -> None:
        trunk(target, s)
        if s >= 14:
            ang = 0.7 * s
            target.paint(np.array([3.5 * np.cos(ang), 10.0 + 2.0 * np.sin(0.3 * s), 3.5 * np.sin(ang)]), 3.5, darts)
            target.paint(np.array([0.0, 11.0, 0.0]), 5.0, darts)
    return paint


def run(target, session: Session, steps: int, progress: Iterable[int] | None = None) -> list:
    """Paint with ``session`` and grow one step, ``steps`` times; returns the step statistics."""
    out = []
    for s in progress if progress is not None else range(steps):
        session(target, s)
        st = target.step()
        out.append(st[-1] if isinstance(st, list) else st)
    return out
