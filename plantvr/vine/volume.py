"""Volume arrays for ViNE (spec 000_vine §1.4–1.5, checklist item 1): checks, writing, 2x downsampling, levels.

Volumes are uint8/16/32, int8/16/32 or float32/float64 (issue 22) in native byte order; float volumes must be
finite, checked slab by slab. No function here makes a float copy of the whole volume. uint8/uint16 keep their
dtype-range histograms and levels; every other dtype is binned and checked over the data's own range, in the
data's units. This numeric core reads no files: every format is read by :func:`plantvr.io.volume.read_volume`
(ViNE's TIFF/.npy/.npz input: :func:`plantvr.io.volume.load_volume`, a thin call into it; issue 30, "one reader
per format").
"""
from __future__ import annotations

import os
import re
import tokenize
from pathlib import Path

import numpy as np

from plantvr._fileio import atomic_write
from plantvr._validation import check_choice, check_int

__all__ = ["MAX_VOLUME_BYTES", "downsample2", "histogram", "save_volume", "suggest_level"]

_DTYPES = tuple(np.dtype(t) for t in (np.uint8, np.uint16, np.uint32, np.int8, np.int16, np.int32,
                                       np.float32, np.float64))
_NARROW = (np.dtype(np.uint8), np.dtype(np.uint16))   # dtype-range histogram and level bounds (unchanged)
_DTYPE_NAMES = "uint8, uint16, uint32, int8, int16, int32, float32 or float64"
#: Bytes of one slab of the slab-wise passes over a volume (range, finiteness).
_SLAB_BYTES = 2 ** 26

#: Largest volume (bytes) :func:`plantvr.io.volume.read_volume` reads into memory: every size a file declares
#: (``.npy``/``.npz`` headers, TIFF pages) is checked against it before anything is allocated. Memory maps need
#: no memory, so they are only checked against the file's real length.
MAX_VOLUME_BYTES = 16 * 2 ** 30


def natural_key(name: str) -> tuple:
    """Sort key of slice file names in natural order: ``img_2.tif`` before ``img_10.tif`` (runs of digits compare
    as numbers, the rest case-insensitively; the name itself breaks ties)."""
    parts = re.split(r"(\d+)", name)
    return tuple((int(t), t) if k % 2 else (t.lower(), t) for k, t in enumerate(parts))


def _check_declared(path, shape, dtype, *, mapped: bool = False) -> None:
    """Refuse a declared volume that is not (X, Y, Z) of a volume dtype or too big to read, before allocating it."""
    dtype = np.dtype(dtype)
    dtype = dtype.newbyteorder("=") if dtype.byteorder != "|" else dtype   # '>u2' is uint16 (read natively)
    shape = tuple(int(s) for s in shape)
    if len(shape) != 3:
        raise ValueError(f"volume in {str(path)!r} must be a 3-D array (X, Y, Z), got shape {shape}")
    if dtype not in _DTYPES:
        raise ValueError(f"volume in {str(path)!r} must have dtype {_DTYPE_NAMES}, got {dtype}")
    n = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if not mapped and n > MAX_VOLUME_BYTES:
        raise ValueError(f"volume in {str(path)!r} declares shape {shape} ({n} bytes), more than the "
                         f"{MAX_VOLUME_BYTES} bytes load_volume reads into memory")


def _npy_header(p: Path) -> tuple[tuple, np.dtype, int]:
    """(shape, dtype, data offset) of a ``.npy`` file, reading its header only."""
    try:
        with open(p, "rb") as fh:
            version = np.lib.format.read_magic(fh)
            read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                    else np.lib.format.read_array_header_2_0)
            shape, _fortran, dtype = read(fh, max_header_size=10_000)
            return shape, dtype, fh.tell()
    except (OSError, EOFError, ValueError, SyntaxError, tokenize.TokenError) as exc:   # numpy tokenizes bad headers
        raise ValueError(f"could not read {str(p)!r} as .npy: {exc}") from None


def _native(vol: np.ndarray, path) -> np.ndarray:
    """``vol`` in native byte order: a big-endian memory map or ``.npy`` (ImageJ writes big-endian TIFF) is
    read into memory swapped, under the :data:`MAX_VOLUME_BYTES` cap."""
    if vol.dtype.isnative:
        return vol
    if vol.nbytes > MAX_VOLUME_BYTES:
        raise ValueError(f"volume in {str(path)!r} is stored {vol.dtype.str} ({vol.nbytes} bytes): swapping it to "
                         f"the native byte order needs more than the {MAX_VOLUME_BYTES} bytes load_volume reads "
                         f"into memory")
    return vol.astype(vol.dtype.newbyteorder("="))


def _check_volume(name: str, vol) -> np.ndarray:
    """``vol`` as a native-order (X, Y, Z) ndarray of a volume dtype; float volumes must be finite (checked slab
    by slab, so a memory map is read once and never copied)."""
    return _checked(name, vol)[0]


def _checked(name: str, vol, *, want_range: bool = False):
    """:func:`_check_volume` plus, for float volumes or when ``want_range``, the data's (min, max) as floats
    (one slab-wise pass finds both and any non-finite value); ``(vol, None)`` otherwise."""
    if not isinstance(vol, np.ndarray):
        vol = np.asarray(vol)
    if vol.dtype.kind in "uif" and not vol.dtype.isnative:
        vol = _native(vol, name)                  # '>u2' is uint16 in the other byte order, not another dtype
    if vol.ndim != 3:
        raise ValueError(f"{name} must be a 3-D array (X, Y, Z), got shape {vol.shape}")
    if vol.dtype not in _DTYPES:
        raise ValueError(f"{name} must have dtype {_DTYPE_NAMES}, got {vol.dtype}")
    if min(vol.shape) < 2:
        raise ValueError(f"{name} must be at least 2 voxels along every axis, got shape {vol.shape}")
    if not (want_range or vol.dtype.kind == "f"):
        return vol, None
    step = max(1, _SLAB_BYTES // max(1, vol.shape[1] * vol.shape[2] * vol.dtype.itemsize))
    lo, hi = np.inf, -np.inf
    for i in range(0, vol.shape[0], step):
        blk = np.asarray(vol[i:i + step])
        a, b = float(blk.min()), float(blk.max())          # NaN and +-inf show in the extremes
        if not (np.isfinite(a) and np.isfinite(b)):
            bad = blk[~np.isfinite(blk)].ravel()[0]
            raise ValueError(f"{name} must hold finite values only, got {bad} in planes [{i}, "
                             f"{min(i + step, vol.shape[0])}) of axis 0")
        lo, hi = min(lo, a), max(hi, b)
    return vol, (lo, hi)


def _data_range(name: str, vol) -> tuple[np.ndarray, float, float]:
    """The checked volume and its data (min, max) in one slab-wise pass."""
    vol, (lo, hi) = _checked(name, vol, want_range=True)
    return vol, lo, hi


def save_volume(path: str | os.PathLike, volume: np.ndarray) -> None:
    """Write a volume as a multi-page TIFF (``.tif``), ``.npy`` or ``.npz`` (key ``"volume"``)."""
    volume = _check_volume("volume", volume)
    p = Path(path)
    suffix = check_choice("path suffix", p.suffix.lower(), (".tif", ".tiff", ".npy", ".npz"))
    with atomic_write(p) as fh:                    # a failed write leaves the old file, no leftovers
        if suffix in (".tif", ".tiff"):
            import tifffile
            tifffile.imwrite(_Unnamed(fh), np.ascontiguousarray(volume))
        elif suffix == ".npy":
            np.save(fh, volume)
        else:
            np.savez_compressed(fh, volume=volume)


class _Unnamed:
    """A file object without ``name`` (tifffile takes the temporary file's integer name for a path)."""

    def __init__(self, fh):
        self._fh = fh

    def __getattr__(self, k):
        if k == "name":
            raise AttributeError(k)
        return getattr(self._fh, k)


def downsample2(volume: np.ndarray, *, method: str = "mean", slab: int = 32) -> np.ndarray:
    """Downsample a volume by 2 along each axis with a 2x2x2 block mean or max, slab by slab.

    Parameters
    ----------
    volume : (X, Y, Z) uint8/16/32, int8/16/32 or float32/64 ndarray
        May be a memory map; odd trailing planes are dropped.
    method : {"mean", "max"}
        Block reduction. ``"mean"`` rounds half up for integer volumes (exact integer sums) and is the float64
        mean rounded to the dtype for float volumes.
    slab : int
        Output planes computed at a time (bounds the temporary memory), in [1, 4096].

    Returns
    -------
    (X//2, Y//2, Z//2) ndarray of the input dtype

    References
    ----------
    .. [1] Spec 000_vine §1.5 step 2: the gerbera was downsampled by 2 along each axis [T Ch. 4].
    """
    volume = _check_volume("volume", volume)
    method = check_choice("method", method, ("mean", "max"))
    slab = check_int("slab", slab, 1, 4096)
    nx, ny, nz = (s // 2 for s in volume.shape)
    out = np.empty((nx, ny, nz), volume.dtype)
    kind = volume.dtype.kind
    acc = np.uint32 if volume.dtype in _NARROW else (np.uint64 if kind == "u" else np.int64)
    for i in range(0, nx, slab):
        j = min(i + slab, nx)
        blk = np.asarray(volume[2 * i:2 * j, :2 * ny, :2 * nz])
        b = blk.reshape(j - i, 2, ny, 2, nz, 2)
        if method == "max":
            out[i:j] = b.max(axis=(1, 3, 5))
        elif kind == "f":
            out[i:j] = b.mean(axis=(1, 3, 5), dtype=np.float64)
        else:
            s = b.sum(axis=(1, 3, 5), dtype=acc)
            out[i:j] = ((s + 4) // 8).astype(volume.dtype)          # floor division: half up for negatives too
    return out


def histogram(volume: np.ndarray, *, bins: int = 256, slab: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Intensity histogram for choosing the iso-value, computed slab by slab.

    Parameters
    ----------
    volume : (X, Y, Z) uint8/16/32, int8/16/32 or float32/64 ndarray
    bins : int
        Number of bins, in [2, 65536]: over the dtype's range ``[0, max + 1)`` for uint8/uint16, over the data's
        range in its own units for every other dtype (``[min, max + 1)`` for integers, ``[min, max]`` for
        floats, as :func:`numpy.histogram`; ``[v - 0.5, v + 0.5]`` when every voxel is ``v``).
    slab : int
        Planes per pass, in [1, 4096].

    Returns
    -------
    counts : (bins,) int64 ndarray
    edges : (bins + 1,) float64 ndarray
    """
    volume = _check_volume("volume", volume)
    bins = check_int("bins", bins, 2, 65536)
    slab = check_int("slab", slab, 1, 4096)
    counts = np.zeros(bins, np.int64)
    if volume.dtype not in _NARROW:
        volume, lo, hi = _data_range("volume", volume)
        if volume.dtype.kind in "iu":
            hi += 1.0
        elif lo == hi:
            lo, hi = lo - 0.5, hi + 0.5
        for i in range(0, volume.shape[0], slab):          # uniform bins: numpy's fast path, same edges per slab
            counts += np.histogram(np.asarray(volume[i:i + slab]), bins=bins, range=(lo, hi))[0]
        return counts, np.histogram_bin_edges(np.zeros(1), bins=bins, range=(lo, hi))
    top = float(np.iinfo(volume.dtype).max) + 1
    edges = np.linspace(0.0, top, bins + 1)
    for i in range(0, volume.shape[0], slab):
        c = np.bincount(np.asarray(volume[i:i + slab]).ravel(), minlength=int(top))
        idx = np.minimum((np.arange(int(top)) * bins) // int(top), bins - 1)
        counts += np.bincount(idx, weights=c, minlength=bins).astype(np.int64)
    return counts, edges


def suggest_level(volume: np.ndarray, *, bins: int = 256) -> float:
    """A starting iso-value for the slider: Otsu's threshold of the slab-wise histogram, in the data's units.

    Parameters
    ----------
    volume : (X, Y, Z) uint8/16/32, int8/16/32 or float32/64 ndarray
    bins : int
        Histogram bins, in [2, 65536] (see :func:`histogram`).

    Returns
    -------
    float
        Integer volumes: Otsu threshold rounded down + 0.5, so that no voxel value equals the level (exact slab
        seams), kept strictly inside the data's range for dtypes other than uint8/uint16. Float volumes: the
        Otsu threshold itself.

    References
    ----------
    .. [1] Spec 000_vine §1.5 step 1/3: the thesis chose the iso-value by hand; this only seeds the choice.
    .. [2] Issue 22: float and signed volumes, the level in the data's own units.
    """
    from skimage.filters import threshold_otsu
    counts, edges = histogram(volume, bins=bins)
    if np.count_nonzero(counts) < 2:
        raise ValueError("volume is constant (all voxels in one histogram bin): no iso-value separates it")
    centres = 0.5 * (edges[:-1] + edges[1:])
    t = float(threshold_otsu(hist=(counts, centres)))
    dtype = np.asarray(volume).dtype                         # histogram checked it (no copy of an ndarray)
    if dtype.kind == "f":
        return t
    level = float(np.floor(t)) + 0.5
    if dtype.newbyteorder("=") not in _NARROW:
        lo, hi = edges[0], edges[-1] - 1.0                   # the data's integer range
        level = min(max(level, lo + 0.5), hi - 0.5)
    return level
