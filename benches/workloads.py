"""The benchmark's workload table: W1-W6, each a core entry point and its NumPy twin
(benches/numpy_impl.py) on identical inputs, with the sizes, the check of their agreement
and the outputs the memory floor allocates. benches/run.py runs them."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy_impl

import splitlf


@dataclasses.dataclass
class Workload:
    name: str
    title: str
    sizes: Callable[[bool], dict[str, Any]]
    setup: Callable[[dict[str, Any]], dict[str, Any]]
    numpy: Callable[[dict[str, Any]], dict[str, np.ndarray]]
    native: Callable[[dict[str, Any], int | None], dict[str, np.ndarray]]
    out_bytes: Callable[[dict[str, Any]], int] | None = None
    # The floor's arrays (shape, dtype), when it allocates and fills the outputs' own arrays
    # rather than one float64 array of their total size.
    out_arrays: Callable[[dict[str, Any]], list[tuple[tuple[int, ...], Any]]] | None = None
    # How NumPy and native results must agree (default: check_equal, 1e-12 relative);
    # returns what it measured of the agreement.
    check: Callable[[dict[str, np.ndarray], dict[str, np.ndarray], str],
                    dict[str, Any]] | None = None
    # At most this many rounds (a reference side that takes minutes per run).
    max_rounds: int | None = None
    # Also measure the native side's peak with tracemalloc (NumPy's allocator).
    traced_memory: bool = False
    # Measure the NumPy side's peak memory too (a fresh run of it in a subprocess).
    numpy_memory: bool = True


WORKLOADS: dict[str, Workload] = {}


def workload(w: Workload) -> Workload:
    WORKLOADS[w.name] = w
    return w


# -- W1: closed forms --------------------------------------------------------------------

def _w1_setup(sizes):
    cam = splitlf.Camera.paper()
    z = np.geomspace(cam.F * 1.001, 1e5, sizes["depths"])
    return {"cam": cam, "z": z}


def _w1_native(inp, n_threads):
    c = splitlf.curves(inp["cam"], inp["z"], n_threads=n_threads)
    return {k: getattr(c, k) for k in ("conjugate", "main_blur", "repetitions",
                                       "microlens_blur", "blur_px", "conventional_px")}


workload(Workload(
    name="W1",
    title="closed forms: every `curves` array",
    sizes=lambda quick: {"depths": 10**5 if quick else 10**7},
    setup=_w1_setup,
    numpy=lambda inp: numpy_impl.curves(inp["cam"], inp["z"]),
    native=_w1_native,
    out_bytes=lambda inp: 11 * 8 * inp["z"].size,
))


# -- W2: footprints ------------------------------------------------------------------------

def _w2_setup(sizes):
    return {"cam": splitlf.Camera.paper(), "z": np.geomspace(150.0, 10_000.0, sizes["depths"])}


def _w2_native(inp, n_threads):
    out = {}
    for half in (1, 2):
        fp = splitlf.footprints(inp["cam"], inp["z"], half, "x", "centroid", n_threads=n_threads)
        out.update({f"position_{half}": fp.position, f"lo_{half}": fp.lo, f"hi_{half}": fp.hi})
    return out


workload(Workload(
    name="W2",
    title="footprints: centroid position and extent of every pixel of both halves along x",
    sizes=lambda quick: {"depths": 100 if quick else 10**4, "pixels_per_half": 266 * 15},
    setup=_w2_setup,
    numpy=lambda inp: numpy_impl.footprints(inp["cam"], inp["z"]),
    native=_w2_native,
    out_bytes=lambda inp: 2 * 3 * 8 * inp["z"].size * inp["cam"].Kx * inp["cam"].Q,
))


# -- W3: new samples ---------------------------------------------------------------------

def _w3_setup(sizes):
    return {"cam": splitlf.Camera.paper(), "z": np.geomspace(150.0, 10_000.0, sizes["depths"]),
            "tol": 1e-6}


def _w3_native(inp, n_threads):
    r = splitlf.new_samples(inp["cam"], inp["z"], tol=inp["tol"], n_threads=n_threads)
    return {"distinct": r.distinct, "max_gap": r.max_gap}


workload(Workload(
    name="W3",
    title="samples: `new_samples` (distinct per half and union, max gap)",
    sizes=lambda quick: {"depths": 200 if quick else 10**4},
    setup=_w3_setup,
    numpy=lambda inp: numpy_impl.new_samples(inp["cam"], inp["z"], inp["tol"]),
    native=_w3_native,
))


# -- W4: full 40-MP sensor -------------------------------------------------------------------

def w4_camera(kx: int = 516, ky: int = 172) -> splitlf.Camera:
    """The seed design on a 40-MP split sensor: 7,740 x 5,160 pixels of mu = 4.5 um, Q = 15.
    The two halves sit one above the other (as the seed's 36 x 24 mm sensor splits into two
    36 x 12 mm halves), so each half is 7,740 x 2,580 pixels: Kx = 7,740 / 15 = 516 and
    Ky = 2,580 / 15 = 172 microlenses. The pitch keeps Q pixels per microlens, d = Q mu =
    0.0675 mm, and v = d v' / D keeps half 1 f-number matched (D v / v' = mu Q), as in the
    seed. --quick uses 1/4 of the microlenses along each axis."""
    cam = splitlf.Camera.paper()
    d = 15 * 0.0045
    return cam.replace(mu=0.0045, d=d, v=d * cam.v1 / cam.D, Kx=kx, Ky=ky)


def _w4_setup(sizes):
    return {"cam": w4_camera(sizes["Kx"], sizes["Ky"]), "z": 500.0}


def _w4_native(inp, n_threads):
    out = {}
    for half in (1, 2):
        X, Y = splitlf.sample_grid(inp["cam"], inp["z"], half, "chief", n_threads=n_threads)
        out.update({f"X_{half}": X, f"Y_{half}": Y})
    return out


def _w4_sizes(quick: bool) -> dict[str, Any]:
    kx, ky = (129, 43) if quick else (516, 172)
    return {"pixels": f"{kx * 15} x {2 * ky * 15}", "Kx": kx, "Ky": ky}


workload(Workload(
    name="W4",
    title="full sensor: `sample_grid` of both halves of a 40-MP split sensor at one depth",
    sizes=_w4_sizes,
    setup=_w4_setup,
    numpy=lambda inp: numpy_impl.sample_grid(inp["cam"], inp["z"]),
    native=_w4_native,
    out_bytes=lambda inp: 2 * 2 * 8 * inp["cam"].Kx * inp["cam"].Ky * inp["cam"].Q ** 2,
))


# -- W5: coverage of a multi-focus camera against SciPy (qhull) ------------------------------

W5_TOL, W5_WINDOW = 1e-6, 16.0


def _small(design: splitlf.Design, f: int) -> splitlf.Design:
    """A design's single sensor-layout channel with 1/f of its lenses and pixels per axis
    (--quick)."""
    ch, res = design.channels[0], design.resolved()[0]
    ch = ch.replace(Kx=ch.Kx // f, Ky=ch.Ky // f, Mx=res["Mx"] // f, My=res["My"] // f)
    return design.replace(channels=(ch,))


def _w5_setup(sizes):
    d = splitlf.Design.preset("raytrix-r12")
    return {"design": _small(d, 4) if sizes["quick"] else d,
            "z": np.geomspace(300.0, 10_000.0, sizes["depths"]),
            "tol": W5_TOL, "window": sizes["window"]}


def _w5_native(inp, n_threads):
    c = splitlf.coverage(inp["design"], inp["z"], inp["tol"], inp["window"],
                         n_threads=n_threads)
    return {"distinct": c.distinct, "covering_radius": c.covering_radius,
            "covering_radius_mm": c.covering_radius_mm}


def check_coverage(a: dict[str, np.ndarray], b: dict[str, np.ndarray],
                   name: str) -> dict[str, Any]:
    """Distinct counts equal; covering radii (in delta and in mm) to 1e-9 relative."""
    assert set(a) == set(b), (name, sorted(a), sorted(b))
    np.testing.assert_array_equal(b["distinct"], a["distinct"], err_msg=f"{name}: distinct")
    worst = 0.0
    for key in ("covering_radius", "covering_radius_mm"):
        np.testing.assert_allclose(b[key], a[key], rtol=1e-9, atol=0,
                                   err_msg=f"{name}: {key}")
        worst = max(worst, float(np.max(np.abs(b[key] / a[key] - 1.0))))
    return {"distinct_equal": True, "covering_radius_max_rel_diff": worst}


workload(Workload(
    name="W5",
    title="`coverage` of raytrix-r12 (distinct 2-D samples, covering radius) vs SciPy/qhull",
    sizes=lambda quick: {"design": "raytrix-r12" + (" / 4 per axis" if quick else ""),
                         "depths": 4 if quick else 100, "z_mm": "300-10,000 geometric",
                         "window": 4.0 if quick else W5_WINDOW, "quick": quick},
    setup=_w5_setup,
    numpy=lambda inp: numpy_impl.coverage(inp["design"], inp["z"], inp["tol"], inp["window"]),
    native=_w5_native,
    check=check_coverage,
    max_rounds=3,
    numpy_memory=False,  # another 100-depth SciPy run (minutes) for a figure of no interest
))


# -- W6: 2-D chief samples of a whole sensor ---------------------------------------------------

W6_Z = 1000.0


def _w6_setup(sizes):
    d = splitlf.Design.preset("lytro-illum")
    return {"design": _small(d, 4) if sizes["quick"] else d, "z": W6_Z}


def _w6_native(inp, n_threads):
    c = splitlf.chief_samples(inp["design"], 1, inp["z"], n_threads=n_threads)
    return {"X": c.X, "Y": c.Y, "lit": c.lit, "lens": c.lens, "type": c.type}


def _w6_arrays(inp) -> list[tuple[tuple[int, ...], Any]]:
    """The arrays `chief_samples` returns: X, Y float64, lit bool, lens (.., 2) and type int64."""
    res = inp["design"].resolved()[0]
    shape = (res["My"], res["Mx"])
    return [(shape, np.float64), (shape, np.float64), (shape, np.bool_),
            ((*shape, 2), np.int64), (shape, np.int64)]


def _nbytes(arrays) -> int:
    return sum(int(np.prod(shape)) * np.dtype(dt).itemsize for shape, dt in arrays)


def check_identical(a: dict[str, np.ndarray], b: dict[str, np.ndarray],
                    name: str) -> dict[str, Any]:
    """Bit for bit (NaN where the other has NaN), same dtypes and shapes."""
    assert set(a) == set(b), (name, sorted(a), sorted(b))
    for key in a:
        assert a[key].dtype == b[key].dtype and a[key].shape == b[key].shape, (name, key)
        np.testing.assert_array_equal(b[key], a[key], err_msg=f"{name}: {key}")
    return {"bit_for_bit": True}


workload(Workload(
    name="W6",
    title="`chief_samples` of the whole lytro-illum sensor at one depth",
    sizes=lambda quick: {"design": "lytro-illum" + (" / 4 per axis" if quick else ""),
                         "pixels": "1932 x 1342" if quick else "7728 x 5368",
                         "z_mm": W6_Z, "quick": quick},
    setup=_w6_setup,
    numpy=lambda inp: numpy_impl.chief_samples(inp["design"], 1, inp["z"]),
    native=_w6_native,
    out_bytes=lambda inp: _nbytes(_w6_arrays(inp)),
    out_arrays=_w6_arrays,
    check=check_identical,
    traced_memory=True,
))
