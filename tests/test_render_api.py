"""The Python side of splitlf.render (issue 21): textures (2-D and their row for the 1-D
simulation), surfaces and scenes, the render's validation and random streams, Raw (shapes,
values, the raw file format), the ``splitlf render`` command and ``splitlf.plot.raw``.

The accuracy of the core's raws is tested elsewhere. Until the native render exists
(``_native.render``), the ``native`` fixture stands in a fake that returns constant raws
of the right shapes; once it exists every test here runs against the real one."""

from __future__ import annotations

import math

import numpy as np
import pytest

import splitlf
from splitlf import (
    BarChart,
    DepthMap,
    Design,
    Image,
    InvalidParameter,
    Plane,
    RandomAlbedo,
    Raw,
    Scene,
    SiemensStar,
    Sinusoid,
    SlantedEdge,
    TooLargeError,
    _native,
    render,
    rendering,
    textures,
)
from splitlf.cli import main

HAS_NATIVE = hasattr(_native, "render")


def small_seed() -> Design:
    """The seed design on 8 x 6 lenses per channel (ideal layout, two channels)."""
    d = Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=8, Ky=6) for c in d.channels))


def small_r12(kx: int = 10, ky: int = 8) -> Design:
    """raytrix-r12 on kx x ky lenses (hex, three lens types, sensor layout, circle)."""
    d = Design.preset("raytrix-r12")
    return d.replace(channels=(d.channels[0].replace(Kx=kx, Ky=ky, Mx=None, My=None),))


def shapes(design: Design) -> list[tuple[int, int]]:
    out = []
    for ch in design.resolved():
        if ch["layout"] == "ideal":
            out.append((ch["Ky"] * ch["Q"], ch["Kx"] * ch["Q"]))
        else:
            out.append((ch["My"], ch["Mx"]))
    return out


class _FakeScene:
    def __init__(self, texture, texture_params, texture_image, surface, surface_params,
                 depth_map, background):
        self.args = (texture, list(texture_params), texture_image, surface,
                     list(surface_params), depth_map, background)


def _fake_render(core, scene, n_threads=None, progress=None):
    if progress is not None:
        progress(1, 1)
    out = []
    for ch in core.channels():
        shape = ((ch["Ky"] * ch["Q"], ch["Kx"] * ch["Q"]) if ch["layout"] == "ideal"
                 else (ch["My"], ch["Mx"]))
        out.append(np.full(shape, 0.5 * ch["share"]))
    return out


def _fake_extent(core, z):
    F, D, _ = core.main_lens()
    ch = core.channels()[0]
    hx = ch["Kx"] * ch["d"] * z / (2 * ch["L"]) + D / 2
    hy = ch["Ky"] * ch["d"] * z / (2 * ch["L"]) + D / 2
    return (-hx, hx, -hy, hy)


@pytest.fixture
def native(monkeypatch):
    """The native render, or (until it lands) a fake of the seam's signatures."""
    if not HAS_NATIVE:
        monkeypatch.setattr(_native, "RenderScene", _FakeScene, raising=False)
        monkeypatch.setattr(_native, "render", _fake_render, raising=False)
        monkeypatch.setattr(_native, "render_extent", _fake_extent, raising=False)
    return _native


def _cli(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


# -- textures -----------------------------------------------------------------------------------

@pytest.mark.parametrize("make, name, error", [
    (lambda: SlantedEdge(math.nan), "angle", InvalidParameter),
    (lambda: SlantedEdge(math.inf), "angle", InvalidParameter),
    (lambda: SlantedEdge("5"), "angle", TypeError),
    (lambda: SlantedEdge(low=-0.1), "low", InvalidParameter),
    (lambda: SlantedEdge(high=math.nan), "high", InvalidParameter),
    (lambda: SlantedEdge(center=(math.nan, 0.0)), "center[0]", InvalidParameter),
    (lambda: SlantedEdge(center=(0.0, math.inf)), "center[1]", InvalidParameter),
    (lambda: SlantedEdge(center=(1.0,)), "center", TypeError),
    (lambda: SlantedEdge(center="ab"), "center", TypeError),
    (lambda: SiemensStar(0), "spokes", InvalidParameter),
    (lambda: SiemensStar(textures.MAX_SPOKES + 1), "spokes", InvalidParameter),
    (lambda: SiemensStar(2.5), "spokes", TypeError),
    (lambda: SiemensStar(True), "spokes", TypeError),
    (lambda: SiemensStar(low=-1), "low", InvalidParameter),
    (lambda: SiemensStar(center=(0.0, math.nan)), "center[1]", InvalidParameter),
])
def test_new_textures_validate_every_field(make, name, error):
    with pytest.raises(error, match=name.replace("[", r"\[").replace("]", r"\]")) as e:
        make()
    if error is InvalidParameter:
        assert e.value.name == name


def _numeric_antiderivative(albedo, x):
    """The integral from 0 of albedo(X, 0) at each x, by the midpoint rule on 2e5 cells."""
    out = []
    for xi in x:
        n = 200_000
        t = (np.arange(n) + 0.5) * (xi / n)
        out.append(float(np.sum(albedo(t, np.zeros_like(t))) * (xi / n)))
    return np.array(out)


@pytest.mark.parametrize("tex", [
    SlantedEdge(), SlantedEdge(0.0), SlantedEdge(-30.0, 0.2, 0.7, (0.3, 0.5)),
    SlantedEdge(120.0, 0.9, 0.1, (-0.2, 0.4)), SlantedEdge(90.0, center=(0.1, -0.3)),
    SiemensStar(), SiemensStar(7, center=(0.05, 0.2)), SiemensStar(12, 0.0, 1.0, (0.1, -0.3)),
    SiemensStar(3, center=(0.2, 0.0)),
])
def test_the_row_y0_antiderivative_integrates_the_2d_albedo(tex):
    x = np.array([-1.3, -0.4, 0.25, 0.9, 2.0])
    want = _numeric_antiderivative(tex.albedo, x)
    got = tex.antiderivative(x)
    assert got.shape == x.shape
    np.testing.assert_allclose(got, want, atol=2e-5)
    assert tex.antiderivative(np.zeros(1))[0] == 0.0


def test_the_edge_and_star_follow_the_seam_conventions():
    edge = SlantedEdge(0.0, 0.1, 0.9)  # vertical edge, high towards +X
    assert edge.albedo(np.array([0.1, -0.1]), np.zeros(2)).tolist() == [0.9, 0.1]
    turned = SlantedEdge(90.0, 0.1, 0.9)  # horizontal edge: high below (the side of +X
    # after turning +Y towards +X by 90 degrees)
    assert turned.albedo(np.zeros(2), np.array([-0.1, 0.1])).tolist() == [0.9, 0.1]
    star = SiemensStar(4, 0.1, 0.9)  # sectors of 45 degrees, the first bright from +X
    t = np.radians([10.0, 55.0, 100.0, 190.0, 350.0])
    assert star.albedo(np.cos(t), np.sin(t)).tolist() == [0.9, 0.1, 0.9, 0.9, 0.1]
    assert edge.seam() == ("edge", [0.0, 0.1, 0.9, 0.0, 0.0], None)
    assert SiemensStar(5, 0.2, 0.8, (1, 2)).seam() == ("star", [5.0, 0.2, 0.8, 1.0, 2.0], None)
    assert Sinusoid(2.0, 0.5, 0.25, 1.0).seam() == ("sinusoid", [2.0, 0.5, 0.25, 1.0], None)
    assert BarChart(3.0, 0.2, 0.6).seam() == ("bars", [3.0, 0.2, 0.6], None)


def test_every_texture_has_a_mean():
    assert Sinusoid(1.0, 0.4, 0.2).mean == 0.4
    assert BarChart(1.0, 0.2, 0.6).mean == pytest.approx(0.4)
    assert SlantedEdge(low=0.2, high=0.6).mean == pytest.approx(0.4)
    assert SiemensStar(low=0.2, high=0.6).mean == pytest.approx(0.4)
    assert RandomAlbedo(low=0.2, high=0.6).mean == pytest.approx(0.4)
    assert Image(np.array([[0.0, 1.0], [1.0, 1.0]]), 2.0).mean == 0.75


def test_an_image_lies_centred_with_square_cells_row_0_at_the_top():
    a = np.arange(15.0).reshape(3, 5)
    img = Image(a, 10.0)
    kind, params, image = img.seam()
    assert kind == "image" and params == [-5.0, 5.0, -3.0, 3.0]
    np.testing.assert_array_equal(image, a)
    assert not img.array.flags.writeable
    with pytest.raises(InvalidParameter, match="width"):
        Image(a, 0.0)


def test_a_random_albedo_covers_the_extent_on_aligned_cells():
    tex = RandomAlbedo(cell=0.1, low=0.2, high=0.3)
    kind, params, image = tex.seam((-0.25, 0.31, -0.05, 0.12), 99.0,
                                   np.random.default_rng(1))
    assert kind == "image"
    np.testing.assert_allclose(params, [-0.3, 0.4, -0.1, 0.2])
    assert image.shape == (3, 7) and image.min() >= 0.2 and image.max() <= 0.3
    again = tex.seam((-0.25, 0.31, -0.05, 0.12), 99.0, np.random.default_rng(1))[2]
    np.testing.assert_array_equal(image, again)
    # default cell: the step given (delta(z) of the scene)
    params = RandomAlbedo().seam((0.0, 1.0, 0.0, 0.5), 0.25, np.random.default_rng(0))[1]
    assert params == [0.0, 1.0, 0.0, 0.5]
    with pytest.raises(TooLargeError, match="RandomAlbedo"):
        RandomAlbedo(cell=1e-6).seam((-50.0, 50.0, -50.0, 50.0), 1.0,
                                     np.random.default_rng(0))


@pytest.mark.parametrize("tex", [SlantedEdge(3.0), SiemensStar(8, center=(0.0, 0.05))])
def test_the_1d_simulation_reads_the_row_y0_of_the_new_textures(tex):
    pytest.importorskip("scipy")
    sim = splitlf.simulate(splitlf.Camera.paper(), 1500.0, tex, window=16, oversample=2,
                           mtf=False, conventional=False)
    x0, x1 = sim.x[0] - sim.delta / 2, sim.x[-1] + sim.delta / 2
    edges = np.linspace(x0, x1, sim.x.size + 1)
    np.testing.assert_allclose(sim.truth, np.diff(tex.antiderivative(edges)) / sim.delta,
                               atol=1e-12)


def test_the_texture_classes_are_the_simulations():
    from splitlf import simulation

    assert simulation.Sinusoid is textures.Sinusoid is splitlf.Sinusoid
    assert simulation.Image is textures.Image


# -- surfaces and scenes ------------------------------------------------------------------------

@pytest.mark.parametrize("make, name, error", [
    (lambda: Plane(0.0), "z0", InvalidParameter),
    (lambda: Plane(-10.0), "z0", InvalidParameter),
    (lambda: Plane(math.nan), "z0", InvalidParameter),
    (lambda: Plane(math.inf), "z0", InvalidParameter),
    (lambda: Plane("1000"), "z0", TypeError),
    (lambda: Plane(True), "z0", TypeError),
    (lambda: Plane(1000.0, gx=math.nan), "gx", InvalidParameter),
    (lambda: Plane(1000.0, gy=math.inf), "gy", InvalidParameter),
    (lambda: Plane(1000.0, gy=None), "gy", TypeError),
    (lambda: DepthMap(np.full((2, 2), 1e3), (0.0, 0.0, 0.0, 1.0)), "extent",
     InvalidParameter),
    (lambda: DepthMap(np.full((2, 2), 1e3), (0.0, 1.0, 1.0, 0.0)), "extent",
     InvalidParameter),
    (lambda: DepthMap(np.full((2, 2), 1e3), (0.0, 1.0, 0.0, math.nan)), "extent[3]",
     InvalidParameter),
    (lambda: DepthMap(np.full((2, 2), 1e3), (0.0, 1.0, 0.0)), "extent", TypeError),
    (lambda: DepthMap(np.array([[1e3, -1.0]]), (0.0, 1.0, 0.0, 1.0)), "depth",
     InvalidParameter),
    (lambda: DepthMap(np.array([[1e3, np.nan]]), (0.0, 1.0, 0.0, 1.0)), "depth",
     InvalidParameter),
    (lambda: DepthMap(np.full(3, 1e3), (0.0, 1.0, 0.0, 1.0)), "depth", InvalidParameter),
    (lambda: DepthMap(np.array([["a"]]), (0.0, 1.0, 0.0, 1.0)), "depth", TypeError),
    (lambda: DepthMap(np.full((2, 2), 1e3), (0, 1, 0, 1), confidence=np.ones(3)),
     "confidence", InvalidParameter),
    (lambda: DepthMap(np.full((2, 2), 1e3), (0, 1, 0, 1), confident=np.ones((2, 2))),
     "confident", InvalidParameter),
    (lambda: Scene(SlantedEdge(), 1000.0, background=-1.0), "background", InvalidParameter),
    (lambda: Scene(SlantedEdge(), 1000.0, background=math.nan), "background",
     InvalidParameter),
    (lambda: Scene(SlantedEdge(), "far"), "depth", TypeError),
    (lambda: Scene(SlantedEdge(), -5.0), "z0", InvalidParameter),
    (lambda: Scene("noise", 1000.0), "texture", TypeError),
    (lambda: Scene(lambda x: x, 1000.0), "texture", TypeError),
])
def test_surfaces_and_scenes_validate_every_field(make, name, error):
    with pytest.raises(error, match=name.split("[")[0]) as e:
        make()
    if error is InvalidParameter:
        assert e.value.name == name


def test_a_scene_holds_its_surface_and_background():
    s = Scene(SiemensStar(low=0.2, high=0.6), 800)
    assert s.depth == Plane(800.0) and s.background == pytest.approx(0.4)
    assert Scene("random", Plane(900.0, 0.01)).texture == RandomAlbedo()
    assert Scene(Image(np.ones((2, 2)), 1.0), 900.0, background=0).background == 0.0
    dm = DepthMap([[900.0, 950.0], [1000.0, 1100.0]], (-1, 1, -2, 2),
                  confidence=np.ones((2, 2)), confident=np.ones((2, 2), bool))
    assert dm.extent == (-1.0, 1.0, -2.0, 2.0) and not dm.depth.flags.writeable
    assert Scene(SlantedEdge(), dm).reference_depth() == 975.0
    assert dm.seam()[0] == "depthmap" and dm.seam()[1] == [-1.0, 1.0, -2.0, 2.0]
    assert Plane(900.0, 0.1, -0.2).seam() == ("plane", [900.0, 0.1, -0.2], None)
    assert DepthMap(np.ones((1, 1)), (0, 1, 0, 1)).confidence is None


# -- render -----------------------------------------------------------------------------------

SCENE = Scene(SlantedEdge(), 1000.0)


@pytest.mark.parametrize("kwargs, name, error", [
    ({"noise": {"photons": 0}}, "noise photons", InvalidParameter),
    ({"noise": {"photons": 100, "read_noise": -1}}, "noise read_noise", InvalidParameter),
    ({"noise": {"photons": 100, "gain": 2}}, "noise", ValueError),
    ({"noise": 100}, "noise", TypeError),
    ({"seed": -1}, "seed", InvalidParameter),
    ({"seed": 1.5}, "seed", TypeError),
    ({"n_threads": 0}, "n_threads", InvalidParameter),
    ({"progress": "yes"}, "progress", TypeError),
])
def test_render_validates_its_arguments_before_any_work(kwargs, name, error, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("the core was called")

    monkeypatch.setattr(_native, "render", boom, raising=False)
    with pytest.raises(error, match=name.split()[0]):
        render(small_seed(), SCENE, **kwargs)
    with pytest.raises(TypeError, match="design"):
        render("seed", SCENE)
    with pytest.raises(TypeError, match="scene"):
        render(small_seed(), SlantedEdge())


@pytest.mark.parametrize("design", [small_seed(), small_r12()], ids=["seed", "r12"])
def test_render_gives_one_raw_per_channel_in_the_layout(native, design):
    raw = render(design, Scene(SiemensStar(), Plane(1200.0, 0.02, -0.01)), progress=False)
    assert isinstance(raw, Raw) and raw.design == design
    assert [a.shape for a in raw.images] == shapes(design)
    for a in raw.images:
        assert a.dtype == np.float64 and not a.flags.writeable and np.all(np.isfinite(a))


def test_a_seed_gives_the_same_raw_bit_for_bit(native):
    d = small_seed()
    scene = Scene("random", 1000.0)
    noise = {"photons": 200.0, "read_noise": 2.0}
    a = render(d, scene, noise=noise, seed=7)
    b = render(d, scene, noise=noise, seed=7)
    c = render(d, scene, noise=noise, seed=8)
    for x, y, z in zip(a.images, b.images, c.images, strict=True):
        np.testing.assert_array_equal(x, y)
        assert not np.array_equal(x, z)


def test_the_noise_stream_does_not_depend_on_the_texture(native):
    """Noise is drawn from default_rng([seed, 1]): the same for any texture (the
    texture's cells come from default_rng([seed, 0]))."""
    d = small_seed()
    noise = {"photons": 100.0}
    clean = render(d, Scene(SlantedEdge(), 1000.0))
    noisy = render(d, Scene(SlantedEdge(), 1000.0), noise=noise, seed=3)
    rng = np.random.default_rng([3, 1])
    for c, n in zip(clean.images, noisy.images, strict=True):
        want = rng.poisson(np.maximum(c, 0.0) * 100.0).astype(np.float64) / 100.0
        np.testing.assert_array_equal(n, want)


def test_a_random_texture_is_drawn_from_the_texture_stream(native):
    d = small_seed()
    scene = Scene(RandomAlbedo(cell=0.5), 1000.0)
    seam = rendering._texture_seam(scene, d, np.random.default_rng([5, 0]))
    x0, x1, y0, y1 = seam[1]
    ext = _native.render_extent(d.core, 1000.0)
    assert x0 <= ext[0] and x1 >= ext[1] and y0 <= ext[2] and y1 >= ext[3]
    assert all(abs(v / 0.5 - round(v / 0.5)) < 1e-9 for v in seam[1])
    image = seam[2]
    assert image.shape == (round((y1 - y0) / 0.5), round((x1 - x0) / 0.5))
    np.testing.assert_array_equal(
        image, np.random.default_rng([5, 0]).uniform(0.0, 1.0, image.shape))
    # a slanted plane: the extent over its depths in view, wider than at z0
    tilted = rendering._random_extent(d, Plane(1000.0, 0.2, 0.0))
    assert tilted[1] > ext[1] and tilted[0] < ext[0]


@pytest.mark.skipif(not HAS_NATIVE, reason="the core checks the surface against F")
def test_a_surface_behind_the_main_lens_is_refused_by_the_core():
    d = small_seed()
    with pytest.raises(ValueError):
        render(d, Scene(SlantedEdge(), d.F * 0.5))


# -- Raw ---------------------------------------------------------------------------------------

def _images(design, seed=0):
    rng = np.random.default_rng(seed)
    return [rng.normal(0.3, 0.2, s) for s in shapes(design)]


def test_raw_wraps_checked_read_only_copies():
    d = small_seed()
    imgs = _images(d)
    raw = Raw(d, imgs)
    assert isinstance(raw.images, tuple) and len(raw.images) == 2
    imgs[0][0, 0] = 99.0
    assert raw.images[0][0, 0] != 99.0 and not raw.images[0].flags.writeable
    assert raw.channel(2) is raw.images[1]
    with pytest.raises(InvalidParameter, match="channel"):
        raw.channel(3)
    with pytest.raises(TypeError, match="channel"):
        raw.channel(1.0)
    ints = Raw(d, [np.zeros(s, dtype=np.int32) for s in shapes(d)])
    assert ints.images[0].dtype == np.float64


@pytest.mark.parametrize("mutate, name, error", [
    (lambda imgs: imgs[:1], "images", InvalidParameter),
    (lambda imgs: [*imgs, imgs[0]], "images", InvalidParameter),
    (lambda imgs: [imgs[0], imgs[1][:-1]], "images[1]", InvalidParameter),
    (lambda imgs: [imgs[0].T, imgs[1]], "images[0]", InvalidParameter),
    (lambda imgs: [imgs[0], imgs[1].ravel()], "images[1]", InvalidParameter),
    (lambda imgs: [np.where(np.arange(imgs[0].size).reshape(imgs[0].shape) == 5, np.nan,
                            imgs[0]), imgs[1]], "images[0]", InvalidParameter),
    (lambda imgs: [imgs[0], np.full(imgs[1].shape, np.inf)], "images[1]", InvalidParameter),
    (lambda imgs: [imgs[0].astype(object), imgs[1]], "images[0]", TypeError),
    (lambda imgs: np.stack(imgs), "images", TypeError),
    (lambda imgs: None, "images", TypeError),
])
def test_raw_refuses_images_that_do_not_fit_the_design(mutate, name, error):
    d = small_seed()
    with pytest.raises(error, match=name.replace("[", r"\[").replace("]", r"\]")) as e:
        Raw(d, mutate(_images(d)))
    if error is InvalidParameter:
        assert e.value.name == name
    with pytest.raises(TypeError, match="design"):
        Raw("seed", _images(d))


@pytest.mark.parametrize("design", [small_seed(), small_r12(), splitlf.Camera.paper()],
                         ids=["seed", "r12", "camera"])
def test_a_raw_file_round_trips_exactly(tmp_path, design):
    if isinstance(design, splitlf.Camera):
        imgs = [np.zeros(s) for s in shapes(design)]
        imgs[0][3, 4] = 1 / 3
    else:
        imgs = _images(design, 4)
    raw = Raw(design, imgs)
    path = tmp_path / "raw.npz"
    raw.save(path)
    back = Raw.load(path)
    assert back.design == design and type(back.design) is Design
    for a, b in zip(raw.images, back.images, strict=True):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes()
    with np.load(path, allow_pickle=False) as npz:
        assert sorted(npz.files) == sorted(["format", "design", *(
            f"channel{i}" for i in range(1, len(imgs) + 1))])
        assert str(npz["format"]) == "splitlf-raw/1"
        assert "[design]" in str(npz["design"])
    with pytest.raises(FileExistsError):
        raw.save(path, force=False)
    raw.save(path)  # force (the default) replaces it
    assert [p.name for p in tmp_path.iterdir()] == ["raw.npz"]


def test_an_interrupted_save_leaves_no_file(tmp_path, monkeypatch):
    d = small_seed()
    raw = Raw(d, _images(d))

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        raw.save(tmp_path / "raw.npz")
    assert list(tmp_path.iterdir()) == []


def _npz(path, **arrays):
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
    return path


def test_load_refuses_anything_that_is_not_a_raw_file(tmp_path):
    d = small_seed()
    good = {"format": np.array("splitlf-raw/1"), "design": np.array(d.to_toml()),
            **{f"channel{i}": a for i, a in enumerate(_images(d), 1)}}
    text = tmp_path / "notes.txt"
    text.write_text("hello\n")
    npy = tmp_path / "a.npy"
    np.save(npy, np.zeros(3))
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    cases = {
        text: "not a NumPy .npz archive",
        npy: "a .npy array",
        empty: "not a NumPy .npz archive",
        _npz(tmp_path / "noformat.npz", **{k: v for k, v in good.items() if k != "format"}):
            "needs format",
        _npz(tmp_path / "format2.npz", **{**good, "format": np.array("splitlf-raw/2")}):
            "needs format",
        _npz(tmp_path / "nodesign.npz", **{k: v for k, v in good.items() if k != "design"}):
            "no design",
        _npz(tmp_path / "baddesign.npz", **{**good, "design": np.array("[design\n")}):
            "not valid TOML",
        _npz(tmp_path / "camera.npz", **{**good, "design": np.array(
            splitlf.Camera.paper().to_toml())}): "one [design] table",
        _npz(tmp_path / "invalid.npz", **{**good, "design": np.array(
            d.to_toml().replace("F = 80.0", "F = -80.0"))}): "F",
        _npz(tmp_path / "missing.npz", **{k: v for k, v in good.items() if k != "channel2"}):
            "channel2",
        _npz(tmp_path / "extra.npz", **good, channel3=good["channel1"]): "channel3",
        _npz(tmp_path / "shape.npz", **{**good, "channel1": good["channel1"][:, :-1]}):
            "images[0]",
        _npz(tmp_path / "nan.npz", **{**good, "channel2": good["channel2"] * np.nan}):
            "images[1]",
        _npz(tmp_path / "pickled.npz", **{**good, "channel1": np.array([{}], dtype=object)}):
            "pickle",
        tmp_path: "a folder",
    }
    for path, what in cases.items():
        with pytest.raises(ValueError) as e:
            Raw.load(path)
        msg = str(e.value)
        assert msg.startswith(str(path)) and what in msg, (path.name, msg)
    with pytest.raises(FileNotFoundError):
        Raw.load(tmp_path / "nope.npz")
    assert Raw.load(_npz(tmp_path / "ok.npz", **good)).design == d


# -- the command line ---------------------------------------------------------------------------

@pytest.fixture
def design_file(tmp_path):
    path = tmp_path / "small.toml"
    small_seed().to_toml(path)
    return path


def _png(path, array):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.imsave(path, array, cmap="gray", vmin=0, vmax=1)


@pytest.mark.parametrize("texture, depth", [
    ("random", "1000"), ("sinusoid:2", "1000"), ("bars:1.5", "plane:1000,0.01,-0.02"),
    ("edge", "1200"), ("edge:10", "1200"), ("star", "1000"), ("star:12", "900"),
    ("IMG.npy", "1000"), ("IMG.png", "1000"), ("edge", "MAP.npy"),
])
def test_cli_render_writes_a_raw_file(native, tmp_path, capsys, design_file, texture, depth):
    extra = []
    if texture.startswith("IMG"):
        img = tmp_path / texture
        a = np.linspace(0, 1, 12).reshape(3, 4)
        np.save(img, a) if img.suffix == ".npy" else _png(img, a)
        texture, extra = str(img), ["--width", "20"]
    if depth == "MAP.npy":
        np.save(tmp_path / depth, np.full((4, 5), 1000.0) + np.arange(5))
        depth, extra = str(tmp_path / depth), ["--extent=-10,10,-8,8"]
    out = tmp_path / "raw.npz"
    code, stdout, err = _cli(["render", str(design_file), "--texture", texture, "--depth",
                              depth, "-o", str(out), *extra], capsys)
    assert (code, err) == (0, "") and stdout == f"{out}\n"
    raw = Raw.load(out)
    assert raw.design == small_seed() and [a.shape for a in raw.images] == shapes(raw.design)


def test_cli_render_with_a_preset_noise_png_and_json(native, tmp_path, capsys, monkeypatch):
    import json

    pytest.importorskip("matplotlib")
    # 4 x 3 lenses: its render (general route, three times) on 10 x 8 took 189 s; the
    # CLI's work is the same on fewer lenses.
    small = small_r12(4, 3)
    monkeypatch.setattr(Design, "preset", classmethod(lambda cls, name: small))
    out, png = tmp_path / "r.npz", tmp_path / "r.png"
    argv = ["render", "raytrix-r12", "--texture", "star:8", "--depth", "1000", "--out",
            str(out), "--png", str(png), "--noise", "500,3", "--seed", "4", "--threads",
            "1", "--json"]
    code, stdout, err = _cli(argv, capsys)
    assert (code, err) == (0, "")
    doc = json.loads(stdout)
    assert doc["path"] == str(out) and doc["png"] == str(png)
    assert doc["noise"] == {"photons": 500.0, "read_noise": 3.0} and doc["seed"] == 4
    assert doc["channels"][0]["shape"] == list(shapes(small)[0])
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    first = Raw.load(out).images[0]
    code, _, err = _cli(argv, capsys)  # exists: refused, nothing changed
    assert code == 2 and "pass --force to overwrite" in err
    code, _, _ = _cli([*argv, "--force"], capsys)
    assert code == 0 and Raw.load(out).images[0].tobytes() == first.tobytes()


@pytest.mark.parametrize("args, message", [
    (["--texture", "noise"], "--texture noise: allowed random[:CELL] (mm), sinusoid:F"),
    (["--texture", "sinusoid:x"], "--texture sinusoid:x:"),
    (["--texture", "sinusoid:-1"], "invalid frequency = -1.0"),
    (["--texture", "star:2.5"], "--texture star:2.5:"),
    (["--texture", "star:0"], "invalid spokes = 0"),
    (["--texture", "edge:nan"], "invalid angle = nan"),
    (["--texture", "random:x"], "--texture random:x:"),
    (["--texture", "random:-1"], "invalid cell = -1.0"),
    (["--texture", "{tmp}/img.npy"], "an image needs --width"),
    (["--texture", "{tmp}/nope.npy", "--width", "5"], "no such file: "),
    (["--texture", "{tmp}/small.toml.png", "--width", "5"], "no such file: "),
    (["--texture", "random", "--width", "5"], "--width: only with an image file"),
    (["--width", "0"], "invalid width '0'"),
    (["--depth", "abc"], "--depth abc: allowed 1 comma-separated finite number"),
    (["--depth", "-5"], "invalid z0 = -5.0"),
    (["--depth", "0"], "invalid z0 = 0.0"),
    (["--depth", "inf"], "--depth inf: allowed"),
    (["--depth", "plane:1000,0.1"], "--depth plane: 1000,0.1: allowed 3 comma-separated"),
    (["--depth", "plane:1000,nan,0"], "allowed 3 comma-separated finite numbers"),
    (["--depth", "{tmp}/map.npy"], "a depth map needs --extent"),
    (["--depth", "{tmp}/map.npy", "--extent", "1,0,0,1"], "invalid extent"),
    (["--depth", "{tmp}/map.npy", "--extent", "0,1,0"], "--extent 0,1,0: allowed 4"),
    (["--depth", "{tmp}/bad.npy", "--extent", "0,1,0,1"], "invalid depth[0, 1] = -1.0"),
    (["--extent", "0,1,0,1"], "--extent: only with a .npy depth map"),
    (["--noise", "0"], "--noise 0: invalid photon count '0'"),
    (["--noise", "100,-1"], "invalid read noise '-1'"),
    (["--noise", "100,x"], "invalid read noise 'x'"),
    (["--seed", "-1"], "invalid seed -1"),
    (["--threads", "0"], "invalid thread count 0"),
    (["-o", "{tmp}/raw.txt"], "--out {tmp}/raw.txt: allowed suffixes .npz"),
    (["--png", "{tmp}/raw.jpg"], "--png {tmp}/raw.jpg: allowed suffixes .png"),
    (["-o", "{tmp}/nofolder/raw.npz"], "does not exist"),
])
def test_cli_render_errors_are_one_line_and_write_nothing(native, tmp_path, capsys,
                                                         design_file, args, message):
    np.save(tmp_path / "img.npy", np.ones((2, 2)))
    np.save(tmp_path / "map.npy", np.full((2, 2), 1000.0))
    np.save(tmp_path / "bad.npy", np.array([[1000.0, -1.0]]))
    before = sorted(p.name for p in tmp_path.iterdir())
    base = {"--texture": "edge", "--depth": "1000", "-o": str(tmp_path / "raw.npz")}
    given = [a.replace("{tmp}", str(tmp_path)) for a in args]
    for k in list(base):
        if k in given:
            del base[k]
    argv = ["render", str(design_file), *[x for kv in base.items() for x in kv], *given]
    code, out, err = _cli(argv, capsys)
    assert (code, out) == (2, ""), err
    assert err.count("\n") == 1 and err.startswith("splitlf render: error: ")
    assert message.replace("{tmp}", str(tmp_path)) in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_render_design_errors(tmp_path, capsys):
    code, out, err = _cli(["render", str(tmp_path / "nope.toml"), "--texture", "edge",
                           "--depth", "1000", "-o", str(tmp_path / "r.npz")], capsys)
    assert (code, out) == (2, "") and err == (f"splitlf render: error: no such file: "
                                              f"{tmp_path / 'nope.toml'}\n")
    code, _, err = _cli(["render", "seed", "--depth", "1000", "-o", "r.npz"], capsys)
    assert code == 2 and "--texture" in err and err.count("\n") == 1
    code, _, err = _cli(["render", "seed", "--texture", "edge", "--depth", "1000"], capsys)
    assert code == 2 and "--out" in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


# -- the picture --------------------------------------------------------------------------------

def test_plot_raw_draws_each_channel_with_a_zoom():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    d = small_seed()
    a = np.zeros(shapes(d)[0])
    a[0, :] = 1.0  # row 0: drawn at the top
    raw = Raw(d, [a, np.full(shapes(d)[1], 0.5)])
    fig = splitlf.plot.raw(raw)
    assert isinstance(fig, Figure) and len(fig.axes) == 4
    first = fig.axes[0].get_images()[0]
    assert first.origin == "upper" and first.get_array()[0, 0] == 1.0
    assert "half 1" in fig.axes[0].get_title()
    zoom = fig.axes[1].get_images()[0].get_array()
    assert zoom.shape == (3 * 15, 3 * 15)
    plt.close(fig)
    _, ax = plt.subplots()
    r12 = small_r12()
    fig = splitlf.plot.raw(Raw(r12, [np.ones(shapes(r12)[0])]), channel=1, zoom=2, ax=ax)
    assert fig is ax.figure and len(ax.child_axes) == 1
    plt.close(fig)
    with pytest.raises(InvalidParameter, match="channel"):
        splitlf.plot.raw(raw, channel=3)
    with pytest.raises(InvalidParameter, match="zoom"):
        splitlf.plot.raw(raw, zoom=0)
    with pytest.raises(TypeError, match="raw"):
        splitlf.plot.raw(a)



# -- fuzz findings (docs/render.md) ----------------------------------------------------------

def tiny_seed() -> Design:
    """The seed on 4 x 3 lenses per channel (the fuzzer's cut)."""
    d = Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=4, Ky=3) for c in d.channels))


# Both routes' error bound on these scenes: tol (1e-3) of a fully lit pixel (1/2 on the
# seed's halves) under the scene's largest albedo (at most 1), twice (two renders).
TWO_TOL = 2 * 1e-3 * 0.5


def test_a_number_is_a_constant_texture_rendering_albedo_times_white():
    """Scene(0.3, z) is Constant(0.3): albedo x the white raw, exactly on the exact route
    (fully lit pixels of the seed's halves read 1/2 under white: 0.15) and to tol on the
    general route (a tilted plane)."""
    d = tiny_seed()
    assert Scene(0.3, 1000.0).texture == splitlf.Constant(0.3)
    white = render(d, Scene(splitlf.Constant(1.0), 1000.0))
    grey = render(d, Scene(0.3, 1000.0))
    for w, g in zip(white.images, grey.images, strict=True):
        np.testing.assert_allclose(g, 0.3 * w, rtol=1e-12, atol=1e-15)
        assert abs(g.max() - 0.15) < 1e-12
    tilted = render(d, Scene(0.3, Plane(1000.0, 0.2, 0.0)))
    for g in tilted.images:
        assert g.max() <= 0.15 + 0.3 * TWO_TOL
        assert abs(np.median(g[g > 0.1]) - 0.15) < 0.3 * TWO_TOL
    with pytest.raises(TypeError):
        Scene(True, 1000.0)
    with pytest.raises(InvalidParameter, match="albedo"):
        Scene(-1.0, 1000.0)


def test_one_spoke_star_is_the_upper_half_plane():
    """SiemensStar(spokes=1) is high where Y >= Y0: a SlantedEdge at -90 degrees
    ((X - X0) 0 - (Y - Y0)(-1) >= 0), by the definitions (it read 0.689 where white is
    0.5 on this cut before)."""
    d = tiny_seed()
    star = render(d, Scene(SiemensStar(spokes=1, low=0.1, high=0.9), 1000.0))
    edge = render(d, Scene(SlantedEdge(angle=-90.0, low=0.1, high=0.9), 1000.0))
    for s, e in zip(star.images, edge.images, strict=True):
        assert s.max() <= 0.9 * 0.5 + TWO_TOL
        np.testing.assert_allclose(s, e, rtol=0, atol=TWO_TOL)


@pytest.mark.parametrize("frequency", [1e-300, 1e-20, 1e-15])
def test_slow_sinusoid_is_its_value_at_the_origin(frequency):
    """A sinusoid of tiny frequency is mean + amplitude sin(phase) over the whole view
    (1e-20 rendered all black before, 1e-15 was 0.5 % off)."""
    d = tiny_seed()
    got = render(d, Scene(Sinusoid(frequency, 0.5, 0.4, 0.3), 1000.0))
    want = render(d, Scene(0.5 + 0.4 * math.sin(0.3), 1000.0))
    for g, w in zip(got.images, want.images, strict=True):
        np.testing.assert_allclose(g, w, rtol=0, atol=TWO_TOL)


def test_bar_charts_of_extreme_frequencies():
    """Bars far finer than a pixel's footprint read their mean (1e18 and up panicked
    before: capacity overflow); bars wider than the view are the edge at X = 0 (high on
    X >= 0: 5e-324 gave 1.45 x the brightest bar before)."""
    d = tiny_seed()
    mean = render(d, Scene(0.5, 1000.0))
    edge = render(d, Scene(SlantedEdge(angle=0.0, low=0.1, high=0.9), 1000.0))
    for f, want in [(1e18, mean), (1e300, mean), (5e-324, edge), (1e-300, edge)]:
        got = render(d, Scene(BarChart(f, 0.1, 0.9), 1000.0))
        for g, w in zip(got.images, want.images, strict=True):
            np.testing.assert_allclose(g, w, rtol=0, atol=TWO_TOL, err_msg=str(f))


@pytest.mark.parametrize("z", [1e22, 1e150, 1e200, 1e300])
def test_depths_beyond_the_bound_are_refused_by_name(z):
    """Depths beyond MAX_SCENE_DEPTH (1e9 mm) are refused naming z0 or the depth map and
    the range, before any work (they panicked, read the low albedo everywhere, or ended
    in a NaN raw blamed on images[0])."""
    d = tiny_seed()
    for tex in (BarChart(1.0), Sinusoid(0.5), SlantedEdge()):
        with pytest.raises(InvalidParameter, match=r"z0.*1e9\] mm"):
            render(d, Scene(tex, z))
    dm = DepthMap(np.full((3, 4), z), (-5.0, 5.0, -4.0, 4.0))
    with pytest.raises(InvalidParameter, match="depth_map"):
        render(d, Scene(SlantedEdge(), dm))


def test_random_albedo_of_tiny_cells_names_cell():
    with pytest.raises(InvalidParameter, match="cell"):
        render(tiny_seed(), Scene(RandomAlbedo(cell=1e-300), 1000.0))


def test_huge_image_albedo_names_the_array_not_the_background():
    with pytest.raises(InvalidParameter, match="Image.array") as e:
        Scene(Image(np.full((3, 4), 1e308), 4.0), 1000.0)
    assert "background" not in str(e.value)


def test_load_checks_declared_shapes_before_reading_the_arrays(tmp_path):
    """A small archive whose channel1.npy declares a 40,000 x 25,000 float64 array (8 GB)
    is refused from its header, naming the declared and the expected shape; no array is
    read (the payload is a few bytes, so reading it would fail differently)."""
    import zipfile

    d = tiny_seed()
    path = tmp_path / "liar.npz"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for key, value in (("format", np.array("splitlf-raw/1")),
                           ("design", np.array(d.to_toml()))):
            with z.open(f"{key}.npy", "w") as fh:
                np.lib.format.write_array(fh, value)
        for i in (1, 2):
            with z.open(f"channel{i}.npy", "w") as fh:
                header = {"descr": "<f8", "fortran_order": False, "shape": (40000, 25000)}
                np.lib.format.write_array_header_1_0(fh, header)
                fh.write(b"\0" * 64)
    with pytest.raises(ValueError, match=r"declares shape \(40000, 25000\)"):
        Raw.load(path)


def test_depth_map_and_raw_reprs_are_short():
    rng = np.random.default_rng(0)
    dm = DepthMap(1000 + rng.random((300, 400)), (-5.0, 5.0, -4.0, 4.0),
                  confident=rng.random((300, 400)) < 0.25)
    text = repr(dm)
    assert len(text) < 200 and "shape=(300, 400)" in text and "confident=" in text
    raw = Raw(tiny_seed(), [np.zeros(s) for s in shapes(tiny_seed())])
    assert len(repr(raw)) < 200 and "2 channel(s)" in repr(raw)
