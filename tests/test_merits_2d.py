"""The 2-D figures of merit (issue 12): worst and median covering radius and median distinct
2-D samples per channel and union, against NumPy's max and median of `splitlf.sampling.samples2d`'s
rows computed here; the Camera against its `Camera.design`; computed only when asked for
(absent otherwise) in evaluate_design, sweep, optimise and the CLI; `window` checked."""

from __future__ import annotations

import json

import numpy as np
import pytest

import splitlf
from splitlf import Camera, Channel, Design, InvalidParameter, _native
from splitlf import evaluate as evaluate_design
from splitlf.cli import main
from splitlf.study.merit import merit_names
from splitlf.study.optimise import optimise
from splitlf.sweep import sweep


def design_metrics(d, merits_2d=False):
    """The core's merit names of ``d`` (the first of :func:`merit_names`)."""
    return tuple(_native.design_metrics(d.core, merits_2d))


#: The 2-D merits of a two-channel design (a Camera's), and every other merit of it.
METRICS_2D = tuple(f"{p}_{r}" for p in ("covering_radius_worst", "covering_radius_median",
                                         "distinct_2d_median")
                   for r in ("channel1", "channel2", "union"))

Z = np.geomspace(150.0, 10_000.0, 7)
PREFIXES = ("covering_radius_worst", "covering_radius_median", "distinct_2d_median")


def small_hex() -> Design:
    """One hex channel on a small sensor behind a circular aperture (a few hundred pixels)."""
    return Design(50.0, 10.0, [
        Channel(L=60.0, d=0.1, v=0.3, mu=0.011, Kx=9, Ky=8, grid="hex", layout="sensor",
                f=(0.3, 0.31, 0.32)),
    ], aperture="circle")


HEX_Z = np.geomspace(80.0, 3000.0, 6)


def _rows(design: Design) -> list[str]:
    return [f"channel{i}" for i in range(1, len(design.channels) + 1)] + ["union"]


def _expected(design, z, window, rows):
    """{name: value} from NumPy's max and median over the depths of coverage's rows."""
    cov = splitlf.coverage(design, z, window=window)
    out = {}
    for k, row in enumerate(rows):
        out[f"covering_radius_worst_{row}"] = float(np.max(cov.covering_radius[k]))
        out[f"covering_radius_median_{row}"] = float(np.median(cov.covering_radius[k]))
        out[f"distinct_2d_median_{row}"] = float(np.median(cov.distinct[k]))
    return out


@pytest.mark.parametrize("make, z, window", [
    (lambda: Design.preset("split3"), Z, 4.0),    # separable channels, general union
    (lambda: Design.preset("split3"), Z[:6], 3.0),  # an even number of depths
    (small_hex, HEX_Z, 16.0),
])
def test_design_merits_are_max_and_median_of_coverage(make, z, window):
    d = make()
    plain = evaluate_design(d, z)
    m = evaluate_design(d, z, merits_2d=True, window=window)
    names = design_metrics(d, merits_2d=True)
    assert list(m) == list(merit_names(d, merits_2d=True))
    assert list(m)[:len(names)] == list(names)
    rows = _rows(d)
    names_2d = [f"{p}_{r}" for p in PREFIXES for r in rows]
    assert list(names) == list(design_metrics(d)) + names_2d
    for k in design_metrics(d):  # the 1-D merits are unchanged, bit for bit (or both NaN)
        assert m[k] == plain[k] or (np.isnan(m[k]) and np.isnan(plain[k])), k
    expected = _expected(d, z, window, rows)
    assert {k: m[k] for k in names_2d} == expected
    assert all(m[f"distinct_2d_median_{r}"] > 0 for r in rows)


def test_camera_merits_are_its_design_merits():
    # a Camera is a Design: its 2-D merits (the two-engine code's *_half1, *_half2,
    # *_union) are its design's per channel and union, bit for bit
    cam = Camera.paper().replace(kappa=0.3)
    plain = evaluate_design(cam, Z)
    m = evaluate_design(cam, Z, merits_2d=True, window=4.0)
    assert list(m) == list(merit_names(cam, merits_2d=True))
    assert set(m) - set(plain) == set(METRICS_2D)
    assert {k: m[k] for k in plain} == dict(plain)  # bit for bit
    assert dict(m) == dict(evaluate_design(cam.design, Z, merits_2d=True, window=4.0))
    expected = _expected(cam.design, Z, 4.0, ["channel1", "channel2", "union"])
    assert {k: m[k] for k in METRICS_2D} == expected


def test_names_are_absent_unless_asked_for():
    d = Design.preset("split3")
    assert not set(evaluate_design(d, Z)) & set(design_metrics(d, merits_2d=True)[18:])
    assert not set(evaluate_design(Camera.paper(), Z)) & set(METRICS_2D)
    assert set(merit_names(d, merits_2d=True)) - set(merit_names(d)) \
        == {f"{p}_{r}" for p in PREFIXES for r in _rows(d)}


def test_sweep_with_and_without_2d_merits():
    pytest.importorskip("xarray")
    d = small_hex()
    grid = {"D": [8.0, 10.0, 40.0]}  # D = 40: overlapping microlens images (invalid)
    plain = sweep(d, grid, HEX_Z, progress=False)
    assert not any(v.startswith(PREFIXES) for v in plain.data_vars)
    ds = sweep(d, grid, HEX_Z, progress=False, merits_2d=True, window=4.0)
    assert ds["valid"].values.tolist() == [True, True, False]
    assert ds.attrs["merits_2d"] == 1 and ds.attrs["window"] == 4.0
    for name in design_metrics(d, merits_2d=True):
        assert name in ds.data_vars and ds[name].attrs["description"]
    for i, D in enumerate(grid["D"][:2]):
        one = evaluate_design(d.replace(D=D), HEX_Z, merits_2d=True, window=4.0)
        for k, v in one.items():
            got = float(ds[k].values[i])
            assert got == v or (np.isnan(got) and np.isnan(v)), k
    assert np.isnan(ds["covering_radius_worst_union"].values[2])
    cam = sweep(Camera.paper(), {"kappa": [0.2, 0.4]}, Z, progress=False, merits_2d=True,
                window=4.0)
    one = evaluate_design(Camera.paper().replace(kappa=0.4), Z, merits_2d=True, window=4.0)
    for k in METRICS_2D:
        assert float(cam[k].values[1]) == one[k]
        assert "channel" in cam[k].attrs["description"] or "union" in cam[k].attrs["description"]


def test_optimise_a_hex_design_for_its_covering_radius(monkeypatch):
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    reached = []
    real = _native.design_figures_of_merit

    def spy(core, z, threshold_px, tol, n_threads, window):
        assert window == 4.0  # the 2-D merits were asked for: the objective names one
        reached.append(core)
        return real(core, z, threshold_px, tol, n_threads, window)

    monkeypatch.setattr(_native, "design_figures_of_merit", spy)
    base = small_hex()
    # large D: the microlens images (D v / L wide) overlap (invalid, never evaluated)
    res = optimise(base, {"D": (4.0, 30.0), "channels[1].v": (0.2, 0.4)},
                   "covering_radius_worst_channel1",
                   constraints={"distinct_2d_median_channel1": (">=", 10.0)}, depths=HEX_Z,
                   window=4.0, maxiter=4, popsize=5, polish_maxfev=15, seed=3)
    assert res.feasible
    h = res.history
    assert (~h["valid"]).sum() > 0 and h["valid"].sum() == len(reached)
    assert set(h.loc[~h["valid"], "violated"]) == {"channels[1].D"}
    names_2d = [f"{p}_channel1" for p in PREFIXES] + [f"{p}_union" for p in PREFIXES]
    assert h.loc[~h["valid"], names_2d].isna().all().all()
    for core in reached:  # every design that reached the core is one the constructor built
        Design._from_core(core).replace()  # noqa: B018 - valid (raises otherwise)
    expected = _expected(res.design, HEX_Z, 4.0, _rows(res.design))
    assert {k: res.merits[k] for k in expected} == expected
    assert res.objective == expected["covering_radius_worst_channel1"]
    feasible = h[h["feasible"]]
    assert res.objective == feasible["covering_radius_worst_channel1"].min()  # min by default
    assert (feasible["distinct_2d_median_channel1"] >= 10.0).all()


def test_optimise_with_2d_merits_on_an_executor_is_identical():
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    import concurrent.futures as cf

    kw = {"depths": HEX_Z, "window": 4.0, "maxiter": 2, "popsize": 4, "polish": False}
    free = {"D": (4.0, 30.0)}
    res = optimise(small_hex(), free, "distinct_2d_median_union", **kw)
    with cf.ThreadPoolExecutor(2) as ex:
        other = optimise(small_hex(), free, "distinct_2d_median_union", executor=ex, **kw)
    assert other.free == res.free and other.history.equals(res.history)
    assert "distinct_2d_median_union" in res.history.columns


def test_optimise_computes_2d_merits_only_when_named():
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    kw = {"depths": Z[:4], "maxiter": 2, "popsize": 3, "polish": False}
    free = {"kappa": (0.1, 0.6)}
    res = optimise(Camera.paper(), free, "sharp_fraction_union", **kw)
    assert not set(res.merits) & set(METRICS_2D)
    assert not set(res.history.columns) & set(METRICS_2D)
    # a constraint naming one turns them on; the objective need not
    res = optimise(Camera.paper(), free, "sharp_fraction_union", window=4.0,
                   constraints={"covering_radius_median_union": ("<=", 100.0)}, **kw)
    assert set(METRICS_2D) <= set(res.merits) and set(METRICS_2D) <= set(res.history.columns)
    # a callable objective reads them with merits_2d=True ...
    res = optimise(Camera.paper(), free, lambda m: m["distinct_2d_median_union"],
                   sense="max", merits_2d=True, window=4.0, **kw)
    assert res.objective == res.merits["distinct_2d_median_union"]
    # ... and without, they are not in its dict
    with pytest.raises(KeyError, match="distinct_2d_median_union"):
        optimise(Camera.paper(), free, lambda m: m["distinct_2d_median_union"], sense="max",
                 **kw)
    with pytest.raises(InvalidParameter) as e:
        optimise(Camera.paper(), free, "covering_radius_worst_union", merits_2d=False, **kw)
    assert e.value.name == "merits_2d"
    with pytest.raises(TypeError, match="merits_2d"):
        optimise(Camera.paper(), free, "sharp_fraction_union", merits_2d="yes", **kw)


@pytest.mark.parametrize("window", [0.0, -4.0, float("nan"), float("inf"), 10**400])
def test_bad_window_is_named(window):
    d = Design.preset("split3")
    for merits_2d in (True, False):  # checked even when the 2-D merits are off
        with pytest.raises(InvalidParameter) as e:
            evaluate_design(d, Z, merits_2d=merits_2d, window=window)
        assert e.value.name == "window"
    with pytest.raises(InvalidParameter) as e:
        sweep(d, {"D": [15.0]}, Z, merits_2d=True, window=window, progress=False)
    assert e.value.name == "window"
    pytest.importorskip("scipy")
    with pytest.raises(InvalidParameter) as e:
        optimise(Camera.paper(), {"kappa": (0.1, 0.6)}, "covering_radius_worst_union",
                 depths=Z, window=window)
    assert e.value.name == "window"
    if window != 10**400:  # the core's own check, for callers of _native
        with pytest.raises(InvalidParameter) as e:
            _native.design_figures_of_merit(d.core, Z, 0.5, 1e-6, None, float(window))
        assert e.value.name == "window"


def test_other_bad_options():
    d = Design.preset("split3")
    with pytest.raises(TypeError, match="window"):
        evaluate_design(d, Z, merits_2d=True, window="4")
    with pytest.raises(TypeError, match="merits_2d"):
        evaluate_design(d, Z, merits_2d=1)
    with pytest.raises(TypeError, match="merits_2d"):
        design_metrics(d, merits_2d=None)
    for tol in (0.0, 2.0):  # the 2-D distinct samples need tol in (0, 1]
        assert evaluate_design(d, Z, tol=tol)  # fine for the 1-D merits alone
        with pytest.raises(InvalidParameter) as e:
            evaluate_design(d, Z, tol=tol, merits_2d=True)
        assert e.value.name == "tol"
        with pytest.raises(InvalidParameter) as e:
            _native.design_figures_of_merit(d.core, Z, 0.5, tol, None, 4.0)
        assert e.value.name == "tol"


def test_cli_optimise_and_sweep_with_2d_merits(tmp_path, capsys):
    pytest.importorskip("scipy")
    argv = ["optimise", "--free", "kappa=0.1:0.6", "--objective", "covering_radius_worst_union",
            "--depths", "150:10000:4", "--maxiter", "2", "--popsize", "3", "--no-polish",
            "--window", "4", "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    res = optimise(Camera.paper(), {"kappa": (0.1, 0.6)}, "covering_radius_worst_union",
                   depths=np.geomspace(150.0, 10_000.0, 4), maxiter=2, popsize=3,
                   polish=False, window=4.0)
    assert doc["objective_value"] == res.objective and doc["free"] == res.free
    assert set(METRICS_2D) <= set(doc["merits"])
    import splitlf.study.optimise

    class Seen(Exception):
        pass

    def seen(*args, **kwargs):
        raise Seen(kwargs)

    with pytest.MonkeyPatch.context() as mp:  # without --window: the default, 16
        mp.setattr(splitlf.study.optimise, "optimise", seen)
        with pytest.raises(Seen) as e:
            main(argv[:-3] + ["--json"])
        assert "window" not in e.value.args[0] and e.value.args[0]["merits_2d"] is None
        with pytest.raises(Seen) as e:
            main(argv + ["--merits-2d"])
        assert e.value.args[0]["window"] == 4.0 and e.value.args[0]["merits_2d"] is True
    with pytest.raises(SystemExit) as e:  # argparse's own error
        main(argv[:-2] + ["0", "--json"])
    assert e.value.code == 2 and "window" in capsys.readouterr().err
    assert main(["optimise", "--free", "kappa=0.1:0.6", "--objective", "sharp_fraction_union",
                 "--depths", "150:10000:4", "--maxiter", "2", "--popsize", "3",
                 "--no-polish", "--json"]) == 0
    assert not set(json.loads(capsys.readouterr().out)["merits"]) & set(METRICS_2D)
    pytest.importorskip("xarray")
    spec = tmp_path / "sweep.toml"
    spec.write_text("[grid]\nkappa = [0.2, 0.4]\n[depths]\nnum = 4\n")
    assert main(["sweep", "--grid", str(spec), "--json"]) == 0
    assert "covering_radius_worst_union" not in json.loads(
        capsys.readouterr().out)["designs"][0]
    assert main(["sweep", "--grid", str(spec), "--json", "--merits-2d", "--window", "4"]) == 0
    rec = json.loads(capsys.readouterr().out)["designs"][1]
    one = evaluate_design(Camera.paper().replace(kappa=0.4), np.geomspace(150.0, 1e4, 4),
                          merits_2d=True, window=4.0)
    for k in METRICS_2D:  # JSON holds 10 significant digits
        assert rec[k] == pytest.approx(one[k], rel=1e-9)
    spec.write_text("[grid]\nkappa = [0.2, 0.4]\n[depths]\nnum = 4\n"
                    "[options]\nmerits_2d = true\nwindow = 4.0\n")
    assert main(["sweep", "--grid", str(spec), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["designs"][1] == rec
    spec.write_text("[grid]\nkappa = [0.2]\n[options]\nwindow = -1.0\n")
    assert main(["sweep", "--grid", str(spec)]) == 2
    assert "window" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["sweep", "--grid", str(spec), "--window", "0"])
    assert e.value.code == 2 and "window" in capsys.readouterr().err
