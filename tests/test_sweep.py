"""Design-space sweeps: grid handling, invalid designs, single-design agreement, Dask."""

from __future__ import annotations

import concurrent.futures as cf
import json

import numpy as np
import pytest

import splitlf
from splitlf import Camera
from splitlf.cli import main
from splitlf.sweep import METRICS, evaluate_design, sweep

xr = pytest.importorskip("xarray")

DEPTHS = np.geomspace(150.0, 10_000.0, 40)
GRID = {"D": [10.0, 20.0], "kappa": [0.2, 0.3866, 0.6], "v1": [79.0, 91.3879]}


@pytest.fixture(scope="module")
def in_process():
    return sweep(Camera.paper(), GRID, DEPTHS, progress=False)


def test_dimensions_and_invalid_designs(in_process):
    ds = in_process
    assert list(ds.sizes) == ["D", "kappa", "v1"] and ds.sizes["kappa"] == 3
    assert set(METRICS) <= set(ds.data_vars)
    bad = ds.sel(v1=79.0)
    assert not bad["valid"].any()
    assert all("v1" in str(r) and "> F" in str(r) for r in bad["reason"].values.ravel())
    assert np.isnan(bad["max_gap_worst_union"]).all()
    good = ds.sel(v1=91.3879)
    assert good["valid"].all() and (good["reason"] == "").all()
    assert np.isfinite(good["sharp_fraction_split"]).all()


def test_value_equals_single_design_functions(in_process):
    cam = Camera.paper().replace(D=10.0, kappa=0.6, v1=91.3879)
    row = in_process.sel(D=10.0, kappa=0.6, v1=91.3879)
    one = evaluate_design(cam, DEPTHS)
    for m in METRICS:
        assert float(row[m]) == one[m], m
    # and against the public single-purpose functions
    sf = splitlf.sharp_fractions(cam, (DEPTHS.min(), DEPTHS.max()))
    assert one["sharp_fraction_half1"] == sf["half1"]
    assert one["sharp_fraction_split"] == sf["split"]
    gaps = splitlf.new_samples(cam, DEPTHS).max_gap
    assert one["max_gap_worst_half1"] == np.max(gaps[0])
    assert one["max_gap_median_union"] == np.median(gaps[2])
    assert one["lit_fraction_half2"] == cam.lit_pixels(2) / cam.Q


def test_thread_pool_executor_gives_same_result(in_process):
    with cf.ThreadPoolExecutor(2) as ex:
        ds = sweep(Camera.paper(), GRID, DEPTHS, executor=ex, progress=False, batch_size=2)
    xr.testing.assert_identical(ds, in_process)


def test_dask_local_cluster_gives_same_result(in_process):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        ds = sweep(Camera.paper(), GRID, DEPTHS, executor=client.get_executor(),
                   progress=False)
    xr.testing.assert_identical(ds, in_process)


@pytest.mark.parametrize("grid, exc, match", [
    ({}, TypeError, "grid"),
    ({"focal": [1.0]}, ValueError, "focal"),
    ({"D": []}, ValueError, "non-empty"),
    ({"D": ["a"]}, TypeError, "numbers"),
])
def test_bad_grid(grid, exc, match):
    with pytest.raises(exc, match=match):
        sweep(Camera.paper(), grid, DEPTHS)


def test_bad_depths_and_batch():
    with pytest.raises(ValueError, match="depths"):
        sweep(Camera.paper(), {"D": [20.0]}, [500.0])
    with pytest.raises(ValueError, match="batch_size"):
        sweep(Camera.paper(), {"D": [20.0]}, DEPTHS, batch_size=0)


def test_counts_in_grid_stay_integers():
    ds = sweep(Camera.paper(), {"Q": np.array([9, 15])}, DEPTHS, progress=False)
    assert ds["valid"].all()


def _write_sweep(tmp_path, body):
    p = tmp_path / "sweep.toml"
    p.write_text(body)
    return str(p)


def test_cli_sweep_outputs(tmp_path, capsys):
    spec = _write_sweep(tmp_path, "[grid]\nD = [10.0, 20.0]\n"
                        "kappa = {start = 0.2, stop = 0.6, num = 3}\n"
                        "[depths]\nmin = 150.0\nmax = 10000.0\nnum = 40\n")
    assert main(["sweep", "--grid", spec, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["designs"]) == 6
    ds = sweep(Camera.paper(), {"D": [10.0, 20.0], "kappa": [0.2, 0.4, 0.6]}, DEPTHS,
               progress=False)
    first = doc["designs"][0]
    assert first["max_gap_worst_union"] == pytest.approx(
        float(ds["max_gap_worst_union"].isel(D=0, kappa=0)), rel=1e-12)
    nc = tmp_path / "out.nc"
    assert main(["sweep", "--grid", spec, "--out", str(nc)]) == 0
    back = xr.open_dataset(nc)
    np.testing.assert_allclose(back["sharp_fraction_split"], ds["sharp_fraction_split"])
    back.close()
    pytest.importorskip("pyarrow")
    pq = tmp_path / "out.parquet"
    assert main(["sweep", "--grid", spec, "--out", str(pq)]) == 0
    import pandas as pd

    assert len(pd.read_parquet(pq)) == 6


@pytest.mark.parametrize("body, needle", [
    ("[grid\n", "not valid TOML"),
    ("[depths]\nmin = 1.0\n", "[grid]"),
    ("[grid]\nD = [1.0]\n[extra]\n", "extra"),
    ("[grid]\nD = [1.0]\n[depths]\nnum = 1\n", "depths.num"),
])
def test_cli_sweep_bad_files(tmp_path, capsys, body, needle):
    spec = _write_sweep(tmp_path, body)
    assert main(["sweep", "--grid", spec]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
