"""The model's tree as meshes and files: generalized-cylinder branches and leaves (spec 000_treewand §3)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import trimesh

from .geometry.export import export_tree
from .geometry.leaves import IncrementalLeafMesh, LeafMesh, build_leaves
from .geometry.mesh import BranchMesh, IncrementalBranchMesh, build_branch_mesh
from .documents.treewand import Model, Snapshot

__all__ = ["tree_geometry", "IncrementalTreeGeometry", "tree_trimesh", "export_model", "snapshot_export", "export_model_as", "export_main",
           "EXPORT_FORMATS", "BILLBOARD_LOD"]

def tree_geometry(snap: Snapshot, params: dict[str, Any], *, leaves: bool = True,
                  lod: tuple[int, int] = (6, 32)) -> tuple[BranchMesh, LeafMesh | None]:
    """Branch mesh and leaf mesh of a snapshot, with the appearance parameters of ``params`` (§4.11 B.2)."""
    branches = build_branch_mesh(snap.pos, snap.parent, snap.radius, main_child=snap.main_child,
                                 bezier_w=params["bezier_weight"], lod=lod, tip_radius=params["tip_radius"],
                                 bark_rate=params["bark_rate"])
    leaf = None
    if leaves and params["leaf_size"] > 0 and len(snap.buds["pos"]):
        leaf = build_leaves(snap.buds["pos"], snap.buds["dir"], snap.buds["radius"], bud_up=snap.buds["up"],
                            leaf_size=params["leaf_size"], radius_threshold=3 * params["tip_radius"],
                            petiole_length=params["petiole_length"], e_twist=params["petiole_twist"],
                            e_up=params["petiole_bend_up"], e_right=params["petiole_bend_right"],
                            iterations=params["leaf_iterations"],
                            leaf_shape=params["leaf_texture"], rng=0)
    return branches, leaf


_GEOMETRY_PARAMS = ("tip_radius", "bezier_weight", "bark_rate", "leaf_size", "petiole_length", "petiole_twist",
                    "petiole_bend_up", "petiole_bend_right", "leaf_iterations", "leaf_texture")


class IncrementalTreeGeometry:
    """Branch and leaf meshes kept across snapshots: each update re-meshes only what changed (spec §3.5, item 20).

    Views call :meth:`update` with every new snapshot; a change of an appearance parameter rebuilds.
    Buffers may hold degenerate rows (free blocks); use :func:`tree_geometry` for export.
    """

    def __init__(self, *, lod: tuple[int, int] = (6, 32), leaves: bool = True):
        self.lod, self.leaves = lod, leaves
        self._key: tuple | None = None
        self.branches: IncrementalBranchMesh | None = None
        self.leaf_mesh: IncrementalLeafMesh | None = None

    def update(self, snap: Snapshot, params: dict[str, Any]) -> None:
        """Bring the meshes to ``snap`` (the first call, or new appearance parameters, build from scratch)."""
        key = tuple(params[k] for k in _GEOMETRY_PARAMS)
        tip = params["tip_radius"]
        if key != self._key or self.branches is None:
            self._key = key
            self.branches = IncrementalBranchMesh(snap.pos, snap.parent, snap.radius, main_child=snap.main_child,
                                                  lod=self.lod, tip_radius=tip, bezier_w=params["bezier_weight"],
                                                  bark_rate=params["bark_rate"])
            self.leaf_mesh = IncrementalLeafMesh(
                radius_threshold=3 * tip, petiole_radius=0.3 * tip, leaf_size=params["leaf_size"],
                petiole_length=params["petiole_length"], e_twist=params["petiole_twist"],
                e_up=params["petiole_bend_up"], e_right=params["petiole_bend_right"],
                iterations=params["leaf_iterations"], leaf_shape=params["leaf_texture"]) if self.leaves else None
        else:
            self.branches.update(snap.pos, snap.parent, snap.radius, main_child=snap.main_child)
        if self.leaf_mesh is not None:
            b = snap.buds
            self.leaf_mesh.update(b["pos"], b["dir"], b["radius"], b["up"])


def tree_trimesh(model: Model, *, leaves: bool = False) -> trimesh.Trimesh:
    """The branches (and optionally leaves) of ``model``'s latest snapshot as one ``trimesh.Trimesh``."""
    branches, leaf = tree_geometry(model.snapshot, model.params, leaves=leaves)
    parts = [branches.to_trimesh()] + ([leaf.to_trimesh()] if leaf is not None else [])
    return trimesh.util.concatenate(parts) if len(parts) > 1 else parts[0]


def export_model(model: Model, path: str | Path) -> Path:
    """Write the model's tree (branches, leaves, textures where the format has them) to .ply, .obj or .glb."""
    branches, leaf = tree_geometry(model.snapshot, model.params)
    return export_tree(path, branches, leaf, bark=model.bark_texture, leaf=model.leaf_texture)


# -- issue 16: every format, LOD levels, and the ``plantvr export`` command --------------------------------------
import numpy as np  # noqa: I001
EXPORT_FORMATS = {"usd": ".usd", "glb": ".glb", "ply": ".ply", "obj": ".obj"}
"""``plantvr export --format`` choices and the suffix each writes (.usda/.usdc also pick USD)."""

BILLBOARD_LOD = 4
"""``lod`` value that exports the billboard impostor instead of a mesh level."""

_SUFFIX_FORMAT = {".usd": "usd", ".usda": "usd", ".usdc": "usd", ".glb": "glb", ".ply": "ply", ".obj": "obj"}


def _bud_nodes(snap: Snapshot) -> np.ndarray:
    """Node each bud sits on (buds are at their node's position); -1 where no node matches."""
    from scipy.spatial import cKDTree

    bp = np.asarray(snap.buds["pos"], float)
    if not len(bp) or not len(snap.pos):
        return np.zeros(len(bp), np.int64)
    d, i = cKDTree(np.asarray(snap.pos, float)).query(bp)
    return np.where(d <= 1e-9 * max(1.0, float(np.abs(snap.pos).max())), i, -1).astype(np.int64)


def snapshot_export(snap: Snapshot, params: dict[str, Any], path: str | Path, *, lod: int = 0,
                    leaves: bool = True, skinned: bool = True) -> Path:
    """Write a snapshot's tree at one LOD level to USD, skinned glTF (.glb), PLY or OBJ (issue 16).

    Parameters
    ----------
    snap : Snapshot
    params : dict
        Appearance parameters (``bezier_weight``, ``tip_radius``, ``bark_rate``, leaf and texture settings).
    path : str or pathlib.Path
        Output file; its suffix (.usd/.usda/.usdc, .glb, .ply, .obj) picks the format.
    lod : int
        Level of :func:`plantvr.geometry.lod.lod_chain`, in [0, 3]: fewer cylinder sides and, from level 1 on,
        twigs pruned to the level's triangle budget; leaves stay only on the nodes kept. ``BILLBOARD_LOD`` (4)
        writes the billboard impostor (.glb or .obj with its RGBA atlas), rendered offscreen from level 1 with
        the leaves (:func:`plantvr.view.billboard.make_billboard`).
    leaves : bool
        Include the leaves.
    skinned : bool
        For .glb: a skeleton with skin weights and the growth animation
        (:func:`plantvr.geometry.gltf_skin.export_skinned_glb`); otherwise the textured trimesh scene.

    Returns
    -------
    pathlib.Path
    """
    from ._validation import check_choice, check_int
    from .geometry.lod import lod_chain

    path = Path(path)
    fmt = _SUFFIX_FORMAT.get(path.suffix.lower())
    if fmt is None:
        check_choice("path suffix", path.suffix.lower(), tuple(_SUFFIX_FORMAT))
    lod = check_int("lod", lod, 0, BILLBOARD_LOD)
    billboard = lod == BILLBOARD_LOD
    if billboard and fmt not in ("glb", "obj"):
        raise ValueError(f"lod {BILLBOARD_LOD} (the billboard) is written as .glb or .obj, got {path.suffix!r}")
    if len(snap.pos) < 2:
        raise ValueError("the tree is empty (no internodes): grow it before exporting")
    mesh_lod = 1 if billboard else lod
    chain = lod_chain(snap.pos, snap.parent, snap.radius, main_child=snap.main_child, levels=mesh_lod + 1,
                      tip_radius=params["tip_radius"], bezier_w=params["bezier_weight"],
                      bark_rate=params["bark_rate"])
    level = chain[mesh_lod]
    branches = level.mesh
    leaf = None
    bud_node = _bud_nodes(snap)
    if leaves and params["leaf_size"] > 0 and len(bud_node):
        keep = (bud_node >= 0) & level.alive[np.maximum(bud_node, 0)]
        b = {k: np.asarray(v)[keep] for k, v in snap.buds.items()}
        bud_node = bud_node[keep]
        if len(bud_node):
            leaf = build_leaves(b["pos"], b["dir"], b["radius"], bud_up=b["up"], leaf_size=params["leaf_size"],
                                radius_threshold=3 * params["tip_radius"],
                                petiole_length=params["petiole_length"], e_twist=params["petiole_twist"],
                                e_up=params["petiole_bend_up"], e_right=params["petiole_bend_right"],
                                iterations=params["leaf_iterations"], leaf_shape=params["leaf_texture"], rng=0)
            if not len(leaf.faces):
                leaf = None
    bark, leaf_tex = params["bark_texture"], params["leaf_texture"]
    if billboard:
        # offscreen rendering lives in the view layer
        from .view.billboard import make_billboard
        return make_billboard([branches, leaf], views=2, resolution=256).export(path)
    if fmt == "usd":
        from .geometry.usd import export_usd
        return export_usd(path, branches, leaf, order=np.asarray(snap.order, np.int64), bark=bark, leaf=leaf_tex)
    if fmt == "glb" and skinned:
        from .geometry.gltf_skin import export_skinned_glb
        return export_skinned_glb(path, branches, snap.pos, snap.parent, snap.radius, main_child=snap.main_child,
                                  leaves=leaf, leaf_node=bud_node if leaf is not None else None)
    return export_tree(path, branches, leaf, bark=bark, leaf=leaf_tex)


def export_model_as(model: Model, path: str | Path, *, lod: int = 0, leaves: bool = True,
                    skinned: bool = True) -> Path:
    """:func:`export_model` for every format and LOD level: USD, skinned .glb, PLY or OBJ by suffix.

    Parameters
    ----------
    model : Model
    path : str or pathlib.Path
        Output file (.usd/.usda/.usdc, .glb, .ply, .obj).
    lod : int
        LOD level in [0, 3], or 4 for the billboard (see :func:`snapshot_export`).
    leaves, skinned : bool
        As in :func:`snapshot_export`.

    Returns
    -------
    pathlib.Path
    """
    return snapshot_export(model.snapshot, model.params, path, lod=lod, leaves=leaves, skinned=skinned)


def export_main(argv: list[str] | None = None) -> int:
    """``plantvr export TREE_FILE --format usd|glb|ply|obj [--lod N] [-o OUT] [--no-leaves] [--unskinned]``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after ``export``; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 on success, 2 when the tree file or an option is rejected (the reason is printed to stderr).
    """
    import argparse
    import os
    import sys
    import time

    ap = argparse.ArgumentParser(prog="plantvr export",
                                 description="Write a saved tree (.tree or .npz) as USD, glTF (.glb), PLY or OBJ.")
    ap.add_argument("tree_file", metavar="TREE_FILE", help="a tree saved by Model.save (.tree or .npz)")
    ap.add_argument("--format", choices=tuple(EXPORT_FORMATS), default=None,
                    help="output format (default: from the suffix of -o, else glb)")
    ap.add_argument("--lod", type=int, default=0,
                    help="LOD level 0 (full) to 3 (coarsest), 4 = billboard (glb/obj); default 0")
    ap.add_argument("-o", "--output", default=None, help="output file (default: TREE_FILE with the format's suffix)")
    ap.add_argument("--no-leaves", action="store_true", help="branches only")
    ap.add_argument("--unskinned", action="store_true", help="glb without skeleton and growth animation")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)

    def fail(msg: str) -> int:                # one line, no traceback (cli.main prints the same way)
        print(f"plantvr export: error: {msg}".replace("\n", " "), file=sys.stderr)
        return 2

    src = Path(args.tree_file)
    if args.output is not None:
        out = Path(args.output)
        fmt = _SUFFIX_FORMAT.get(out.suffix.lower())
        if args.format is not None and fmt != args.format:
            if fmt is None:
                out = out.with_suffix(EXPORT_FORMATS[args.format])
            else:
                return fail(f"--format {args.format} does not match the output suffix {out.suffix!r}")
    else:
        out = src.with_suffix(EXPORT_FORMATS[args.format or "glb"])
    try:
        if _SUFFIX_FORMAT.get(out.suffix.lower()) is None:
            raise ValueError(f"-o {str(out)!r}: the output suffix must be one of {sorted(_SUFFIX_FORMAT)}")
        if not 0 <= args.lod <= BILLBOARD_LOD:
            raise ValueError(f"lod must be an integer in [0, {BILLBOARD_LOD}], got {args.lod}")
        folder = out.parent if str(out.parent) else Path(".")
        if not folder.is_dir():
            raise ValueError(f"-o {str(out)!r}: the folder {str(folder)!r} does not exist")
        if not os.access(folder, os.W_OK):
            raise ValueError(f"-o {str(out)!r}: the folder {str(folder)!r} is not writable")
        if not src.is_file():
            raise ValueError(f"TREE_FILE {str(src)!r} does not exist")
        model = Model.load(src)
        t0 = time.perf_counter()
        path = export_model_as(model, out, lod=args.lod, leaves=not args.no_leaves, skinned=not args.unskinned)
    except ValueError as exc:
        return fail(str(exc))
    except OSError as exc:                     # disk full, permission denied while writing
        return fail(f"{exc.strerror or exc}{f': {exc.filename}' if exc.filename else ''}")
    print(f"wrote {path} ({model.snapshot.n_internodes} internodes, LOD {args.lod}, "
          f"{time.perf_counter() - t0:.2f} s)")
    return 0
