"""Per-label meshes, table and chart (issue 15) against trimesh areas and scipy connected components."""
import os

import numpy as np
import pandas as pd
import pytest
import trimesh
from scipy.sparse import csgraph

from plantvr.documents.labels import Segmentation
from plantvr.io import labels as IO
from plantvr.view.plots import plot_label_areas
from plantvr.vine import labelstats as L
from plantvr.vine.colors import ColorTable
from plantvr.vine.fill import mesh_graph


@pytest.fixture(scope="module")
def table(surface, truth):
    return L.label_table(surface.vertices, surface.faces, truth, colors=ColorTable(), names={2: "receptacle"})


def test_table_against_trimesh_and_csgraph(surface, truth, table):
    v, f = surface.vertices, surface.faces
    A = mesh_graph(v, f).to_scipy()
    assert table["label"].tolist() == np.unique(truth).tolist()
    assert int(table["vertices"].sum()) == len(v)
    for row in table.itertuples():
        sv, sf, _ids = L.label_mesh(v, f, truth, row.label)
        m = trimesh.Trimesh(sv, sf, process=False)
        assert row.area == pytest.approx(m.area, rel=1e-9)
        assert row.faces == len(sf)
        mask = truth == row.label
        assert row.vertices == mask.sum()
        np.testing.assert_allclose([row.xmin, row.ymin, row.zmin], v[mask].min(0))
        np.testing.assert_allclose([row.xmax, row.ymax, row.zmax], v[mask].max(0))
        assert row.components == csgraph.connected_components(A[mask][:, mask], directed=False)[0]
    assert table.loc[table.label == 2, "name"].item() == "receptacle"
    assert table[["r", "g", "b"]].to_numpy().tolist() == ColorTable().rgba[table.label, :3].tolist()


def test_label_mesh_faces_all_carry_label(surface, truth):
    sv, sf, ids = L.label_mesh(surface.vertices, surface.faces, truth, 3)
    np.testing.assert_array_equal(sv, surface.vertices[ids])
    assert np.all(truth[ids[sf]] == 3)
    f = surface.faces
    full = np.all(truth[f] == 3, axis=1)
    assert len(sf) == full.sum()


def test_export_label_meshes_formats(tmp_path, surface, truth):
    for fmt in ("ply", "obj", "glb"):
        d = tmp_path / fmt
        d.mkdir()
        out = IO.write_label_meshes(d, surface.vertices, surface.faces, truth, fmt=fmt, colors=ColorTable(),
                                    which=[2, 3])
        assert sorted(out) == [2, 3]
        for k, p in out.items():
            assert os.path.exists(p) and p.endswith(f"_{k:03d}.{fmt}")
            m = trimesh.load(p, process=False, force="mesh")
            sv, sf, _ = L.label_mesh(surface.vertices, surface.faces, truth, k)
            assert len(m.faces) == len(sf)
            assert m.area == pytest.approx(trimesh.Trimesh(sv, sf, process=False).area, rel=1e-5)
    out = IO.write_label_meshes(tmp_path, surface.vertices, surface.faces, truth)
    assert sorted(out) == sorted(set(np.unique(truth[surface.faces][np.all(
        truth[surface.faces] == truth[surface.faces][:, :1], axis=1)][:, 0]).tolist()))


def test_csv_round_trip_and_chart(tmp_path, table):
    p = tmp_path / "labels.csv"
    table.to_csv(p, index=False)
    back = pd.read_csv(p, keep_default_na=False)
    np.testing.assert_allclose(back["area"], table["area"])
    fig = plot_label_areas(table)
    ax = fig.axes[0]
    bars = ax.patches
    assert len(bars) == len(table) - 1                  # label 0 left out
    np.testing.assert_allclose([b.get_height() for b in bars], table["area"].to_numpy()[1:])
    np.testing.assert_allclose(bars[1].get_facecolor()[:3], ColorTable().rgba[2, :3] / 255)
    fig.savefig(tmp_path / "areas.png")


def test_segmentation_wrappers(tmp_path, surface, truth):
    seg = Segmentation(surface.vertices, surface.faces, labels=truth)
    t = seg.label_table()
    assert t["vertices"].sum() == seg.n_vertices
    out = IO.export_label_meshes(seg, tmp_path, fmt="ply", which=[1])
    assert list(out) == [1]
    IO.export_label_table(seg, tmp_path / "t.csv")
    assert pd.read_csv(tmp_path / "t.csv").shape[0] == len(t)


def test_rejects(tmp_path, surface, truth):
    v, f = surface.vertices, surface.faces
    with pytest.raises(ValueError, match="fmt must be one of"):
        IO.write_label_meshes(tmp_path, v, f, truth, fmt="stl")
    with pytest.raises(ValueError, match="directory must be an existing directory"):
        IO.write_label_meshes(tmp_path / "nope", v, f, truth)
    with pytest.raises(ValueError, match="labels must be uint8"):
        L.label_table(v, f, truth.astype(np.int32))
    with pytest.raises(ValueError, match="label must be an integer in"):
        L.label_mesh(v, f, truth, 256)
    with pytest.raises(ValueError, match="which must be an integer in"):
        IO.write_label_meshes(tmp_path, v, f, truth, which=[-1])
    assert not list(tmp_path.iterdir())


def test_kernels_match_numpy_twins(monkeypatch, surface, truth):
    v, f = surface.vertices, surface.faces
    got = L._label_stats_numba(v, f, truth)
    want = L._label_stats_numpy(v, f, truth)
    for a, b in zip(got, want):
        np.testing.assert_allclose(a, b, rtol=1e-12)
    from plantvr.vine.fill import label_components
    comp, _ = label_components(mesh_graph(v, f), truth)
    np.testing.assert_array_equal(L._components_per_label_numba(comp, truth), L._components_per_label(comp, truth))
    monkeypatch.setattr(L, "_label_stats_numba", L._label_stats_numba.py_func)
    monkeypatch.setattr(L, "_components_per_label_numba", L._components_per_label_numba.py_func)
    small = f[:500]
    t = L.label_table(v, small, truth)
    assert t["faces"].sum() == int(np.sum(np.all(truth[small] == truth[small][:, :1], axis=1)))
