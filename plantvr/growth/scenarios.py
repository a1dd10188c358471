"""Scripted wand sessions: the built-in demo and the thesis scenarios of Figs. 12.1–12.7 (spec 000_treewand §6.1, TW-V23).

A scenario is a function of the step index that paints with the wand; it drives anything with
``paint(center, radius, n_darts)`` and ``step()`` — a :class:`~plantvr.growth.engine.GrowthEngine`
or a :class:`plantvr.Model` — so scripts, tests and notebooks replay the same strokes.
"""
from __future__ import annotations

from typing import Callable, Iterable

import numpy as np

from plantvr._validation import check_int

__all__ = ["demo_session", "vertical_stroke", "sweep_session", "run", "y_session", "broad_session",
           "concentrations_session", "crown_session"]

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
    """Paint with ``session`` and grow one step, ``steps`` times (in [0, 10**9]); returns the step statistics."""
    if progress is None:
        steps = check_int("steps", steps, 0, 10 ** 9)
    if not callable(session):
        raise ValueError(f"session must be a function (target, step) -> None, got {type(session).__name__}")
    out = []
    for s in progress if progress is not None else range(steps):
        session(target, s)
        st = target.step()
        out.append(st[-1] if isinstance(st, list) else st)
    return out


# -- Figs. 12.2, 12.4–12.6 (added for the replayable stroke files of plantvr.documents.scenarios) ----------------------
# Only the motions the thesis states are reproduced (spec 000_treewand §6.1); positions, radii and timings are
# [INFERRED] to give the stated shape on the default 16-unit scene.

def y_session(fork: float = 6.0, top: float = 12.0, spread: float = 4.0, speed: float = 0.5,
              small: float = 1.2, large: float = 3.5, darts: int = 60) -> Session:
    """Fig. 12.2: a "Y" drawn with a small brush (trunk, then two arms), then a larger brush on the top."""
    t_fork = int(np.ceil((fork - 2.0) / speed))
    t_top = t_fork + int(np.ceil((top - fork) / speed))

    def paint(target, s: int) -> None:
        if s <= t_fork:
            target.paint(np.array([0.0, 2.0 + speed * s, 0.0]), small, darts)
        elif s <= t_top:
            f = (s - t_fork) / max(t_top - t_fork, 1)
            for side in (-1.0, 1.0):
                target.paint(np.array([side * spread * f, fork + (top - fork) * f, 0.0]), small, darts)
        elif s <= t_top + 6:
            for side in (-1.0, 1.0):
                target.paint(np.array([side * spread, top + 1.0, 0.0]), large, 2 * darts)
    return paint


def broad_session(centre: tuple = (0.0, 8.0, 0.0), size: tuple = (6.0, 4.0, 6.0), broad: float = 3.5,
                  fine: float = 1.2, broad_steps: int = 16, darts: int = 150) -> Session:
    """Fig. 12.4: very broad motions filling a crown ellipsoid with markers, then a smaller radius on chosen
    spots "to add more internodes to areas I wanted to be more developed"."""
    c, a = np.asarray(centre, float), np.asarray(size, float)
    trunk = vertical_stroke(top=c[1] - a[1] * 0.5, darts=darts // 2)

    def paint(target, s: int) -> None:
        trunk(target, s)
        if s < 4:
            return
        k = s - 4
        if k < broad_steps:  # a wide circling motion over the crown, rising and falling
            ang = 2 * np.pi * k / 6.0
            p = c + a * np.array([0.8 * np.cos(ang), 0.6 * np.sin(0.5 * ang), 0.8 * np.sin(ang)])
            target.paint(p, broad, darts)
        elif k < broad_steps + 8:  # small touches on two chosen spots
            spot = c + a * (np.array([0.7, 0.3, 0.2]) if k % 2 else np.array([-0.5, 0.5, -0.6]))
            target.paint(spot, fine, darts // 2)
    return paint


def concentrations_session(centres=((-5.0, 10.0, 2.0), (5.0, 11.0, 1.0), (0.5, 13.0, -5.0)),
                           radius: float = 3.5, trunk_top: float = 6.0, darts: int = 150) -> Session:
    """Fig. 12.5: the tree grown "deliberately" towards three concentrations of leaves with a broad brush:
    the trunk first, then each concentration in turn, the brush moved out from the trunk top."""
    trunk = vertical_stroke(top=trunk_top, darts=darts // 2)
    cs = np.asarray(centres, float)
    start = int(np.ceil((trunk_top - 2.0) / 0.35))

    def paint(target, s: int) -> None:
        trunk(target, s)
        k = s - start
        if k < 0:
            return
        i, j = divmod(k, 6)
        if i < len(cs):
            f = (j + 1) / 6.0
            target.paint(np.array([0.0, trunk_top, 0.0]) * (1 - f) + cs[i] * f, radius, darts)
        elif i < len(cs) + 2:  # all three once more, so the earlier ones keep growing
            target.paint(cs[j % len(cs)], radius, darts)
    return paint


def crown_session(top: float = 12.0, radius: float = 4.0, darts: int = 150) -> Session:
    """Fig. 12.6 (maple): a trunk stroke, then a rounded crown painted around the top."""
    trunk = vertical_stroke(top=top - 3.0, darts=darts // 2)

    def paint(target, s: int) -> None:
        trunk(target, s)
        if s >= 12:
            ang = 2.4 * s
            target.paint(np.array([3.0 * np.cos(ang), top - 1.0 + np.sin(0.5 * s), 3.0 * np.sin(ang)]), radius,
                         darts)
    return paint
