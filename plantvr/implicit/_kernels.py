"""numba kernels and their numpy twins for BlobTree field evaluation (spec 003_implicit_sca §2.2-2.4).

One kernel sums the Wyvill fields of many point/segment primitives with per-primitive affine transforms,
skipping each primitive outside its bounding box (the hot path of a deep summation blend). Kernels do no I/O.
"""
from __future__ import annotations

import numba
import numpy as np

from .fields import WYVILL_A, WYVILL_B, WYVILL_C

__all__ = ["segment_blend_numba", "segment_blend_numpy"]


@numba.njit(cache=True, nogil=True)
def segment_blend_numba(p, a, b, radius, minv, lo, hi):  # pragma: no cover - covered through the numpy twin
    n = p.shape[0]
    k_count = a.shape[0]
    out = np.zeros(n)
    for i in range(n):
        x, y, z = p[i, 0], p[i, 1], p[i, 2]
        acc = 0.0
        for k in range(k_count):
            if x < lo[k, 0] or x > hi[k, 0] or y < lo[k, 1] or y > hi[k, 1] or z < lo[k, 2] or z > hi[k, 2]:
                continue
            m = minv[k]
            qx = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]
            qy = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]
            qz = m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3]
            ex = b[k, 0] - a[k, 0]
            ey = b[k, 1] - a[k, 1]
            ez = b[k, 2] - a[k, 2]
            dx = qx - a[k, 0]
            dy = qy - a[k, 1]
            dz = qz - a[k, 2]
            ee = ex * ex + ey * ey + ez * ez
            t = 0.0
            if ee > 0.0:
                t = (dx * ex + dy * ey + dz * ez) / ee
                if t < 0.0:
                    t = 0.0
                elif t > 1.0:
                    t = 1.0
            rx = dx - t * ex
            ry = dy - t * ey
            rz = dz - t * ez
            s = (rx * rx + ry * ry + rz * rz) / (radius[k] * radius[k])
            if s < 1.0:
                acc += ((WYVILL_A * s + WYVILL_B) * s + WYVILL_C) * s + 1.0
        out[i] = acc
    return out


def segment_blend_numpy(p, a, b, radius, minv, lo, hi):
    """Readable numpy twin of :func:`segment_blend_numba` (same arithmetic, vectorised over points)."""
    out = np.zeros(p.shape[0])
    for k in range(a.shape[0]):
        inside = np.all((p >= lo[k]) & (p <= hi[k]), axis=1)
        if not inside.any():
            continue
        q = p[inside] @ minv[k, :, :3].T + minv[k, :, 3]
        e = b[k] - a[k]
        d = q - a[k]
        ee = float(e @ e)
        t = np.clip(d @ e / ee, 0.0, 1.0) if ee > 0.0 else np.zeros(len(q))
        r = d - t[:, None] * e
        s = np.einsum("ij,ij->i", r, r) / (radius[k] * radius[k])
        f = ((WYVILL_A * s + WYVILL_B) * s + WYVILL_C) * s + 1.0
        out[inside] += np.where(s < 1.0, f, 0.0)
    return out
