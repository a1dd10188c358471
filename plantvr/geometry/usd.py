"""USD export of a tree: mesh prims with UVs, normals, UsdPreviewSurface materials, branch-order subsets
(spec 000_treewand §3.3–§3.4; issue 16).

Layout of the stage (Y up, metres)::

    /Tree                      Xform, default prim
    /Tree/Branches             Mesh  (primvars:st, primvars:normals; GeomSubsets "order_K" if orders given)
    /Tree/Leaves               Mesh  (double-sided)
    /Tree/Looks/Bark, /Leaf    Material with a UsdPreviewSurface shader (and a UsdUVTexture when textured)

usd-core (``pxr``) is imported only when a function here is called.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from plantvr._validation import check_array, check_choice, check_range

from .leaves import LeafMesh
from .mesh import BranchMesh

__all__ = ["export_usd", "BARK_MATERIAL", "LEAF_MATERIAL"]

BARK_MATERIAL = "Bark"
LEAF_MATERIAL = "Leaf"
_BARK_RGB = (96 / 255, 66 / 255, 40 / 255)
_LEAF_RGB = (70 / 255, 140 / 255, 45 / 255)


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt
    except ImportError as e:               # pragma: no cover - depends on the environment
        raise RuntimeError("USD export needs usd-core: pip install usd-core") from e
    return Gf, Sdf, Usd, UsdGeom, UsdShade, Vt


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


def export_usd(path, branches: BranchMesh, leaves: LeafMesh | None = None, *, order=None,
               textures: bool = False, bark: str = "furrowed", leaf: str = "ovate",
               meters_per_unit: float = 1.0) -> Path:
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
        Texture choices, as in :func:`plantvr.geometry.export.tree_scene`.
    meters_per_unit : float
        Stage metadata ``metersPerUnit``.

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
    from .textures import BARK_TEXTURES, LEAF_TEXTURES

    path = Path(path)
    check_choice("suffix", path.suffix.lower(), (".usd", ".usda", ".usdc"))
    check_choice("bark", bark, BARK_TEXTURES)
    check_choice("leaf", leaf, LEAF_TEXTURES)
    meters_per_unit = check_range("meters_per_unit", meters_per_unit, 0.0, np.inf, low_open=True)
    if order is not None:
        nmax = int(branches.node_id.max()) + 1 if len(branches.node_id) else 0
        order = check_array("order", order, shape=(None,), dtype=np.int64)
        if len(order) < nmax:
            raise ValueError(f"order must have at least {nmax} entries (one per node), got {len(order)}")
    Gf, Sdf, Usd, UsdGeom, UsdShade, Vt = _pxr()

    bark_tex = leaf_tex = None
    if textures:
        from PIL import Image

        from .textures import bark_texture, leaf_texture
        bark_tex = f"{path.stem}_bark.png"
        Image.fromarray(np.asarray(bark_texture(bark))).save(path.parent / bark_tex)
        if leaves is not None:
            leaf_tex = f"{path.stem}_leaf.png"
            Image.fromarray(np.asarray(leaf_texture(leaf))).save(path.parent / leaf_tex)

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    root = UsdGeom.Xform.Define(stage, "/Tree")
    stage.SetDefaultPrim(root.GetPrim())
    UsdGeom.Scope.Define(stage, "/Tree/Looks")
    bark_mat = _material(stage, f"/Tree/Looks/{BARK_MATERIAL}", _BARK_RGB, texture=bark_tex, leaf=False)
    mesh = _mesh(stage, "/Tree/Branches", branches, bark_mat, double_sided=False)
    if order is not None and len(branches.faces):
        face_order = order[branches.node_id[branches.faces[:, 0]]]
        for k in np.unique(face_order):
            idx = np.flatnonzero(face_order == k).astype(np.int32)
            UsdGeom.Subset.CreateGeomSubset(mesh, f"order_{int(k)}", UsdGeom.Tokens.face,
                                            Vt.IntArray.FromNumpy(idx), "branchOrder", UsdGeom.Tokens.partition)
    if leaves is not None and len(leaves.faces):
        leaf_mat = _material(stage, f"/Tree/Looks/{LEAF_MATERIAL}", _LEAF_RGB, texture=leaf_tex, leaf=True)
        _mesh(stage, "/Tree/Leaves", leaves, leaf_mat, double_sided=True)
    stage.GetRootLayer().Save()
    return path
