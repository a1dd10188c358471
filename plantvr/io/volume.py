"""Volume readers on the field's own libraries (issue 22 "Volume readers"; spec 000_vine §1.4).

:func:`read_volume` opens the image stacks researchers already have and returns a :class:`Volume`: the voxel
array as stored (native byte order; float, signed and 8/16/32/64-bit integer data are returned as they are,
never rescaled), the voxel spacing and origin in the file's physical units, in the array's own axis order,
and the file's metadata.

=================================  ==================  =================================================
suffix                             library             spacing / origin from
=================================  ==================  =================================================
``.tif`` ``.tiff`` (or a folder    tifffile            ImageJ ``spacing`` + X/YResolution tags; OME
of 2-D slices in natural order,                        ``PhysicalSize{X,Y,Z}``; plain: resolution tags
or a list of slice files)
``.nrrd`` ``.nhdr``                pynrrd              ``space directions`` / ``spacings``, ``space origin``
``.nii`` ``.nii.gz``               nibabel             the affine (zooms, translation)
``.mgh`` ``.mgz``                  nibabel             FreeSurfer MGH: the vox2ras affine
``.mnc``                           nibabel             MINC 1 (netCDF) and MINC 2 (HDF5): the affine from
                                                       each dimension's ``step``, ``start``, cosines
``.mha`` ``.mhd``                  SimpleITK           ``ElementSpacing``, ``Offset``, ``TransformMatrix``
``.vti``                           VTK (via pyvista)   ``Spacing``, ``Origin``, ``Direction``; a cell-data
                                                       array lies on the cell centres (origin + half a voxel)
``.h5`` ``.hdf5``                  h5py                the ``element_size_um`` attribute if present
``.zarr`` (folder)                 zarr (+ dask)       OME-Zarr multiscales level 0: its ``scale`` and
                                                       ``translation`` coordinate transformations
a folder of DICOM slices           pydicom             ``PixelSpacing``, slice positions,
                                                       ``ImagePositionPatient`` (sorted along the normal)
``.npy`` ``.npz``                  numpy               (none: spacing 1, origin 0)
=================================  ==================  =================================================

Axis order is each library's own: (Z, Y, X) for TIFF, MetaImage, HDF5, Zarr and DICOM; (X, Y, Z) for NRRD,
NIfTI, MGH and .vti; MINC's as its dimensions are stored (usually Z, Y, X), named from the affine.
Compressed TIFF (LZW, deflate with or without the horizontal predictor, ...) is decoded by imagecodecs. MINC
voxels come scaled to their real values by nibabel (MINC scales each slice by its own image-min/max), as float. ``Volume.meta["axes"]`` names them. ``origin[k]`` is the position of voxel 0 along array
axis ``k``'s direction, so ``index * spacing + origin`` is the physical coordinate along each axis; where the
file's axes are rotated against its world frame, ``meta["direction"]`` (3, 3) holds the unit world direction
of each array axis (rows), and ``world = direction.T @ (index * spacing + origin)``.

``Volume.geometry`` (:class:`VolumeGeometry`) is that mapping as one record in LPS world coordinates (NIfTI's RAS
and NRRD's RAS/LAS flipped; SimpleITK's convention), carried unchanged to
:func:`plantvr.io.label_volume.write_label_volume`, which puts labels on the source's own voxels in every label
format (issue 32). ``channel=`` and ``time=`` pick one channel (or RGB sample) and one time point of 4-D/5-D and
RGB volumes. Whatever a library raises on a damaged file comes out as one ``ValueError`` naming the file
(issue 34), and a parameter that does not apply to the format is refused by name.

This module reads only; it sits in the io layer (the numeric cores never import it).
"""
from __future__ import annotations

import contextlib
import logging
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._validation import MAX_COUNT
from plantvr.vine.volume import MAX_VOLUME_BYTES, natural_key

__all__ = ["MAX_LAZY_VOXELS", "SUFFIXES", "Volume", "VolumeGeometry", "load_volume", "read_volume"]

#: File suffixes :func:`read_volume` reads (``.zarr`` is a folder; any other folder is a TIFF slice stack or a
#: DICOM series).
SUFFIXES = (".tif", ".tiff", ".nrrd", ".nhdr", ".nii", ".nii.gz", ".mgh", ".mgz", ".mnc", ".mha", ".mhd",
            ".vti", ".h5", ".hdf5", ".zarr", ".npy", ".npz")

#: Largest voxel count a lazy (dask) read accepts; eager reads are capped at
#: :data:`plantvr.vine.volume.MAX_VOLUME_BYTES` bytes, and every axis at :data:`plantvr._validation.MAX_COUNT`.
MAX_LAZY_VOXELS = 2 ** 40

_LAZY = ("Zarr", "TIFF")


@dataclass(frozen=True, eq=False)
class Volume:
    """A 3-D image read from a file.

    Attributes
    ----------
    array : (A0, A1, A2) ndarray or dask array
        The voxels as stored (native byte order, no rescaling); a dask array when read with ``lazy=True``.
    spacing : (3,) float64 ndarray
        Voxel size along each array axis, in the file's physical units (``meta["unit"]`` where the file names
        one), finite and > 0.
    origin : (3,) float64 ndarray
        Position of voxel 0 along each array axis, same units.
    meta : dict
        ``axes`` (e.g. ``"zyx"``), ``format``, and what the file declares (ImageJ/OME metadata, NRRD header,
        NIfTI affine and scaling, DICOM rescale slope/intercept, ...).
    source : str
        The path read.
    format : str
        ``"TIFF"``, ``"NRRD"``, ``"NIfTI"``, ``"MGH"``, ``"MINC"``, ``"MetaImage"``, ``"VTI"``, ``"HDF5"``,
        ``"Zarr"``, ``"DICOM"`` or ``"NumPy"``.
    geometry : VolumeGeometry
        Where every voxel is, in LPS world coordinates (shape, axis order, spacing, origin, direction): pass it
        to :func:`plantvr.io.label_volume.write_label_volume` so that labels land on the same physical points.
    """

    array: Any
    spacing: np.ndarray
    origin: np.ndarray
    meta: dict = field(default_factory=dict)
    source: str = ""
    format: str = ""
    geometry: VolumeGeometry | None = None

    def __post_init__(self):
        if self.geometry is None:
            object.__setattr__(self, "geometry", _geometry(self.array.shape, self.spacing, self.origin,
                                                           self.meta))

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(s) for s in self.array.shape)

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(self.array.dtype)

    def to_physical(self, index: np.ndarray) -> np.ndarray:
        """(N, 3) float voxel indices (array axis order, e.g. isosurface vertices) -> (N, 3) float64
        physical coordinates along the same axes: ``index * spacing + origin``."""
        return np.asarray(index, np.float64) * self.spacing + self.origin


@dataclass(frozen=True, eq=False)
class VolumeGeometry:
    """One volume's voxel-to-world mapping, carried unchanged from :func:`read_volume` to every label writer
    (issue 32).

    ``world = origin + (index * spacing) @ direction`` for an (N, 3) ``index`` in the array's own axis order:
    row ``k`` of ``direction`` is the unit world direction of array axis ``k``. World coordinates are LPS
    (ITK, DICOM, SimpleITK, 3D Slicer files): NIfTI's RAS and NRRD's RAS/LAS spaces are flipped to it on
    reading and back on writing. Formats without a direction (TIFF, HDF5, Zarr, NumPy) map each array axis to the
    world axis its letter names (a Z, Y, X TIFF: rows ``(0, 0, 1)``, ``(0, 1, 0)``, ``(1, 0, 0)``).

    Attributes
    ----------
    shape : tuple of 3 int
    spacing : (3,) float64 ndarray
        Voxel size along each array axis (> 0).
    origin : (3,) float64 ndarray
        LPS world position of voxel (0, 0, 0)'s centre.
    direction : (3, 3) float64 ndarray
        Rows: LPS unit direction of each array axis.
    axes : str
        The array's axis letters (``"zyx"``, ``"xyz"``).
    unit : str or None
        The length unit the file names, if any.
    """

    shape: tuple
    spacing: np.ndarray
    origin: np.ndarray
    direction: np.ndarray
    axes: str = "xyz"
    unit: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "shape", tuple(int(n) for n in self.shape))
        for name, shape in (("spacing", (3,)), ("origin", (3,)), ("direction", (3, 3))):
            a = np.array(getattr(self, name), np.float64).reshape(shape)     # an own, read-only copy
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @classmethod
    def from_grid(cls, shape, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), *, axes: str = "xyz",
                  unit: str | None = None) -> VolumeGeometry:
        """Axis-aligned geometry: array axis ``k`` runs along the world axis ``axes[k]`` names; ``origin`` is the
        position of voxel 0 along each array axis (the convention of ``Volume.origin`` and
        :func:`plantvr.vine.label_volumes.labels_to_volume`)."""
        d = _axis_permutation(axes)
        s = np.asarray(spacing, np.float64).reshape(3)
        o = np.asarray(origin, np.float64).reshape(3)
        return cls(tuple(int(n) for n in shape), s, d.T @ o, d, axes, unit)

    def index_to_world(self, index) -> np.ndarray:
        """(N, 3) voxel indices (array axis order, fractional allowed) -> (N, 3) LPS world points."""
        return self.origin + (np.asarray(index, np.float64) * self.spacing) @ self.direction

    def world_to_index(self, world) -> np.ndarray:
        """(N, 3) LPS world points -> (N, 3) fractional voxel indices in the array's axis order."""
        rel = np.asarray(world, np.float64) - self.origin
        return np.linalg.solve(self.direction.T, rel.T).T / self.spacing

    @property
    def affine(self) -> np.ndarray:
        """(4, 4) LPS voxel-to-world affine (columns: ``direction[k] * spacing[k]``, then the origin)."""
        a = np.eye(4)
        a[:3, :3] = (self.direction * self.spacing[:, None]).T
        a[:3, 3] = self.origin
        return a


def _axis_permutation(axes: str) -> np.ndarray:
    """Rows: the unit world axis each array axis letter names (x, y, z); unnamed axes keep Z, Y, X order."""
    letters = [a for a in axes.lower()]
    if sorted(letters) != ["x", "y", "z"]:
        letters = ["z", "y", "x"] if len(letters) == 3 else ["x", "y", "z"]
    return np.stack([np.eye(3)["xyz".index(a)] for a in letters])


def _geometry(shape, spacing, origin, meta: dict) -> VolumeGeometry:
    """The LPS geometry of a volume read from a file (see :class:`VolumeGeometry`)."""
    axes = str(meta.get("axes", "xyz"))
    unit = meta.get("unit")
    d = meta.get("direction")
    if d is None:
        return VolumeGeometry.from_grid(shape, spacing, origin, axes=axes, unit=unit)
    d = np.asarray(d, np.float64).reshape(3, 3)
    s = np.asarray(spacing, np.float64).reshape(3)
    o = meta.get("world_origin")
    o = d.T @ np.asarray(origin, np.float64) if o is None else np.asarray(o, np.float64).reshape(3)
    flip = _TO_LPS.get(meta.get("world_frame", "LPS"), np.ones(3))
    return VolumeGeometry(tuple(int(n) for n in shape), s, o * flip, d * flip, axes, unit)


def read_volume(path, *, dataset: str | None = None, lazy: bool = False, channel: int | None = None,
                time: int | None = None, mmap: bool = False) -> Volume:
    """Read a 3-D image stack with its spacing, origin and metadata, dispatching on the suffix.

    Parameters
    ----------
    path : str, path-like, or a list of them
        A file with one of :data:`SUFFIXES`, a ``.zarr`` folder (or any Zarr group folder, e.g. OME-Zarr
        ``labels/<name>``), a folder of 2-D TIFF slices (stacked in natural
        order: ``img_2.tif`` before ``img_10.tif``), a folder holding one DICOM series, or an explicit list of
        2-D TIFF slice files (stacked in the order given) or DICOM files (ordered by slice position).
    dataset : str, optional
        The array inside a container: the HDF5 dataset path, the Zarr array path (default: OME-Zarr
        multiscales level 0, else the only array), the ``.npz`` key, or the ``.vti`` point- or cell-data array
        name (a cell array's voxels are the cells, at their centres). Default: the only (or active) array.
    lazy : bool
        Return a dask array instead of reading the voxels (Zarr and TIFF only), for volumes bigger than memory.
        A chunk that cannot be decoded raises, when it is computed, a ``ValueError`` naming the file.
    mmap : bool
        Memory-map a ``.npy`` file or an uncompressed, native-byte-order TIFF instead of reading it (a
        ``numpy.memmap``; no size cap but the file's own length); other files are read as usual.
    channel : int, optional
        The channel (or RGB sample) to read from a multi-channel volume: an ImageJ/OME hyperstack's C axis, a
        TIFF's samples (RGB), a NRRD non-spatial axis, MetaImage vector components, a NIfTI 5th axis, an
        OME-Zarr channel axis, an HDF5 axis labelled ``c``; or an unlabelled 4th axis (HDF5, NumPy). Refused for a
        file with no such axis.
    time : int, optional
        The time point to read from a 4-D volume: a T axis (ImageJ, OME, OME-Zarr), a NIfTI 4th axis, a 4-D
        MetaImage's last axis, an HDF5 axis labelled ``t``; or an unlabelled 4th axis. Refused for a file with
        no such axis.

    Returns
    -------
    Volume

    Raises
    ------
    ValueError
        A missing path or unknown suffix; a file the library cannot read; a volume that is not 3-D after
        dropping singleton channel/time axes (the message names the axes), smaller than 2 voxels along an
        axis, of a non-numeric dtype (RGB, complex), bigger than :data:`~plantvr.vine.volume.MAX_VOLUME_BYTES`
        (eager) or :data:`MAX_LAZY_VOXELS` (lazy), or with a spacing that is not finite and > 0. Every size is
        checked from the header before the voxels are read.

    References
    ----------
    .. [1] Issue 22, "Volume readers": TIFF (ImageJ, OME, both byte orders), NRRD, NIfTI, MetaImage, .vti,
       HDF5, Zarr/OME-Zarr (lazy), DICOM series.
    """
    files = None
    if isinstance(path, (list, tuple)):
        files = _file_list(path)
        path = files[0]
    elif not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a file or folder path (or a list of slice files), got "  # noqa: TRY004
                         f"{type(path).__name__}")
    pick = {"channel": channel, "time": time}
    for name, v in pick.items():
        if v is not None and (isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v < 0):
            raise ValueError(f"{name} must be an integer >= 0 (an index along the file's {name} axis) or None, "
                             f"got {v!r}")
    if dataset is not None and not isinstance(dataset, str):
        raise ValueError(f"dataset must be a string (an array path or name) or None, got {dataset!r}")
    if not isinstance(lazy, (bool, np.bool_)):
        raise ValueError(f"lazy must be True or False, got {lazy!r}")
    if not isinstance(mmap, (bool, np.bool_)):
        raise ValueError(f"mmap must be True or False, got {mmap!r}")
    if mmap and lazy:
        raise ValueError("pass lazy=True (a dask array) or mmap=True (a memory map), not both")
    p = Path(path)
    if not p.exists():
        raise ValueError(f"path does not exist: {str(p)!r}")
    suffix = _suffix(p)
    if files is not None:
        kind = "TIFF" if suffix in (".tif", ".tiff") else "DICOM"
    elif p.is_dir() and suffix != ".zarr" and not any((p / m).is_file() for m in _ZARR_MARKERS):
        kind = "TIFF" if any(f.suffix.lower() in (".tif", ".tiff") for f in p.iterdir()) else "DICOM"
    elif p.is_dir() or suffix == ".zarr":
        kind = "Zarr"
    else:
        kind = _KINDS.get(suffix)
        if kind is None:
            raise ValueError(f"path must end in one of {', '.join(SUFFIXES)} (or be a folder of TIFF or DICOM "
                             f"slices), got {str(p)!r}")
    if lazy and kind not in _LAZY:
        raise ValueError(f"lazy=True reads {' and '.join(_LAZY)} volumes only, got a {kind} file {str(p)!r}")
    if dataset is not None and kind not in _DATASET_KINDS and suffix != ".npz":
        raise ValueError(f"dataset names an array inside an HDF5, Zarr, .npz or .vti file; a {kind} file holds "
                         f"one volume, so dataset={dataset!r} does not apply to {str(p)!r}")
    stack = files is not None or (p.is_dir() and kind in ("TIFF", "DICOM"))
    for name, v in pick.items():
        if v is not None and (kind in ("VTI", "DICOM") or stack):
            raise ValueError(f"{name}={v!r} does not apply to {str(p)!r}: a {kind} "
                             f"{'slice stack' if stack else 'file'} holds one 3-D volume (no {name} axis)")
    reader = _READERS[kind]
    kw = {"files": files} if kind in ("TIFF", "DICOM") else {}
    if kind in ("TIFF", "NumPy"):
        kw["mmap"] = bool(mmap)
    try:
        with _quiet_tifffile():
            array, spacing, origin, axes, meta = reader(p, dataset=dataset, lazy=bool(lazy), pick=pick, **kw)
    except MemoryError:
        raise ValueError(f"volume in {str(p)!r} does not fit in memory (read it with lazy=True: "
                         f"{', '.join(_LAZY)})") from None
    except Exception as exc:  # noqa: BLE001 - every library raises its own types on a corrupt file
        raise _read_error(p, kind, exc) from None
    return _finish(p, kind, array, spacing, origin, axes, meta)


#: Files that make a folder a Zarr group or array (v2, v3), whatever its name (an OME-Zarr labels group).
_ZARR_MARKERS = (".zgroup", ".zarray", ".zattrs", "zarr.json")

#: Formats whose files hold several arrays, one picked by ``dataset`` (and ``.npz``).
_DATASET_KINDS = ("HDF5", "Zarr", "VTI")


def _read_error(p: Path, kind: str, exc: BaseException) -> ValueError:
    """The error :func:`read_volume` raises for what a reader raised: this module's own door checks (a plain
    ``ValueError`` naming the path) as they are; anything a library raised (``tifffile.TiffFileError``, a
    ``ValueError`` subclass; pynrrd's ``NRRDError``; ``zlib.error``; ``KeyError``; ...) as one ``ValueError``
    naming the file, the format and what the library said (cut to 300 characters)."""
    if type(exc) is ValueError and str(p) in str(exc):
        return exc
    what = f"{type(exc).__name__}: {exc}"
    if len(what) > 300:
        what = what[:297] + "..."
    if "imagecodecs" in what:                     # tifffile decodes LZW, JPEG, ... with imagecodecs only
        what += " (pip install imagecodecs)"
    return ValueError(f"could not read {str(p)!r} as {kind}: {what}")


@contextlib.contextmanager
def _quiet_tifffile():
    """tifffile logs a warning for every damaged tag it skips; the caller gets one clear error instead."""
    log = logging.getLogger("tifffile")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)


# ---------------------------------------------------------------------------------------------- lazy reads


class _GuardedChunks:
    """A Zarr array (or tifffile's Zarr view of a TIFF) whose reads raise the one :func:`read_volume` error: a
    damaged chunk or strip of a lazy volume surfaces only when dask computes it, and then as a ``ValueError``
    naming the file (issue 34's rule), not as whatever the codec raised."""

    def __init__(self, path: Path, kind: str, arr):
        self.path, self.kind, self.arr = path, kind, arr
        self.shape, self.dtype, self.ndim = tuple(arr.shape), np.dtype(arr.dtype), len(arr.shape)

    def __getitem__(self, key):
        try:
            with _quiet_tifffile():
                return np.asarray(self.arr[key])
        except MemoryError:
            raise
        except Exception as exc:  # noqa: BLE001 - every codec and store raises its own types
            raise _read_error(self.path, self.kind, exc) from None


def _lazy(p: Path, kind: str, arr):
    """A dask array over ``arr``'s own chunks whose chunk reads fail with a ``ValueError`` naming ``p``."""
    import dask.array as da
    from dask.base import tokenize
    st = p.stat()
    name = "read_volume-" + tokenize(os.fspath(p.resolve()), st.st_mtime_ns, st.st_size, getattr(arr, "path", ""),
                                     tuple(arr.shape), str(arr.dtype))
    chunks = getattr(arr, "chunks", None) or tuple(arr.shape)
    return da.from_array(_GuardedChunks(p, kind, arr), chunks=chunks, name=name, asarray=False, fancy=False,
                         meta=np.empty((0,) * len(arr.shape), arr.dtype))


# ---------------------------------------------------------------------------------------------- door checks


def _suffix(p: Path) -> str:
    name = p.name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else p.suffix.lower()


def _declared(path, shape, dtype, *, lazy: bool = False, mapped: bool = False) -> None:
    """Refuse a declared array of a non-numeric dtype or beyond the size caps, before reading it (a memory map
    needs no memory: ``mapped`` skips the byte cap)."""
    dtype = np.dtype(dtype)
    shape = tuple(int(s) for s in shape)
    if dtype.kind not in "biuf" or dtype.fields is not None:
        raise ValueError(f"volume in {str(path)!r} must hold one number per voxel (bool, integer or float), "
                         f"got dtype {dtype}")
    if any(s < 0 or s > MAX_COUNT for s in shape):
        raise ValueError(f"volume in {str(path)!r} declares shape {shape}: every axis must be at most "
                         f"{MAX_COUNT} voxels")
    n = int(np.prod(shape, dtype=object))
    if lazy and n > MAX_LAZY_VOXELS:
        raise ValueError(f"volume in {str(path)!r} declares shape {shape} ({n} voxels), more than the "
                         f"{MAX_LAZY_VOXELS} a lazy read accepts")
    if not lazy and not mapped and n * dtype.itemsize > MAX_VOLUME_BYTES:
        raise ValueError(f"volume in {str(path)!r} declares shape {shape} ({n * dtype.itemsize} bytes), more "
                         f"than the {MAX_VOLUME_BYTES} bytes read into memory (read Zarr/TIFF with lazy=True)")


def _file_list(path) -> list[Path]:
    """An explicit list of slice files: 2 or more existing files, all TIFF or all DICOM-like."""
    if len(path) < 2:
        raise ValueError(f"path must list at least 2 slice files, got {len(path)}")
    files = []
    for k, f in enumerate(path):
        if not isinstance(f, (str, os.PathLike)):
            raise ValueError(f"path[{k}] must be a file path, got {type(f).__name__}")
        f = Path(f)
        if not f.is_file():
            raise ValueError(f"path[{k}] is not an existing file: {str(f)!r}")
        files.append(f)
    tif = [f.suffix.lower() in (".tif", ".tiff") for f in files]
    if any(tif) and not all(tif):
        raise ValueError(f"path must list TIFF slices only or DICOM files only, got {str(files[tif.index(False)])!r}"
                         f" among TIFF files")
    if not any(tif) and any(_suffix(f) in _KINDS for f in files):
        bad = next(f for f in files if _suffix(f) in _KINDS)
        raise ValueError(f"path must list 2-D TIFF slices or DICOM files, got {str(bad)!r} (read a single "
                         f"volume file by its path)")
    return files


def _pick_index(path, shape, axes: str, keep: list[int], pick: dict) -> tuple:
    """The index tuple selecting the kept axes and the picked channel/time point (0 on dropped singletons)."""
    return tuple(slice(None) if i in keep else pick.get(("at", i), 0) for i in range(len(shape)))


def _keep_axes(path, shape, axes: str, pick: dict | None = None) -> list[int]:
    """Indices of the three axes kept after dropping singleton non-spatial axes and the axes ``pick`` selects
    (``{"channel": c, "time": t}``); clear error otherwise. The chosen index along each dropped axis is stored in
    ``pick[("at", axis)]`` (see :func:`_pick_index`).

    ``axes`` holds one lower-case letter per axis; ``x``, ``y``, ``z`` are spatial, ``t`` time, ``c``/``s``
    channel (``s``: samples, e.g. RGB), ``?`` unknown (dropped only if it has one entry and more than three axes
    remain, or picked by ``channel`` or ``time`` when it is the one extra axis).
    """
    shape = tuple(int(s) for s in shape)
    pick = {} if pick is None else pick
    keep = list(range(len(shape)))
    named = {"time": "t", "channel": "cs"}
    for name, letters in named.items():
        v = pick.get(name)
        if v is None:
            continue
        cands = [i for i in keep if axes[i] in letters]
        cands = [i for i in cands if shape[i] > 1] or cands
        other = "channel" if name == "time" else "time"
        if not cands and pick.get(other) is None:        # an unlabelled extra axis (NumPy, HDF5)
            unknown = [i for i in keep if axes[i] == "?"]
            n_spatial = 3 - sum(axes[i] in "xyz" for i in keep)
            extra = unknown[:max(0, len(unknown) - n_spatial)]
            cands = ([i for i in extra if shape[i] > 1] or extra)[:1]
        if not cands:
            raise ValueError(f"{name}={v!r} does not apply to {str(path)!r}: it has no {name} axis (axes "
                             f"{''.join(axes).upper()}, shape {shape})")
        i = cands[0]
        if v >= shape[i]:
            raise ValueError(f"{name} must be in [0, {shape[i] - 1}] for {str(path)!r} ({name} axis "
                             f"{axes[i].upper()} has {shape[i]} entries), got {v}")
        pick[("at", i)] = int(v)
        keep.remove(i)
    for i in range(len(shape)):                                    # named non-spatial singletons first
        if len(keep) > 3 and shape[i] == 1 and axes[i] not in "xyz?":
            keep.remove(i)
    for i in range(len(shape)):                                    # then unnamed singletons, leading first
        if len(keep) > 3 and shape[i] == 1 and i in keep and axes[i] not in "xyz":
            keep.remove(i)
    for i in range(len(shape)):
        if len(keep) > 3 and shape[i] == 1 and i in keep:
            keep.remove(i)
    if len(keep) != 3:
        named = "".join(axes).upper()
        raise ValueError(f"volume in {str(path)!r} must be 3-D after dropping singleton channel/time axes: it "
                         f"has axes {named} with shape {shape}"
                         + (" (a 2-D image)" if len(keep) < 3 else
                            f"; axes {''.join(axes[i] for i in keep).upper()} all have more than one entry "
                            f"(pick one with channel= or time=)"))
    return keep


def _native(a):
    """The array in native byte order (a copy only when the file's order differs)."""
    dt = np.dtype(a.dtype)
    if dt.isnative:
        return a
    return a.astype(dt.newbyteorder("="))


def _finish(p: Path, kind: str, array, spacing, origin, axes: str, meta: dict) -> Volume:
    shape = tuple(int(s) for s in array.shape)
    if len(shape) != 3:          # readers already squeezed; this guards a reader that did not
        raise ValueError(f"volume in {str(p)!r} must be 3-D, got shape {shape}")
    if min(shape) < 2:
        raise ValueError(f"volume in {str(p)!r} must be at least 2 voxels along every axis, got shape {shape} "
                         f"(axes {axes.upper()})")
    spacing = np.asarray(spacing, np.float64).reshape(3)
    origin = np.asarray(origin, np.float64).reshape(3)
    if not (np.all(np.isfinite(spacing)) and np.all(spacing > 0)):
        raise ValueError(f"voxel spacing in {str(p)!r} must be finite and > 0 along every axis, got "
                         f"{spacing.tolist()} (axes {axes.upper()})")
    if not np.all(np.isfinite(origin)):
        raise ValueError(f"origin in {str(p)!r} must be finite, got {origin.tolist()}")
    array = _native(array)
    if isinstance(array, np.ndarray) and not isinstance(array, np.memmap):
        array = np.asarray(array)
    meta = dict(meta, axes=axes, format=kind)
    spacing.setflags(write=False)
    origin.setflags(write=False)
    return Volume(array, spacing, origin, meta, str(p), kind)


#: NRRD ``space`` values and the frame their world coordinates are in (ITK reads RAS/LAS as LPS, flipped).
_NRRD_FRAMES = {"right-anterior-superior": "RAS", "ras": "RAS", "left-anterior-superior": "LAS", "las": "LAS",
                "left-posterior-superior": "LPS", "lps": "LPS"}

#: World frame -> the diagonal flip taking its coordinates to LPS (ITK, DICOM, SimpleITK).
_TO_LPS = {"RAS": np.array([-1.0, -1.0, 1.0]), "LAS": np.array([1.0, -1.0, 1.0]), "LPS": np.ones(3)}


def _frame(dirs, origin_world):
    """Spacing, origin along each axis and unit directions from (3, 3) axis vectors (rows, world units)."""
    d = np.asarray(dirs, np.float64).reshape(3, 3)
    spacing = np.linalg.norm(d, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = d / spacing[:, None]
    o = np.asarray(origin_world, np.float64).reshape(3)
    return spacing, unit @ o, unit


# ---------------------------------------------------------------------------------------------- TIFF


def _tiff(p: Path, *, dataset, lazy, pick, files=None, mmap=False):
    import tifffile
    if p.is_dir() or files is not None:
        return _tiff_folder(p, lazy=lazy, files=files)
    with tifffile.TiffFile(str(p)) as tf:
        series = tf.series[0]
        shape, dtype, axes_raw = tuple(series.shape), series.dtype, series.axes
        size = os.path.getsize(p)
        for page in tf.pages:                      # every strip/tile inside the file (else: truncated)
            ends = [o + n for o, n in zip(page.dataoffsets, page.databytecounts)]
            if ends and max(ends) > size:
                raise ValueError(f"could not read {str(p)!r} as TIFF: page data ends at byte {max(ends)}, past "
                                 f"the file's {size} (truncated)")
        mapped = bool(mmap) and series.dataoffset is not None and np.dtype(dtype).newbyteorder(
            tf.byteorder).isnative                   # contiguous, uncompressed, native order: a memory map
        _declared(p, shape, dtype, lazy=lazy, mapped=mapped)
        axes = _tiff_axes(axes_raw)
        keep = _keep_axes(p, shape, axes, pick)
        meta: dict[str, Any] = {"tiff_axes": axes_raw, "byteorder": tf.byteorder}
        sp = {"x": 1.0, "y": 1.0, "z": 1.0}
        org = {"x": 0.0, "y": 0.0, "z": 0.0}
        page0 = tf.pages[0]
        for ax, tag in (("x", "XResolution"), ("y", "YResolution")):
            t = page0.tags.get(tag)
            if t is not None:
                num, den = t.value
                if num > 0 and den > 0:
                    sp[ax] = den / num
        if tf.is_imagej:
            ij = dict(tf.imagej_metadata or {})
            meta["imagej"] = ij
            if "spacing" in ij:
                sp["z"] = float(ij["spacing"])
            for ax in "xyz":                         # ImageJ calibration: world = (pixel - xorigin) * pixelWidth
                if f"{ax}origin" in ij:
                    org[ax] = -float(ij[f"{ax}origin"]) * sp[ax]
            if ij.get("unit"):
                meta["unit"] = str(ij["unit"]).replace("\\u00B5", "µ")
        elif tf.is_ome:
            meta["ome"] = tf.ome_metadata
            for el in ET.fromstring(tf.ome_metadata).iter():
                if el.tag.endswith("}Pixels") or el.tag == "Pixels":
                    for ax in "xyz":
                        v = el.get(f"PhysicalSize{ax.upper()}")
                        if v is not None:
                            sp[ax] = float(v)
                    unit = el.get("PhysicalSizeXUnit")
                    meta["unit"] = unit if unit is not None else "µm"     # the OME schema's default
                    break
            for el in ET.fromstring(tf.ome_metadata).iter():
                if el.tag.endswith("}Plane") or el.tag == "Plane":      # stage position of the first plane
                    for ax in "xyz":
                        v = el.get(f"Position{ax.upper()}")
                        if v is not None:
                            org[ax] = float(v)
                    break
        if lazy:
            import zarr
            store = series.aszarr(level=0) if series.levels else series.aszarr()
            arr = _lazy(p, "TIFF", zarr.open(store, mode="r"))
        elif mapped:
            arr = tifffile.memmap(str(p), mode="r", series=0)
        else:
            arr = series.asarray()
    arr = arr[_pick_index(p, shape, axes, keep, pick)]
    kept = "".join(axes[i] for i in keep)
    kept = kept.replace("?", "z") if kept.count("?") == 1 and "z" not in kept else kept
    spacing = [sp.get(a, 1.0) for a in kept]
    origin = [org.get(a, 0.0) for a in kept]
    return arr, spacing, origin, kept, meta


def _tiff_axes(axes: str) -> str:
    """tifffile's axis codes as x/y/z plus '?' (generic pages I/Q) and lower-case non-spatial letters."""
    out = []
    for a in axes.upper():
        out.append({"X": "x", "Y": "y", "Z": "z", "I": "?", "Q": "?"}.get(a, a.lower() if a.lower() not in "xyz?"
                                                                         else "c"))
    return "".join(out)


def _tiff_folder(p: Path, *, lazy, files=None):
    import tifffile
    if files is None:                 # natural order: img_2.tif before img_10.tif (not the name order)
        files = sorted((f for f in p.iterdir() if f.suffix.lower() in (".tif", ".tiff")),
                       key=lambda f: natural_key(f.name))
    shapes = []
    for f in files:
        try:
            with tifffile.TiffFile(str(f)) as tf:
                shapes.append((tuple(tf.series[0].shape), np.dtype(tf.series[0].dtype)))
        except Exception as exc:  # noqa: BLE001 - tifffile raises many types on a damaged slice
            raise ValueError(f"folder {str(p)!r}: could not read the slice {str(f)!r} as TIFF: "
                             f"{type(exc).__name__}: {str(exc)[:200]}") from None
    if len(set(shapes)) != 1 or len(shapes[0][0]) != 2:
        raise ValueError(f"folder {str(p)!r}: every slice must be one 2-D image of the same shape and dtype, got "
                         f"{sorted({(s, str(d)) for s, d in shapes})[:3]}")
    _declared(p, (len(files), *shapes[0][0]), shapes[0][1], lazy=lazy)
    if lazy:
        import zarr
        arr = _lazy(p, "TIFF", zarr.open(tifffile.imread([str(f) for f in files], aszarr=True), mode="r"))
    else:
        arr = tifffile.imread([str(f) for f in files])
    sp = [1.0, 1.0, 1.0]
    with tifffile.TiffFile(str(files[0])) as tf:
        for k, tag in ((2, "XResolution"), (1, "YResolution")):
            t = tf.pages[0].tags.get(tag)
            if t is not None and t.value[0] > 0 and t.value[1] > 0:
                sp[k] = t.value[1] / t.value[0]
    return arr, sp, [0.0, 0.0, 0.0], "zyx", {"slices": [f.name for f in files]}


# ---------------------------------------------------------------------------------------------- NRRD


def _nrrd(p: Path, *, dataset, lazy, pick):
    import nrrd
    header = nrrd.read_header(str(p))
    sizes = tuple(int(s) for s in header["sizes"])
    dtype = nrrd.reader._determine_datatype(header)
    _declared(p, sizes, dtype)
    n = len(sizes)
    need = int(np.prod(sizes, dtype=object)) * np.dtype(dtype).itemsize
    if str(header.get("encoding", "raw")).lower() == "raw" and "data file" not in header \
            and "datafile" not in header and p.stat().st_size < need:
        raise ValueError(f"could not read {str(p)!r} as NRRD: its header declares {need} bytes of raw data but "
                         f"the file holds {p.stat().st_size} bytes (truncated)")
    dirs = header.get("space directions")
    spatial = [True] * n
    vecs = None
    if dirs is not None:
        rows = [None if r is None or (np.ndim(r) == 1 and np.all(np.isnan(np.asarray(r, float)))) else
                np.asarray(r, np.float64) for r in dirs]
        spatial = [r is not None for r in rows]
        vecs = rows
    kinds = header.get("kinds")
    if kinds is not None and dirs is None:
        spatial = [str(k).lower() in ("domain", "space") for k in kinds]
    axes_lbl = "".join("?" if s else "c" for s in spatial)
    keep = _keep_axes(p, sizes, axes_lbl, pick)
    data, header = nrrd.read(str(p), index_order="F")
    arr = data[_pick_index(p, sizes, axes_lbl, keep, pick)]
    if vecs is not None and all(vecs[i] is not None for i in keep) and len(vecs[keep[0]]) == 3:
        o = header.get("space origin")
        o = np.zeros(3) if o is None else np.asarray(o, np.float64)
        spacing, origin, unit = _frame([vecs[i] for i in keep], o)
        meta_dir, world0 = unit, o
    else:
        sps = header.get("spacings")
        spacing = [1.0, 1.0, 1.0] if sps is None else [float(sps[i]) for i in keep]
        spacing = [1.0 if np.isnan(s) else s for s in spacing]
        origin, meta_dir, world0 = [0.0, 0.0, 0.0], np.eye(3), np.zeros(3)
    hdr = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in header.items()}
    meta = {"nrrd": hdr, "direction": meta_dir, "world_origin": world0,
            "world_frame": _NRRD_FRAMES.get(str(header.get("space", "")).lower(), "LPS")}
    if header.get("space units"):
        meta["unit"] = header["space units"][0]
    return arr, spacing, origin, "xyz", meta


# ---------------------------------------------------------------------------------------------- NIfTI


def _nifti(p: Path, *, dataset, lazy, pick):
    """NIfTI, FreeSurfer MGH/MGZ and MINC 1/2, all through nibabel (whose affines are RAS+ world coordinates)."""
    import nibabel as nib
    img = nib.load(str(p))
    shape = tuple(int(s) for s in img.shape)
    kind = _KINDS[_suffix(p)]
    minc = kind == "MINC"
    _declared(p, shape, np.float64 if minc else img.get_data_dtype())     # nibabel scales MINC to float64
    aff = np.asarray(img.affine, np.float64)
    spacing, origin, unit = _frame(aff[:3, :3].T, aff[:3, 3])
    if minc:          # MINC stores time (and vector dimensions) before the spatial ones: (t, z, y, x)
        labels = "t" * (len(shape) - 3) + "???"
    else:             # NIfTI: x, y, z, t, then components; MGH: x, y, z, frames
        labels = "xyztc"[:len(shape)] + "c" * max(0, len(shape) - 5)
    keep = _keep_axes(p, shape, labels, pick)
    spatial = list(range(len(shape) - 3, len(shape))) if minc else [0, 1, 2]
    if keep != spatial:
        raise ValueError(f"volume in {str(p)!r} must hold its 3 spatial axes {'last' if minc else 'first'}, got "
                         f"shape {shape}")
    if minc:
        arr = np.asarray(img.dataobj[_pick_index(p, shape, labels, keep, pick)])
    else:
        raw = img.dataobj.get_unscaled() if hasattr(img.dataobj, "get_unscaled") else img.dataobj
        arr = np.asanyarray(raw)[_pick_index(p, shape, labels, keep, pick)]
    meta: dict[str, Any] = {"affine": aff, "direction": unit, "world_origin": aff[:3, 3], "world_frame": "RAS",
                            f"{kind.lower()}_header": img.header}
    if not minc:
        slope, inter = getattr(img.dataobj, "slope", 1.0), getattr(img.dataobj, "inter", 0.0)
        meta["scl_slope"], meta["scl_inter"] = float(slope), float(inter)   # physical = stored * slope + inter
    axes = "".join("xyz"[int(np.argmax(np.abs(r)))] for r in unit)     # the world axis each array axis runs along
    if sorted(axes) != ["x", "y", "z"]:
        axes = "zyx" if minc else "xyz"
    try:
        meta["unit"] = img.header.get_xyzt_units()[0]
    except Exception:  # noqa: BLE001 - NIfTI-1/2 only; MGH and MINC are in millimetres
        meta["unit"] = "mm"
    return arr, spacing, origin, axes if minc else "xyz", meta


# ---------------------------------------------------------------------------------------------- MetaImage


def _metaimage(p: Path, *, dataset, lazy, pick):
    import SimpleITK as sitk
    r = sitk.ImageFileReader()
    r.SetFileName(str(p))
    r.ReadImageInformation()
    size = tuple(int(s) for s in r.GetSize())[::-1]            # numpy order (..., z, y, x)
    ncomp = r.GetNumberOfComponents()
    dim = r.GetDimension()
    pix = sitk.GetPixelIDValueAsString(r.GetPixelID())
    dtype = _SITK_DTYPES.get(sitk.GetPixelIDValueAsString(r.GetPixelID()).replace("vector of ", ""))
    if dtype is None or "complex" in pix or (ncomp != 1 and pick.get("channel") is None):
        raise ValueError(f"volume in {str(p)!r} must hold one number per voxel, got pixel type {pix!r} with "
                         f"{ncomp} components" + (" (pick one with channel=)" if ncomp > 1 and dtype else ""))
    labels = "t" * (dim - 3) + "zyx" + ("c" if ncomp > 1 else "")     # numpy order; a 4-D image's 4th is time
    full = size + ((ncomp,) if ncomp > 1 else ())
    _declared(p, full, dtype)
    keep = _keep_axes(p, full, labels, pick)
    if keep != list(range(dim - 3, dim)):
        raise ValueError(f"volume in {str(p)!r} must hold x, y, z as its first three axes, got size {size[::-1]}")
    img = r.Execute()
    if dim > 3:
        ext = sitk.ExtractImageFilter()
        ext.SetSize(list(img.GetSize()[:3]) + [0] * (dim - 3))
        ext.SetIndex([0, 0, 0] + [pick.get(("at", dim - 4 - k), 0) for k in range(dim - 3)])
        img = ext.Execute(img)
    if ncomp > 1:
        img = sitk.VectorIndexSelectionCast(img, int(pick[("at", len(full) - 1)]))
    arr = sitk.GetArrayFromImage(img)                           # (z, y, x)
    sp = np.asarray(img.GetSpacing(), np.float64)
    d = np.asarray(img.GetDirection(), np.float64).reshape(3, 3)   # columns: world direction of x, y, z
    spacing, origin, unit = _frame((d * sp).T[::-1], img.GetOrigin())
    meta = {"direction": unit, "itk_direction": d, "itk_origin": tuple(img.GetOrigin()),
            "world_origin": np.asarray(img.GetOrigin(), np.float64),
            "keys": {k: r.GetMetaData(k) for k in r.GetMetaDataKeys()}}
    return arr, spacing, origin, "zyx", meta


_SITK_DTYPES = {
    "8-bit unsigned integer": np.uint8, "8-bit signed integer": np.int8,
    "16-bit unsigned integer": np.uint16, "16-bit signed integer": np.int16,
    "32-bit unsigned integer": np.uint32, "32-bit signed integer": np.int32,
    "64-bit unsigned integer": np.uint64, "64-bit signed integer": np.int64,
    "32-bit float": np.float32, "64-bit float": np.float64,
}


# ---------------------------------------------------------------------------------------------- VTI


def _vti(p: Path, *, dataset, lazy, pick):
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkObject
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader
    r = vtkXMLImageDataReader()
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()          # VTK prints every parse error; the caller gets one ValueError
    try:
        return _vti_read(p, r, dataset, pv, vtkStreamingDemandDrivenPipeline)
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)


def _vti_read(p: Path, r, dataset, pv, vtkStreamingDemandDrivenPipeline):
    if not r.CanReadFile(str(p)):
        raise ValueError(f"could not read {str(p)!r} as VTI: not a VTK XML ImageData file")
    r.SetFileName(str(p))
    r.UpdateInformation()
    if r.GetErrorCode():
        raise ValueError(f"could not read {str(p)!r} as VTI: its XML header is damaged")
    e = r.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.WHOLE_EXTENT())
    dims = (e[1] - e[0] + 1, e[3] - e[2] + 1, e[5] - e[4] + 1)
    _declared(p, dims, np.uint8)                       # the dtype is checked once the array is known
    r.Update()
    if r.GetErrorCode() or r.GetOutput() is None:
        raise ValueError(f"could not read {str(p)!r} as VTI: its data is damaged or truncated")
    grid = pv.wrap(r.GetOutput())
    names = list(grid.point_data.keys())
    cells = list(grid.cell_data.keys())
    if dataset is None:       # the active point scalars, the only point array, else the only cell array
        name = grid.point_data.active_scalars_name or (names[0] if len(names) == 1 else None)
        if name is None and not names and len(cells) == 1:
            name = cells[0]
    else:
        name = dataset
    if name is None or (name not in names and name not in cells):
        raise ValueError(f"dataset must name one of the point-data arrays {names} or cell-data arrays {cells} in "
                         f"{str(p)!r}, got {dataset!r}")
    on_cells = name not in names
    flat = grid.cell_data[name] if on_cells else grid.point_data[name]
    if flat.ndim != 1:
        raise ValueError(f"array {name!r} in {str(p)!r} must hold one number per voxel, got {flat.shape[1]} "
                         f"components")
    d = np.asarray(grid.direction_matrix, np.float64).reshape(3, 3)    # columns: world direction of i, j, k
    step = np.asarray(grid.spacing, np.float64)
    world0 = np.asarray(grid.origin, np.float64)
    if on_cells:              # one voxel per cell, at the cell's centre: half a voxel along each axis
        dims = tuple(max(n - 1, 1) for n in dims)
        world0 = world0 + d @ (0.5 * step)
    _declared(p, dims, flat.dtype)
    if flat.size != int(np.prod(dims)):
        raise ValueError(f"array {name!r} in {str(p)!r} holds {flat.size} values, its extent {dims} needs "
                         f"{int(np.prod(dims))}")
    arr = np.asarray(flat).reshape(dims, order="F")        # (x, y, z), a view of the VTK array
    spacing, origin, unit = _frame((d * step).T, world0)
    return arr, spacing, origin, "xyz", {"array": name, "direction": unit, "arrays": names, "cell_arrays": cells,
                                         "on_cells": on_cells, "world_origin": world0}


# ---------------------------------------------------------------------------------------------- HDF5


def _hdf5(p: Path, *, dataset, lazy, pick):
    import h5py
    with h5py.File(str(p), "r") as f:
        found: list[str] = []
        f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) and o.ndim >= 3 else None)
        if dataset is None:
            if len(found) != 1:
                raise ValueError(f"dataset must name the volume inside {str(p)!r}: it holds the >= 3-D datasets "
                                 f"{found}")
            dataset = found[0]
        obj = f.get(dataset)
        if not isinstance(obj, h5py.Dataset):
            raise ValueError(f"dataset must name a dataset inside {str(p)!r} (one of {found}), got {dataset!r}")
        shape = tuple(int(s) for s in obj.shape)
        _declared(p, shape, obj.dtype)
        attrs = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in obj.attrs.items()}
        labels = ["?"] * len(shape)
        try:                                            # HDF5 dimension scales labels, if the writer set them
            for i, dim in enumerate(obj.dims):
                lab = (dim.label or "").lower()[:1]
                if lab:
                    labels[i] = lab if lab in "xyzt" else "c"
        except Exception:  # noqa: BLE001, S110 - dimension-scale support varies between writers
            pass
        keep = _keep_axes(p, shape, "".join(labels), pick)
        arr = obj[_pick_index(p, shape, labels, keep, pick)]
    spacing = [1.0, 1.0, 1.0]
    esu = attrs.get("element_size_um")
    if esu is not None:
        esu = np.asarray(esu, np.float64).ravel()
        if len(esu) == len(shape):
            esu = esu[keep]
        if len(esu) != 3:
            raise ValueError(f"element_size_um of {dataset!r} in {str(p)!r} must hold one value per axis, got "
                             f"{esu.tolist()}")
        spacing = esu
    meta = {"dataset": dataset, "attrs": attrs}
    if esu is not None:
        meta["unit"] = "µm"
    kept = "".join(labels[i] for i in keep)
    return arr, spacing, [0.0, 0.0, 0.0], kept if set(kept) == set("xyz") else "zyx", meta


# ---------------------------------------------------------------------------------------------- Zarr


def _zarr(p: Path, *, dataset, lazy, pick):
    import zarr
    node = zarr.open(str(p), mode="r")
    attrs = dict(node.attrs)
    ms = (attrs.get("ome") or {}).get("multiscales") or attrs.get("multiscales")
    scale = trans = None
    axes_meta = None
    if isinstance(node, zarr.Array):
        arr_node, path = node, ""
    else:
        path = dataset
        if path is None and ms:
            m0 = ms[0]
            ds0 = m0["datasets"][0]
            path = ds0["path"]
            axes_meta = m0.get("axes")
            scale, trans = _ome_transforms(ds0.get("coordinateTransformations"))
            s2, t2 = _ome_transforms(m0.get("coordinateTransformations"))
            if s2 is not None:                          # the multiscale's own transforms apply after the level's
                scale = s2 if scale is None else scale * s2
                trans = None if trans is None else trans * s2
            if t2 is not None:
                trans = t2 if trans is None else trans + t2
        if path is None:
            arrays = [k for k, _ in node.arrays()]
            if len(arrays) != 1:
                raise ValueError(f"dataset must name the array inside {str(p)!r}: it holds {arrays} and no "
                                 f"OME-Zarr multiscales")
            path = arrays[0]
        try:
            arr_node = node[path]
        except KeyError:
            raise ValueError(f"dataset must name an array inside {str(p)!r}, got {path!r}") from None
        if not isinstance(arr_node, zarr.Array):
            raise ValueError(f"dataset must name an array inside {str(p)!r}, got the group {path!r}")
        if dataset is not None and ms:                  # a chosen level of the multiscales: its own transforms
            for ds in ms[0]["datasets"]:
                if ds["path"] == dataset:
                    axes_meta = ms[0].get("axes")
                    scale, trans = _ome_transforms(ds.get("coordinateTransformations"))
    shape = tuple(int(s) for s in arr_node.shape)
    _declared(p, shape, arr_node.dtype, lazy=lazy)
    n = len(shape)
    if axes_meta:
        names = [a["name"] if isinstance(a, dict) else str(a) for a in axes_meta]
        types = [a.get("type", "") if isinstance(a, dict) else "" for a in axes_meta]
        labels = "".join(nm.lower()[:1] if (t == "space" or nm.lower() in "xyz") and nm.lower()[:1] in "xyz"
                         else "t" if t == "time" or (not t and nm.lower() == "t") else "c"
                         for nm, t in zip(names, types))
    else:
        labels = "?" * n
    if len(labels) != n:
        raise ValueError(f"OME-Zarr axes {labels.upper()} in {str(p)!r} do not match the array's shape {shape}")
    keep = _keep_axes(p, shape, labels, pick)
    sel = _pick_index(p, shape, labels, keep, pick)
    if lazy:
        arr = _lazy(p, "Zarr", arr_node)[sel]
    else:
        arr = arr_node[sel]
    spacing = [1.0, 1.0, 1.0] if scale is None else [float(np.asarray(scale)[i]) for i in keep]
    origin = [0.0, 0.0, 0.0] if trans is None else [float(np.asarray(trans)[i]) for i in keep]
    meta = {"dataset": path, "attrs": attrs}
    if axes_meta:
        units = {a.get("unit") for a in axes_meta if isinstance(a, dict) and a.get("type") == "space"} - {None}
        if len(units) == 1:
            meta["unit"] = units.pop()
    kept = "".join(labels[i] for i in keep)
    return arr, spacing, origin, kept if set(kept) == set("xyz") else "zyx", meta


def _ome_transforms(cts):
    scale = trans = None
    for ct in cts or []:
        if ct.get("type") == "scale" and "scale" in ct:
            scale = np.asarray(ct["scale"], np.float64)
        elif ct.get("type") == "translation" and "translation" in ct:
            trans = np.asarray(ct["translation"], np.float64)
    return scale, trans


# ---------------------------------------------------------------------------------------------- DICOM


def _dicom(p: Path, *, dataset, lazy, pick, files=None):
    import pydicom
    from pydicom.errors import InvalidDicomError
    heads = []
    for f in (sorted(p.iterdir(), key=lambda f: natural_key(f.name)) if files is None else files):
        if not f.is_file():
            continue
        try:
            ds = pydicom.dcmread(str(f), stop_before_pixels=True)
        except (InvalidDicomError, OSError, EOFError) as exc:
            if files is not None:
                raise ValueError(f"could not read {str(f)!r} as DICOM: {type(exc).__name__}: "
                                 f"{str(exc)[:200]}") from None
            continue
        if "PixelData" in ds or hasattr(ds, "Rows"):
            heads.append((f, ds))
    if not heads:
        raise ValueError(f"folder {str(p)!r} holds no TIFF or DICOM slices")
    series = {str(getattr(ds, "SeriesInstanceUID", "")) for _, ds in heads}
    if len(series) != 1:
        raise ValueError(f"folder {str(p)!r} must hold one DICOM series, got {len(series)} (SeriesInstanceUID)")
    if len(heads) < 2:
        raise ValueError(f"folder {str(p)!r} holds one DICOM slice: a volume needs at least 2")
    ds0 = heads[0][1]
    rows, cols = int(ds0.Rows), int(ds0.Columns)
    bits, signed = int(ds0.BitsAllocated), int(getattr(ds0, "PixelRepresentation", 0))
    if int(getattr(ds0, "SamplesPerPixel", 1)) != 1 or bits not in (8, 16, 32):
        raise ValueError(f"DICOM series in {str(p)!r} must hold one 8/16/32-bit sample per pixel, got "
                         f"{getattr(ds0, 'SamplesPerPixel', 1)} samples of {bits} bits")
    dtype = np.dtype(("i" if signed else "u") + str(bits // 8))
    _declared(p, (len(heads), rows, cols), dtype)
    iop = np.asarray(getattr(ds0, "ImageOrientationPatient", [1, 0, 0, 0, 1, 0]), np.float64)
    row_dir, col_dir = iop[:3], iop[3:]
    normal = np.cross(row_dir, col_dir)
    pos = []
    for f, ds in heads:
        if (int(ds.Rows), int(ds.Columns)) != (rows, cols):
            raise ValueError(f"DICOM slice {str(f)!r} is {ds.Rows}x{ds.Columns}, the series is {rows}x{cols}")
        ipp = getattr(ds, "ImagePositionPatient", None)
        if ipp is None:
            raise ValueError(f"DICOM slice {str(f)!r} has no ImagePositionPatient: the slices cannot be ordered")
        pos.append(np.asarray(ipp, np.float64))
    pos = np.asarray(pos)
    along = pos @ normal
    order = np.argsort(along, kind="stable")
    gaps = np.diff(along[order])
    if np.any(gaps <= 0):
        raise ValueError(f"DICOM series in {str(p)!r} has two slices at the same position along the normal")
    dz = float(np.median(gaps))
    if np.ptp(gaps) > 1e-3 * dz + 1e-6:
        raise ValueError(f"DICOM series in {str(p)!r} has uneven slice gaps {sorted(set(np.round(gaps, 4)))[:5]}:"
                         f" not one regular volume")
    arr = np.empty((len(heads), rows, cols), dtype)
    for k, i in enumerate(order):
        arr[k] = pydicom.dcmread(str(heads[i][0])).pixel_array
    ps = [float(v) for v in getattr(ds0, "PixelSpacing", [1.0, 1.0])]     # (row spacing, column spacing)
    dirs = np.stack([normal * dz, col_dir * ps[0], row_dir * ps[1]])        # axis 0 slices, 1 rows, 2 columns
    spacing, origin, unit = _frame(dirs, pos[order[0]])
    meta = {"direction": unit, "image_position": pos[order[0]], "unit": "mm", "world_origin": pos[order[0]],
            "rescale_slope": float(getattr(ds0, "RescaleSlope", 1.0)),
            "rescale_intercept": float(getattr(ds0, "RescaleIntercept", 0.0)),
            "modality": str(getattr(ds0, "Modality", "")), "files": [heads[i][0].name for i in order]}
    return arr, spacing, origin, "zyx", meta


# ---------------------------------------------------------------------------------------------- NumPy


def _numpy(p: Path, *, dataset, lazy, pick, mmap=False):
    from plantvr._fileio import npy_headers, read_npz
    if p.suffix.lower() == ".npy":
        from plantvr.vine.volume import _npy_header
        shape, dtype, offset = _npy_header(p)
        _declared(p, shape, dtype, mapped=bool(mmap) and np.dtype(dtype).isnative)
        n = int(np.prod(shape, dtype=object)) * np.dtype(dtype).itemsize
        if n != p.stat().st_size - offset:
            raise ValueError(f"could not read {str(p)!r} as .npy: its header declares {n} bytes of data but the "
                             f"file holds {p.stat().st_size - offset} (truncated or corrupt)")
        arr = np.load(p, mmap_mode="r" if mmap else None, allow_pickle=False)
    else:
        try:
            heads = npy_headers(p, what="volume file", max_members=1000)
        except ValueError as exc:               # the archive itself: one wording with every other reader
            raise ValueError(f"could not read {str(p)!r} as .npz: {str(exc).split(': ', 1)[-1]}") from None
        names = list(heads)
        key = dataset if dataset is not None else ("volume" if "volume" in names else
                                                   (names[0] if len(names) == 1 else None))
        if key is None or key not in names:
            raise ValueError(f"dataset must name one of the arrays {names} in {str(p)!r}, got {dataset!r}")
        shape, dtype = heads[key][0], heads[key][1]
        _declared(p, shape, dtype)
        try:
            arr = read_npz(p, what="volume file", max_bytes=MAX_VOLUME_BYTES + 2 ** 26)[key]
        except ValueError as exc:
            raise ValueError(f"could not read {str(p)!r} as .npz: {str(exc).split(': ', 1)[-1]}") from None
    keep = _keep_axes(p, arr.shape, "?" * arr.ndim, pick)
    arr = arr[_pick_index(p, arr.shape, "?" * arr.ndim, keep, pick)]
    return arr, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0], "zyx", {}


def load_volume(path, *, key: str | None = None, mmap: bool = True) -> np.ndarray:
    """ViNE's volume input (spec 000_vine §1.4): :func:`read_volume`'s voxels of a TIFF stack (a multi-page file
    or a folder of 2-D slices in natural order), ``.npy`` or ``.npz``, checked for the numeric cores.

    A thin call into :func:`read_volume` (issue 30, "one reader per format"): the same errors, the same size
    caps, checked from the headers before anything is allocated.

    Parameters
    ----------
    path : str or path-like
        ``.tif``/``.tiff``, a folder of 2-D TIFF slices, ``.npy`` or ``.npz``.
    key : str, optional
        Array name inside a ``.npz`` (default: ``"volume"`` if present, else the only array).
    mmap : bool
        Memory-map ``.npy`` files and uncompressed native-order TIFF files instead of reading them.

    Returns
    -------
    (A0, A1, A2) ndarray
        uint8/16/32, int8/16/32, float32 or float64, native byte order, axes as stored (a TIFF stack: page,
        row, column); float volumes are finite.

    Raises
    ------
    ValueError
        Naming the file: as :func:`read_volume`, plus another suffix, another dtype or a non-finite float.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a file or folder path, got {type(path).__name__}")  # noqa: TRY004
    p = Path(path)
    if p.exists() and not p.is_dir() and _suffix(p) not in (".tif", ".tiff", ".npy", ".npz"):
        raise ValueError(f"path must end in .tif, .tiff, .npy or .npz (or be a folder of TIFF slices), got "
                         f"{str(p)!r}")
    if key is not None and _suffix(p) != ".npz":
        raise ValueError(f"key names an array inside a .npz file, so key={key!r} does not apply to {str(p)!r}")
    if not isinstance(mmap, (bool, np.bool_)):
        raise ValueError(f"mmap must be True or False, got {mmap!r}")
    vol = read_volume(p, dataset=key, mmap=bool(mmap) and not p.is_dir() and _suffix(p) != ".npz")
    from plantvr.vine.volume import _check_volume
    try:
        return _check_volume("volume", vol.array)
    except ValueError as exc:
        raise ValueError(f"{exc} (in {str(p)!r})") from None


_KINDS = {".tif": "TIFF", ".tiff": "TIFF", ".nrrd": "NRRD", ".nhdr": "NRRD", ".nii": "NIfTI", ".nii.gz": "NIfTI",
          ".mgh": "MGH", ".mgz": "MGH", ".mnc": "MINC",
          ".mha": "MetaImage", ".mhd": "MetaImage", ".vti": "VTI", ".h5": "HDF5", ".hdf5": "HDF5",
          ".zarr": "Zarr", ".npy": "NumPy", ".npz": "NumPy"}
_READERS = {"TIFF": _tiff, "NRRD": _nrrd, "NIfTI": _nifti, "MGH": _nifti, "MINC": _nifti, "MetaImage": _metaimage,
            "VTI": _vti, "HDF5": _hdf5, "Zarr": _zarr, "DICOM": _dicom, "NumPy": _numpy}
