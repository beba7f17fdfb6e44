"""Design sweeps and inverse design on a Design base: merits per channel and union against
the camera and an independent NumPy derivation, grids of free-field names, optimise."""

from __future__ import annotations

import concurrent.futures as cf

import numpy as np
import pytest

import splitlf
from splitlf import Camera, Design, _native
from splitlf import evaluate as evaluate_design
from splitlf.errors import InvalidParameter
from splitlf.study.merit import merit_names
from splitlf.sweep import design_fields, sweep

DEPTHS = np.geomspace(150.0, 10_000.0, 30)


def design_metrics(d, merits_2d=False):
    """The core's merit names of ``d`` (the first of :func:`merit_names`)."""
    return tuple(_native.design_metrics(d.core, merits_2d))


def test_camera_and_its_design_agree():
    # a Camera is a Design: its merits are its plain design's, bit for bit (half i is
    # channel i; the old camera names sharp_fraction_half1/_split, max_gap_*_half*,
    # lit_fraction_half2 are channel1/union/channel*)
    cam = Camera.paper().replace(kappa=0.3)
    a = evaluate_design(cam, DEPTHS)
    b = evaluate_design(cam.design, DEPTHS)
    assert list(b) == list(merit_names(cam.design)) == list(a)
    assert dict(a) == dict(b)
    assert list(b)[:13] == list(design_metrics(cam.design))
    assert b["lit_fraction_channel1"] == cam.lit_pixels(1) / cam.Q
    assert b["lit_fraction_channel2"] == cam.lit_pixels(2) / cam.Q
    # a fully lit pixel of half 1 in Ng's setting has the 1-D etendue mu d / v
    light = 0.5 * cam.mu * cam.d / cam.v
    assert b["light_per_pixel_channel1"] == pytest.approx(light, rel=1e-12)


def test_three_channel_design_against_numpy():
    d = Design.preset("split3")
    m = evaluate_design(d, DEPTHS)
    names = design_metrics(d)
    assert len(names) == 5 * 3 + 3 and list(m)[:len(names)] == list(names)
    assert list(m) == list(merit_names(d)) and len(m) == len(names) + 1 + 4 * 3
    sf = splitlf.sharp_fractions(d, (DEPTHS.min(), DEPTHS.max()))
    gaps = splitlf.new_samples(d, DEPTHS).max_gap
    rows = ["channel1", "channel2", "channel3", "union"]
    for k, row in enumerate(rows):
        label = "union" if row == "union" else f"channel {k + 1}"
        assert m[f"sharp_fraction_{row}"] == sf[label]
        assert m[f"max_gap_worst_{row}"] == np.max(gaps[k])
        assert m[f"max_gap_median_{row}"] == np.median(gaps[k])
    for i, ch in enumerate(d.channels, 1):
        tr = splitlf.trace(d, channel=i)
        assert m[f"lit_fraction_channel{i}"] == tr.lit.sum() / tr.lit.size
        light = ch.share * np.mean(tr.area[tr.lit]) / d.channels[0].L
        assert m[f"light_per_pixel_channel{i}"] == pytest.approx(light, rel=1e-13)


def test_hex_channel_gives_nan_for_the_line_merits():
    d = Design.preset("raytrix-r12")
    m = evaluate_design(d, DEPTHS)
    assert np.isfinite(m["sharp_fraction_channel1"]) and np.isfinite(m["sharp_fraction_union"])
    for name in ("max_gap_worst_union", "max_gap_median_channel1", "lit_fraction_channel1",
                 "light_per_pixel_channel1"):
        assert np.isnan(m[name]), name


GRID = {"channels[2].L": [75.0, 109.05161441151259], "D": [15.0, 20.0]}


@pytest.fixture(scope="module")
def design_sweep():
    pytest.importorskip("xarray")
    return sweep(Design.preset("split3"), GRID, DEPTHS, progress=False)


def test_sweep_over_a_design_grid(design_sweep):
    ds = design_sweep
    assert list(ds.sizes) == ["channels[2].L", "D"]
    assert set(design_metrics(Design.preset("split3"))) <= set(ds.data_vars)
    bad = ds.sel({"channels[2].L": 75.0})
    assert not bad["valid"].any()
    assert all("channels[2].L" in str(r) for r in bad["reason"].values)
    assert np.isnan(bad["sharp_fraction_union"]).all()
    good = ds.sel({"channels[2].L": GRID["channels[2].L"][1], "D": 15.0})
    assert bool(good["valid"])
    one = evaluate_design(Design.preset("split3").replace(D=15.0), DEPTHS)
    for name, value in one.items():
        assert float(good[name]) == value or (np.isnan(value) and np.isnan(good[name]))
    assert "base_design" in ds.attrs


def test_design_sweep_on_an_executor_is_identical(design_sweep):
    xr = pytest.importorskip("xarray")
    with cf.ThreadPoolExecutor(2) as ex:
        ds = sweep(Design.preset("split3"), GRID, DEPTHS, executor=ex, progress=False,
                   batch_size=1)
    xr.testing.assert_identical(ds, design_sweep)


def test_design_count_axis_and_focal_lengths():
    pytest.importorskip("xarray")
    base = Design.preset("seed-plain")
    ch = base.channels[0]
    base = base.replace(channels=(ch.replace(f=(1.0 / (1 / ch.L + 1 / ch.v),)),))
    assert "channels[1].f[0]" in design_fields(base)
    ds = sweep(base, {"channels[1].Kx": np.linspace(100, 200, 2),
                      "channels[1].f[0]": [0.6, 0.62]}, DEPTHS[:5], progress=False)
    assert ds["channels[1].Kx"].dtype == np.int64
    assert ds["valid"].all()


@pytest.mark.parametrize("name", ["channels[9].L", "channels[1].f[5]", "channels[0].L",
                                  "channels[1].grid", "channels[1].foo", "kappa",
                                  "channels[1].L[0]"])
def test_bad_field_names_are_named_errors(name):
    pytest.importorskip("xarray")
    pytest.importorskip("scipy")
    d = Design.preset("split3")
    with pytest.raises(InvalidParameter) as e:
        splitlf.optimise(d, free={name: (1.0, 2.0)}, objective="sharp_fraction_union")
    assert e.value.name == "free"
    with pytest.raises(InvalidParameter) as e:
        sweep(d, {name: [1.0]}, DEPTHS)
    assert e.value.name == "grid"


def test_focal_length_of_ng_setting_is_refused():
    with pytest.raises(InvalidParameter, match="Ng's setting"):
        splitlf.optimise(Design.preset("split3"), free={"channels[1].f[0]": (0.5, 0.7)},
                         objective="sharp_fraction_union")


def _closed_form_run(**kw):
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    return splitlf.optimise(
        Design.preset("split3"), free={"channels[2].L": (95.0, 120.0)},
        objective="out_of_focus_depth_channel2", sense="max",
        constraints={"out_of_focus_depth_channel2": ("<=", 300.0)},
        depths=np.geomspace(150.0, 10_000.0, 6), maxiter=8, popsize=5, **kw)


def test_optimise_a_design_finds_the_closed_form():
    res = _closed_form_run()
    F, z0 = 80.0, 300.0
    L = F * z0 / (z0 - F)  # z = F L / (L - F) = z0
    assert isinstance(res.design, Design)
    assert res.feasible
    assert res.free["channels[2].L"] == pytest.approx(L, rel=1e-9)
    assert res.design.channels[1].L == res.free["channels[2].L"]
    assert res.active == ("constraint: out_of_focus_depth_channel2 <= 300.0",)
    assert "sharp_fraction_union" in res.merits and "channels[2].L" in res.history.columns
    again = _closed_form_run()
    assert again.free == res.free and again.history.equals(res.history)


def test_optimise_a_design_on_an_executor_is_identical():
    res = _closed_form_run(polish=False)
    with cf.ThreadPoolExecutor(2) as ex:
        other = _closed_form_run(polish=False, executor=ex)
    assert other.free == res.free
    assert other.history.equals(res.history)


def test_optimise_a_design_records_invalid_candidates():
    # channel 2 close to the main lens: its microlens images overlap (invalid, named)
    pytest.importorskip("scipy")
    res = splitlf.optimise(Design.preset("split3"), free={"channels[2].L": (85.0, 140.0)},
                           objective="sharp_fraction_channel2",
                           depths=np.geomspace(150.0, 10_000.0, 6), maxiter=3, popsize=5,
                           polish=False)
    bad = res.history[~res.history["valid"]]
    assert len(bad) and bad["violated"].str.startswith("channels[2].").all()
    assert (bad["reason"] != "").all()
    assert np.isnan(bad["sharp_fraction_union"]).all()


def test_design_merits_do_not_depend_on_threads_and_check_input():
    d = Design.preset("split3")
    one = evaluate_design(d, DEPTHS, n_threads=1)
    assert one == evaluate_design(d, DEPTHS, n_threads=2)  # a Merits equals its items
    with pytest.raises(InvalidParameter) as e:
        evaluate_design(d, [50.0, 500.0])  # a depth not beyond F = 80
    assert e.value.name == "depths"
    with pytest.raises(InvalidParameter) as e:
        evaluate_design(d, DEPTHS, tol=-1.0)
    assert e.value.name == "tol"
    with pytest.raises(TypeError):
        evaluate_design({"F": 80.0}, DEPTHS)


def test_design_sweep_on_a_process_pool_is_identical(design_sweep):
    # only plain dicts and numbers cross to the workers (pickled by a process pool)
    import multiprocessing

    xr = pytest.importorskip("xarray")
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(1, mp_context=ctx) as ex:
        ds = sweep(Design.preset("split3"), GRID, DEPTHS, executor=ex, progress=False)
    xr.testing.assert_identical(ds, design_sweep)
