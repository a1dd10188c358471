"""Session bundles: one zip file with the whole ViNE labels document (spec 000_vine §2.7 persistence,
checklist item 24; issue 15).

A bundle holds the mesh (or the SHA-256 of its source volume plus the iso-value and meshing options, voxel
spacing and origin included, so the mesh is rebuilt from the scan in the same physical units), labels, colour table, visibility, saved views, undo/redo history, the
brush mode and the command log (:class:`~plantvr.commandlog.CommandLog` text), optionally the volume itself
(small scans) or a path to it.

Layout: ``manifest.json`` (sorted keys) and one ``.npy`` member per array, written in a fixed order with a
fixed time stamp, so saving the same state twice gives the same bytes, on any machine. The zip comment
holds the SHA-256 of every member; a truncated, tampered or foreign file raises ``ValueError`` saying why
and nothing is loaded.
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
from dataclasses import dataclass, field

import numpy as np

from plantvr._fileio import MAX_READ_BYTES, atomic_write, npy_bytes, npy_headers, read_zip, zip_directory
from plantvr._validation import check_int, check_range
from plantvr.commandlog import CommandLog
from plantvr.documents.labels import Segmentation
from plantvr.documents.labels_file import _STATE_NAMES, check_grid
from plantvr.vine._filecheck import check_elements
from plantvr.vine.volume import _check_declared, _check_volume

__all__ = ["Bundle", "load_bundle", "restore_bundle", "save_bundle", "volume_sha256"]

BUNDLE_FORMAT = 2   # 2: the event log is CommandLog text (issue 21)
_MAGIC = "plantvr-vine-bundle"
_STAMP = (1980, 1, 1, 0, 0, 0)
_STORED = ("arrays/vertices.npy", "arrays/normals.npy")

#: Cap on the inflated size of a bundle :func:`load_bundle` reads (bytes), checked before inflating.
MAX_BUNDLE_BYTES = MAX_READ_BYTES


def volume_sha256(volume: np.ndarray) -> str:
    """SHA-256 (hex) of a volume's dtype, shape and C-order bytes (read in slabs; memory maps stay mapped)."""
    vol = np.asarray(volume)
    h = hashlib.sha256(f"{vol.dtype.str}{tuple(vol.shape)}".encode())
    for k in range(vol.shape[0] if vol.ndim else 1):
        h.update(np.ascontiguousarray(vol[k] if vol.ndim else vol).tobytes())
    return h.hexdigest()


@dataclass
class Bundle:
    """What :func:`load_bundle` returns.

    Attributes
    ----------
    segmentation : Segmentation
        The restored session (command log included).
    level : float or None
        Iso-value the mesh was extracted at.
    volume : ndarray or None
        The embedded volume, or the one passed to :func:`load_bundle`.
    volume_sha256 : str or None
    volume_path : str or None
        Where the volume lived when the bundle was saved (a reference only).
    spacing, origin : tuple of 3 float
        The voxel grid the mesh was extracted on (physical units; ``(1, 1, 1)`` and ``(0, 0, 0)`` for bundles
        saved before origins were recorded); also the segmentation's :attr:`~Segmentation.spacing` /
        :attr:`~Segmentation.origin`.
    meta : dict
        Free-form JSON metadata saved with the bundle.
    """

    segmentation: Segmentation
    level: float | None = None
    volume: np.ndarray | None = None
    volume_sha256: str | None = None
    volume_path: str | None = None
    spacing: tuple = (1.0, 1.0, 1.0)
    origin: tuple = (0.0, 0.0, 0.0)
    meta: dict = field(default_factory=dict)


def save_bundle(path: str | os.PathLike, seg, *, volume: np.ndarray | None = None, level: float | None = None,
                include_mesh: bool = True, embed_volume: bool = False, volume_path: str | None = None,
                slab: int = 64, spacing=None, origin=None, meta: dict | None = None) -> str:
    """Write a segmentation session to one bundle file (atomically: temporary file, then rename).

    Parameters
    ----------
    path : path-like
        Target file (``.vine.zip`` suggested).
    seg : Segmentation
        No stroke may be open.
    volume : (X, Y, Z) uint8/16/32, int8/16/32 or float32/64 ndarray, optional
        The source scan; its SHA-256 (dtype included) is stored so :func:`load_bundle` can refuse another scan,
        and an embedded volume keeps its dtype. ``level`` is in the volume's own units.
    level : float, optional
        Iso-value of the mesh (required with ``include_mesh=False``).
    include_mesh : bool
        Store the mesh; ``False`` stores only the volume hash, ``level``, ``slab``, ``spacing`` and ``origin``
        and the mesh is re-extracted on load in the same units (and checked against the stored fingerprint).
    embed_volume : bool
        Store the volume itself (deflated) so the bundle is self-contained.
    volume_path : str, optional
        Reference to where the volume lives.
    slab : int
        Meshing slab, in [2, 65536] (as in :func:`extract_isosurface`).
    spacing : (3,) float, optional
        Voxel size used for meshing, each in (0, 1e6] (default: the segmentation's :attr:`~Segmentation.spacing`,
        ``(1, 1, 1)`` unless it came from :meth:`Segmentation.from_volume` with a spacing).
    origin : (3,) float, optional
        Position of voxel 0, within ±1e6 (default: the segmentation's :attr:`~Segmentation.origin`).
    meta : dict, optional
        JSON-serialisable metadata.

    Returns
    -------
    str
        SHA-256 (hex) of the bundle's contents (also its zip comment).
    """
    if not isinstance(seg, Segmentation):
        raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")  # noqa: TRY004
    if seg._stroke is not None:
        raise ValueError("a stroke is open; end_stroke() before saving a bundle")
    if volume is not None:
        volume = _check_volume("volume", volume)
    if level is not None:
        level = check_range("level", level, -np.inf, np.inf, low_open=True, high_open=True)
    slab = check_int("slab", slab, 2, 65536)
    sp, org = check_grid(seg.spacing if spacing is None else spacing,
                                      seg.origin if origin is None else origin)
    if not include_mesh and (volume is None or level is None):
        raise ValueError("include_mesh=False needs the volume and level to rebuild the mesh on load")
    if embed_volume and volume is None:
        raise ValueError("embed_volume=True needs volume")
    try:
        meta_json = json.loads(json.dumps(meta or {}, sort_keys=True))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"meta must be JSON-serialisable: {exc}") from None
    events = seg.log.to_text()
    arrays = seg._state_arrays(include_mesh=include_mesh)
    if embed_volume:
        arrays["volume"] = np.ascontiguousarray(volume)
    pres = seg.preserve
    manifest = {
        "magic": _MAGIC, "format": BUNDLE_FORMAT, "include_mesh": bool(include_mesh),
        "level": level, "slab": slab, "spacing": list(sp), "origin": list(org),
        "volume_sha256": None if volume is None else volume_sha256(volume),
        "volume_shape": None if volume is None else list(volume.shape),
        "volume_dtype": None if volume is None else volume.dtype.str,
        "volume_path": None if volume_path is None else str(volume_path),
        "volume_embedded": bool(embed_volume),
        "mesh": [seg.n_vertices, len(seg.faces), seg.mesh_fingerprint()],
        "preserve": pres if isinstance(pres, bool) else list(pres),
        "event_log": events, "meta": meta_json,
        "arrays": sorted(arrays),
    }
    members = [("manifest.json", json.dumps(manifest, sort_keys=True, indent=1).encode())]
    members += [(f"arrays/{k}.npy", npy_bytes(arrays[k])) for k in sorted(arrays)]
    digest = _digest(members)
    with atomic_write(path) as fh, zipfile.ZipFile(fh, "w") as z:   # a failed save leaves the old file
        for name, data in members:
            info = zipfile.ZipInfo(name, date_time=_STAMP)
            # float meshes barely deflate (~10 %) and cost most of the time: store them
            info.compress_type = zipfile.ZIP_STORED if name in _STORED else zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, data, compresslevel=1)
        z.comment = f"{_MAGIC} sha256={digest}".encode()
    return digest


def _digest(members) -> str:
    h = hashlib.sha256()
    for name, data in members:
        h.update(name.encode() + b"\0" + len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


def _read(path) -> tuple[dict, dict]:
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise ValueError(f"bundle {p!r} does not exist")
    # sizes first: every array header against what its mesh allows, the total against the cap, unknown
    # members refused, all before anything is inflated
    names, comment = zip_directory(p, what="bundle", max_members=64)
    if "manifest.json" not in names:
        raise ValueError(f"bundle {p!r} has no manifest.json (not a ViNE bundle)")
    heads = npy_headers(p, what="bundle", prefix="arrays/", max_members=64)
    rows = heads.get("vertices", heads.get("labels", ((None,), None)))[0]
    n = int(rows[0]) if len(rows) in (1, 2) and rows[0] is not None else None
    check_elements(heads, Segmentation._element_bounds(n), what="bundle", path=p)
    if "volume" in heads:
        _check_declared(p, *heads["volume"])
    allowed = {"manifest.json"} | {f"arrays/{k}.npy" for k in (*_STATE_NAMES, "volume")}
    data = read_zip(p, what="bundle", max_bytes=MAX_BUNDLE_BYTES, max_members=64, allowed=allowed)
    members = [(k, data.pop(k)) for k in ["manifest.json"] + sorted(k for k in data if k != "manifest.json")]
    comment = comment.decode("ascii", "replace")
    want = comment.partition("sha256=")[2]
    if not comment.startswith(_MAGIC) or not want:
        raise ValueError(f"bundle {p!r} has no PlantVR checksum (not a ViNE bundle)")
    got = _digest(members)
    if got != want:
        raise ValueError(f"bundle {p!r} was modified after saving: content sha256 {got[:12]}… != recorded "
                         f"{want[:12]}…")
    try:
        manifest = json.loads(members[0][1].decode())
    except (UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"bundle {p!r}: manifest.json is not valid JSON: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("magic") != _MAGIC:
        raise ValueError(f"bundle {p!r}: manifest is not a ViNE bundle manifest")
    if manifest.get("format") != BUNDLE_FORMAT:
        raise ValueError(f"bundle {p!r}: format must be {BUNDLE_FORMAT}, got {manifest.get('format')!r}")
    arrays = {}
    for name, blob in members[1:]:
        if not (name.startswith("arrays/") and name.endswith(".npy")):
            raise ValueError(f"bundle {p!r}: unexpected member {name!r}")
        try:
            arrays[name[7:-4]] = np.lib.format.read_array(io.BytesIO(blob), allow_pickle=False)
        except (ValueError, EOFError, SyntaxError) as exc:
            raise ValueError(f"bundle {p!r}: array {name!r} is unreadable: {exc}") from None
    if sorted(arrays) != manifest.get("arrays"):
        raise ValueError(f"bundle {p!r}: arrays {sorted(arrays)} differ from the manifest's list")
    _check_manifest(manifest, p)
    return manifest, arrays


def _is_num(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and bool(np.isfinite(x))


def _check_manifest(man: dict, p: str) -> None:
    """Types and ranges of every manifest field load_bundle uses; raises ``ValueError`` naming the field."""
    def bad(field, want):
        raise ValueError(f"bundle {p!r}: manifest field {field!r} must be {want}, got {man.get(field)!r:.200}")
    if not isinstance(man.get("include_mesh"), bool):
        bad("include_mesh", "true or false")
    if man.get("level") is not None and not _is_num(man["level"]):
        bad("level", "a finite number or null")
    slab = man.get("slab", 64)
    if not (isinstance(slab, int) and not isinstance(slab, bool) and 2 <= slab <= 65536):
        bad("slab", "an integer in [2, 65536]")
    sp = man.get("spacing", [1.0, 1.0, 1.0])
    if not (isinstance(sp, list) and len(sp) == 3 and all(_is_num(x) and 0 < x <= 1e6 for x in sp)):
        bad("spacing", "3 numbers in (0, 1e6]")
    org = man.get("origin", [0.0, 0.0, 0.0])
    if not (isinstance(org, list) and len(org) == 3 and all(_is_num(x) and abs(x) <= 1e6 for x in org)):
        bad("origin", "3 numbers within ±1e6")
    sha = man.get("volume_sha256")
    if sha is not None and not (isinstance(sha, str) and len(sha) == 64):
        bad("volume_sha256", "a 64-digit hex string or null")
    if man.get("volume_path") is not None and not isinstance(man["volume_path"], str):
        bad("volume_path", "a string or null")
    mesh = man.get("mesh")
    if not (isinstance(mesh, list) and len(mesh) == 3 and all(isinstance(x, int) and x >= 0 for x in mesh)):
        bad("mesh", "3 non-negative integers (vertices, faces, fingerprint)")
    pres = man.get("preserve", False)
    if not (isinstance(pres, bool) or (isinstance(pres, list) and all(isinstance(x, int) for x in pres))):
        bad("preserve", "true, false or a list of labels")
    if not isinstance(man.get("event_log"), str):
        bad("event_log", "command log text")
    if not isinstance(man.get("meta", {}), dict):
        bad("meta", "an object")


def load_bundle(path: str | os.PathLike, *, volume: np.ndarray | None = None, index: str = "grid") -> Bundle:
    """Open a bundle written by :func:`save_bundle`.

    Parameters
    ----------
    path : path-like
    volume : (X, Y, Z) ndarray, optional
        The source scan. Required when the bundle holds neither the mesh nor the volume; if the bundle
        recorded a volume hash, a volume with another hash is refused.
    index : {"grid", "kdtree"}
        Brush index of the restored segmentation.

    Returns
    -------
    Bundle

    Raises
    ------
    ValueError
        Truncated, tampered or foreign file, wrong volume, or a mesh that does not rebuild identically; the
        message says which.
    """
    p = os.fspath(path)
    man, arrays = _read(p)
    grid = check_grid(man.get("spacing", (1.0, 1.0, 1.0)), man.get("origin", (0.0, 0.0, 0.0)))
    want = man.get("volume_sha256")
    if volume is not None:
        volume = _check_volume("volume", volume)
        if want is not None:
            got = volume_sha256(volume)
            if got != want:
                raise ValueError(f"bundle {p!r} was made from a volume with sha256 {want[:16]}…, but the given "
                                 f"volume hashes to {got[:16]}… (shape {list(volume.shape)}, "
                                 f"{volume.dtype}); pass the scan the bundle was made from")
    if "volume" in arrays:
        emb = arrays.pop("volume")
        if want is not None and volume_sha256(emb) != want:
            raise ValueError(f"bundle {p!r}: the embedded volume does not match its recorded sha256")
        volume = emb if volume is None else volume
    if not man["include_mesh"]:
        if volume is None:
            raise ValueError(f"bundle {p!r} holds no mesh and no volume; pass volume= (the scan with sha256 "
                             f"{str(want)[:16]}…) to rebuild the mesh")
        base = Segmentation.from_volume(volume, man["level"], slab=int(man["slab"]), spacing=grid[0],
                                        origin=grid[1])
        if [base.n_vertices, len(base.faces), base.mesh_fingerprint()] != man["mesh"]:
            raise ValueError(f"bundle {p!r}: the mesh rebuilt from the volume differs from the saved one "
                             f"(vertices, faces, fingerprint) {man['mesh']}")
        d = Segmentation._check_state(arrays, p, base)
    else:
        d = Segmentation._check_state(arrays, p)
    seg = Segmentation._from_state(d, index=index)
    seg.spacing, seg.origin = grid
    if [seg.n_vertices, len(seg.faces), seg.mesh_fingerprint()] != man["mesh"]:
        raise ValueError(f"bundle {p!r}: mesh does not match the manifest's fingerprint")
    pres = man.get("preserve", False)
    seg.preserve = seg.check_preserve(pres if isinstance(pres, bool) else tuple(pres))
    try:
        log = CommandLog.from_text(man["event_log"], where=f"bundle {p!r}", commands=Segmentation.COMMANDS,
                                   document=Segmentation.KIND)
    except ValueError as exc:
        raise ValueError(f"bundle {p!r}: manifest field 'event_log' is not a ViNE command log: {exc}") from None
    seg.log.events = log.events
    return Bundle(seg, level=man.get("level"), volume=volume, volume_sha256=want,
                  volume_path=man.get("volume_path"), spacing=grid[0], origin=grid[1], meta=man.get("meta", {}))


def restore_bundle(seg, path: str | os.PathLike, *, volume: np.ndarray | None = None) -> Bundle:
    """Replace ``seg``'s state with a bundle's (observers stay and get one ``"all"`` change).

    On any error ``seg`` is left unchanged.
    """
    if not isinstance(seg, Segmentation):
        raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")  # noqa: TRY004
    b = load_bundle(path, volume=volume, index=seg.index_kind)
    pres = b.segmentation.preserve
    seg._adopt(b.segmentation, log=True, command="restore_bundle")
    seg.preserve = pres
    b.segmentation = seg
    return b
