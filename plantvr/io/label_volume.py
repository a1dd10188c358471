"""Label volumes written in the formats napari, 3D Slicer and ImageJ/Fiji open (issue 22 "Labels"; issue 32 "data
out exactly").

:func:`write_label_volume` picks the writer by suffix, each the format's own library. Every writer puts voxel
``index`` of the array at the same LPS world point ``geometry.index_to_world(index)``
(:class:`~plantvr.io.volume.VolumeGeometry`), so labels painted on a volume read by
:func:`~plantvr.io.volume.read_volume` and written with ``geometry=volume.geometry`` land on the source's voxels
in every format, whatever its axis order, flips and rotation:

==================  ==========  ===============================================================================
suffix              library     grid
==================  ==========  ===============================================================================
``.tif, .tiff``     tifffile    ImageJ hyperstack, pages along world Z, rows Y, columns X; ``resolution`` = 1 /
                                the X and Y spacing, ``spacing`` = Z, ``xorigin/yorigin/zorigin`` in pixels
                                (ImageJ's calibration: world = (pixel - xorigin) * pixelWidth). The reader's
                                Z, Y, X order comes back as it was; axes flipped against the world are
                                reversed; a rotated geometry is refused (ImageJ has no direction)
``.nrrd``           pynrrd      ``space`` left-posterior-superior, ``space directions`` = direction * spacing,
                                ``space origin``, data in the array's own axis order, gzip
``.nii, .nii.gz``   nibabel     NIfTI-1, qform and sform = the RAS affine of the geometry (code 1: scanner),
                                data in the array's own axis order
``.mha, .mhd``      SimpleITK   ``TransformMatrix``/``Offset``/``ElementSpacing`` of the geometry, data in
                                the array's own axis order (ITK axis 0 = the array's last)
==================  ==========  ===============================================================================

Without ``geometry``, ``spacing`` and ``origin`` describe an (X, Y, Z) array: voxel ``(i, j, k)`` is at
``origin + (i, j, k) * spacing`` in each file's own coordinates (NIfTI's affine, NRRD's space directions with no
named space), the convention of :func:`plantvr.vine.label_volumes.labels_to_volume`.
Writes are atomic (a temporary file beside ``path``, renamed over it), so a failed write leaves the previous
file as it was; the folder must exist (:func:`plantvr._fileio.check_target`).
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
LABEL_VOLUME_SUFFIXES = (".tif", ".tiff", ".nrrd", ".nii", ".nii.gz", ".mha", ".mhd")

#: LPS <-> RAS (NIfTI's world frame): x and y flip.
_RAS = np.array([-1.0, -1.0, 1.0])


def _suffix(path: Path) -> str:
    name = path.name.lower()
    for s in sorted(LABEL_VOLUME_SUFFIXES, key=len, reverse=True):
        if name.endswith(s):
            return s
    raise ValueError(f"path must end in one of {list(LABEL_VOLUME_SUFFIXES)}, got {os.fspath(path)!r}")


def _imagej_grid(vol: np.ndarray, g) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``vol`` as (Z, Y, X) world-aligned pages with positive steps, its (z, y, x) spacing and world origin.

    An array axis running against its world axis is reversed (voxel 0 then sits at the other end), so the same
    voxels keep the same world points; a direction that is not a signed axis permutation is refused.
    """
    d = g.direction
    world_axis = np.argmax(np.abs(d), axis=1)
    sign = np.sign(d[np.arange(3), world_axis])
    if sorted(world_axis) != [0, 1, 2] or not np.allclose(np.abs(d), np.eye(3)[world_axis], atol=1e-9):
        raise ValueError(f"geometry is rotated against the world axes (direction {np.round(d, 6).tolist()}): an "
                         f"ImageJ TIFF has no direction, so write .nrrd, .nii or .mha to keep the labels on "
                         f"their physical points")
    o = np.array(g.origin, np.float64)
    for a in range(3):
        if sign[a] < 0:
            vol = np.flip(vol, axis=a)
            o = o + d[a] * g.spacing[a] * (vol.shape[a] - 1)     # the new voxel 0 is the old last one
    order = [int(np.flatnonzero(world_axis == w)[0]) for w in (2, 1, 0)]     # array axes along world z, y, x
    return np.ascontiguousarray(vol.transpose(order)), g.spacing[order], o[[2, 1, 0]]


def _imagej_unit(unit) -> str | None:
    u = str(unit or "").strip().lower()
    return {"µm": "micron", "um": "micron", "micron": "micron", "micrometer": "micron", "mm": "mm",
            "nm": "nm", "cm": "cm", "m": "m"}.get(u)


def _write_tiff(tmp: str, vol: np.ndarray, g, unit: str | None, lps: bool) -> None:
    import tifffile
    zyx, s, o = _imagej_grid(vol, g)              # s, o: (z, y, x)
    meta = {"axes": "ZYX", "spacing": float(s[0]), "xorigin": float(-o[2] / s[2]),
            "yorigin": float(-o[1] / s[1]), "zorigin": float(-o[0] / s[0])}
    u = _imagej_unit(unit)
    if u:
        meta["unit"] = u
    tifffile.imwrite(tmp, zyx, imagej=True, resolution=(1.0 / s[2], 1.0 / s[1]), metadata=meta)


def _write_nrrd(tmp: str, vol: np.ndarray, g, unit: str | None, lps: bool) -> None:
    import nrrd
    header = {"space directions": g.direction * g.spacing[:, None], "space origin": np.asarray(g.origin, np.float64),
              "kinds": ["domain", "domain", "domain"], "encoding": "gzip"}
    if lps:
        header["space"] = "left-posterior-superior"
    else:                                          # spacing/origin alone: coordinates in no named frame
        header["space dimension"] = 3
    if unit:
        header["space units"] = [str(unit)] * 3
    nrrd.write(tmp, np.asfortranarray(vol), header, index_order="F")


def _write_nifti(tmp: str, vol: np.ndarray, g, unit: str | None, lps: bool) -> None:
    import nibabel as nib
    affine = g.affine
    if lps:
        affine[:3, :] *= _RAS[:, None]             # LPS -> RAS rows (x, y flip)
    img = nib.Nifti1Image(np.asanyarray(vol), affine)
    img.set_qform(affine, code=1)
    img.set_sform(affine, code=1)
    u = _imagej_unit(unit)
    img.header.set_xyzt_units({"micron": "micron", "mm": "mm", "m": "meter"}.get(u, "unknown"))
    nib.save(img, tmp)


def _write_metaimage(tmp: str, vol: np.ndarray, g, unit: str | None, lps: bool) -> None:
    import SimpleITK as sitk
    img = sitk.GetImageFromArray(np.ascontiguousarray(vol), isVector=False)    # ITK axis 0 = array axis 2
    img.SetSpacing([float(x) for x in g.spacing[::-1]])
    img.SetOrigin([float(x) for x in g.origin])
    img.SetDirection([float(x) for x in g.direction[::-1].T.ravel()])          # columns: ITK axes' directions
    sitk.WriteImage(img, tmp, True)


_WRITERS = {".tif": _write_tiff, ".tiff": _write_tiff, ".nrrd": _write_nrrd, ".nii": _write_nifti,
            ".nii.gz": _write_nifti, ".mha": _write_metaimage, ".mhd": _write_metaimage}


def _check_geometry(geometry, shape):
    from plantvr.io.volume import Volume, VolumeGeometry
    g = geometry.geometry if isinstance(geometry, Volume) else geometry
    if not isinstance(g, VolumeGeometry):
        raise ValueError(f"geometry must be a VolumeGeometry or a Volume (read_volume's), got "
                         f"{type(geometry).__name__}")
    if tuple(g.shape) != tuple(shape):
        raise ValueError(f"geometry is for a volume of shape {tuple(g.shape)}, but volume has shape {tuple(shape)} "
                         f"(labels must be on the source's own grid, in its axis order)")
    s = check_array("geometry.spacing", g.spacing, shape=(3,), dtype=np.float64)
    if np.any(s <= 0) or np.any(s > 1e6):
        raise ValueError(f"geometry.spacing must be 3 values in (0, 1e6], got {s.tolist()}")
    check_array("geometry.origin", g.origin, shape=(3,), dtype=np.float64, max_abs=1e12)
    d = check_array("geometry.direction", g.direction, shape=(3, 3), dtype=np.float64, max_abs=1.0 + 1e-6)
    if not np.allclose(d @ d.T, np.eye(3), atol=1e-6):
        raise ValueError(f"geometry.direction must be orthonormal (rows: unit axis directions), got "
                         f"{np.round(d, 6).tolist()}")
    return g


def write_label_volume(path: str | os.PathLike, volume: np.ndarray, *, spacing=None, origin=None,
                       geometry=None) -> Path:
    """Write a label volume in the format its suffix names (``.tif``, ``.nrrd``, ``.nii``, ``.nii.gz``, ``.mha``,
    ``.mhd``), each voxel at its physical point.

    Parameters
    ----------
    path : path-like
        Target file; its folder must exist.
    volume : (A0, A1, A2) uint8 or uint16 ndarray
        Labels (0 = background) on the source's grid, in its axis order (e.g. from
        :func:`plantvr.vine.label_volumes.labels_to_volume` with the source's shape, spacing and origin).
    spacing : (3,) float, optional
        Without ``geometry``: voxel size along X, Y, Z = array axes 0, 1, 2, each in (0, 1e6] (default 1).
    origin : (3,) float, optional
        Without ``geometry``: world position of voxel (0, 0, 0)'s centre (default 0).
    geometry : VolumeGeometry or Volume, optional
        The source's geometry (``read_volume(...).geometry``, or the Volume itself): shape, axis order,
        spacing, origin and direction. Refused together with ``spacing``/``origin``.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    ValueError
        Naming the parameter: a bad suffix, volume, spacing, origin or geometry (another shape, a non-orthonormal
        direction; for TIFF a rotated one), a missing folder.
    """
    p = Path(os.fspath(path)) if isinstance(path, (str, os.PathLike)) else None
    if p is None:
        raise ValueError(f"path must be a file path, got {type(path).__name__}")
    suffix = _suffix(p)
    if not isinstance(volume, np.ndarray) or volume.ndim != 3 or volume.dtype not in (np.uint8, np.uint16) \
            or min(volume.shape) < 1:
        raise ValueError("volume must be a non-empty 3-D uint8 or uint16 ndarray, got "
                         + (f"{volume.dtype} {volume.shape}" if isinstance(volume, np.ndarray)
                            else type(volume).__name__))
    from plantvr.io.volume import VolumeGeometry
    if geometry is not None:
        if spacing is not None or origin is not None:
            raise ValueError("pass either geometry (the source's) or spacing/origin, not both: geometry already "
                             "holds the spacing and origin")
        g = _check_geometry(geometry, volume.shape)
        unit, lps = g.unit, True
    else:
        s = check_array("spacing", (1.0, 1.0, 1.0) if spacing is None else spacing, shape=(3,), dtype=np.float64)
        if np.any(s <= 0) or np.any(s > 1e6):
            raise ValueError(f"spacing must be 3 values in (0, 1e6], got {s.tolist()}")
        o = check_array("origin", (0.0, 0.0, 0.0) if origin is None else origin, shape=(3,), dtype=np.float64,
                        max_abs=1e12)
        g = VolumeGeometry.from_grid(volume.shape, s, o, axes="xyz")
        unit, lps = "micron", False
    if suffix in (".tif", ".tiff"):
        _imagej_grid(volume[:1, :1, :1], g)         # a rotated geometry is refused before anything is written
    folder = check_target(p)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=suffix, dir=folder)
    os.close(fd)
    try:
        _WRITERS[suffix](tmp, volume, g, unit, lps)
        if suffix == ".mhd":                     # the .mhd names its data file: rename both
            raw = Path(tmp).with_suffix(".raw") if Path(tmp).with_suffix(".raw").exists() else \
                Path(tmp).with_suffix(".zraw")
            target_raw = p.with_name(p.name[:-4] + raw.suffix)
            text = Path(tmp).read_text(encoding="latin-1").replace(raw.name, target_raw.name)
            Path(tmp).write_text(text, encoding="latin-1")
            os.replace(raw, target_raw)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if suffix == ".mhd":
            for ext in (".raw", ".zraw"):
                with contextlib.suppress(OSError):
                    os.unlink(Path(tmp).with_suffix(ext))
        raise
    return p
