"""Yggdrasil: L-system graph → control mesh → Loop subdivision (spec 001_subdivision §1.4–§3).

Pipeline::

    g = parse_lsystem("F(2,0.2)[+F(1,0.1)][-F(1,0.1)]F(1,0.15)", angle=40)   # or graph_from_arrays(pos, parent, radius)
    cm = build_control_mesh(g, sides=4)                                        # open at base and tips
    mesh = tree_mesh(g, levels=3)                                              # watertight trimesh.Trimesh
    plantvr.io.mesh.export_mesh(mesh, "tree.ply")                          # writers live in plantvr.io
    mesh, uv = tree_mesh_uv(g, levels=3)                                       # + per-corner bark UVs (F, 3, 2)
    plantvr.io.obj.write_obj("tree.obj", mesh.vertices, mesh.faces, uv)       # f v/vt/vn, seams kept
"""
from __future__ import annotations

from plantvr._validation import check_int

from .graph import BranchGraph, graph_from_arrays, joint_offsets, pair_offset, simplify
from .loop import cap_boundaries, loop_weight, subdivide_loop
from .lsystem import parse_lsystem
from .mesh import ControlMesh, build_control_mesh, radius_factor
from .selfintersect import self_intersections
from .uv import branch_uvs, control_uvs, propagate_uvs, read_obj, subdivide_uvs, vertex_normals

__all__ = [
    "BranchGraph",
    "ControlMesh",
    "as_graph",
    "branch_uvs",
    "build_control_mesh",
    "cap_boundaries",
    "control_uvs",
    "graph_from_arrays",
    "joint_offsets",
    "loop_weight",
    "pair_offset",
    "parse_lsystem",
    "propagate_uvs",
    "radius_factor",
    "read_obj",
    "self_intersections",
    "simplify",
    "subdivide_loop",
    "subdivide_uvs",
    "tree_mesh",
    "tree_mesh_uv",
    "vertex_normals",
]


def as_graph(tree) -> BranchGraph:
    """Coerce an L-system string, a ``(pos, parent, radius)`` tuple or a :class:`BranchGraph` to a graph.

    Parameters
    ----------
    tree : str or tuple or BranchGraph or Snapshot or Model
        An LST / turtle string (parsed with defaults), a grown tree's ``(pos, parent, radius)`` node arrays,
        a growth-engine snapshot (anything with ``pos``, ``parent`` and ``radius`` node arrays, e.g.
        ``plantvr.Model.snapshot``), an object holding such a ``snapshot`` (a ``plantvr.Model``), or a graph.

    Returns
    -------
    BranchGraph

    Raises
    ------
    ValueError
        For any other type, or if the arrays do not form a forward-ordered tree (see
        :func:`graph_from_arrays`).
    """
    if isinstance(tree, BranchGraph):
        return tree.validate()
    if isinstance(tree, str):
        return parse_lsystem(tree)
    if isinstance(tree, (tuple, list)) and len(tree) == 3:
        return graph_from_arrays(*tree)
    if not all(hasattr(tree, a) for a in ("pos", "parent", "radius")) and hasattr(tree, "snapshot"):
        tree = tree.snapshot                     # a plantvr.Model: read its latest published snapshot
    if all(hasattr(tree, a) for a in ("pos", "parent", "radius")):
        if len(tree.pos) < 2:
            raise ValueError(f"tree: the snapshot has {len(tree.pos)} node(s); grow at least one internode first")
        return graph_from_arrays(tree.pos, tree.parent, tree.radius)
    raise ValueError(f"tree must be an L-system str, a (pos, parent, radius) tuple, a growth snapshot, a Model "
                     f"or a BranchGraph, got {type(tree).__name__}")


def tree_mesh(tree, *, levels: int = 3, sides: int = 4, compensate_radius: bool = True, cap: bool = True,
              weight_rule: str = "loop_cos", boundary_rule: str = "fixed", **control_kw):
    """Branch structure → one smooth watertight ``trimesh.Trimesh`` (spec §2.8).

    The open control mesh is Loop-subdivided ``levels`` times with fixed base and tips (spec §3.2), then
    every open loop is closed by a flat fan (``cap=True``), so the result is watertight and the tips stay
    sharp.

    Parameters
    ----------
    tree : str or tuple or BranchGraph or Snapshot or Model
        See :func:`as_graph` (e.g. ``plantvr.Model(...).snapshot`` of a grown tree).
    levels : int
        Loop subdivision levels, 0–6.
    sides : int
        Vertices per branch loop (3–64).
    compensate_radius : bool
        See :func:`build_control_mesh`.
    cap : bool
        Close base and tips.
    weight_rule, boundary_rule : str
        See :func:`subdivide_loop`.
    **control_kw
        Further options of :func:`build_control_mesh` (``offset_mode``, ``min_offset``, ``rounding`` ...).

    Returns
    -------
    trimesh.Trimesh
        Built with ``process=False``.
    """
    import trimesh

    levels = check_int("levels", levels, 0, 6)
    g = as_graph(tree)
    cm = build_control_mesh(g, sides=sides, compensate_radius=compensate_radius, cap=False,
                            **{"fold_level": max(1, min(levels, 4)), **control_kw})
    V, F = subdivide_loop(cm.vertices, cm.faces, levels, weight_rule=weight_rule, boundary_rule=boundary_rule)
    if cap:
        V, F = cap_boundaries(V, F)
    return trimesh.Trimesh(V, F, process=False)


def tree_mesh_uv(tree, *, levels: int = 3, sides: int = 4, compensate_radius: bool = True, cap: bool = True,
                 wrap: str = "triangle", weight_rule: str = "loop_cos", boundary_rule: str = "fixed", **control_kw):
    """Like :func:`tree_mesh`, with per-corner bark UVs carried through subdivision (spec §2.6, §3.3).

    Tubes get the cylindrical map, joints UVs by propagation (:func:`control_uvs`); Loop subdivision carries
    them linearly (:func:`subdivide_uvs`); cap faces added after subdivision get propagated UVs too.

    Parameters
    ----------
    tree, levels, sides, compensate_radius, cap, weight_rule, boundary_rule, **control_kw
        See :func:`tree_mesh`.
    wrap : {"triangle", "coordinate", "none"}
        See :func:`propagate_uvs`.

    Returns
    -------
    mesh : trimesh.Trimesh
        The same mesh as :func:`tree_mesh` with the same arguments (``process=False``).
    uv : (F, 3, 2) float64 ndarray
        Corner UVs of every face; write them with :func:`plantvr.io.obj.write_obj`.
    """
    import numpy as np
    import trimesh

    levels = check_int("levels", levels, 0, 6)
    g = as_graph(tree)
    cm = build_control_mesh(g, sides=sides, compensate_radius=compensate_radius, cap=False,
                            **{"fold_level": max(1, min(levels, 4)), **control_kw})
    uv = subdivide_uvs(control_uvs(cm, wrap=wrap), levels)
    V, F = subdivide_loop(cm.vertices, cm.faces, levels, weight_rule=weight_rule, boundary_rule=boundary_rule)
    if cap:
        nf = len(F)
        V, F = cap_boundaries(V, F)
        uv = np.concatenate([uv, np.full((len(F) - nf, 3, 2), np.nan)])
        known = np.arange(len(F)) < nf
        uv = propagate_uvs(V, F, uv, known, wrap=wrap)
    return trimesh.Trimesh(V, F, process=False), uv
