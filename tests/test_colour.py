"""Colour (docs/model.md §12): RGB textures and a Bayer colour filter array.

Every check is against an independent derivation: the pattern's phase from its name's
letters in plain NumPy, the grey render of each colour's texture, NumPy's own Poisson draw
of the mosaic, and the reconstruction's pixels counted and disturbed by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _cli import run_cli, small_raw

import splitlf
from splitlf import (
    BarChart,
    ColourReconstruction,
    ColourTexture,
    Design,
    Image,
    Raw,
    Scene,
    Sinusoid,
    measure,
    reconstruct,
    render,
)
from splitlf.errors import InvalidParameter

PATTERNS = ("RGGB", "GRBG", "GBRG", "BGGR")
QE = (0.6, 0.9, 0.35)


def ideal() -> Design:
    """The seed on 8 x 6 lenses per channel (two channels, ideal layout)."""
    d = Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=8, Ky=6) for c in d.channels))


def sensor() -> Design:
    """A rect sensor-layout channel of two defocused lens types (images spill onto the
    neighbours' pixels: the sensor grid's own indices) beside an ideal-layout one."""
    seed = Design.preset("seed")
    s1, s2 = seed.channels
    ch1 = splitlf.Channel(L=s1.L, d=s1.d, v=s1.v, mu=s1.mu, Kx=5, Ky=4, f=(0.55, 0.7),
                          layout="sensor", share=0.6)
    ch2 = splitlf.Channel(L=s2.L, d=s2.d, v=s2.v, mu=s2.mu, Kx=4, Ky=3, Q=15, share=0.4)
    return Design(seed.F, seed.D, (ch1, ch2))


DESIGNS = {"ideal": ideal, "sensor": sensor}


def numpy_colours(pattern: str, shape: tuple[int, int]) -> np.ndarray:
    """Each pixel's colour (0 R, 1 G, 2 B) from the pattern's letters, row by row."""
    block = np.array(["RGB".index(ch) for ch in pattern]).reshape(2, 2)
    r, c = np.indices(shape)
    return block[r % 2, c % 2]


@pytest.mark.parametrize("layout", DESIGNS)
def test_a_white_texture_gives_each_pixel_its_colours_white(layout):
    """Albedo 1 through each phase: each pixel is the grey raw times its colour's QE, the
    colour read from the pattern's name (the sensor layout's own indices included)."""
    d = DESIGNS[layout]()
    grey = render(d, Scene(1.0, 1000.0))
    for pattern in PATTERNS:
        raw = render(d, Scene(1.0, 1000.0), cfa=pattern, qe=QE)
        assert raw.cfa == {"pattern": pattern, "qe": QE}
        for g, c in zip(grey.images, raw.images, strict=True):
            want = g * np.asarray(QE)[numpy_colours(pattern, g.shape)]
            np.testing.assert_array_equal(c, want)
            assert g.max() > 0.1  # pixels are lit: the check has teeth
        # The grey raw of the mosaic is the grey render (a grey scene: exact but rounding).
        for g, back in zip(grey.images, raw.grey().images, strict=True):
            np.testing.assert_allclose(back, g, rtol=1e-15, atol=0)


def test_the_default_qe_is_one():
    d = ideal()
    g, c = render(d, Scene(0.7, 900.0)), render(d, Scene(0.7, 900.0), cfa="BGGR")
    assert c.cfa == {"pattern": "BGGR", "qe": (1.0, 1.0, 1.0)}
    for a, b in zip(g.images, c.images, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("layout", DESIGNS)
def test_each_colour_is_the_grey_render_of_its_texture(layout):
    """Linear, one render per colour: each colour's pixels are bit for bit the grey
    render of that colour's texture (times its QE), for a ColourTexture and a colour
    Image."""
    d = DESIGNS[layout]()
    rng = np.random.default_rng(7)
    array = rng.uniform(0.0, 1.0, (9, 13, 3))
    textures = [ColourTexture(Sinusoid(0.8), BarChart(1.3, 0.2, 0.7), 0.4),
                Image(array, 2.5)]
    for tex in textures:
        scene = Scene(tex, 950.0)
        raw = render(d, scene, cfa="GRBG", qe=QE)
        for k in range(3):
            grey = render(d, Scene(tex.colour(k), 950.0, background=scene.background))
            for g, c in zip(grey.images, raw.images, strict=True):
                sel = numpy_colours("GRBG", g.shape) == k
                np.testing.assert_array_equal(c[sel], g[sel] * QE[k])
    # The three colours differ: the test tells them apart.
    a = [render(d, Scene(Image(array[..., k], 2.5), 950.0)).images[0] for k in range(3)]
    assert not np.array_equal(a[0], a[1]) and not np.array_equal(a[1], a[2])


def test_the_noise_is_drawn_on_the_mosaic():
    """Photo-electrons N QE value: NumPy's Poisson on the noise-free mosaic, drawn from
    the render's noise stream, channel 1 first."""
    d, n = ideal(), 300.0
    scene = Scene(ColourTexture(0.9, 0.5, 0.2), 1000.0)
    clean = render(d, scene, cfa="RGGB", qe=QE)
    noisy = render(d, scene, cfa="RGGB", qe=QE, noise={"photons": n}, seed=5)
    rng = np.random.default_rng([5, 1])
    for a, b in zip(clean.images, noisy.images, strict=True):
        np.testing.assert_array_equal(b, rng.poisson(a * n) / n)
    assert noisy.noise == {"photons": n, "read_noise": 0.0}


def test_the_cfa_round_trips_and_older_files_load_grey(tmp_path):
    d = ideal()
    raw = render(d, Scene(0.5, 1000.0), cfa="GBRG", qe=QE, noise={"photons": 1e3}, seed=1)
    raw.save(tmp_path / "c.npz")
    back = Raw.load(tmp_path / "c.npz")
    assert back.cfa == raw.cfa and back.noise == raw.noise
    for a, b in zip(raw.images, back.images, strict=True):
        np.testing.assert_array_equal(a, b)
    # A file without the keys (as before colour) is a grey raw.
    with np.load(tmp_path / "c.npz") as z:
        old = {k: z[k] for k in z.files if k not in ("cfa", "qe")}
    np.savez(tmp_path / "old.npz", **old)
    assert Raw.load(tmp_path / "old.npz").cfa is None
    np.savez(tmp_path / "qe.npz", **old, qe=np.array(QE))
    with pytest.raises(ValueError, match="qe"):
        Raw.load(tmp_path / "qe.npz")
    np.savez(tmp_path / "bad.npz", **old, cfa=np.array("RGBG"))
    with pytest.raises(ValueError, match="cfa"):
        Raw.load(tmp_path / "bad.npz")


@pytest.mark.parametrize(("kwargs", "error", "name"), [
    ({"cfa": "rggb"}, InvalidParameter, "cfa"),
    ({"cfa": "RGBG"}, InvalidParameter, "cfa"),
    ({"cfa": 3}, TypeError, "cfa"),
    ({"cfa": "RGGB", "qe": (1.2, 1.0, 1.0)}, InvalidParameter, "qe[0]"),
    ({"cfa": "RGGB", "qe": (1.0, 0.0, 1.0)}, InvalidParameter, "qe[1]"),
    ({"cfa": "RGGB", "qe": (1.0, 1.0, math.nan)}, InvalidParameter, "qe[2]"),
    ({"cfa": "RGGB", "qe": (1.0, 1.0)}, InvalidParameter, "qe"),
    ({"cfa": "RGGB", "qe": "high"}, TypeError, "qe"),
    ({"qe": (1.0, 1.0, 1.0)}, InvalidParameter, "qe"),
])
def test_bad_cfa_options_are_refused_by_name(kwargs, error, name):
    with pytest.raises(error, match=name.replace("[", r"\[").replace("]", r"\]")):
        render(ideal(), Scene(1.0, 1000.0), **kwargs)


def test_bad_colour_textures_are_refused_by_name():
    with pytest.raises(InvalidParameter, match="Image.array"):
        Image(np.ones((4, 5, 2)), 1.0)
    with pytest.raises(TypeError, match="ColourTexture.green"):
        ColourTexture(0.5, Image(np.ones((4, 5, 3)), 1.0), 0.5)
    with pytest.raises(TypeError, match="ColourTexture.blue"):
        ColourTexture(0.5, 0.5, "random")
    with pytest.raises(InvalidParameter, match="cfa"):
        render(ideal(), Scene(ColourTexture(0.1, 0.2, 0.3), 1000.0))
    with pytest.raises(InvalidParameter, match="texture"):
        splitlf.simulate(splitlf.Camera.paper(), 1000.0, Image(np.ones((4, 5, 3)), 1.0))
    with pytest.raises(InvalidParameter, match="colour"):
        Image(np.ones((4, 5, 3)), 1.0).colour(3)
    d = ideal()
    images = render(d, Scene(1.0, 1000.0)).images
    with pytest.raises(InvalidParameter, match="cfa"):
        Raw(d, images, cfa={"pattern": "XYZW"})
    with pytest.raises(InvalidParameter, match="cfa"):
        Raw(d, images, cfa={"pattern": "RGGB", "gain": 2})


def _disturbed(raw: Raw, k: int) -> Raw:
    """The raw with every pixel of a colour other than k set to 5 (five times white)."""
    assert raw.cfa is not None
    images = []
    for a in raw.images:
        b = a.copy()
        b[numpy_colours(raw.cfa["pattern"], a.shape) != k] = 5.0
        images.append(b)
    return Raw(raw.design, images, noise=raw.noise, cfa=raw.cfa)


@pytest.mark.parametrize("layout", DESIGNS)
def test_a_colour_is_reconstructed_from_its_own_pixels_only(layout):
    """The factored route (the ideal layout) and the explicit one (the sensor layout's
    channel): each colour's rows are its pixels (they add up to the grey raw's) and no
    other pixel moves its image (set to 5 x white, the image is bit for bit the same;
    GRBG, whose red and blue swap if rows and columns were mixed up)."""
    d = DESIGNS[layout]()
    rng = np.random.default_rng(3)
    depth = 1000.0
    scene = Scene(Image(rng.uniform(0.1, 0.9, (8, 8, 3)), 2.0), depth)
    raw = render(d, scene, cfa="GRBG", qe=QE, noise={"photons": 1e4}, seed=2)
    side = 0.25 if layout == "ideal" else 0.12
    opts = {"region": (-side, side, -side, side), "regularization": 1.0,
            "channels": (1, 2) if layout == "ideal" else (1,)}
    rec = reconstruct(raw, depth, **opts)
    assert isinstance(rec, ColourReconstruction) and rec.image.shape[2] == 3
    grey = reconstruct(raw.grey(), depth, noise={"photons": 1e4}, **opts)
    assert sum(r.rows for r in rec.colours) == grey.rows
    assert rec.colours[1].rows > 1.5 * rec.colours[0].rows  # two greens a block
    for k in range(3) if layout == "ideal" else (0,):
        again = reconstruct(_disturbed(raw, k), depth, **opts)
        np.testing.assert_array_equal(again.colours[k].image, rec.colours[k].image)
        assert not np.array_equal(again.colours[(k + 1) % 3].image,
                                  rec.colours[(k + 1) % 3].image)
        assert rec.colours[k].noise_model == {"photons": 1e4 * QE[k], "read_noise": 0.0}
    with pytest.raises(TypeError, match="colours"):
        measure.psnr(rec, scene.texture)


def test_colour_reconstruction_against_the_full_grey_raw():
    """Each colour from its own pixels against the grey reconstruction of a full grey
    raw of that colour's texture (photon noise N = 1e4, same seed; rendered by the model
    that inverts it, an inverse crime the noise tempers): a quarter (red, blue) or half
    (green) of the rows, within 1.5 dB of PSNR here (docs/reconstruct.md measures the
    loss over seeds: 0.0x-0.x dB)."""
    d = ideal()
    rng = np.random.default_rng([50, 0])
    tex = Image(rng.uniform(0.1, 0.9, (12, 18, 3)), 3.0)
    region = (-0.5, 0.5, -0.5, 0.5)
    raw = render(d, Scene(tex, 1000.0, background=0.5), cfa="RGGB", noise={"photons": 1e4})
    rec = reconstruct(raw, 1000.0, region=region)
    for k in range(3):
        full = render(d, Scene(tex.colour(k), 1000.0, background=0.5),
                      noise={"photons": 1e4})
        ref = reconstruct(full, 1000.0, region=region)
        got = rec.colours[k]
        assert got.rows * (2 if k == 1 else 4) == ref.rows
        loss = measure.psnr(ref, tex.colour(k)) - measure.psnr(got, tex.colour(k))
        assert measure.psnr(ref, tex.colour(k)) > 15.0
        assert -1.0 < loss < 1.5, (k, loss)


def test_depth_of_a_mosaic_is_the_depth_of_its_grey_raw():
    """estimate_depth matches a mosaic's grey raw: for a grey scene under unequal QEs the
    same estimate as the grey render's (the division is exact to rounding)."""
    d = ideal()
    rng = np.random.default_rng(4)
    scene = Scene(Image(rng.uniform(0.1, 0.9, (20, 30)), 5.0), 1000.0)
    cands = np.linspace(850.0, 1200.0, 8)
    region = (-1.0, 1.0, -1.0, 1.0)
    grey = splitlf.estimate_depth(render(d, scene), depths=cands, region=region)
    mosaic = splitlf.estimate_depth(render(d, scene, cfa="GBRG", qe=QE), depths=cands,
                                    region=region)
    np.testing.assert_allclose(mosaic.depth, grey.depth, rtol=1e-9)
    assert np.mean(np.abs(grey.depth - 1000.0) < 60.0) > 0.5


def test_the_cli_renders_through_a_cfa_and_reconstructs_in_colour(tmp_path, capsys):
    """``splitlf render --cfa --qe`` with a colour .npy texture writes the raw the library
    renders (CFA recorded); without --cfa it is refused naming cfa; ``reconstruct`` of it
    writes the (ny, nx, 3) image of the library's ColourReconstruction."""
    array = np.random.default_rng(9).uniform(0.1, 0.9, (6, 8, 3))
    np.save(tmp_path / "t.npy", array)
    args = ["--texture", str(tmp_path / "t.npy"), "--width", "2", "--depth", "1000"]
    raw_path = small_raw(tmp_path, (4, 3), *args, "--cfa", "GBRG", "--qe", "0.5,1,0.7",
                         capsys=capsys)
    raw = Raw.load(raw_path)
    d = raw.design
    want = render(d, Scene(Image(array, 2.0), 1000.0), cfa="GBRG", qe=(0.5, 1.0, 0.7))
    assert raw.cfa == want.cfa
    for a, b in zip(raw.images, want.images, strict=True):
        np.testing.assert_array_equal(a, b)
    code, _, err = run_cli(["render", str(tmp_path / "d.toml"), *args, "-o",
                            str(tmp_path / "g.npz")], capsys)
    assert code == 2 and "cfa" in err
    code, _, err = run_cli(["render", str(tmp_path / "d.toml"), *args, "--qe", "1,1,1",
                            "-o", str(tmp_path / "g.npz")], capsys)
    assert code == 2 and "--qe" in err
    out = tmp_path / "rec.npy"
    region = "--region=-0.2,0.2,-0.2,0.2"
    code, _, err = run_cli(["reconstruct", str(raw_path), "--depth", "1000", region,
                            "--regularization", "1", "-o", str(out)], capsys)
    assert code == 0, err
    rec = reconstruct(raw, 1000.0, region=(-0.2, 0.2, -0.2, 0.2), regularization=1.0)
    np.testing.assert_array_equal(np.load(out), rec.image)


def test_a_colour_render_in_bands_is_the_in_process_one():
    """With an executor each colour's render runs in bands of rows: the mosaic (and its
    noise) is the in-process one bit for bit, a random colour drawn once per colour."""
    import concurrent.futures as cf

    d = ideal()
    scene = Scene(ColourTexture(splitlf.RandomAlbedo(0.3), 0.5, Sinusoid(1.0)), 1000.0)
    opts = {"cfa": "BGGR", "qe": QE, "noise": {"photons": 500.0}, "seed": 4}
    here = render(d, scene, **opts)
    with cf.ThreadPoolExecutor(2) as pool:
        there = render(d, scene, executor=pool, rows_per_task=7, **opts)
    for a, b in zip(here.images, there.images, strict=True):
        np.testing.assert_array_equal(a, b)
