"""Label volumes written in the formats napari, 3D Slicer and ImageJ/Fiji open (issue 22 "Labels").

:func:`write_label_volume` picks the writer by suffix, each the format's own library:

==================  ==========  ===============================================================================
suffix              library     grid
==================  ==========  ===============================================================================
``.tif, .tiff``     tifffile    ImageJ hyperstack, pages = axis 2 (ZYX), ``resolution`` = 1 / spacing of axes 0
                                and 1, ``spacing`` = axis 2, ``xorigin/yorigin/zorigin`` in pixels (ImageJ's
                                calibration: world = (pixel - xorigin) * pixelWidth)
``.nrrd``           pynrrd      ``space directions`` = diag(spacing), ``space origin`` = origin, data in
                                Fortran index order (axis 0 fastest), gzip
``.nii, .nii.gz``   nibabel     NIfTI-1, affine = diag(spacing) with origin (sform and qform)
==================  ==========  ===============================================================================

Voxel ``(i, j, k)`` of the array is at ``origin + (i, j, k) * spacing`` in every format, the convention of
:func:`plantvr.vine.label_volumes.labels_to_volume`. Writes are atomic (a temporary file beside ``path``,
renamed over it), so a failed write leaves the previous file as it was.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np

from plantvr._fileio import check_target
from plantvr._validation import check_array

__all__ = ["LABEL_VOLUME_SUFFIXES", "write_label_volume"]

#: Suffixes :func:`write_label_volume` writes.
LABEL_VOLUME_SUFFIXES = (".tif", ".tiff", ".nrrd", ".nii", ".nii.gz")


def _suffix(path: Path) -> str:
    name = path.name.lower()
    for s in sorted(LABEL_VOLUME_SUFFIXES, key=len, reverse=True):
        if name.endswith(s):
            return s
    raise ValueError(f"path must end in one of {list(LABEL_VOLUME_SUFFIXES)}, got {os.fspath(path)!r}")


def _write_tiff(tmp: str, vol: np.ndarray, s: np.ndarray, o: np.ndarray) -> None:
    import tifffile
    tifffile.imwrite(tmp, np.ascontiguousarray(vol.transpose(2, 1, 0)), imagej=True,
                     resolution=(1.0 / s[0], 1.0 / s[1]),
                     metadata={"axes": "ZYX", "spacing": float(s[2]), "unit": "micron",
                               "xorigin": float(-o[0] / s[0]), "yorigin": float(-o[1] / s[1]),
                               "zorigin": float(-o[2] / s[2])})


def _write_nrrd(tmp: str, vol: np.ndarray, s: np.ndarray, o: np.ndarray) -> None:
    import nrrd
    header = {"space dimension": 3, "space directions": np.diag(s), "space origin": o,
              "kinds": ["domain", "domain", "domain"], "encoding": "gzip"}
    nrrd.write(tmp, np.asfortranarray(vol), header, index_order="F")


def _write_nifti(tmp: str, vol: np.ndarray, s: np.ndarray, o: np.ndarray) -> None:
    import nibabel as nib
    affine = np.eye(4)
    affine[:3, :3] = np.diag(s)
    affine[:3, 3] = o
    img = nib.Nifti1Image(np.asanyarray(vol), affine)
    img.set_qform(affine, code=1)
    img.set_sform(affine, code=1)
    img.header.set_xyzt_units("micron")
    nib.save(img, tmp)


_WRITERS = {".tif": _write_tiff, ".tiff": _write_tiff, ".nrrd": _write_nrrd, ".nii": _write_nifti,
            ".nii.gz": _write_nifti}


def write_label_volume(path: str | os.PathLike, volume: np.ndarray, *, spacing=(1.0, 1.0, 1.0),
                       origin=(0.0, 0.0, 0.0)) -> Path:
    """Write a label volume in the format its suffix names (``.tif``, ``.nrrd``, ``.nii``, ``.nii.gz``).

    Parameters
    ----------
    path : path-like
        Target file; its folder must exist.
    volume : (X, Y, Z) uint8 or uint16 ndarray
        Labels (0 = background), e.g. from :func:`plantvr.vine.label_volumes.labels_to_volume`.
    spacing : (3,) float
        Voxel size along each axis, each in (0, 1e6].
    origin : (3,) float
        World position of voxel (0, 0, 0)'s centre.

    Returns
    -------
    Path
        The path written.
    """
    p = Path(os.fspath(path))
    suffix = _suffix(p)
    if not isinstance(volume, np.ndarray) or volume.ndim != 3 or volume.dtype not in (np.uint8, np.uint16) \
            or min(volume.shape) < 1:
        raise ValueError("volume must be a non-empty 3-D uint8 or uint16 ndarray, got "
                         + (f"{volume.dtype} {volume.shape}" if isinstance(volume, np.ndarray)
                            else type(volume).__name__))
    s = check_array("spacing", spacing, shape=(3,), dtype=np.float64)
    if np.any(s <= 0) or np.any(s > 1e6):
        raise ValueError(f"spacing must be 3 values in (0, 1e6], got {s.tolist()}")
    o = check_array("origin", origin, shape=(3,), dtype=np.float64, max_abs=1e12)
    folder = check_target(p)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=suffix, dir=folder)
    os.close(fd)
    try:
        _WRITERS[suffix](tmp, volume, s, o)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return p
