"""Saving and loading trees: the bracketed ``.tree`` text (spec 000_treewand §4.5, TW-V24) and a binary ``.npz``.

Text format ([INFERRED] in the spec, lossless here), version 2: a first line ``# plantvr-tree 2``, then
``key=value`` parameter lines, then one line ``tree=`` followed by the tree in depth-first bracketed form, and a
last line ``# sha256=<hex>``: the SHA-256 of every byte before that line (UTF-8). Each node is
``N(px,py,pz,hx,hy,hz,lx,ly,lz)`` followed by one item per slot: ``[...]`` a child subtree, ``B`` a bud, ``-`` an
absent slot. Floats are written with ``repr`` so they round-trip exactly. Radius, vigor and light are
recomputed after loading.

The ``.npz`` state holds every tree array (``tree_<field>``), the parameters (JSON), ``nslots``, the extra
state of :data:`STATE_EXTRAS`, ``format`` = ``"plantvr-tree"``, ``version`` = 2 and ``checksum``
(:func:`plantvr._fileio.digest_arrays` of every other member). It is written deterministically (fixed member
order and timestamps), so the same state gives the same bytes.

Readers refuse, with a ``ValueError`` naming the file and the problem, and before building anything: another
format or version, a missing or wrong checksum, more than :data:`MAX_TREE_BYTES`, and any tree that fails
:func:`~plantvr.growth.tree.check_tree_arrays` (issue 20).
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import re
import struct
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from .._fileio import digest_arrays, npy_bytes, read_npz, write_atomic
from .._validation import MAX_COORD
from ..params import PARAM_BY_NAME, validate
from .tree import _FIELDS, BUD, MAX_NODES, NO_SLOT, Tree

__all__ = ["tree_to_text", "tree_from_text", "state_to_npz", "state_from_npz", "state_to_bytes",
           "FORMAT_NAME", "FORMAT_VERSION", "MAX_TREE_BYTES", "STATE_EXTRAS"]

_NODE = re.compile(r"N\(([^)]*)\)")
FORMAT_NAME = "plantvr-tree"
#: Version written and the only one read (version 1 files had no checksum).
FORMAT_VERSION = 2
_HEADER = f"# {FORMAT_NAME} {FORMAT_VERSION}"
_SUM = "# sha256="
#: Cap on the size of a ``.tree`` file and on the inflated size of an ``.npz`` state (bytes).
MAX_TREE_BYTES = 2**30

#: Extra state members of the ``.npz`` besides the tree: name -> (shape, dtype); ``None`` is a free length.
STATE_EXTRAS = {"markers": ((None, 3), np.float64), "marker_age": ((None,), np.int64),
                "step_count": ((), np.int64), "rng_state": ((), "U"), "new_nodes": ((None,), np.int64)}
_STATE_MEMBERS = ("format", "version", "checksum", "params", "nslots", *(f"tree_{k}" for k in _FIELDS),
                  *STATE_EXTRAS)


# -- text ------------------------------------------------------------------------------------------------------
def tree_to_text(tree: Tree, params: dict[str, Any]) -> str:
    """Return the ``.tree`` text (version 2, with its checksum line) of the live part of ``tree`` with ``params``."""
    lines = [_HEADER] + [f"{k}={json.dumps(params[k])}" for k in PARAM_BY_NAME if k in params]
    out = io.StringIO()
    stack: list[Any] = [0]
    while stack:  # iterative depth-first writer: trees can be thousands of internodes deep
        item = stack.pop()
        if isinstance(item, str):
            out.write(item)
            continue
        n = item
        vals = np.concatenate([tree.pos[n], tree.head[n], tree.lat[n]])
        out.write("N(" + ",".join(repr(float(v)) for v in vals) + ")")
        parts: list[Any] = []
        for c in tree.child[n, : tree.nslots]:
            if c >= 0 and tree.alive[c]:
                parts += ["[", int(c), "]"]
            else:
                parts.append("-" if c == NO_SLOT else "B")
        stack.extend(reversed(parts))
    lines.append("tree=" + out.getvalue())
    text = "\n".join(lines) + "\n"
    return text + f"{_SUM}{hashlib.sha256(text.encode('utf-8')).hexdigest()}\n"


def _check_envelope(text: str) -> str:
    """Check the header (format, version) and the checksum line; return the text before the checksum."""
    if not isinstance(text, str):
        raise ValueError(f".tree text must be a str, got {type(text).__name__}")
    if len(text) > MAX_TREE_BYTES:
        raise ValueError(f".tree text is {len(text)} characters, more than the cap of {MAX_TREE_BYTES}")
    text = text.replace("\r\n", "\n")  # a file written in text mode on Windows
    first = text.split("\n", 1)[0]
    m = re.fullmatch(r"# plantvr-tree (\S+)", first)
    if not m:
        raise ValueError(f"not a PlantVR .tree file: the first line must be {_HEADER!r}, got {first[:40]!r}")
    if m.group(1) != str(FORMAT_VERSION):
        raise ValueError(f".tree format version {m.group(1)[:20]!r} is not supported (this PlantVR reads "
                         f"version {FORMAT_VERSION} only)")
    body, sep, last = text[:-1].rpartition("\n")
    if not text.endswith("\n") or not sep or not last.startswith(_SUM):
        raise ValueError(f".tree file has no checksum: its last line must be '{_SUM}<64 hex digits>'")
    body += "\n"
    digest = hashlib.sha256(body.encode("utf-8", "surrogatepass")).hexdigest()
    if last[len(_SUM):] != digest:
        raise ValueError(".tree checksum mismatch: the file is damaged or was edited (sha256 of its text "
                         f"{digest[:12]}..., the file says {last[len(_SUM):len(_SUM) + 12]!r}...)")
    return body


def tree_from_text(text: str) -> tuple[Tree, dict[str, Any]]:
    """Parse ``.tree`` text; raises ``ValueError`` (naming the problem) on any malformed input.

    The header's version and the checksum are checked first, then the parameters, then the tree (including
    :func:`~plantvr.growth.tree.check_tree_arrays`), so nothing damaged is returned.
    """
    text = _check_envelope(text)
    params: dict[str, Any] = {}
    body = None
    for ln, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        key, sep, val = line.partition("=")
        if not sep:
            raise ValueError(f".tree line {ln}: expected key=value, got {line[:40]!r}")
        if key == "tree":
            if body is not None:
                raise ValueError(f".tree line {ln}: a second 'tree=' line")
            body = val.strip()
            continue
        try:
            params[key] = json.loads(val)
        except (json.JSONDecodeError, RecursionError):
            raise ValueError(f".tree line {ln}: value of {key[:40]!r} is not valid ({val[:40]!r})") from None
    if body is None:
        raise ValueError(".tree file has no 'tree=' line")
    params = validate(params)
    nslots = 3 if params.get("branching", PARAM_BY_NAME["branching"].default) == "opposite" else 2
    return _parse_body(body, nslots).check(".tree file"), params


def _parse_body(body: str, nslots: int) -> Tree:
    tree = Tree(nslots)
    i, n = 0, len(body)
    stack: list[list[int]] = []  # [node, next slot]
    while i < n:
        ch = body[i]
        if stack and ch in "NB-" and stack[-1][1] >= nslots:
            raise ValueError(f".tree body: node at character {i} has more than {nslots} slots")
        if ch == "N":
            m = _NODE.match(body, i)
            if not m:
                raise ValueError(f".tree body: malformed node at character {i}")
            try:
                v = np.array([float(x) for x in m.group(1).split(",")])
            except ValueError:
                raise ValueError(f".tree body: bad number in node at character {i}") from None
            if v.size != 9 or not np.all(np.isfinite(v)):
                raise ValueError(f".tree body: node at character {i} needs 9 finite numbers, got {v.size}")
            if np.abs(v).max() > MAX_COORD:
                raise ValueError(f".tree body: node at character {i}: values must lie in [-{MAX_COORD:g}, "
                                 f"{MAX_COORD:g}], got magnitude {np.abs(v).max():g}")
            if tree.n >= MAX_NODES:
                raise ValueError(f".tree body: more than {MAX_NODES} nodes")
            parent = stack[-1][0] if stack else -1
            order = 0
            if stack:
                order = tree.order[parent] + (stack[-1][1] > 0)
            elif tree.n:
                raise ValueError(".tree body: more than one root")
            k = tree.append(v[:3], parent=parent, head=v[3:6], lat=v[6:9], order=int(order))
            if stack:
                tree.child[parent, stack[-1][1]] = k
            i = m.end()
            stack.append([k, 0])
            continue
        if not stack:
            raise ValueError(f".tree body: unexpected {ch!r} at character {i}")
        if ch == "[":
            if body[i + 1: i + 2] != "N":
                raise ValueError(f".tree body: '[' must open a node at character {i}")
        elif ch == "]":
            if stack[-1][1] != nslots:
                raise ValueError(f".tree body: node closed at character {i} has {stack[-1][1]} of {nslots} slots")
            stack.pop()
            if not stack:
                raise ValueError(f".tree body: unbalanced ']' at character {i}")
            stack[-1][1] += 1
        elif ch in "B-":
            tree.child[stack[-1][0], stack[-1][1]] = BUD if ch == "B" else NO_SLOT
            stack[-1][1] += 1
        else:
            raise ValueError(f".tree body: unexpected {ch!r} at character {i}")
        i += 1
    if len(stack) != 1 or stack[0][1] != nslots:
        raise ValueError(".tree body: truncated (unbalanced brackets or missing slots)")
    if tree.n < 2:
        raise ValueError(".tree body: a tree needs the base point and the first internode")
    return tree


# -- npz -------------------------------------------------------------------------------------------------------
def state_to_bytes(tree: Tree, params: dict[str, Any], extra: dict[str, np.ndarray]) -> bytes:
    """The ``.npz`` bytes of the full state (every tree array, parameters, :data:`STATE_EXTRAS`, checksum)."""
    unknown = sorted(set(extra) - set(STATE_EXTRAS))
    if unknown:
        raise ValueError(f"extra state members must be among {sorted(STATE_EXTRAS)}, got {unknown}")
    arrays = {"format": np.array(FORMAT_NAME), "version": np.array(FORMAT_VERSION, np.int64),
              "params": np.array(json.dumps(params)), "nslots": np.array(tree.nslots, np.int64),
              **{f"tree_{k}": v for k, v in tree.arrays().items()}, **extra}
    arrays["checksum"] = np.array(digest_arrays(arrays))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for k in sorted(arrays):  # fixed order and timestamp: the same state gives the same bytes
            info = zipfile.ZipInfo(f"{k}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, npy_bytes(arrays[k]))
    return buf.getvalue()


def state_to_npz(path, tree: Tree, params: dict[str, Any], extra: dict[str, np.ndarray]) -> Path:
    """Write the full state losslessly and atomically to ``path`` (.npz); returns the path."""
    return write_atomic(path, state_to_bytes(tree, params, extra))


def state_from_npz(path) -> tuple[Tree, dict[str, Any], dict[str, np.ndarray]]:
    """Read what :func:`state_to_npz` wrote; raises ``ValueError`` on a corrupt or foreign file.

    The file is read through :func:`plantvr._fileio.read_npz` (members limited to the known names, inflated
    size to :data:`MAX_TREE_BYTES`); then format, version and checksum, the parameters, the tree
    (:func:`~plantvr.growth.tree.check_tree_arrays`) and every extra array (shape, dtype, finite, bounds) are
    checked. Returns copies, so the result owns its memory.
    """
    where = f"PlantVR state {os.fspath(path)!r}"
    try:
        data = read_npz(path, what="PlantVR state", max_bytes=MAX_TREE_BYTES, allowed=_STATE_MEMBERS)
    except (OSError, zlib.error, NotImplementedError, EOFError, zipfile.BadZipFile, RuntimeError, struct.error,
            UnicodeDecodeError, OverflowError) as exc:  # damage _fileio lets through (a bad deflate stream...)
        raise ValueError(f"cannot read PlantVR state from {path!s}: corrupt member ({exc})") from None

    def fail(msg: str):
        raise ValueError(f"{where}: {msg}")

    def text(name: str) -> str:
        a = data.get(name)
        if a is None or a.shape != () or a.dtype.kind != "U":
            fail(f"member {name!r} must be a text scalar")
        return str(a)

    if "format" not in data or text("format") != FORMAT_NAME:
        fail(f"not a PlantVR state file (format {FORMAT_NAME!r})")
    ver = data.get("version")
    if ver is None or ver.shape != () or ver.dtype.kind not in "iu" or int(ver) != FORMAT_VERSION:
        got = "none" if ver is None else repr(ver.tolist())[:20]
        fail(f"format version {got} is not supported (this PlantVR reads version {FORMAT_VERSION} only)")
    want = text("checksum") if "checksum" in data else fail("no checksum member")
    if digest_arrays({k: v for k, v in data.items() if k != "checksum"}) != want:
        fail("checksum mismatch: the file is damaged or was edited")
    missing = sorted(set(_STATE_MEMBERS) - set(data))
    if missing:
        fail(f"lacks the members {missing[:5]}")
    try:
        params = json.loads(text("params"))
    except (json.JSONDecodeError, RecursionError):
        fail("member 'params' is not valid JSON")
    if not isinstance(params, dict):
        fail(f"member 'params' must be a JSON object, got {type(params).__name__}")
    try:
        params = validate(params)
    except ValueError as exc:
        fail(f"member 'params': {exc}")
    nslots = data["nslots"]
    if nslots.shape != () or nslots.dtype != np.int64 or int(nslots) not in (2, 3):
        fail(f"member 'nslots' must be 2 or 3, got {nslots.tolist()!r}"[:200])
    want_slots = 3 if params.get("branching", PARAM_BY_NAME["branching"].default) == "opposite" else 2
    if int(nslots) != want_slots:
        fail(f"nslots {int(nslots)} does not match branching={params.get('branching', 'alternate')!r}")
    tree = Tree.from_arrays({k: data[f"tree_{k}"] for k in _FIELDS}, int(nslots), what=where)
    extra = {k: data[k] for k in STATE_EXTRAS}
    for k, (shape, dtype) in STATE_EXTRAS.items():
        a = extra[k]
        if a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape)):
            fail(f"member {k!r} must have shape {shape}, got {a.shape}")
        if (a.dtype.kind != "U") if dtype == "U" else (a.dtype != np.dtype(dtype)):
            fail(f"member {k!r} must have dtype {dtype}, got {a.dtype}")
    m, age, step, new = extra["markers"], extra["marker_age"], extra["step_count"], extra["new_nodes"]
    if not np.isfinite(m).all() or (m.size and np.abs(m).max() > MAX_COORD):
        fail(f"member 'markers' must be finite and lie in [-{MAX_COORD:g}, {MAX_COORD:g}]")
    if len(age) != len(m) or (age.size and age.min() < 0):
        fail(f"member 'marker_age' must hold {len(m)} ages >= 0, got {len(age)}")
    if not 0 <= int(step) <= 2**62:
        fail(f"member 'step_count' must be in [0, {2**62}], got {int(step)}")
    if new.size and (new.min() < 0 or new.max() >= tree.n):
        fail(f"member 'new_nodes' must hold node indices in [0, {tree.n - 1}]")
    return tree, params, {k: np.array(v) for k, v in extra.items()}
