"""The colour route's measurement (docs/reconstruct.md "Colour", docs/depth.md "Colour").

A colour image texture (i.i.d. cells, three independent colours) on the fronto-parallel
plane at 1 m, the seed design on 16 x 12 lenses per channel, rendered by splitlf.render
through an RGGB CFA (QE 1) with photon noise N = 1e4 (the same model inverts it: an
inverse crime, stated; the noise keeps it honest). Each colour is reconstructed

- (a) per-colour rows: from its own pixels only (``reconstruct`` of the mosaiced raw);
- (b) demosaiced first: a bilinear demosaic of each channel's raw (normalised convolution
  with [[1, 2, 1], [2, 4, 2], [1, 2, 1]], which keeps each pixel's own colour and fills
  the others from the nearest pixels of that colour, across micro-image edges too), then
  a grey ``reconstruct`` of each colour's full raw (its noise stated as N);
- reference: a grey ``reconstruct`` of a full-resolution grey raw of that colour's texture
  (every pixel of that colour, the same noise seed).

PSNR per colour (splitlf.measure.psnr against the texture's cell averages) over seeds;
then estimate_depth on the mosaic's grey raw against the same scene's grey render of its
luminance (the colours' mean), N = 2000. Run: python docs/make_colour.py (prints a table).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import convolve

import splitlf
from splitlf import Design, Image, Raw, Scene, measure, reconstruct, render

NOISE = {"photons": 1e4}
REGION = (-0.6, 0.6, -0.6, 0.6)
KERNEL = np.array([[1.0, 2.0, 1.0], [2.0, 4.0, 2.0], [1.0, 2.0, 1.0]])


def design() -> Design:
    d = Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=16, Ky=12) for c in d.channels))


def demosaic(raw: Raw, k: int) -> Raw:
    """Colour k's bilinear demosaic of every channel (normalised convolution)."""
    assert raw.cfa is not None
    images = []
    for a in raw.grey().images:
        mask = (splitlf.imaging.cfa.colours(raw.cfa, a.shape) == k).astype(float)
        num = convolve(a * mask, KERNEL, mode="mirror")
        den = convolve(mask, KERNEL, mode="mirror")
        images.append(num / den)
    return Raw(raw.design, images, noise=raw.noise)


def main(seeds: int = 4) -> None:
    d = design()
    depth(d)
    rows = []
    for s in range(seeds):
        rng = np.random.default_rng([50, s])
        img = rng.uniform(0.1, 0.9, (12, 18, 3))
        tex = Image(img, 3.0)  # cells of 1/6 mm, about 1.7 delta at 1 m
        scene = Scene(tex, 1000.0, background=0.5)
        mosaic = render(d, scene, cfa="RGGB", noise=NOISE, seed=s)
        rec = reconstruct(mosaic, 1000.0, region=REGION)
        assert isinstance(rec, splitlf.ColourReconstruction)
        for k in range(3):
            truth = tex.colour(k)
            full = render(d, Scene(truth, 1000.0, background=0.5), noise=NOISE, seed=s)
            ref = reconstruct(full, 1000.0, region=REGION)
            dem = reconstruct(demosaic(mosaic, k), 1000.0, region=REGION)
            rows.append((s, k, measure.psnr(ref, truth), measure.psnr(rec.colours[k], truth),
                         measure.psnr(dem, truth), rec.colours[k].rows, ref.rows))
    print("seed colour  full-grey  per-colour  demosaic  rows(colour/full)")
    for s, k, a, b, c, m, n in rows:
        print(f"{s:4d} {'RGB'[k]:>6} {a:10.2f} {b:11.2f} {c:9.2f}   {m}/{n}")
    arr = np.array([r[2:5] for r in rows])
    for k in range(3):
        sel = arr[[r[1] == k for r in rows]]
        lo_a, lo_b = sel[:, 0] - sel[:, 1], sel[:, 0] - sel[:, 2]
        print(f"{'RGB'[k]}: per-colour loss {lo_a.mean():.2f} dB (sd {lo_a.std():.2f}), "
              f"demosaic loss {lo_b.mean():.2f} dB (sd {lo_b.std():.2f})")


def depth(d: Design, z: float = 1000.0) -> None:
    """estimate_depth (over depths 250-4000 mm, region what half 1 sees) on a colour
    scene's mosaic (its grey raw) against the grey scene of the colours' mean (the
    luminance), photon noise N = 2000: i.i.d. cells of 10 delta(z), the three colours
    independent (the worst case: the mosaic's grey raw then carries a chroma pattern
    that no lens's neighbour repeats) or sharing one luminance with a 20 % tint."""
    cell = 10 * d.resolution_step(z)
    x0, x1, y0, y1 = splitlf._native.render_extent(d.core, z)
    n = 2 * int(np.ceil(max(abs(x0), abs(x1), abs(y0), abs(y1)) / cell)) + 2
    rng = np.random.default_rng([50, 99])
    independent = rng.uniform(0.0, 1.0, (n, n, 3))
    lum = rng.uniform(0.0, 1.0, (n, n))
    tint = np.clip(lum[..., None] * (1 + 0.2 * rng.uniform(-1, 1, (n, n, 3))), 0, 1)
    region = splitlf._native.seen_region(d.core, z, [1])
    noise = {"photons": 2000.0}
    for name, img in (("independent colours", independent), ("tinted luminance", tint)):
        tex = Image(img, n * cell)
        cases = (("mosaic", render(d, Scene(tex, z), cfa="RGGB", noise=noise, seed=1)),
                 ("luminance", render(d, Scene(Image(img.mean(axis=2), n * cell), z),
                                      noise=noise, seed=1)))
        for what, raw in cases:
            est = splitlf.estimate_depth(raw, depths=(250.0, 4000.0), region=region)
            rel = np.abs(est.sweep.estimate / z - 1.0)
            print(f"depth, {name}, {what}: median |error| {np.median(rel):.2%}, 90th pct "
                  f"{np.percentile(rel, 90):.2%}, confident {np.mean(est.confident):.0%}")


if __name__ == "__main__":
    main()
