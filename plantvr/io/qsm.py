"""Quantitative structure models (QSM) in: laser-scanned trees as the shared tree (issue 22, "Trees from scans").

A QSM describes a tree as cylinders, each with a start point, an end point (or an axis and a length), a radius
and the id of its parent cylinder. The readers here turn the three common tables into one
:class:`plantvr.types.TreeArrays` (positions, parents, radii, main children), so a scanned tree goes through the
same tree→mesh entry points (:func:`plantvr.io.tree.tree_geometry`), Yggdrasil
(:func:`plantvr.subdivision.graph_from_arrays`), every exporter and a Tree Wand :class:`~plantvr.documents.Model`
(:func:`model_from_tree`) as a grown one.

=========================  ===================================================================================
reader                     table
=========================  ===================================================================================
:func:`read_treeqsm`       TreeQSM ``.mat``: 2.1-2.4 ``qsm.cylinder`` struct (``start``, ``axis``, ``length``,
                           ``radius``, ``parent`` 1-based with 0 for none, optional ``extension``, ``branch``);
                           2.0 variables ``Sta``, ``Axe``, ``Len``, ``Rad``, ``CPar``, ``CExt``, ``BoC``
:func:`read_simpleforest`  SimpleForest CSV (``ID``, ``parentID``, ``startX..Z``, ``endX..Z``, ``radius``,
                           optional ``branchID``)
:func:`read_archi`         aRchi CSV (``cyl_ID``, ``parent_ID``, ``startX..Z``, ``endX..Z``, ``radius_cyl``,
                           optional ``axis_ID``, ``extension_ID``)
:func:`read_qsm`           any of them, by suffix (``.mat``) or by the CSV header
=========================  ===================================================================================

How cylinders become nodes (:func:`cylinders_to_tree`): every cylinder keeps its geometry: its internodes run from
its recorded start to its recorded end along its own axis, with its radius, so the tree's cylinder lengths and
volumes are the file's (issue 32). Node 0 is the root cylinder's start. A child is attached to its parent at the
point of the parent's axis nearest its start (TreeQSM branches start on the parent's surface, part-way along it,
and consecutive cylinders of a branch leave millimetre gaps): at the parent's end node (an extension child, the
continuing child of a branch starting anywhere in the parent's second half, or a start past the end), its start
node, or a node inserted on the parent's axis there (splitting the parent into pieces that add up to its length).
Where the child's recorded start is not that point, a **connector** joins them: a short internode from the attach
node to the child's recorded start, with the child's radius (from the parent's axis to its surface a branch's
connector lies inside the parent's wood). Connectors are not cylinders of the file: ``cylinders_to_tree(...,
return_map=True)`` marks them (:attr:`QSMMap.connector`) and gives their lengths (:attr:`QSMMap.offset`); the
tree's length and volume over the other internodes are the file's. The continuing child of each cylinder
(``extension``, the same branch id, else the child best aligned with it) is the node's main child (through its
connector), so branch orders follow the QSM's branches. Nodes are numbered breadth-first, so every parent precedes
its children.
"""
from __future__ import annotations

import csv
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_choice, check_int, check_range
from plantvr.growth.tree import BUD, NO_SLOT, Tree
from plantvr.types import TreeArrays

__all__ = [
    "QSM_FORMATS",
    "QSMMap",
    "cylinders_to_tree",
    "model_from_tree",
    "read_archi",
    "read_qsm",
    "read_simpleforest",
    "read_treeqsm",
    "to_growth_tree",
]

QSM_FORMATS = ("treeqsm", "simpleforest", "archi")
"""Formats :func:`read_qsm` reads."""

#: Most cylinders a QSM read here may have.
MAX_CYLINDERS = 2_000_000
#: A child starting within this fraction of its parent's length from the parent's end (or start) attaches there.
ATTACH_TOL = 1e-3
#: A child whose recorded start is farther than this fraction of its own length from its attach node gets a
#: connector internode; a nearer one grows from the attach node (its length changes by at most this fraction).
CONNECT_TOL = 1e-6


@dataclass(frozen=True)
class QSMMap:
    """Where each cylinder went (:func:`cylinders_to_tree` with ``return_map=True``).

    Attributes
    ----------
    end_node : (C,) int64 ndarray
        Node at each cylinder's end.
    start_node : (C,) int64 ndarray
        Node each cylinder grows from (its parent's end, a split node on the parent, or node 0).
    offset : (C,) float64 ndarray
        Distance between each cylinder's recorded start and the node it grows from (0 for the root): the length
        of its connector.
    base_node : (C,) int64 ndarray
        Node at each cylinder's recorded start: the end of its connector, or ``start_node`` where it has none.
    connector : (N,) bool ndarray
        True where the internode ending at the node is a connector (not one of the file's cylinders): sum
        lengths and volumes over ``~connector`` to get the file's totals.
    """

    end_node: np.ndarray
    start_node: np.ndarray
    offset: np.ndarray
    base_node: np.ndarray
    connector: np.ndarray


# -- cylinders → tree ---------------------------------------------------------------------------------------------
def _check_cylinders(start, end, radius, parent, branch, extension):
    start = check_array("start", start, shape=(None, 3), min_rows=1, max_abs=MAX_COORD)
    c = len(start)
    if c > MAX_CYLINDERS:
        raise ValueError(f"a QSM may have at most {MAX_CYLINDERS} cylinders, got {c}")
    end = check_array("end", end, shape=(c, 3), max_abs=MAX_COORD)
    radius = check_array("radius", radius, shape=(c,), max_abs=MAX_COORD)
    bad = np.flatnonzero(~(radius > 0))
    if bad.size:
        raise ValueError(f"radius must be > 0 for every cylinder, got {radius[bad[0]]!r} at cylinder {bad[0]}")
    length = np.linalg.norm(end - start, axis=1)
    bad = np.flatnonzero(~(length > 1e-12 * max(1.0, float(np.abs(start).max()))))
    if bad.size:
        raise ValueError(f"every cylinder must have a length > 0; cylinder {bad[0]} has length {length[bad[0]]!r}")
    par = np.asarray(parent)
    if par.shape != (c,) or (par.size and par.dtype.kind not in "iuf"):
        raise ValueError(f"parent must be an integer array of shape ({c},), got {par.dtype} {par.shape}")
    if par.dtype.kind == "f" and not np.all(np.isfinite(par) & (par == np.round(par))):
        raise ValueError("parent must hold whole numbers (cylinder indices, -1 for none)")
    par = par.astype(np.int64)
    bad = np.flatnonzero((par < -1) | (par >= c) | (par == np.arange(c)))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"parent[{i}] = {par[i]} must be -1 (none) or another cylinder index in [0, {c - 1}]")
    roots = np.flatnonzero(par < 0)
    if len(roots) != 1:
        raise ValueError(f"a QSM tree must have exactly one root cylinder (parent -1), got {len(roots)}"
                         + (f" (cylinders {roots[:5].tolist()})" if len(roots) else ""))
    out = []
    for name, a in (("branch", branch), ("extension", extension)):
        if a is None:
            out.append(None)
            continue
        a = np.asarray(a)
        if a.shape != (c,) or (a.size and a.dtype.kind not in "iuf") or not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be a finite integer array of shape ({c},), got {a.dtype} {a.shape}")
        out.append(a.astype(np.int64))
    branch, extension = out
    if extension is not None and np.any((extension < -1) | (extension >= c)):
        raise ValueError(f"extension must be -1 (none) or a cylinder index in [0, {c - 1}]")
    return start, end, radius, par, int(roots[0]), branch, extension


def cylinders_to_tree(start, end, radius, parent, *, branch=None, extension=None,
                      return_map: bool = False) -> TreeArrays | tuple[TreeArrays, QSMMap]:
    """Turn QSM cylinders into the shared tree (see the module docstring for the rules).

    Parameters
    ----------
    start, end : (C, 3) float64 array_like
        Cylinder start and end points, in the QSM's units (TreeQSM: metres, z up).
    radius : (C,) float64 array_like
        Cylinder radii, > 0.
    parent : (C,) int array_like
        Index of each cylinder's parent cylinder in ``[0, C)``, ``-1`` for the one root cylinder.
    branch : (C,) int array_like, optional
        Branch id of each cylinder: the child with its parent's branch id continues it (main child).
    extension : (C,) int array_like, optional
        Index of the cylinder continuing each one (TreeQSM ``extension``), ``-1`` for none; wins over ``branch``.
    return_map : bool
        Also return a :class:`QSMMap` (cylinder → nodes, start offsets).

    Returns
    -------
    TreeArrays
        Node 0 at the root cylinder's start; ``radius[i]`` the radius of the cylinder ending at node ``i``.

    Raises
    ------
    ValueError
        Bad shapes, non-finite values, radii or lengths not > 0, parent ids out of range, not exactly one root,
        or a cycle (cylinders not reachable from the root), naming the cylinder.
    """
    start, end, radius, par, root, branch, extension = _check_cylinders(start, end, radius, parent, branch,
                                                                        extension)
    c = len(start)
    children: list[list[int]] = [[] for _ in range(c)]
    for i in np.flatnonzero(par >= 0):
        children[par[i]].append(int(i))
    # breadth-first order of the cylinders; unreached cylinders sit on a cycle
    order, seen = [root], np.zeros(c, bool)
    seen[root] = True
    k = 0
    while k < len(order):
        for ch in children[order[k]]:
            seen[ch] = True
            order.append(ch)
        k += 1
    if len(order) != c:
        bad = int(np.flatnonzero(~seen)[0])
        raise ValueError(f"parent ids form a cycle: cylinder {bad} is not reachable from the root cylinder {root}")
    axis = end - start
    length = np.linalg.norm(axis, axis=1)
    unit = axis / length[:, None]
    cont = _continuations(children, unit, branch, extension, par)

    pos = [start[root]]
    npar = [-1]
    nrad = [radius[root]]
    conn = [False]
    start_node = np.zeros(c, np.int64)       # the node on the parent each cylinder is attached to
    base_node = np.zeros(c, np.int64)        # the node at each cylinder's recorded start
    end_node = np.zeros(c, np.int64)
    offset = np.zeros(c)
    for cy in order:
        b = int(start_node[cy])
        if cy != root and offset[cy] > CONNECT_TOL * length[cy]:    # a connector: attach point -> recorded start
            pos.append(start[cy].copy())
            npar.append(b)
            nrad.append(radius[cy])
            conn.append(True)
            b = len(pos) - 1
        base_node[cy] = b
        p0 = pos[b]                          # the cylinder's own start (within CONNECT_TOL of its length)
        seg = end[cy] - p0
        seg_len = float(np.linalg.norm(seg))
        if not seg_len > 1e-12 * max(1.0, float(np.abs(p0).max())):
            raise ValueError(f"cylinder {cy} ends where it is attached to its parent (zero-length internode)")
        kids = children[cy]  # where each child starts along this cylinder's axis, as a fraction t of it
        ts = [round(float(np.dot(start[ch] - p0, seg)) / (seg_len * seg_len), 12) for ch in kids]
        nx = cont.get(cy, -1)      # the continuing child grows from the end (its branch goes on) unless it starts
        if nx >= 0 and ts[kids.index(nx)] <= 0.5:                  # in the first half: a fork there
            nx = -1
        prev, split = b, {}
        for t in sorted({t for ch, t in zip(kids, ts) if ATTACH_TOL < t < 1.0 - ATTACH_TOL and ch != nx}):
            pos.append(p0 + t * seg)         # on the axis: the pieces add up to the cylinder's length
            npar.append(prev)
            nrad.append(radius[cy])
            conn.append(False)
            prev = split[t] = len(pos) - 1
        pos.append(end[cy].copy())
        npar.append(prev)
        nrad.append(radius[cy])
        conn.append(False)
        end_node[cy] = len(pos) - 1
        for ch, t in zip(kids, ts):
            if t >= 1.0 - ATTACH_TOL or ch == nx:
                node = int(end_node[cy])
            elif t <= ATTACH_TOL:
                node = b
            else:
                node = split[t]
            start_node[ch] = node
            offset[ch] = float(np.linalg.norm(start[ch] - pos[node]))
    pos = np.asarray(pos)
    npar = np.asarray(npar, np.int64)
    # main children: along each cylinder's chain of nodes (connector included), and from its end node into its
    # continuation
    first = np.array([_chain_head(npar, int(start_node[cy]), int(end_node[cy])) if cy != root else
                      _chain_head(npar, 0, int(end_node[cy])) for cy in range(c)], np.int64)
    main = np.full(len(pos), -1, np.int64)
    for cy in order:
        v = int(end_node[cy])
        stop = 0 if cy == root else int(start_node[cy])
        while npar[v] != stop:
            main[npar[v]] = v
            v = int(npar[v])
    main[0] = first[root]
    for cy in order:
        nx = cont.get(cy, -1)
        if nx >= 0 and start_node[nx] == end_node[cy]:
            main[end_node[cy]] = first[nx]
    tree = TreeArrays.from_arrays(pos, npar, np.asarray(nrad), main_child=main)
    if return_map:
        return tree, QSMMap(end_node, start_node, offset, base_node, np.asarray(conn, bool))
    return tree


def _chain_head(npar, s_node, e_node):
    v = e_node
    while npar[v] != s_node:
        v = int(npar[v])
    return v


def _continuations(children, unit, branch, extension, par) -> dict[int, int]:
    """Continuing child of each cylinder: ``extension``, else the child of the same branch, else the best-aligned
    child (ties to the lowest index)."""
    out = {}
    for cy, kids in enumerate(children):
        if not kids:
            continue
        if extension is not None and extension[cy] >= 0 and par[extension[cy]] == cy:
            out[cy] = int(extension[cy])
            continue
        if branch is not None:
            same = [k for k in kids if branch[k] == branch[cy]]
            if same:
                out[cy] = min(same)
                continue
        dots = [float(np.dot(unit[k], unit[cy])) for k in kids]
        out[cy] = kids[int(np.argmax(dots))]
    return out


# -- readers --------------------------------------------------------------------------------------------------------
def _check_path(path, suffixes: tuple[str, ...]) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or path-like, got {type(path).__name__}")
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise ValueError(f"path must end in {' or '.join(suffixes)}, got {str(p)!r}")
    if not p.is_file():
        raise ValueError(f"QSM file {str(p)!r} does not exist")
    return p


def read_treeqsm(path, *, index: int = 0, return_map: bool = False):
    """Read a TreeQSM ``.mat`` file: a 2.1-2.4 ``QSM`` or ``qsm`` struct (or a bare ``cylinder`` struct), or
    the TreeQSM 2.0 layout, one variable per cylinder field (``Rad``, ``Len``, ``Sta``, ``Axe``, ``CPar``,
    ``CExt``, ``BoC``).

    Parameters
    ----------
    path : str or path-like
        ``.mat`` file saved by TreeQSM (``save(..., 'QSM')``): MATLAB v5/v7 files are read by ``scipy.io.loadmat``,
        v7.3 (HDF5) files by ``h5py``.
    index : int
        Which model of a QSM array (TreeQSM saves one per input parameter set), in [0, count).
    return_map : bool
        Also return the :class:`QSMMap`.

    Returns
    -------
    TreeArrays
        As :func:`cylinders_to_tree`; TreeQSM's ``parent`` (1-based, 0 = none) and ``extension`` are converted.

    References
    ----------
    .. [1] Raumonen et al. 2013, "Fast automatic precision tree models from terrestrial laser scanner data";
       TreeQSM 2.4 ``cylinder`` fields; TreeQSM 2.0 variable names as rTwig's ``import_treeqsm(version="2.0")``
       maps them (``BoC[:, 0]`` the branch, 1-based ``CPar``/``CExt`` with 0 for none).
    """
    p = _check_path(path, (".mat",))
    index = check_int("index", index, 0, 10 ** 6)
    import scipy.io

    try:
        mat = scipy.io.loadmat(str(p), squeeze_me=True, struct_as_record=False)
    except NotImplementedError:                      # MATLAB v7.3: an HDF5 file behind a 512-byte header
        fields = _treeqsm_v73(p, index)
    except (ValueError, TypeError, OSError, IndexError, KeyError, EOFError, scipy.io.matlab.MatReadError) as exc:
        raise ValueError(f"cannot read TreeQSM file {str(p)!r}: {exc or type(exc).__name__}"[:300]) from None
    else:
        fields = _treeqsm_v7(p, mat, index)

    def field(name, required=True):
        if name not in fields:
            if required:
                raise ValueError(f"{str(p)!r}: qsm.cylinder has no field {name!r}")
            return None
        return fields[name]

    start = np.atleast_2d(field("start").astype(np.float64))
    axis = np.atleast_2d(field("axis").astype(np.float64))
    length = np.atleast_1d(field("length").astype(np.float64)).ravel()
    radius = np.atleast_1d(field("radius").astype(np.float64)).ravel()
    parent = np.atleast_1d(field("parent")).ravel()
    c = len(radius)
    for name, a, shp in (("start", start, (c, 3)), ("axis", axis, (c, 3)), ("length", length, (c,)),
                         ("parent", parent, (c,))):
        if a.shape != shp:
            raise ValueError(f"{str(p)!r}: qsm.cylinder.{name} must have shape {shp}, got {a.shape}")
    ext = field("extension", False)
    br = field("branch", False)
    parent = np.asarray(parent, np.float64) - 1  # 1-based, 0 = none
    ext = None if ext is None or np.atleast_1d(ext).shape != (c,) else np.atleast_1d(ext).astype(np.int64) - 1
    br = None if br is None or np.atleast_1d(br).shape != (c,) else np.atleast_1d(br)
    an = np.linalg.norm(axis, axis=1)
    if not np.all(np.isfinite(an) & (an > 0)):
        raise ValueError(f"{str(p)!r}: qsm.cylinder.axis must be non-zero finite vectors")
    end = start + axis / an[:, None] * length[:, None]
    try:
        return cylinders_to_tree(start, end, radius, parent, branch=br, extension=ext, return_map=return_map)
    except ValueError as exc:
        raise ValueError(f"{str(p)!r}: {exc}") from None


_QSM_KEYS = ("QSM", "qsm", "Q", "OptQSM", "cylinder")
_CYLINDER_FIELDS = ("start", "axis", "length", "radius", "parent", "extension", "branch")


def _treeqsm_v7(p: Path, mat: dict, index: int) -> dict[str, np.ndarray]:
    """The ``cylinder`` fields of a v5/v7 file read by ``scipy.io.loadmat``."""
    cyl = None
    for key in _QSM_KEYS:
        if key in mat:
            obj = mat[key]
            if isinstance(obj, np.ndarray) and obj.dtype == object:
                if index >= obj.size:
                    raise ValueError(f"index must be in [0, {obj.size - 1}] for {str(p)!r}, got {index}")
                obj = obj.flat[index]
            cyl = obj if key == "cylinder" else getattr(obj, "cylinder", None)
            break
    if cyl is None and all(k in mat for k in _V20_REQUIRED):        # TreeQSM 2.0: one variable per field
        if index != 0:
            raise ValueError(f"index must be 0 for {str(p)!r} (a TreeQSM 2.0 file holds one model), got {index}")
        return _v20_fields({k: np.asarray(mat[k]) for k in _V20_FIELDS if k in mat})
    if cyl is None:
        raise ValueError(f"{str(p)!r} holds no TreeQSM 'qsm.cylinder' struct (2.1-2.4) nor the TreeQSM 2.0 "
                         f"variables {list(_V20_REQUIRED)} (variables: "
                         f"{sorted(k for k in mat if not k.startswith('__'))[:8]})")
    return {name: np.asarray(getattr(cyl, name)) for name in _CYLINDER_FIELDS if hasattr(cyl, name)}


#: TreeQSM 2.0 saves each cylinder field as its own variable (``Rad``, ``Len``, ``Sta``, ``Axe``, ``CPar``,
#: ``CExt``, and ``BoC``: branch, branch order and position in branch, one row per cylinder); 2.1 onwards put them
#: in the ``qsm.cylinder`` struct as ``radius``, ``length``, ``start``, ``axis``, ``parent``, ``extension``,
#: ``branch``.
_V20_FIELDS = {"Rad": "radius", "Len": "length", "Sta": "start", "Axe": "axis", "CPar": "parent",
               "CExt": "extension", "BoC": "branch"}
_V20_REQUIRED = ("Rad", "Len", "Sta", "Axe", "CPar")


def _v20_fields(raw: dict) -> dict[str, np.ndarray]:
    out = {_V20_FIELDS[k]: v for k, v in raw.items()}
    boc = out.get("branch")
    if boc is not None:
        boc = np.atleast_2d(boc)
        if boc.ndim == 2 and boc.shape[1] >= 1 and boc.dtype.kind in "fiub":
            out["branch"] = boc[:, 0]                    # BoC column 1: the branch each cylinder belongs to
        else:
            del out["branch"]
    return out


def _h5_matrix(p, ds, label: str, vector: bool) -> np.ndarray:
    """A MATLAB v7.3 numeric matrix (HDF5 stores it transposed), checked; a row or column as a vector when
    ``vector``."""
    if ds.size > 50_000_000 or ds.ndim > 2 or ds.dtype.kind not in "fiub":
        raise ValueError(f"{str(p)!r}: {label} must be a numeric matrix of at most 5e7 values, got "
                         f"{ds.dtype} {ds.shape}")
    a = np.asarray(ds[()]).T
    return a.ravel() if vector and a.ndim == 2 and 1 in a.shape else a


def _treeqsm_v73(p: Path, index: int) -> dict[str, np.ndarray]:
    """The ``cylinder`` fields of a MATLAB v7.3 (HDF5) file: a struct is a group, a struct array a group of
    reference datasets, and every matrix is stored transposed (MATLAB is column-major)."""
    try:
        import h5py
    except ImportError:
        raise ValueError(f"cannot read TreeQSM file {str(p)!r}: MATLAB v7.3 files need h5py "
                         "(pip install plantvr[formats])") from None
    try:
        with h5py.File(p, "r") as f:
            key = next((k for k in _QSM_KEYS if k in f), None)
            if key is None and all(isinstance(f.get(k), h5py.Dataset) for k in _V20_REQUIRED):   # TreeQSM 2.0
                if index != 0:
                    raise ValueError(f"index must be 0 for {str(p)!r} (a TreeQSM 2.0 file holds one model), got "
                                     f"{index}")
                return _v20_fields({k: _h5_matrix(p, f.get(k), k, k not in ("Sta", "Axe", "BoC"))
                                    for k in _V20_FIELDS if isinstance(f.get(k), h5py.Dataset)})
            if key is None:
                raise ValueError(f"{str(p)!r} holds no TreeQSM 'qsm.cylinder' struct (variables: "
                                 f"{sorted(k for k in f if not k.startswith('#'))[:8]})")
            obj = f[key]
            cyl = obj if key == "cylinder" else (obj.get("cylinder") if isinstance(obj, h5py.Group) else None)
            if isinstance(cyl, h5py.Dataset) and cyl.dtype == h5py.ref_dtype:   # a QSM struct array
                refs = cyl[()].ravel()
                if index >= refs.size:
                    raise ValueError(f"index must be in [0, {refs.size - 1}] for {str(p)!r}, got {index}")
                cyl = f[refs[index]]
            elif index != 0:
                raise ValueError(f"index must be 0 for {str(p)!r} (one model), got {index}")
            if not isinstance(cyl, h5py.Group):
                raise ValueError(f"{str(p)!r} holds no TreeQSM 'qsm.cylinder' struct")
            return {name: _h5_matrix(p, cyl.get(name), f"qsm.cylinder.{name}", name not in ("start", "axis"))
                    for name in _CYLINDER_FIELDS if isinstance(cyl.get(name), h5py.Dataset)}
    except ValueError:
        raise
    except (OSError, KeyError, TypeError, RuntimeError) as exc:
        raise ValueError(f"cannot read TreeQSM file {str(p)!r}: {exc or type(exc).__name__}"[:300]) from None


_SF_COLUMNS = {"id": ("id",), "parent": ("parentid", "parent_id", "parent"),
               "sx": ("startx",), "sy": ("starty",), "sz": ("startz",),
               "ex": ("endx",), "ey": ("endy",), "ez": ("endz",), "radius": ("radius",),
               "branch": ("branchid", "branch_id"), "extension": ()}
_ARCHI_COLUMNS = {"id": ("cyl_id",), "parent": ("parent_id",),
                  "sx": ("startx",), "sy": ("starty",), "sz": ("startz",),
                  "ex": ("endx",), "ey": ("endy",), "ez": ("endz",), "radius": ("radius_cyl", "radius"),
                  "branch": ("branch_id", "axis_id"), "extension": ("extension_id",)}
# Column names as rTwig's standardize_qsm() maps them (SimpleForest: ID, parentID, branchID, startX..endZ, radius;
# aRchi: cyl_ID, parent_ID, branch_ID, startX..endZ, radius_cyl); older aRchi exports name the branch axis_ID.


def _read_table(p: Path) -> tuple[list[str], np.ndarray]:
    try:
        with open(p, newline="", encoding="utf-8-sig") as fh:
            sample = fh.read(4096)
            fh.seek(0)
            try:
                dialect = csv.Sniffer().sniff(sample, delimiters=",;\t ")
            except csv.Error:
                dialect = csv.excel
            rows = list(csv.reader(fh, dialect))
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read QSM table {str(p)!r}: {exc}"[:300]) from None
    rows = [r for r in rows if r and any(x.strip() for x in r)]
    if len(rows) < 2:
        raise ValueError(f"QSM table {str(p)!r} needs a header row and at least one cylinder row")
    header = [h.strip().strip('"').lower() for h in rows[0]]
    if len(rows) - 1 > MAX_CYLINDERS:
        raise ValueError(f"a QSM may have at most {MAX_CYLINDERS} cylinders, got {len(rows) - 1}")
    return header, rows[1:]


def _columns(p, header, rows, spec, fmt):
    idx = {}
    for key, names in spec.items():
        hit = [header.index(n) for n in names if n in header]
        idx[key] = hit[0] if hit else None
    missing = [spec[k][0] for k in ("id", "parent", "sx", "sy", "sz", "ex", "ey", "ez", "radius") if idx[k] is None]
    if missing:
        raise ValueError(f"{str(p)!r} is not a {fmt} table: missing column(s) {missing} (header: {header[:12]})")

    def col(key):
        j = idx[key]
        out = np.empty(len(rows))
        for r, row in enumerate(rows):
            try:
                v = row[j].strip().strip('"')
                out[r] = float(v) if v not in ("", "NA", "NaN", "nan") else np.nan
            except (IndexError, ValueError):
                raise ValueError(f"{str(p)!r} row {r + 2}: column {header[j]!r} is not a number") from None
        return out
    return {k: (col(k) if idx[k] is not None else None) for k in spec}


def _from_ids(p, cols, fmt, return_map):
    ids, pid = cols["id"], cols["parent"]
    if not np.all(np.isfinite(ids) & (ids == np.round(ids))):
        raise ValueError(f"{str(p)!r}: {fmt} cylinder ids must be whole numbers")
    ids = ids.astype(np.int64)
    by_id = np.argsort(ids, kind="stable")  # cylinders in id order, whatever the row order
    cols = {k: (None if v is None else v[by_id]) for k, v in cols.items()}
    ids, pid = ids[by_id], cols["parent"]
    uniq, counts = np.unique(ids, return_counts=True)
    if np.any(counts > 1):
        raise ValueError(f"{str(p)!r}: cylinder id {int(uniq[np.argmax(counts > 1)])} appears more than once")
    lookup = {int(v): i for i, v in enumerate(ids)}

    def remap(a, what):
        out = np.full(len(a), -1, np.int64)
        for i, v in enumerate(a):
            if not np.isfinite(v) or v < 0 or (int(v) not in lookup and v == 0):
                continue  # NA, -1 or 0 (aRchi and SimpleForest mark the root so) when 0 is not an id
            if v != round(v) or int(v) not in lookup:
                raise ValueError(f"{str(p)!r} row {i + 2}: {what} {v!r} is not a cylinder id")
            out[i] = lookup[int(v)]
        return out

    parent = remap(pid, "parent id")
    ext = remap(cols["extension"], "extension id") if cols["extension"] is not None else None
    br = cols["branch"]
    if br is not None and not np.all(np.isfinite(br)):
        br = None
    start = np.stack([cols["sx"], cols["sy"], cols["sz"]], axis=1)
    end = np.stack([cols["ex"], cols["ey"], cols["ez"]], axis=1)
    try:
        return cylinders_to_tree(start, end, cols["radius"], parent, branch=br, extension=ext, return_map=return_map)
    except ValueError as exc:
        raise ValueError(f"{str(p)!r}: {exc}") from None


def read_simpleforest(path, *, return_map: bool = False):
    """Read a SimpleForest QSM CSV (cylinder rows: ``ID``, ``parentID``, ``startX..Z``, ``endX..Z``, ``radius``).

    Column names are matched case-insensitively; ``branchID`` (optional) picks the continuing children; a parent
    id of -1 (or 0 when no cylinder has id 0, or empty) marks the root. Cylinders are taken in id order (the
    :class:`QSMMap` rows follow it), whatever the row order. Returns :class:`TreeArrays`.

    References
    ----------
    .. [1] Hackenberg et al. 2015, "SimpleTree — an efficient open source tool to build tree models from TLS
       clouds"; SimpleForest (Computree) QSM export.
    """
    p = _check_path(path, (".csv", ".txt"))
    header, rows = _read_table(p)
    return _from_ids(p, _columns(p, header, rows, _SF_COLUMNS, "SimpleForest"), "SimpleForest", return_map)


def read_archi(path, *, return_map: bool = False):
    """Read an aRchi QSM CSV (``cyl_ID``, ``parent_ID``, ``startX..Z``, ``endX..Z``, ``radius_cyl``).

    ``extension_ID`` and ``axis_ID`` (optional) pick the continuing children. Returns :class:`TreeArrays`.

    References
    ----------
    .. [1] Martin-Ducup et al. 2021, "aRchi: an R package for tree architecture from TLS" (its QSM table).
    """
    p = _check_path(path, (".csv", ".txt"))
    header, rows = _read_table(p)
    return _from_ids(p, _columns(p, header, rows, _ARCHI_COLUMNS, "aRchi"), "aRchi", return_map)


def read_qsm(path, *, format: str | None = None, return_map: bool = False):
    """Read a QSM in any supported format: ``.mat`` is TreeQSM; a CSV is aRchi when its header has ``cyl_ID``,
    else SimpleForest. ``format`` (one of :data:`QSM_FORMATS`) forces one. Returns :class:`TreeArrays`."""
    if format is not None:
        format = check_choice("format", format, QSM_FORMATS)
    p = _check_path(path, (".mat", ".csv", ".txt"))
    if format is None:
        if p.suffix.lower() == ".mat":
            format = "treeqsm"
        else:
            header, _ = _read_table(p)
            format = "archi" if "cyl_id" in header else "simpleforest"
    reader = {"treeqsm": read_treeqsm, "simpleforest": read_simpleforest, "archi": read_archi}[format]
    return reader(p, return_map=return_map)


# -- into Tree Wand ---------------------------------------------------------------------------------------------------
_Z_TO_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # (x, y, z) -> (x, z, -y), a rotation


def to_growth_tree(tree: TreeArrays, *, nslots: int = 2, z_up: bool = True, helper_fraction: float = 1e-3) -> Tree:
    """A growth :class:`~plantvr.growth.tree.Tree` (Tree Wand's node store) holding ``tree``.

    Tree Wand nodes have one main and ``nslots - 1`` lateral slots; a joint with more children (QSM joints often
    have 4–10) is split into a short chain: helper nodes ``helper_fraction`` × the shortest internode apart along
    the main child's direction, each carrying the next laterals. The base keeps one child only (Tree Wand's
    first internode). Every free slot is a bud, so growth continues from every node.

    Parameters
    ----------
    tree : TreeArrays
        One root (node 0).
    nslots : {2, 3}
        2 alternate, 3 opposite branching.
    z_up : bool
        The tree is z-up (QSMs are): rotate it to Tree Wand's y-up frame, (x, y, z) → (x, z, −y).
    helper_fraction : float
        In (0, 0.5].

    Returns
    -------
    Tree
        Base moved to the origin; ``radius`` and ``order`` copied, helpers take their joint's.
    """
    if not isinstance(tree, TreeArrays):
        raise ValueError(f"tree must be a TreeArrays, got {type(tree).__name__}")
    nslots = check_choice("nslots", nslots, (2, 3))
    if not isinstance(z_up, (bool, np.bool_)):
        raise ValueError(f"z_up must be a bool, got {type(z_up).__name__}")
    helper_fraction = check_range("helper_fraction", helper_fraction, 0.0, 0.5, low_open=True)
    n = len(tree)
    if n < 2 or np.count_nonzero(tree.parent < 0) != 1 or tree.parent[0] != -1:
        raise ValueError("tree must have at least 2 nodes and exactly one root, node 0")
    pos = tree.pos - tree.pos[0]
    if z_up:
        pos = pos @ _Z_TO_Y.T
    seg = np.linalg.norm(pos[1:] - pos[tree.parent[1:]], axis=1)
    if not np.all(seg > 0):
        raise ValueError(f"tree: internode ending at node {int(np.argmin(seg)) + 1} has zero length")
    eps = helper_fraction * float(seg.min())
    kids: list[list[int]] = [[] for _ in range(n)]
    for i in range(1, n):
        kids[tree.parent[i]].append(i)
    # expanded nodes, numbered as they are made (a node is made after its parent, so parents precede children)
    P, PAR, RAD, ORD, SLOTS = [pos[0]], [-1], [float(tree.radius[0])], [int(tree.order[0])], [[]]
    queue = [(0, 0)]  # (original node, new id), breadth-first

    def add(p, parent, r, o, orig=None):
        P.append(p)
        PAR.append(parent)
        RAD.append(float(r))
        ORD.append(int(o))
        SLOTS.append([])
        if orig is not None:
            queue.append((orig, len(P) - 1))
        return len(P) - 1

    k = 0
    while k < len(queue):
        v, nv = queue[k]
        k += 1
        ch = kids[v]
        if not ch:
            continue
        m = int(tree.main_child[v]) if tree.main_child[v] in ch else ch[0]
        lat = [c for c in ch if c != m]
        cap = 0 if v == 0 else nslots - 1  # the base has its first internode only
        holder = nv
        d = (pos[m] - pos[v]) / np.linalg.norm(pos[m] - pos[v])
        while len(lat) > cap:  # too many children: a helper node carries the rest
            take, lat = lat[:cap], lat[cap:]
            h = add(P[holder] + eps * d, holder, tree.radius[m], tree.order[m])
            SLOTS[holder] = [h] + [add(pos[c], holder, tree.radius[c], tree.order[c], c) for c in take]
            holder, cap = h, nslots - 1
        SLOTS[holder] = [add(pos[c], holder, tree.radius[c], tree.order[c], c) for c in [m] + lat]
    # the loop above appends helpers before their children, so PAR[i] < i holds; build the arrays
    N = len(P)
    posa = np.asarray(P, np.float64)
    par = np.asarray(PAR, np.int64)
    child = np.full((N, 3), BUD, np.int64)
    if nslots == 2:
        child[:, 2] = NO_SLOT
    child[0, 1:] = NO_SLOT
    for i, sl in enumerate(SLOTS):
        for j, c in enumerate(sl):
            child[i, j] = c
    head = np.zeros((N, 3))
    head[0] = (0.0, 1.0, 0.0)
    d = posa[1:] - posa[par[1:]]
    head[1:] = d / np.linalg.norm(d, axis=1)[:, None]
    ref = np.where(np.abs(head[:, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    lat = np.cross(head, ref)
    lat /= np.linalg.norm(lat, axis=1)[:, None]
    arrays = {
        "pos": posa, "head": head, "lat": lat, "parent": par, "child": child,
        "order": np.asarray(ORD, np.int64), "alive": np.ones(N, bool), "radius": np.asarray(RAD, np.float64),
        "vigor": np.zeros(N), "Q": np.zeros(N), "Qw": np.zeros(N), "Qslot": np.zeros((N, 3)), "L": np.zeros(N),
        "bud_vigor": np.zeros((N, 3)), "shadow_cast": np.zeros(N, bool), "born": np.zeros(N, np.int64),
        "light_factor": np.ones(N),
    }
    return Tree.from_arrays(arrays, nslots, what="scanned tree")


def model_from_tree(tree: TreeArrays, *, seed: int | None = None, z_up: bool = True, **params: Any):
    """A Tree Wand :class:`~plantvr.documents.treewand.Model` whose tree is ``tree`` (a scanned QSM), ready for
    ``prune``, ``paint``/``add_markers`` and ``step``.

    The tree goes through :func:`to_growth_tree` (nslots from ``params["branching"]``) and the model's own
    ``.tree`` loader (:meth:`Model.restore`), so it is checked like any saved tree; Tree Wand then recomputes
    light, vigor and pipe-model radii from its own parameters (the QSM's measured radii stay in ``tree``).
    """
    from plantvr.documents.treewand import Model
    from plantvr.growth.treefile import tree_to_text

    m = Model(seed=seed, **params)
    gt = to_growth_tree(tree, nslots=3 if m.params["branching"] == "opposite" else 2, z_up=z_up)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "scan.tree"
        path.write_text(tree_to_text(gt, m.params), encoding="utf-8")
        m.restore(path)
    return m

