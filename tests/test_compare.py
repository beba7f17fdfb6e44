"""The architecture comparison (splitlf.compare, `splitlf compare`, splitlf.plot.compare):
its numbers against report, coverage, trace and closed forms computed here; validity and
determinism of the optimised designs; the CLI's files; the figure's line data."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import splitlf
from splitlf import Design
from splitlf.cli import main
from splitlf.compare import (
    ARCHITECTURES,
    DEPTH_RANGE,
    architectures,
    compare,
    evaluate,
    mtf50,
)
from splitlf.errors import InvalidParameter
from splitlf.report import report_data

pytest.importorskip("scipy")
pd = pytest.importorskip("pandas")

Z = np.geomspace(150.0, 10_000.0, 7)
#: A tiny budget: one generation of a small population, few depths, a narrow field.
TINY = {"maxiter": 1, "popsize": 2, "optimise_depths": np.geomspace(150.0, 10_000.0, 3),
        "depths": Z, "window": 2.0, "progress": False}


def _log_fraction(intervals, lo, hi):
    """The share of [lo, hi] (log depth) inside the open intervals (far None: infinite)."""
    total = 0.0
    for a, b in intervals:
        b = math.inf if b is None else b
        a, b = max(a, lo), min(b, hi)
        if b > a:
            total += math.log(b / a)
    return total / math.log(hi / lo)


def _inside(intervals, z):
    return any(a < z and (b is None or z < b) for a, b in intervals)


# -- the numbers of a given design equal the report's and coverage's ------------------------

def test_seed_numbers_equal_report_coverage_and_trace():
    seed = Design.preset("seed")
    table, curves = evaluate({"split": seed}, Z, window=3.0)
    row = table.loc["split"]
    # covering radius per depth and over the depths: splitlf.sampling.samples2d, row "union"
    cov = splitlf.coverage(seed, Z, window=3.0)
    np.testing.assert_array_equal(curves["z_mm"], Z)
    np.testing.assert_array_equal(curves["covering_radius"], cov.covering_radius[-1])
    np.testing.assert_array_equal(curves["covering_radius_mm"], cov.covering_radius_mm[-1])
    np.testing.assert_array_equal(curves["distinct_2d"], cov.distinct[-1])
    assert row["covering_radius_worst"] == np.max(cov.covering_radius[-1])
    assert row["covering_radius_median"] == np.median(cov.covering_radius[-1])
    assert row["distinct_2d_median"] == np.median(cov.distinct[-1])
    # sharpness: the report's depth of field of the union
    dof = report_data(seed, samples=False)["depth_of_field"]["light_field"]["union"]
    assert row["sharp_fraction"] == pytest.approx(_log_fraction(dof, Z.min(), Z.max()),
                                                  rel=1e-12)
    assert curves["sharp"].tolist() == [_inside(dof, z) for z in Z]
    # light per pixel: share x mean polygon area of the lit pixels along x / L_1 (trace),
    # averaged over both halves' lit pixels; the seed's halves share 1/2 of the light
    num = den = 0.0
    for i, ch in enumerate(seed.channels, 1):
        tr = splitlf.trace(seed, channel=i)
        num += ch.share * tr.area[tr.lit].sum() / seed.channels[0].L
        den += tr.lit.sum()
    assert row["light_per_pixel"] == pytest.approx(num / den, rel=1e-12)
    assert not row["light_from_rect_twin"]
    assert row["pixels"] == 2 * (266 * 15) * (88 * 15)
    assert row["out_of_focus_mm"] == "642.0 217.0"


def test_table_equals_the_2d_merits_of_the_optimiser():
    # the evaluation's worst and median covering radius and median distinct samples are the
    # core's 2-D merits (what optimise constrains) over the same depths and field
    from splitlf import evaluate as evaluate_design

    d = Design.preset("split3")
    table, _ = evaluate({"split3": d}, Z, window=2.5)
    m = evaluate_design(d, Z, merits_2d=True, window=2.5)
    row = table.loc["split3"]
    assert row["covering_radius_worst"] == m["covering_radius_worst_union"]
    assert row["covering_radius_median"] == m["covering_radius_median_union"]
    assert row["distinct_2d_median"] == m["distinct_2d_median_union"]


def test_a_2d_constraint_is_computed_over_the_search_window():
    res = compare("seed", "sharp_fraction_union", "max",
                  {"covering_radius_median_union": ("<=", 1.5)}, which=["split"],
                  optimise_window=2.0, **TINY)
    r = res.optimisations["split"]
    assert "covering_radius_median_union" in r.merits
    from splitlf import evaluate as evaluate_design

    m = evaluate_design(r.design, TINY["optimise_depths"], merits_2d=True, window=2.0)
    assert r.merits["covering_radius_median_union"] == m["covering_radius_median_union"]
    assert r.feasible == (m["covering_radius_median_union"] <= 1.5)


def test_conventional_camera_against_closed_forms():
    arch = architectures("seed")["conventional"]
    d = arch.base
    L, mu, D = d.channels[0].L, d.channels[0].mu, d.D
    table, curves = evaluate({"conventional": d}, Z, conventional=["conventional"],
                             window=8.0)
    # its samples are its pixel grid: a square grid of pitch delta(z), rho = 1/sqrt(2)
    np.testing.assert_allclose(curves["covering_radius"], 1.0 / math.sqrt(2.0), rtol=1e-9)
    # sharp where the conventional blur (D L / 2) |1/z' - 1/L| / mu is below 0.5 px
    zc = d.F * Z / (Z - d.F)
    blur = D * L / 2.0 * np.abs(1.0 / zc - 1.0 / L) / mu
    np.testing.assert_allclose(curves["blur_px"], blur, rtol=1e-9)
    assert curves["sharp"].tolist() == (blur < 0.5).tolist()
    # one pixel behind the whole aperture: etendue D mu / L per pixel along x
    assert table.loc["conventional", "light_per_pixel"] == pytest.approx(D * mu / L, rel=1e-12)
    assert table.loc["conventional", "light_relative"] == 1.0
    assert table.loc["conventional", "pixels"] == 4000 * 2666


def test_conventional_focus_is_the_closed_form_optimum():
    # Sharp where |1/z' - 1/L| < 2 t mu / (D L): the far limit 1/z'_far = (1 + 2 t mu / D) / L.
    # Focusing farther lengthens the depth of field (in log depth) until its far limit
    # reaches the range's far end; beyond that the near limit recedes. So the best plane is
    # L = (1 + 2 t mu / D) z'(far end).
    res = compare("seed", "sharp_fraction_union", which=["conventional"], **TINY)
    d = res.designs["conventional"]
    t, mu, D, F = 0.5, d.channels[0].mu, d.D, d.F
    zmax = TINY["optimise_depths"].max()
    expected = (1.0 + 2.0 * t * mu / D) * F * zmax / (zmax - F)
    assert d.channels[0].L == pytest.approx(expected, rel=1e-7)
    # not searched: "feasible" is not applicable, pandas' <NA> in a nullable boolean column
    assert res.table["feasible"].dtype == "boolean"
    assert res.table.loc["conventional", "feasible"] is pd.NA
    assert math.isnan(res.table.loc["conventional", "objective"])


# -- the architectures -------------------------------------------------------------------

@pytest.mark.parametrize("preset", ["seed", "raytrix-r12"])
def test_architectures_share_the_sensor_and_main_lens(preset):
    archs = architectures(preset)
    assert tuple(archs) == ARCHITECTURES
    ref = Design.preset(preset)
    for a in archs.values():
        assert (a.base.F, a.base.D, a.base.aperture) == (ref.F, ref.D, ref.aperture)
        assert all(ch.mu == ref.channels[0].mu for ch in a.base.channels)
        assert sum(ch.share for ch in a.base.channels) == pytest.approx(1.0, rel=1e-12)
        for name, (lo, hi) in a.free.items():
            assert lo < hi, name
            if name.endswith(".L"):  # planes whose out-of-focus depths are 50 m and 120 mm
                assert lo == pytest.approx(ref.F * 50_000.0 / (50_000.0 - ref.F), rel=1e-13)
                assert hi == pytest.approx(ref.F * 120.0 / (120.0 - ref.F), rel=1e-13)
    counts = {n: len(a.base.channels) for n, a in archs.items()}
    assert counts == {"plain": 1, "split": 2, "split3": 3, "multifocus": 1,
                      "conventional": 1}
    multi = archs["multifocus"].base.channels[0]
    assert multi.grid == "hex" and len(multi.f) == 3
    if preset == "seed":
        assert archs["split"].base == Design.preset("seed")
        assert archs["plain"].base == Design.preset("seed-plain")
        assert (multi.Mx, multi.My, multi.Ky) == (4000, 2666, 205)
    else:
        assert archs["multifocus"].base == ref
        # rect channels stacked along y on the 3068 pixel rows, each 1/n of the height
        for n, name in ((1, "plain"), (2, "split"), (3, "split3")):
            chs = archs[name].base.channels
            assert [c.My for c in chs] == [3068 // n] * n
            assert all(c.Ky * c.d <= 3068 * 0.0055 / n for c in chs)
    with pytest.raises(InvalidParameter) as e:
        architectures("lytro-illum")
    assert e.value.name == "preset"


# -- the optimised designs -------------------------------------------------------------------

def test_optimised_designs_are_valid_within_bounds_and_deterministic():
    kw = dict(which=["plain", "split", "multifocus"], **TINY)
    a = compare("seed", "sharp_fraction_union", **kw)
    b = compare("seed", "sharp_fraction_union", **kw)
    assert list(a.designs) == ["plain", "split", "multifocus"]
    for name, d in a.designs.items():
        assert d == b.designs[name]
        assert Design.from_dict(d.as_dict()) == d          # the constructor accepts it
        res = a.optimisations[name]
        assert res.feasible
        for field, (lo, hi) in a.architectures[name].free.items():
            assert lo <= res.free[field] <= hi
        hist = res.history
        assert hist["valid"].any()
    pd.testing.assert_frame_equal(a.table, b.table)
    pd.testing.assert_frame_equal(a.curves, b.curves)
    # the table's sharp fraction over the evaluation depths is the optimum's merit when the
    # two depth sets share their range
    for name, res in a.optimisations.items():
        assert a.table.loc[name, "sharp_fraction"] == pytest.approx(
            res.merits["sharp_fraction_union"], rel=1e-12)
        assert a.table.loc[name, "objective"] == res.objective
    # a hex channel has no 1-D light: it comes from its rect twin
    assert a.table.loc["multifocus", "light_from_rect_twin"]


def test_executor_passthrough_gives_the_same_designs():
    import concurrent.futures as cf

    kw = dict(which=["split"], **TINY)
    a = compare("seed", "sharp_fraction_union", **kw)
    with cf.ThreadPoolExecutor(2) as ex:
        b = compare("seed", "sharp_fraction_union", executor=ex, **kw)
    assert a.designs == b.designs


def test_bad_arguments_are_named():
    with pytest.raises(InvalidParameter) as e:
        compare("seed", "sharp_fraction_union", which=["plain", "nope"], **TINY)
    assert e.value.name == "which"
    with pytest.raises(InvalidParameter) as e:
        compare("seed", "no_such_merit", which=["plain"], **TINY)
    assert e.value.name == "objective"
    with pytest.raises(InvalidParameter) as e:
        evaluate({"x": Design.preset("seed")}, Z, conventional=["y"])
    assert e.value.name == "conventional"
    with pytest.raises(TypeError):
        evaluate({"x": "seed"}, Z)


def _first_crossing(freqs, contrast):
    """MTF50 by hand: the first frequency where the contrast drops below 0.5, linearly
    interpolated from (0, 1) or the previous tested frequency."""
    f, c = np.concatenate([[0.0], freqs]), np.concatenate([[1.0], contrast])
    k = next((i for i in range(1, c.size) if c[i] < 0.5), None)
    if k is None:
        return f[-1]
    return f[k - 1] + (f[k] - f[k - 1]) * (c[k - 1] - 0.5) / (c[k - 1] - c[k])


def test_mtf50_where_the_simulation_applies():
    seed, plain = Design.preset("seed"), Design.preset("seed-plain")
    r12 = Design.preset("raytrix-r12")
    conv = architectures("seed")["conventional"].base
    designs = {"plain": plain, "split": seed, "multifocus": r12, "conventional": conv}
    depths = [300.0, 642.0]
    table, _ = evaluate(designs, Z, window=2.0, conventional=["conventional"],
                        simulate_depths=depths)
    opts = {"seed": 0, "window": 128, "n_frequencies": 16, "oversample": 4}
    for z in depths:
        col = f"mtf50_{z:g}mm"
        for name in ("plain", "split"):
            # the union of the light field design, simulated without the reference camera
            sim = splitlf.simulate(designs[name], z, conventional=False, **opts)
            assert "conventional 1" not in sim.mtf50
            assert table.loc[name, col] == sim.mtf50["union"]
            assert sim.mtf50["union"] == pytest.approx(
                _first_crossing(sim.frequencies, sim.contrast["union"]), rel=1e-12)
            # and the same number as with the reference camera
            assert splitlf.simulate(designs[name], z, **opts).mtf50["union"] == \
                sim.mtf50["union"]
        # the conventional camera: its own sensor, the simulation's conventional row
        sim = splitlf.simulate(conv, z, **opts)
        assert table.loc["conventional", col] == sim.mtf50["conventional 1"]
        assert sim.mtf50["conventional 1"] == pytest.approx(
            _first_crossing(sim.frequencies, sim.contrast["conventional 1"]), rel=1e-12)
        assert math.isnan(table.loc["multifocus", col])  # hex: no 1-D simulation
    # the columns alone, without the rest of the evaluation
    alone = mtf50(designs, depths, conventional=["conventional"])
    pd.testing.assert_frame_equal(alone, table[alone.columns])
    with pytest.raises(TypeError, match="simulate_depths"):
        mtf50(designs, ["far"])


# -- CLI and figure ------------------------------------------------------------------------

def _cli_args(tmp_path, *extra):
    return ["compare", "--preset", "seed", "--objective", "sharp_fraction_union",
            "--architectures", "split,conventional", "--maxiter", "1", "--popsize", "2",
            "--depths", "150:10000:5", "--optimise-depths", "150:10000:3", "--window", "2",
            *extra]


def test_cli_writes_what_it_says(tmp_path, capsys):
    out, fig = tmp_path / "cmp", tmp_path / "cmp.png"
    assert main(_cli_args(tmp_path, "--out", str(out), "--figure", str(fig), "--json")) == 0
    doc = json.loads(capsys.readouterr().out)
    written = sorted(doc["written"])
    expected = sorted(str(p) for p in [out / "table.csv", out / "curves.csv",
                                       out / "split.toml", out / "conventional.toml", fig])
    assert written == expected
    assert fig.stat().st_size > 0
    table = pd.read_csv(out / "table.csv", index_col="architecture")
    assert list(table.index) == ["split", "conventional"]
    for rec in doc["table"]:
        assert table.loc[rec["architecture"], "sharp_fraction"] == pytest.approx(
            rec["sharp_fraction"], rel=1e-12)
    for name in ("split", "conventional"):
        d = Design.from_toml(out / f"{name}.toml")
        assert d.as_dict() == doc["designs"][name]
    # the same comparison through the API
    res = compare("seed", "sharp_fraction_union", which=["split", "conventional"],
                  maxiter=1, popsize=2, depths=np.geomspace(*DEPTH_RANGE, 5),
                  optimise_depths=np.geomspace(*DEPTH_RANGE, 3), window=2.0, progress=False)
    np.testing.assert_allclose(table["covering_radius_median"],
                               res.table["covering_radius_median"], rtol=1e-12)
    # no overwrite without --force; the text form names the files
    assert main(_cli_args(tmp_path, "--out", str(out))) == 2
    assert "--force" in capsys.readouterr().err
    assert main(_cli_args(tmp_path, "--out", str(out), "--force")) == 0
    text = capsys.readouterr().out
    assert "splitlf compare: preset seed" in text and str(out / "table.csv") in text


@pytest.mark.parametrize("extra, needle", [
    (["--architectures", "plain,bogus"], "--architectures"),
    (["--figure", "x.pdf"], "--figure"),
    (["--depths", "10:5:3"], "--depths"),
    (["--simulate-depths", "-5"], "--simulate-depths"),
    (["--constraint", "sharp_fraction_union=1"], "--constraint"),
])
def test_cli_bad_options(tmp_path, capsys, extra, needle):
    assert main(_cli_args(tmp_path, *extra)) == 2
    assert needle in capsys.readouterr().err


def test_plot_draws_the_api_numbers():
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    from matplotlib.figure import Figure

    res = compare("seed", "sharp_fraction_union", which=["split", "conventional"], **TINY)
    fig = Figure()
    a_mm, a_delta, a_table = splitlf.plot.compare(res, ax=fig.subplots(3, 1))
    for a, column in ((a_mm, "covering_radius_mm"), (a_delta, "covering_radius")):
        lines = {ln.get_label(): ln for ln in a.get_lines()}
        for name in res.designs:
            c = res.curve(name)
            label = res.architectures[name].label
            ln = lines[label]
            np.testing.assert_array_equal(ln.get_xdata(), c["z_mm"])
            np.testing.assert_array_equal(ln.get_ydata(), c[column])
            bad = lines[f"_{label}: not sharp"]
            np.testing.assert_array_equal(bad.get_xdata(), c["z_mm"][~c["sharp"]])
            np.testing.assert_array_equal(bad.get_ydata(), c[column][~c["sharp"]])
        assert a.get_xscale() == "log" and a.get_yscale() == "log"
    # the table's cells are the table's numbers
    cells = a_table.tables[0].get_celld()
    ncols = max(j for _, j in cells) + 1
    heads = [cells[0, j].get_text().get_text() for j in range(ncols)]
    j = heads.index("median rho\n[delta]")
    for i, name in enumerate(res.designs, 1):
        assert cells[i, j].get_text().get_text() == \
            f"{res.table.loc[name, 'covering_radius_median']:.3f}"
    assert splitlf.plot.compare(res, ax=Figure().subplots()).get_xscale() == "log"
    with pytest.raises(ValueError):
        splitlf.plot.compare(res, ax=list(Figure().subplots(4, 1)))
    with pytest.raises(TypeError):
        splitlf.plot.compare("not a comparison")


def test_table_of_a_camera_is_its_designs():
    # A Camera is its two-channel design: the comparison table gives the same row (the
    # rect twin of the light merits is built on the general design; a Camera's replace
    # takes its own fields only).
    pd = pytest.importorskip("pandas")
    z = np.geomspace(300.0, 3000.0, 3)
    a, _ = splitlf.compare.evaluate({"seed": splitlf.Camera.paper()}, z, window=2.0)
    b, _ = splitlf.compare.evaluate({"seed": splitlf.Design.preset("seed")}, z, window=2.0)
    pd.testing.assert_frame_equal(a, b)
