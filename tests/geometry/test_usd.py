"""USD export: round trip through pxr, materials, branch-order subsets, compliance (issue 16)."""
import numpy as np
import pytest

from plantvr.geometry.leaves import build_leaves
from plantvr.geometry.lod import axis_start

from ._trees import leafy_tree, random_tree

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom, UsdShade, UsdUtils

from plantvr.io.usd import BARK_MATERIAL, LEAF_MATERIAL, export_usd, leaf_instances


@pytest.fixture(scope="module")
def tree():
    pos, parent, radius, mc, m, lv, _ = leafy_tree(80, seed=7)
    st = axis_start(parent, mc)
    order = np.zeros(len(pos), np.int64)            # branch order: number of lateral starts on the path
    for i in range(2, len(pos)):
        order[i] = order[parent[i]] + (st[i] == i)
    return m, lv, order


def _bound_material(prim):
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    return mat.GetPrim().GetName()


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_round_trip(tree, tmp_path, suffix):
    m, lv, order = tree
    p = export_usd(tmp_path / f"tree{suffix}", m, lv, order=order, leaf_instancer=False)
    stage = Usd.Stage.Open(str(p))
    assert stage.GetDefaultPrim().GetPath() == "/Tree"
    assert UsdGeom.GetStageUpAxis(stage) == "Y"
    br = UsdGeom.Mesh(stage.GetPrimAtPath("/Tree/Branches"))
    pts = np.asarray(br.GetPointsAttr().Get())
    assert len(pts) == len(m.vertices)
    np.testing.assert_allclose(pts, m.vertices, atol=1e-5)
    idx = np.asarray(br.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    np.testing.assert_array_equal(idx, m.faces)
    ext = np.asarray(br.GetExtentAttr().Get())
    np.testing.assert_allclose(ext, [m.vertices.min(0), m.vertices.max(0)], atol=1e-5)
    api = UsdGeom.PrimvarsAPI(br)
    st = api.GetPrimvar("st")
    assert st.GetInterpolation() == "vertex" and st.GetTypeName() == "texCoord2f[]"
    np.testing.assert_allclose(np.asarray(st.Get()), m.uv, atol=1e-6)
    np.testing.assert_allclose(np.asarray(api.GetPrimvar("normals").Get()), m.normals, atol=1e-6)
    lvp = UsdGeom.Mesh(stage.GetPrimAtPath("/Tree/Leaves"))
    assert len(lvp.GetPointsAttr().Get()) == len(lv.vertices)
    assert _bound_material(br.GetPrim()) == BARK_MATERIAL
    assert _bound_material(lvp.GetPrim()) == LEAF_MATERIAL
    sh = UsdShade.Shader(stage.GetPrimAtPath(f"/Tree/Looks/{BARK_MATERIAL}/PreviewSurface"))
    assert sh.GetIdAttr().Get() == "UsdPreviewSurface"
    # branch-order subsets partition the faces
    subsets = UsdGeom.Subset.GetGeomSubsets(br, "face", "branchOrder")
    assert len(subsets) == len(np.unique(order[m.node_id]))
    allidx = np.sort(np.concatenate([np.asarray(s.GetIndicesAttr().Get()) for s in subsets]))
    np.testing.assert_array_equal(allidx, np.arange(len(m.faces)))
    valid, reason = UsdGeom.Subset.ValidateFamily(br, "face", "branchOrder")
    assert valid, reason


@pytest.mark.parametrize("textures", [False, True])
def test_compliance_checker_reports_no_errors(tree, tmp_path, textures):
    m, lv, order = tree
    p = export_usd(tmp_path / "tree.usda", m, lv, order=order, textures=textures)
    if textures:
        assert (tmp_path / "tree_bark.png").exists() and (tmp_path / "tree_leaf.png").exists()
    assert _check(p) == []


def _check(path):
    """usdchecker's Python equivalent: UsdUtils.ComplianceChecker (older usd-core) or UsdValidation (>= 25)."""
    if hasattr(UsdUtils, "ComplianceChecker"):
        checker = UsdUtils.ComplianceChecker(rootPackageOnly=False, skipVariants=False)
        checker.CheckCompliance(str(path))
        return list(checker.GetErrors()) + list(checker.GetFailedChecks())
    from pxr import UsdValidation
    ctx = UsdValidation.ValidationContext(UsdValidation.ValidationRegistry().GetOrLoadAllValidators())
    return [f"{e.GetName()}: {e.GetMessage()}" for e in ctx.Validate(Usd.Stage.Open(str(path)))
            if e.GetType() == UsdValidation.ValidationErrorType.Error]


def test_checker_catches_a_broken_stage(tmp_path):
    p = tmp_path / "bad.usda"
    stage = Usd.Stage.CreateNew(str(p))              # no default prim, no up axis, no metersPerUnit
    UsdGeom.Mesh.Define(stage, "/A")
    stage.GetRootLayer().Save()
    assert _check(p) != []


def test_without_leaves_or_order(tree, tmp_path):
    m, _, _ = tree
    p = export_usd(tmp_path / "b.usd", m)
    stage = Usd.Stage.Open(str(p))
    assert not stage.GetPrimAtPath("/Tree/Leaves")
    assert UsdGeom.Subset.GetAllGeomSubsets(UsdGeom.Mesh(stage.GetPrimAtPath("/Tree/Branches"))) == []


def test_validation(tree, tmp_path):
    m, lv, order = tree
    with pytest.raises(ValueError, match="suffix"):
        export_usd(tmp_path / "t.obj", m)
    with pytest.raises(ValueError, match="order"):
        export_usd(tmp_path / "t.usda", m, order=order[:3])
    with pytest.raises(ValueError, match="bark"):
        export_usd(tmp_path / "t.usda", m, bark="oak")
    assert not (tmp_path / "t.usda").exists()


@pytest.mark.parametrize("shape", ["ovate", "lobed"])
def test_leaf_instances_rebuild_blades(shape):
    pos, parent, radius, mc = random_tree(60, seed=2)
    tips = np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)
    d = pos[tips] - pos[parent[tips]]
    lv = build_leaves(pos[tips], d / np.linalg.norm(d, axis=1)[:, None], radius[tips], leaf_size=0.3,
                      leaf_shape=shape, rng=1)
    inst = leaf_instances(lv, leaf_shape=shape)
    assert len(inst.positions) == len(lv.frames) > 0
    np.testing.assert_allclose(inst.scales, 0.3, rtol=1e-12)
    np.testing.assert_allclose(inst.world_vertices(), lv.vertices[:inst.n_blade_vertices], atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(inst.rotations), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(inst.quaternions, axis=1), 1.0, atol=1e-12)
    other = "lobed" if shape == "ovate" else "ovate"
    with pytest.raises(ValueError, match="leaf_shape"):
        leaf_instances(lv, leaf_shape=other)


def test_leaves_as_point_instancer(tree, tmp_path):
    """Leaves round trip as a PointInstancer: one blade prototype, instance transforms rebuild the blades."""
    m, lv, order = tree
    p = export_usd(tmp_path / "tree.usdc", m, lv, order=order)
    stage = Usd.Stage.Open(str(p))
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/Tree/Leaves"))
    assert pi and len(pi.GetPrototypesRel().GetTargets()) == 1
    proto = UsdGeom.Mesh(stage.GetPrimAtPath(pi.GetPrototypesRel().GetTargets()[0]))
    loc = np.asarray(proto.GetPointsAttr().Get(), float)
    xf = np.asarray(pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default()))
    assert len(xf) == len(lv.frames)
    world = (np.c_[loc, np.ones(len(loc))][None] @ xf)[..., :3].reshape(-1, 3)      # USD: row vectors
    nb = len(lv.frames) * len(loc)
    np.testing.assert_allclose(world, lv.vertices[:nb], atol=1e-5)
    pet = UsdGeom.Mesh(stage.GetPrimAtPath("/Tree/Petioles"))
    # vertex count: blades (prototype x instances) + petioles = the leaf mesh
    assert nb + len(pet.GetPointsAttr().Get()) == len(lv.vertices)
    assert _bound_material(proto.GetPrim()) == LEAF_MATERIAL
    assert _bound_material(pet.GetPrim()) == LEAF_MATERIAL
    assert _check(p) == []
