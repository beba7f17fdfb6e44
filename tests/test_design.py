"""General designs (docs/model.md §9, docs/architectures.md): closed forms per channel and
lens type against the NumPy reference, the camera's design bit for bit, depth of field,
presets and their derived numbers, TOML, errors, pickling and the report."""

from __future__ import annotations

import json
import math
import pickle
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import reference as ref
import splitlf
from designs import OPTICS
from splitlf import Camera, Channel, Design, InvalidParameter
from splitlf.cli import main

CHANNEL_KEYS = ("main_blur", "repetitions", "conventional_px", "channel_blur_px")
TYPE_KEYS = ("microlens_blur", "blur_px")


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def multi() -> Design:
    """Three channels: a rect channel with two lens types, a hexagonal multi-focus channel
    (three types, Galilean like the R12) and a plain channel in Ng's setting."""
    rect = Channel(L=58.0, d=0.1, v=0.4, mu=0.005, Kx=30, Ky=20, f=(0.35, 0.42), Q=20,
                   share=0.3)
    hexa = Channel(L=56.86, d=0.12744, v=0.33713, mu=0.0055, Kx=20, Ky=16,
                   f=(0.58267, 0.52402, 0.56057), grid="hex", layout="sensor", share=0.4)
    plain = Channel(L=75.0, d=0.1, v=0.5, mu=0.01, Kx=10, Ky=10, Q=10, share=0.3)
    return Design(50.0, 12.0, (rect, hexa, plain), aperture="circle")


def all_designs() -> dict[str, Design]:
    out = {name: Design.preset(name) for name in splitlf.model.design.PRESETS}
    out["multi"] = multi()
    out["non_ng"] = OPTICS["non_ng"]().design
    return out


DESIGNS = all_designs()


def depths(design: Design, n: int = 4000, seed: int = 0) -> np.ndarray:
    """Log-spaced and random depths from just beyond F to 100 m, with every channel's
    out-of-focus plane and every lens type's focus depth exactly."""
    rng = np.random.default_rng(seed)
    F = design.F
    special = []
    for i in range(1, len(design.channels) + 1):
        special.append(design.out_of_focus_depth(i))
        special += [z for z in design.focus_depths(i) if z is not None]
    return np.concatenate([F * (1.0 + np.logspace(-6, 3.3, n // 2)),
                           np.exp(rng.uniform(np.log(F * 1.0001), np.log(1e5), n - n // 2)),
                           special])


# -- closed forms ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(OPTICS))
def test_camera_design_is_the_camera_bit_for_bit(name):
    cam = OPTICS[name]()
    z = depths(cam.design)
    a, b = splitlf.curves(cam, z), splitlf.curves(cam.design, z)
    assert b.channels == b.rows == ("channel 1", "channel 2")
    for key in ("conjugate", "main_blur", "repetitions", "microlens_blur", "blur_px",
                "conventional_px"):
        assert np.array_equal(bits(getattr(a, key)), bits(getattr(b, key))), key
    assert np.array_equal(bits(b.channel_blur_px), bits(a.blur_px))
    assert np.array_equal(bits(b.union_blur_px), bits(a.blur_px.min(axis=0)))
    for t in (0.5, 0.1, 2.0, 9.0):
        d1, d2 = splitlf.depth_of_field(cam, t), splitlf.depth_of_field(cam.design, t)
        assert d2.rows == ("channel 1", "channel 2", "union")
        assert d2["channel 1"] == d1.half1 and d2["channel 2"] == d1.half2
        assert d2.union == d2["union"] == d1.split
        assert d2.conventional == (d1.conventional1, d1.conventional2)


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_design_curves_match_reference(name):
    design = DESIGNS[name]
    z = depths(design)
    got = splitlf.curves(design, z)
    want = ref.design_curves(design, z)
    rows = want["rows"]
    assert len(got.rows) == len(rows) and got.channels == tuple(
        f"channel {i + 1}" for i in range(len(design.channels)))
    for c, t in rows:
        one = sum(1 for cc, _ in rows if cc == c) == 1
        assert got.rows[rows.index((c, t))] == (
            f"channel {c + 1}" if one else f"channel {c + 1} type {t + 1}")
    for key in ("conjugate", *CHANNEL_KEYS, *TYPE_KEYS, "union_blur_px"):
        g = getattr(got, key)
        assert g.shape == want[key].shape, key
        np.testing.assert_allclose(g, want[key], rtol=1e-12, atol=0, err_msg=key)
    np.testing.assert_array_equal(got.z, z)


def test_lens_type_is_sharp_at_its_focus_depth():
    design = DESIGNS["raytrix-r12"]
    zf = [z for z in design.focus_depths(1) if z is not None]
    assert len(zf) == 3
    c = splitlf.curves(design, zf)
    for k in range(3):
        assert c.microlens_blur[k, k] < 1e-12
        assert c.microlens_blur[(k + 1) % 3, k] > 1e-4


def test_curves_input_errors():
    d = DESIGNS["split3"]
    with pytest.raises(ValueError, match=r"z\[1\]"):
        splitlf.curves(d, [100.0, 80.0])
    with pytest.raises(ValueError, match="n_threads"):
        splitlf.curves(d, [100.0], n_threads=0)
    with pytest.raises(TypeError, match="design must be a splitlf.Design"):
        splitlf.curves(d.as_dict(), [100.0])
    empty = splitlf.curves(d, [])
    assert empty.blur_px.shape == (3, 0) and empty.union_blur_px.shape == (0,)
    base = splitlf.curves(d, depths(d, 500))
    for n in (1, 3):
        again = splitlf.curves(d, depths(d, 500), n_threads=n)
        assert np.array_equal(bits(again.union_blur_px), bits(base.union_blur_px))


# -- depth of field --------------------------------------------------------------------------

def _inside(intervals, z):
    z = np.asarray(z)
    m = np.zeros(z.shape, bool)
    for a, b in intervals:
        m |= (z > a) & (z < b)
    return m


def _row_blur(design: Design, z) -> dict[str, np.ndarray]:
    """Reference LF blur of every depth-of-field row: a lens type, a channel (its smallest
    type), the union (the smallest of all)."""
    r = ref.design_curves(design, z)
    rows = r["rows"]
    out = {}
    for c in range(len(design.channels)):
        own = [k for k, (cc, _) in enumerate(rows) if cc == c]
        if len(own) > 1:
            for k in own:
                out[f"channel {c + 1} type {rows[k][1] + 1}"] = r["blur_px"][k]
        out[f"channel {c + 1}"] = r["channel_blur_px"][c]
    if len(design.channels) > 1:
        out["union"] = r["union_blur_px"]
    return out


@pytest.mark.parametrize("name", sorted(DESIGNS))
@pytest.mark.parametrize("threshold", [0.5, 0.2, 2.0])
def test_dof_membership_by_sampling(name, threshold):
    """Membership in the closed-form intervals = sharpness by the reference blur, on
    200 000 log-spaced depths (away from the boundaries themselves)."""
    design = DESIGNS[name]
    dof = splitlf.depth_of_field(design, threshold)
    z = design.F * (1.0 + np.logspace(-5, 4, 200_000))
    blur = _row_blur(design, z)
    assert tuple(blur) == dof.rows
    conv = ref.design_curves(design, z)["conventional_px"]
    checks = [(dof[row], blur[row]) for row in dof.rows]
    checks += [(iv, conv[i]) for i, iv in enumerate(dof.conventional)]
    for iv, b in checks:
        ok = np.abs(b / threshold - 1.0) > 1e-6
        assert np.array_equal(_inside(iv, z)[ok], (b < threshold)[ok])
    assert dof.union == dof.intervals[-1]


@pytest.mark.parametrize("name", ["multi", "raytrix-r12", "split3"])
def test_dof_boundaries_hit_threshold(name):
    design = DESIGNS[name]
    dof = splitlf.depth_of_field(design, 0.5)
    for row, iv in zip(dof.rows, dof.intervals, strict=True):
        for near, far in iv:
            assert design.F <= near < far
            for bound in (near, far):
                if math.isinf(bound) or bound == design.F:
                    continue
                assert _row_blur(design, [bound])[row][0] == pytest.approx(0.5, rel=1e-7)


def test_dof_names_and_json():
    dof = splitlf.depth_of_field(DESIGNS["multi"])
    assert dof.rows == ("channel 1 type 1", "channel 1 type 2", "channel 1",
                        "channel 2 type 1", "channel 2 type 2", "channel 2 type 3",
                        "channel 2", "channel 3", "union")
    assert dof.channels == ("channel 1", "channel 2", "channel 3")
    d = dof.as_dict()
    assert list(d["light_field"]) == list(dof.rows)
    assert all(b is None or math.isfinite(b) for iv in d["light_field"].values()
               for _, b in iv)
    json.dumps(d, allow_nan=False)
    with pytest.raises(KeyError, match="channel 9"):
        dof["channel 9"]
    one = splitlf.depth_of_field(DESIGNS["raytrix-r12"])
    assert one.rows[-1] == "channel 1" and one.union == one["channel 1"]
    with pytest.raises(ValueError, match="threshold_px"):
        splitlf.depth_of_field(DESIGNS["multi"], 0.0)


# -- presets ---------------------------------------------------------------------------------

def test_presets_validate():
    assert splitlf.model.design.PRESETS == ("seed", "seed-plain", "split3", "raytrix-r12",
                                      "lytro-illum")
    for name in splitlf.model.design.PRESETS:
        d = Design.preset(name)
        assert sum(ch.share for ch in d.channels) <= 1.0 + 1e-12
        for ch in d.channels:
            # The aperture's image behind a lens fits in its image cell (the side of the
            # square image must fit the square cell, or the disc the hexagon's inscribed
            # circle; for a square image in a hexagon, its corner must).
            size, pitch = d.D * ch.v / ch.L, ch.d * (1 + ch.v / ch.L)
            if ch.grid == "rect" or d.aperture == "circle":
                assert size <= pitch
            else:
                assert size / 2 * (0.5 + math.sqrt(3) / 2) <= pitch / 2
        assert Design(d.F, d.D, d.channels, d.aperture) == d
    with pytest.raises(InvalidParameter, match="preset") as e:
        Design.preset("raytrix")
    assert e.value.name == "preset"
    with pytest.raises(TypeError, match="preset"):
        Design.preset(3)


def test_seed_presets():
    cam = Camera.paper()
    assert Design.preset("seed") == cam.design
    F, D, d, mu = 80.0, 20.0, 0.135, 0.009
    v1 = F * 642.0 / (642.0 - F)
    L2 = F * 217.0 / (217.0 - F)
    v = d * v1 / D
    plain = Design.preset("seed-plain")
    (ch,) = plain.channels
    assert (plain.F, plain.D, plain.aperture) == (F, D, "square")
    assert (ch.L, ch.d, ch.v, ch.mu, ch.Q, ch.Kx, ch.share) == (v1, d, v, mu, 15, 266, 1.0)
    assert ch.Ky == 2 * 88 and ch.Ky * d <= 24.0 and ch.f is None
    s3 = Design.preset("split3")
    kappa = L2 / v1 - 1.0
    planes = [c.L for c in s3.channels]
    assert planes[0] == v1 and planes[2] == pytest.approx(L2, rel=1e-15)
    assert planes[1] == pytest.approx(v1 * (1 + kappa / 2), rel=1e-15)
    assert planes[1] == pytest.approx((v1 + L2) / 2, rel=1e-15)
    assert all(c.Ky == math.floor(24.0 / 3 / d) == 59 for c in s3.channels)
    assert all(c.share == 1 / 3 for c in s3.channels)
    oof = [s3.out_of_focus_depth(i) for i in (1, 2, 3)]
    assert oof == pytest.approx([642.0, 300.30, 217.0], abs=0.005)
    # Interleaving: each channel's out-of-focus plane is sharp in both other channels.
    dof = splitlf.depth_of_field(s3)
    for i, z in enumerate(oof, 1):
        for j in (1, 2, 3):
            assert _inside(dof[f"channel {j}"], [z])[0] == (i != j)
    assert dof.union == [(80.0, math.inf)]


def test_raytrix_preset_derived_numbers():
    d = Design.preset("raytrix-r12")
    (ch,) = d.channels
    F, L, v, pitch, mu = 49.885, 56.860, 0.33713, 0.12744, 0.0055
    assert (d.F, ch.L, ch.v, ch.d, ch.mu) == (F, L, v, pitch, mu)
    assert ch.f == (0.58267, 0.52402, 0.56057)
    assert (ch.grid, ch.layout, ch.Kx, ch.Ky, ch.Mx, ch.My) == ("hex", "sensor", 176, 152,
                                                                4080, 3068)
    assert d.aperture == "circle" and ch.share == 1.0
    # D = d L / v: the aperture's image behind a lens, D v / L, is one pitch.
    D = pitch * L / v
    assert d.D == D and D == pytest.approx(21.494, abs=5e-4)
    assert d.f_number == pytest.approx(2.321, abs=5e-4)
    assert D * v / L == pytest.approx(pitch, rel=1e-15)
    # The micro-image pitch on the sensor, d (1 + v/L), is the published 23.3126 px.
    image_pitch_px = pitch * (1 + v / L) / mu
    assert image_pitch_px == pytest.approx(23.3126, rel=5e-4)
    # The plane imaged on the sensor (z' = L + v) lies at h = 450 mm from the sensor (the
    # calibration's focus configuration R12-A), to 1 %.
    s = L + v
    z_h = F * s / (s - F)
    assert z_h + s == pytest.approx(450.0, rel=0.01)
    # Out-of-focus plane and the depth each type is focused on (b_t = 0).
    assert d.out_of_focus_depth(1) == pytest.approx(F * L / (L - F), rel=1e-15)
    assert d.out_of_focus_depth(1) == pytest.approx(406.66, abs=0.005)
    want = []
    for f in ch.f:
        zc = L - 1.0 / (1.0 / f - 1.0 / v)
        want.append(F * zc / (zc - F))
    assert d.focus_depths(1) == pytest.approx(want, rel=1e-12)
    assert want == pytest.approx([369.95, 364.08, 368.08], abs=0.005)
    # Galilean: every type is focused on a virtual image behind the array (z' > L), so
    # on a depth nearer than the out-of-focus plane.
    assert all(z < d.out_of_focus_depth(1) for z in want)
    assert d.image_radius(1) / mu == pytest.approx(pitch / (2 * mu), rel=1e-14)


def test_lytro_preset_derived_numbers():
    d = Design.preset("lytro-illum")
    (ch,) = d.channels
    F, N, pitch, mu = 9.9845, 2.0, 0.020, 0.0014
    assert (d.F, ch.d, ch.mu, ch.Kx, ch.Ky, ch.Mx, ch.My) == (F, pitch, mu, 541, 434,
                                                              7728, 5368)
    assert (ch.grid, ch.layout, ch.f, d.aperture, ch.share) == ("hex", "sensor", None,
                                                                "circle", 1.0)
    D = F / N
    assert d.D == D and d.f_number == N
    # Focused at the hyperfocal distance H = F^2 / (N c) + F with c = d.
    H = F * F / (N * pitch) + F
    assert ch.L == pytest.approx(F * H / (H - F), rel=1e-14)
    assert ch.L == pytest.approx(F + N * pitch, rel=1e-15)
    assert d.out_of_focus_depth(1) == pytest.approx(H, rel=1e-12)
    assert H == pytest.approx(2502.24, abs=0.005)
    # v = d L / D: microlens images one pitch wide, 7.14 px in radius (7.172 px published).
    assert ch.v == pytest.approx(pitch * ch.L / D, rel=1e-15)
    assert ch.v == pytest.approx(0.040160, abs=5e-7)
    assert d.image_radius(1) / mu == pytest.approx(pitch / (2 * mu), rel=1e-14)
    assert d.image_radius(1) / mu == pytest.approx(7.172, rel=0.005)
    # The hexagonal rows fill the sensor: 434 rows of pitch d sqrt(3)/2 and 541 lenses of
    # pitch d match 5368 and 7728 pixels of 1.4 um to 0.1 %.
    assert 434 * pitch * math.sqrt(3) / 2 == pytest.approx(5368 * mu, rel=1e-3)
    assert 541 * pitch == pytest.approx(7728 * mu, rel=1e-3)
    (row,) = d.resolved()
    assert row["ng"] and row["f"][0] == pytest.approx(ref.ng_focal(ch.L, ch.v), rel=1e-15)
    assert d.focus_depths(1) == [None]


def _hex_cover_numpy(L, d, v, mu, kx, ky):
    """(M_x, M_y) of the smallest axis-centred grid holding every hex image cell, and M_x
    of a grid as wide as the cells' bounding box, from the lattice of docs/model.md §9
    (row k shifted by k mod 2 halves, centres mean-centred) in plain NumPy."""
    j, k = np.meshgrid(np.arange(kx), np.arange(ky), indexing="ij")
    x = j + (k % 2) / 2.0
    y = k * math.sqrt(3) / 2
    p = d * (1 + v / L)
    x, y = (x - x.mean()) * p, (y - y.mean()) * p
    # Pointy-top hexagon of pitch p: flat sides p/2 either side, corners p/sqrt(3) up.
    lo_x, hi_x = (x - p / 2).min(), (x + p / 2).max()
    hi_y = np.abs(y).max() + p / math.sqrt(3)
    mx = math.ceil(2 * max(-lo_x, hi_x) / mu)
    my = math.ceil(2 * hi_y / mu)
    return mx, my, math.ceil((hi_x - lo_x) / mu)


@pytest.mark.parametrize("kx, ky, want", [(6, 5, 134), (8, 7, 173), (6, 6, 132),
                                          (8, 8, 172), (7, 1, 142)])
def test_default_hex_sensor_covers_every_image_cell(kx, ky, want):
    # The mean-centred lattice of an odd number of rows sits (1/2 - floor(Ky/2)/Ky) d/2
    # off its bounding box's centre: a centred grid as wide as the box missed a sliver on
    # one side (6 x 5: 132 columns, 8 x 7: 172). Even Ky and one row are symmetric.
    L, d, v, mu = 60.0, 0.1, 0.3, 0.00498
    ch = Channel(L=L, d=d, v=v, mu=mu, Kx=kx, Ky=ky, grid="hex", layout="sensor")
    (row,) = Design(50.0, 10.0, (ch,)).resolved()
    mx, my, box = _hex_cover_numpy(L, d, v, mu, kx, ky)
    assert (row["Mx"], row["My"]) == (mx, my)
    assert row["Mx"] == want
    assert box == (want if ky % 2 == 0 or ky == 1 else {5: 132, 7: 172}[ky])


# -- TOML, dicts, pickling --------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_toml_round_trip(name, tmp_path):
    d = DESIGNS[name]
    p = tmp_path / "d.toml"
    text = d.to_toml(p)
    assert p.read_text(encoding="utf-8") == text
    assert Design.from_toml(p) == d
    assert Design.from_dict(d.as_dict()) == d
    assert not list(tmp_path.glob(".*tmp*"))


finite = dict(allow_nan=False, allow_infinity=False)


@st.composite
def designs(draw):
    F = draw(st.floats(5.0, 200.0, **finite))
    D = draw(st.floats(1.0, 60.0, **finite))
    n = draw(st.integers(1, 3))
    shares = draw(st.lists(st.floats(0.01, 1.0 / n, **finite), min_size=n, max_size=n))
    aperture = draw(st.sampled_from(["square", "circle"]))
    channels = []
    for share in shares:
        grid = draw(st.sampled_from(["rect", "hex"]))
        L = F * draw(st.floats(1.001, 4.0, **finite))
        d = draw(st.floats(0.005, 0.5, **finite))
        # v below d L / D keeps the aperture's image inside the cell (a square image in a
        # hexagon needs its corner inside: a factor 0.7 more).
        v = d * L / D * draw(st.floats(0.05, 0.7, **finite))
        mu = d / draw(st.floats(2.0, 30.0, **finite))
        T = draw(st.sampled_from([1, 3] if grid == "hex" else [1, 2, 3]))
        f = draw(st.one_of(st.none(), st.lists(st.floats(0.001, 10.0, **finite),
                                               min_size=T, max_size=T).map(tuple)))
        layout = "ideal" if grid == "rect" and draw(st.booleans()) else "sensor"
        kw = {}
        if layout == "ideal":
            kw["Q"] = draw(st.integers(1, 40))
        elif draw(st.booleans()):
            kw["Mx"], kw["My"] = draw(st.integers(1, 5000)), draw(st.integers(1, 5000))
        channels.append(Channel(L=L, d=d, v=v, mu=mu, Kx=draw(st.integers(2, 300)),
                                Ky=draw(st.integers(2, 300)), f=f, grid=grid,
                                layout=layout, share=share, **kw))
    try:
        return Design(F, D, tuple(channels), aperture)
    except InvalidParameter:
        assume(False)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(design=designs())
def test_toml_round_trip_random(design):
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "design.toml"
        design.to_toml(p)
        back = Design.from_toml(p)
    assert back == design
    assert back.to_toml() == design.to_toml()
    assert pickle.loads(pickle.dumps(design)) == design


def test_pickling():
    for d in DESIGNS.values():
        back = pickle.loads(pickle.dumps(d))
        assert back == d and hash(back) == hash(d)
        z = [d.F * 2, d.F * 10]
        assert np.array_equal(splitlf.curves(back, z).blur_px, splitlf.curves(d, z).blur_px)
    ch = DESIGNS["multi"].channels[1]
    assert pickle.loads(pickle.dumps(ch)) == ch
    dof = splitlf.depth_of_field(DESIGNS["multi"])
    assert pickle.loads(pickle.dumps(dof)) == dof


@pytest.mark.parametrize("edit, exc, needle", [
    (lambda t: "[camera]\nF = 80.0\n", ValueError, "needs a [design] table"),
    (lambda t: t.replace("[design]", "[designs]"), ValueError,
     "unknown top-level key(s) ['designs']"),
    (lambda t: t + "\n[camera]\nF = 1\n", ValueError, "unknown top-level key(s) ['camera']"),
    (lambda t: t.replace("aperture =", "shape ="), ValueError, "unknown design field(s)"),
    (lambda t: t.replace("F = 80.0", ""), ValueError, "missing design field(s) ['F']"),
    (lambda t: t.replace("Kx = 266", "Kx = 266\nKz = 3", 1), ValueError,
     "channels[1]: unknown channel field(s) ['Kz']"),
    (lambda t: t.replace("mu = 0.009", "", 1), ValueError,
     "channels[1]: missing channel field(s) ['mu']"),
    (lambda t: t.replace("Ky = 59", 'Ky = "59"', 1), TypeError,
     "channels[1]: Channel.Ky must be an integer"),
    (lambda t: t.replace("share = 0.3333333333333333", "share = 0.6"), InvalidParameter,
     "invalid share = a total of"),
    (lambda t: t.replace("L = 109.05161441151259", "L = 70.0"), InvalidParameter,
     "invalid channels[2].L = 70"),
    (lambda t: t.replace("[design]", "[design\n"), ValueError, "not valid TOML"),
])
def test_toml_errors_name_file_and_key(tmp_path, edit, exc, needle):
    p = tmp_path / "bad.toml"
    p.write_text(edit(Design.preset("split3").to_toml()), encoding="utf-8")
    with pytest.raises(exc) as e:
        Design.from_toml(p)
    assert str(e.value).startswith(str(p)) and needle in str(e.value), str(e.value)


def test_from_dict_errors():
    good = DESIGNS["multi"].as_dict()
    with pytest.raises(TypeError, match="expected a table of design fields"):
        Design.from_dict([good])
    with pytest.raises(TypeError, match="channels must be a list"):
        Design.from_dict({**good, "channels": good["channels"][0]})
    with pytest.raises(TypeError, match=r"design: channels\[2\]: expected a table"):
        Design.from_dict({**good, "channels": [good["channels"][0], 3]})
    bad = {**good, "channels": [{**good["channels"][0], "L": math.inf}]}
    with pytest.raises(InvalidParameter, match=r"channels\[1\]") as e:
        Design.from_dict(bad)
    assert e.value.name == "channels[1].L"


# -- invalid designs ---------------------------------------------------------------------------

def _seed_channel(**changes) -> Channel:
    return Design.preset("seed").channels[0].replace(**changes)


@pytest.mark.parametrize("make, name, allowed", [
    (lambda: Design(80.0, 20.0, (_seed_channel(L=80.0),)), "channels[1].L", "> F = 80"),
    (lambda: Design(80.0, 20.0, (_seed_channel(L=60.0),)), "channels[1].L", "> F = 80"),
    (lambda: Design(80.0, 20.0, (_seed_channel(share=-0.5),)), "channels[1].share",
     "(0, 1]"),
    (lambda: Design(80.0, 20.0, (_seed_channel(share=0.6), _seed_channel(share=0.6))),
     "share", "sum to at most 1"),
    (lambda: Design(50.0, 10.0, (Channel(L=60.0, d=0.1, v=0.3, mu=0.005, Kx=9, Ky=8,
                                         f=(0.3, 0.31), grid="hex", layout="sensor"),)),
     "channels[1].f", "1 or >= 3 lens types on a hex grid"),
    (lambda: Design(50.0, 10.0, (Channel(L=60.0, d=0.1, v=0.3, mu=0.005, Kx=9, Ky=8,
                                         grid="hex", Q=5),)),
     "channels[1].layout", '"sensor" on a hex grid'),
    (lambda: Design(80.0, 20.0, (_seed_channel(v=2 * 0.135 * 91.4 / 20.0),)),
     "channels[1].D", "neighbouring microlens images overlap"),
])
def test_bad_designs_raise_named_errors(make, name, allowed):
    with pytest.raises(InvalidParameter) as e:
        make()
    assert e.value.name == name and allowed in e.value.allowed, str(e.value)
    assert name in str(e.value)


def test_channel_arguments():
    d = DESIGNS["split3"]
    with pytest.raises(InvalidParameter, match=r"channel = 4: allowed an integer in \[1, 3\]"):
        d.out_of_focus_depth(4)
    with pytest.raises(TypeError, match="channel must be an integer"):
        d.image_radius(True)
    with pytest.raises(TypeError, match="channel must be an integer"):
        d.focus_depths(1.0)


# -- report and CLI -----------------------------------------------------------------------------

def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("name", splitlf.model.design.PRESETS)
def test_report_preset_json(name, capsys):
    code, out, err = run(["report", "--preset", name, "--json"], capsys)
    assert code == 0 and err == ""
    data = json.loads(out)
    d = Design.preset(name)
    assert data["source"] == f"preset {name}"
    assert Design.from_dict(data["design"]) == d
    for i, ch in enumerate(data["derived"]["channels"], 1):
        assert ch["out_of_focus_depth_mm"] == d.out_of_focus_depth(i)
        assert [t["focus_depth_mm"] for t in ch["lens_types"]] == d.focus_depths(i)
    dof = splitlf.depth_of_field(d)
    assert data["depth_of_field"] == json.loads(json.dumps(dof.as_dict()))


def test_report_preset_text(capsys):
    code, out, err = run(["report", "--preset", "split3", "--full"], capsys)
    assert code == 0 and err == ""
    assert out.startswith("splitlf report: preset split3\n")
    for needle in ("642.00 mm", "300.30 mm", "217.00 mm", "union (any channel)",
                   "80.0 - inf", "Channel 3: share 0.333333"):
        assert needle in out, needle
    code, out, _ = run(["report", "--preset", "raytrix-r12", "--threshold", "1", "--full"],
                       capsys)
    assert "lens type 2: f" in out and "focused at z = 364.08 mm" in out
    assert "channel 1 type 3 (light field)" in out and "blur < 1 px" in out


def test_report_design_config(tmp_path, capsys):
    p = tmp_path / "d.toml"
    DESIGNS["multi"].to_toml(p)
    code, out, _ = run(["report", "--config", str(p), "--json"], capsys)
    assert code == 0 and Design.from_dict(json.loads(out)["design"]) == DESIGNS["multi"]
    code, out, err = run(["report", "--config", str(p), "--preset", "seed"], capsys)
    assert code == 2 and out == "" and "give one of them" in err
    with pytest.raises(SystemExit) as e:
        main(["report", "--preset", "nope"])
    assert e.value.code == 2 and "invalid choice: 'nope'" in capsys.readouterr().err
    p.write_text(DESIGNS["multi"].to_toml().replace("L = 75.0", "L = 40.0"))
    code, out, err = run(["report", "--config", str(p)], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert f"{p}: invalid channels[3].L = 40" in err


def test_fields_of_the_wrong_type_are_named_before_missing_ones():
    # issue 20's fuzz: a file with a wrongly typed field that also lacks others was
    # reported only as missing.
    with pytest.raises(TypeError, match=r"camera: Camera\.Q must be an integer"):
        splitlf.Camera.from_dict({"F": 80.0, "Q": 1.5})
    with pytest.raises(TypeError, match=r"channels\[1\]: Channel\.Kx must be an integer"):
        splitlf.Design.from_dict({"F": 80.0, "D": 10.0, "channels": [{"L": 90.0, "Kx": "a"}]})
    with pytest.raises(ValueError, match=r"missing channel field\(s\) \['d', 'v'"):
        splitlf.Design.from_dict({"F": 80.0, "D": 10.0, "channels": [{"L": 90.0, "Kx": 3}]})


@pytest.mark.parametrize("f", [{1.0: 2}, {0.5, 0.6}, frozenset([0.5])])
def test_unordered_focal_lengths_are_refused(f):
    # A dict's keys (or a set) would be taken as the lens types in no defined order.
    with pytest.raises(TypeError, match="Channel.f must be"):
        splitlf.Channel(90.0, 0.1, 0.5, 0.01, 3, 3, f=f)


def test_masked_depths_are_refused_not_silently_unmasked():
    z = np.ma.masked_array([500.0, 600.0], [0, 1])
    with pytest.raises(splitlf.InvalidParameter, match="masked"):
        splitlf.curves(splitlf.Camera.paper(), z)
    full = np.ma.masked_array([500.0, 600.0], [0, 0])
    assert splitlf.curves(splitlf.Camera.paper(), full).z.tolist() == [500.0, 600.0]


def test_one_depth_message_counts_what_was_given():
    with pytest.raises(splitlf.InvalidParameter) as e:
        splitlf.sample_grid(splitlf.Camera.paper(), [500.0, 600.0], 1)
    assert e.value.value == 2 and "2 depths given, allowed one depth" in str(e.value)
