"""The 1-D engine on designs (docs/model.md §3-§6 per channel, §9; docs/architectures.md,
"The 1-D engine"): trace, footprints, new_samples, coincidence_planes and sharp_fractions
take a Design and its channel. A Camera's results through ``Camera.design`` are its own,
bit for bit; a design with several channels, lens types, a sensor layout and a circular
aperture is checked against the NumPy transcriptions of tests/reference.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

import designs
import reference as ref
import splitlf
from splitlf import Camera, Channel, Design, InvalidParameter

#: Three channels: f-number matched (the image one lens pitch wide, wider than its Q
#: pixels), a sensor layout with three lens types, an ideal layout with two lens types whose
#: image exactly fills its Q pixels. Circular aperture; shares sum to 1.
MIX = Design(F=50.0, D=10.0, aperture="circle", channels=(
    Channel(L=60.0, d=0.1, v=0.6, mu=0.01, Kx=21, Ky=5, Q=9, share=0.3),
    Channel(L=66.0, d=0.12, v=0.5, mu=0.008, Kx=17, Ky=4, layout="sensor",
            f=(0.45, 0.5, 0.55), share=0.3),
    Channel(L=75.0, d=0.1, v=0.6, mu=0.01, Kx=15, Ky=3, Q=8, f=(0.5, 0.62), share=0.4),
))

#: Square aperture, ideal layouts, lens types: where docs/model.md §6 holds per channel.
IDEAL = Design(F=50.0, D=10.0, aperture="square", channels=(
    Channel(L=60.0, d=0.1, v=0.6, mu=0.01, Kx=23, Ky=7, Q=10, f=(0.5, 0.55), share=0.5),
    Channel(L=72.0, d=0.1, v=0.6, mu=0.01, Kx=19, Ky=6, Q=10, share=0.5),
))

CAMERAS = {"seed": designs.seed, "non_ng": designs.non_ng, "vignetted": designs.vignetted,
           "off_ng": designs.off_ng}
Z = np.geomspace(120.0, 20_000.0, 40)


def same(a, b) -> bool:
    """Equal bit for bit (NaN where NaN)."""
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f":
        return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))
    return np.array_equal(a, b)


# -- a Camera through its design: bit for bit -----------------------------------------------
@pytest.mark.parametrize("name", CAMERAS)
def test_camera_design_trace_and_footprints_bit_for_bit(name):
    cam = CAMERAS[name]()
    d = cam.design
    z = np.concatenate([Z, [cam.out_of_focus_depth(1), cam.out_of_focus_depth(2)]])
    z = z[z > cam.F]
    for h in (1, 2):
        for axis in ("x", "y"):
            a, b = splitlf.trace(cam, h, axis), splitlf.trace(d, channel=h, axis=axis)
            for col in ("vertices", "n_vertices", "area", "centroid", "lens", "pixel",
                        "chief", "lit", "theta", "type"):
                assert same(getattr(a, col), getattr(b, col)), (h, axis, col)
        for sample in ("centroid", "chief"):
            a = splitlf.footprints(cam, z, h, sample=sample, kernel=True)
            b = splitlf.footprints(d, z, channel=h, sample=sample, kernel=True)
            for col in ("position", "lo", "hi", "kernel_breaks", "kernel_values"):
                assert same(getattr(a, col), getattr(b, col)), (h, sample, col)
            # positional channel works too
            assert same(splitlf.footprints(d, z[:3], h, sample=sample).position,
                        a.position[:3])


@pytest.mark.parametrize("name", CAMERAS)
def test_camera_design_counts_and_planes(name):
    cam = CAMERAS[name]()
    d = cam.design
    for h in (1, 2):
        a = splitlf.coincidence_planes(cam, h, max_n=3)
        b = splitlf.coincidence_planes(d, channel=h, max_n=3)
        assert len(a) == len(b) > 0
        for col in ("N", "T", "side", "conjugate", "z", "repetitions", "new_samples_x",
                    "new_samples_y", "new_samples", "counted"):
            assert same(getattr(a, col), getattr(b, col)), (h, col)
    z = Z[Z > cam.F]
    for sample in ("chief", "centroid"):
        a = splitlf.new_samples(cam, z, sample=sample)
        b = splitlf.new_samples(d, z, sample=sample)
        assert a.rows == b.rows == ("channel 1", "channel 2", "union")
        for col in ("distinct", "sampled", "max_gap"):  # delta(z) = mu_1 z / L_1 (model §9)
            assert same(getattr(a, col), getattr(b, col)), (sample, col)


def test_camera_design_sharp_fractions():
    cam = Camera.paper()
    a = splitlf.sharp_fractions(cam, (150.0, 10_000.0))
    b = splitlf.sharp_fractions(cam.design, (150.0, 10_000.0))
    assert list(a) == list(b) == ["channel 1", "channel 2", "union", "conventional channel 1",
                                  "conventional channel 2"]
    assert a == b


# -- a general design against the NumPy reference -----------------------------------------
@pytest.mark.parametrize("channel", [1, 2, 3])
def test_pixels_types_and_lit_against_reference(channel):
    tr = splitlf.trace(MIX, channel=channel)
    want = ref.line_pixels(MIX, channel)
    assert np.array_equal(tr.lens, want["j"])
    assert np.array_equal(tr.type, want["type"])
    assert same(tr.theta, want["theta"])
    assert np.array_equal(tr.lit, want["lit"])
    assert same(tr.chief[:, 1], want["w"])
    assert tr.channel == channel and tr.half == channel


@pytest.mark.parametrize("channel", [1, 2, 3])
def test_polygons_against_exact_rationals(channel):
    tr = splitlf.trace(MIX, channel=channel)
    px = ref.line_pixels(MIX, channel)
    scale = float(tr.area.max())
    worst = 0.0
    for i in range(tr.area.size):
        strips = ref.line_strips(MIX, channel, float(px["c"][i]), float(px["theta"][i]),
                                 int(px["type"][i]))
        exact = ref.exact_strip_region(strips)
        if exact is None or exact[0] < 1e-9 * scale:  # docs/model.md §9, "Lit by area"
            assert tr.area[i] == 0.0 and tr.n_vertices[i] == 0
            continue
        area, cu, cw = exact
        worst = max(worst, abs(tr.area[i] - area) / scale)
        assert abs(tr.area[i] - area) <= 1e-12 * scale, (i, tr.area[i], area)
        assert abs(tr.centroid[i, 1] - cw) <= 1e-12 * MIX.D
        assert abs(tr.centroid[i, 0] - cu) <= 1e-12 * (abs(cu) + MIX.D)
    assert worst < 1e-12


@pytest.mark.parametrize("design", [MIX, IDEAL])
def test_light_is_conserved_per_channel(design):
    """docs/model.md §8 per channel: the polygon areas under one lens sum to at most
    D d L_1 / L (every ray through the aperture and the lens, in ray space referred to
    L_1), with equality when the light behind the lens falls on its own pixels; the
    channel receives `share` of it. The light behind a lens of focal length f spans
    s' = alpha x - (v/L) w + (v/f) c over the lens and the aperture: a segment of width
    |alpha| d + D v / L centred on the lens's image centre (D v / L in Ng's setting)."""
    chs = design.resolved()
    L1 = chs[0]["L"]
    checked = {True: 0, False: 0}
    for c, ch in enumerate(chs, start=1):
        tr = splitlf.trace(design, channel=c)
        L, v, d, mu = ch["L"], ch["v"], ch["d"], ch["mu"]
        full = design.D * d * L1 / L
        alpha = np.array([1 + v / L - v / f for f in ch["f"]])
        spot = np.abs(alpha) * d + design.D * v / L  # per lens type
        if ch["layout"] == "ideal":
            fits = spot <= ch["Q"] * mu
        else:  # a neighbour's pixel reaches at most mu/2 into the lens's cell
            fits = spot / 2 <= d * (1 + v / L) / 2 - mu / 2
        sums = np.bincount(tr.lens, weights=tr.area, minlength=ch["Kx"])
        light = sums * ch["share"]
        assert np.all(sums <= full * (1 + 1e-12))
        lens_fits = fits[np.arange(ch["Kx"]) % len(ch["f"])]
        np.testing.assert_allclose(light[lens_fits], full * ch["share"], rtol=1e-12)
        assert np.all(light[~lens_fits] < full * ch["share"])
        checked[True] += int(lens_fits.sum())
        checked[False] += int((~lens_fits).sum())
    assert checked[True] > 0 and checked[False] > 0
    assert sum(ch["share"] for ch in chs) <= 1.0 + 1e-12


def test_shares_above_one_are_refused():
    with pytest.raises(InvalidParameter) as e:
        MIX.replace(channels=(*MIX.channels[:2], MIX.channels[2].replace(share=0.5)))
    assert e.value.name == "share"


def test_chief_samples_and_counts_against_reference():
    z = np.concatenate([Z, [MIX.out_of_focus_depth(c) for c in (1, 2, 3)]])
    fp = [splitlf.footprints(MIX, z, channel=c, sample="chief") for c in (1, 2, 3)]
    worst = 0.0
    for c, f in enumerate(fp, start=1):
        lit = ref.line_pixels(MIX, c)["lit"]
        assert np.array_equal(np.isfinite(f.position), np.broadcast_to(lit, f.position.shape))
        for k, zk in enumerate(z):
            want = ref.line_chief_X(MIX, c, zk)
            got = f.position[k][lit]
            err = np.max(np.abs(got - want) / np.maximum(np.abs(want), 1e-300 + zk * 1e-6))
            worst = max(worst, err)
    assert worst < 1e-12
    r = splitlf.new_samples(MIX, z)
    distinct, gap, sampled = ref.design_new_samples(MIX, z)
    assert r.rows == ("channel 1", "channel 2", "channel 3", "union")
    assert np.array_equal(r.distinct, distinct)
    assert np.array_equal(r.sampled, sampled)
    assert np.array_equal(np.isfinite(r.max_gap), np.isfinite(gap))
    fin = np.isfinite(gap)
    np.testing.assert_allclose(r.max_gap[fin], gap[fin], rtol=1e-12)
    # the union: at least each channel, at most their sum; gaps only shrink
    assert np.all(r.distinct[-1] >= r.distinct[:-1].max(axis=0))
    assert np.all(r.distinct[-1] <= r.distinct[:-1].sum(axis=0))
    assert np.all(r.max_gap[-1] <= r.max_gap[:-1].min(axis=0))
    assert r["union"]["distinct"] is not None and r["channel 2"]["max_gap"].shape == z.shape


def test_centroid_counts_against_footprints():
    z = Z[::4]
    r = splitlf.new_samples(MIX, z, tol=1e-6, sample="centroid")
    ch1 = MIX.resolved()[0]
    pos = [splitlf.footprints(MIX, z, channel=c, sample="centroid").position
           for c in (1, 2, 3)]
    for k, zk in enumerate(z):
        delta = ch1["mu"] * zk / ch1["L"]
        W = ch1["Kx"] * ch1["d"] * zk / (4 * ch1["L"])
        xs = [np.sort(p[k][np.isfinite(p[k])]) for p in pos]
        xs.append(np.sort(np.concatenate(xs)))
        assert list(r.distinct[:, k]) == [ref.greedy_count(x, 1e-6 * delta) for x in xs]
        gaps = [ref.field_gap(x, W) / delta for x in xs]
        np.testing.assert_allclose(r.max_gap[:, k], gaps, rtol=1e-12)
    assert list(r.sampled[:3]) == [int(np.isfinite(p[0]).sum()) for p in pos]


def test_sensor_channel_out_of_focus_plane_collapses_to_lenses():
    """On a channel's out-of-focus plane every lit pixel of a lens samples its centre."""
    for c in (1, 2, 3):
        z = MIX.out_of_focus_depth(c)
        r = splitlf.new_samples(MIX, [z])
        lenses = np.unique(splitlf.trace(MIX, channel=c).lens[ref.line_pixels(MIX, c)["lit"]])
        assert r.distinct[c - 1, 0] == lenses.size


@pytest.mark.parametrize("channel", [1, 2])
def test_design_coincidence_planes_equal_eqs_8_9(channel):
    p = splitlf.coincidence_planes(IDEAL, channel=channel, max_n=4)
    assert len(p) > 10 and {"near", "far"} <= set(p.side)
    assert np.array_equal(p.counted, p.new_samples)
    ch = IDEAL.resolved()[channel - 1]
    L, q = ch["L"], ch["Q"]
    w = -(L / ch["v"]) * ch["mu"] * (np.arange(q) - (q - 1) / 2)
    q_lit = int(np.count_nonzero(np.abs(w) < IDEAL.D / 2))
    for k in range(len(p)):
        n, t = int(p.N[k]), int(p.T[k])
        r = n * ch["d"] * ch["v"] / (t * ch["mu"] * L)
        zc = L / (1 + r) if p.side[k] == "far" else L / (1 - r)
        assert p.conjugate[k] == pytest.approx(zc, rel=1e-14)
        assert p.z[k] == pytest.approx(IDEAL.F * zc / (zc - IDEAL.F), rel=1e-14)
        want = (ref.closed_form(ch["Kx"], q_lit, n, t) * ref.closed_form(ch["Ky"], q_lit, n, t))
        assert p.new_samples[k] == want


# -- the 2-D grid of a rect channel -----------------------------------------------------------
@pytest.mark.parametrize("name", ["seed", "vignetted"])
def test_camera_design_sample_grid_bit_for_bit(name):
    cam = CAMERAS[name]().replace(Kx=30, Ky=12)
    for h in (1, 2):
        for sample in ("chief", "centroid"):
            a = splitlf.sample_grid(cam, 400.0, h, sample)
            b = splitlf.sample_grid(cam.design, 400.0, channel=h, sample=sample)
            assert same(a.X, b.X) and same(a.Y, b.Y)


@pytest.mark.parametrize("channel", [1, 2, 3])
def test_sample_grid_of_a_design_is_its_chief_samples(channel):
    """Per-axis lines combined under the circular aperture: the lit pixels and samples of
    the 2-D chief samples (docs/model.md §9), up to the order of operations."""
    for z in (150.0, 700.0, 5_000.0):
        g = splitlf.sample_grid(MIX, z, channel=channel)
        c = splitlf.chief_samples(MIX, channel, z)
        assert np.array_equal(np.isfinite(g.X), c.lit)
        assert np.array_equal(np.isfinite(g.Y), c.lit)
        np.testing.assert_allclose(g.X[c.lit], c.X[c.lit], rtol=1e-12, atol=1e-12 * z)
        np.testing.assert_allclose(g.Y[c.lit], c.Y[c.lit], rtol=1e-12, atol=1e-12 * z)
    with pytest.raises(InvalidParameter) as e:
        splitlf.sample_grid(MIX, 500.0, channel=channel, sample="centroid")
    assert e.value.name == "aperture"


def test_centroid_sample_grid_of_a_design_is_the_product_of_its_footprints():
    z = 900.0
    g = splitlf.sample_grid(IDEAL, z, channel=1, sample="centroid")
    fx = splitlf.footprints(IDEAL, [z], channel=1, axis="x").position[0]
    fy = splitlf.footprints(IDEAL, [z], channel=1, axis="y").position[0]
    lit = np.isfinite(fy)[:, None] & np.isfinite(fx)[None, :]
    assert np.array_equal(np.isfinite(g.X), lit)
    assert same(g.X[lit], np.broadcast_to(fx, g.X.shape)[lit])
    assert same(g.Y[lit], np.broadcast_to(fy[:, None], g.Y.shape)[lit])


# -- refusals ---------------------------------------------------------------------------------
def test_hex_channels_are_refused_by_the_1d_engine():
    raytrix = Design.preset("raytrix-r12")
    calls = [
        lambda: splitlf.trace(raytrix, channel=1),
        lambda: splitlf.footprints(raytrix, [500.0], channel=1),
        lambda: splitlf.new_samples(raytrix, [500.0]),
        lambda: splitlf.coincidence_planes(raytrix, channel=1),
    ]
    for call in calls:
        with pytest.raises(InvalidParameter) as e:
            call()
        assert e.value.name == "channels[1].grid"
        assert "rect" in str(e.value.allowed)
    mixed = MIX.replace(channels=(*MIX.channels[:2], Channel(
        L=75.0, d=0.1, v=0.6, mu=0.01, Kx=15, Ky=3, grid="hex", layout="sensor",
        share=0.4)))
    with pytest.raises(InvalidParameter) as e:
        splitlf.new_samples(mixed, [500.0])
    assert e.value.name == "channels[3].grid"
    assert splitlf.trace(mixed, channel=2).area.size > 0  # rect channels still work


def test_coincidence_planes_refuse_where_model_6_does_not_hold():
    with pytest.raises(InvalidParameter) as e:
        splitlf.coincidence_planes(IDEAL.replace(channels=(IDEAL.channels[0], Channel(
            L=72.0, d=0.1, v=0.6, mu=0.01, Kx=19, Ky=6, layout="sensor", share=0.5))),
            channel=2)
    assert e.value.name == "channels[2].layout" and "ideal" in str(e.value.allowed)
    with pytest.raises(InvalidParameter) as e:
        splitlf.coincidence_planes(MIX, channel=1)
    assert e.value.name == "aperture" and "square" in str(e.value.allowed)


def test_bad_channel_arguments():
    with pytest.raises(InvalidParameter) as e:
        splitlf.trace(MIX, channel=4)
    assert e.value.name == "channel" and "[1, 3]" in str(e.value.allowed)
    with pytest.raises(InvalidParameter):
        splitlf.new_samples(MIX, [40.0])  # z <= F
    with pytest.raises(InvalidParameter) as e:
        splitlf.footprints(MIX, [500.0], channel=0)
    assert e.value.name == "channel"
    with pytest.raises(TypeError):
        splitlf.trace(MIX, channel=True)
    with pytest.raises(TypeError):
        splitlf.trace(MIX, 1, channel=1)
    with pytest.raises(TypeError):
        splitlf.coincidence_planes(IDEAL)
    with pytest.raises(TypeError):
        splitlf.new_samples("seed", [500.0])
    with pytest.raises(InvalidParameter) as e:
        splitlf.coincidence_planes(IDEAL, channel=1, max_n=0)
    assert e.value.name == "max_n"


# -- sweeps and fractions ------------------------------------------------------------------
def test_sweep_and_worst_resolution_of_a_design():
    z = splitlf.sampling.samples.sweep_depths(IDEAL, (100.0, 5_000.0), n=50)
    for c in (1, 2):
        assert np.any(np.isclose(z, IDEAL.out_of_focus_depth(c), rtol=0, atol=0))
    planes = splitlf.coincidence_planes(IDEAL, channel=1, max_n=3).z
    inside = planes[(planes >= 100.0) & (planes <= 5_000.0)]
    assert np.all(np.isin(inside, z))
    w = splitlf.sampling.samples.worst_resolution(MIX, (100.0, 5_000.0), n=60)
    assert [k for k in w if k.startswith(("channel", "union"))] == [
        "channel 1", "channel 2", "channel 3", "union"]
    assert w["union"]["max_gap"] <= min(w[f"channel {c}"]["max_gap"] for c in (1, 2, 3))


def test_sharp_fractions_of_a_design_follow_depth_of_field_rows():
    f = splitlf.sharp_fractions(MIX, (60.0, 10_000.0))
    dof = splitlf.depth_of_field(MIX)
    assert list(f) == [*dof.rows, "conventional channel 1", "conventional channel 2",
                       "conventional channel 3"]
    for row, iv in zip(dof.rows, dof.intervals, strict=True):
        covered = sum(math.log(min(b, 1e4) / max(a, 60.0)) for a, b in iv
                      if min(b, 1e4) > max(a, 60.0))
        assert f[row] == pytest.approx(covered / math.log(1e4 / 60.0), rel=1e-12, abs=1e-15)
