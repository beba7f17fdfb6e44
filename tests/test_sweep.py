"""Design-space sweeps: grid handling, invalid designs, single-design agreement, Dask."""

from __future__ import annotations

import concurrent.futures as cf
import json
import warnings

import numpy as np
import pytest

import splitlf
from splitlf import Camera, evaluate
from splitlf.cli import main
from splitlf.study.merit import merit_names
from splitlf.sweep import sweep

xr = pytest.importorskip("xarray")

DEPTHS = np.geomspace(150.0, 10_000.0, 40)
GRID = {"D": [10.0, 20.0], "kappa": [0.2, 0.3866, 0.6], "v1": [79.0, 91.3879]}


@pytest.fixture(scope="module")
def in_process():
    return sweep(Camera.paper(), GRID, DEPTHS, progress=False)


def test_dimensions_and_invalid_designs(in_process):
    ds = in_process
    assert list(ds.sizes) == ["D", "kappa", "v1"] and ds.sizes["kappa"] == 3
    assert set(merit_names(Camera.paper())) | {"valid", "reason"} == set(ds.data_vars)
    bad = ds.sel(v1=79.0)
    assert not bad["valid"].any()
    assert all("v1" in str(r) and "> F" in str(r) for r in bad["reason"].values.ravel())
    assert np.isnan(bad["max_gap_worst_union"]).all()
    good = ds.sel(v1=91.3879)
    assert good["valid"].all() and (good["reason"] == "").all()
    assert np.isfinite(good["sharp_fraction_union"]).all()


def test_value_equals_single_design_functions(in_process):
    cam = Camera.paper().replace(D=10.0, kappa=0.6, v1=91.3879)
    row = in_process.sel(D=10.0, kappa=0.6, v1=91.3879)
    one = evaluate(cam, DEPTHS)
    for m in merit_names(cam):
        assert float(row[m]) == one[m], m
    # and against the public single-purpose functions (half i is channel i)
    sf = splitlf.sharp_fractions(cam, (DEPTHS.min(), DEPTHS.max()))
    assert one["sharp_fraction_channel1"] == sf["channel 1"]
    assert one["sharp_fraction_union"] == sf["union"]
    gaps = splitlf.new_samples(cam, DEPTHS).max_gap
    assert one["max_gap_worst_channel1"] == np.max(gaps[0])
    assert one["max_gap_median_union"] == np.median(gaps[2])
    assert one["lit_fraction_channel2"] == cam.lit_pixels(2) / cam.Q


#: The README's sweep at D = 20 mm, computed by the two-engine code before Camera became a
#: Design (its camera metrics sharp_fraction_split, max_gap_worst_half2,
#: lit_fraction_half2: now sharp_fraction_union, max_gap_worst_channel2,
#: lit_fraction_channel2); kappa = linspace(0.1, 0.6, 11).
README_D20 = {
    "max_gap_worst_union": [
        4.799925456470787, 11.774104756117927, 8.186302037084578, 6.966969817316678,
        5.695886043781289, 8.233430868118871, 4.863598475763058, 8.69578100048507,
        3.5198099557705276, 6.860575960363885, 9.253709119614268],
    "sharp_fraction_union": [
        0.8838751814195719, 0.948504573041373, 0.9951656958108516] + [1.0] * 8,
    "max_gap_worst_channel2": [
        13.208411848292121, 12.423729229220982, 12.068940652884564, 11.975534431706414,
        11.531273363418746, 10.930216200329053, 10.68255357509271, 10.049675217684651,
        9.961976726619346, 9.38856258443938, 9.253709119614465],
    "max_gap_median_union": [
        1.5080081130701077, 1.501626174570219, 1.3927669420841227, 1.359324614006427,
        1.47418413469068, 1.5174877046456219, 1.4342751653535242, 1.4931301623899684,
        1.4007432755521618, 1.6095627686487646, 1.5744697359293522],
    "lit_fraction_channel2": [0.8666666666666667] * 4 + [0.7333333333333333] * 5
    + [0.6] * 2,
    "sharp_fraction_channel1": [0.5762691488879526] * 11,
    "max_gap_worst_channel1": [14.569546667141804] * 11,
}


def test_readme_sweep_keeps_its_numbers_and_marks_overlapping_designs_invalid():
    ds = sweep(splitlf.Camera.paper(),
               {"D": [10.0, 20.0, 40.0], "kappa": np.linspace(0.1, 0.6, 11)},
               depths=np.geomspace(150.0, 10_000.0, 200), progress=False)
    for name, expected in README_D20.items():
        np.testing.assert_allclose(ds[name].sel(D=20.0), expected, rtol=1e-12, atol=0,
                                   err_msg=name)
    # D = 40 mm overlaps the microlens images (docs/model.md §9): invalid rows, NaN merits,
    # the constructor's message as the reason; D = 10, 20 are valid
    assert ds["valid"].sel(D=[10.0, 20.0]).all()
    bad = ds.sel(D=40.0)
    assert not bad["valid"].any() and np.isnan(bad["max_gap_worst_union"]).all()
    assert all("overlap" in str(r) for r in bad["reason"].values)


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
    np.testing.assert_allclose(back["sharp_fraction_union"], ds["sharp_fraction_union"])
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


# -- counts, whole-sweep errors, limits ------------------------------------------------------

FEW = np.geomspace(150.0, 10_000.0, 6)


def test_integral_floats_of_counts_are_counts():
    as_floats = sweep(Camera.paper(), {"Q": np.linspace(9, 15, 3), "Kx": [100.0, 101.0]},
                      FEW, progress=False)
    as_ints = sweep(Camera.paper(), {"Q": [9, 12, 15], "Kx": [100, 101]}, FEW, progress=False)
    assert as_floats["valid"].all()
    assert as_floats["Q"].dtype == np.int64 and as_floats["Kx"].dtype == np.int64
    xr.testing.assert_identical(as_floats, as_ints)
    # a non-integral value stays an error of that design only
    mixed = sweep(Camera.paper(), {"Q": [9.0, 9.5]}, FEW, progress=False)
    assert mixed["valid"].values.tolist() == [True, False]
    assert "integer" in str(mixed["reason"].values[1])


@pytest.mark.parametrize("kwargs, name", [
    ({"threshold_px": -1}, "threshold_px"),
    ({"threshold_px": 10**400}, "threshold_px"),
    ({"tol": float("nan")}, "tol"),
    ({"tol": -1e-6}, "tol"),
    ({"depths": [150.0, np.inf]}, "depths"),
    ({"depths": [-5.0, 100.0]}, "depths"),
    ({"depths": [50.0, 500.0]}, "depths"),  # <= F of every design
    ({"depths": [500.0, 500.0]}, "depths"),
])
def test_whole_sweep_errors_are_one_error_before_any_work(monkeypatch, kwargs, name):
    import splitlf.sweep as sw

    def no_work(*args, **kw):
        raise AssertionError("a design was evaluated before the sweep's arguments were checked")

    monkeypatch.setattr(sw, "evaluate_batch", no_work)
    args = {"depths": FEW} | kwargs
    depths = args.pop("depths")
    with pytest.raises(splitlf.InvalidParameter) as e:
        sweep(Camera.paper(), {"D": [10.0, 20.0]}, depths, progress=False, **args)
    assert e.value.name == name


def test_depths_below_some_designs_F_only_invalidate_those():
    ds = sweep(Camera.paper(), {"F": [80.0, 200.0], "v1": [91.3879, 250.0]},
               np.geomspace(150.0, 5000.0, 5), progress=False)
    assert bool(ds["valid"].sel(F=80.0, v1=91.3879))
    assert not ds["valid"].sel(F=200.0).any()


def test_grid_larger_than_the_limit_is_refused_up_front():
    from splitlf.sweep import MAX_DESIGNS

    big = {"D": np.linspace(10.0, 20.0, 10**4), "kappa": np.linspace(0.2, 0.6, 10**4)}
    with pytest.raises(splitlf.TooLargeError, match=f"{MAX_DESIGNS}") as e:
        sweep(Camera.paper(), big, FEW, progress=False)
    assert "100000000 designs" in str(e.value) and e.value.limit == MAX_DESIGNS
    with pytest.raises(splitlf.TooLargeError, match="depths"):
        sweep(Camera.paper(), {"D": [20.0]}, np.geomspace(150.0, 1e4, 100_001))


def test_cli_sweep_toml_range_of_counts(tmp_path, capsys):
    spec = _write_sweep(tmp_path, "[grid]\nKx = {start = 100, stop = 300, num = 3}\n"
                        "[depths]\nmin = 150.0\nmax = 10000.0\nnum = 6\n")
    assert main(["sweep", "--grid", spec, "--json"]) == 0
    designs = json.loads(capsys.readouterr().out)["designs"]
    assert [d["Kx"] for d in designs] == [100, 200, 300]
    assert all(d["valid"] and d["reason"] == "" for d in designs)


@pytest.mark.parametrize("body, needle", [
    ("[grid]\nD = [10.0]\n[options]\nthreshold_px = -1\n", "threshold_px"),
    ("[grid]\nD = [10.0]\n[options]\ntol = nan\n", "tol"),
    ("[grid]\nD = [10.0]\n[depths]\nnum = 100000000000\n", "depths.num"),
    ("[grid]\nD = [10.0]\n[depths]\nmax = inf\n", "depths.max"),
    ("[grid]\nD = [10.0]\n[depths]\nmin = 1" + "0" * 400 + "\n", "depths.min"),
    ("[grid]\nD = {start = 1" + "0" * 400 + ", stop = 2.0, num = 2}\n", "grid.D.start"),
    ("[grid]\nD = {start = 1.0, stop = 2.0, num = 10000000000}\n", "grid.D.num"),
    ("[grid]\nD = [10.0]\n" + Camera.paper().to_toml().replace("F = 80.0", "F = 1" + "0" * 400),
     "invalid F"),
    ("[grid]\nD = [10.0]\n" + Camera.paper().to_toml().replace("Q = 15", "Q = 1" + "0" * 400),
     "invalid Q"),
])
def test_cli_sweep_whole_sweep_errors_exit_2(tmp_path, capsys, body, needle):
    spec = _write_sweep(tmp_path, body)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning before the error
        assert main(["sweep", "--grid", spec]) == 2
    out = capsys.readouterr()
    assert out.out == "" and needle in out.err and out.err.count("\n") == 1
    assert len(out.err) < 400


def test_cli_sweep_binary_file_names_it(tmp_path, capsys):
    p = tmp_path / "grid.toml"
    p.write_bytes(bytes(range(256)))
    assert main(["sweep", "--grid", str(p)]) == 2
    assert "grid.toml" in capsys.readouterr().err


def test_cli_sweep_never_overwrites_without_force(tmp_path, capsys):
    spec = _write_sweep(tmp_path, "[grid]\nD = [10.0, 20.0]\n[depths]\nnum = 6\n")
    for suffix in (".nc", ".parquet", ".json"):
        out = tmp_path / f"old{suffix}"
        out.write_text("previous results")
        assert main(["sweep", "--grid", spec, "--out", str(out)]) == 2
        assert "--force" in capsys.readouterr().err
        assert out.read_text() == "previous results"
        assert main(["sweep", "--grid", spec, "--out", str(out), "--force"]) == 0
        assert capsys.readouterr().out.strip() == str(out)
        assert out.read_bytes() != b"previous results"
    assert len(json.loads((tmp_path / "old.json").read_text())["designs"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "old.json", "old.nc", "old.parquet", "sweep.toml"]  # no temporary files


def test_cli_sweep_json_with_out_does_both(tmp_path, capsys):
    spec = _write_sweep(tmp_path, "[grid]\nD = [10.0, 20.0]\n[depths]\nnum = 6\n")
    out = tmp_path / "s.json"
    assert main(["sweep", "--grid", spec, "--out", str(out), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["path"] == str(out)
    assert printed["designs"] == json.loads(out.read_text())["designs"]


def test_cli_sweep_bad_suffix_before_work(tmp_path, capsys):
    spec = _write_sweep(tmp_path, "[grid]\nD = [10.0]\n")
    assert main(["sweep", "--grid", spec, "--out", str(tmp_path / "s.csv")]) == 2
    assert ".parquet" in capsys.readouterr().err
