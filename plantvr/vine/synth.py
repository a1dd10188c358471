"""Synthetic flower-head volumes with ground-truth component labels (spec 000_vine §5.2, checklist item 27).

The generator draws sphere-swept polylines (veins, stem) and ellipsoids (florets, receptacle, bracts,
noise blobs) into a uint8 intensity volume with a smooth, sub-voxel ramp, so marching cubes gives smooth
surfaces, and writes the winning component of every voxel into a uint8 label volume.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_int, check_points, check_range

__all__ = ["COMPONENTS", "FlowerHead", "synth_balls", "synth_flowerhead", "synth_vessels", "tile_mesh",
           "vertex_labels_from_volume"]

#: Component names by label index (0 = background / unpainted).
COMPONENTS = ("background", "stem", "receptacle", "centrifugal", "centripetal", "floret_vein",
              "disk_floret", "ray_floret", "bract", "noise")
_CONTRAST = np.array([0, 220, 150, 230, 225, 215, 160, 150, 140, 190], np.float32)
#: Suggested iso-value: half the dimmest contrast, off the integer grid so no voxel equals it.
_LEVEL = float(0.5 * _CONTRAST[1:].min()) - 0.5
_GOLDEN = np.deg2rad(137.50776405003785)


@dataclass(frozen=True)
class FlowerHead:
    """A synthetic flower head: intensity volume, ground-truth labels and the suggested iso-value.

    Attributes
    ----------
    volume : (X, Y, Z) uint8 ndarray
        Intensity, axis 2 is "up".
    labels : (X, Y, Z) uint8 ndarray
        Index into :data:`COMPONENTS` of the primitive that dominates each voxel (0 = background).
    level : float
        Iso-value at which every component, noise included, becomes part of the surface.
    """

    volume: np.ndarray
    labels: np.ndarray
    level: float


@numba.njit(cache=True, nogil=True, inline="always")
def _stamp(vol, lab, i, j, k, v, thr, label):  # pragma: no cover - numba kernel
    """Raise voxel (i, j, k) to the rounded intensity ``v`` (no voxel is lowered); label it where ``v`` reaches
    ``thr``."""
    q = np.uint8(min(np.floor(v + 0.5), 255.0))
    if q > vol[i, j, k]:
        vol[i, j, k] = q
        if v >= thr:
            lab[i, j, k] = np.uint8(label)


@numba.njit(cache=True, nogil=True)
def _stamp_capsules(vol, lab, seg, width, thr):  # pragma: no cover - numba kernel
    nx, ny, nz = vol.shape
    for s in range(seg.shape[0]):
        ax, ay, az, bx, by, bz, r0, r1, label, contrast = seg[s]
        rmax = max(r0, r1) + width
        i0 = max(int(np.floor(min(ax, bx) - rmax)), 0)
        i1 = min(int(np.ceil(max(ax, bx) + rmax)) + 1, nx)
        j0 = max(int(np.floor(min(ay, by) - rmax)), 0)
        j1 = min(int(np.ceil(max(ay, by) + rmax)) + 1, ny)
        k0 = max(int(np.floor(min(az, bz) - rmax)), 0)
        k1 = min(int(np.ceil(max(az, bz) + rmax)) + 1, nz)
        dx, dy, dz = bx - ax, by - ay, bz - az
        ll = dx * dx + dy * dy + dz * dz
        for i in range(i0, i1):
            for j in range(j0, j1):
                for k in range(k0, k1):
                    px, py, pz = i - ax, j - ay, k - az
                    t = 0.0
                    if ll > 0.0:
                        t = min(max((px * dx + py * dy + pz * dz) / ll, 0.0), 1.0)
                    qx, qy, qz = px - t * dx, py - t * dy, pz - t * dz
                    d = np.sqrt(qx * qx + qy * qy + qz * qz)
                    r = r0 + t * (r1 - r0)
                    _stamp(vol, lab, i, j, k, contrast * min(max(0.5 + (r - d) / width, 0.0), 1.0), thr, label)


@numba.njit(cache=True, nogil=True)
def _stamp_ellipsoids(vol, lab, ell, width, thr):  # pragma: no cover - numba kernel
    nx, ny, nz = vol.shape
    for s in range(ell.shape[0]):
        cx, cy, cz, a, b, c, label, contrast, tilt, phi = ell[s]
        # local frame: rotate by phi about z, then tilt about the local y axis
        cp, sp, ct, st = np.cos(phi), np.sin(phi), np.cos(tilt), np.sin(tilt)
        rmax = max(a, max(b, c)) + width
        i0 = max(int(np.floor(cx - rmax)), 0)
        i1 = min(int(np.ceil(cx + rmax)) + 1, nx)
        j0 = max(int(np.floor(cy - rmax)), 0)
        j1 = min(int(np.ceil(cy + rmax)) + 1, ny)
        k0 = max(int(np.floor(cz - rmax)), 0)
        k1 = min(int(np.ceil(cz + rmax)) + 1, nz)
        mn = min(a, min(b, c))
        for i in range(i0, i1):
            for j in range(j0, j1):
                for k in range(k0, k1):
                    px, py, pz = i - cx, j - cy, k - cz
                    u = cp * px + sp * py
                    w = -sp * px + cp * py
                    u2 = ct * u + st * pz
                    z2 = -st * u + ct * pz
                    q = np.sqrt((u2 / a) ** 2 + (w / b) ** 2 + (z2 / c) ** 2)
                    d = (q - 1.0) * mn
                    _stamp(vol, lab, i, j, k, contrast * min(max(0.5 - d / width, 0.0), 1.0), thr, label)


def _polyline(points: np.ndarray, r0: float, r1: float, label: int) -> list:
    n = len(points) - 1
    radii = np.linspace(r0, r1, n + 1)
    return [(*points[i], *points[i + 1], radii[i], radii[i + 1], label, _CONTRAST[label]) for i in range(n)]


def _bezier(p0, p1, p2, n):
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) ** 2 * p0 + 2 * (1 - t) * t * p1 + t ** 2 * p2


def _check_shape(shape) -> tuple[int, int, int]:
    """A volume size (int: a cube, or 3 ints), each checked in [16, 4096]."""
    if isinstance(shape, (int, np.integer, float, np.floating)) and not isinstance(shape, (bool, np.bool_)):
        shape = (shape, shape, shape)
    if isinstance(shape, (str, bytes)) or not hasattr(shape, "__len__") or len(tuple(shape)) != 3:
        raise ValueError(f"shape must be an int or 3 ints, got {shape!r:.80}")
    return tuple(check_int("shape", s, 16, 4096) for s in shape)


def synth_flowerhead(shape: int | tuple[int, int, int] = 64, *, n_veins: int = 8, n_florets: int | None = None,
                     noise_blobs: int = 12, noise_level: float = 4.0,
                     rng: int | np.random.Generator | None = 0) -> FlowerHead:
    """Make a synthetic flower-head micro-CT volume with ground-truth component labels.

    Parameters
    ----------
    shape : int or tuple of 3 int
        Volume size in voxels (X, Y, Z); an int gives a cube. Each in [16, 4096].
    n_veins : int
        Number of centrifugal veins (each with one centripetal branch), in [1, 64].
    n_florets : int, optional
        Disk florets in phyllotactic order (golden angle 137.5°); default scales with the size.
    noise_blobs : int
        Small bright blobs near the centre that the iso-value also captures (spec Fig. 5.12), in [0, 10000].
    noise_level : float
        Standard deviation of additive Gaussian intensity noise, in grey levels, in [0, 50].
    rng : int, numpy.random.Generator or None
        Seed for the random placement.

    Returns
    -------
    FlowerHead
        ``volume`` and ``labels`` (X, Y, Z) uint8 and the iso-value ``level``.

    References
    ----------
    .. [1] Spec 000_vine §5.2 (generator); component glossary of §5.1 (thesis Ch. 6).
    """
    shape = _check_shape(shape)
    n_veins = check_int("n_veins", n_veins, 1, 64)
    noise_blobs = check_int("noise_blobs", noise_blobs, 0, 10000)
    noise_level = check_range("noise_level", noise_level, 0.0, 50.0)
    if n_florets is None:
        n_florets = int(np.clip(min(shape[:2]) // 3, 8, 400))
    n_florets = check_int("n_florets", n_florets, 0, 20000)
    rng = np.random.default_rng(rng)

    sx, sy, sz = (float(s) for s in shape)
    size = min(sx, sy)
    cx, cy = (sx - 1) / 2, (sy - 1) / 2
    R = 0.38 * size                     # head radius
    z_top = 0.62 * sz                   # top of receptacle
    z_rec = 0.50 * sz                   # receptacle centre
    vr = max(0.018 * size, 1.3)         # main vein radius
    caps: list = []
    ells: list = []
    # stem
    caps += _polyline(np.array([[cx, cy, 1.0], [cx, cy, z_rec - 0.05 * sz]]), 2.2 * vr, 2.0 * vr, 1)
    # receptacle: flattened disk
    ells.append((cx, cy, z_rec, 0.8 * R, 0.8 * R, 0.07 * sz, 2, _CONTRAST[2], 0.0, 0.0))
    phase = rng.uniform(0, 2 * np.pi)
    for v in range(n_veins):
        ang = phase + 2 * np.pi * v / n_veins + rng.normal(0, 0.08)
        d = np.array([np.cos(ang), np.sin(ang), 0.0])
        p0 = np.array([cx, cy, z_rec - 0.12 * sz])
        p2 = np.array([cx, cy, z_rec]) + 0.97 * R * d + np.array([0, 0, 0.06 * sz])
        p1 = np.array([cx, cy, z_rec - 0.12 * sz]) + 0.75 * R * d
        cf = _bezier(p0, p1, p2, 14)
        caps += _polyline(cf, 1.1 * vr, 0.8 * vr, 3)
        # centripetal branch: from 70 % along the centrifugal vein, inward and up to near the centre
        b0 = cf[9]
        b2 = np.array([cx, cy, z_top - 0.02 * sz]) + 0.15 * R * np.array([np.cos(ang + 0.4), np.sin(ang + 0.4), 0])
        b1 = 0.5 * (b0 + b2) + np.array([0, 0, 0.08 * sz])
        caps += _polyline(_bezier(b0, b1, b2, 10), 0.8 * vr, 0.6 * vr, 4)
        # bract at the vein end, hanging under the rim
        bp = p2 + 0.08 * R * d - np.array([0, 0, 0.05 * sz])
        ells.append((*bp, 0.16 * R, 0.07 * R, max(0.012 * sz, 1.2), 8, _CONTRAST[8], 0.5, ang))
        # ray florets at the rim, between veins
        ra = ang + np.pi / n_veins
        rd = np.array([np.cos(ra), np.sin(ra), 0.0])
        rp = np.array([cx, cy, z_top]) + 1.02 * R * rd
        ells.append((*rp, 0.14 * R, 0.05 * R, max(0.02 * sz, 1.3), 7, _CONTRAST[7], -0.2, ra))
    # disk florets in phyllotaxis on the top surface, each fed by a floret vein from the receptacle
    fr = max(0.03 * size, 1.5)
    for k in range(n_florets):
        rho = 0.8 * R * np.sqrt((k + 0.5) / n_florets)
        th = k * _GOLDEN
        top = np.array([cx + rho * np.cos(th), cy + rho * np.sin(th), z_top + 0.08 * sz])
        ells.append((*top, fr, fr, 1.6 * fr, 6, _CONTRAST[6], 0.0, 0.0))
        base = np.array([cx + 0.9 * rho * np.cos(th), cy + 0.9 * rho * np.sin(th), z_rec])
        caps += _polyline(np.array([base, top - np.array([0, 0, 1.2 * fr])]), 0.45 * vr, 0.4 * vr, 5)
    # noise blobs, concentrated near the centre (spec Fig. 5.12)
    for _ in range(noise_blobs):
        p = np.array([cx, cy, z_top + 0.2 * sz]) + rng.normal(0, 0.12 * size, 3)
        r = max(0.008 * size, 1.0) * rng.uniform(0.8, 1.6)
        ells.append((*p, r, r, r, 9, _CONTRAST[9], 0.0, 0.0))

    width = 1.5
    vol = np.zeros(shape, np.uint8)                  # 2 bytes per voxel in all (volume + labels)
    lab = np.zeros(shape, np.uint8)
    _stamp_ellipsoids(vol, lab, np.asarray(ells, np.float64), width, _LEVEL)
    _stamp_capsules(vol, lab, np.asarray(caps, np.float64), width, _LEVEL)
    if noise_level > 0:
        _add_noise(vol, lambda shape: rng.normal(0.0, noise_level, shape).astype(np.float32))
    return FlowerHead(volume=vol, labels=lab, level=_LEVEL)


def synth_vessels(shape: int | tuple[int, int, int] = (256, 256, 128), *, n_trees: int | None = None,
                  depth: int = 6, radius: float | None = None, noise_level: float = 4.0,
                  rng: int | np.random.Generator | None = 0) -> tuple[np.ndarray, float]:
    """Make a large synthetic vessel volume: branching tubes rising from the bottom, intensity only (issue 14).

    Meant for isosurface benchmarks at the 1624x1624x710 class: it writes no label volume (1 byte per voxel in
    all) and its surface grows with the volume's cross-section like a scanned flower head's vascular bundle.

    Parameters
    ----------
    shape : int or tuple of 3 int
        Volume size in voxels (X, Y, Z); an int gives a cube. Each in [16, 4096]. Axis 2 is "up".
    n_trees : int, optional
        Vessel trees, in [1, 100000]; default one per 96x96 voxels of the (X, Y) cross-section, which at
        1624x1624x710 gives a gerbera-class surface (~35 M triangles).
    depth : int
        Branching generations per tree (each tube splits in two), in [1, 12].
    radius : float, optional
        Root tube radius in voxels, in [0.5, 1000]; default 4. Children are 0.75x.
    noise_level, rng
        As in :func:`synth_flowerhead`.

    Returns
    -------
    volume : (X, Y, Z) uint8 ndarray
    level : float
        Suggested iso-value (half the vessel contrast, off the integer grid).
    """
    shape = _check_shape(shape)
    sx, sy, sz = (float(s) for s in shape)
    if n_trees is None:
        n_trees = max(1, int(sx * sy / 96 ** 2))
    n_trees = check_int("n_trees", n_trees, 1, 100000)
    depth = check_int("depth", depth, 1, 12)
    radius = check_range("radius", 4.0 if radius is None else radius, 0.5, 1000.0)
    noise_level = check_range("noise_level", noise_level, 0.0, 50.0)
    rng = np.random.default_rng(rng)
    contrast = float(_CONTRAST[3])
    caps = []
    seg_len = sz / (depth + 1)
    for _ in range(n_trees):
        stack = [(np.array([rng.uniform(0, sx - 1), rng.uniform(0, sy - 1), 0.0]), np.array([0.0, 0.0, 1.0]),
                  radius, 0)]
        while stack:
            p, d, r, g = stack.pop()
            d = d + rng.normal(0, 0.35, 3)
            d[2] = abs(d[2]) + 0.3                              # keep rising
            d /= np.linalg.norm(d)
            q = p + seg_len * rng.uniform(0.7, 1.2) * d
            bend = 0.5 * (p + q) + rng.normal(0, 0.15 * seg_len, 3)
            caps += _polyline(_bezier(p, bend, q, 6), r, 0.9 * r, 3)
            if g + 1 < depth:
                side = np.cross(d, rng.normal(size=3))
                side /= np.linalg.norm(side) + 1e-12
                for sgn in (1.0, -1.0):
                    stack.append((q, d + 0.6 * sgn * side, 0.75 * r, g + 1))
    cap = np.asarray(caps, np.float64)
    cap[:, 9] = contrast
    vol = np.zeros(shape, np.uint8)
    _stamp_capsules(vol, np.zeros((1, 1, 1), np.uint8), cap, 1.5, np.inf)   # thr = inf: no label writes
    if noise_level > 0:
        _add_noise(vol, lambda shape: noise_level * rng.standard_normal(shape, dtype=np.float32))
    return vol, 0.5 * contrast - 0.5


def _add_noise(vol: np.ndarray, draw) -> None:
    """Add the float32 noise ``draw(shape)`` to the uint8 ``vol`` in place, rounded and clipped to [0, 255], slab by
    slab along axis 0 so the float temporary stays small."""
    for i in range(0, vol.shape[0], 16):
        sl = vol[i:i + 16].astype(np.float32)
        sl += draw(sl.shape)
        np.clip(np.rint(sl, out=sl), 0, 255, out=sl)
        vol[i:i + 16] = sl


def synth_balls(n: int = 16, centers=None, radius: float | None = None, *, value: int = 200) -> np.ndarray:
    """An ``n``³ uint8 volume of solid balls (``value`` inside, 0 outside): the smallest closed test surfaces.

    ``centers`` (k, 3) voxel coordinates default to the grid centre, ``radius`` (voxels) to ``n / 3``; a voxel is
    inside when its distance to a centre is ``< radius``.
    """
    n = check_int("n", n, 2, 1024)
    c = np.full((1, 3), (n - 1) / 2) if centers is None else check_points("centers", centers)
    r = n / 3 if radius is None else check_range("radius", radius, 0.0, 1e6, low_open=True)
    value = check_int("value", value, 1, 255)
    g = np.mgrid[:n, :n, :n].astype(np.float32)
    inside = np.zeros((n, n, n), bool)
    for x in c:
        inside |= np.sqrt(((g - x.astype(np.float32)[:, None, None, None]) ** 2).sum(0)) < r
    return inside.astype(np.uint8) * np.uint8(value)


def vertex_labels_from_volume(vertices: np.ndarray, volume: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Ground-truth label of each isosurface vertex: the label of the brightest labelled corner of its cell.

    Vertices whose eight cell corners are all unlabelled get 0.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
        Vertex positions in voxel index coordinates (as returned by marching cubes).
    volume : (X, Y, Z) ndarray
        Intensity volume the surface was extracted from.
    labels : (X, Y, Z) uint8 ndarray
        Ground-truth label volume.

    Returns
    -------
    (V,) uint8 ndarray
    """
    from plantvr.vine.volume import _check_volume
    v = check_array("vertices", vertices, shape=(None, 3), max_abs=MAX_COORD)
    volume = _check_volume("volume", volume)
    labels = np.asarray(labels) if isinstance(labels, np.ndarray) else labels
    if not isinstance(labels, np.ndarray) or labels.shape != volume.shape or labels.dtype != np.uint8:
        raise ValueError(f"labels must be a uint8 array of the volume's shape {volume.shape}, got "
                         f"{getattr(labels, 'dtype', type(labels).__name__)} {getattr(labels, 'shape', '')}")
    base = np.floor(v).astype(np.int64)
    best = np.full(len(v), -np.inf)
    out = np.zeros(len(v), np.uint8)
    hi = np.array(volume.shape) - 1
    for corner in np.ndindex(2, 2, 2):
        c = np.clip(base + np.array(corner), 0, hi)
        val = volume[c[:, 0], c[:, 1], c[:, 2]].astype(np.float64)     # any volume dtype, exact to 2**53
        lab = labels[c[:, 0], c[:, 1], c[:, 2]]
        take = (val > best) & (lab > 0)
        best[take] = val[take]
        out[take] = lab[take]
    return out


def tile_mesh(vertices: np.ndarray, faces: np.ndarray, n_vertices: int, *, gap: float = 1.05
              ) -> tuple[np.ndarray, np.ndarray]:
    """Tile copies of a mesh on a grid until it has at least ``n_vertices`` (scale tests, spec §5.2 V13).

    Parameters
    ----------
    vertices : (V, 3) float32 ndarray
    faces : (F, 3) integer ndarray
    n_vertices : int
        Target vertex count, in [1, 2**31 - 1].
    gap : float
        Spacing of copies as a multiple of the mesh's bounding-box size.

    Returns
    -------
    vertices : (V', 3) float32 ndarray
    faces : (F', 3) uint32 ndarray
    """
    from plantvr.vine.fill import _check_mesh_arrays
    n_vertices = check_int("n_vertices", n_vertices, 1, 2 ** 31 - 1)
    gap = check_range("gap", gap, 0.0, 1e3)
    v, f = _check_mesh_arrays(vertices, faces)
    v, f = v.astype(np.float32), f.astype(np.int64)
    if (n_vertices // len(v) + 1) * max(len(f), 1) > 2 ** 31 - 1:
        raise ValueError(f"n_vertices {n_vertices} would need more than 2**31 - 1 faces")
    copies = int(np.ceil(n_vertices / max(len(v), 1)))
    side = int(np.ceil(copies ** (1 / 3)))
    ext = (v.max(0) - v.min(0)) * gap
    out_v = np.empty((copies * len(v), 3), np.float32)
    out_f = np.empty((copies * len(f), 3), np.uint32)
    for c in range(copies):
        ijk = np.array([c % side, (c // side) % side, c // (side * side)], np.float32)
        out_v[c * len(v):(c + 1) * len(v)] = v + ijk * ext
        out_f[c * len(f):(c + 1) * len(f)] = f + c * len(v)
    return out_v, out_f
