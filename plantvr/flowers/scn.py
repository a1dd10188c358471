"""FCComposer scene inputs: SCN placements and RBA rigid-body animation series (spec 002 §3.8, §4.5; C16).

SCN (App. C.2): one placement per line, ``type: id pos_x pos_y pos_z scale_x scale_y scale_z up_x up_y up_z
right_x right_y right_z [type fields]``; ``mtl: matID`` right after an entry assigns a material; ``#`` starts
a comment line. RBA (App. C.3): one file per moment, each line ``id pos(3) scale(3) up(3) right(3)`` where
``id`` is the index of the placement in the companion SCN file. Numbers are written in their shortest
round-trip form, so write -> read returns identical values. A malformed file raises ``ValueError`` naming
the file, the line and what is wrong.
"""
from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plantvr._fileio import make_folder, read_text, write_atomic
from plantvr._validation import MAX_COORD, check_array, check_choice, check_int, check_range

__all__ = [
    "SCN_TYPES",
    "Placement",
    "RigidBodyFrame",
    "format_rba",
    "format_scn",
    "load_scene_tree",
    "parse_rba",
    "parse_scn",
    "placements_from_arrays",
    "rba_at",
    "read_rba",
    "read_rba_sequence",
    "read_scn",
    "scene_from_frames",
    "write_rba",
    "write_rba_sequence",
    "write_scn",
]

#: Entry types of App. C.2 and their type-specific field names (after the 13-number preamble).
SCN_TYPES: dict[str, tuple[str, ...]] = {
    "o": (),                                                   # place OBJ
    "ca": ("frame_start", "frame_end"),                        # constraint based animation
    "i": ("interpolation",),         # ERRATUM A.13: "interploationValue"; interpolated instance of animation
    "ta": ("frame_start", "frame_end", "x", "y", "z"),         # translate geometry animation
    "ra": ("frame_start", "frame_end", "x", "y", "z", "angle"),  # rotate around axis by an angle
    "rba": ("frame_start", "frame_end"),                       # rigid body animation
}
#: Number of material definitions (App. C.2: "256 material definitions").
N_MATERIALS = 256
_PREAMBLE = 13
#: Largest SCN/RBA file a reader accepts (bytes) and largest magnitude of a frame number / type field.
MAX_FILE_BYTES = 1 << 30
MAX_FIELD = 1e12


def _fmt(v: float) -> str:
    """Shortest text that reads back to exactly ``v`` (integers without a decimal point)."""
    v = float(v)
    if v == 0.0 and np.signbit(v):
        return "-0"
    if v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


@dataclass(frozen=True)
class Placement:
    """One SCN entry (App. C.2).

    Attributes
    ----------
    kind : str
        One of :data:`SCN_TYPES` (``"o"``, ``"ca"``, ``"i"``, ``"ta"``, ``"ra"``, ``"rba"``).
    id : int
        ``obj`` / ``animation`` / ``rigid body animation`` entry of the parameter file.
    position, scale, up, right : tuple of 3 float
        Placement frame as written (``right`` is the 4th vector; the example's "Left" is ERRATUM A.9).
    extra : tuple of float
        The type's own fields, named by ``SCN_TYPES[kind]``.
    material : int or None
        ``mtl:`` material index in [0, 255], if any.
    """

    kind: str
    id: int
    position: tuple
    scale: tuple
    up: tuple
    right: tuple
    extra: tuple = ()
    material: int | None = None

    def __post_init__(self):
        check_choice("kind", self.kind, tuple(SCN_TYPES))
        object.__setattr__(self, "id", check_int("id", self.id, 0, 2**62))
        for name in ("position", "scale", "up", "right"):   # a position is any finite float (pure data)
            v = check_array(name, getattr(self, name), shape=(3,), max_abs=None if name == "position" else MAX_COORD)
            object.__setattr__(self, name, tuple(float(x) for x in v))
        if not np.all(np.asarray(self.scale) > 0):
            raise ValueError(f"scale must be > 0 on every axis, got {self.scale}")
        up, right = np.asarray(self.up), np.asarray(self.right)
        nu, nr = np.linalg.norm(up), np.linalg.norm(right)
        if nu == 0 or nr == 0 or np.linalg.norm(np.cross(up, right)) <= 1e-12 * nu * nr:
            raise ValueError(f"up must be non-zero and right not parallel to it, got up={self.up}, "
                             f"right={self.right}")
        names = SCN_TYPES[self.kind]
        extra = check_array("extra", self.extra, shape=(len(names),), max_abs=MAX_FIELD)
        object.__setattr__(self, "extra", tuple(float(x) for x in extra))
        if "frame_start" in names and self.extra[1] < self.extra[0]:
            raise ValueError(f"frame_end must be >= frame_start, got {self.extra[0]} .. {self.extra[1]}")
        if self.material is not None:
            object.__setattr__(self, "material", check_int("material", self.material, 0, N_MATERIALS - 1))

    def field(self, name: str) -> float:
        """A type-specific field by name, e.g. ``p.field("frame_end")``."""
        names = SCN_TYPES[self.kind]
        if name not in names:
            raise ValueError(f"{self.kind!r} entries have fields {list(names)}, got {name!r}")
        return self.extra[names.index(name)]

    def frame(self) -> np.ndarray:
        """(3, 3) float64 rotation with orthonormal columns (right, up, right x up).

        ``up`` is normalised and ``right`` made orthogonal to it, as spec §3.8 proposes; local +x maps to
        ``right`` and local +y to ``up`` (the y-up floret OBJs of the thesis's example).
        """
        up = np.asarray(self.up) / np.linalg.norm(self.up)
        right = np.asarray(self.right) - np.dot(self.right, up) * up
        right /= np.linalg.norm(right)
        return np.column_stack([right, up, np.cross(right, up)])

    def transform(self, x_local: np.ndarray) -> np.ndarray:
        """World positions ``pos + [right | up | right x up] (scale * x_local)`` (spec §3.8 [INFERRED]).

        Parameters
        ----------
        x_local : (V, 3) float64 array_like
            Vertices of the placed object in its own (y-up) coordinates.

        Returns
        -------
        (V, 3) float64 ndarray
        """
        x = check_array("x_local", x_local, shape=(None, 3))
        return np.asarray(self.position) + (x * np.asarray(self.scale)) @ self.frame().T

    def line(self) -> str:
        """The entry as one SCN line (without its ``mtl`` line)."""
        nums = (self.id, *self.position, *self.scale, *self.up, *self.right, *self.extra)
        return f"{self.kind}: " + " ".join(_fmt(v) for v in nums)


def _content_lines(text: str, source: str):
    """Yield ``(where, line)`` for each stripped line of ``text`` that is neither blank nor a ``#`` comment."""
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")  # noqa: TRY004
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line and not line.startswith("#"):
            yield f"{source}, line {lineno}", line


def _entry_numbers(tokens: list[str], where: str) -> list[float]:
    """Numbers of an SCN/RBA entry whose first field is a non-negative integer id."""
    v = _numbers(tokens, where)
    if not v[0].is_integer() or v[0] < 0 or v[0] > 2**62:
        raise ValueError(f"{where}: id must be a non-negative integer (at most 2**62), got {tokens[0]!r}")
    return v


def _numbers(tokens: list[str], where: str) -> list[float]:
    out = []
    for t in tokens:
        try:
            v = float(t)
        except ValueError:
            raise ValueError(f"{where}: {t!r} is not a number") from None
        if not np.isfinite(v):
            raise ValueError(f"{where}: numbers must be finite, got {t!r}")
        out.append(v)
    return out


_COMPACT = re.compile(r"^[0-9]{3}$")


def _expand_compact(tokens: list[str], n_extra: int) -> list[str]:
    """The App. C.2 example prints vectors as "000 111 010 100"; read each digit as a component [INFERRED]."""
    if len(tokens) == 1 + 4 + n_extra and all(_COMPACT.match(t) for t in tokens[1:5]):
        return [tokens[0], *[c for t in tokens[1:5] for c in t], *tokens[5:]]
    return tokens


def parse_scn(text: str, *, source: str = "<scn>") -> list[Placement]:
    """Parse SCN text into placements (App. C.2).

    Parameters
    ----------
    text : str
        File contents.
    source : str
        Name used in error messages.

    Returns
    -------
    list of Placement

    Raises
    ------
    ValueError
        On an unknown type, a wrong field count, a non-numeric or non-finite number, a non-integer id, an
        ``mtl`` line without a preceding entry (or a second one), or an invalid frame.

    References
    ----------
    .. [1] Owens 2016, Ch. 8 d–f and App. C.2 (entry types); ERRATUM A.9 (4th vector is "right") and A.13
       ("interploationValue"). Reading the example's run-together vectors ("000 111 010 100") digit by digit
       is [INFERRED].
    """
    out: list[Placement] = []
    mtl_done = True
    for where, line in _content_lines(text, source):
        kind, colon, rest = line.partition(":")
        kind = kind.strip()
        if not colon:
            raise ValueError(f"{where}: expected 'type: fields', got {line!r}")
        tokens = rest.split()
        if kind == "mtl":
            if not out or mtl_done:
                raise ValueError(f"{where}: 'mtl:' must follow a placement entry (once per entry)")
            if len(tokens) != 1:
                raise ValueError(f"{where}: 'mtl:' takes one material index, got {len(tokens)} fields")
            m = _numbers(tokens, where)[0]
            if not (m.is_integer() and 0 <= m < N_MATERIALS):
                raise ValueError(f"{where}: material index must be an integer in [0, {N_MATERIALS - 1}], got "
                                 f"{tokens[0]!r}")
            p = out[-1]
            out[-1] = Placement(p.kind, p.id, p.position, p.scale, p.up, p.right, p.extra, int(m))
            mtl_done = True
            continue
        if kind not in SCN_TYPES:
            raise ValueError(f"{where}: unknown entry type {kind!r}; expected one of {[*SCN_TYPES, 'mtl']}")
        n_extra = len(SCN_TYPES[kind])
        tokens = _expand_compact(tokens, n_extra)
        if len(tokens) != _PREAMBLE + n_extra:
            names = ", ".join(("id", "position", "scale", "up", "right", *SCN_TYPES[kind]))
            raise ValueError(f"{where}: {kind!r} entries have {_PREAMBLE + n_extra} fields ({names}), "
                             f"got {len(tokens)}")
        v = _entry_numbers(tokens, where)
        try:
            out.append(Placement(kind, int(v[0]), v[1:4], v[4:7], v[7:10], v[10:13], tuple(v[13:])))
        except ValueError as err:
            raise ValueError(f"{where}: {err}") from None
        mtl_done = False
    return out


def format_scn(placements: Sequence[Placement], *, header: bool = True) -> str:
    """SCN text of ``placements`` (each followed by its ``mtl`` line when it has a material)."""
    # ERRATUM A.9: the example's comment says "Up Left"; the 4th vector is "right" as in the field list
    lines = ["# type: ID Position Scale Up Right [type fields]"] if header else []
    for k, p in enumerate(placements):
        if not isinstance(p, Placement):
            raise ValueError(f"placements[{k}] must be a Placement, got {type(p).__name__}")  # noqa: TRY004
        lines.append(p.line())
        if p.material is not None:
            lines.append(f"mtl: {p.material}")
    return "\n".join(lines) + "\n"


def write_scn(path, placements: Sequence[Placement]) -> Path:
    """Write an SCN file atomically (a failed write leaves the old file); returns its path."""
    text = format_scn(placements)                             # validates before touching the file
    path = Path(path)
    write_atomic(path, text)
    return path


def read_scn(path) -> list[Placement]:
    """Read an SCN file (see :func:`parse_scn`)."""
    return parse_scn(read_text(path, what="SCN file", max_bytes=MAX_FILE_BYTES), source=str(path))


# -------------------------------------------------------------------------------------------------------
# RBA


@dataclass(frozen=True)
class RigidBodyFrame:
    """One RBA file: placements of SCN entries at one moment (App. C.3).

    Attributes
    ----------
    ids : (n,) int64 ndarray
        Index of the placement in the companion SCN file (unique within a file).
    position, scale, up, right : (n, 3) float64 ndarray
    """

    ids: np.ndarray
    position: np.ndarray
    scale: np.ndarray
    up: np.ndarray
    right: np.ndarray

    def __post_init__(self):
        ids = check_array("ids", self.ids, shape=(None,), dtype=np.int64)
        n = ids.size
        object.__setattr__(self, "ids", ids)
        for name in ("position", "scale", "up", "right"):
            object.__setattr__(self, name, check_array(name, getattr(self, name), shape=(n, 3),
                                                       max_abs=None if name == "position" else MAX_COORD))
        if n and (ids.min() < 0 or ids.max() > 2**62):
            raise ValueError(f"ids must be in [0, 2**62], got range [{ids.min()}, {ids.max()}]")
        if np.unique(ids).size != n:
            raise ValueError("ids must be unique within one RBA file")
        if np.any(self.scale <= 0):
            raise ValueError("scale must be > 0 on every axis")
        if n and (np.any(np.linalg.norm(self.up, axis=1) == 0)
                  or np.any(np.linalg.norm(np.cross(self.up, self.right), axis=1) == 0)):
            raise ValueError("up must be non-zero and right not parallel to it in every row")

    def __eq__(self, other) -> bool:
        return isinstance(other, RigidBodyFrame) and all(
            np.array_equal(getattr(self, k), getattr(other, k))
            for k in ("ids", "position", "scale", "up", "right"))

    __hash__ = None


def parse_rba(text: str, *, source: str = "<rba>") -> RigidBodyFrame:
    """Parse one RBA file's text; ``#`` comment lines and blank lines are skipped.

    Parameters
    ----------
    text : str
        The RBA file's text: one line ``id x y z sx sy sz ux uy uz rx ry rz`` per placed entry.
    source : str
        File name that error messages start with.

    Returns
    -------
    RigidBodyFrame

    References
    ----------
    .. [1] Owens 2016, App. C.3 and Fig. 8.2 (ids index the companion SCN file's entries).
    """
    rows = []
    for where, line in _content_lines(text, source):
        tokens = line.split()
        if len(tokens) != _PREAMBLE:
            raise ValueError(f"{where}: RBA lines have {_PREAMBLE} fields (id, position, scale, up, right), "
                             f"got {len(tokens)}")
        rows.append(_entry_numbers(tokens, where))
    a = np.array(rows, dtype=np.float64).reshape(len(rows), _PREAMBLE)
    try:
        return RigidBodyFrame(a[:, 0].astype(np.int64), a[:, 1:4], a[:, 4:7], a[:, 7:10], a[:, 10:13])
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from None


def format_rba(frame: RigidBodyFrame) -> str:
    """RBA text of one frame."""
    if not isinstance(frame, RigidBodyFrame):
        raise ValueError(f"frame must be a RigidBodyFrame, got {type(frame).__name__}")  # noqa: TRY004
    lines = []
    for k in range(frame.ids.size):
        nums = (frame.ids[k], *frame.position[k], *frame.scale[k], *frame.up[k], *frame.right[k])
        lines.append(" ".join(_fmt(v) for v in nums))
    return "\n".join(lines) + ("\n" if lines else "")


def write_rba(path, frame: RigidBodyFrame) -> Path:
    """Write one RBA file; returns its path."""
    text = format_rba(frame)
    path = Path(path)
    write_atomic(path, text)
    return path


def read_rba(path) -> RigidBodyFrame:
    """Read one RBA file."""
    return parse_rba(read_text(path, what="RBA file", max_bytes=MAX_FILE_BYTES), source=str(path))


_NUMBERED = re.compile(r"^(.*?)(\d+)\.rba$")


def write_rba_sequence(folder, frames: Sequence[RigidBodyFrame], *, prefix: str = "frame_") -> list[Path]:
    """Write ``frames`` as ``<prefix>0000.rba``, ``<prefix>0001.rba``, ... into ``folder`` (created, one level)."""
    frames = list(frames)
    for k, f in enumerate(frames):
        if not isinstance(f, RigidBodyFrame):
            raise ValueError(f"frames[{k}] must be a RigidBodyFrame, got {type(f).__name__}")  # noqa: TRY004
    if not re.fullmatch(r"[A-Za-z0-9_.-]*", prefix) or (prefix and prefix[-1].isdigit()):
        raise ValueError(f"prefix must be letters, digits, '_', '-', '.' and not end in a digit, "
                         f"got {prefix!r}")
    folder = make_folder(folder)             # one level; its parent must exist (plantvr._fileio's rule)
    width = max(4, len(str(max(len(frames) - 1, 0))))
    texts = [format_rba(f) for f in frames]                   # all formatted before any file is touched
    paths = [folder / f"{prefix}{k:0{width}d}.rba" for k in range(len(frames))]
    for path, text in zip(paths, texts):
        write_atomic(path, text)
    # frames of an earlier, longer sequence would be read back as part of this one: remove them
    keep = {p.name for p in paths}
    for p in folder.iterdir():
        m = _NUMBERED.match(p.name)
        if m and m.group(1) == prefix and p.name not in keep and p.is_file():
            p.unlink()
    return paths


def read_rba_sequence(folder, *, scene: Sequence[Placement] | None = None) -> list[RigidBodyFrame]:
    """Read every ``*.rba`` file of ``folder`` ordered by its numeric suffix (not by name).

    Parameters
    ----------
    folder : path
    scene : list of Placement, optional
        Companion SCN placements; every RBA id must index one of them.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"RBA folder {str(folder)!r} does not exist")
    if scene is not None and not all(isinstance(p, Placement) for p in scene):
        raise ValueError("scene must be a list of Placement")
    found = []
    for p in folder.iterdir():
        m = _NUMBERED.match(p.name)
        if p.suffix == ".rba" and not m:
            raise ValueError(f"{p.name!r}: RBA file names must end in a frame number, e.g. frame_0001.rba")
        if m:
            found.append((int(m.group(2)), p))
    nums = [k for k, _ in found]
    if len(set(nums)) != len(nums):
        raise ValueError(f"{str(folder)!r}: two RBA files share a frame number")
    if len(nums) > 10**6:
        raise ValueError(f"{str(folder)!r}: more than 10**6 RBA files")
    frames = [read_rba(p) for _, p in sorted(found)]
    if scene is not None:
        for (_, p), f in zip(sorted(found), frames):
            if f.ids.size and f.ids.max() >= len(scene):
                raise ValueError(f"{p}: id {int(f.ids.max())} has no entry in the {len(scene)}-entry "
                                 "SCN file")
    return frames


def rba_at(frames: Sequence[RigidBodyFrame], f: float, *, mode: str = "interpolate") -> RigidBodyFrame:
    """Placements of an RBA series at a (fractional) frame ``f`` (spec §3.8 [INFERRED]).

    Parameters
    ----------
    frames : sequence of RigidBodyFrame
        The series, file k holding frame k.
    f : float
        Frame in [0, len(frames) - 1].
    mode : {"interpolate", "floor"}
        ``floor``: file floor(f). ``interpolate``: for ids in both neighbouring files, position and scale
        linearly, the (up, right) frame by spherical linear interpolation of the rotation; ids present only
        in the earlier file are kept as they are (newborn ids appear at the next file).

    Returns
    -------
    RigidBodyFrame
    """
    from scipy.spatial.transform import Rotation

    frames = list(frames)
    if not frames or not all(isinstance(x, RigidBodyFrame) for x in frames):
        raise ValueError("frames must be a non-empty sequence of RigidBodyFrame")
    f = check_range("f", f, 0.0, float(len(frames) - 1))
    mode = check_choice("mode", mode, ("interpolate", "floor"))
    k = min(int(np.floor(f)), len(frames) - 1)
    t = f - k
    a = frames[k]
    if mode == "floor" or t == 0.0:
        return a
    b = frames[k + 1]
    common, ia, ib = np.intersect1d(a.ids, b.ids, assume_unique=True, return_indices=True)
    pos, scale = a.position.copy(), a.scale.copy()
    up, right = a.up.copy(), a.right.copy()
    pos[ia] = (1 - t) * a.position[ia] + t * b.position[ib]
    scale[ia] = (1 - t) * a.scale[ia] + t * b.scale[ib]

    def frame_of(u, r):
        u = u / np.linalg.norm(u, axis=1, keepdims=True)
        r = r - np.einsum("ij,ij->i", r, u)[:, None] * u
        r /= np.linalg.norm(r, axis=1, keepdims=True)
        return Rotation.from_matrix(np.stack([r, u, np.cross(r, u)], axis=2))

    if common.size:
        ra, rb = frame_of(a.up[ia], a.right[ia]), frame_of(b.up[ib], b.right[ib])
        rel = (ra.inv() * rb).as_rotvec()
        m = (ra * Rotation.from_rotvec(t * rel)).as_matrix()        # slerp per placement
        right[ia], up[ia] = m[:, :, 0], m[:, :, 1]
    return RigidBodyFrame(a.ids, pos, scale, up, right)


# -------------------------------------------------------------------------------------------------------
# Nested scenes


def load_scene_tree(root, rba_scenes: Mapping[int, str | Path]) -> dict[Path, list[Placement]]:
    """Load an SCN file and every SCN file its ``rba`` entries instantiate, refusing cycles (spec §3.8).

    Parameters
    ----------
    root : path
        Top SCN file.
    rba_scenes : mapping of int to path
        ``rigid body animation`` ids of the parameter file -> the scene file each instantiates.

    Returns
    -------
    dict of Path to list of Placement
        Every reachable scene, by resolved path.

    Raises
    ------
    ValueError
        On a recursive relation ("care must be taken by the modeler to ensure this not happen",
        App. C.3), an ``rba`` id missing from ``rba_scenes``, or a malformed file.
    """
    scenes: dict[Path, list[Placement]] = {}
    stack: list[Path] = []

    def visit(path: Path):
        path = Path(path).resolve()
        if path in stack:
            chain = " -> ".join(p.name for p in [*stack[stack.index(path):], path])
            raise ValueError(f"recursive scene reference: {chain}")
        if path in scenes:
            return
        stack.append(path)
        placements = read_scn(path)
        for k, p in enumerate(placements):
            if p.kind != "rba":
                continue
            if p.id not in rba_scenes:
                raise ValueError(f"{path}: entry {k} is 'rba' with id {p.id}, which names no rigid body "
                                 "animation "
                                 f"(known ids: {sorted(rba_scenes)})")
            visit(Path(rba_scenes[p.id]))
        stack.pop()
        scenes[path] = placements

    visit(Path(root))
    return scenes


# -------------------------------------------------------------------------------------------------------
# From phyllotaxis to files


def placements_from_arrays(position: np.ndarray, up: np.ndarray, right: np.ndarray, scale: np.ndarray, *,
                           kind: str = "o", object_id: int | np.ndarray = 0, extra: np.ndarray | None = None
                           ) -> list[Placement]:
    """SCN placements of a static pattern, e.g. :meth:`HierarchicalPhyllotaxis.florets` (spec §3.8).

    Parameters
    ----------
    position, up, right : (n, 3) float64 array_like
    scale : (n,) or (n, 3) float64 array_like
        Uniform or per-axis scale.
    kind : str
        Entry type (one of :data:`SCN_TYPES`).
    object_id : int or (n,) int array_like
        Parameter-file object per placement (e.g. ray vs disc floret animation).
    extra : (n, k) float64 array_like, optional
        The type's own fields (k = ``len(SCN_TYPES[kind])``).

    Returns
    -------
    list of Placement
    """
    kind = check_choice("kind", kind, tuple(SCN_TYPES))
    position = check_array("position", position, shape=(None, 3))
    n = position.shape[0]
    up = check_array("up", up, shape=(n, 3))
    right = check_array("right", right, shape=(n, 3))
    scale = np.asarray(scale, dtype=np.float64)
    if scale.ndim == 1:
        scale = np.repeat(scale[:, None], 3, axis=1)
    scale = check_array("scale", scale, shape=(n, 3))
    ids = check_array("object_id", np.broadcast_to(np.asarray(object_id), (n,)), shape=(n,), dtype=np.int64)
    k = len(SCN_TYPES[kind])
    extra = np.zeros((n, 0)) if extra is None and k == 0 else check_array("extra", extra, shape=(n, k))
    return [Placement(kind, int(ids[i]), position[i], scale[i], up[i], right[i], tuple(extra[i]))
            for i in range(n)]


def scene_from_frames(frames: Sequence, *, object_id: int = 0, kind: str = "ca",
                      area_ref: float | None = None, opening_frames: float = 100.0,
                      frames_per_step: float = 1.0) -> tuple[list[Placement], list[RigidBodyFrame]]:
    """SCN placements and the RBA series of a dynamic pattern (spec §3.8 "static vs dynamic", §4.5).

    Primordium k becomes SCN entry k (production order), so RBA ids are production indices.

    Parameters
    ----------
    frames : sequence of DynamicFrame
        Output of :meth:`~plantvr.flowers.dynamic.DynamicPhyllotaxis.run`; the last one gives the SCN
        (final positions of a static model).
    object_id : int
        Parameter-file ``animation`` id used for every floret.
    kind : {"ca", "o", "rba"}
        Entry type. ``ca`` entries start at the primordium's birth frame and end ``opening_frames`` later
        (stage from age, §4.5 [INFERRED] mapping).
    area_ref : float, optional
        Area of a floret at scale 1 (default the largest final area); scale = sqrt(area / area_ref).
    opening_frames : float
        Frames from birth to full opening.
    frames_per_step : float
        Rendered frames per pattern step.

    Returns
    -------
    placements : list of Placement
    rba : list of RigidBodyFrame
        One per input frame, holding the primordia present at that frame.
    """
    frames = list(frames)
    if not frames:
        raise ValueError("frames must hold at least one DynamicFrame")
    object_id = check_int("object_id", object_id, 0, 2**62)
    kind = check_choice("kind", kind, ("ca", "o", "rba"))
    opening_frames = check_range("opening_frames", opening_frames, 0.0, 1e12)
    frames_per_step = check_range("frames_per_step", frames_per_step, 0.0, 1e12, low_open=True)
    last = frames[-1]
    if area_ref is None:
        area_ref = float(last.area.max()) if last.n else 1.0
    area_ref = check_range("area_ref", area_ref, 0.0, 1e12, low_open=True)
    t0 = frames[0].t
    dt = (frames[1].t - frames[0].t) if len(frames) > 1 else 1.0

    def to_frame(t):
        return (t - t0) / dt * frames_per_step if dt > 0 else 0.0

    placements = []
    for k in range(last.n):
        sc = float(np.sqrt(last.area[k] / area_ref))
        extra = () if kind == "o" else (to_frame(last.birth[k]), to_frame(last.birth[k]) + opening_frames)
        placements.append(Placement(kind, object_id, last.position[k], (sc, sc, sc), last.up[k],
                                    last.right[k], extra))
    rba = []
    for f in frames:
        sc = np.sqrt(f.area / area_ref)
        rba.append(RigidBodyFrame(f.ids, f.position, np.repeat(sc[:, None], 3, axis=1), f.up, f.right))
    return placements, rba
