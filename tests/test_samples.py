"""Coincidence planes, genuinely new samples (Eqs. 8-9) and max gap, checked against the plain
NumPy transcription of docs/model.md §3, §5 and §6 in tests/reference.py (sort, then merge)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference as ref
import splitlf
from designs import SAMPLES as DESIGNS
from designs import seed
from splitlf import Camera


def special_depths(cam: Camera, max_n: int = 2) -> list[float]:
    zs = [cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)]
    for h in (1, 2):
        t = splitlf.coincidence_planes(cam, h, max_n=max_n)
        zs += list(t.z)
    return zs


# ---------------------------------------------------------------------------------------
# Coincidence planes


@pytest.mark.parametrize("name", DESIGNS)
@pytest.mark.parametrize("half", [1, 2])
def test_counted_equals_eqs_8_9_on_every_plane(name, half):
    cam = DESIGNS[name]()
    t = splitlf.coincidence_planes(cam, half, max_n=5)
    want = ref.coincidence_planes(cam, half, 5, cam.Q)
    got = {(int(n), int(tt), str(s)): zc for n, tt, s, zc in zip(t.N, t.T, t.side, t.conjugate,
                                                                 strict=True)}
    assert set(got) == set(want)
    assert {"far", "near"} <= set(t.side)
    for key, zc in want.items():
        assert got[key] == pytest.approx(zc, rel=1e-13)
    q_lit = ref.lit_w(cam, half).size
    assert q_lit == cam.lit_pixels(half)
    for i in range(len(t)):
        N, T = int(t.N[i]), int(t.T[i])
        nx, ny = ref.closed_form(cam.Kx, q_lit, N, T), ref.closed_form(cam.Ky, q_lit, N, T)
        assert (t.new_samples_x[i], t.new_samples_y[i]) == (nx, ny)
        assert t.new_samples[i] == nx * ny
        assert t.counted[i] == t.new_samples[i], (name, half, N, T, t.side[i])
        # The count itself, redone by the NumPy reference (sort and merge, x and y).
        eps = 1e-6 * cam.mu  # tol * delta(z) on plane v', delta = mu z / v' (§9)
        cx = ref.greedy_count(np.sort(ref.chief_p(cam, half, cam.Kx, t.conjugate[i]).ravel()), eps)
        cy = ref.greedy_count(np.sort(ref.chief_p(cam, half, cam.Ky, t.conjugate[i]).ravel()), eps)
        assert cx * cy == t.counted[i]
        # Depth, repetitions = D r / d (Eqs. 1, 4-5 on the plane).
        zc = t.conjugate[i]
        assert t.z[i] == pytest.approx(cam.F * zc / (zc - cam.F), rel=1e-13)
        r = N * cam.d * cam.v / (T * cam.mu * ref.array_plane(cam, half))
        assert t.repetitions[i] == pytest.approx(cam.D * r / cam.d, rel=1e-12)
    assert np.all(np.diff(t.z) > 0)  # sorted by depth, nearest first


def test_seed_planes_hit_the_vignetting_branch():
    # Half 2 of the seed lights 11 of 15 pixels: for T > 11 nothing overlaps (n = K Q_lit),
    # which Eq. 9 with Q = 15 would get wrong.
    cam = seed()
    t = splitlf.coincidence_planes(cam, 2, max_n=1)
    big = t.T > 11
    assert big.any()
    assert np.all(t.counted[big] == (cam.Kx * 11) * (cam.Ky * 11))
    eq9_with_q = (1 * 15 + t.T[big] * (cam.Kx - 1)) * (1 * 15 + t.T[big] * (cam.Ky - 1))
    assert np.all(t.counted[big] != eq9_with_q)


def test_f_number_matched_repetitions():
    # Half 1 of the seed is f-number matched: rep = Q N / T on its planes (docs/model.md §6).
    t = splitlf.coincidence_planes(seed(), 1, max_n=3)
    np.testing.assert_allclose(t.repetitions, 15 * t.N / t.T, rtol=1e-12)


def test_planes_table_api(monkeypatch):
    t = splitlf.coincidence_planes(seed(), 1, max_n=3, max_t=4)
    assert len(t) == len(t.z) == len(t.rows())
    assert list(t.columns()) == list(splitlf.sampling.samples.PLANE_COLUMNS)
    assert t.N.dtype == np.int64 and t.z.dtype == np.float64 and t.side.dtype.kind == "U"
    assert t.T.max() <= 4 and t.N.max() <= 3
    with pytest.raises(dataclasses_frozen()):
        t.z = None
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match="pip install pandas"):
        t.to_pandas()


def dataclasses_frozen():
    import dataclasses

    return dataclasses.FrozenInstanceError


def test_to_pandas_when_installed():
    pd = pytest.importorskip("pandas")
    t = splitlf.coincidence_planes(seed(), 2, max_n=2)
    df = t.to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) == len(t)
    assert list(df.columns) == list(splitlf.sampling.samples.PLANE_COLUMNS)


# ---------------------------------------------------------------------------------------
# new_samples


@pytest.mark.parametrize("name", DESIGNS)
def test_out_of_focus_plane_collapses_to_k(name):
    cam = DESIGNS[name]()
    for h in (1, 2):
        r = splitlf.new_samples(cam, [cam.out_of_focus_depth(h)])
        assert r.distinct[h - 1, 0] == cam.Kx


def test_pixelization_of_half_1_is_q():
    cam = seed()
    r = splitlf.new_samples(cam, [cam.out_of_focus_depth(1)])
    assert r.max_gap[0, 0] == pytest.approx(cam.Q, rel=1e-9)
    assert r.max_gap[2, 0] < 2  # the split sensor removes the pixelization band


@pytest.mark.parametrize("name", DESIGNS)
def test_union_bounds(name):
    cam = DESIGNS[name]()
    z = np.concatenate([np.geomspace(cam.F * 1.05, 2e4, 300), special_depths(cam, 3)])
    r = splitlf.new_samples(cam, z)
    assert np.all(r.distinct[2] >= np.maximum(r.distinct[0], r.distinct[1]))
    assert np.all(r.distinct[2] <= r.distinct[0] + r.distinct[1])
    assert np.all(r.max_gap[2] <= np.minimum(r.max_gap[0], r.max_gap[1]))
    assert np.all(r.distinct[:2] <= r.sampled[:2, None])


@pytest.mark.parametrize("name", DESIGNS)
def test_matches_numpy_reference(name):
    cam = DESIGNS[name]()
    rng = np.random.default_rng(4)
    z = np.concatenate([cam.F * (1 + rng.uniform(0.02, 3, 12)),
                        np.geomspace(150, 1e4, 12), special_depths(cam, 2)[:12]])
    r = splitlf.new_samples(cam, z)
    distinct, _, gap, lit = ref.new_samples(cam, z)
    np.testing.assert_array_equal(r.distinct, distinct)
    np.testing.assert_array_equal(r.sampled, lit)
    np.testing.assert_array_equal(np.isinf(r.max_gap), np.isinf(gap))
    np.testing.assert_allclose(r.max_gap, gap, rtol=1e-9)
    assert r.distinct.dtype == np.int64 and r.max_gap.shape == (3, z.size)


def test_tolerance_merges():
    cam = seed()
    # A huge tolerance merges everything closer than tol * delta: the count only drops.
    z = [300.0, 1000.0]
    fine = splitlf.new_samples(cam, z, tol=1e-9)
    coarse = splitlf.new_samples(cam, z, tol=0.5)
    assert np.all(coarse.distinct <= fine.distinct)
    assert np.any(coarse.distinct < fine.distinct)
    np.testing.assert_array_equal(coarse.distinct, ref.new_samples(cam, z, tol=0.5)[0])


def test_threads_agree_and_strided_input():
    cam = seed()
    z = np.geomspace(150, 1e4, 400)
    a = splitlf.new_samples(cam, z, n_threads=1)
    b = splitlf.new_samples(cam, z[::-1][::-1].copy(), n_threads=2)
    c = splitlf.new_samples(cam, np.repeat(z, 2)[::2])  # non-contiguous view
    for x in (b, c):
        np.testing.assert_array_equal(a.distinct, x.distinct)
        np.testing.assert_array_equal(a.max_gap, x.max_gap)


def test_empty_and_scalar_depths():
    r = splitlf.new_samples(seed(), [])
    assert r.distinct.shape == (3, 0) and r.max_gap.shape == (3, 0)
    assert splitlf.new_samples(seed(), 500.0).distinct.shape == (3, 1)


# ---------------------------------------------------------------------------------------
# Properties (hypothesis): random small designs and depths against the reference.


@st.composite
def small_cameras(draw):
    Q = draw(st.integers(1, 8))
    v1, v = draw(st.floats(52.0, 80.0)), draw(st.floats(0.2, 1.0))
    # D up to the widest aperture whose microlens images do not overlap (D v / v' within
    # half 1's image cell d (1 + v / v'), docs/model.md §9).
    return Camera(
        F=50.0,
        D=min(30.0, 0.1 * (v1 + v) / v) * draw(st.floats(0.15, 0.999)),
        v1=v1,
        kappa=draw(st.floats(0.0, 0.9)),
        d=0.1,
        v=v,
        mu=0.1 / Q * draw(st.floats(0.5, 1.0)),
        Q=Q,
        Kx=draw(st.integers(1, 12)),
        Ky=draw(st.integers(1, 6)),
    )


@settings(max_examples=60, deadline=None)
@given(cam=small_cameras(), t=st.floats(1.01, 100.0))
def test_property_matches_reference(cam, t):
    z = [cam.F * t, cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)]
    r = splitlf.new_samples(cam, z)
    distinct, _, gap, lit = ref.new_samples(cam, z)
    np.testing.assert_array_equal(r.distinct, distinct)
    np.testing.assert_array_equal(r.sampled, lit)
    np.testing.assert_allclose(r.max_gap, gap, rtol=1e-9)


def test_near_coincident_channels_merge_at_the_sensor_step():
    """Regression (a Hypothesis example): channels at L = 52 and 52.0000062 mm, one pixel
    per lens (w = 0), so half 2's sample j is (v'/L_2) c_j, |c_j| (1 - v'/L_2) = 5.37e-8,
    4.17e-8, ... mm from half 1's on plane v' for |c_j| = 0.45, 0.35, ... mm. The merge
    tolerance is tol * delta(z) with delta(z) = mu_1 z / L_1 for every design, a Camera too
    (docs/model.md §9): 1e-6 * mu = 5e-8 mm here, so the outermost pairs (|c_j| = 0.45 mm)
    stay apart and the union counts 10 + 2 = 12 at every depth. In §6's step d z / (Q v')
    (d = 2 Q mu here: 1e-7 mm) every pair would merge, 10: the reference once merged in
    that step while the core merged in mu_1 z / L_1."""
    cam = Camera(F=50.0, D=2.65, v1=52.0, kappa=0.0000062 / 52.0, d=0.1, v=1.0, mu=0.05,
                 Q=1, Kx=10, Ky=1)
    assert cam.v1 * (1 + cam.kappa) == pytest.approx(52.0000062, abs=1e-9)
    z = [cam.F * 2.0, cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)]
    r = splitlf.new_samples(cam, z)
    distinct, _, gap, lit = ref.new_samples(cam, z)
    np.testing.assert_array_equal(r.distinct, [[10] * 3, [10] * 3, [12] * 3])
    np.testing.assert_array_equal(r.distinct, distinct)
    np.testing.assert_array_equal(r.sampled, lit)
    np.testing.assert_allclose(r.max_gap, gap, rtol=1e-9)
    # In units of d z / (Q v') (tol twice as large here) all ten pairs merge.
    wide = splitlf.new_samples(cam, z, tol=1e-6 * cam.d / (cam.Q * cam.mu))
    np.testing.assert_array_equal(wide.distinct, [[10] * 3] * 3)
    np.testing.assert_array_equal(wide.distinct, ref.new_samples(cam, z, tol=2e-6)[0])


@settings(max_examples=40, deadline=None)
@given(cam=small_cameras(), half=st.sampled_from([1, 2]), max_n=st.integers(1, 5))
def test_property_counted_equals_closed_form(cam, half, max_n):
    t = splitlf.coincidence_planes(cam, half, max_n=max_n)
    assert np.array_equal(t.counted, t.new_samples)
    assert set(zip(t.N.tolist(), t.T.tolist(), t.side.tolist(), strict=True)) == set(
        ref.coincidence_planes(cam, half, max_n, cam.Q))


# ---------------------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize("tol", [-1e-6, -1.0, math.nan, math.inf])
def test_bad_tol(tol):
    with pytest.raises(ValueError, match="tol"):
        splitlf.new_samples(seed(), [500.0], tol=tol)


@pytest.mark.parametrize("sample", ["Centroid", "foo", ""])
def test_bad_sample_mode(sample):
    with pytest.raises(ValueError, match="sample"):
        splitlf.new_samples(seed(), [500.0], sample=sample)


def test_bad_arguments():
    cam = seed()
    with pytest.raises(TypeError, match="sample"):
        splitlf.new_samples(cam, [500.0], sample=1)
    with pytest.raises(ValueError, match="depth"):
        splitlf.new_samples(cam, [500.0, cam.F])
    with pytest.raises(ValueError, match="depth"):
        splitlf.new_samples(cam, [math.nan])
    with pytest.raises(ValueError, match="n_threads"):
        splitlf.new_samples(cam, [500.0], n_threads=0)
    for bad in (0, -1):
        with pytest.raises(ValueError, match="max_n"):
            splitlf.coincidence_planes(cam, 1, max_n=bad)
    with pytest.raises(ValueError, match="max_t"):
        splitlf.coincidence_planes(cam, 1, max_t=0)
    with pytest.raises(TypeError, match="max_n"):
        splitlf.coincidence_planes(cam, 1, max_n=2.5)
    for bad in (0, 3):
        with pytest.raises(ValueError, match="half"):
            splitlf.coincidence_planes(cam, bad)
    for bad in (True, "1", 1.0):
        with pytest.raises(TypeError, match="half"):
            splitlf.coincidence_planes(cam, bad)
    with pytest.raises(TypeError, match="design must be a splitlf.Design"):
        splitlf.new_samples(object(), [500.0])


# ---------------------------------------------------------------------------------------
# Depth sweep, report and figure


def test_sweep_depths_include_the_dips():
    cam = seed()
    z = splitlf.sampling.samples.sweep_depths(cam, (150.0, 1e4), n=50, max_n=2)
    assert np.all(np.diff(z) > 0) and z[0] == 150.0 and z[-1] == 1e4
    for h in (1, 2):
        assert np.any(z == cam.out_of_focus_depth(h))
        planes = splitlf.coincidence_planes(cam, h, max_n=2).z
        inside = planes[(planes >= 150) & (planes <= 1e4)]
        assert inside.size > 0 and np.isin(inside, z).all()
    for bad in ((50.0, 100.0), (500.0, 200.0), (150.0, math.inf)):
        with pytest.raises(ValueError, match="z_range"):
            splitlf.sampling.samples.sweep_depths(cam, bad)


def test_report_has_planes_and_worst_resolution():
    import json

    from splitlf.report import format_report, report_data

    cam = seed()
    data = report_data(cam)
    json.dumps(data, allow_nan=False)
    for h in (1, 2):
        rows = data["coincidence_planes"][f"channel {h}"]
        assert rows and all(r["N"] <= 3 for r in rows)
        assert all(r["counted"] == r["new_samples"] for r in rows)
        assert {r["side"] for r in rows} == {"near", "far"}
    res = data["resolution"]
    assert res["z_range_mm"] == [150.0, 10000.0]
    # Half 1's worst case is its out-of-focus plane: pixelization, a gap of Q steps.
    assert res["channel 1"]["max_gap"] == pytest.approx(15.0, rel=1e-9)
    assert res["channel 1"]["z_mm"] == pytest.approx(642.0, rel=1e-9)
    assert res["union"]["max_gap"] <= min(res["channel 1"]["max_gap"],
                                          res["channel 2"]["max_gap"])
    text = format_report(data, "t", full=True)
    assert "Coincidence planes (N <= 3" in text and "Worst resolution over 150" in text
    assert "half 1: 63 planes, counted == Eq. 8/9 on 63" in text
    assert "split sensor   max gap" in text
    short = format_report(data, "t")
    assert "Coincidence planes" not in short and "split sensor   max gap" in short


def test_cli_report_json_has_samples(capsys):
    import json

    from splitlf.cli import main

    assert main(["report", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "coincidence_planes" in doc and "resolution" in doc


def test_plot_samples():
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")  # the test selects the backend; the library never does
    import matplotlib.pyplot as plt

    import splitlf.plot

    cam = seed()
    a_count, a_gap = splitlf.plot.samples(cam, (150.0, 2000.0), n=80)
    assert len(a_count.get_lines()) >= 3 and len(a_gap.get_lines()) >= 3
    assert a_count.get_xscale() == "log"
    fig, axes = plt.subplots(2, 1)
    got = splitlf.plot.samples(cam, (150.0, 2000.0), ax=axes, n=20)
    assert got[0] is axes[0] and got[1] is axes[1]
    with pytest.raises(ValueError, match="pair of Axes"):
        splitlf.plot.samples(cam, (150.0, 2000.0), ax=[axes[0]])
    plt.close("all")


def test_plot_without_matplotlib(monkeypatch):
    import splitlf.plot

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r'pip install "splitlf\[plot\]"'):
        splitlf.plot.samples(seed(), (150.0, 1000.0))


# ---------------------------------------------------------------------------------------
# Centroid samples


@pytest.mark.parametrize("name", DESIGNS)
def test_centroid_samples_match_footprints(name):
    cam = DESIGNS[name]()
    z = [150.0, 217.0, 300.0, 642.0, 1000.0, 2224.0, 9000.0]
    r = splitlf.new_samples(cam, z, sample="centroid")
    for k, zk in enumerate(z):
        pos = [splitlf.footprints(cam, [zk], h, sample="centroid").position[0] for h in (1, 2)]
        counts, gaps, lit = ref.centroid_counts(cam, zk, pos, 1e-6)
        assert list(r.distinct[:, k]) == counts, zk
        np.testing.assert_allclose(r.max_gap[:, k], gaps, rtol=1e-9)
        assert list(r.sampled[:2]) == lit


def test_centroid_equals_chief_for_fully_lit_ng_pixels():
    """Half 1 of the seed design: every pixel fully lit, Ng's setting, so the centroid
    sample is the chief sample. Half 2 is vignetted: its microlens image (radius 5.41 px)
    ends inside pixels q = 7 +- 5, so the same 11 pixels yield samples, but the centroids
    of the two partially lit ones are not their chief samples and the gaps change."""
    cam = seed()
    z = np.geomspace(150.0, 10_000.0, 60)
    chief = splitlf.new_samples(cam, z, sample="chief")
    cen = splitlf.new_samples(cam, z, sample="centroid")
    np.testing.assert_array_equal(cen.distinct[0], chief.distinct[0])
    np.testing.assert_allclose(cen.max_gap[0], chief.max_gap[0], rtol=1e-9)
    assert cen.sampled[1] == chief.sampled[1] == cam.Kx * 11
    assert np.any(np.abs(cen.max_gap[1] / chief.max_gap[1] - 1.0) > 1e-3)
