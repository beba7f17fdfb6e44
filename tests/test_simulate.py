"""Super-resolution simulation: forward model against Monte-Carlo ray integration
and a NumPy reference, reconstruction with known depth, bad input, determinism."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import reference as ref
import splitlf
from splitlf import Camera, Image, RandomAlbedo, Sinusoid, simulate
from splitlf.inverse.simulate import forward, system_matrix

SEED = Camera.paper()


def contrast_at(x, rec, f):
    """Fitted amplitude of rec at frequency f over a sinusoid of amplitude 0.4."""
    w = 2 * np.pi * f
    basis = np.column_stack([np.ones_like(x), np.sin(w * x), np.cos(w * x)])
    coef = np.linalg.lstsq(basis, rec, rcond=None)[0]
    return float(np.hypot(coef[1], coef[2]) / 0.4)


# -- forward model against a brute-force Monte-Carlo ray integration ------------------------

def _sample_polygon(verts, n, rng):
    """n points uniform in a convex polygon (rejection from its bounding box)."""
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    out = []
    while sum(len(o) for o in out) < n:
        p = rng.uniform(lo, hi, size=(4 * n, 2))
        inside = np.ones(len(p), bool)
        for a, b in zip(verts, np.roll(verts, -1, axis=0), strict=True):
            cross = (b[0] - a[0]) * (p[:, 1] - a[1]) - (b[1] - a[1]) * (p[:, 0] - a[0])
            inside &= cross >= 0  # counter-clockwise
        out.append(p[inside])
    return np.concatenate(out)[:n]


@pytest.mark.parametrize("z", [300.0, 642.0, 2000.0])
@pytest.mark.parametrize("source", ["half1", "half2", "conventional1", "conventional2"])
def test_forward_matches_monte_carlo_rays(z, source):
    cam = SEED
    rng = np.random.default_rng(7)
    h = ref.resolution_step(cam, z) / 4
    n_cells = 6000 if source.startswith("conv") else 1200
    origin = -n_cells * h / 2
    tex = rng.uniform(0, 1, n_cells)
    values, pixels = forward(cam, z, source, origin, h, tex)
    assert values.shape == pixels.shape and values.size > 50
    n_rays = 40_000
    if source.startswith("half"):
        half = int(source[-1])
        tr = splitlf.trace(cam, half)
        transmission = 0.5
    else:
        half = int(source[-1])
        transmission = 1.0
    checked = 0
    for i in rng.choice(values.size, 12, replace=False):
        px = pixels[i]
        if source.startswith("half"):
            verts = tr.vertices[px, : tr.n_vertices[px]]
            area = tr.area[px]
            uw = _sample_polygon(verts, n_rays, rng)
            u, w = uw[:, 0], uw[:, 1]
        else:
            # No microlenses: rays through the aperture and pixel px (width mu) on plane L.
            Lh = ref.array_plane(cam, half)
            n_px = cam.Kx * cam.Q
            s = (px - (n_px - 1) / 2) * cam.mu
            w = rng.uniform(-cam.D / 2, cam.D / 2, n_rays)
            xl = rng.uniform(s - cam.mu / 2, s + cam.mu / 2, n_rays)
            a, b = Lh / cam.v1, 1 - Lh / cam.v1
            u = (xl - b * w) / a
            area = cam.D * cam.mu / a
        X = -(u + ref.sigma_of(cam, z)[0] * w) * z / cam.v1
        k = np.floor((X - origin) / h).astype(int)
        assert k.min() >= 0 and k.max() < n_cells
        t = tex[k]
        norm = transmission * area / (cam.D * cam.mu)
        mc = norm * t.mean()
        se = norm * t.std() / np.sqrt(n_rays)
        assert abs(values[i] - mc) <= 4 * se, (px, values[i], mc, se)
        checked += 1
    assert checked == 12


# -- the sparse matrix against a NumPy reference ------------------------------------------------

@pytest.mark.parametrize("z", [217.0, 642.0, 1500.0])
@pytest.mark.parametrize("half", [1, 2])
def test_system_matrix_matches_numpy_reference(z, half):
    cam = SEED.replace(Kx=40)  # a small design: 600 pixels per half
    delta = ref.resolution_step(cam, z)
    n = 900
    origin = -n * delta / 2
    edges = origin + np.arange(n + 1) * delta
    A, pixels = system_matrix(cam, z, f"half{half}", origin, delta, n)
    assert A.shape == (pixels.size, n) and pixels.size > 100
    fp = splitlf.footprints(cam, [z], half, kernel=True)
    dense = A.toarray()
    for r in range(0, pixels.size, 7):
        p = pixels[r]
        ok = np.isfinite(fp.kernel_breaks[0, p])
        b, v = fp.kernel_breaks[0, p][ok], fp.kernel_values[0, p][ok]
        # (v'/z) from dp' = (v'/z) dX, beam splitter 1/2, units of D mu.
        want = ref.cell_integrals(b, v, edges) * (cam.v1 / z) * 0.5 / (cam.D * cam.mu)
        np.testing.assert_allclose(dense[r], want, rtol=1e-9, atol=1e-12 * want.max())
    # Every pixel of the design whose footprint fits in the grid is a row.
    inside = (fp.lo[0] >= edges[0]) & (fp.hi[0] <= edges[-1])
    assert set(pixels) == set(np.flatnonzero(inside & np.isfinite(fp.lo[0])))


# -- reconstruction --------------------------------------------------------------------------------

def test_split_recovers_band_limited_texture_where_union_resolves():
    cam = SEED
    candidates = np.array([300.0, 400.0, 1000.0, 2000.0, 5000.0])
    gap = splitlf.new_samples(cam, candidates).max_gap[2]
    depths = candidates[gap <= 1.6]
    assert depths.size >= 3, gap
    rng = np.random.default_rng(3)
    for z in depths:
        nyq = 0.5 / ref.resolution_step(cam, z)
        f = rng.uniform(0.02, 0.3, 6) * nyq  # band-limited well below the sampling limit
        ph = rng.uniform(0, 2 * np.pi, 6)

        def texture(X, f=f, ph=ph):
            return 0.5 + 0.06 * np.sin(2 * np.pi * f[:, None] * X + ph[:, None]).sum(axis=0)

        r = simulate(cam, z, texture=texture, mtf=False)
        assert r.rmse["union"] < 0.01, (z, dict(r.rmse))
        assert r.truth.std() > 0.05


def test_half1_cannot_resolve_finer_than_microlens_pitch_on_its_out_of_focus_plane():
    cam = SEED
    z1 = cam.F * cam.v1 / (cam.v1 - cam.F)  # half 1's out-of-focus plane, 642 mm
    assert z1 == pytest.approx(642.0)
    pitch = cam.d * z1 / cam.v1  # microlens pitch on the object
    nyq = 0.5 / ref.resolution_step(cam, z1)
    # Half 2's pixels integrate a microlens strip of width d v'/L_2 in u at fixed w
    # (docs/model.md §4), so its transfer vanishes at multiples of L_2 / (d z) on the object: test
    # midway between those zeros, at periods finer than the pitch and below delta's Nyquist.
    L2 = cam.v1 * (1 + cam.kappa)
    for j in (1, 2, 3):
        f = (j + 0.5) * L2 / (cam.d * z1)
        k = f * pitch
        assert 1 < k and f < nyq
        r = simulate(cam, z1, texture=Sinusoid(f, phase=0.3), mtf=False)
        c1 = contrast_at(r.x, r.half1, f)
        cs = contrast_at(r.x, r.split, f)
        assert c1 < 0.2, (k, c1)
        assert cs > 0.7, (k, cs)
    # and the MTF search says the same: half 1 stops below the microlens frequency
    r = simulate(cam, z1)
    assert r.microlens_frequency == pytest.approx(1 / pitch)
    assert r.mtf50["channel 1"] < 1 / pitch < r.mtf50["union"]


def test_conventional_in_focus_and_result_fields():
    r = simulate(SEED, 642.0, mtf=True, n_frequencies=16)
    # In focus the conventional pixels are exactly the delta cells: exact recovery.
    assert r.rmse["conventional 1"] < 1e-6
    assert r.mtf50["conventional 1"] == pytest.approx(r.frequencies[-1])
    assert r.configs == r.rows == ("channel 1", "channel 2", "union", "conventional 1")
    assert set(r.rmse) == set(r.psnr) == set(r.mtf50) == set(r.configs)
    assert r.conventional_half == r.conventional_channel == 1
    assert r.conventional is r.reconstructions["conventional 1"]
    assert r.half1 is r.reconstructions["channel 1"] and r.half2 is r.reconstructions["channel 2"]
    assert r.x.shape == r.truth.shape == r.split.shape == (256,)
    assert r.delta == pytest.approx(SEED.d * 642.0 / (SEED.Q * SEED.v1))
    assert np.all(np.diff(r.frequencies) > 0) and r.frequencies[-1] < r.nyquist
    s = r.summary()
    assert s["rmse"]["union"] == r.rmse["union"]


def test_noise_units_and_determinism():
    noise = {"photons": 2000.0, "read_noise": 3.0}
    a = simulate(SEED, 900.0, noise=noise, seed=5, mtf=False)
    b = simulate(SEED, 900.0, noise=noise, seed=5, mtf=False)
    c = simulate(SEED, 900.0, noise=noise, seed=6, mtf=False)
    np.testing.assert_array_equal(a.split, b.split)
    np.testing.assert_array_equal(a.truth, b.truth)
    assert not np.array_equal(a.truth, c.truth)
    clean = simulate(SEED, 900.0, seed=5, mtf=False)
    np.testing.assert_array_equal(clean.truth, a.truth)
    assert a.rmse["union"] > clean.rmse["union"]
    # Shot noise in photons: a white texture on half 1 reads N/2 photo-electrons.
    x0 = -2.0
    values, _ = forward(SEED, 900.0, "half1", x0, 0.01, np.ones(400))
    assert np.median(values) == pytest.approx(0.5, rel=1e-9)


def test_textures():
    img = np.zeros((5, 40))
    img[2, ::2] = 1.0
    r = simulate(SEED, 1000.0, texture=Image(img, width=8.0), mtf=False)
    assert r.truth.max() <= 1.0 and r.truth.min() >= 0.0
    r = simulate(SEED, 1000.0, texture=splitlf.BarChart(1.0), mtf=False)
    assert set(np.round(r.truth[np.abs(r.x) < 1.0], 6)) <= {0.1, 0.9} | set(
        np.round(r.truth, 6))
    r = simulate(SEED, 1000.0, texture=RandomAlbedo(cell=0.5), mtf=False)
    assert np.unique(np.round(r.truth, 9)).size < r.truth.size


@pytest.mark.parametrize("kwargs, exc", [
    ({"z": 50.0}, ValueError),
    ({"z": float("nan")}, ValueError),
    ({"texture": "noise"}, ValueError),
    ({"texture": 3}, TypeError),
    ({"texture": Image(np.ones((2, 2)), 1.0), "noise": {"photon": 1}}, ValueError),
    ({"noise": {"photons": -1}}, ValueError),
    ({"noise": 5}, TypeError),
    ({"seed": 1.5}, TypeError),
    ({"window": 2}, ValueError),
    ({"conventional_half": 3}, ValueError),
    ({"texture": lambda X: -np.ones_like(X)}, ValueError),
    ({"texture": lambda X: np.full_like(X, np.nan)}, ValueError),
    ({"texture": lambda X: np.ones(3)}, ValueError),
    ({"n_threads": 0}, ValueError),
])
def test_bad_input(kwargs, exc):
    args = {"z": 700.0, "mtf": False} | kwargs
    with pytest.raises(exc):
        simulate(SEED, **args)


@pytest.mark.parametrize("array, exc", [
    (np.ones(4), ValueError),
    (np.array([[1.0, -1.0]]), ValueError),
    (np.array([[1.0, np.inf]]), ValueError),
    (np.array([["a"]]), TypeError),
])
def test_bad_image(array, exc):
    with pytest.raises(exc):
        Image(array, 1.0)


def test_bad_forward_input():
    with pytest.raises(ValueError):
        forward(SEED, 700.0, "half3", 0.0, 0.1, np.ones(10))
    with pytest.raises(ValueError):
        forward(SEED, 700.0, "half1", 0.0, 0.1, -np.ones(10))
    with pytest.raises(ValueError):
        forward(SEED, 700.0, "half1", 0.0, -0.1, np.ones(10))
    with pytest.raises(ValueError):
        forward(SEED, 700.0, "half1", 0.0, 0.1, np.ones((2, 2, 2)))
    with pytest.raises(ValueError):
        system_matrix(SEED, 700.0, "half1", 0.0, 0.1, 10, field=(1.0, 0.0))
    # strided input is accepted and equals the contiguous copy
    t = np.random.default_rng(0).uniform(0, 1, (2, 4000))
    a, _ = forward(SEED, 700.0, "half2", -20.0, 0.01, t[:, ::2])
    b, _ = forward(SEED, 700.0, "half2", -20.0, 0.01, np.ascontiguousarray(t[:, ::2]))
    np.testing.assert_array_equal(a, b)


def test_cli_simulate(capsys, tmp_path):
    import json

    from splitlf.cli import main

    assert main(["simulate", "--z", "642", "--json", "--threads", "1"]) == 0
    data = json.loads(capsys.readouterr().out)
    r = simulate(SEED, 642.0, n_threads=1)
    assert data["results"][0]["mtf50_cycles_per_mm"] == dict(r.mtf50)
    np.save(tmp_path / "img.npy", np.ones((3, 8)))
    assert main(["simulate", "--z-range", "300", "2000", "--n", "2",
                 "--texture", f"image:{tmp_path / 'img.npy'}:5"]) == 0
    assert "union" in capsys.readouterr().out
    for bad in (["--texture", "stripes"], ["--z", "10"], ["--texture", "sinusoid:-1"]):
        assert main(["simulate", *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("splitlf simulate: error:") and err.count("\n") == 1


def test_plot_resolution_returns_axes():

    from matplotlib.figure import Figure

    from splitlf.plot import resolution

    fig = Figure()
    axes = fig.subplots(2, 1)
    out = resolution(SEED, (300.0, 1000.0), ax=axes, n=2, n_frequencies=8, window=64)
    assert list(out) == list(axes)
    assert len(out[0].lines) >= 6
    with pytest.raises(ValueError):
        resolution(SEED, (1000.0, 300.0), ax=axes)


def test_seed_and_photons_have_named_errors():
    with pytest.raises(splitlf.InvalidParameter, match="invalid seed = -1") as e:
        simulate(SEED, 700.0, seed=-1, mtf=False)
    assert e.value.name == "seed"
    with pytest.raises(TypeError, match="seed"):
        simulate(SEED, 700.0, seed=True, mtf=False)
    with pytest.raises(splitlf.InvalidParameter, match="photons") as e:
        simulate(SEED, 700.0, noise={"photons": 1e300}, mtf=False)
    assert "1e+15" in str(e.value)
    with pytest.raises(splitlf.InvalidParameter, match="photons"):
        simulate(SEED, 700.0, noise={"photons": 10**400}, mtf=False)
    # a bright texture: the Poisson mean itself is checked, with the parameter's name
    bright = Image(np.full((2, 2), 1e6), 50.0)
    with pytest.raises(splitlf.InvalidParameter, match="photons.*brightest pixel"):
        simulate(SEED, 700.0, texture=bright, noise={"photons": 1e15}, window=16,
                 mtf=False)


def test_summary_is_json_ready_for_an_exact_reconstruction():
    import json

    r = simulate(SEED, 700.0, texture=Image(np.zeros((2, 2)), 10.0), window=16,
                 n_frequencies=4)
    assert r.psnr["union"] == float("inf")
    s = r.summary()
    assert s["psnr_db"]["union"] is None
    json.dumps(s, allow_nan=False)


def test_cli_simulate_exact_reconstruction_gives_valid_json(tmp_path, capsys):
    import json

    from splitlf.cli import main

    np.save(tmp_path / "zeros.npy", np.zeros((4, 4)))
    assert main(["simulate", "--texture", f"image:{tmp_path / 'zeros.npy'}:10",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["results"][0]["psnr_db"]["union"] is None
    assert doc["results"][0]["rmse"]["union"] == 0.0


@pytest.mark.parametrize("args, needle", [
    (["--n", "3"], "--n: only with --z-range"),
    (["--read-noise", "2"], "--read-noise: only with --photons"),
    (["--z-range", "900", "300"], "needs 0 < A < B"),
    (["--out", "x.txt"], ".json"),
])
def test_cli_simulate_options_never_ignored(tmp_path, monkeypatch, capsys, args, needle):
    from splitlf.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["simulate", *args]) == 2
    out = capsys.readouterr()
    assert out.out == "" and needle in out.err and out.err.count("\n") == 1


def test_cli_simulate_out(tmp_path, capsys):
    import json

    from splitlf.cli import main

    out = tmp_path / "sim.json"
    base = ["simulate", "--z", "700", "--threads", "1", "--out", str(out)]
    assert main([*base, "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    written = json.loads(out.read_text())
    assert printed["path"] == str(out) and printed["results"] == written["results"]
    assert main(base) == 2
    assert "--force" in capsys.readouterr().err
    assert json.loads(out.read_text()) == written
    assert main([*base, "--force", "--seed", "1"]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert json.loads(out.read_text())["results"] != written["results"]

# -- the seed's numbers, pinned before the camera path was folded into the design path ------

#: The simulation of the seed run in a fresh process with single-threaded BLAS. ``probe`` is
#: a LAPACK fingerprint: the simulation's own solve of a fixed banded system.
PIN_CODE = """
import json
import numpy as np
import scipy.sparse as sp
from splitlf import Camera, simulate, simulation

rng = np.random.default_rng(0)
n = 700
a = rng.uniform(0, 1, (900, n)) * (np.abs(np.subtract.outer(
    np.arange(900) * n / 900, np.arange(n))) < 30)
sol, _ = simulation._solve(sp.csr_matrix(a), rng.uniform(0, 1, (2, 900)), None, None)
out = {"probe": [float(sol.sum()), float((sol * np.arange(1, n + 1)).sum())], "runs": []}
for z in (642.0, 1000.0, 2000.0):
    for noise in (None, {"photons": 1e4, "read_noise": 3.0}):
        s = simulate(Camera.paper(), z, noise=noise, seed=5)
        rows = {}
        for k in s.configs:
            r = s.reconstructions[k]
            w = np.arange(1, r.size + 1)
            rows[k] = [s.rmse[k], s.psnr[k], s.mtf50[k], s.regularization[k], s.pixels[k],
                       float(r.sum()), float((r * r).sum()), float((w * r).sum())]
        out["runs"].append({"z": z, "noise": noise is not None, "delta": s.delta,
                            "nyquist": s.nyquist, "truth": float(s.truth.sum()),
                            "rows": rows})
print(json.dumps(out))
"""

#: Recorded with the Camera path of splitlf (``_native.render``/``system_matrix`` on the
#: CameraCore, commit 8b558a0) by PIN_CODE with its row names mapped (half1 -> channel 1,
#: half2 -> channel 2, split -> union, conventional -> conventional 1); the design path gave
#: the same bits. Re-recorded when the noise-free regularisation weight became a fixed floor
#: (docs/simulate.md; it had grown with the number of pixels, so that the union lost to
#: half 2 at 642 mm): the noise-free rows changed (union RMSE at 642 mm 0.158 -> 0.093,
#: half 2 0.130 -> 0.111), the noisy ones only by this machine's LAPACK (the probe).
#: Re-recorded on 2026-12-01 when the general route's pixel squares began to be built from
#: their edges (docs/render.md, "A memo of the corners": the data move by ~1e-15), on a
#: machine whose LAPACK fingerprint differs from the old record's in its last digits: the
#: noise-free conventional rows (an ill-conditioned solve) moved by up to 1.6e-5 relative,
#: the other noise-free rows by up to 1.5e-7, the noisy ones by up to 4e-11; delta, truth
#: and pixel counts not at all.
#: Per row: RMSE, PSNR, MTF50, lambda, pixels, then the reconstruction's sum, sum of
#: squares and sum weighted by 1..W.
SEED_PINS = {
    "probe": (23.21975132340014, 8019.731997423737),
    "runs": {
        (642.0, False): {
            "delta": 0.06322499999999999, "nyquist": 7.908264136022145,
            "truth": 123.06438872693033,
            "channel 1": (0.2828787660400381, 10.96799302242209, 0.5317349148135833,
                1.5625000000000052e-10, 390, 121.9832259204419,
                59.435236964381644, 15406.919851140356),
            "channel 2": (0.11095141965318497, 19.09734272963991, 1.4803069464191674,
                1.5625000000000329e-10, 334, 123.02645897101607,
                77.51735087839592, 15427.269716864255),
            "union": (0.0928263077894316, 20.64657846945698, 6.080693728400529,
                1.5625000000000329e-10, 724, 123.08589394475376,
                78.35035465389154, 15438.627090639977),
            "conventional 1": (4.61334066808925e-10, 186.719689482261, 7.74350863318835,
                6.250000000000019e-10, 262, 123.0643887268367,
                81.04699359173506, 15420.996214716732),
        },
        (642.0, True): {
            "delta": 0.06322499999999999, "nyquist": 7.908264136022145,
            "truth": 123.06438872693033,
            "channel 1": (0.2828419625623073, 10.96912315936124, 0.5311982818084073,
                0.00015291580707703638, 390, 122.06902063515511,
                59.50712178282674, 15400.031491771828),
            "channel 2": (0.2775333021780739, 11.133697938436304, 1.1680697896864545,
                0.00014975641420962742, 334, 122.93284056550067,
                64.19506637547524, 15457.24294902806),
            "union": (0.26895154566612595, 11.406519109640081, 1.25012979485983,
                0.00015145829710781734, 724, 123.01994788152109,
                64.8841630563189, 15478.07610919152),
            "conventional 1": (0.00684549299782037, 43.29190538880858, 7.74350863318835,
                0.0003015240109512511, 262, 123.11155623015816,
                81.1029969233405, 15414.28569990507),
        },
        (1000.0, False): {
            "delta": 0.09848130841121494, "nyquist": 5.077105575326216,
            "truth": 120.9702436088154,
            "channel 1": (0.22904409224038463, 12.801618110981254, 1.3605533723848309,
                1.5625000000000068e-10, 398, 121.5670673395356,
                66.84381576466488, 15634.536301993652),
            "channel 2": (0.12868578055796903, 17.80938877696765, 2.845548717325956,
                1.5625000000000287e-10, 346, 120.98386518007223,
                73.26026620313108, 15555.179128457656),
            "union": (0.0536871734371603, 25.40258920997281, 4.620553448086444,
                1.5625000000000287e-10, 744, 120.9132992612133,
                76.73545454454671, 15546.814773464626),
            "conventional 1": (0.1451813363940865, 16.761784204679195, 0.5071850242576554,
                6.250000000000002e-10, 374, 121.17024564099017,
                73.60635516491155, 15663.569868968294),
        },
        (1000.0, True): {
            "delta": 0.09848130841121494, "nyquist": 5.077105575326216,
            "truth": 120.9702436088154,
            "channel 1": (0.28184878391957024, 10.999676693417255, 0.728980554392095,
                0.00015209292903678307, 398, 121.55095288995238,
                66.04341780124136, 15586.05327365742),
            "channel 2": (0.29062622198893084, 10.733304073896008, 0.678516053267118,
                0.0001482015473562796, 346, 121.92297210785233,
                65.00578137427468, 15630.574012285218),
            "union": (0.28468893545616564, 10.912588230907765, 0.9962346837780602,
                0.0001502832273412801, 744, 121.50448666337115,
                66.25343904891912, 15556.033800572875),
            "conventional 1": (0.2764785314404394, 11.166771720381607, 0.5051107126105538,
                0.00030233127833159944, 374, 122.54566296382663,
                65.67322682588653, 15635.657099947526),
        },
        (2000.0, False): {
            "delta": 0.19696261682242988, "nyquist": 2.538552787663108,
            "truth": 122.59853091718091,
            "channel 1": (0.13113465939366814, 17.645650148800975, 1.0277331926115472,
                1.5625000000000068e-10, 404, 122.55657377374408,
                76.7829242505232, 15815.285693749072),
            "channel 2": (0.1372994005905828, 17.246627175260606, 1.8599590759666123,
                1.5625000000000313e-10, 354, 122.71700939805152,
                75.09859843933296, 15834.971915106406),
            "union": (0.032775430150288304, 29.689031996924932, 2.4463200806309393,
                1.5625000000000313e-10, 758, 122.59873463275363,
                80.25770536279562, 15815.80320285549),
            "conventional 1": (0.1485564302787655, 16.562170899536284, 0.18397289078992546,
                6.250000000000002e-10, 474, 122.45520431764652,
                76.18287645283846, 15807.488067138536),
        },
        (2000.0, True): {
            "delta": 0.19696261682242988, "nyquist": 2.538552787663108,
            "truth": 122.59853091718091,
            "channel 1": (0.2878112231251833, 10.817845497334858, 0.3051673484308411,
                0.00014895238078071346, 404, 123.44042636104871,
                63.8233238007842, 16011.777143327019),
            "channel 2": (0.297040118493071, 10.54369781072571, 0.37778424407936145,
                0.00014718578286033473, 354, 123.56786597301885,
                65.89834137492531, 15817.910348909281),
            "union": (0.2906352033962954, 10.733035652460277, 0.5903332476368678,
                0.00014812734692343896, 758, 123.32639045029539,
                66.13592267495963, 15914.15540386812),
            "conventional 1": (0.29856395629437876, 10.499252460505117, 0.18333981252201403,
                0.0002993748108243062, 474, 120.40184846553211,
                64.92530954136572, 15412.103697540279),
        },
    },
}


def test_seed_simulation_numbers_are_pinned():
    """simulate(Camera.paper(), z) at 642 mm, 1 m and 2 m, noise-free and with noise and
    a seed, gives the camera path's numbers to 1e-12 relative. The noise-free solve is
    ill-conditioned (lambda a tiny fixed floor): a LAPACK build or thread count other than the
    recording's moves its rows by up to 4e-6 relative (measured between 1 and 2 OpenBLAS
    threads), and the noise-free conventional rows, the worst conditioned, by 1.6e-5
    (measured between the two LAPACK fingerprints seen: the record's and one whose probe
    differs in its last digit). So BLAS runs single-threaded, and where the fingerprint
    differs from the recording's the solve's outputs are held to 1e-5, the noise-free
    conventional rows' to 1e-4; everything before the solve (delta, truth, pixel counts) is
    always held to 1e-12."""
    env = os.environ | {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
                        "MKL_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-c", PIN_CODE], env=env, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    got = json.loads(r.stdout)
    rel = 1e-12 if tuple(got["probe"]) == SEED_PINS["probe"] else 1e-5
    runs = {(g["z"], g["noise"]): g for g in got["runs"]}
    assert runs.keys() == SEED_PINS["runs"].keys()
    for key, want in SEED_PINS["runs"].items():
        g = runs[key]
        for name in ("delta", "nyquist", "truth"):
            assert g[name] == pytest.approx(want[name], rel=1e-12, abs=0), (key, name)
        rows = [k for k in want if k.startswith(("channel", "union", "conventional"))]
        assert list(g["rows"]) == rows, key
        for row in rows:
            ill = not key[1] and row.startswith("conventional") and rel > 1e-12
            for i, (a, b) in enumerate(zip(g["rows"][row], want[row], strict=True)):
                tol = 1e-12 if i == 4 else (1e-4 if ill else rel)
                assert a == pytest.approx(b, rel=tol, abs=0), (key, row, i, a, b)


@pytest.mark.parametrize("z", [642.0, 1000.0, 2000.0])
def test_more_data_never_hurts(z):
    """Noise-free, the union of both halves reconstructs at least as well as either half
    alone (the regularisation weight does not grow with the number of pixels), and at
    642 mm keeps at least 0.9 of half 2's contrast at 4 cycles per microlens pitch (before
    the fix: 0.54 against 0.90)."""
    d = splitlf.Design.preset("seed")
    s = splitlf.simulate(d, z, conventional=False)
    assert s.rmse["union"] <= min(s.rmse["channel 1"], s.rmse["channel 2"]), s.rmse
    if z == 642.0:
        f4 = 4.0 / (d.channels[0].d * z / d.resolved()[0]["L"])
        i = int(np.argmin(np.abs(np.asarray(s.frequencies) - f4)))
        assert s.contrast["union"][i] >= 0.9 * s.contrast["channel 2"][i], s.contrast
