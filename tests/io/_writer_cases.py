"""Every exporter of plantvr on seeded inputs, for the bit-identity check of the writer registry (issue 30).

:func:`write_all` writes each export path into a folder; :func:`digests` gives the sha256 of every file there
(side files too: a .gltf's .bin, an OBJ's .mtl and PNGs, frame sequences). ``python tests/io/_writer_cases.py``
prints them as JSON (how ``tests/io/writer_hashes.json`` was made, at commit 4e157e1, before the registry; the
USD layers embed nothing time-dependent: two runs minutes apart gave the same bytes).
"""
from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

__all__ = ["billboard", "digests", "write_all"]


def _snapshot():
    from plantvr import Model
    from plantvr.growth.scenarios import demo_session, run

    model = Model(seed=1)
    run(model, demo_session(), 12, range(12))
    return model.snapshot, model.params


def _tree_meshes():
    from plantvr.geometry.synthetic import leafy_tree

    *_, m, lv, _ = leafy_tree(40, seed=7)
    return m, lv


def _segmentation():
    import trimesh

    from plantvr.documents.labels import Segmentation

    s = trimesh.creation.icosphere(2)
    lab = np.where(s.vertices[:, 2] > 0.2, 2, np.where(s.vertices[:, 0] > 0, 1, 0)).astype(np.uint8)
    return Segmentation(s.vertices, s.faces, labels=lab)


def billboard():
    """A seeded :class:`plantvr.view.billboard.Billboard` (atlas made up, no rendering)."""
    from plantvr.view.billboard import Billboard

    rng = np.random.default_rng(3)
    atlas = rng.integers(0, 256, (16, 32, 4), dtype=np.uint8)
    atlas[..., 3] = np.where(atlas[..., 3] > 128, 255, 0)
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    verts, uvs, faces = [], [], []
    for k, right in enumerate(([1.0, 0, 0], [0, 0, -1.0])):
        verts.append(np.array([0, 1.0, 0]) + corners[:, :1] * right + corners[:, 1:] * [0, 1.0, 0])
        uvs.append(np.stack([(k + (corners[:, 0] + 1) / 2) / 2, (corners[:, 1] + 1) / 2], axis=1))
        faces.append(np.array([[0, 1, 2], [0, 2, 3]]) + 4 * k)
    return Billboard(np.concatenate(verts), np.concatenate(faces).astype(np.int64), atlas, np.concatenate(uvs),
                     np.array([0, 1.0, 0]), 1.0)


def write_all(out: str | os.PathLike, *, usd: bool = True, billboards: bool = True) -> Path:
    """Write every export path on seeded inputs into ``out`` (created); returns it."""
    import trimesh

    from plantvr.io import labels as L
    from plantvr.io.landscape import export_landscape
    from plantvr.io.mesh import export_mesh
    from plantvr.io.obj import write_obj_sequence
    from plantvr.io.tree import export_skinned_glb, export_tree, snapshot_export

    out = Path(out)
    out.mkdir(exist_ok=True)
    ico = trimesh.creation.icosphere(1)
    for ft in ("ply", "obj", "gltf", "glb"):
        (out / f"mesh_{ft}").mkdir(exist_ok=True)
        export_mesh(ico, out / f"mesh_{ft}" / f"m.{ft}")
    branches, leaves = _tree_meshes()
    for s in ("ply", "obj", "glb"):
        (out / f"tree_{s}").mkdir(exist_ok=True)
        export_tree(out / f"tree_{s}" / f"t.{s}", branches, leaves, bark="birch", leaf="lobed")
    snap, params = _snapshot()
    (out / "skinned").mkdir(exist_ok=True)
    export_skinned_glb(out / "skinned" / "s.glb", branches, *_tree_arrays(), leaves=None)
    kinds = (("usda", 0), ("usdc", 1), ("glb", 0), ("glb", 2), ("ply", 1), ("obj", 3))
    for s, lod in kinds:
        if s.startswith("usd") and not usd:
            continue
        (out / f"snap_{s}_{lod}").mkdir(exist_ok=True)
        snapshot_export(snap, params, out / f"snap_{s}_{lod}" / f"t.{s}", lod=lod)
    (out / "snap_glb_flat").mkdir(exist_ok=True)
    snapshot_export(snap, params, out / "snap_glb_flat" / "t.glb", lod=1, skinned=False)
    if usd:
        from plantvr.io.usd import export_usd
        (out / "usd_tex").mkdir(exist_ok=True)
        export_usd(out / "usd_tex" / "t.usda", branches, leaves, textures=True, leaf_instancer=False)
    seg = _segmentation()
    (out / "labels").mkdir(exist_ok=True)
    L.export_ply(seg, out / "labels" / "s.ply")
    L.export_ply(seg, out / "labels" / "v.ply", visible_only=True, with_labels=False)
    L.export_gltf(seg, out / "labels" / "s.glb")
    L.export_gltf(seg, out / "labels" / "s.gltf")
    for fmt in L.LABEL_FORMATS:
        (out / f"label_meshes_{fmt}").mkdir(exist_ok=True)
        L.export_label_meshes(seg, out / f"label_meshes_{fmt}", fmt=fmt)
    rng = np.random.default_rng(5)
    frames = ico.vertices[None] + 0.01 * rng.normal(size=(3, *ico.vertices.shape))
    write_obj_sequence(os.fspath(out / "seq"), np.asarray(ico.faces, np.int64), frames, prefix="fl",
                       fixed=np.array([0, 4, 7]))
    (out / "landscape").mkdir(exist_ok=True)
    t0 = (branches.vertices, branches.faces)
    export_landscape(out / "landscape" / "l.glb", [t0, t0, (ico.vertices, ico.faces)],
                     np.array([[0, 0, 0], [3.0, 0, 1], [-2, 0.5, 2]]), yaw=np.array([0.0, 1.0, 2.0]),
                     scale=np.array([1.0, 0.5, 2.0]), terrain=(rng.random((6, 5)), (10.0, 8.0)),
                     leaves=[(leaves.vertices, leaves.faces), (leaves.vertices, leaves.faces), None])
    if billboards:
        bb = billboard()
        for s in ("glb", "obj"):
            (out / f"billboard_{s}").mkdir(exist_ok=True)
            bb.export(out / f"billboard_{s}" / f"b.{s}")
    return out


def _tree_arrays():
    from plantvr.geometry.synthetic import random_tree

    pos, parent, radius, _ = random_tree(40, seed=7)
    return pos, parent, radius


def digests(folder: str | os.PathLike, *, skip=("billboard_",)) -> dict[str, str]:
    """``{relative path: sha256}`` of every file under ``folder`` (paths under a ``skip`` prefix left out)."""
    folder = Path(folder)
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()
            and not p.relative_to(folder).as_posix().startswith(tuple(skip))}


if __name__ == "__main__":
    print(json.dumps(digests(write_all(sys.argv[1])), indent=1))
