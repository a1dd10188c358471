"""The one USD writer (:func:`emit_usd`, the ``usd`` row of the writer registry :data:`plantvr.io.writers.WRITERS`;
issue 30). USD export of a tree: mesh prims with UVs, normals, UsdPreviewSurface materials, branch-order subsets
(spec 000_treewand §3.3–§3.4; issue 16).

Layout of the stage (Y up, metres)::

    /Tree                      Xform, default prim
    /Tree/Branches             Mesh  (primvars:st, primvars:normals; GeomSubsets "order_K" if orders given)
    /Tree/Leaves               PointInstancer: one blade prototype (/Tree/Leaves/Prototypes/Blade), one
                               instance per leaf (position, orientation, scale); or a Mesh when
                               ``leaf_instancer=False``
    /Tree/Petioles             Mesh of the petioles (each bends differently, so they are not instanced)
    /Tree/Looks/Bark, /Leaf    Material with a UsdPreviewSurface shader (and a UsdUVTexture when textured)

usd-core (``pxr``) is imported only when a function here is called.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plantvr._validation import check_choice, check_range
from plantvr.geometry.leaves import LEAF_SHAPES, LeafMesh, _blade
from plantvr.geometry.mesh import BranchMesh
from plantvr.types import TriMesh

from ._checks import check_tree_meshes
from .parts import Part, as_parts, format_of, save_with

__all__ = ["BARK_MATERIAL", "LEAF_MATERIAL", "LeafInstances", "emit_usd", "export_usd", "leaf_instances"]

BARK_MATERIAL = "Bark"
LEAF_MATERIAL = "Leaf"
#: The USD suffixes (text, binary, either) and their format, the ``usd`` row of the writer registry.
USD_SUFFIXES = {".usd": "usd", ".usda": "usd", ".usdc": "usd"}
_BARK_RGB = (96 / 255, 66 / 255, 40 / 255)
_LEAF_RGB = (70 / 255, 140 / 255, 45 / 255)


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt
    except ImportError as e:               # pragma: no cover - depends on the environment
        raise RuntimeError("USD export needs usd-core: pip install usd-core") from e
    return Gf, Sdf, Usd, UsdGeom, UsdShade, Vt


@dataclass
class LeafInstances:
    """Leaves of a :class:`LeafMesh` as instances of one blade prototype.

    Attributes
    ----------
    positions : (L, 3) float64 ndarray
        Attachment point of each blade (the petiole's end p2, §10.2.2).
    rotations : (L, 3, 3) float64 ndarray
        Columns (r̂, ĥ, û): the prototype's x, y, z axes in world space (right-handed, ``r = h × u``).
    quaternions : (L, 4) float64 ndarray
        The same rotations as unit quaternions (w, x, y, z).
    scales : (L,) float64 ndarray
        Blade size (the ``leaf_size`` the leaves were built with).
    prototype_vertices : (P, 3) float64 ndarray
        Blade in its local frame (x along r̂, y along ĥ, z along û), unit size.
    prototype_faces : (Q, 3) int64 ndarray
    prototype_uv : (P, 2) float32 ndarray
    n_blade_vertices, n_blade_faces : int
        Blades occupy the first ``L × P`` vertices and ``L × Q`` faces of the leaf mesh; the rest are petioles.
    """

    positions: np.ndarray
    rotations: np.ndarray
    quaternions: np.ndarray
    scales: np.ndarray
    prototype_vertices: np.ndarray
    prototype_faces: np.ndarray
    prototype_uv: np.ndarray
    n_blade_vertices: int
    n_blade_faces: int

    def world_vertices(self) -> np.ndarray:
        """(L × P, 3) float64 blade vertices rebuilt from the instances (equal to the leaf mesh's blades)."""
        loc = self.prototype_vertices
        w = self.positions[:, None, :] + self.scales[:, None, None] * np.einsum("lij,pj->lpi", self.rotations, loc)
        return w.reshape(-1, 3)


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation
    q = Rotation.from_matrix(R).as_quat()          # (x, y, z, w)
    return np.concatenate([q[:, 3:], q[:, :3]], axis=1)


def leaf_instances(leaves: LeafMesh, *, leaf_shape: str = "ovate") -> LeafInstances:
    """Attachment frame of every leaf of a :class:`LeafMesh`, recovered from its blade vertices and frames.

    ``build_leaves`` places blade vertex k of leaf i at ``p2 + s (x_k r̂ + y_k ĥ + z_k û)``; with the frame known
    (``leaves.frames``), the attachment point p2 and the size s follow by least squares over the blade's vertices.

    Parameters
    ----------
    leaves : LeafMesh
    leaf_shape : {"ovate", "lobed"}
        The blade geometry the leaves were built with.

    Returns
    -------
    LeafInstances
        ``world_vertices()`` reproduces the blade vertices.

    Raises
    ------
    ValueError
        When the leaf mesh was not built with ``leaf_shape`` (the blades do not fit the prototype).

    References
    ----------
    .. [1] Thesis §10.2.2 (petiole p0, p1, p2; blade at p2 with the final frame); OpenUSD UsdGeomPointInstancer.
    """
    check_choice("leaf_shape", leaf_shape, LEAF_SHAPES)
    loc, uv, faces = _blade(leaf_shape)
    L, P = len(leaves.frames), len(loc)
    if len(leaves.vertices) < L * P:
        raise ValueError(f"leaves have {len(leaves.vertices)} vertices, fewer than {L} blades of {P} "
                         f"({leaf_shape!r}); pass the leaf_shape the leaves were built with")
    h, r, u = leaves.frames[:, 0], leaves.frames[:, 1], leaves.frames[:, 2]
    R = np.stack([r, h, u], axis=2)                             # columns r, h, u
    bv = leaves.vertices[:L * P].reshape(L, P, 3)
    local = np.einsum("lpi,lij->lpj", bv, R)                    # R^T v per vertex
    lc = local - local.mean(1, keepdims=True)
    mc = loc - loc.mean(0)
    s = np.einsum("lpj,pj->l", lc, mc) / float(np.sum(mc * mc)) if L else np.zeros(0)
    pos = bv.mean(1) - s[:, None] * np.einsum("lij,j->li", R, loc.mean(0))
    inst = LeafInstances(pos, R, _quat_wxyz(R) if L else np.zeros((0, 4)), s, loc.astype(float),
                         faces.astype(np.int64), uv.astype(np.float32), L * P, L * len(faces))
    if L:
        err = np.abs(inst.world_vertices() - leaves.vertices[:L * P]).max()
        scale = max(1.0, float(np.abs(leaves.vertices).max()))
        if err > 1e-6 * scale:
            raise ValueError(f"leaves do not fit the {leaf_shape!r} blade (residual {err:.3g}); "
                             f"pass the leaf_shape the leaves were built with")
    return inst


def _material(stage, path: str, rgb, *, texture: str | None, leaf: bool):
    Gf, Sdf, Usd, UsdGeom, UsdShade, Vt = _pxr()
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/PreviewSurface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.9)
    sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    color = sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    if texture is None:
        color.Set(Gf.Vec3f(*rgb))
    else:
        reader = UsdShade.Shader.Define(stage, path + "/stReader")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        tex = UsdShade.Shader.Define(stage, path + "/Texture")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(texture)
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("repeat")
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("repeat")
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
            reader.ConnectableAPI(), "result")
        rgb_out = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        color.ConnectToSource(rgb_out)
        if leaf:
            a_out = tex.CreateOutput("a", Sdf.ValueTypeNames.Float)
            sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(a_out)
            sh.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def _mesh(stage, path: str, m, material, *, double_sided: bool):
    Gf, Sdf, Usd, UsdGeom, UsdShade, Vt = _pxr()
    mesh = UsdGeom.Mesh.Define(stage, path)
    v = np.ascontiguousarray(m.vertices, np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(v))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(m.faces), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(m.faces, np.int32).ravel()))
    lo, hi = (v.min(0), v.max(0)) if len(v) else (np.zeros(3, np.float32), np.zeros(3, np.float32))
    mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    mesh.CreateDoubleSidedAttr(bool(double_sided))
    api = UsdGeom.PrimvarsAPI(mesh)
    st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(m.uv, np.float32)))
    nrm = api.CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.vertex)
    nrm.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(m.normals, np.float32)))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    return mesh


@dataclass(eq=False)
class _Part(TriMesh):
    """One USD mesh prim's arrays (a leaf prototype, the petioles)."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray


def _instancer(stage, path: str, inst: LeafInstances, material):
    Gf, Sdf, Usd, UsdGeom, UsdShade, Vt = _pxr()
    pi = UsdGeom.PointInstancer.Define(stage, path)
    proto_path = path + "/Prototypes/Blade"
    UsdGeom.Scope.Define(stage, path + "/Prototypes")
    nrm = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (len(inst.prototype_vertices), 1))
    proto = _Part(inst.prototype_vertices, inst.prototype_faces, nrm, inst.prototype_uv)
    _mesh(stage, proto_path, proto, material, double_sided=True)
    pi.CreatePrototypesRel().SetTargets([Sdf.Path(proto_path)])
    L = len(inst.positions)
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(L, np.int32)))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(inst.positions, np.float32)))
    q = np.ascontiguousarray(inst.quaternions, np.float64)
    pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(*map(float, x)) for x in q]))   # wide support
    pi.CreateOrientationsfAttr(Vt.QuatfArray([Gf.Quatf(*map(float, x)) for x in q]))  # precise (read first)
    sc = np.repeat(inst.scales[:, None], 3, axis=1)
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(sc, np.float32)))
    wv = inst.world_vertices() if L else np.zeros((1, 3))
    lo, hi = wv.min(0), wv.max(0)
    pi.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
    return pi


def export_usd(path, branches: BranchMesh, leaves: LeafMesh | None = None, *, order=None,
               textures: bool = False, bark: str = "furrowed", leaf: str = "ovate",
               meters_per_unit: float = 1.0, leaf_instancer: bool = True, leaf_shape: str | None = None) -> Path:
    """Write a tree to a USD layer (.usd/.usdc binary, .usda text).

    Parameters
    ----------
    path : str or pathlib.Path
        Output file; the suffix picks the format.
    branches : BranchMesh
    leaves : LeafMesh, optional
    order : (N,) int ndarray, optional
        Branch order of every node (indexed like ``branches.node_id``); adds one face GeomSubset per order
        (family ``branchOrder``, a partition of the branch faces).
    textures : bool
        Also write the procedural bark and leaf textures as PNGs beside the file and read them in the
        materials through UsdUVTexture; otherwise the materials carry constant colours.
    bark, leaf : str
        Texture choices, as in :func:`plantvr.io.tree.export_tree`.
    meters_per_unit : float
        Stage metadata ``metersPerUnit``.
    leaf_instancer : bool
        Write the blades as a ``UsdGeomPointInstancer`` of one prototype blade (see :func:`leaf_instances`) and
        the petioles as a mesh; otherwise all leaves as one mesh.
    leaf_shape : {"ovate", "lobed"}, optional
        Blade geometry the leaves were built with; default ``leaf``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    RuntimeError
        When usd-core is not installed.

    References
    ----------
    .. [1] OpenUSD UsdGeomMesh, UsdGeomSubset and UsdPreviewSurface specifications.
    """
    from plantvr.geometry.textures import BARK_TEXTURES, LEAF_TEXTURES, bark_texture, leaf_texture

    path = Path(path)
    format_of(path, USD_SUFFIXES)
    check_choice("bark", bark, BARK_TEXTURES)
    check_choice("leaf", leaf, LEAF_TEXTURES)
    meters_per_unit = check_range("meters_per_unit", meters_per_unit, 0.0, np.inf, low_open=True)
    leaf_shape = check_choice("leaf_shape", leaf if leaf_shape is None else leaf_shape, LEAF_SHAPES)
    from plantvr._validation import check_index

    check_tree_meshes(branches, leaves)
    node_id = check_index("branches.node_id", branches.node_id, shape=(len(branches.vertices),), low=0,
                          high=2**62)
    inst = None
    if leaves is not None and len(leaves.faces) and leaf_instancer:
        inst = leaf_instances(leaves, leaf_shape=leaf_shape)        # raises before any file is written
    if order is not None:
        nmax = int(node_id.max()) + 1 if len(node_id) else 0
        order = check_index("order", order, shape=(None,), low=0, high=2**31 - 1)
        if len(order) < nmax:
            raise ValueError(f"order must have at least {nmax} entries (one per node), got {len(order)}")
    face_order = None
    if order is not None and len(branches.faces):
        face_order = order[branches.node_id[branches.faces[:, 0]]]
    _pxr()                                                          # usd-core is there before anything is written
    parts = [Part("bark", branches.vertices, branches.faces, normals=branches.normals, uv=branches.uv,
                  image=bark_texture(bark) if textures else None)]
    if leaves is not None:
        parts.append(Part("leaf", leaves.vertices, leaves.faces, normals=leaves.normals, uv=leaves.uv,
                          image=leaf_texture(leaf) if textures else None))
    return save_with(emit_usd, path, parts, instances=inst, face_order=face_order,
                meters_per_unit=meters_per_unit)


def emit_usd(res, name: str, parts, *, instances: LeafInstances | None = None, face_order=None,
             meters_per_unit: float = 1.0, **_other) -> None:
    """The USD emitter of the writer registry: a tree stage (layout in the module docstring) as ``name`` in
    ``res``'s folder, its format by the suffix (.usda text, .usd/.usdc binary).

    ``parts[0]`` is the branch mesh (``/Tree/Branches``), ``parts[1]`` if given the leaf mesh (``/Tree/Leaves``,
    with ``/Tree/Petioles`` when ``instances`` are given); a part with an image reads it as the texture
    ``<stem>_<part name>.png``, written beside the layer. ``face_order`` (one branch order per branch face) adds
    the ``branchOrder`` GeomSubsets.
    """
    import contextlib
    import os
    import tempfile

    parts = as_parts(parts)
    if len(parts) not in (1, 2):
        raise ValueError(f"parts must be the branches and optionally the leaves, got {len(parts)} parts")
    branches = parts[0]
    leaves = parts[1] if len(parts) == 2 else None
    stem, suffix = Path(name).stem, Path(name).suffix
    tex = []
    for p in parts:
        tex.append(None if p.image is None else f"{stem}_{p.name}.png")
        if p.image is not None:
            res.write_png(tex[-1], np.asarray(p.image))
    # pxr saves a layer to a file name of its format: a temporary file in the same folder, whose bytes are then
    # written through the resolver (a failed export leaves the previous files and no temporary file; issue 20)
    fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=suffix, dir=res.folder)
    os.close(fd)
    os.unlink(tmp)
    try:
        _write_stage(tmp, branches, leaves, instances, face_order, tex[0], tex[1] if leaves is not None else None,
                     meters_per_unit)
        with open(tmp, "rb") as fh:
            data = fh.read()
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
    res.write(name, data)


def _write_stage(tmp: str, branches, leaves, inst, face_order, bark_tex, leaf_tex, meters_per_unit) -> None:
    Gf, Sdf, Usd, UsdGeom, UsdShade, Vt = _pxr()
    stage = Usd.Stage.CreateNew(tmp)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    root = UsdGeom.Xform.Define(stage, "/Tree")
    stage.SetDefaultPrim(root.GetPrim())
    UsdGeom.Scope.Define(stage, "/Tree/Looks")
    bark_mat = _material(stage, f"/Tree/Looks/{BARK_MATERIAL}", _BARK_RGB, texture=bark_tex, leaf=False)
    mesh = _mesh(stage, "/Tree/Branches", branches, bark_mat, double_sided=False)
    if face_order is not None:
        for k in np.unique(face_order):
            idx = np.flatnonzero(face_order == k).astype(np.int32)
            UsdGeom.Subset.CreateGeomSubset(mesh, f"order_{int(k)}", UsdGeom.Tokens.face,
                                            Vt.IntArray.FromNumpy(idx), "branchOrder", UsdGeom.Tokens.partition)
    if leaves is not None and len(leaves.faces):
        leaf_mat = _material(stage, f"/Tree/Looks/{LEAF_MATERIAL}", _LEAF_RGB, texture=leaf_tex, leaf=True)
        if inst is None:
            _mesh(stage, "/Tree/Leaves", leaves, leaf_mat, double_sided=True)
        else:
            _instancer(stage, "/Tree/Leaves", inst, leaf_mat)
            if len(leaves.faces) > inst.n_blade_faces:
                nv = inst.n_blade_vertices
                pet = _Part(leaves.vertices[nv:], leaves.faces[inst.n_blade_faces:] - nv, leaves.normals[nv:],
                            leaves.uv[nv:])
                _mesh(stage, "/Tree/Petioles", pet, leaf_mat, double_sided=False)
    stage.GetRootLayer().Save()
