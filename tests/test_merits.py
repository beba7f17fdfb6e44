"""Image merits (docs/merits.md): the core's Monte-Carlo estimate of the reconstruction's
expected error against its closed form with dense NumPy matrices on a tiny patch, the
edge's mean response against the dense estimator's, the ensemble's fit, and the checks."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
import scipy.linalg

import splitlf
from splitlf import _native
from splitlf.errors import InvalidParameter
from splitlf.inverse.merits import Ensemble, image_merits
from splitlf.inverse.reconstruct import NOISE_FLOOR

Z = 1000.0
PHOTONS = 2000.0
ENSEMBLE = Ensemble(0.45, 0.03, 2.0)


def _small() -> splitlf.Design:
    """The Illum cut to 6 x 6 lenses (a hex lattice behind a circular aperture: the
    general route, whose rows surface_system gives)."""
    d = splitlf.Design.preset("lytro-illum")
    return d.replace(channels=tuple(c.replace(Kx=6, Ky=6, Mx=None, My=None)
                                    for c in d.channels))


def _request(lam: float | None, samples: int, seed: int = 3,
             rule: str = "oracle", parabola: bool = False,
             ensemble: Ensemble = ENSEMBLE, coarse: bool = True,
             df_weight: float = 1.25) -> dict[str, Any]:
    return {"channels": [1], "lens_types": None, "photons": PHOTONS,
            "ensemble": (ensemble.mean, ensemble.amplitude, ensemble.exponent, ensemble.floor,
                         list(ensemble.spectrum)),
            "patch": 8,
            "step": None, "regularization": lam, "rule": rule, "df_weight": df_weight,
            "settings": (NOISE_FLOOR, 1e-10, 5000, samples, 1e-2, 1e4, 4, seed, 1.0, 4, 1e-6,
                         parabola),
            "coarse": coarse}


def _dense(design: splitlf.Design, out: dict[str, Any],
           ensemble: Ensemble = ENSEMBLE) -> dict[str, Any]:
    """The patch's dense system from surface_system on the padded grid (one pixel span of
    padding), the rows weighted as the merits weight them, the prior's DᵀD, the ensemble's
    covariance over the grid and the inner cells' indices."""
    h = out["step"]
    x0, x1, y0, y1 = out["extent"]
    pad = math.ceil(_native.pixel_span(design.core, Z, [1]) / h) * h
    grid = _native.cell_grid((x0 - pad, x1 + pad, y0 - pad, y1 + pad), h)
    nx, ny = grid[3], grid[4]
    assert (nx, ny) == tuple(out["padded"])
    scene = _native.RenderScene("constant", [0.0], None, *splitlf.Plane(Z).seam(), 0.0)
    chan, _pix, indptr, indices, data = _native.surface_system(design.core, scene, grid, [1])
    a = np.zeros((len(chan), nx * ny))
    for r in range(len(chan)):
        a[r, indices[indptr[r]:indptr[r + 1]]] = data[indptr[r]:indptr[r + 1]]
    share = design.channels[0].share
    sigma = np.maximum(np.sqrt(np.maximum(ENSEMBLE.mean * a.sum(1), 0.0) / PHOTONS),
                       NOISE_FLOOR * share)
    w = 1.0 / sigma ** 2
    # First differences between horizontal and vertical neighbours (docs/model.md §11).
    diffs = []
    for j in range(ny):
        for i in range(nx):
            for dj, di in ((0, 1), (1, 0)):
                if j + dj < ny and i + di < nx:
                    row = np.zeros(nx * ny)
                    row[j * nx + i], row[(j + dj) * nx + i + di] = -1.0, 1.0
                    diffs.append(row)
    dmat = np.asarray(diffs)
    g = max(nx, ny)
    g = 1 << (g - 1).bit_length()
    k = np.fft.fftfreq(g) * g
    f = np.hypot(k[None, :], k[:, None]) / g
    s = np.zeros_like(f)
    s[f > 0] = _spectrum(ensemble, f[f > 0])
    cov = np.real(np.fft.ifft2(s))  # C(d) = (1/G^2) sum_f S(f) cos(2 pi f d / G)
    jj, ii = np.divmod(np.arange(nx * ny), nx)
    sigma_x = cov[(jj[:, None] - jj[None, :]) % g, (ii[:, None] - ii[None, :]) % g]
    inner_nx = round((x1 - x0) / h)
    inner_ny = round((y1 - y0) / h)
    left = round((x0 - grid[0]) / h)
    top = round((grid[1] - y1) / h)
    inner = np.array([(top + j) * nx + left + i for j in range(inner_ny)
                      for i in range(inner_nx)])
    return {"a": a, "w": w, "r": dmat.T @ dmat, "cov": sigma_x, "inner": inner, "grid": grid}


def _spectrum(ensemble: Ensemble, f: np.ndarray) -> np.ndarray:
    """S(f) > 0 of the ensemble, flat below its floor (0: none): the power law, or its
    knots interpolated linearly in log f - log S, flat beyond the ends (np.interp)."""
    f = np.maximum(f, ensemble.floor)
    if not ensemble.spectrum:
        return ensemble.amplitude ** 2 * f ** -ensemble.exponent
    kf, ks = np.log(np.asarray(ensemble.spectrum)).T
    return np.exp(np.interp(np.log(f), kf, ks))


def _expected_mse(m: dict[str, Any], lam: float) -> float:
    """E |x_hat - x|^2 per inner cell, closed form: lam^2 tr(S M^-1 R C R M^-1 S') (bias)
    + tr(S M^-1 A'WA M^-1 S') (noise), M = A'WA + lam R."""
    n = m["a"].T @ (m["w"][:, None] * m["a"])
    minv = np.linalg.inv(n + lam * m["r"])
    s = minv[m["inner"]]
    bias = lam ** 2 * np.trace(s @ m["r"] @ m["cov"] @ m["r"] @ s.T)
    noise = np.trace(s @ n @ s.T)
    return float((bias + noise) / m["inner"].size)


@pytest.mark.parametrize("lam", [3.0, 300.0])
def test_expected_error_is_the_dense_closed_form(lam: float) -> None:
    """The core's Monte-Carlo expected squared error (32 draws, CG to 1e-10) at a given
    lambda against the closed form of the linear estimator's bias and noise with dense
    matrices: within 3 of the draws' standard errors (plus 2 % for the periodic
    synthesis' finite sums)."""
    d = _small()
    out = _native.image_merits(d.core, Z, _request(lam, 32), None, n_threads=2)
    want = _expected_mse(_dense(d, out), lam)
    assert abs(out["mse"] - want) <= 3.0 * out["error"] + 0.02 * want, (
        out["mse"], out["error"], want)
    assert out["error"] < 0.2 * out["mse"]


def test_expected_error_with_a_floor_is_the_dense_closed_form() -> None:
    """The same with the ensemble's spectrum flat below a floor of 0.2 cycles per cell
    (the covariance built here from S(f) = a^2 max(f, floor)^-alpha): the draws follow
    the floored spectrum."""
    d = _small()
    ens = Ensemble(ENSEMBLE.mean, ENSEMBLE.amplitude, ENSEMBLE.exponent, 0.2)
    out = _native.image_merits(d.core, Z, _request(3.0, 32, ensemble=ens), None, n_threads=2)
    want = _expected_mse(_dense(d, out, ens), 3.0)
    assert abs(out["mse"] - want) <= 3.0 * out["error"] + 0.02 * want, (
        out["mse"], out["error"], want)
    bare = _expected_mse(_dense(d, out), 3.0)
    assert want < bare, (want, bare)  # the floor removes the slow modes' power


def test_expected_error_with_a_measured_spectrum_is_the_dense_closed_form() -> None:
    """The same with a measured spectrum in place of the power law: knots with a bump at
    0.1-0.2 cycles per cell (no power law has one), the covariance built here from the
    knots by np.interp in log-log: the draws follow the knots, not the power law."""
    d = _small()
    knots = ((0.03, 0.02), (0.1, 0.002), (0.15, 0.004), (0.2, 0.001), (0.5, 2e-5))
    ens = Ensemble(ENSEMBLE.mean, ENSEMBLE.amplitude, ENSEMBLE.exponent, 0.0, knots)
    out = _native.image_merits(d.core, Z, _request(3.0, 32, ensemble=ens), None, n_threads=2)
    want = _expected_mse(_dense(d, out, ens), 3.0)
    assert abs(out["mse"] - want) <= 3.0 * out["error"] + 0.02 * want, (
        out["mse"], out["error"], want)
    bare = _expected_mse(_dense(d, out), 3.0)
    assert abs(want - bare) > 0.2 * bare, (want, bare)  # the knots are not the law


def test_edge_response_is_the_dense_estimators_mean() -> None:
    """The edge's expected image: (A'WA + lam R)^-1 A'WA x_e with x_e the edge's cell
    averages, against the dense solve (CG to 1e-10)."""
    d = _small()
    edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
    scene = _native.RenderScene(*edge.seam(), "plane", [Z, 0.0, 0.0], None, 0.0)
    out = _native.image_merits(d.core, Z, _request(30.0, 2), scene, n_threads=2)
    m = _dense(d, out)
    xe = _native.cell_averages(scene, m["grid"]).ravel()
    n = m["a"].T @ (m["w"][:, None] * m["a"])
    want = np.linalg.solve(n + 30.0 * m["r"], n @ xe)[m["inner"]]
    got = out["edge"].ravel()
    assert np.max(np.abs(got - want)) < 1e-6, np.max(np.abs(got - want))


def test_least_error_lambda_is_the_closed_forms_minimum() -> None:
    """The chosen lambda's expected error is within the scatter of the closed form's
    least over a fine grid of lambda (the search finds the minimum of a flat valley)."""
    d = _small()
    out = _native.image_merits(d.core, Z, _request(None, 16), None, n_threads=2)
    m = _dense(d, out)
    best = min(_expected_mse(m, lam) for lam in np.geomspace(1e-1, 1e4, 21))
    at = _expected_mse(m, out["lam"])
    assert at <= best * 1.05 + 3.0 * out["error"], (at, best, out["lam"])


def _gcv_parts(m: dict[str, Any]) -> dict[str, Any]:
    """The pencil N = A'WA, R = D'D diagonalised once (scipy.linalg.eigh(N, N + R): V'NV =
    diag(mu), V'(N + R)V = I, so V'(N + lam R)V = diag(mu + lam (1 - mu))), for GCV's
    closed form at many lambda."""
    a, w = m["a"], m["w"]
    n = a.T @ (w[:, None] * a)
    mu, v = scipy.linalg.eigh(n, n + m["r"])
    g = a @ v
    cy = a @ m["cov"] @ a.T + np.diag(1.0 / w)
    return {"mu": mu, "g": g, "w": w, "cy": cy}


def _expected_gcv(parts: dict[str, Any], lam: float,
                  rho: float = 1.0) -> tuple[float, float, float]:
    """GCV's parts in expectation over the ensemble and the noise, closed form: df =
    tr(M^-1 A'WA) = sum mu / (mu + lam (1 - mu)), E RSS = tr(W P (A C A' + W^-1) P'),
    P = I - A M^-1 A'W (the mean albedo drops out: P A 1 = 0 as D 1 = 0), and the score
    m E RSS / (m - rho df)^2."""
    mu, g, w = parts["mu"], parts["g"], parts["w"]
    d = 1.0 / (mu + lam * (1.0 - mu))
    df = float(np.sum(mu * d))
    p = np.eye(g.shape[0]) - (g * d[None, :]) @ g.T * w[None, :]
    rss = float(np.trace((w[:, None] * p) @ parts["cy"] @ p.T))
    rows = g.shape[0]
    return df, rss, rows * rss / (rows - rho * df) ** 2


@pytest.mark.parametrize(("rule", "rho"), [("gcv", 1.0), ("weighted gcv", 2.0)])
def test_gcv_lambda_is_the_expected_scores_minimum(rule: str, rho: float) -> None:
    """rule "gcv" (and "weighted gcv", df charged rho times; 2 here so that its valley
    lies apart from plain GCV's): at each lambda tried, df within 4 Hutchinson standard
    errors (4 probes, variance at most 2 tr(H^2) <= 2 df per probe) of the dense trace, the
    draws' mean RSS within 5 % of its expectation (16 draws: about 1.5 % scatter), the
    score m RSS / (m - rho df)^2 of them, and the chosen lambda's expected score within 3 %
    of the least of a fine grid's (the score's valley is flat)."""
    d = _small()
    out = _native.image_merits(d.core, Z, _request(None, 16, rule=rule, df_weight=rho), None,
                               n_threads=2)
    m = _dense(d, out)
    parts = _gcv_parts(m)
    assert out["gcv"] and out["lam"] == min(out["gcv"], key=lambda t: t[1])[0]
    rows = m["a"].shape[0]
    assert out["rows"] == rows
    for lam, score, rss, df in out["gcv"]:
        want_df, want_rss, _ = _expected_gcv(parts, lam, rho)
        assert abs(df - want_df) <= 4.0 * math.sqrt(2.0 * want_df / 4.0), (lam, df, want_df)
        assert abs(rss - want_rss) <= 0.05 * want_rss, (lam, rss, want_rss)
        assert score == pytest.approx(rows * rss / (rows - rho * df) ** 2, rel=1e-9)
    best = min(_expected_gcv(parts, lam, rho)[2] for lam in np.geomspace(1e-2, 1e4, 97))
    assert _expected_gcv(parts, out["lam"], rho)[2] <= 1.03 * best, (out["lam"], best)
    # The expected error there against the closed form, as at a given lambda.
    want = _expected_mse(m, out["lam"])
    assert abs(out["mse"] - want) <= 3.0 * out["error"] + 0.02 * want


def test_gcv_parabolic_step_is_the_vertex_through_the_decades() -> None:
    """GCV's parabolic step (settings' last item; off by default, docs/merits.md "Speed"):
    after the decades, one lambda at the vertex in log lambda of the parabola through the
    least decade's score and its neighbours' (NumPy's polyfit through the three trials),
    the choice the least score tried, and that lambda's expected score within 3 % of the
    least of a fine grid's, as the golden sections' (the same test above)."""
    d = _small()
    out = _native.image_merits(d.core, Z, _request(None, 16, rule="gcv", parabola=True),
                               None, n_threads=2)
    trials = out["gcv"]
    decades = [(math.log10(t[0]), t[1]) for t in trials[:-1]]
    first = decades[0][0]
    assert all(abs(e - first - round(e - first)) < 1e-9 for e, _ in decades), decades
    best = min(decades, key=lambda t: t[1])[0]
    e3 = np.array([best - 1.0, best, best + 1.0])
    f3 = [next(f for e, f in decades if abs(e - x) < 1e-9) for x in e3]
    c2, c1, _ = np.polyfit(e3, f3, 2)
    assert c2 > 0
    assert math.log10(trials[-1][0]) == pytest.approx(-c1 / (2.0 * c2), abs=1e-9)
    assert out["lam"] == min(trials, key=lambda t: t[1])[0]
    parts = _gcv_parts(_dense(d, out))
    least = min(_expected_gcv(parts, lam)[2] for lam in np.geomspace(1e-2, 1e4, 97))
    assert _expected_gcv(parts, out["lam"])[2] <= 1.03 * least, (out["lam"], least)


def test_ensemble_fit_recovers_a_draws_spectrum() -> None:
    """Ensemble.fit on a draw of the merits' synthesis (docs/merits.md: periodic, 256 x 256)
    recovers its exponent within 0.25 and amplitude within 25 % (measured: +0.16 and
    -17 %: the octave bins' centres and the lowest bins' few frequencies bias the line)."""
    want = Ensemble(0.4, 0.02, 2.5)
    rng = np.random.default_rng(5)
    g = 256
    k = np.fft.fftfreq(g) * g
    f = np.hypot(k[None, :], k[:, None]) / g
    h = np.zeros_like(f)
    h[f > 0] = want.amplitude * f[f > 0] ** (-want.exponent / 2)
    z = rng.standard_normal((g, g)) + 1j * rng.standard_normal((g, g))
    x = want.mean + np.real(np.fft.ifft2(h * z)) * g
    got = Ensemble.fit(x)
    assert abs(got.exponent - want.exponent) < 0.25, got
    assert abs(got.amplitude / want.amplitude - 1.0) < 0.25, got
    assert abs(got.mean - want.mean) < 0.05
    assert got.floor == 0.0
    # Flat below the band: the same line, the floor at the band's bottom (2 cycles per
    # image); a bad floor or flag is refused.
    flat = Ensemble.fit(x[:, :200], flat_below_band=True)
    assert flat.floor == 2.0 / 200 and flat.exponent == Ensemble.fit(x[:, :200]).exponent
    with pytest.raises(splitlf.InvalidParameter, match="floor"):
        Ensemble(0.4, 0.02, 2.5, 0.7)
    with pytest.raises(TypeError, match="flat_below_band"):
        Ensemble.fit(x, flat_below_band=1)


def test_ensemble_measure_recovers_a_draws_spectrum() -> None:
    """Ensemble.measure on a draw of a spectrum no power law has (a power law times a bump
    of 4 at 0.08-0.16 cycles per cell, periodic 256 x 256): each knot within 25 % of the
    spectrum at the knot above 0.03 cycles per cell (each bin's mean of a few hundred
    periodogram values or more; measured: within 13 %), the bump seen (the knots' power
    at 0.11 against the law's, 3-5x), flat below the first knot, fit's line on the record;
    bad knots, a bad per_octave and a flat image are refused by name."""
    g = 256
    k = np.fft.fftfreq(g) * g
    f = np.hypot(k[None, :], k[:, None]) / g

    def law(f: np.ndarray) -> np.ndarray:
        return 4e-4 * f ** -2.0 * np.where((f > 0.08) & (f < 0.16), 4.0, 1.0)

    h = np.zeros_like(f)
    h[f > 0] = np.sqrt(law(f[f > 0]))
    z = np.random.default_rng(9).standard_normal((g, g)) * (1 + 1j)
    x = 0.5 + np.real(np.fft.ifft2(h * z)) * g
    got = Ensemble.measure(x)
    kf, ks = np.asarray(got.spectrum).T
    assert kf[0] > 2.0 / g and kf[-1] < math.sqrt(0.5) and np.all(np.diff(kf) > 0)
    # Away from the bump's two edges (a bin straddling one averages both sides).
    away = (kf > 0.03) & (np.abs(kf - 0.08) > 0.01) & (np.abs(kf - 0.16) > 0.02)
    assert np.all(np.abs(ks[away] / law(kf[away]) - 1.0) < 0.25), ks / law(kf)
    near = int(np.argmin(np.abs(kf - 0.113)))
    assert 3.0 < ks[near] / (4e-4 * kf[near] ** -2.0) < 5.0
    line = Ensemble.fit(x)
    assert (got.mean, got.amplitude, got.exponent, got.floor) == (
        line.mean, line.amplitude, line.exponent, 0.0)
    with pytest.raises(splitlf.InvalidParameter, match="strictly increasing"):
        Ensemble(0.5, 0.01, 2.0, 0.0, ((0.2, 1.0), (0.1, 1.0)))
    with pytest.raises(splitlf.InvalidParameter, match="knot 0's S"):
        Ensemble(0.5, 0.01, 2.0, 0.0, ((0.2, 0.0),))
    with pytest.raises(splitlf.InvalidParameter, match="knot 1's f"):
        Ensemble(0.5, 0.01, 2.0, 0.0, ((0.2, 1.0), (1.5, 1.0)))
    with pytest.raises(TypeError, match="spectrum"):
        Ensemble(0.5, 0.01, 2.0, 0.0, 3.0)  # type: ignore[arg-type]
    with pytest.raises(splitlf.InvalidParameter, match="per_octave"):
        Ensemble.measure(x, per_octave=0)
    with pytest.raises(splitlf.InvalidParameter, match="image"):
        Ensemble.measure(np.full((32, 32), 0.5))


def test_image_merits_rows_and_checks() -> None:
    """Every row of the seed cut at one depth (channel 1, channel 2, union): finite PSNR
    with its error, MTF50 a share of Nyquist in (0, 1], the union at least as good as the
    worse channel; bad arguments raise naming the parameter."""
    seed = splitlf.Design.preset("seed")
    cut = seed.replace(channels=tuple(c.replace(Kx=12, Ky=8) for c in seed.channels))
    r = image_merits(cut, [800.0], 2000.0, ensemble=ENSEMBLE, patch=24, samples=3)
    assert set(r.rows) == {"channel 1", "channel 2", "union"}
    for v in r.rows.values():
        assert np.isfinite(v["psnr"]).all() and (v["psnr_error"] > 0).all()
        assert ((v["mtf50"] > 0) & (v["mtf50"] <= 1)).all()
    u = r.rows["union"]["psnr"][0]
    assert u >= min(r.rows["channel 1"]["psnr"][0], r.rows["channel 2"]["psnr"][0]) - 0.5
    with pytest.raises(InvalidParameter, match="photons"):
        image_merits(cut, [800.0], -1.0, ensemble=ENSEMBLE)
    with pytest.raises(InvalidParameter, match="rows"):
        image_merits(cut, [800.0], ensemble=ENSEMBLE, rows=["type 2"])
    with pytest.raises(InvalidParameter, match="patch"):
        image_merits(cut, [800.0], ensemble=ENSEMBLE, patch=4)
    with pytest.raises(TypeError, match="ensemble"):
        image_merits(cut, [800.0], ensemble=(0.5, 0.1, 2.0))
    with pytest.raises(InvalidParameter, match="exponent"):
        Ensemble(0.5, 0.1, 5.0)
    with pytest.raises(InvalidParameter, match="margin"):
        image_merits(cut, [800.0], ensemble=ENSEMBLE, margin=0.5)
    with pytest.raises(InvalidParameter, match="rule.*gcv, weighted gcv, oracle"):
        image_merits(cut, [800.0], ensemble=ENSEMBLE, rule="best")


def test_rows_of_the_same_pixels_are_one_computation() -> None:
    """A one-channel design's "channel 1" and "union" are the same rows: the same numbers,
    the seconds too (one computation reported under both names)."""
    d = _small()
    r = image_merits(d, [Z], PHOTONS, ensemble=ENSEMBLE, patch=24, samples=2)
    assert set(r.rows) == {"channel 1", "union"}
    for q in ("psnr", "psnr_error", "mtf50", "regularization", "seconds"):
        np.testing.assert_array_equal(r.rows["channel 1"][q], r.rows["union"][q])


def test_two_level_preconditioner_is_the_same_merit_in_fewer_iterations() -> None:
    """The merits' CG with the two-level preconditioner (docs/merits.md, "Two-level
    preconditioner") against Jacobi alone, both to 1e-10, on the seed's half 1 at 1 m
    (patch 16, its padded grid coarsened into aggregates): the same expected error and
    edge response to 1e-8, in fewer iterations."""
    d = splitlf.Design.preset("seed")
    edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
    scene = _native.RenderScene(*edge.seam(), "plane", [Z, 0.0, 0.0], None, 0.0)
    out = {}
    for coarse in (False, True):
        req = _request(30.0, 2, coarse=coarse)
        req["patch"] = 16
        out[coarse] = _native.image_merits(d.core, Z, req, scene, n_threads=2)
    a, b = out[False], out[True]
    assert a["padded"][0] * a["padded"][1] > 4 * 576  # coarsened (COARSE_CELLS = 576)
    assert abs(a["mse"] - b["mse"]) <= 1e-8 * a["mse"], (a["mse"], b["mse"])
    assert np.max(np.abs(a["edge"] - b["edge"])) < 1e-8
    assert b["iterations"] < a["iterations"], (a["iterations"], b["iterations"])
