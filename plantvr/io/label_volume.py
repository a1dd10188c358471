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
``.seg.nrrd``       pynrrd      3D Slicer's segmentation: the ``.nrrd`` grid (always LPS) plus, per label, the
                                ``Segment<k>_ID/Name/Color/LabelValue/Layer/Extent/Tags`` keys Slicer writes
                                (``Extent``: the label's voxel bounding box, inclusive) and the
                                ``Segmentation_*`` keys (binary labelmap master representation)
``.nii, .nii.gz``   nibabel     NIfTI-1, qform and sform = the RAS affine of the geometry (code 1: scanner),
                                data in the array's own axis order
``.mha, .mhd``      SimpleITK   ``TransformMatrix``/``Offset``/``ElementSpacing`` of the geometry, data in
                                the array's own axis order (ITK axis 0 = the array's last)
``.zarr``           zarr        OME-Zarr labels (NGFF image-label, 0.4 in a Zarr v2 image, 0.5 in a v3 one)
                                written *into* the existing image ``path``: ``labels/<name>/`` holds one level
                                per image level (nearest label at each level's voxel centres, the image's own
                                ``coordinateTransformations``), ``image-label`` with ``colors``, ``properties``
                                (names) and ``source.image = "../../"``, and ``labels/``' ``labels`` list
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
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from plantvr._fileio import check_target, write_atomic
from plantvr._validation import check_array

__all__ = ["LABEL_VOLUME_SUFFIXES", "write_label_volume"]

#: Suffixes :func:`write_label_volume` writes.
LABEL_VOLUME_SUFFIXES = (".tif", ".tiff", ".nrrd", ".seg.nrrd", ".nii", ".nii.gz", ".mha", ".mhd", ".zarr")

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


#: Colours of segments without one (Slicer's own first generic colours, RGB in [0, 1]).
_SLICER_COLORS = ((0.502, 0.682, 0.502), (0.945, 0.839, 0.569), (0.694, 0.478, 0.396), (0.435, 0.722, 0.824),
                  (0.847, 0.396, 0.310), (0.867, 0.510, 0.396), (0.565, 0.933, 0.565), (0.753, 0.408, 0.545))


def _segments(volume: np.ndarray, names, colors) -> list[dict]:
    """One record per label present (id, name, colour in [0, 1], inclusive voxel extent), checked."""
    present = [int(v) for v in np.unique(volume) if v != 0]
    for pname, table in (("names", names), ("colors", colors)):
        if table is not None and not isinstance(table, dict):
            raise ValueError(f"{pname} must be a dict {{label: value}}, got {type(table).__name__}")
        extra = sorted(set(table or {}) - set(present))
        if extra:
            raise ValueError(f"{pname} names labels {extra[:5]} that are not in volume (labels {present[:10]})")
    out = []
    for k, lab in enumerate(present):
        name = (names or {}).get(lab)
        if name is not None and (not isinstance(name, str) or not name.strip() or any(c in name for c in "\n\r|")):
            raise ValueError(f"names[{lab}] must be a non-empty one-line string without '|', got {name!r}")
        rgb = (colors or {}).get(lab)
        if rgb is not None:
            c = np.asarray(rgb, np.float64).ravel()
            if c.shape != (3,) or not np.all(np.isfinite(c)) or np.any(c < 0):
                raise ValueError(f"colors[{lab}] must be 3 values, RGB in [0, 1] or [0, 255], got {rgb!r}")
            c = c / 255.0 if np.any(c > 1) else c
            if np.any(c > 1):
                raise ValueError(f"colors[{lab}] must be 3 values, RGB in [0, 1] or [0, 255], got {rgb!r}")
        else:
            c = np.asarray(_SLICER_COLORS[k % len(_SLICER_COLORS)])
        idx = np.argwhere(volume == lab)
        lo, hi = idx.min(axis=0), idx.max(axis=0)
        out.append({"label": lab, "name": name, "color": c,
                    "extent": [int(v) for pair in zip(lo, hi) for v in pair]})
    return out


#: Suffixes of the label tables written beside a plain label image (see :func:`write_label_volume`).
ITKSNAP_SUFFIX, SLICER_SUFFIX = "_labels.txt", ".ctbl"


def _itksnap_table(segments: list[dict]) -> str:
    """ITK-SNAP's label description file: ``IDX R G B A VIS MSH "LABEL"`` per label, 0-255 colours, the clear
    label 0 first (the layout ITK-SNAP's *Export Label Descriptions* writes)."""
    rows = ["################################################", "# ITK-SnAP Label Description File",
            "# Written by PlantVR", "# Fields: IDX R G B A VIS MSH LABEL", "################################################",
            '    0     0    0    0        0  0  0    "Clear Label"']
    for seg in segments:
        r, g, b = (int(round(255 * x)) for x in seg["color"])
        name = (seg["name"] or f"Segment_{seg['label']}").replace('"', "'")
        rows.append(f'{seg["label"]:5d} {r:5d} {g:4d} {b:4d}        1  1  1    "{name}"')
    return "\n".join(rows) + "\n"


def _slicer_table(segments: list[dict]) -> str:
    """A 3D Slicer colour table (``.ctbl``: ``label name R G B A`` per line, 0-255, names without spaces)."""
    rows = ["# Color table file written by PlantVR", f"# {len(segments) + 1} values", "0 Background 0 0 0 0"]
    for seg in segments:
        r, g, b = (int(round(255 * x)) for x in seg["color"])
        name = re.sub(r"\s+", "_", seg["name"] or f"Segment_{seg['label']}")
        rows.append(f"{seg['label']} {name} {r} {g} {b} 255")
    return "\n".join(rows) + "\n"


def _write_seg_nrrd(tmp: str, vol: np.ndarray, g, unit: str | None, lps: bool, segments=()) -> None:
    import nrrd
    header = {"space": "left-posterior-superior", "space directions": g.direction * g.spacing[:, None],
              "space origin": np.asarray(g.origin, np.float64), "kinds": ["domain", "domain", "domain"],
              "encoding": "gzip"}
    for k, seg in enumerate(segments):
        key = f"Segment{k}_"
        header[key + "Color"] = " ".join(f"{x:.6g}" for x in seg["color"])
        header[key + "ColorAutoGenerated"] = "0"
        header[key + "Extent"] = " ".join(str(v) for v in seg["extent"])
        header[key + "ID"] = f"Segment_{seg['label']}"
        header[key + "LabelValue"] = str(seg["label"])
        header[key + "Layer"] = "0"
        header[key + "Name"] = seg["name"] or f"Segment_{seg['label']}"
        header[key + "NameAutoGenerated"] = "0" if seg["name"] else "1"
        header[key + "Tags"] = "Segmentation.Status:inprogress|"
    header["Segmentation_ContainedRepresentationNames"] = "Binary labelmap|"
    header["Segmentation_MasterRepresentation"] = "Binary labelmap"
    header["Segmentation_ReferenceImageExtentOffset"] = "0 0 0"
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


# ------------------------------------------------------------------------------------- OME-Zarr labels (NGFF)

#: Label group names OME-Zarr labels may take here (one path component).
_LABEL_NAME = r"[A-Za-z0-9][A-Za-z0-9._-]{0,127}"


def _ome_image(p: Path):
    """The OME-Zarr image at ``p``: (zarr format, NGFF version, multiscales[0], spatial axis indices, its
    level-0 geometry). Refuses a folder that is not one."""
    import zarr

    from plantvr.io.volume import VolumeGeometry, _ome_transforms
    if not p.is_dir():
        raise ValueError(f"path must be an existing OME-Zarr image folder (labels are written into it, beside the "
                         f"image), got {os.fspath(p)!r}")
    try:
        root = zarr.open_group(str(p), mode="r")
        attrs = dict(root.attrs)
    except Exception as exc:  # noqa: BLE001 - zarr raises many types on a damaged store
        raise ValueError(f"could not open {os.fspath(p)!r} as an OME-Zarr image: {type(exc).__name__}: "
                         f"{str(exc)[:200]}") from None
    fmt = int(root.metadata.zarr_format)
    ome = attrs.get("ome") if fmt == 3 else attrs
    ms = (ome or {}).get("multiscales")
    if not isinstance(ms, list) or not ms or not isinstance(ms[0], dict) or not ms[0].get("datasets"):
        raise ValueError(f"path must be an OME-Zarr image (a .zarr folder with NGFF 'multiscales'), "
                         f"{os.fspath(p)!r} has none")
    m0 = ms[0]
    version = str((ome or {}).get("version") or m0.get("version") or ("0.5" if fmt == 3 else "0.4"))
    axes = m0.get("axes") or []
    spatial = [i for i, a in enumerate(axes) if isinstance(a, dict) and a.get("type") == "space"]
    if len(spatial) != 3:
        raise ValueError(f"OME-Zarr image {os.fspath(p)!r} must have 3 space axes for a label volume, got axes "
                         f"{[a.get('name') if isinstance(a, dict) else a for a in axes]}")
    levels = []
    for ds in m0["datasets"]:
        try:
            arr = root[ds["path"]]
        except Exception:  # noqa: BLE001 - a missing level is a damaged image
            raise ValueError(f"OME-Zarr image {os.fspath(p)!r} names the level {ds.get('path')!r}, which it does "
                             f"not hold") from None
        scale, trans = _ome_transforms(ds.get("coordinateTransformations"))
        n = len(arr.shape)
        scale = np.ones(n) if scale is None else scale
        trans = np.zeros(n) if trans is None else trans
        levels.append((ds, tuple(int(arr.shape[i]) for i in spatial), scale[spatial], trans[spatial]))
    s2, t2 = _ome_transforms(m0.get("coordinateTransformations"))     # the multiscale's own, after each level's
    if s2 is not None or t2 is not None:
        s2 = np.ones(len(axes)) if s2 is None else s2
        t2 = np.zeros(len(axes)) if t2 is None else t2
        levels = [(ds, sh, sc * s2[spatial], tr * s2[spatial] + t2[spatial]) for ds, sh, sc, tr in levels]
    letters = "".join(str(axes[i].get("name", "?")).lower()[:1] for i in spatial)
    units = {axes[i].get("unit") for i in spatial} - {None}
    g0 = VolumeGeometry.from_grid(levels[0][1], levels[0][2], levels[0][3], axes=letters,
                                  unit=units.pop() if len(units) == 1 else None)
    return fmt, version, m0, spatial, levels, g0


def _write_ome_zarr_labels(p: Path, vol: np.ndarray, geometry, name: str, segments: list[dict]) -> Path:
    import zarr
    fmt, version, m0, spatial, levels, g0 = _ome_image(p)
    if vol.shape != g0.shape:
        raise ValueError(f"volume has shape {vol.shape}, but the OME-Zarr image {os.fspath(p)!r} has level-0 space "
                         f"axes of shape {g0.shape}: labels lie on the image's own voxels")
    if geometry is not None:
        g = _check_geometry(geometry, vol.shape)
        if not (np.allclose(g.spacing, g0.spacing, rtol=1e-9) and np.allclose(g.direction, g0.direction)
                and np.allclose(g.origin, g0.origin, rtol=1e-9, atol=1e-9 * float(np.max(g0.spacing)))):
            raise ValueError(f"geometry (spacing {g.spacing.tolist()}, origin {g.origin.tolist()}) is not the "
                             f"level-0 grid of the OME-Zarr image {os.fspath(p)!r} (spacing {g0.spacing.tolist()},"
                             f" origin {g0.origin.tolist()}): OME-Zarr labels lie on their image's voxels")
    axes = [dict(m0["axes"][i]) for i in spatial]
    colors = [{"label-value": s["label"], "rgba": [int(round(255 * c)) for c in s["color"]] + [255]}
              for s in segments]
    props = [{"label-value": s["label"], "name": s["name"] or f"label {s['label']}"} for s in segments]
    image_label = {"colors": colors, "properties": props, "source": {"image": "../../"}}
    datasets = []
    for ds, _shape, sc, tr in levels:
        datasets.append({"path": str(ds["path"]),
                         "coordinateTransformations": [{"type": "scale", "scale": [float(x) for x in sc]},
                                                       {"type": "translation", "translation": [float(x) for x in tr]}]})
    multiscales = [{"axes": axes, "datasets": datasets, "name": name}]
    if fmt == 2:
        image_label["version"] = version
        multiscales[0]["version"] = version
        attrs = {"image-label": image_label, "multiscales": multiscales}
    else:
        attrs = {"ome": {"version": version, "image-label": image_label, "multiscales": multiscales}}
    labels_dir = p / "labels"
    made = not labels_dir.exists()
    tmp = None
    try:
        lab_group = zarr.open_group(str(labels_dir), mode="a", zarr_format=fmt)
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=labels_dir))
        grp = zarr.open_group(str(tmp), mode="w", zarr_format=fmt)
        s0, t0 = levels[0][2], levels[0][3]
        for ds, shape, sc, tr in levels:            # nearest level-0 label at each level voxel's centre
            idx = [np.clip(np.rint((np.arange(shape[a]) * sc[a] + tr[a] - t0[a]) / s0[a]), 0, vol.shape[a] - 1)
                   .astype(np.intp) for a in range(3)]
            data = vol[np.ix_(*idx)]
            arr = grp.create_array(str(ds["path"]), shape=data.shape, dtype=data.dtype,
                                   chunks=tuple(min(n, 64) for n in data.shape),
                                   **({"dimension_names": [a.get("name") for a in axes]} if fmt == 3 else {}))
            arr[...] = data
        grp.attrs.update(attrs)
        final = labels_dir / name
        old = None
        if final.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{name}.old.", dir=labels_dir))
            os.replace(final, old / name)
        os.replace(tmp, final)
        tmp = None
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        ome_l = dict(lab_group.attrs)
        if fmt == 3:
            inner = dict(ome_l.get("ome") or {})
            names = [n for n in inner.get("labels", []) if n != name] + [name]
            lab_group.attrs.update({"ome": {**inner, "version": version, "labels": names}})
        else:
            names = [n for n in ome_l.get("labels", []) if n != name] + [name]
            lab_group.attrs.update({"labels": names})
    except BaseException:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        if made:
            shutil.rmtree(labels_dir, ignore_errors=True)
        raise
    return labels_dir / name


_WRITERS = {".tif": _write_tiff, ".tiff": _write_tiff, ".nrrd": _write_nrrd, ".seg.nrrd": _write_seg_nrrd,
            ".nii": _write_nifti,
            ".nii.gz": _write_nifti, ".mha": _write_metaimage, ".mhd": _write_metaimage}


def _check_geometry(geometry, shape):
    from plantvr.io.volume import Volume, VolumeGeometry
    g = geometry.geometry if isinstance(geometry, Volume) else geometry
    if not isinstance(g, VolumeGeometry):
        raise ValueError(f"geometry must be a VolumeGeometry or a Volume (read_volume's), got "  # noqa: TRY004
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
                       geometry=None, names: dict | None = None, colors: dict | None = None,
                       name: str | None = None) -> Path:
    """Write a label volume in the format its suffix names (``.tif``, ``.nrrd``, ``.seg.nrrd``, ``.nii``,
    ``.nii.gz``, ``.mha``, ``.mhd``; ``.zarr``: OME-Zarr labels inside that image), each voxel at its physical
    point.

    Parameters
    ----------
    path : path-like
        Target file; its folder must exist. For ``.zarr``: an existing OME-Zarr image, which gets the labels
        group ``labels/<name>`` (the NGFF image-label layout napari and ome-zarr-py open as its labels).
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
        For ``.zarr``, optional: it must be the image's level-0 grid (the default).
    names, colors : dict, optional
        Segment name and RGB colour (in [0, 1], or [0, 255]) of each label present (default ``Segment_<label>``
        and Slicer's generic colours). ``.seg.nrrd`` and ``.zarr`` hold them; for the other formats, giving
        either writes the label table beside the image: ``<base>_labels.txt`` (ITK-SNAP's label description
        file, *Segmentation > Import Label Descriptions*) and ``<base>.ctbl`` (a 3D Slicer colour table).
    name : str, optional
        ``.zarr`` only: the labels group's name (default ``"labels"``), letters, digits, ``.``, ``_``, ``-``.

    Returns
    -------
    Path
        The path written (for ``.zarr``, the labels group ``path/labels/<name>``).

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
    if name is not None and suffix != ".zarr":
        raise ValueError(f"name names an OME-Zarr labels group: it applies to .zarr only, not to {os.fspath(p)!r}")
    inside = suffix in (".seg.nrrd", ".zarr")             # formats that hold the label table themselves
    segments = _segments(volume, names, colors) if inside or names is not None or colors is not None else None
    if suffix == ".zarr":
        name = "labels" if name is None else name
        if not isinstance(name, str) or not re.fullmatch(_LABEL_NAME, name):
            raise ValueError(f"name must be 1-128 letters, digits, '.', '_' or '-' (not starting with '.', '_' or "
                             f"'-'), got {name!r}")
        if spacing is not None or origin is not None:
            raise ValueError("spacing and origin do not apply to OME-Zarr labels: they lie on the image's level-0 "
                             "grid (pass geometry=, or nothing)")
        return _write_ome_zarr_labels(p, volume, geometry, name, segments)
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
        extra = {"segments": segments} if inside else {}
        _WRITERS[suffix](tmp, volume, g, unit, lps, **extra)
        if segments is not None and not inside:     # the label table beside the image, before the image lands
            base = p.name[:-len(suffix)]
            write_atomic(p.with_name(base + ITKSNAP_SUFFIX), _itksnap_table(segments))
            write_atomic(p.with_name(base + SLICER_SUFFIX), _slicer_table(segments))
        if suffix == ".mhd":                     # the .mhd names its data file: rename both
            raw = Path(tmp).with_suffix(".raw") if Path(tmp).with_suffix(".raw").exists() else \
                Path(tmp).with_suffix(".zraw")
            target_raw = p.with_name(p.name[:-4] + raw.suffix)
            header = Path(tmp).read_bytes().replace(raw.name.encode(), target_raw.name.encode())
            Path(tmp).write_bytes(header)          # the header just written (our temp file), byte for byte
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
