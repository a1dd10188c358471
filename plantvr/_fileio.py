"""Atomic writes and bounded reads shared by every PlantVR file format (issue 20: nothing loses work).

Every save goes through :func:`atomic_write`: the bytes go to a temporary file in the target's folder,
are flushed and fsync-ed, then renamed over the target, so a save that fails half way (disk full, a bad
value met while writing, a killed kernel) leaves the previous file as it was and no temporary file behind.

Every zip/npz read goes through :func:`read_npz` or :func:`read_zip`: the member list and each member's
declared size (and, for ``.npy`` members, the array header) are checked against a stated cap *before*
anything is inflated, so a zip bomb is refused at the cost of reading its central directory. ``zipfile``
never inflates past a member's declared size, so the declared sizes bound the memory a read can take.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import struct
import tempfile
import tokenize
import zipfile
import zlib
from collections.abc import Collection, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = ["MAX_JSON_BYTES", "MAX_READ_BYTES", "MAX_TEXT_BYTES", "TextDecodeError", "read_json", "read_text", "atomic_write", "check_target", "make_folder", "write_atomic", "write_npz", "write_png", "read_npz", "read_zip",
           "npy_bytes", "npy_headers", "zip_directory", "digest_arrays"]

#: What a corrupt zip member can raise while it is read (``zlib.error``: a damaged deflate stream; ``SyntaxError``,
#: ``tokenize.TokenError``: a damaged ``.npy`` header dict, which numpy parses as Python).
_READ_ERRORS = (OSError, EOFError, zipfile.BadZipFile, RuntimeError, NotImplementedError, zlib.error, struct.error,
                SyntaxError, tokenize.TokenError)

#: Default cap on the inflated size of one zip/npz file PlantVR reads (bytes). Readers of formats whose
#: files are bigger by design (a 36 M-face segmentation with its mesh) pass a larger ``max_bytes``.
MAX_READ_BYTES = 16 * 2**30


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb") -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on a clean exit it replaces ``path`` atomically.

    On any exception the temporary file is removed and ``path`` is left untouched.

    Parameters
    ----------
    path : path-like
        The file to (re)write. Its folder must exist.
    mode : {"wb", "w"}
        Binary or text (UTF-8) mode.
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"mode must be 'wb' or 'w', got {mode!r}")
    path = Path(path)
    folder = check_target(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, mode, **({"encoding": "utf-8", "newline": ""} if mode == "w" else {})) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        with contextlib.suppress(OSError):  # keep the target's permissions when overwriting
            os.chmod(tmp, os.stat(path).st_mode & 0o7777 if path.exists() else 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    with contextlib.suppress(OSError):  # make the rename itself durable
        dfd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


def check_target(path: str | os.PathLike, *, name: str = "path") -> Path:
    """The one rule every PlantVR writer follows before it writes: the target's folder must already exist (no
    writer creates folders, so a typo in a folder name is an error, not a new folder tree) and the target must
    not be a folder. Returns the folder (``.`` for a bare file name).

    Raises
    ------
    ValueError
        Naming ``name``, the path and what is wrong.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"{name} must be a file path, got {type(path).__name__}")  # noqa: TRY004
    path = Path(path)
    if not path.name:
        raise ValueError(f"{name} must name a file, got {os.fspath(path)!r}")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise ValueError(f"cannot write {os.fspath(path)!r}: folder {os.fspath(folder)!r} {what} (create it "
                         f"first; {name} must be in an existing folder)")
    if path.is_dir():
        raise ValueError(f"cannot write {os.fspath(path)!r}: {name} is a folder, not a file")
    return folder


def make_folder(folder: str | os.PathLike, *, name: str = "folder") -> Path:
    """The folder a multi-file writer (a frame sequence, a tree library) writes into: created if missing, one level
    only, under :func:`check_target`'s rule (its own folder must already exist). Returns it as a ``Path``.

    Raises
    ------
    ValueError
        Naming ``name`` and the path: its parent folder does not exist, or it exists and is not a folder.
    """
    if not isinstance(folder, (str, os.PathLike)):
        raise ValueError(f"{name} must be a folder path, got {type(folder).__name__}")  # noqa: TRY004
    folder = Path(folder)
    if folder.is_dir():
        return folder
    if folder.exists():
        raise ValueError(f"{name} {os.fspath(folder)!r} exists and is not a folder")
    parent = folder.parent if str(folder.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"cannot create {name} {os.fspath(folder)!r}: its folder {os.fspath(parent)!r} does not "
                         f"exist (create it first; no writer creates folders above its own)")
    try:
        folder.mkdir(exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot create {name} {os.fspath(folder)!r}: {exc.strerror or exc}") from None
    return folder


def write_atomic(path: str | os.PathLike, data: bytes | str) -> Path:
    """Write ``data`` (bytes, or text as UTF-8) to ``path`` atomically; returns the path."""
    with atomic_write(path, "w" if isinstance(data, str) else "wb") as fh:
        fh.write(data)
    return Path(path)


def write_npz(path: str | os.PathLike, arrays: Mapping[str, np.ndarray], *, compress: bool = True) -> Path:
    """Write ``arrays`` as an ``.npz`` file atomically (no pickles: an object array is refused before anything is
    written); returns the path."""
    arrays = {k: np.asanyarray(v) for k, v in arrays.items()}
    for k, v in arrays.items():
        if v.dtype.hasobject:
            raise ValueError(f"arrays[{k!r}] must be a numeric, bool or string array (no Python objects: .npz files "
                             f"are read without pickles), got dtype {v.dtype}")
    with atomic_write(path) as fh:
        (np.savez_compressed if compress else np.savez)(fh, allow_pickle=False, **arrays)
    return Path(path)


def write_png(path: str | os.PathLike, image: np.ndarray) -> Path:
    """Write an (H, W, 3|4) uint8 image as a PNG atomically (screenshots, thumbnails, atlases)."""
    if Path(path).suffix.lower() != ".png":
        raise ValueError(f"path must end in .png, got {os.fspath(path)!r}")
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
        raise ValueError(f"image must be (H, W, 3 or 4) uint8, got {img.dtype} {img.shape}")
    from PIL import Image  # noqa: PLC0415
    with atomic_write(path) as fh:
        Image.fromarray(img).save(fh, format="PNG")
    return Path(path)


def _zip_error(what: str, path, msg: str) -> ValueError:
    return ValueError(f"cannot read {what} {os.fspath(path)!r}: {msg}")


def _open_zip(path, what: str) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(path)
    except (OSError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, NotImplementedError,
            struct.error) as exc:  # a flipped bit in the central directory: "zip file version 14.8"
        raise _zip_error(what, path, f"corrupt, truncated or not a zip file ({exc})") from None


def _check_members(z: zipfile.ZipFile, path, what: str, *, max_bytes: int, max_members: int,
                   allowed: Collection[str] | None) -> list[zipfile.ZipInfo]:
    infos = z.infolist()
    if len(infos) > max_members:
        raise _zip_error(what, path, f"{len(infos)} members, more than the {max_members} allowed")
    names = [i.filename for i in infos]
    if len(set(names)) != len(names):
        raise _zip_error(what, path, "duplicate member names")
    if allowed is not None:
        extra = sorted(set(names) - set(allowed))
        if extra:
            raise _zip_error(what, path, f"unexpected members {extra[:5]}")
    total = sum(i.file_size for i in infos)
    if total > max_bytes:
        raise _zip_error(what, path, f"members declare {total} bytes inflated, more than the cap of {max_bytes}")
    return infos


def read_zip(path: str | os.PathLike, *, what: str = "file", max_bytes: int = MAX_READ_BYTES,
             max_members: int = 10_000, allowed: Collection[str] | None = None) -> dict[str, bytes]:
    """Return ``{member name: bytes}`` of a zip file whose declared sizes fit ``max_bytes``.

    Raises ``ValueError`` naming ``what`` and the path for a corrupt, truncated or oversized file.
    """
    with _open_zip(path, what) as z:
        infos = _check_members(z, path, what, max_bytes=max_bytes, max_members=max_members, allowed=allowed)
        try:
            return {i.filename: z.read(i) for i in infos}
        except (*_READ_ERRORS, ValueError) as exc:
            raise _zip_error(what, path, f"corrupt member ({exc})") from None


def read_npz(path: str | os.PathLike, *, what: str = "file", max_bytes: int = MAX_READ_BYTES,
             max_members: int = 1_000, allowed: Collection[str] | None = None) -> dict[str, np.ndarray]:
    """Return the arrays of an ``.npz`` file, each header checked before its data is inflated.

    Each member must be a ``.npy`` whose header declares a non-object dtype and a shape whose byte size
    matches the member's declared size; the sum of declared sizes must fit ``max_bytes``. ``allowed``
    (array names, without ``.npy``) refuses unknown members.

    Raises
    ------
    ValueError
        Naming ``what`` and the path: not a zip, truncated, bit-flipped (CRC), a bomb, a pickle, a header
        that lies about its size.
    """
    allowed_members = None if allowed is None else {f"{n}.npy" for n in allowed}
    out: dict[str, np.ndarray] = {}
    with _open_zip(path, what) as z:
        infos = _check_members(z, path, what, max_bytes=max_bytes, max_members=max_members,
                               allowed=allowed_members)
        for info in infos:
            name = info.filename
            if not name.endswith(".npy"):
                raise _zip_error(what, path, f"member {name!r} is not a .npy array")
            bad, corrupt = f"array {name[:-4]!r} is unreadable", f"corrupt member {name!r}"
            with _member_errors(what, path, bad, corrupt), z.open(info) as fh:
                shape, fortran, dtype = _read_header(fh, path, what, name)
                n = int(np.prod(shape, dtype=object)) * dtype.itemsize
                if n != info.file_size - fh.tell():
                    raise _zip_error(what, path, f"array {name[:-4]!r} declares {n} bytes of data but its "
                                     f"member holds {info.file_size - fh.tell()}")
                data = bytearray(n)
                if fh.readinto(memoryview(data)) != n:
                    raise _zip_error(what, path, f"array {name[:-4]!r} is truncated")
            arr = np.frombuffer(data, dtype=dtype)
            out[name[:-4]] = arr.reshape(shape, order="F" if fortran else "C")
    return out


@contextlib.contextmanager
def _member_errors(what: str, path, bad: str, corrupt: str) -> Iterator[None]:
    """Turn what reading one zip member raises into a clear ``ValueError``: ``bad (why)`` for a damaged
    header or array, ``corrupt (why)`` for damaged zip data; this module's own ``cannot read ...`` errors
    pass as they are."""
    try:
        yield
    except ValueError as exc:
        if str(exc).startswith("cannot read"):
            raise
        raise _zip_error(what, path, f"{bad} ({exc})") from None
    except _READ_ERRORS as exc:
        raise _zip_error(what, path, f"{corrupt} ({exc})") from None


def _read_header(fh, path, what: str, name: str) -> tuple[tuple, bool, np.dtype]:
    """(shape, fortran order, dtype) from an open ``.npy`` member, refusing object arrays."""
    version = np.lib.format.read_magic(fh)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    try:
        shape, fortran, dtype = read(fh, max_header_size=10_000)
    except (SyntaxError, tokenize.TokenError) as exc:  # a damaged header dict (numpy parses it as Python)
        raise ValueError(f"header is not a .npy header ({exc})") from None
    if dtype.hasobject:
        raise _zip_error(what, path, f"array {name[:-4]!r} holds Python objects (refused)")
    return tuple(int(x) for x in shape), fortran, dtype


def npy_headers(path: str | os.PathLike, *, what: str = "file", prefix: str = "",
                max_members: int = 1_000) -> dict[str, tuple[tuple, np.dtype]]:
    """``{array name: (shape, dtype)}`` of the ``.npy`` members under ``prefix``, inflating only their headers.

    Lets a reader refuse an array larger than its format allows (labels longer than the mesh) before
    :func:`read_npz` inflates anything. Raises ``ValueError`` like :func:`read_npz`.
    """
    out: dict[str, tuple[tuple, np.dtype]] = {}
    with _open_zip(path, what) as z:
        infos = _check_members(z, path, what, max_bytes=2**63, max_members=max_members, allowed=None)
        for info in infos:
            name = info.filename
            if not (name.startswith(prefix) and name.endswith(".npy")):
                continue
            bad = f"array {name[:-4]!r} has an unreadable header"
            with _member_errors(what, path, bad, bad), z.open(info) as fh:
                shape, _fortran, dtype = _read_header(fh, path, what, name)
            out[name[len(prefix):-4]] = (shape, dtype)
    return out


def zip_directory(path: str | os.PathLike, *, what: str = "file", max_members: int = 1_000
                  ) -> tuple[list[str], bytes]:
    """Member names and the zip comment, from the central directory only (nothing is inflated)."""
    with _open_zip(path, what) as z:
        infos = _check_members(z, path, what, max_bytes=2**63, max_members=max_members, allowed=None)
        return [i.filename for i in infos], z.comment


def digest_arrays(arrays: Mapping[str, np.ndarray]) -> str:
    """SHA-256 (hex) over the names, dtypes, shapes and bytes of ``arrays`` in name order (a checksum)."""
    h = hashlib.sha256()
    for k in sorted(arrays):
        a = np.ascontiguousarray(arrays[k])
        h.update(f"{k}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(memoryview(a).cast("B") if a.size else b"")
    return h.hexdigest()


def npy_bytes(a: np.ndarray) -> bytes:
    """``.npy`` bytes of ``a`` with its shape kept (0-d included), no pickles (members of zip formats)."""
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.array(a, order="C", copy=True), allow_pickle=False)
    return buf.getvalue()


#: Largest PlantVR JSON file (preset, stroke file) read, in bytes.
MAX_JSON_BYTES = 64 * 2**20
#: Largest text file (scripts, grammars, point and props files) a reader accepts, in bytes.
MAX_TEXT_BYTES = 1 << 30


class TextDecodeError(ValueError):
    """A file that is not UTF-8 text; ``line`` and ``column`` (1-based) locate its first bad byte."""

    def __init__(self, message: str, line: int, column: int):
        super().__init__(message)
        self.line, self.column = line, column


def read_text(path: str | os.PathLike, *, what: str = "file", max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of the file at ``path`` (the one text reader of the package: scripts, grammars, point, props
    and JSON files), or a ``ValueError`` naming ``what`` and the path: not a path, missing, not a file, larger
    than ``max_bytes``, unreadable, or not UTF-8 (:class:`TextDecodeError`, with the bad byte's line and column)."""
    try:
        p = Path(path)
    except TypeError:
        raise ValueError(f"{what} path must be a path, got {type(path).__name__}") from None
    try:
        size = p.stat().st_size
        if not p.is_file():
            raise ValueError(f"{what} {str(p)!r} is not a file")
        if size > max_bytes:
            raise ValueError(f"{what} {str(p)!r} has {size} bytes, more than the {max_bytes} allowed")
        raw = p.read_bytes()
    except FileNotFoundError:
        raise ValueError(f"{what} {str(p)!r} does not exist") from None
    except OSError as exc:
        raise ValueError(f"cannot read {what} {str(p)!r}: {exc}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        col = e.start - (raw.rfind(b"\n", 0, e.start) + 1) + 1
        raise TextDecodeError(f"{what} {str(p)!r} is not UTF-8 text (byte {raw[e.start]:#04x} at offset "
                              f"{e.start})", line, col) from None


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a finite number")


def read_json(path: Path, kind: str) -> Any:
    """The parsed JSON of a PlantVR file (preset, stroke file, log header); a ValueError naming the ``kind`` of file and
    its path when it is missing, too large, unreadable, not JSON, or holds NaN/Infinity or nesting too deep."""
    text = read_text(path, what=kind, max_bytes=MAX_JSON_BYTES)
    try:
        return json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{kind} {path!s} is not valid JSON ({exc.msg}, line {exc.lineno})") from None
    except RecursionError:
        raise ValueError(f"{kind} {path!s} is nested too deeply") from None
    except ValueError as exc:
        if str(exc).startswith(kind):
            raise
        raise ValueError(f"{kind} {path!s}: {exc}") from None
