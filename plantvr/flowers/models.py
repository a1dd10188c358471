"""The seven example models of spec 002 §6.2 / C28 (Ch. 9): sunflower-like, Gaillardia-like, dahlia, Dyssodia,
yarrow, Orlaya and lilac.

Each model runs the pipeline of spec 002 §1.2 a–f: floret key poses → one OBJ-like animation per floret
type (fixed topology) → centripetal fractionation on the receptacle (Eq. 5.2) → floret fate by the cone
test (Eq. 6.1 with ERRATUM A.4) → stage from primordium age (phase effect) → a :class:`Canopy` whose
growth :func:`~plantvr.flowers.composer.grow` resolves with PBD + CCD. The ray-floret count is emergent
(from n and alpha), never assigned: 34 for the sunflower-like head, 21 for the Gaillardia-like head (V35).
The dahlia is a ball of cupped, incurved ray florets layered like scales (:func:`dahlia_head`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantvr._validation import check_int, check_range
from plantvr.flowers.branching import BranchTree, compound_umbel, rodkaew, scale_tree
from plantvr.flowers.composer import Canopy, FloretType
from plantvr.flowers.fate import cone_dmin, floret_fate, ray_florets
from plantvr.flowers.floret import Corolla, build_floret, midrib, petal_net, roll_margins
from plantvr.flowers.phyllotaxis import (
    centripetal_fractionation,
    disc_receptacle,
    dome_receptacle,
    floret_stage,
    place_on_receptacle,
    vogel_disc,
)

__all__ = ["DAHLIA_BANDS", "FlowerHead", "dahlia_floret", "dahlia_head", "disc_floret", "dyssodia_head", "gaillardia_head", "lilac_panicle",
           "orlaya_umbel", "quill_floret", "ray_floret", "sunflower_head", "yarrow_corymb"]

DISC, RAY = 0, 1


def disc_floret(*, detail: float = 1.0, n_frames: int = 8, n_fold: int = 5, open_deg: float = 55.0
                ) -> FloretType:
    """A tubular, 5-fold fused disc floret opening from a closed bud (spec 002 §2, C1–C4).

    ``detail`` scales the polygonization density (rows from Eq. 2.1 and samples per row).
    """
    detail = check_range("detail", detail, 0.1, 10.0)
    n_frames = check_int("n_frames", n_frames, 2, 1000)
    n_fold = check_int("n_fold", n_fold, 2, 64)
    open_deg = check_range("open_deg", open_deg, -180.0, 180.0)
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
    length = check_range("length", length, 0.01, 1e6)         # lam scales with it (Eq. 2.1 rows)
    width = check_range("width", width, 0.01, 1e6)             # narrower ligules polygonize to nothing
    open_deg = check_range("open_deg", open_deg, -180.0, 180.0)
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
    head: np.ndarray | None = None        # (n,) int: head / umbellet / cyme of each floret (compound models)
    centres: np.ndarray | None = None     # (H, 3): centre of each head / umbellet
    tree: BranchTree | None = None        # branching structure (corymb, umbel, panicle), node 0 = base
    level: np.ndarray | None = None       # (N,) int: branching level of each tree node
    fate: np.ndarray | None = None        # (n,) int: fate.DISC / SMALL_RAY / LARGE_RAY (threshold models)
    size: np.ndarray | None = None        # (n,) float: relative ray-petal size from d_min (Fig. 6.4c)

    @property
    def n_rays(self) -> int:
        """Number of ray florets (emergent from the fate cone test)."""
        return int(np.sum(self.kind == RAY))

    def schedule(self, n_steps: int, *, t_end: float | None = None) -> np.ndarray:
        """(n_steps + 1, n) per-instance stages from t = 0 (all buds) to ``t_end`` (default: all open)."""
        n_steps = check_int("n_steps", n_steps, 1, 1_000_000)
        t_end = (float(self.birth.max() + self.opening_duration) if t_end is None
                 else check_range("t_end", t_end, -1e12, 1e12))
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


# ---------------------------------------------------------------------------------------------------------
# The remaining example models of spec 002 §6.2 / C28: dahlia, Dyssodia, yarrow, Orlaya, lilac


def quill_floret(*, detail: float = 1.0, n_frames: int = 8, length: float = 2.2, incurve_deg: float = -70.0
                 ) -> FloretType:
    """An incurved, almost tubular ray floret (dahlia 'Jomanda', spec 002 §6.2): a narrow 3-fold fused tube
    whose tip bends back toward the floret axis by ``incurve_deg``."""
    detail = check_range("detail", detail, 0.1, 10.0)
    n_frames = check_int("n_frames", n_frames, 2, 1000)
    length = check_range("length", length, 0.01, 1e6)         # lam scales with it (Eq. 2.1 rows)
    incurve_deg = check_range("incurve_deg", incurve_deg, -180.0, 180.0)
    bud = Corolla(petal_net(opening_deg=4, length=0.3, width=0.1, base_radius=0.05), n_fold=3, fused_rows=3)
    opn = Corolla(petal_net(opening_deg=35, curl_deg=incurve_deg, length=length, width=0.32, base_radius=0.05),
                  n_fold=3, fused_rows=3)
    fm = build_floret([bud, opn], n_frames=n_frames, growth="sinusoidal", lam=0.2 * length / 2.2 / detail,
                      eta=lambda v: 3 + 2 * detail * v)
    return FloretType(fm.faces, fm.frames, fm.fixed)


def _flat_frames(pos, centres):
    """Florets facing +z on a planar canopy; ligules point away from their head centre."""
    up = np.tile([0.0, 0.0, 1.0], (len(pos), 1))
    out = (pos - centres) * [1.0, 1.0, 0.0]
    n = np.linalg.norm(out, axis=1, keepdims=True)
    out = np.where(n > 1e-12, out / np.where(n > 0, n, 1), [[1.0, 0.0, 0.0]])
    return up, np.cross(up, out)


def _heads(centres, n_per_head, radius, height_frac=0.3):
    """Capitula of ``n_per_head`` florets (centripetal fractionation on a dome) around each centre."""
    rec = dome_receptacle(radius, height_frac * radius)
    s, a, birth = centripetal_fractionation(rec, area=rec.area / n_per_head, dt_prod=1.0 / n_per_head)
    s, a, birth = s[:n_per_head], a[:n_per_head], birth[:n_per_head]
    p, u, r = place_on_receptacle(rec, s, a)
    H = len(centres)
    pos = (p[None] + centres[:, None]).reshape(-1, 3)
    return (pos, np.tile(u, (H, 1)), np.tile(r, (H, 1)), np.tile(birth, H),
            np.repeat(np.arange(H), n_per_head), np.sqrt(rec.area / n_per_head))


def _cupped_net(length: float, width: float, opening_deg: float, incurve_deg: float, roll_deg: float, *,
                nu: int = 7, nv: int = 7, base_radius: float = 0.05, base_width: float = 0.3) -> np.ndarray:
    """A broad ligule with a rounded tip, leaning ``opening_deg`` from the floret axis, its tip bent by
    ``incurve_deg`` and its margins rolled by ``roll_deg`` (dahlia ray floret, spec 002 §6.2)."""
    t = np.linspace(0.0, 1.0, nv)
    mid = midrib(length, opening_deg, incurve_deg, nv, base_radius)
    rise = np.sin(0.5 * np.pi * np.minimum(t / 0.55, 1.0)) ** 0.7                # widening from the base
    tip = np.sqrt(np.clip(1.0 - ((t - 0.55) / 0.47) ** 2, 0.0, 1.0))              # elliptic, rounded tip
    prof = width * (base_width + (1.0 - base_width) * np.where(t <= 0.55, rise, tip))
    prof[-1] = 0.35 * width
    ctrl = np.repeat(mid[None], nu, axis=0)
    ctrl[:, :, 1] = np.linspace(-1.0, 1.0, nu)[:, None] * prof[None, :] / 2
    return roll_margins(ctrl, roll_deg)


def dahlia_floret(*, detail: float = 1.0, n_frames: int = 8, length: float = 3.6, width: float = 2.2,
                  open_deg: float = 60.0, incurve_deg: float = -30.0, roll_deg: float = 90.0) -> FloretType:
    """An incurved, cupped ray floret of a ball dahlia (spec 002 §6.2, Figs. 9.1–9.2).

    One broad ligule (n-fold 1) with a rounded tip whose margins roll toward its upper side by ``roll_deg``
    ("incurved, almost tubular"); it opens from a tight, upright tube (the bud) to lean ``open_deg`` from the
    floret axis with its tip bent back by ``incurve_deg``. Sizes are in units of the floret spacing. As for
    :func:`ray_floret`, the ligule points along -y in floret coordinates (outward on a receptacle).
    About 108 triangles at ``detail=1``.
    """
    detail = check_range("detail", detail, 0.1, 10.0)
    n_frames = check_int("n_frames", n_frames, 2, 1000)
    length = check_range("length", length, 0.0, 1e6, low_open=True)
    width = check_range("width", width, 0.01, 1e6)             # narrower ligules polygonize to nothing
    open_deg = check_range("open_deg", open_deg, -90.0, 120.0)
    incurve_deg = check_range("incurve_deg", incurve_deg, -180.0, 180.0)
    roll_deg = check_range("roll_deg", roll_deg, 0.0, 175.0)
    bud = _cupped_net(0.35 * length, 0.5 * width, 5.0, -4.0, max(roll_deg, 150.0))
    opn = _cupped_net(length, width, open_deg, incurve_deg, roll_deg)
    fm = build_floret([Corolla(bud, n_fold=1), Corolla(opn, n_fold=1)], n_frames=n_frames, growth="sinusoidal",
                      lam=0.11 / detail, eta=3 + 4 * detail)
    rot = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])     # +x -> -y
    return FloretType(fm.faces, fm.frames @ rot.T, fm.fixed)


#: Dahlia bands over the polar angle of the receptacle (fraction of 90 deg): (from, opening deg, scale). The
#: innermost florets lean over the apex and close the centre [INFERRED, from the photograph of Fig. 9.2].
DAHLIA_BANDS = ((0.0, -50.0, 1.2), (0.1, 45.0, 1.0), (0.2, None, 1.0))


def dahlia_head(n_florets: int = 300, *, radius: float = 10.0, detail: float = 1.0, n_frames: int = 8,
                open_deg: float = 60.0, incurve_deg: float = -30.0, roll_deg: float = 90.0, length: float = 3.6,
                width: float = 2.2) -> FlowerHead:
    """Dahlia 'Jomanda'-like ball (Figs. 9.1–9.2): phyllotaxis on a hemispherical receptacle, every floret an
    incurved, cupped ray floret; the florets overlap like scales and collisions shape them (spec 002 §6.2).

    There is no fate test: the head is "populated almost exclusively by ... ray florets". Florets lean
    ``open_deg`` away from the apex, so each one covers the base of its outer neighbours and the ligules
    (``length`` x ``width`` floret spacings, margins rolled by ``roll_deg``) layer into a closed ball; toward the
    apex they lean less and the innermost ones lean over the apex (:data:`DAHLIA_BANDS`). The phase effect
    opens the rim first. 300 florets give about 32,000 triangles at ``detail=1`` (Table 4.1: 30,000).
    """
    n_florets = check_int("n_florets", n_florets, 3, 100_000)
    radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
    open_deg = check_range("open_deg", open_deg, -90.0, 120.0)
    detail = check_range("detail", detail, 0.1, 10.0)
    n_frames = check_int("n_frames", n_frames, 2, 1000)
    kw = {"detail": detail, "n_frames": n_frames, "length": length, "width": width, "roll_deg": roll_deg}
    rec = dome_receptacle(radius, radius)                  # hemisphere: "approximately spherical surface"
    s, a, birth = centripetal_fractionation(rec, area=rec.area / n_florets, dt_prod=1.0 / n_florets)
    s, a, birth = s[:n_florets], a[:n_florets], birth[:n_florets]
    pos, up, right = place_on_receptacle(rec, s, a)
    spacing = np.sqrt(rec.area / n_florets)
    polar = np.arccos(np.clip(up[:, 2], -1.0, 1.0)) / (0.5 * np.pi)
    types, kind, scale = [], np.zeros(n_florets, np.int64), np.full(n_florets, spacing)
    for i, (start, ang, _) in enumerate(DAHLIA_BANDS):
        ang = open_deg if ang is None else min(ang, open_deg)
        types.append(dahlia_floret(open_deg=ang, incurve_deg=-incurve_deg / 2 if ang < 0 else incurve_deg, **kw))
        kind[polar >= start] = i
    scale *= np.array([b[2] for b in DAHLIA_BANDS])[kind]
    can = Canopy(types, kind, pos, up, right, scale)
    centre = np.array([[0.0, 0.0, 0.0]])
    return FlowerHead(can, np.full(n_florets, RAY), birth, 0.6, head=np.zeros(n_florets, np.int64),
                      centres=centre)


def dyssodia_head(florets_per_head: int = 55, *, n_outer: int = 5, head_radius: float = 2.0, ring: float = 2.4,
                  alpha_deg: float = 53.0, th_b: float | None = None, detail: float = 1.0, n_frames: int = 8
                  ) -> FlowerHead:
    """Dyssodia decipiens-like compound head (Figs. 9.7–9.8): a central head surrounded by ``n_outer`` = 5 heads,
    fate of Fig. 6.4b (spec 002 §4.6): ray iff d_min(P) > Th_b with Th_b larger than the distance between the
    heads, O = centre of P's own head, alpha = 53 deg. Rays emerge "at the level of the entire inflorescence":
    none in the central head, only on the outer sides of the peripheral heads.

    ``th_b`` defaults to twice the distance between head centres (``2 ring head_radius``).
    """
    florets_per_head = check_int("florets_per_head", florets_per_head, 3, 100_000)
    n_outer = check_int("n_outer", n_outer, 1, 64)
    head_radius = check_range("head_radius", head_radius, 0.0, 1e6, low_open=True)
    ring = check_range("ring", ring, 2.0, 1e3)
    alpha_deg = check_range("alpha_deg", alpha_deg, 0.0, 180.0)
    th_b = 2 * ring * head_radius if th_b is None else check_range("th_b", th_b, 0.0, 1e12, low_open=True)
    t = np.deg2rad(90.0 + 360.0 / n_outer * np.arange(n_outer))
    C = np.vstack([[0.0, 0.0, 0.0], np.column_stack([ring * head_radius * np.cos(t),
                                                      ring * head_radius * np.sin(t), np.zeros(n_outer)])])
    pos, up, right, birth, hid, spacing = _heads(C, florets_per_head, head_radius)
    d = cone_dmin(pos * [1.0, 1.0, 0.0], alpha_deg=alpha_deg, centres=C[hid] * [1.0, 1.0, 0.0])
    fate, size = floret_fate(d, th_b=th_b)
    kind = np.where(fate > 0, RAY, DISC)
    types = [disc_floret(detail=detail, n_frames=n_frames),
             ray_floret(detail=detail, n_frames=n_frames, length=2.4, width=1.0, open_deg=80.0)]
    pos = pos + (kind == RAY)[:, None] * 0.15 * spacing * up
    can = Canopy(types, kind, pos, up, right, np.full(len(pos), 0.65 * spacing))
    return FlowerHead(can, kind, birth, 0.6, head=hid, centres=C, fate=fate, size=size)


def yarrow_corymb(n_heads: int = 13, florets_per_head: int = 6, *, head_radius: float = 1.0,
                  head_spacing: float = 3.5, height: float = 14.0, alpha_deg: float = 53.0,
                  th_a: float | None = None, detail: float = 1.0, n_frames: int = 8) -> FlowerHead:
    """Yarrow-like corymb of heads (Figs. 1.3, 9.9–9.10, 9.13–9.14; spec 002 §6.2).

    Head centres follow a Vogel spiral (the first level of the recursive pattern of Fig. 5.3, [INFERRED]
    simplification) in a single plane at ``height``; florets in each head by centripetal fractionation; fate of
    Fig. 6.4a: ray iff d_min(P) > Th_a with Th_a larger than the floret spacing in a head and smaller than the
    distance between heads (default 0.7x the gap between neighbouring heads), alpha = 53 deg, so every head
    differentiates its rays independently (6 florets per head give 5 rays, as in a yarrow capitulum). The branching structure is the extended Rodkaew algorithm from the head centres to
    the base (florets first), with a high base attraction for an elongated corymb.
    """
    n_heads = check_int("n_heads", n_heads, 1, 10_000)
    florets_per_head = check_int("florets_per_head", florets_per_head, 3, 10_000)
    head_radius = check_range("head_radius", head_radius, 0.0, 1e6, low_open=True)
    head_spacing = check_range("head_spacing", head_spacing, 2.0 * head_radius, 1e6)
    height = check_range("height", height, 0.0, 1e6, low_open=True)
    alpha_deg = check_range("alpha_deg", alpha_deg, 0.0, 180.0)
    th_a = 0.7 * (head_spacing - 2 * head_radius) if th_a is None else check_range("th_a", th_a, 0.0, 1e12, low_open=True)
    C = vogel_disc(n_heads, c=head_spacing / np.sqrt(np.pi) * 1.05) + [0.0, 0.0, height]
    spread = float(np.abs(C[:, :2]).max())
    if spread > 100.0 * height:                 # the branching runs in units of height (delta = 0.01)
        raise ValueError(f"height must be at least 1/100 of the corymb's spread ({spread!r}), got {height!r}")
    pos, up, right, birth, hid, spacing = _heads(C, florets_per_head, head_radius)
    d = cone_dmin(pos * [1.0, 1.0, 0.0], alpha_deg=alpha_deg, centres=C[hid] * [1.0, 1.0, 0.0])
    fate, size = floret_fate(d, th_a=th_a)
    kind = np.where(fate > 0, RAY, DISC)
    # branching in unit scale (the prototype's step and merge constants), then scaled to the scene
    s = height
    order = np.argsort(-np.linalg.norm(C[:, :2], axis=1), kind="stable")      # rim heads emerge first
    tau = np.empty(n_heads)
    tau[order] = np.arange(n_heads) * 2.0
    tree = rodkaew(C / s, [0.0, 0.0, 0.0], emergence=tau, w_a=1.5, delta=0.01, merge_dist=0.012,
                   search_radius=0.08)
    tree = scale_tree(tree, s, about=[0.0, 0.0, 0.0])
    types = [disc_floret(detail=detail, n_frames=n_frames),
             ray_floret(detail=detail, n_frames=n_frames, length=1.6, width=1.2, open_deg=80.0)]
    pos = pos + (kind == RAY)[:, None] * 0.15 * spacing * up
    can = Canopy(types, kind, pos, up, right, np.full(len(pos), 0.65 * spacing))
    level = np.ones(tree.n_nodes, np.int64)
    return FlowerHead(can, kind, birth, 0.6, head=hid, centres=C, tree=tree, level=level, fate=fate, size=size)


def orlaya_umbel(n_umbellets: int = 13, florets_per_umbellet: int = 21, *, scale: float = 10.0,
                 alpha_deg: float = 53.0, th_a: float | None = None, th_b: float | None = None,
                 detail: float = 1.0, n_frames: int = 8) -> FlowerHead:
    """Orlaya grandiflora-like compound umbel (Figs. 1.1, 9.11–9.13; spec 002 §6.2).

    Two branching levels generated separately and joined (Fig. 7.2b, :func:`compound_umbel`): spiral
    phyllotaxis of umbellets in the umbel and of florets in each umbellet. Fate of Fig. 6.4c with O = the
    umbellet centre and alpha = 53 deg: large rays where d_min > Th_b (periphery of the whole umbel), small
    rays with size proportional to d_min where Th_a < d_min <= Th_b (outer florets of the umbellets), small
    five-fold disc florets inside. Defaults: Th_a = 2x the floret spacing, Th_b = 1.2x the umbellet spacing.
    """
    n_umbellets = check_int("n_umbellets", n_umbellets, 1, 10_000)
    florets_per_umbellet = check_int("florets_per_umbellet", florets_per_umbellet, 3, 10_000)
    scale = check_range("scale", scale, 0.0, 1e6, low_open=True)
    alpha_deg = check_range("alpha_deg", alpha_deg, 0.0, 180.0)
    r_um = 0.5 * np.sqrt(n_umbellets / 13.0)
    r_fl = 0.08 * np.sqrt(florets_per_umbellet / 21.0)
    tree, level = compound_umbel(n_umbellets, florets_per_umbellet, radius=r_um, umbellet_radius=r_fl)
    tree = scale_tree(tree, scale, about=[0.0, 0.0, 0.0])
    pos = tree.pos[tree.tips]
    hid = np.repeat(np.arange(n_umbellets), florets_per_umbellet)
    C = np.array([pos[hid == j].mean(axis=0) for j in range(n_umbellets)])
    fl_sp = scale * r_fl * np.sqrt(np.pi / florets_per_umbellet)
    um_sp = scale * r_um * np.sqrt(np.pi / n_umbellets)
    th_a = 2.0 * fl_sp if th_a is None else check_range("th_a", th_a, 0.0, 1e12, low_open=True)
    if th_b is None and th_a >= 1.2 * um_sp:
        raise ValueError(f"th_a must be below th_b (default 1.2x the umbellet spacing = {1.2 * um_sp!r}), "
                         f"got {th_a!r}")
    th_b = 1.2 * um_sp if th_b is None else check_range("th_b", th_b, th_a, 1e12, low_open=True)
    d = cone_dmin(pos * [1.0, 1.0, 0.0], alpha_deg=alpha_deg, centres=C[hid] * [1.0, 1.0, 0.0])
    fate, size = floret_fate(d, th_a=th_a, th_b=th_b, small_size=0.6, large_size=1.0)
    kind = np.where(fate > 0, RAY, DISC)
    up, right = _flat_frames(pos, C[hid])
    base = 0.6 * fl_sp
    sc = np.where(kind == RAY, base * (0.35 + 0.65 * size), base)
    types = [disc_floret(detail=detail, n_frames=n_frames, open_deg=70.0),
             ray_floret(detail=detail, n_frames=n_frames, length=2.6, width=1.6, open_deg=85.0)]
    radial = np.linalg.norm(pos[:, :2], axis=1)
    birth = (radial.max() - radial) / max(radial.max(), 1e-12)        # outer florets first
    can = Canopy(types, kind, pos, up, right, sc)
    return FlowerHead(can, kind, birth, 0.6, head=hid, centres=C, tree=tree, level=level.astype(np.int64),
                      fate=fate, size=size)


def lilac_panicle(n_pairs: int = 6, *, height: float = 20.0, branch_length: float = 7.0, cyme: int = 3,
                  detail: float = 1.0, n_frames: int = 8) -> FlowerHead:
    """Lilac-like panicle, branching first (Figs. 4.9–4.10; spec 002 §6.2, after [8]).

    A main axis with ``n_pairs`` decussate pairs of lateral branches (opposite, successive pairs at 90 deg)
    whose length decreases linearly toward the apex (conical thyrse); every lateral and the apex end in a
    cyme of ``cyme`` pedicels, each bearing one four-fold salverform floret. Florets are placed on the
    branching structure and packed closely, so collisions displace and deform them (the only PBD use here).

    Floret count: ``cyme * (2 n_pairs + 1)``. Tree levels: 1 main axis, 2 laterals, 3 pedicels.
    """
    n_pairs = check_int("n_pairs", n_pairs, 1, 1000)
    height = check_range("height", height, 0.0, 1e6, low_open=True)
    branch_length = check_range("branch_length", branch_length, 0.0, 1e6, low_open=True)
    cyme = check_int("cyme", cyme, 1, 12)
    pos, parent, level, tips, fl_up = [[0.0, 0.0, 0.0]], [-1], [1], [], []
    ped = 0.12 * branch_length

    def add(p, par, lv):
        pos.append(list(p))
        parent.append(par)
        level.append(lv)
        return len(pos) - 1

    def add_cyme(node, direction):
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        side = np.cross(d, [0.0, 0.0, 1.0])
        side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-9 else np.array([1.0, 0.0, 0.0])
        up2 = np.cross(side, d)
        for k in range(cyme):
            ang = 2 * np.pi * k / cyme
            u = d + 0.8 * (np.cos(ang) * side + np.sin(ang) * up2) if cyme > 1 else d
            u = u / np.linalg.norm(u)
            tips.append(add(np.asarray(pos[node]) + ped * u, node, 3))
            fl_up.append(u)

    prev = 0
    for i in range(n_pairs):
        z = height * (0.25 + 0.7 * i / n_pairs)
        node = add([0.0, 0.0, z], prev, 1)
        prev = node
        L = branch_length * (1.0 - 0.8 * i / n_pairs)
        phi = (np.pi / 2) * i                                     # decussate
        for sgn in (1.0, -1.0):
            d = np.array([sgn * np.cos(phi), sgn * np.sin(phi), 0.9])
            d /= np.linalg.norm(d)
            end = add(np.asarray(pos[node]) + L * d, node, 2)
            add_cyme(end, d)
    apex = add([0.0, 0.0, height], prev, 1)
    add_cyme(apex, [0.0, 0.0, 1.0])
    pos, tips, fl_up = np.asarray(pos), np.asarray(tips, np.int64), np.asarray(fl_up)
    tree = BranchTree(pos, np.asarray(parent, np.int64), np.zeros(len(pos), np.int64), tips, [])
    n = len(tips)
    ref = np.where(np.abs(fl_up[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    right = np.cross(fl_up, ref)
    spacing = ped * 0.9
    can = Canopy([disc_floret(detail=detail, n_frames=n_frames, n_fold=4, open_deg=80.0)], np.zeros(n, np.int64),
                 pos[tips], fl_up, right, np.full(n, spacing))
    birth = np.linspace(0.0, 1.0, n)                              # acropetal: lower branches open first
    return FlowerHead(can, np.full(n, DISC), birth, 0.6, head=np.repeat(np.arange(n // cyme), cyme),
                      tree=tree, level=np.asarray(level, np.int64))
