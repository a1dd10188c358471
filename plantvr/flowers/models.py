"""Example flower-head models: sunflower-like and Gaillardia-like capitula (spec 002 §6, C28; Ch. 9).

Each model runs the pipeline of spec 002 §1.2 a–f: floret key poses → one OBJ-like animation per floret
type (fixed topology) → centripetal fractionation on the receptacle (Eq. 5.2) → floret fate by the cone
test (Eq. 6.1 with ERRATUM A.4) → stage from primordium age (phase effect) → a :class:`Canopy` whose
growth :func:`~plantvr.flowers.composer.grow` resolves with PBD + CCD. The ray-floret count is emergent
(from n and alpha), never assigned: 34 for the sunflower-like head, 21 for the Gaillardia-like head (V35).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantvr._validation import check_int, check_range
from plantvr.flowers.composer import Canopy, FloretType
from plantvr.flowers.fate import ray_florets
from plantvr.flowers.floret import Corolla, build_floret, petal_net
from plantvr.flowers.phyllotaxis import (
    centripetal_fractionation,
    disc_receptacle,
    dome_receptacle,
    floret_stage,
    place_on_receptacle,
)

__all__ = ["FlowerHead", "disc_floret", "gaillardia_head", "ray_floret", "sunflower_head"]

DISC, RAY = 0, 1


def disc_floret(*, detail: float = 1.0, n_frames: int = 8, n_fold: int = 5, open_deg: float = 55.0
                ) -> FloretType:
    """A tubular, 5-fold fused disc floret opening from a closed bud (spec 002 §2, C1–C4).

    ``detail`` scales the polygonization density (rows from Eq. 2.1 and samples per row).
    """
    detail = check_range("detail", detail, 0.1, 10.0)
    n_frames = check_int("n_frames", n_frames, 2, 1000)
    bud = Corolla(petal_net(opening_deg=6, length=0.35, width=0.07, base_radius=0.06), n_fold=n_fold,
                  fused_rows=3)
    opn = Corolla(petal_net(opening_deg=open_deg, curl_deg=25, length=0.8, width=0.42, base_radius=0.06),
                  n_fold=n_fold, fused_rows=3)
    fm = build_floret([bud, opn], n_frames=n_frames, growth="sinusoidal", lam=0.2 / detail,
                      eta=lambda v: 3 + 2 * detail * v)
    return FloretType(fm.faces, fm.frames, fm.fixed)


def ray_floret(*, detail: float = 1.0, n_frames: int = 8, length: float = 3.0, width: float = 0.9,
               open_deg: float = 80.0) -> FloretType:
    """A ligulate ray floret: one long strap petal opening outward (spec 002 §2; ERRATUM A.12 reading).

    In floret coordinates the ligule points along -y, which :class:`Canopy` maps to the outward
    radial direction of a receptacle placement (right = circumferential tangent).
    """
    detail = check_range("detail", detail, 0.1, 10.0)
    n_frames = check_int("n_frames", n_frames, 2, 1000)
    length = check_range("length", length, 0.0, 1e6, low_open=True)
    width = check_range("width", width, 0.0, 1e6, low_open=True)
    bud = petal_net(opening_deg=8, length=0.3, width=0.12, base_radius=0.03, nu=5, nv=7)
    opn = petal_net(opening_deg=open_deg, curl_deg=15, length=length, width=width, base_radius=0.03,
                    nu=5, nv=7)
    fm = build_floret([Corolla(bud, n_fold=1), Corolla(opn, n_fold=1)], n_frames=n_frames, growth="sinusoidal",
                      lam=0.12 * length / 3.0 / detail, eta=lambda v: 3 + 4 * detail * np.sin(np.pi * (0.15 + 0.7 * v)))
    rot = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])     # +x -> -y
    return FloretType(fm.faces, fm.frames @ rot.T, fm.fixed)


@dataclass
class FlowerHead:
    """A composed flower head: canopy, floret kinds, birth times and the stage schedule."""

    canopy: Canopy
    kind: np.ndarray          # (n,) int: DISC (0) or RAY (1)
    birth: np.ndarray         # (n,) float: production time (rim first, phase effect)
    opening_duration: float

    @property
    def n_rays(self) -> int:
        """Number of ray florets (emergent from the fate cone test)."""
        return int(np.sum(self.kind == RAY))

    def schedule(self, n_steps: int, *, t_end: float | None = None) -> np.ndarray:
        """(n_steps + 1, n) per-instance stages from t = 0 (all buds) to ``t_end`` (default: all open)."""
        n_steps = check_int("n_steps", n_steps, 1, 1_000_000)
        t_end = float(self.birth.max() + self.opening_duration) if t_end is None else t_end
        return np.array([floret_stage(t - self.birth, opening_duration=self.opening_duration, growth="linear")
                         for t in np.linspace(0.0, t_end, n_steps + 1)])


def _head(receptacle, n_florets, alpha_deg, detail, n_frames, disc_scale, ray_kw, opening_duration):
    s, a, birth = centripetal_fractionation(receptacle, area=receptacle.area / n_florets,
                                            dt_prod=1.0 / n_florets)
    # [INFERRED] the last primordium fills the residual inner region (< A) and sits at the apex, about half
    # a spacing from its predecessor: a real head has no room for it, so it is not made into a floret
    s, a, birth = s[:n_florets], a[:n_florets], birth[:n_florets]
    pos, up, right = place_on_receptacle(receptacle, s, a)
    flat = pos * np.array([1.0, 1.0, 0.0])                 # fate assumes a planar canopy (§7 item 9)
    kind = np.where(ray_florets(flat, alpha_deg=alpha_deg), RAY, DISC)
    spacing = np.sqrt(receptacle.area / n_florets)
    types = [disc_floret(detail=detail, n_frames=n_frames), ray_floret(detail=detail, n_frames=n_frames, **ray_kw)]
    scale = np.full(len(s), disc_scale * spacing)
    # rays sit at the rim, facing outward and slightly raised so their ligules clear the disc florets
    pos = pos + (kind == RAY)[:, None] * 0.15 * spacing * up
    can = Canopy(types, kind, pos, up, right, scale)
    return FlowerHead(can, kind, birth, opening_duration)


def sunflower_head(n_florets: int = 280, *, alpha_deg: float = 75.0, detail: float = 1.0, n_frames: int = 8,
                   radius: float = 10.0) -> FlowerHead:
    """Sunflower-like head on a flat receptacle; 280 florets and alpha = 75 deg give 34 rays (V35).

    Lengths are in scene units with the receptacle ``radius`` (default 10) chosen so that the collision
    thickness h = 0.005 of the App. C.1 example file is small against the florets' edges.
    ``detail`` sets the triangle count (about 100k triangles at ``detail=2.2`` with 280 florets).
    """
    n_florets = check_int("n_florets", n_florets, 3, 100_000)
    alpha_deg = check_range("alpha_deg", alpha_deg, 0.0, 180.0)
    radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
    return _head(disc_receptacle(radius), n_florets, alpha_deg, detail, n_frames, 0.65,
                 {"length": 3.2, "width": 0.9}, 0.6)


def gaillardia_head(n_florets: int = 150, *, alpha_deg: float = 75.0, detail: float = 1.0, n_frames: int = 8,
                    radius: float = 10.0) -> FlowerHead:
    """Gaillardia-like head on a domed receptacle; 150 florets and alpha = 75 deg give 21 rays (V35)."""
    n_florets = check_int("n_florets", n_florets, 3, 100_000)
    alpha_deg = check_range("alpha_deg", alpha_deg, 0.0, 180.0)
    radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
    return _head(dome_receptacle(radius, 0.35 * radius), n_florets, alpha_deg, detail, n_frames, 0.65,
                 {"length": 2.6, "width": 1.1, "open_deg": 75.0}, 0.6)
