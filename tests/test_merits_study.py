"""The image merits against a full-field study computed in the test (docs/merits.md,
"Agreement"): docs/fig2.md's procedure on a smaller cut of the seed.

Study side, as docs/make_fig2.py: its design, the seed cut to 24 x 16 lenses per half (a
smaller cut's field is narrower than the merits' padded patch: measured on 12 x 8 at
642 mm, half 2's merit lay 3.5 dB under its study); at each depth a
natural image (scikit-image's ``camera``, 0.1 + 0.8 of its grey levels, 512 x 512 texture
cells, each 0.79 of a reconstruction cell at 642 mm and 0.87 at 1000 mm, not aligned with
the grid) and a 5-degree slanted edge
(analytic) rendered by ``splitlf.render`` (exact route) with photon noise (N = 2000 for
white, the raw carrying it), reconstructed over the central half (per axis) of what both
arrays image at ``regularization=None`` (the data-chosen, GCV, weight) from half 1, half
2 and both, measured by ``splitlf.measure`` (PSNR on the image, MTF50 on the edge). The
renderer is the package's own exact route, as the study's; neither texture is
representable on the reconstruction's grid (no inverse crime: the data's texture cells
are of another size and phase than the grid's, or the texture is continuous), and the
noise is Poisson.

Merit side: ``splitlf.image_merits`` at the same N, the ensemble of the study's truth at
that depth (``splitlf.measure.truth``): its measured radial spectrum (``Ensemble.measure``;
with the power law fitted to it instead, ``Ensemble.fit``, the merit lay up to 1.53 dB
off: docs/merits.md, "A measured spectrum"), the same rows.
"""

from __future__ import annotations

import numpy as np
import pytest

import splitlf
from splitlf import measure
from splitlf.inverse.merits import Ensemble, image_merits

PHOTONS = 2000.0
DEPTHS = (642.0, 1000.0)
ROWS = {"channel 1": 1, "channel 2": 2, "union": None}
#: The issue's bounds, 1 dB and 0.03 of Nyquist. With the measured spectrum, on
#: docs/fig2.md's depths at N = 2000 the merit's PSNR lies from 0.96 dB below the study's
#: mean of two draws (half 2, 300 mm) to 0.73 dB above (half 2, 2000 mm), within 0.27 dB at
#: 642 and 1000 mm, its MTF50 within 0.023 of Nyquist at 642 and 1000 mm (0.10 at 500 and
#: 800 mm, where the study's own MTF50 is fragile); one study draw scatters by about 0.3 dB
#: and 0.02 more. Measured here (one draw): PSNR -0.34 to +0.24 dB, MTF50 -0.015 to +0.022
#: (with the fitted power law instead, before: PSNR -0.94 to +1.53 dB, MTF50 -0.028 to
#: +0.023).
PSNR_BOUND = 1.0
MTF50_BOUND = 0.03


def _cut() -> splitlf.Design:
    seed = splitlf.Design.preset("seed")
    return seed.replace(channels=tuple(c.replace(Kx=24, Ky=16) for c in seed.channels))


def _region(design: splitlf.Design, z: float) -> tuple[float, float, float, float]:
    hx = min(z / c["L"] * c["Kx"] * c["d"] for c in design.resolved()) / 4.0
    hy = min(z / c["L"] * c["Ky"] * c["d"] for c in design.resolved()) / 4.0
    return (-hx, hx, -hy, hy)


def _study(design: splitlf.Design, z: float) -> dict[str, tuple[float, float, np.ndarray]]:
    """Per row: the study's PSNR, MTF50 / Nyquist, and the natural image's truth."""
    from skimage import data

    region = _region(design, z)
    span = splitlf._native.pixel_span(design.core, z, None)
    img = 0.1 + 0.8 * data.camera().astype(np.float64) / 255.0
    tex = splitlf.Image(img, 2.0 * (max(abs(v) for v in region) + 2.0 * span))
    edge = splitlf.SlantedEdge(5.0, 0.1, 0.9)
    noise = {"photons": PHOTONS, "read_noise": 0.0}
    nyq = 1.0 / (2.0 * design.resolution_step(z))
    raws = [splitlf.render(design, splitlf.Scene(t, z), noise=noise, seed=11 + i,
                           progress=False) for i, t in enumerate((tex, edge))]
    out = {}
    for row, ch in ROWS.items():
        rec = splitlf.reconstruct(raws[0], z, region=region, channels=ch, progress=False)
        assert rec.regularization_rule == "weighted gcv"
        rec_e = splitlf.reconstruct(raws[1], z, region=region, channels=ch, progress=False)
        out[row] = (measure.psnr(rec, tex), measure.mtf50(rec_e, edge) / nyq,
                    measure.truth(rec, tex))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("z", DEPTHS)
def test_merits_agree_with_the_rendered_study(z: float) -> None:
    """At each depth and row, |merit - study| <= PSNR_BOUND (1 dB) and <= MTF50_BOUND
    (0.03 of Nyquist), the issue's bounds: the largest gaps measured at these depths with
    the measured spectrum (0.34 dB; 0.023, here and in fig2's) with one study draw's
    scatter (about 0.3 dB, 0.02) left inside them (docs/merits.md, "A measured
    spectrum"). About 80 s on 2 idle cores: slow tier."""
    d = _cut()
    study = _study(d, z)
    for row, (psnr, mtf, truth) in study.items():
        m = image_merits(d, [z], PHOTONS, ensemble=Ensemble.measure(truth), rows=[row])
        got = m.rows[row]
        print(f"{z:g} {row}: PSNR merit {got['psnr'][0]:.2f} study {psnr:.2f}; "
              f"MTF50 merit {got['mtf50'][0]:.3f} study {mtf:.3f}")
        assert abs(got["psnr"][0] - psnr) <= PSNR_BOUND, (row, got["psnr"][0], psnr)
        assert abs(got["mtf50"][0] - mtf) <= MTF50_BOUND, (row, got["mtf50"][0], mtf)
