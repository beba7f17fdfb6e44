"""Write docs/depth_r12.png and docs/depth_r12.json: the paper's Fig. 2 scene for
`raytrix-r12` -- one slanted plane across its working range -- its depth from the raw, the
depth's error, and the image end to end (with a plane fitted to the estimated depth) beside
the one with the known plane.

- Camera: `raytrix-r12` (hexagonal lattice, three lens types, circular aperture, sensor
  layout) cut to KX x KY lenses, its sensor cut to match.
- Scene: the plane Z = z0 + gy Y through NEAR at the bottom of the field and FAR at its
  top (about ten times steeper than 45 degrees along Y, as the seed's Fig. 2 plane),
  carrying a photograph (scikit-image's "camera") laid on it so that the camera sees it
  undistorted (each TEXEL texture cell takes the photograph's value at its view angle).
- Data: ``splitlf.render`` (the general route: the R12's sensor layout is beyond the
  tests' Monte-Carlo renderer, which draws the ideal layout only) with its error target
  RENDER_TOL, ten times finer than its default, and photon noise N = 2000. The texture's
  cells (TEXEL, bilinear) are several times finer than the reconstruction's, which assumes
  cell-constant albedo on its own grid and records its rows with a fixed rule
  (docs/reconstruct.md step 6), not the renderer's adaptive one: the raw is not the
  reconstruction's forward model applied to its own unknowns. The depth sweep's model
  (chief rays and lens-to-lens spreads, docs/depth.md) is cruder still.
- Depth: ``splitlf.estimate_depth`` over each band padded by a pixel's span (candidates
  CANDIDATES), its error against the true plane over the confident cells.
- Images: per band (depths in BINS), cells of STEP sensor steps delta(z) at the band's
  middle depth over the central half (per axis) of what the array images at its near
  depth: with the known plane, and end to end with a plane fitted to the band's estimate
  (make_fig2_end_to_end's robust fit, both tilts kept). Both take the R12's general route
  (docs/reconstruct.md step 6). The estimate's own depth map goes through that route too,
  but far slower: on a band from 420 to 502 mm it had not finished after 20 minutes,
  where a plane's image takes about 5.
  PSNR and RMSE against the scene's cell averages.

Run: python docs/make_depth_r12.py [--cache DIR] (about 35 minutes on 2 cores: 11 for the
raw, about 5 for each image).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import make_fig2_slanted as seedfig  # docs/, the script's own folder
import matplotlib
from make_fig2_end_to_end import centres, fit_plane

matplotlib.use("Agg")  # a script, not the library: it may pick a backend

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import splitlf  # noqa: E402
from splitlf import _native, measure  # noqa: E402
from splitlf.report import report_data  # noqa: E402

HERE = Path(__file__).parent
KX, KY = 10, 40
NEAR, FAR = 350.0, 800.0  # the plane's depth at the bottom and top of the field
BINS = np.geomspace(450.0, 638.0, 3)  # the bands' depth edges
NOISE = {"photons": 2000.0, "read_noise": 0.0}
RENDER_TOL = 1e-4
TEXEL = 0.05  # mm
STEP = 8.0  # the reconstruction's cells, in delta(z)
CANDIDATES = np.geomspace(250.0, 2000.0, 64)


def design() -> splitlf.Design:
    full = splitlf.Design.preset("raytrix-r12")
    c = full.channels[0]
    return full.replace(channels=(c.replace(Kx=KX, Ky=KY, Mx=None, My=None),))


def plane(d: splitlf.Design) -> tuple[splitlf.Plane, float, float]:
    """The plane through NEAR at the bottom and FAR at the top of the field, and the
    field's half-angles in X and Y (hex rows sqrt(3)/2 d apart)."""
    c = d.resolved()[0]
    theta_y = c["Ky"] * c["d"] * np.sqrt(3.0) / 2.0 / 2.0 / c["L"]
    theta_x = c["Kx"] * c["d"] / 2.0 / c["L"]
    gy = (FAR - NEAR) / (theta_y * (FAR + NEAR))
    return splitlf.Plane(NEAR + gy * theta_y * NEAR, 0.0, gy), theta_x, theta_y


def texture(d: splitlf.Design, p: splitlf.Plane, theta_x: float, theta_y: float
            ) -> splitlf.Image:
    """The photograph as the camera sees it, over everything a pixel sees on the plane
    (the field at FAR, padded by a pixel's span there): each texture cell takes the
    photograph's value at its view angle (X/Z, Y/Z), the photograph spanning the field's
    height (and its width, at the same angular scale, centred)."""
    span = _native.pixel_span(d.core, FAR, None)
    width = 2.0 * (theta_x * FAR + span)
    top = max((FAR - p.z0) / p.gy + span, span - (NEAR - p.z0) / p.gy)  # centred on the axis
    cols, rows = round(width / TEXEL), round(2.0 * top / TEXEL)
    X = (np.arange(cols) + 0.5) * TEXEL - width / 2.0
    Y = rows * TEXEL / 2.0 - (np.arange(rows) + 0.5) * TEXEL
    Xg, Yg = np.meshgrid(X, Y)
    return splitlf.Image(seedfig.photograph(p, 1.05 * theta_y, Xg, Yg), cols * TEXEL)


def render(d: splitlf.Design, p: splitlf.Plane, tex: splitlf.Image, cache: Path | None
           ) -> splitlf.Raw:
    path = None if cache is None else cache / "depth_r12_raw.npz"
    if path is not None and path.exists():
        return splitlf.Raw.load(path)
    raw = splitlf.render(d, splitlf.Scene(tex, p), noise=NOISE, seed=2026, tol=RENDER_TOL)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        raw.save(path)
    return raw


def bands(d: splitlf.Design, p: splitlf.Plane) -> list[tuple[float, tuple, float]]:
    """(middle depth, region, step) of each band: depths in BINS, cells of STEP delta(z)
    at the band's middle depth, the central half (per axis) of what the array images
    across at its near depth."""
    c = d.resolved()[0]
    out = []
    for zlo, zhi in zip(BINS[:-1], BINS[1:], strict=True):
        zm = float(np.sqrt(zlo * zhi))
        hx = zlo / c["L"] * c["Kx"] * c["d"] / 4.0
        out.append((zm, (-hx, hx, (zlo - p.z0) / p.gy, (zhi - p.z0) / p.gy),
                    STEP * d.resolution_step(zm)))
    return out


def fitted(est: splitlf.DepthMap, Xg: np.ndarray, Yg: np.ndarray
           ) -> tuple[splitlf.Plane, float]:
    """The plane fitted to the estimate's confident cells at (Xg, Yg) (make_fig2_end_to_end's
    robust least squares, both tilts kept: the R12 takes the general route either way), and
    the share of those cells the fit kept."""
    m = est.confident
    z0, gx, gy, kept = fit_plane(Xg[m], Yg[m], est.depth[m])
    return splitlf.Plane(z0, gx, gy), kept


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", type=Path, default=None,
                    help="a folder to keep the rendered raw in between runs")
    ap.add_argument("--bands", type=int, nargs="*", default=None,
                    help="only these bands (0 = nearest), for a quick look; no files written")
    args = ap.parse_args()
    t0 = time.perf_counter()
    d = design()
    p, theta_x, theta_y = plane(d)
    tex = texture(d, p, theta_x, theta_y)
    raw = render(d, p, tex, args.cache)
    print(f"raw {raw.images[0].shape}: {time.perf_counter() - t0:.0f} s", flush=True)
    band_mm = report_data(d)["derived"]["channels"][0]["out_of_focus_depth_mm"]

    recs: dict[str, list] = {"known plane": [], "from the raw": []}
    depth_views, error_views, rows = [], [], []
    for i, (zm, region, step) in enumerate(bands(d, p)):
        if args.bands is not None and i not in args.bands:
            continue
        x0, x1, y0, y1 = region
        zlo, zhi = p.z0 + p.gy * y0, p.z0 + p.gy * y1
        span = _native.pixel_span(d.core, zhi, None)
        padded = (x0 - span, x1 + span, y0 - span, y1 + span)
        t1 = time.perf_counter()
        est = splitlf.estimate_depth(raw, depths=CANDIDATES, region=padded, progress=False)
        t_depth = time.perf_counter() - t1
        e = measure.depth_errors(est, p)
        Xg, Yg = centres(est)
        true = p.z0 + p.gx * Xg + p.gy * Yg
        rel = (est.depth - true) / true
        depth_views.append(SimpleNamespace(extent=est.extent, image=np.where(
            est.confident, est.depth, np.nan)))
        error_views.append(SimpleNamespace(extent=est.extent, image=np.where(
            est.confident, 100.0 * np.abs(rel), np.nan)))
        surface, kept = fitted(est, Xg, Yg)
        yc = 0.5 * (y0 + y1)
        z_true, z_fit = p.z0 + p.gy * yc, surface.z0 + surface.gy * yc
        row: dict[str, Any] = {"depth": zm, "region": list(region), "step": step,
                               "depth_region": list(est.extent), "depth_errors": e,
                               "depth_seconds": t_depth,
                               "fit": {"z0": surface.z0, "gx": surface.gx, "gy": surface.gy,
                                       "kept": kept},
                               "fit_error_mid": (z_fit - z_true) / z_true,
                               "fit_error_ends": [
                                   (surface.z0 + surface.gy * y - p.z0 - p.gy * y)
                                   / (p.z0 + p.gy * y) for y in (y0, y1)],
                               "signed_median": float(np.median(rel[est.confident]))
                               if est.confident.any() else None}
        for name, surf in (("known plane", p), ("from the raw", surface)):
            t1 = time.perf_counter()
            r = splitlf.reconstruct(raw, surf, region=region, step=step, noise=NOISE,
                                    progress=False)
            recs[name].append(r)
            t = measure.truth(r, tex)
            row[name] = {"psnr": measure.psnr(r, tex),
                         "rmse": float(np.sqrt(np.mean((r.image - t) ** 2))),
                         "seconds": time.perf_counter() - t1}
        row["rmse_ratio"] = row["from the raw"]["rmse"] / row["known plane"]["rmse"]
        rows.append(row)
        print(f"{zm:.0f} mm ({zlo:.0f}-{zhi:.0f}): depth median {100 * e['median']:.2f} %, "
              f"p90 {100 * e['p90']:.2f} %, {100 * e['confident']:.0f} % confident "
              f"({t_depth:.0f} s); known {row['known plane']['psnr']:.1f} dB "
              f"({row['known plane']['seconds']:.0f} s), from the raw "
              f"{row['from the raw']['psnr']:.1f} dB ({row['from the raw']['seconds']:.0f} s),"
              f" RMSE x{row['rmse_ratio']:.2f}  [{time.perf_counter() - t0:.0f} s]",
              flush=True)
    if args.bands is not None:
        return
    out = {"preset": "raytrix-r12", "lenses": [KX, KY], "band_mm": band_mm,
           "plane": {"z0": p.z0, "gx": p.gx, "gy": p.gy}, "bands": rows,
           "photons": NOISE["photons"], "render_tol": RENDER_TOL, "texel_mm": TEXEL,
           "candidates": [float(CANDIDATES[0]), float(CANDIDATES[-1]), len(CANDIDATES)],
           "step_delta": STEP,
           "seconds": time.perf_counter() - t0}
    (HERE / "depth_r12.json").write_text(json.dumps(out, indent=1) + "\n")
    figure(d, p, theta_x, rows, recs, depth_views, error_views, band_mm)
    print(f"docs/depth_r12.png, .json in {time.perf_counter() - t0:.0f} s")


def figure(d: splitlf.Design, p: splitlf.Plane, theta_x: float, rows: list[dict],
           recs: dict[str, list], depth_views: list, error_views: list,
           band_mm: float) -> None:
    """The images, the depth and its error as the camera sees them (one column each), and
    PSNR and the depth error against depth."""
    tyb = (BINS[0] - p.z0) / p.gy / BINS[0]
    tyt = (BINS[-1] - p.z0) / p.gy / BINS[-1]
    txw = theta_x / 2.0 * BINS[0] / BINS[-1]
    ty = np.linspace(tyt, tyb, 700)
    tx = np.linspace(-txw, txw, max(50, int(700 * 2 * txw / (tyt - tyb))))
    fig = plt.figure(figsize=(12.5, 7.4))
    gs = fig.add_gridspec(2, 5, width_ratios=[1, 1, 1, 1, 2.6])
    panels = [(f"{n}", recs[n], "gray", (0.0, 1.0)) for n in recs] + [
        ("depth from the raw (mm)", depth_views, "viridis", (BINS[0], BINS[-1])),
        ("its error (%)", error_views, "magma", (0.0, 10.0))]
    zmark = [z for z in (450, 500, 550, 600, 650, 700) if BINS[0] <= z <= BINS[-1]]
    for k, (name, r, cmap, (lo, hi)) in enumerate(panels):
        ax = fig.add_subplot(gs[:, k])
        im = ax.imshow(seedfig.view(r, p, ty, tx), cmap=cmap, vmin=lo, vmax=hi,
                       aspect="auto", extent=(tx[0], tx[-1], ty[-1], ty[0]),
                       interpolation="nearest")
        ax.set_title(name, fontsize=8)
        ax.set_xticks([])
        if k == 0:
            ax.set_yticks([(z - p.z0) / p.gy / z for z in zmark])
            ax.set_yticklabels([f"{z:.0f} mm" for z in zmark], fontsize=8)
        else:
            ax.set_yticks([])
        ax.set_ylim(ty[-1], ty[0])  # ticks must not widen the view past the bands
        if k >= 2:
            fig.colorbar(im, ax=ax, orientation="horizontal", pad=0.02, fraction=0.04)
    mids = [r["depth"] for r in rows]
    ax = fig.add_subplot(gs[0, 4])
    for name in recs:
        ax.plot(mids, [r[name]["psnr"] for r in rows], "o-", ms=3, label=name)
    ax.set_ylabel("PSNR (dB)")
    ax.legend(fontsize=7)
    ax = fig.add_subplot(gs[1, 4])
    ax.plot(mids, [100 * r["depth_errors"]["median"] for r in rows], "o-", label="median")
    ax.plot(mids, [100 * r["depth_errors"]["p90"] for r in rows], "s--",
            label="90th percentile")
    ax.set_yscale("log")
    ax.set_xlabel("depth on the plane (mm)")
    ax.set_ylabel("depth error, confident cells (%)")
    ax.legend(fontsize=7)
    for a in fig.axes[-2:]:
        a.set_xscale("log")
        a.axvline(band_mm, color="0.6", lw=0.8, ls=":")
        a.grid(alpha=0.3, which="both")
    fig.suptitle(f"raytrix-r12 cut to {KX} x {KY} lenses: one slanted plane, {NEAR:.0f} mm "
                 f"(bottom) to {FAR:.0f} mm (top); render's general route, N = 2000; "
                 f"grey line: the array's conjugate ({band_mm:.0f} mm)", fontsize=9)
    fig.tight_layout()
    fig.savefig(HERE / "depth_r12.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
