"""Parameter sweeps over a replayed scenario: tasks, metrics, determinism (serial and dask), thumbnails."""
import dataclasses

import numpy as np
import pytest

import plantvr
from plantvr.documents.scenarios import load_scenario, replay_scenario
from plantvr.documents.sweep import grow_variant, sweep, tree_metrics
from plantvr.view.thumbnails import thumbnail, thumbnail_grid

GRID = {"apical_dominance": [0.4, 0.7], "tropism_angle": [0.0]}


@pytest.fixture(scope="module")
def table():
    return sweep("fig12_7_vigor", GRID)


def test_sweep_rows_metrics_and_params(table):
    assert list(table["apical_dominance"]) == [0.4, 0.7] and list(table["tropism_angle"]) == [0.0, 0.0]
    for col in ("internodes", "height", "crown_width", "crown_ratio", "lateral_share", "trunk_fraction", "state"):
        assert col in table.columns
    assert (table["internodes"] > 20).all() and (table["height"] > 5).all()
    assert ((table["trunk_fraction"] > 0) & (table["trunk_fraction"] <= 1 + 1e-9)).all()
    # the metrics are those of the model replayed by hand with the same parameters
    ref = plantvr.Model(seed=0)
    sc = load_scenario("fig12_7_vigor")
    replay_scenario(ref, dataclasses.replace(sc, params={**sc.params, "apical_dominance": 0.4}))
    got = tree_metrics(ref)
    assert got["internodes"] == table["internodes"][0] and got["height"] == pytest.approx(table["height"][0])


def test_tasks_are_deterministic_serial_and_on_dask(table):
    again = grow_variant("fig12_7_vigor", {"apical_dominance": 0.7, "tropism_angle": 0.0})
    assert again["state"] == table["state"][1]
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        remote = sweep("fig12_7_vigor", GRID, client=client)
    assert list(remote["state"]) == list(table["state"])


def test_thumbnails(table):
    img = thumbnail(table["state"][0], size=(120, 140))
    assert img.shape == (140, 120, 3) and img.dtype == np.uint8
    r, g, b = (img[..., k].astype(int) for k in range(3))
    bark = (r > g + 10) & (g > b) & (r > 40)          # the warm bark texture, not sky, ground or leaves
    assert bark.sum() > 20  # some brown bark was drawn
    grid = thumbnail_grid(table, "apical_dominance", "tropism_angle", size=(100, 100), metric="internodes")
    assert grid.shape == (2 * (100 + 34), 100, 3)


def test_bad_grids_are_rejected_before_any_task():
    with pytest.raises(ValueError, match="grid parameter must be one of"):
        sweep("fig12_7_vigor", {"no_such": [1]})
    with pytest.raises(ValueError, match="view_angle"):
        sweep("fig12_7_vigor", {"view_angle": [10.0, 999.0]})
    with pytest.raises(ValueError, match="non-empty list"):
        sweep("fig12_7_vigor", {"view_angle": []})
    with pytest.raises(ValueError, match="non-empty dict"):
        sweep("fig12_7_vigor", {})
    with pytest.raises(ValueError, match="npz bytes"):
        thumbnail(b"")


def test_sweep_options_are_checked_before_any_task():
    with pytest.raises(ValueError, match="client must be None, 'sync' or a dask Client"):
        sweep("fig12_7_vigor", GRID, client="threads")
    with pytest.raises(ValueError, match="progress must be True or False"):
        sweep("fig12_7_vigor", GRID, progress="yes")
    with pytest.raises(ValueError, match="tasks"):
        sweep("fig12_7_vigor", GRID, tasks=0)


@pytest.mark.slow  # ~20 s: worker processes start and import the model
def test_sweep_one_and_two_worker_processes_and_an_address_give_the_same_bytes(table):
    """Batched tasks on 1 and 2 worker processes, and through a scheduler address string: the same table."""
    from plantvr.documents.sweep import warm_up_sweep
    distributed = pytest.importorskip("dask.distributed")
    got = []
    for n in (1, 2):
        with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster:
            with distributed.Client(cluster) as client:
                assert all(s > 0 for s in client.run(warm_up_sweep).values())
                got.append(sweep("fig12_7_vigor", GRID, client=client, progress=True))
            if n == 2:
                got.append(sweep("fig12_7_vigor", GRID, client=cluster.scheduler_address, tasks=1))
    for t in got:
        assert list(t["state"]) == list(table["state"])
        assert list(t["internodes"]) == list(table["internodes"])
    assert got[1].attrs["scaleout"]["n_workers"] == 2 and got[1].attrs["scaleout"]["n_tasks"] == 2
    assert got[2].attrs["scaleout"]["n_tasks"] == 1 and table.attrs["scaleout"]["n_workers"] == 1
