"""QSM importers (issue 22 "Trees from scans"): TreeQSM .mat, SimpleForest and aRchi CSV into TreeArrays."""
import csv

import numpy as np
import pytest
import scipy.io

from plantvr.io.qsm import (
    cylinders_to_tree,
    model_from_tree,
    read_archi,
    read_qsm,
    read_simpleforest,
    read_treeqsm,
    to_growth_tree,
)
from plantvr.types import TreeArrays


def qsm_like(seed=0, joint=8):
    """A QSM-like cylinder list: a 6-cylinder stem, one joint with ``joint`` short branches at the end of stem
    cylinder 3, and two branches starting part-way along stem cylinders (as TreeQSM writes them)."""
    rng = np.random.default_rng(seed)
    start, end, radius, parent, branch = [], [], [], [], []

    def add(s, e, r, p, b):
        start.append(np.asarray(s, float))
        end.append(np.asarray(e, float))
        radius.append(r)
        parent.append(p)
        branch.append(b)
        return len(start) - 1

    p = -1
    for k in range(6):  # stem, z up, slightly wavy
        s = np.array([0.0, 0.0, k * 1.0]) if p < 0 else end[p]
        p = add(s, s + [rng.normal() * 0.02, rng.normal() * 0.02, 1.0], 0.2 - 0.02 * k, p, 1)
    joint_at = 3
    for j in range(joint):  # crowded joint: short leaf branches
        a = 2 * np.pi * j / joint
        d = np.array([np.cos(a), np.sin(a), 0.6])
        s = end[joint_at]
        c = add(s, s + 0.3 * d, 0.03, joint_at, 10 + j)
        add(end[c], end[c] + 0.15 * d, 0.02, c, 10 + j)
    for cyl, t in ((1, 0.4), (4, 0.7)):  # branches starting along the parent's axis
        s = start[cyl] + t * (end[cyl] - start[cyl])
        d = np.array([1.0, -0.5, 0.5])
        add(s, s + 0.8 * d, 0.05, cyl, 100 + cyl)
    return (np.array(start), np.array(end), np.array(radius), np.array(parent), np.array(branch))


def _treeqsm_fields(start, end, parent, branch):
    """TreeQSM's ``axis`` (unit), ``length`` and 1-based ``extension`` (0 = none) of a cylinder list."""
    axis = end - start
    length = np.linalg.norm(axis, axis=1)
    ext = np.zeros(len(start))
    for i, p in enumerate(parent):
        if p >= 0 and branch[i] == branch[p]:
            ext[p] = i + 1
    return axis, length, ext


def _write_treeqsm(path, start, end, radius, parent, branch):
    axis, length, ext = _treeqsm_fields(start, end, parent, branch)
    cyl = {"radius": radius[:, None], "length": length[:, None], "start": start, "axis": axis / length[:, None],
           "parent": (parent + 1)[:, None].astype(float), "extension": ext[:, None], "branch": branch[:, None]}
    scipy.io.savemat(path, {"QSM": {"cylinder": cyl, "treedata": {"TotalVolume": 1.0}}})


def _write_csv(path, header, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)


def _write_simpleforest(path, start, end, radius, parent, branch, base_id=7):
    ids = np.arange(len(start)) + base_id
    rows = [[ids[i], ids[parent[i]] if parent[i] >= 0 else -1, branch[i], *start[i], *end[i], radius[i], 0.5]
            for i in range(len(start))]
    _write_csv(path, ["ID", "parentID", "branchID", "startX", "startY", "startZ", "endX", "endY", "endZ", "radius",
                      "growthVolume"], rows[::-1])  # rows in any order


def _write_archi(path, start, end, radius, parent, branch):
    ids = np.arange(len(start)) + 1
    rows = [[ids[i], ids[parent[i]] if parent[i] >= 0 else 0, *start[i], *end[i], radius[i], branch[i]]
            for i in range(len(start))]
    _write_csv(path, ["cyl_ID", "parent_ID", "startX", "startY", "startZ", "endX", "endY", "endZ", "radius_cyl",
                      "branch_ID"], rows)


def _check_tree(tree, start, end, radius, parent, nmap):
    assert isinstance(tree, TreeArrays)
    assert tree.parent[0] == -1 and np.all(tree.parent[1:] < np.arange(1, len(tree)))
    np.testing.assert_allclose(tree.pos[nmap.end_node], end, atol=1e-12)
    np.testing.assert_allclose(tree.radius[nmap.end_node], radius)
    np.testing.assert_allclose(tree.pos[0], start[0])
    # two branches start part-way along their parent: two split nodes
    assert len(tree) == len(start) + 1 + 2
    np.testing.assert_allclose(nmap.offset, 0.0, atol=1e-12)
    assert np.all(tree.order[nmap.end_node[:6]] == 0)  # the stem continues through the joint and the splits
    assert np.all(tree.order[nmap.end_node[6:]] == 1)


def test_cylinders_to_tree_and_every_format(tmp_path):
    cyl = qsm_like()
    ref, nmap = cylinders_to_tree(*cyl[:4], branch=cyl[4], return_map=True)
    _check_tree(ref, *cyl[:4], nmap)
    _write_treeqsm(tmp_path / "t.mat", *cyl)
    _write_simpleforest(tmp_path / "sf.csv", *cyl)
    _write_archi(tmp_path / "a.csv", *cyl)
    for tree in (read_treeqsm(tmp_path / "t.mat"), read_simpleforest(tmp_path / "sf.csv"),
                 read_archi(tmp_path / "a.csv"), read_qsm(tmp_path / "t.mat"), read_qsm(tmp_path / "sf.csv"),
                 read_qsm(tmp_path / "a.csv")):
        np.testing.assert_allclose(tree.pos, ref.pos, atol=1e-12)
        np.testing.assert_array_equal(tree.parent, ref.parent)
        np.testing.assert_allclose(tree.radius, ref.radius)
        np.testing.assert_array_equal(tree.order, ref.order)


def test_treeqsm_without_extension_uses_alignment(tmp_path):
    start, end, radius, parent, _ = qsm_like(1)
    axis = end - start
    length = np.linalg.norm(axis, axis=1)
    scipy.io.savemat(tmp_path / "q.mat", {"qsm": {"cylinder": {
        "radius": radius, "length": length, "start": start, "axis": axis / length[:, None],
        "parent": parent + 1.0}}})
    tree, nmap = read_treeqsm(tmp_path / "q.mat", return_map=True)
    assert np.all(tree.order[nmap.end_node[:6]] == 0)  # the vertical child continues the vertical stem


def test_child_off_the_parent_axis_gets_a_connector():
    start = np.array([[0, 0, 0], [0.1, 0, 0.5]], float)  # child starts on the parent's surface, half way up
    end = np.array([[0, 0, 1], [1, 0, 1]], float)
    tree, nmap = cylinders_to_tree(start, end, [0.1, 0.05], [-1, 0], return_map=True)
    assert len(tree) == 5                                # base, split, parent end, connector end, child end
    np.testing.assert_allclose(tree.pos[nmap.start_node[1]], [0, 0, 0.5])     # attached on the parent's axis
    np.testing.assert_allclose(tree.pos[nmap.base_node[1]], start[1])         # the child keeps its own start
    np.testing.assert_allclose(nmap.offset, [0, 0.1])
    assert nmap.connector.tolist() == [False, False, False, True, False]
    assert tree.parent[nmap.base_node[1]] == nmap.start_node[1]


def _off_axis_qsm(seed=3):
    """TreeQSM-like cylinders as TreeQSM writes them: consecutive cylinders of a branch leave gaps (or overlap),
    branches start on the parent's surface part-way along it, some before the parent's start or past its end.
    Returns start, axis, length, radius, parent (1-based, 0 none), extension (1-based), BranchOrder, branch."""
    rng = np.random.default_rng(seed)
    S, A, L, R, P, X, O, B = [], [], [], [], [], [], [], []

    def chain(s, d, n, r, parent, order, branch):
        prev = parent
        for k in range(n):
            d = d + rng.normal(0, 0.08, 3)
            d /= np.linalg.norm(d)
            length = rng.uniform(2.0, 5.0) * r
            S.append(s), A.append(d), L.append(length), R.append(r), P.append(prev + 1), O.append(order)
            B.append(branch)
            X.append(0)
            if prev >= 0 and k > 0:
                X[prev] = len(S)
            prev = len(S) - 1
            e = s + d * length
            s = e + rng.normal(0, 0.05 * r, 3)           # the next one starts off this one's end
            r *= 0.93
        return list(range(len(S) - n, len(S)))

    stem = chain(np.zeros(3), np.array([0.0, 0.0, 1.0]), 12, 0.15, -1, 0, 1)
    nb = 1
    for k, cy in enumerate(stem[1:-2]):
        s, d, length, r = S[cy], A[cy], L[cy], R[cy]
        t = [0.3, 0.7, -0.1, 1.2][k % 4]                 # along the parent, before its start, past its end
        side = np.cross(d, [np.cos(k), np.sin(k), 0.0])
        side /= np.linalg.norm(side)
        nb += 1
        first = chain(s + t * length * d + r * side, side + 0.5 * d, 4, 0.3 * r, cy, 1, nb)[0]
        if k % 3 == 0:                                   # a second-order branch on the first cylinder
            nb += 1
            chain(S[first] + 0.5 * L[first] * A[first] + R[first] * np.cross(A[first], [0, 0, 1.0]) /
                  np.linalg.norm(np.cross(A[first], [0, 0, 1.0])), A[first] + [0, 0, 0.5], 2, 0.5 * R[first],
                  first, 2, nb)
    return (np.array(S), np.array(A), np.array(L), np.array(R), np.array(P, float), np.array(X, float),
            np.array(O, float), np.array(B, float))


def _totals(tree, nmap):
    seg = np.linalg.norm(tree.pos[1:] - tree.pos[tree.parent[1:]], axis=1)
    keep = ~nmap.connector[1:]
    r = tree.radius[1:]
    return seg[keep].sum(), (np.pi * r * r * seg)[keep].sum()


@pytest.mark.parametrize("layout", ["2.4 qsm.cylinder", "2.0 variables"])
def test_treeqsm_off_axis_starts_keep_every_cylinder(tmp_path, layout):
    """Issue 32: every cylinder keeps its start, end and radius; total length and volume are the file's (the
    projection on the parent's axis this replaces was +3.9 % / +2.1 % on rTwig's QSM.mat); joints are connectors,
    and branch orders are TreeQSM's own BranchOrder."""
    S, A, L, R, P, X, O, B = _off_axis_qsm()
    c = len(S)
    p = tmp_path / "q.mat"
    if layout.startswith("2.4"):
        scipy.io.savemat(p, {"OptQSM": {"cylinder": {
            "radius": R[:, None], "length": L[:, None], "start": S, "axis": A, "parent": P[:, None],
            "extension": X[:, None], "branch": B[:, None], "BranchOrder": O[:, None],
            "PositionInBranch": np.ones((c, 1))}}})
    else:
        scipy.io.savemat(p, {"Rad": R, "Len": L, "Sta": S, "Axe": A, "CPar": P, "CExt": X,
                             "BoC": np.column_stack([B, O, np.ones(c)])})
    tree, nmap = read_treeqsm(p, return_map=True)
    E = S + A * L[:, None]
    np.testing.assert_allclose(tree.pos[nmap.base_node], S, atol=1e-12)
    np.testing.assert_allclose(tree.pos[nmap.end_node], E, atol=1e-12)
    assert np.all(tree.radius[nmap.end_node] == R)
    length, volume = _totals(tree, nmap)
    assert abs(length / L.sum() - 1) < 1e-9 and abs(volume / (np.pi * R * R * L).sum() - 1) < 1e-9
    assert np.array_equal(tree.order[nmap.end_node], O.astype(int))
    assert nmap.offset[1:].min() > 0 and nmap.connector.sum() == c - 1        # every start was off its parent
    np.testing.assert_allclose(np.linalg.norm(tree.pos[nmap.base_node] - tree.pos[nmap.start_node], axis=1),
                               nmap.offset, atol=1e-12)
    seg = np.linalg.norm(tree.pos[1:] - tree.pos[tree.parent[1:]], axis=1)
    np.testing.assert_allclose(seg[nmap.connector[1:]].sum(), nmap.offset.sum(), rtol=1e-12)


@pytest.mark.parametrize("bad, match", [
    (dict(parent=[-1, -1]), "exactly one root"),
    (dict(parent=[-1, 5]), "parent\\[1\\]"),
    (dict(radius=[0.1, 0.0]), "radius must be > 0"),
    (dict(end=[[0, 0, 1], [0, 0, 1]], start=[[0, 0, 0], [0, 0, 1]]), "length > 0"),
    (dict(start=[[0, 0, np.nan], [0, 0, 1]]), "start"),
])
def test_cylinders_checked_at_the_door(bad, match):
    kw = dict(start=[[0, 0, 0], [0, 0, 1]], end=[[0, 0, 1], [0, 0, 2]], radius=[0.1, 0.1], parent=[-1, 0])
    kw.update(bad)
    with pytest.raises(ValueError, match=match):
        cylinders_to_tree(kw["start"], kw["end"], kw["radius"], kw["parent"])


def test_cycle_refused():
    s = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 2]], float)
    with pytest.raises(ValueError, match="cycle"):
        cylinders_to_tree(s, s + [0, 0, 1], [0.1] * 3, [-1, 2, 1])


def test_bad_files(tmp_path):
    _write_csv(tmp_path / "x.csv", ["a", "b"], [[1, 2]])
    with pytest.raises(ValueError, match="missing column"):
        read_simpleforest(tmp_path / "x.csv")
    with pytest.raises(ValueError, match="does not exist"):
        read_treeqsm(tmp_path / "nope.mat")
    scipy.io.savemat(tmp_path / "e.mat", {"foo": np.zeros(3)})
    with pytest.raises(ValueError, match="qsm.cylinder"):
        read_treeqsm(tmp_path / "e.mat")
    (tmp_path / "g.mat").write_bytes(b"not a mat file at all")
    with pytest.raises(ValueError, match="cannot read"):
        read_treeqsm(tmp_path / "g.mat")
    cyl = qsm_like()
    _write_archi(tmp_path / "a.csv", *cyl)
    with open(tmp_path / "a.csv") as fh:
        rows = list(csv.reader(fh))
    rows[3][1] = "999"
    _write_csv(tmp_path / "b.csv", rows[0], rows[1:])
    with pytest.raises(ValueError, match="not a cylinder id"):
        read_archi(tmp_path / "b.csv")
    with pytest.raises(ValueError, match="format"):
        read_qsm(tmp_path / "a.csv", format="lidar")


def test_scanned_tree_meshes_yggdrasil_and_exports(tmp_path):
    from plantvr.io.tree import export_tree, tree_geometry
    from plantvr.params import TREEWAND
    from plantvr.subdivision import graph_from_arrays

    cyl = qsm_like(2, joint=10)
    tree = cylinders_to_tree(*cyl[:4], branch=cyl[4])
    branches, leaves = tree_geometry(tree, TREEWAND.defaults(), leaves=False)
    assert leaves is None and len(branches.faces) > 0
    out = export_tree(tmp_path / "scan.glb", branches)
    assert out.stat().st_size > 0
    g = graph_from_arrays(tree.pos, tree.parent, tree.radius)
    assert len(g.start) == len(tree) - 1


@pytest.mark.parametrize("nslots", [2, 3])
def test_growth_tree_splits_crowded_joints(nslots):
    cyl = qsm_like(3, joint=9)
    tree = cylinders_to_tree(*cyl[:4], branch=cyl[4])
    gt = to_growth_tree(tree, nslots=nslots)
    gt.check()
    # every original node survives (helpers added), z-up turned y-up, base at the origin
    assert gt.n >= len(tree)
    np.testing.assert_allclose(gt.pos[0], 0.0)
    top = np.argmax(tree.pos[:, 2])
    assert np.isclose(gt.pos[:, 1].max(), tree.pos[top, 2] - tree.pos[0, 2])
    # the 10-child joint (stem + 9 leaf branches) needs ceil(9 / laterals per node) - 1 helpers; nothing else does
    assert gt.n - len(tree) == -(-9 // (nslots - 1)) - 1


def test_model_from_scanned_tree_prunes_and_grows():
    cyl = qsm_like(4, joint=6)
    tree = cylinders_to_tree(*cyl[:4], branch=cyl[4])
    m = model_from_tree(tree, seed=0)
    n0 = m.n_internodes
    assert n0 >= len(tree) - 1
    snap = m.latest
    i = int(np.argmax(snap.pos[:, 1]))
    top = 0.5 * (snap.pos[i] + snap.pos[snap.parent[i]])  # midpoint of the top internode
    removed = m.prune(top, 0.3)
    assert removed > 0 and m.n_internodes < n0
    m.add_markers(top + np.random.default_rng(0).normal(scale=0.5, size=(200, 3)))
    m.step(3)
    assert m.n_internodes > n0 - removed
    m.undo()


def _write_treeqsm_v73(path, models):
    """A MATLAB v7.3 file as MATLAB writes it (h5py oracle of the layout): a 512-byte MATLAB header as the HDF5
    user block, structs as groups tagged ``MATLAB_class``, matrices transposed, and a struct array as a group
    whose fields are object-reference datasets into ``#refs#``."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        def put_cyl(group, start, end, radius, parent, branch):
            group.attrs["MATLAB_class"] = np.bytes_("struct")
            axis, length, ext = _treeqsm_fields(start, end, parent, branch)
            for name, a in (("radius", radius[:, None]), ("length", length[:, None]), ("start", start),
                            ("axis", axis / length[:, None]), ("parent", (parent + 1)[:, None].astype(float)),
                            ("extension", ext[:, None]), ("branch", branch[:, None].astype(float))):
                ds = group.create_dataset(name, data=np.ascontiguousarray(a.T))   # column-major on disk
                ds.attrs["MATLAB_class"] = np.bytes_("double")
        q = f.create_group("QSM")
        q.attrs["MATLAB_class"] = np.bytes_("struct")
        if len(models) == 1:
            put_cyl(q.create_group("cylinder"), *models[0])
        else:
            refs = f.create_group("#refs#")
            rr = []
            for k, m in enumerate(models):
                g = refs.create_group(f"c{k}")
                put_cyl(g, *m)
                rr.append(g.ref)
            q.create_dataset("cylinder", data=np.array(rr, dtype=h5py.ref_dtype)[:, None])
    with open(path, "r+b") as fh:                    # MATLAB's text header in the user block
        text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Wed Dec  2 04:00:00 2026 HDF5 schema 1.00 ."
        fh.write(text.ljust(116) + b"\0" * 8 + b"\x00\x02" + b"IM")   # subsystem offset, version 0x0200, endian


def test_treeqsm_v73_hdf5_files(tmp_path):
    """Issue 22: TreeQSM saves big models with save(..., '-v7.3'), which scipy.io.loadmat refuses."""
    a, b = qsm_like(0), qsm_like(4, joint=6)
    _write_treeqsm_v73(tmp_path / "one.mat", [a])
    _write_treeqsm_v73(tmp_path / "two.mat", [a, b])
    with pytest.raises(NotImplementedError):
        scipy.io.loadmat(tmp_path / "one.mat")
    for path, index, cyl in ((tmp_path / "one.mat", 0, a), (tmp_path / "two.mat", 0, a),
                             (tmp_path / "two.mat", 1, b)):
        ref = cylinders_to_tree(*cyl[:4], branch=cyl[4])
        for tree in (read_treeqsm(path, index=index), read_qsm(path) if index == 0 else ref):
            np.testing.assert_allclose(tree.pos, ref.pos, atol=1e-12)
            np.testing.assert_array_equal(tree.parent, ref.parent)
            np.testing.assert_array_equal(tree.order, ref.order)
    with pytest.raises(ValueError, match=r"index must be in \[0, 1\]"):
        read_treeqsm(tmp_path / "two.mat", index=2)
    with pytest.raises(ValueError, match="index must be 0"):
        read_treeqsm(tmp_path / "one.mat", index=1)


def test_treeqsm_v73_crafted_files_are_refused(tmp_path):
    h5py = pytest.importorskip("h5py")
    _write_treeqsm_v73(tmp_path / "q.mat", [qsm_like(0)])
    with h5py.File(tmp_path / "q.mat", "r+") as f:
        del f["QSM/cylinder/radius"]
        f["QSM/cylinder"].create_dataset("radius", data=np.array([b"abc"]))
    with pytest.raises(ValueError, match="radius"):
        read_treeqsm(tmp_path / "q.mat")
    with h5py.File(tmp_path / "q.mat", "r+") as f:
        del f["QSM/cylinder"]
    with pytest.raises(ValueError, match="qsm.cylinder"):
        read_treeqsm(tmp_path / "q.mat")
    _write_treeqsm_v73(tmp_path / "r.mat", [qsm_like(0)])
    with h5py.File(tmp_path / "r.mat", "r+") as f:
        del f["QSM/cylinder/start"]
        f["QSM/cylinder"].create_dataset("start", data=np.zeros((2, 5)))
    with pytest.raises(ValueError, match="start must have shape"):
        read_treeqsm(tmp_path / "r.mat")
