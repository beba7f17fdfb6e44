"""Every subcommand and public function that takes a Camera also takes a Design (issue 11):
`sweep`, `simulate`, `optimise` with --preset or a [design] TOML against the API on the
same design, and against the Camera path for Camera.design; `plot.resolution` of a Design
against `simulate`'s numbers; `report_data` of a Design; named errors for bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _cli import run_cli

import splitlf
from splitlf import Camera, Design, InvalidParameter, simulate
from splitlf.cli import json_text, main
from splitlf.study.merit import merit_names

SEED = Camera.paper()
Z = np.geomspace(150.0, 10_000.0, 12)


def _design_file(tmp_path, design, name="design.toml"):
    path = tmp_path / name
    design.to_toml(path)
    return str(path)


def _sweep_file(tmp_path, grid_lines, base="", name="sweep.toml"):
    path = tmp_path / name
    path.write_text("[grid]\n" + grid_lines + "[depths]\nmin = 150.0\nmax = 10000.0\n"
                    f"num = {Z.size}\n" + base)
    return str(path)


# -- sweep ----------------------------------------------------------------------------------

def test_cli_sweep_of_a_preset_equals_the_api(tmp_path, capsys):
    xr = pytest.importorskip("xarray")
    from splitlf.study.merit import merit_names as design_metrics
    from splitlf.sweep import sweep

    d = Design.preset("split3")
    spec = _sweep_file(tmp_path, '"channels[2].L" = [100.0, 115.0]\nD = [15.0, 20.0]\n')
    code, out, err = run_cli(["sweep", "--grid", spec, "--preset", "split3", "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    ds = sweep(d, {"channels[2].L": [100.0, 115.0], "D": [15.0, 20.0]}, Z, progress=False)
    assert len(doc["designs"]) == 4 and "base_design" not in doc["attrs"]
    df = ds.to_dataframe().reset_index()
    for rec, (_, row) in zip(doc["designs"], df.iterrows(), strict=True):
        assert rec["channels[2].L"] == row["channels[2].L"] and rec["D"] == row["D"]
        for m in design_metrics(d):
            assert rec[m] == (None if np.isnan(row[m]) else row[m]), m
    # the same base as a [design] table in the sweep file, written to NetCDF
    import tomllib

    base = "\n" + d.to_toml()
    spec2 = _sweep_file(tmp_path, '"channels[2].L" = [100.0, 115.0]\nD = [15.0, 20.0]\n', base,
                        "with_base.toml")
    nc = tmp_path / "s.nc"
    code, out, err = run_cli(["sweep", "--grid", spec2, "--out", str(nc)], capsys)
    assert code == 0, err
    with xr.open_dataset(nc) as back:
        np.testing.assert_array_equal(back["max_gap_worst_union"], ds["max_gap_worst_union"])
        assert Design.from_dict(tomllib.loads(back.attrs["base_design"])["design"]) == d
    # the text table names the design's union rows
    code, out, _ = run_cli(["sweep", "--grid", spec, "--preset", "split3"], capsys)
    assert code == 0 and "sharp_fraction_union" in out and "sharp_fraction_channel3" in out


def test_cli_sweep_of_camera_design_equals_the_camera_path(tmp_path, capsys):
    pytest.importorskip("xarray")
    spec = _sweep_file(tmp_path, "D = [10.0, 20.0]\n")
    assert main(["sweep", "--grid", spec, "--json"]) == 0
    cam = json.loads(capsys.readouterr().out)["designs"]
    cfg = _design_file(tmp_path, SEED.design)
    assert main(["sweep", "--grid", spec, "--config", cfg, "--json"]) == 0
    des = json.loads(capsys.readouterr().out)["designs"]
    for a, b in zip(cam, des, strict=True):
        assert a["D"] == b["D"] and a["valid"] and b["valid"]
        for m in merit_names(SEED):  # the camera is its design: the same merits
            assert b[m] == pytest.approx(a[m], rel=1e-14, nan_ok=True), m


@pytest.mark.parametrize("grid, base, extra, needle", [
    ('kappa = [0.2, 0.3]\n', "", ["--preset", "split3"], "invalid grid = 'kappa'"),
    ('"channels[4].L" = [100.0]\n', "", ["--preset", "split3"], "a channel number in [1, 3]"),
    ("D = [10.0]\n", "\n" + SEED.to_toml(), ["--preset", "seed"], "--preset: "),
    ("D = [10.0]\n", "\n" + SEED.to_toml() + "\n" + SEED.design.to_toml(), [],
     "a [camera] and a [design] table"),
    ("D = [10.0]\n", "", ["--preset", "seed", "--config", "x.toml"], "--preset and --config"),
    ("D = [10.0]\n", "", ["--preset", "nope"], "invalid choice: 'nope'"),
])
def test_cli_sweep_bad_bases_are_named(tmp_path, capsys, grid, base, extra, needle):
    pytest.importorskip("xarray")
    spec = _sweep_file(tmp_path, grid, base)
    code, out, err = run_cli(["sweep", "--grid", spec, *extra], capsys)
    assert code == 2 and out == "" and needle in err and err.count("\n") == 1, err


# -- simulate -------------------------------------------------------------------------------

def test_cli_simulate_of_a_preset_equals_the_api(capsys):
    pytest.importorskip("scipy")
    code, out, err = run_cli(["simulate", "--preset", "split3", "--z", "700", "--threads", "1",
                           "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["source"] == "preset split3"
    r = simulate(Design.preset("split3"), 700.0, n_threads=1)
    assert doc["results"] == [json.loads(json_text(r.summary()))]
    assert list(doc["results"][0]["rmse"]) == list(r.rows) == \
        ["channel 1", "channel 2", "channel 3", "union", "conventional 1"]
    code, out, _ = run_cli(["simulate", "--preset", "split3", "--z", "700"], capsys)
    rows = [ln.split() for ln in out.splitlines()[2:]]
    assert code == 0 and [" ".join(w[1:-4]) for w in rows] == list(r.rows)
    assert [float(w[-4]) for w in rows] == [round(r.rmse[k], 4) for k in r.rows]
    assert [float(w[-1]) for w in rows] == [round(256 * r.delta, 3)] * len(r.rows)
    assert "window 256 cells of delta(z)" in out.splitlines()[0]


def test_cli_simulate_of_camera_design_equals_the_camera_path(tmp_path, capsys):
    pytest.importorskip("scipy")
    # at 642 mm delta(z) of the design and the camera agree to the bit, so every number does
    assert main(["simulate", "--z", "642", "--json"]) == 0
    cam = json.loads(capsys.readouterr().out)["results"][0]
    cfg = _design_file(tmp_path, SEED.design)
    assert main(["simulate", "--config", cfg, "--z", "642", "--json"]) == 0
    des = json.loads(capsys.readouterr().out)["results"][0]
    assert des["delta_mm"] == cam["delta_mm"]
    for key in ("rmse", "psnr_db", "mtf50_cycles_per_mm", "regularization", "pixels"):
        assert cam[key] == des[key], key


def test_cli_simulate_refuses_a_hex_design_by_name(tmp_path, capsys):
    code, out, err = run_cli(["simulate", "--preset", "raytrix-r12", "--z", "900"], capsys)
    assert code == 2 and out == "" and "channels[1].grid" in err and err.count("\n") == 1


# -- optimise -------------------------------------------------------------------------------

OPT = ["--depths", "150:10000:12", "--maxiter", "3", "--popsize", "4", "--threads", "1"]


def test_cli_optimise_of_a_preset_equals_the_api_and_writes_a_design(tmp_path, capsys):
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    out = tmp_path / "best.toml"
    code, text, err = run_cli(["optimise", "--preset", "split3", "--free", "channels[2].L=95:140",
                            "--objective", "sharp_fraction_channel2", *OPT, "--out", str(out),
                            "--json"], capsys)
    assert code == 0, err
    doc = json.loads(text)
    res = splitlf.optimise(Design.preset("split3"), {"channels[2].L": (95.0, 140.0)},
                           "sharp_fraction_channel2", depths=np.geomspace(150.0, 1e4, 12),
                           maxiter=3, popsize=4, n_threads=1)
    assert doc["free"] == res.free and doc["merits"] == json.loads(json_text(res.merits))
    assert doc["design"] == res.design.as_dict() and "camera" not in doc
    assert Design.from_toml(out) == res.design
    code, text, err = run_cli(["report", "--config", str(out), "--json"], capsys)
    assert code == 0 and json.loads(text)["design"] == res.design.as_dict()


def test_cli_optimise_of_camera_design_equals_the_camera_path(tmp_path, capsys):
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    hist_c, hist_d = tmp_path / "c.csv", tmp_path / "d.csv"
    common = ["--free", "D=8:40", *OPT, "--no-polish"]
    assert main(["optimise", *common, "--objective", "sharp_fraction_union",
                 "--history", str(hist_c)]) == 0
    capsys.readouterr()
    cfg = _design_file(tmp_path, SEED.design)
    assert main(["optimise", "--config", cfg, *common, "--objective", "sharp_fraction_union",
                 "--history", str(hist_d)]) == 0
    capsys.readouterr()
    import pandas as pd

    a, b = pd.read_csv(hist_c), pd.read_csv(hist_d)
    # the same candidates, the same validity and the same objective, candidate by candidate
    assert len(a) == len(b) > 10
    np.testing.assert_array_equal(a["D"], b["D"])
    np.testing.assert_array_equal(a["valid"], b["valid"])
    np.testing.assert_array_equal(a["objective"], b["objective"])
    np.testing.assert_array_equal(a["sharp_fraction_union"], b["sharp_fraction_union"])


@pytest.mark.parametrize("extra, needle", [
    (["--preset", "seed", "--free", "kappa=0.05:0.8"], "invalid --free = 'kappa'"),
    (["--preset", "seed", "--free", "D=8:40", "--objective", "sharp_fraction_split"],
     "invalid --objective = 'sharp_fraction_split': allowed one of: sharp_fraction_channel1"),
    (["--preset", "nope", "--free", "D=8:40"], "invalid choice: 'nope'"),
])
def test_cli_optimise_bad_design_options_are_named(capsys, extra, needle):
    argv = ["optimise", "--objective", "sharp_fraction_union", *extra]
    code, out, err = run_cli(argv, capsys)
    assert code == 2 and out == "" and needle in err and err.count("\n") == 1, err
    assert "callable" not in err


# -- plot.resolution ------------------------------------------------------------------------

def test_plot_resolution_of_a_design_draws_the_simulation(capsys):
    pytest.importorskip("scipy")
    from matplotlib.figure import Figure

    from splitlf.plot import resolution

    d = Design.preset("split3")
    fig = Figure()
    axes = fig.subplots(2, 1)
    kw = dict(window=32, n_frequencies=6)
    resolution(d, (300.0, 2000.0), ax=axes, n=2, n_threads=1, **kw)
    # the depths: the two ends and every channel's out-of-focus plane inside
    planes = [d.out_of_focus_depth(c) for c in (1, 2, 3)]
    z = np.unique(np.concatenate([np.geomspace(300.0, 2000.0, 2),
                                  [p for p in planes if 300.0 < p < 2000.0]]))
    assert z.size >= 3
    runs = [simulate(d, zk, seed=0, oversample=4, n_threads=1, **kw) for zk in z]
    rows = runs[0].rows
    mtf = {ln.get_label(): ln for ln in axes[0].lines}
    rmse = {ln.get_label(): ln for ln in axes[1].lines}
    labels = ["channel 1 alone", "channel 2 alone", "channel 3 alone",
              "union (all channels)", "conventional (no microlenses, sensor on plane 1)"]
    for row, label in zip(rows, labels, strict=True):
        np.testing.assert_array_equal(mtf[label].get_xdata(), z)
        np.testing.assert_array_equal(mtf[label].get_ydata(), [r.mtf50[row] for r in runs])
        np.testing.assert_array_equal(rmse[label].get_ydata(), [r.rmse[row] for r in runs])
    nyq = next(ln for ln in axes[0].lines if ln.get_label().startswith("full sensor"))
    np.testing.assert_allclose(nyq.get_ydata(), [0.5 / d.resolution_step(zk) for zk in z],
                               rtol=1e-15)
    ml = next(ln for ln in axes[0].lines if ln.get_label().startswith("microlens"))
    ch1 = d.channels[0]
    np.testing.assert_allclose(ml.get_ydata(), ch1.L / (ch1.d * z), rtol=1e-15)


def test_plot_resolution_of_camera_design_equals_the_camera_figure():
    pytest.importorskip("scipy")
    from matplotlib.figure import Figure

    from splitlf.plot import resolution

    kw = dict(n=2, window=32, n_frequencies=6, n_threads=1)
    # depths 400, 700 mm and half 1's out-of-focus plane (642 mm) between them
    fa, fb = Figure().subplots(2, 1), Figure().subplots(2, 1)
    resolution(SEED, (400.0, 700.0), ax=fa, **kw)
    resolution(SEED.design, (400.0, 700.0), ax=fb, **kw)
    za, zb = fa[0].lines[0].get_xdata(), fb[0].lines[0].get_xdata()
    np.testing.assert_allclose(zb, za, rtol=1e-15)
    assert za[0] == 400.0 and za[1] == pytest.approx(642.0, rel=1e-12) and za.size == 3
    # delta(z) is d z / (Q v') for the camera, mu_1 z / L_1 for its design: where the two
    # agree to the bit (400 mm among them) every number agrees to the bit, elsewhere to
    # the 1e-2 of a pixel entering or leaving the field (tests/test_design_simulate.py)
    same = np.array([SEED.core.resolution_step(z) == SEED.design.resolution_step(z)
                     for z in za])
    assert same[0]
    for k in range(4):  # half 1, half 2, split, conventional; channel 1, 2, union, conv. 1
        assert fb[0].lines[k].get_label() == fa[0].lines[k].get_label()
        for a, b in ((fa[0], fb[0]), (fa[1], fb[1])):
            ya, yb = a.lines[k].get_ydata(), b.lines[k].get_ydata()
            np.testing.assert_array_equal(ya[same], yb[same])
            np.testing.assert_allclose(yb[~same], ya[~same], rtol=1e-2)


def test_plot_resolution_refuses_a_hex_design_before_drawing():
    from matplotlib.figure import Figure

    from splitlf.plot import resolution

    axes = Figure().subplots(2, 1)
    with pytest.raises(InvalidParameter) as e:
        resolution(Design.preset("raytrix-r12"), ax=axes)
    assert e.value.name == "channels[1].grid"
    assert not axes[0].lines and not axes[1].lines
    with pytest.raises(TypeError, match="splitlf.Design"):
        resolution("seed", ax=axes)


# -- report ---------------------------------------------------------------------------------

def test_report_data_of_a_design_is_the_design_report():
    from splitlf.report import format_report, report_data

    d = Design.preset("raytrix-r12")
    data = report_data(d, 1.0)
    assert "resolution" not in report_data(d, 1.0, samples=False)  # the explorer's form
    assert format_report(data, "t", full=True).startswith("t\n\nMain lens")
    # one builder: the camera's report is its design's
    assert report_data(SEED) == report_data(SEED.design)
    assert report_data(SEED)["design"] == SEED.design.as_dict()
    with pytest.raises(TypeError, match="splitlf.Design"):
        report_data(SEED.as_dict())
    with pytest.raises(InvalidParameter) as e:
        report_data(d, n_threads=0)
    assert e.value.name == "n_threads"


def test_design_report_has_the_sample_sections():
    from splitlf.report import report_data

    des = report_data(SEED)
    for h in (1, 2):
        rows = des["coincidence_planes"][f"channel {h}"]
        assert rows and all(r["counted"] == r["new_samples"] for r in rows)
    res = des["resolution"]
    assert res["channel 1"]["max_gap"] == pytest.approx(15.0, rel=1e-9)
    assert res["union"]["max_gap"] < res["channel 2"]["max_gap"]
    # a hex design: no coincidence planes, no 1-D worst resolution, said so
    hexd = report_data(Design.preset("raytrix-r12"))
    assert hexd["coincidence_planes"] == {"channel 1": None} and hexd["resolution"] is None


def test_cli_report_of_a_design_prints_the_sample_sections(capsys):
    code, out, _ = run_cli(["report", "--preset", "split3", "--threads", "1", "--full"], capsys)
    assert code == 0
    for needle in ("Coincidence planes (N <= 3", "channel 3: ", "Worst resolution over 150",
                   "  union          max gap"):
        assert needle in out, needle
    code, out, _ = run_cli(["report", "--preset", "lytro-illum", "--full"], capsys)
    assert code == 0 and "channel 1: none defined" in out and "not defined for a hex" in out
