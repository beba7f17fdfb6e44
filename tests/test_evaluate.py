"""splitlf.evaluate is the one source of a design's merits: sweep, optimise and compare
report what it gives for the same design and depths, and no other module calls the core's
merit entry."""

from __future__ import annotations

import pathlib
import re

import numpy as np
import pytest

import splitlf
from splitlf import Camera, Design, Merits, evaluate
from splitlf.study.merit import merit_doc, merit_names

Z = np.geomspace(150.0, 10_000.0, 12)
PACKAGE = pathlib.Path(splitlf.__file__).parent


def test_only_evaluate_calls_the_core_merit_entry():
    callers = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                     if re.search(r"\bdesign_figures_of_merit\b|\bfigures_of_merit\b",
                                  p.read_text(encoding="utf-8")))
    assert callers == ["study/merit.py"]


def test_merits_is_a_read_only_mapping_with_its_settings():
    m = evaluate(Camera.paper(), Z, threshold_px=0.5)
    assert isinstance(m, Merits) and list(m) == list(merit_names(Camera.paper()))
    assert m == dict(m) and m["sharp_fraction_union"] == 1.0
    assert m.threshold_px == 0.5 and m.window is None and m.depths.tolist() == Z.tolist()
    with pytest.raises(TypeError):
        m["f_number"] = 1.0  # type: ignore[index]
    assert all(merit_doc(n) for n in m)
    # a Camera is a Design: the same merits as its plain design, bit for bit
    assert dict(m) == dict(evaluate(Design.preset("seed"), Z))


def test_closed_form_merits():
    cam = Camera.paper()
    m = evaluate(cam, Z)
    assert m["f_number"] == cam.F / cam.D
    assert m["image_fill_channel1"] == pytest.approx(cam.D * cam.v / (cam.v1 * cam.Q * cam.mu),
                                                     rel=1e-12)
    assert m["microlens_f_number_channel2"] == pytest.approx(cam.f2 / cam.d, rel=1e-12)
    sf = splitlf.sharp_fractions(cam, (Z.min(), Z.max()))
    assert m["sharp_fraction_conventional_channel1"] == sf["conventional channel 1"]


def test_sweep_reports_evaluate():
    xr = pytest.importorskip("xarray")
    assert xr
    from splitlf.sweep import sweep

    d = Design.preset("split3")
    ds = sweep(d, {"D": [15.0, 20.0]}, Z, progress=False, merits_2d=True, window=3.0)
    one = evaluate(d.replace(D=15.0), Z, merits_2d=True, window=3.0)
    for k, v in one.items():
        assert float(ds[k].sel(D=15.0)) == v, k


def test_optimise_reports_evaluate():
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    res = splitlf.optimise(Camera.paper(), {"kappa": (0.1, 0.6)}, "max_gap_worst_union",
                           depths=Z, maxiter=2, popsize=3, polish=False)
    assert res.merits == dict(evaluate(res.design, Z))
    assert type(res.design) is Camera


def test_compare_reports_evaluate():
    pytest.importorskip("scipy")
    pd = pytest.importorskip("pandas")
    assert pd
    from splitlf.compare import evaluate as compare_designs

    d = Design.preset("seed")
    table, _ = compare_designs({"split": d}, Z, window=2.0)
    m = evaluate(d, Z, merits_2d=True, window=2.0)
    row = table.loc["split"]
    assert row["sharp_fraction"] == m["sharp_fraction_union"]
    assert row["covering_radius_worst"] == m["covering_radius_worst_union"]
    assert row["covering_radius_median"] == m["covering_radius_median_union"]
    assert row["distinct_2d_median"] == m["distinct_2d_median_union"]


def _seed_cut() -> Design:
    seed = Design.preset("seed")
    return seed.replace(channels=tuple(c.replace(Kx=12, Ky=8) for c in seed.channels))


def test_image_merit_names_docs_and_checks():
    """The image merits' names per channel and union, each documented, "max" by nature;
    a bad name is a clear error naming the allowed ones, in evaluate, sweep and optimise;
    the simulated MTF50's names keep their own doc."""
    from splitlf.study.merit import image_merit_names
    from splitlf.study.optimise import natural_sense

    d = _seed_cut()
    names = image_merit_names(d)
    assert len(names) == 12 and "psnr_worst_union" in names
    assert "mtf50_median_channel1" in names
    assert all("splitlf.image_merits" in merit_doc(n) for n in names)
    assert "least" in merit_doc("psnr_worst_union") and "median" in merit_doc(
        "mtf50_median_channel2")
    assert "simulate" in merit_doc("mtf50_642mm")
    assert all(natural_sense(n) == "max" for n in names)
    assert natural_sense("mtf50_642mm") is None
    with pytest.raises(splitlf.InvalidParameter, match="image.*psnr_worst_channel1, "):
        evaluate(d, Z, image=["psnr_best_union"])
    with pytest.raises(TypeError, match="image"):
        evaluate(d, Z, image="psnr_worst_union")
    with pytest.raises(splitlf.InvalidParameter, match="photons"):
        evaluate(d, Z, image=["psnr_worst_union"], photons=0.0)
    assert merit_names(d, image=["mtf50_worst_union"])[-1] == "mtf50_worst_union"
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    with pytest.raises(splitlf.InvalidParameter, match="objective.*psnr_worst_union"):
        splitlf.optimise(d, {"D": (15.0, 20.0)}, "psnr_best_union", depths=Z, maxiter=1)
    with pytest.raises(splitlf.InvalidParameter, match="image"):
        splitlf.optimise(d, {"D": (15.0, 20.0)}, "max_gap_worst_union", depths=Z,
                         maxiter=1, image=["psnr"])
    xr = pytest.importorskip("xarray")
    assert xr
    from splitlf.sweep import sweep

    with pytest.raises(splitlf.InvalidParameter, match="image"):
        sweep(d, {"D": [15.0]}, Z, progress=False, image=["psnr_worst"])


def test_sweep_image_merit_is_image_merits():
    """A sweep with an image merit reports what splitlf.image_merits gives directly for the
    same design: the least PSNR of channel 1 over 5 depths log-spaced over the depths'
    range (the same draws: the same numbers, bit for bit)."""
    xr = pytest.importorskip("xarray")
    assert xr
    from splitlf.study.merit import IMAGE_DEPTHS
    from splitlf.sweep import sweep

    d = _seed_cut()
    z = np.array([700.0, 900.0])
    ds = sweep(d, {"D": [d.D]}, z, progress=False, image=["psnr_worst_channel1"])
    direct = splitlf.image_merits(d, np.geomspace(700.0, 900.0, IMAGE_DEPTHS), 2000.0,
                                  rows=["channel 1"])
    want = float(np.min(direct.rows["channel 1"]["psnr"]))
    assert float(ds["psnr_worst_channel1"].sel(D=d.D)) == want
    assert ds.attrs["image_photons"] == 2000.0


def test_compare_table_image_columns_are_checked():
    """`compare.evaluate`'s image columns: a sequence of names, each an image merit of some
    design (one that no design has is an error naming the allowed ones), before any work."""
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    from splitlf.compare import evaluate as compare_designs

    d = _seed_cut()
    plain = d.replace(channels=d.channels[:1])
    with pytest.raises(splitlf.InvalidParameter, match="image.*psnr_worst_channel2"):
        compare_designs({"plain": plain, "split": d}, Z, image=["psnr_worst_channel3"])
    with pytest.raises(TypeError, match="image"):
        compare_designs({"split": d}, Z, image="psnr_worst_union")
    with pytest.raises(TypeError, match="image"):
        compare_designs({"split": d}, Z, image=[3])
    with pytest.raises(splitlf.InvalidParameter, match="photons"):
        compare_designs({"split": d}, Z, image=["psnr_worst_union"], photons=-1.0)
    with pytest.raises(splitlf.InvalidParameter, match="photons"):
        splitlf.compare.compare("seed", "psnr_worst_union", which=["plain"], photons=0.0)


def test_compare_table_lists_the_image_merits():
    """The comparison table's image columns are `splitlf.evaluate`'s merits of each design,
    bit for bit; a design without the row (a one-channel design's channel 2) gets NaN, and
    a one-channel design made of the split sensor's half 1 has half 1's merits."""
    pytest.importorskip("scipy")
    pytest.importorskip("pandas")
    from splitlf.compare import evaluate as compare_designs

    d = _seed_cut()
    plain = d.replace(channels=d.channels[:1])
    z = np.array([400.0, 450.0])
    names = ["psnr_worst_channel1", "mtf50_median_channel2"]
    table, _ = compare_designs({"split": d, "plain": plain}, z, window=2.0, image=names,
                               photons=2000.0)
    m = evaluate(d, z, image=names, photons=2000.0)
    for n in names:
        assert table.loc["split", n] == m[n], n
    assert table.loc["plain", "psnr_worst_channel1"] == m["psnr_worst_channel1"]
    assert np.isnan(table.loc["plain", "mtf50_median_channel2"])
    assert 5.0 < m["psnr_worst_channel1"] < 60.0 and 0.0 < m["mtf50_median_channel2"] < 1.0
