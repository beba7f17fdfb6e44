"""Write docs/fig2_end_to_end.json and docs/fig2_end_to_end.png: the Fig. 2 plane
(docs/make_fig2_slanted.py, the same Monte-Carlo raw) reconstructed from the raw alone,
beside the image with the known plane.

Per depth band (make_fig2_slanted's eight bands):
1. Depth: ``splitlf.estimate_depth`` over the band (candidates 250 mm to 3 m, cells of
   0.1 mm), as in make_fig2_slanted.
   The estimate covers the band widened by half 1's pixel span at the band's near depth
   (so that the pixels that see the band's edge see the surface), within the field.
2. The estimate's own surface: ``reconstruct(raw, est)`` takes an estimate as
   ``est.surface(design)`` (docs/depth.md, "The estimate's surface": confident cells
   hold, the others follow, slopes limited to what every ray meets once, so its map takes
   the footprint route). Until 2026-11-29 this step fitted a plane per band (its X tilt
   dropped), as the estimate's map went through the render's own first-hit integral,
   hours for this raw. The fit's parameters are still recorded (``fit``) for comparison.
3. The band reconstructed from both halves with that surface, and with the true plane;
   PSNR and RMSE of each against the scene's cell averages, the surface's depth error
   (median over the band's confident cells) and the seconds each reconstruction took.

Run: python docs/make_fig2_end_to_end.py [--cache DIR] [--bands I,J,...] (only those
bands, numbered from 0 from the nearest) (the raw is rendered as in
make_fig2_slanted.py, or read from DIR).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import make_fig2_slanted as fig  # docs/, the script's own folder
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import splitlf  # noqa: E402
from splitlf import measure  # noqa: E402

HERE = Path(__file__).parent


def fit_plane(X: np.ndarray, Y: np.ndarray, Z: np.ndarray) -> tuple[float, ...]:
    """(z0, gx, gy, share kept) of the least-squares plane through the points, refitted
    three times without the points beyond 3 robust deviations (1.4826 x the median
    absolute residual)."""
    keep = np.ones(Z.size, bool)
    A = np.stack([np.ones_like(X), X, Y], axis=1)
    coef = np.zeros(3)
    for _ in range(4):
        coef, *_ = np.linalg.lstsq(A[keep], Z[keep], rcond=None)
        res = Z - A @ coef
        mad = 1.4826 * np.median(np.abs(res[keep]))
        keep = np.abs(res) <= 3.0 * mad
    return float(coef[0]), float(coef[1]), float(coef[2]), float(keep.mean())


def centres(est: splitlf.DepthMap) -> tuple[np.ndarray, np.ndarray]:
    """X and Y [mm] of the estimate's cell centres (row 0 at the top)."""
    ny, nx = est.depth.shape
    x0, x1, y0, y1 = est.extent
    Xg, Yg = np.meshgrid(x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx,
                         y1 - (np.arange(ny) + 0.5) * (y1 - y0) / ny)
    return Xg, Yg


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", type=Path, default=None,
                    help="a folder to keep the rendered raw in between runs")
    ap.add_argument("--bands", type=lambda v: {int(b) for b in v.split(",")}, default=None,
                    help="only these bands (numbered from 0, nearest first)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    d = fig.design()
    p, theta = fig.plane(d)
    tex = fig.texture(p, theta)
    truth_tex = splitlf.Image(tex, fig.WIDTH)
    raw = fig.render(d, p, tex, args.cache)[0]  # the first noise draw
    rows = []
    recs: dict[str, list] = {"known plane": [], "from the raw": []}
    for k, (zm, region, step) in enumerate(fig.bands(d, p)):
        if args.bands is not None and k not in args.bands:
            continue
        x0, x1, y0, y1 = region
        zlo = min(p.depths(region))
        span = float(splitlf._native.pixel_span(d.core, zlo, [1]))
        field = splitlf._native.seen_region(d.core, zm, [1])
        wide = (max(x0 - span, 2.0 * field[0]), min(x1 + span, 2.0 * field[1]),
                y0 - span, y1 + span)
        est = splitlf.estimate_depth(raw, depths=(250.0, 3000.0), region=wide,
                                     step=fig.DEPTH_STEP, progress=False)
        Xg, Yg = centres(est)
        m = est.confident
        z0, gx, gy, kept = fit_plane(Xg[m], Yg[m], est.depth[m])
        surface = est.surface(d)
        inside = m & (Xg >= x0) & (Xg <= x1) & (Yg >= y0) & (Yg <= y1)
        zt = p.z0 + p.gy * Yg
        err = (surface.depth - zt) / zt
        out: dict = {"depth": zm, "fit": {"z0": z0, "gx": gx, "gy": gy, "kept": kept},
                     "depth_error_median": float(np.median(err[inside])),
                     "depth_error_p90": float(np.percentile(np.abs(err[inside]), 90)),
                     "confident": float(inside.sum() / max(1, ((Xg >= x0) & (Xg <= x1)
                                                                & (Yg >= y0)
                                                                & (Yg <= y1)).sum()))}
        for name, surf in (("known plane", p), ("from the raw", est)):
            t1 = time.perf_counter()
            try:
                r = splitlf.reconstruct(raw, surf, region=region, step=step,
                                        channels=(1, 2), progress=False, allow_slow=True)
            except splitlf.errors.InvalidParameter:
                out[name] = {"psnr": None, "rmse": None}
                continue
            recs[name].append(r)
            t = measure.truth(r, truth_tex)
            out[name] = {"psnr": measure.psnr(r, truth_tex),
                         "rmse": float(np.sqrt(np.mean((r.image - t) ** 2))),
                         "seconds": time.perf_counter() - t1,
                         "regularization": r.regularization,
                         "surface": type(r.depth).__name__}
        got = out["from the raw"]["rmse"]
        out["rmse_ratio"] = None if got is None else got / out["known plane"]["rmse"]
        rows.append(out)
        print(f"{zm:.0f} mm: known {out['known plane']['psnr']:.1f} dB, from the raw "
              f"{out['from the raw']['psnr']} dB, RMSE x{out['rmse_ratio']}, "
              f"surface's median depth error {100 * out['depth_error_median']:+.2f} % "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    result = {"true": {"z0": p.z0, "gx": p.gx, "gy": p.gy}, "bands": rows,
              "photons": fig.NOISE["photons"], "seconds": time.perf_counter() - t0}
    (HERE / "fig2_end_to_end.json").write_text(json.dumps(result, indent=1))

    # the figure: both images as the camera sees them, and PSNR against depth
    ty, tx = fig.display_grid(d, p)
    f = plt.figure(figsize=(9.5, 7.4))
    gs = f.add_gridspec(2, 3, width_ratios=[1, 1, 2.4])
    for k, (name, r) in enumerate(recs.items()):
        fig.show_view(f.add_subplot(gs[:, k]), fig.view(r, p, ty, tx), ty, tx, p,
                      f"split sensor, {name}", k == 0)
    mids = [r["depth"] for r in rows]
    fig.psnr_axes(f.add_subplot(gs[0, 2]), mids, {
        name: [np.nan if r[name]["psnr"] is None else r[name]["psnr"] for r in rows]
        for name in recs})
    ax = f.add_subplot(gs[1, 2])
    ax.plot(mids, [100 * r["depth_error_median"] for r in rows], "o-",
            label="the estimate's surface, median over the band")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.axvline(642.0, color="tab:red", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_xlabel("depth on the plane (mm)")
    ax.set_ylabel("depth error (%)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    f.suptitle("The Fig. 2 plane end to end: depth per band from the raw, its surface, "
               "the image (N = 2000)", fontsize=10)
    f.tight_layout()
    f.savefig(HERE / "fig2_end_to_end.png", dpi=110)
    plt.close(f)
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
