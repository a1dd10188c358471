"""Saving and loading trees: the bracketed ``.tree`` text (spec 000_treewand §4.5, TW-V24) and a binary ``.npz``.

Text format ([INFERRED] in the spec, lossless here): ``key=value`` parameter lines, then one line
``tree=`` followed by the tree in depth-first bracketed form. Each node is ``N(px,py,pz,hx,hy,hz,lx,ly,lz)``
followed by one item per slot: ``[...]`` a child subtree, ``B`` a bud, ``-`` an absent slot. Floats are
written with ``repr`` so they round-trip exactly. Radius, vigor and light are recomputed after loading.
"""
from __future__ import annotations

import io
import json
import re
from typing import Any

import numpy as np

from ..params import PARAM_BY_NAME, validate
from .tree import BUD, NO_SLOT, Tree

__all__ = ["tree_to_text", "tree_from_text", "state_to_npz", "state_from_npz"]

_NODE = re.compile(r"N\(([^)]*)\)")
_FORMAT = "plantvr-tree 1"


def tree_to_text(tree: Tree, params: dict[str, Any]) -> str:
    """Return the ``.tree`` text of the live part of ``tree`` with ``params``."""
    lines = [f"# {_FORMAT}"] + [f"{k}={json.dumps(params[k])}" for k in PARAM_BY_NAME if k in params]
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
    return "\n".join(lines) + "\n"


def tree_from_text(text: str) -> tuple[Tree, dict[str, Any]]:
    """Parse ``.tree`` text; raises ``ValueError`` (naming the problem) on any malformed input."""
    params: dict[str, Any] = {}
    body = None
    for ln, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        key, sep, val = line.partition("=")
        if not sep:
            raise ValueError(f".tree line {ln}: expected key=value, got {line[:40]!r}")
        if key == "tree":
            body = val.strip()
            continue
        try:
            params[key] = json.loads(val)
        except json.JSONDecodeError:
            raise ValueError(f".tree line {ln}: value of {key!r} is not valid ({val[:40]!r})") from None
    if body is None:
        raise ValueError(".tree file has no 'tree=' line")
    params = validate(params)
    nslots = 3 if params.get("branching", PARAM_BY_NAME["branching"].default) == "opposite" else 2
    return _parse_body(body, nslots), params


def _parse_body(body: str, nslots: int) -> Tree:
    tree = Tree(nslots)
    i, n = 0, len(body)
    stack: list[list[int]] = []  # [node, next slot]
    while i < n:
        ch = body[i]
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
            parent = stack[-1][0] if stack else -1
            order = 0
            if stack:
                order = tree.order[parent] + (stack[-1][1] > 0)
            k = tree.append(v[:3], parent=parent, head=v[3:6], lat=v[6:9], order=int(order))
            if stack:
                tree.child[parent, stack[-1][1]] = k
            elif k != 0:
                raise ValueError(".tree body: more than one root")
            i = m.end()
            stack.append([k, 0])
            continue
        if not stack:
            raise ValueError(f".tree body: unexpected {ch!r} at character {i}")
        if ch == "[":
            if body[i + 1: i + 2] != "N":
                raise ValueError(f".tree body: '[' must open a node at character {i}")
        elif ch == "]":
            stack.pop()
            if not stack:
                raise ValueError(f".tree body: unbalanced ']' at character {i}")
            stack[-1][1] += 1
        elif ch in "B-":
            tree.child[stack[-1][0], stack[-1][1]] = BUD if ch == "B" else NO_SLOT
            stack[-1][1] += 1
        else:
            raise ValueError(f".tree body: unexpected {ch!r} at character {i}")
        if stack[-1][1] > nslots:
            raise ValueError(f".tree body: node at character {i} has more than {nslots} slots")
        i += 1
    if len(stack) != 1 or stack[0][1] != nslots:
        raise ValueError(".tree body: truncated (unbalanced brackets or missing slots)")
    if tree.n < 2:
        raise ValueError(".tree body: a tree needs the base point and the first internode")
    return tree


def state_to_npz(path, tree: Tree, params: dict[str, Any], extra: dict[str, np.ndarray]) -> None:
    """Write the full state (every tree array, parameters, markers...) losslessly to ``path`` (.npz)."""
    arrays = {f"tree_{k}": v for k, v in tree.arrays().items()}
    np.savez_compressed(path, format=np.array(_FORMAT), params=np.array(json.dumps(params)),
                        nslots=np.array(tree.nslots), **arrays, **extra)


def state_from_npz(path) -> tuple[Tree, dict[str, Any], dict[str, np.ndarray]]:
    """Read what :func:`state_to_npz` wrote; raises ``ValueError`` on a corrupt or foreign file."""
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except Exception as exc:  # zipfile, OSError, pickle refusal: all mean "not our file"
        raise ValueError(f"cannot read PlantVR state from {path!s}: {exc}") from None
    if str(data.get("format", "")) != _FORMAT:
        raise ValueError(f"{path!s} is not a PlantVR state file (format {_FORMAT!r})")
    params = validate(json.loads(str(data["params"])))
    tree = Tree(int(data["nslots"]))
    n = len(data["tree_pos"])
    tree._reserve(n)
    for k in tree._data:
        if f"tree_{k}" in data:
            tree._data[k][:n] = data[f"tree_{k}"]
        elif k == "light_factor":  # files written before TreeSketch's gravimorphism factor
            tree._data[k][:n] = 1.0
        else:
            raise ValueError(f"{path!s} lacks the tree field {k!r}")
    tree.n = n
    extra = {k: v for k, v in data.items() if not k.startswith("tree_") and k not in ("format", "params", "nslots")}
    return tree, params, extra
