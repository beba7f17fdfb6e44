"""splitlf.export and `splitlf export` (issue 50, docs/export.md): the micro-image centres
against a plain NumPy derivation from docs/model.md §9-§10, their round trip through each
target's calibration file to 1e-9 px, the 16-bit images' round trip to one DN, the white
image, the sidecar, the ground truth, the command line, and bad input."""

from __future__ import annotations

import csv
import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from _cli import run_cli, small_raw

import splitlf
from reference import lens_centres
from splitlf.errors import InvalidParameter
from splitlf.exchange import formats

pytest.importorskip("tifffile")
pytest.importorskip("PIL")
import tifffile  # noqa: E402
from PIL import Image  # noqa: E402

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 (the tomli backport)
    import tomli as tomllib

TOL_PX = 1e-9


def lytro_cut(kx: int = 12, ky: int = 10, **changes) -> splitlf.Design:
    d = splitlf.Design.preset("lytro-illum")
    return d.replace(channels=(d.channels[0].replace(Kx=kx, Ky=ky, Mx=None, My=None,
                                                     **changes),))


def seed_cut(kx: int = 6, ky: int = 4) -> splitlf.Design:
    d = splitlf.Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=kx, Ky=ky) for c in d.channels))


def rect_sensor() -> splitlf.Design:
    """A rect array on a uniform sensor grid (one given smaller than the default cover, so
    that some centres fall off the raw)."""
    d = splitlf.Design.preset("seed-plain")
    return d.replace(channels=(d.channels[0].replace(Kx=7, Ky=5, layout="sensor", Q=None,
                                                     Mx=60, My=40),))


def reference_centres(design: splitlf.Design, channel: int) -> np.ndarray:
    """[row, column, k, j] per lens, lattice rows first, from docs/model.md alone: the
    chief ray through the main lens's centre and lens centre c meets the sensor at
    s = c (1 + v/L) (§9 "Lattices", §10 "Rays" with w = 0); the sensor layout's pixel
    (m_x, m_y) is centred at mu (m - (M - 1)/2) (§9 "Pixel layouts"); the ideal layout's
    Q x Q block of lens (j, k) starts at [k Q, j Q] (§10 "Raw layout")."""
    ch = design.resolved()[channel - 1]
    c = lens_centres(ch)  # (Ky, Kx, 2) on the array plane
    k, j = np.meshgrid(np.arange(ch["Ky"]), np.arange(ch["Kx"]), indexing="ij")
    if ch["layout"] == "ideal":
        q = ch["Q"]
        row, col = k * q + (q - 1) / 2, j * q + (q - 1) / 2
    else:
        s = c * (1 + ch["v"] / ch["L"])
        col = s[..., 0] / ch["mu"] + (ch["Mx"] - 1) / 2
        row = s[..., 1] / ch["mu"] + (ch["My"] - 1) / 2
    return np.stack([row, col, k, j], axis=-1).reshape(-1, 4).astype(np.float64)


def on_raw(centres: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    r, c = centres[:, 0], centres[:, 1]
    return centres[(r >= -0.5) & (r < shape[0] - 0.5) & (c >= -0.5) & (c < shape[1] - 0.5)]


@pytest.fixture(scope="module")
def hex_raw() -> splitlf.Raw:
    """A noisy lytro-illum cut of 12 x 10 lenses (a slanted edge of albedos 0.1 and 0.6,
    photon noise N = 500, no read noise: nothing below 0 or above the white level)."""
    return splitlf.render(lytro_cut(), splitlf.Scene(splitlf.SlantedEdge(high=0.6), 1000.0),
                          noise={"photons": 500.0}, seed=3, progress=False)


@pytest.fixture(scope="module")
def seed_raw() -> splitlf.Raw:
    """The seed's two halves cut to 6 x 4 lenses, noise-free (the exact route)."""
    return splitlf.render(seed_cut(), splitlf.Scene(splitlf.Sinusoid(0.1), 800.0),
                          progress=False)


# -- the centres ---------------------------------------------------------------------------------

@pytest.mark.parametrize("design", [lytro_cut(), lytro_cut(9, 7), seed_cut(), rect_sensor(),
                                    splitlf.Design.preset("raytrix-r12")],
                         ids=["hex", "hex-odd-rows", "ideal", "rect-sensor", "raytrix-r12"])
def test_micro_image_centres_are_the_chief_ray_through_each_lens(design):
    for i in range(1, len(design.channels) + 1):
        got = design.micro_image_centers(i)
        want = reference_centres(design, i)
        assert got.shape == want.shape and got.dtype == np.float64
        np.testing.assert_array_equal(got[:, 2:], want[:, 2:])
        assert np.abs(got[:, :2] - want[:, :2]).max() < TOL_PX


@pytest.mark.parametrize("design", [lytro_cut(), seed_cut(), rect_sensor(), lytro_cut(1, 1)],
                         ids=["hex", "ideal", "rect-sensor", "one-lens"])
def test_micro_image_steps_are_the_lattice_steps_in_pixels(design):
    ch = design.resolved()[0]
    if ch["layout"] == "ideal":
        want = (ch["Q"], ch["Q"])
    else:  # the image pitch d (1 + v/L) of §9 in pixels; hex rows sqrt(3)/2 of it apart
        p = ch["d"] * (1 + ch["v"] / ch["L"]) / ch["mu"]
        want = (p * math.sqrt(3) / 2 if ch["grid"] == "hex" else p, p)
    assert design.micro_image_steps(1) == pytest.approx(want, rel=1e-14)


def test_a_one_lens_array_exports(tmp_path):
    raw = splitlf.render(lytro_cut(1, 1), splitlf.Scene(0.5, 1000.0), progress=False)
    splitlf.export(raw, "plenopticam", tmp_path / "out")
    cal = json.loads((tmp_path / "out" / "ch1" / "white.json").read_text())
    assert len(cal["mic_list"]) == 1 and cal["mic_list"][0][2:] == [0, 0]
    assert cal["ptc_mean"] == pytest.approx(list(raw.design.micro_image_steps(1)))


def test_centres_of_a_bad_channel_are_refused():
    d = lytro_cut()
    with pytest.raises(InvalidParameter, match="channel"):
        d.micro_image_centers(2)
    with pytest.raises(TypeError):
        d.micro_image_centers("1")


# -- round trips -----------------------------------------------------------------------------

def _image_pitch_px(design: splitlf.Design, i: int) -> float:
    ch = design.resolved()[i - 1]
    if ch["layout"] == "ideal":
        return float(ch["Q"])
    return ch["d"] * (1 + ch["v"] / ch["L"]) / ch["mu"]


def test_plenopticam_calibration_round_trip(tmp_path, hex_raw):
    done = splitlf.export(hex_raw, "plenopticam", tmp_path / "out")
    cal = json.loads((tmp_path / "out" / "ch1" / "white.json").read_text())
    assert sorted(cal) == ["mic_list", "pat_type", "ptc_mean"]  # PlenoptiCam's CALIBS_KEYS
    got = np.array(cal["mic_list"], dtype=np.float64)
    want = reference_centres(hex_raw.design, 1)  # the default sensor covers every lens
    assert got.shape == want.shape
    np.testing.assert_array_equal(got[:, 2:], want[:, 2:])
    assert np.abs(got[:, :2] - want[:, :2]).max() < TOL_PX
    p = _image_pitch_px(hex_raw.design, 1)
    assert cal["pat_type"] == "hex"
    np.testing.assert_allclose(cal["ptc_mean"], [p * math.sqrt(3) / 2, p], rtol=0, atol=TOL_PX)
    assert done.sidecar["channels"][0]["centres"] == {"written": 120, "off_the_raw": 0}


def test_plenpy_grid_round_trip(tmp_path, hex_raw):
    splitlf.export(hex_raw, "plenpy", tmp_path / "out")
    ch = tmp_path / "out" / "ch1"
    assert (ch / "Images" / "raw.png").is_file() and (ch / "Calibration" / "white.png").is_file()
    with np.load(ch / "Calibration" / "grid.npz", allow_pickle=False) as g:
        want = reference_centres(hex_raw.design, 1)
        assert np.abs(g["grid_points"] - want[:, :2]).max() < TOL_PX
        p = _image_pitch_px(hex_raw.design, 1)
        # plenpy's hex rows lie 1/2 spacing_x apart: spacing_x = sqrt(3) p, spacing_y = p
        np.testing.assert_allclose(g["grid_parameters_spacing"], [math.sqrt(3) * p, p],
                                   rtol=0, atol=1e-9)
        assert list(g["grid_parameters_size"]) == list(hex_raw.images[0].shape)
        np.testing.assert_array_equal(g["grid_parameters_offset"], g["grid_points"][0])
        assert (int(g["n"]), int(g["m"])) == (10, 12) and float(g["crop_amount"]) == 0.0
        assert not g["noise"].any() and float(g["grid_parameters_rotation"]) == 0.0


def test_tiff_target_centres_csv_round_trip_and_off_the_raw(tmp_path):
    d = rect_sensor()
    raw = splitlf.render(d, splitlf.Scene(0.5, 900.0), progress=False)
    done = splitlf.export(raw, "tiff", tmp_path / "out")
    with open(tmp_path / "out" / "ch1" / "centres.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["row", "column", "k", "j"]
    got = np.array(rows[1:], dtype=np.float64)
    want = on_raw(reference_centres(d, 1), raw.images[0].shape)
    assert 0 < len(want) < 35  # the 60 x 40 sensor cuts some of the 7 x 5 lenses off
    assert got.shape == want.shape and np.abs(got - want).max() < TOL_PX
    assert done.sidecar["channels"][0]["centres"] == {"written": len(want),
                                                      "off_the_raw": 35 - len(want)}


def test_images_round_trip_to_one_dn_and_the_default_scale(tmp_path, seed_raw):
    done = splitlf.export(seed_raw, "tiff", tmp_path / "out")
    white = splitlf.render(seed_raw.design, splitlf.Scene(1.0, 3000.0), progress=False)
    scale = done.sidecar["scale"]["dn_per_unit"]
    # the default: the white image's brightest pixel at the 16-bit white level
    assert scale == pytest.approx(65535 / max(float(a.max()) for a in white.images), rel=1e-12)
    for i in (1, 2):
        dn = tifffile.imread(tmp_path / "out" / f"ch{i}" / "raw.tiff")
        assert dn.dtype == np.uint16 and dn.shape == seed_raw.images[i - 1].shape
        assert np.abs(dn - seed_raw.images[i - 1] * scale).max() <= 0.5
        wdn = tifffile.imread(tmp_path / "out" / f"ch{i}" / "white.tiff")
        # the white of a scene at another depth: a uniform white looks the same from anywhere
        assert np.abs(wdn - white.images[i - 1] * scale).max() <= 0.5 + 1e-6
    assert done.clipped == 0


def test_plenopticam_images_are_rgb_and_png_round_trips(tmp_path, hex_raw):
    splitlf.export(hex_raw, "plenopticam", tmp_path / "a", scale=40000.0)
    rgb = tifffile.imread(tmp_path / "a" / "ch1" / "raw.tiff")
    assert rgb.shape == (*hex_raw.images[0].shape, 3)
    assert (rgb == rgb[..., :1]).all()
    want = np.clip(hex_raw.images[0] * 40000.0, 0, 65535)
    assert np.abs(rgb[..., 0] - want).max() <= 0.5
    splitlf.export(hex_raw, "plenpy", tmp_path / "b", scale=40000.0)
    with Image.open(tmp_path / "b" / "ch1" / "Images" / "raw.png") as im:
        png = np.asarray(im).astype(np.uint16)
    np.testing.assert_array_equal(png, rgb[..., 0])


def test_clipping_is_counted_and_warned(tmp_path):
    """Values above the white level, and read noise below the black level 0."""
    raw = splitlf.render(lytro_cut(), splitlf.Scene(splitlf.SlantedEdge(), 1000.0),
                         noise={"photons": 500.0, "read_noise": 3.0}, seed=3, progress=False)
    scale = 1.3 * 65535 / float(raw.images[0].max())
    with pytest.warns(UserWarning, match="above the white level"):
        done = splitlf.export(raw, "tiff", tmp_path / "out", scale=scale)
    above = int(np.count_nonzero(np.rint(raw.images[0] * scale) > 65535))
    below = int(np.count_nonzero(np.rint(raw.images[0] * scale) < 0))
    assert above > 0 and below > 0
    assert done.sidecar["channels"][0]["clipped"]["raw"] == {"above": above, "below": below}
    dn = tifffile.imread(tmp_path / "out" / "ch1" / "raw.tiff")
    assert int(np.count_nonzero(dn == 65535)) >= above
    assert int(np.count_nonzero(dn == 0)) >= below


# -- the sidecar ---------------------------------------------------------------------------------

def test_sidecar_states_design_noise_scale_and_orientation(tmp_path, hex_raw):
    done = splitlf.export(hex_raw, "plenopticam", tmp_path / "out")
    doc = json.loads((tmp_path / "out" / "splitlf.json").read_text())
    assert doc == json.loads(json.dumps(done.sidecar))
    assert doc["format"] == "splitlf-export/1" and doc["target"] == "plenopticam"
    assert splitlf.Design.from_dict(tomllib.loads(doc["design"]["toml"])["design"]) \
        == hex_raw.design
    assert (tmp_path / "out" / "design.toml").read_text() == doc["design"]["toml"]
    scale = doc["scale"]["dn_per_unit"]
    assert doc["scale"]["black_level_dn"] == 0 and doc["scale"]["white_level_dn"] == 65535
    assert doc["scale"]["white_level_value"] == pytest.approx(65535 / scale)
    n = doc["noise"]
    assert (n["photons"], n["read_noise"]) == (500.0, 0.0)
    assert n["gain_dn_per_electron"] == pytest.approx(scale / 500.0)
    assert n["read_noise_dn"] == 0.0
    o = doc["orientation"]
    assert "upright" in o["rows"] and "mirrored" in o["columns"] and "PlenoptiCam" in o["target"]
    files = doc["channels"][0]["files"]
    assert all((tmp_path / "out" / f).is_file() for f in files.values())
    assert doc["ground_truth"] is None


def test_a_noise_free_raw_says_so(tmp_path, seed_raw):
    doc = splitlf.export(seed_raw, "tiff", tmp_path / "out").sidecar
    assert doc["noise"]["stated"] and doc["noise"]["photons"] == math.inf
    assert json.loads((tmp_path / "out" / "splitlf.json").read_text())["noise"]["photons"] \
        is None
    assert [c["channel"] for c in doc["channels"]] == [1, 2]


def test_white_options_are_passed_to_render(tmp_path, hex_raw, monkeypatch):
    from splitlf.exchange import export as module

    seen = {}
    real = module.render

    def spy(design, scene, **kw):
        seen.update(kw)
        return real(design, scene, **{k: v for k, v in kw.items() if k != "falloff"})

    monkeypatch.setattr(module, "render", spy)
    done = splitlf.export(hex_raw, "tiff", tmp_path / "out",
                          white_options={"falloff": True, "tol": 1e-4})
    assert seen["falloff"] is True and seen["tol"] == 1e-4
    assert done.sidecar["white"]["options"] == {"falloff": True, "tol": 1e-4}


# -- the ground truth ------------------------------------------------------------------------

def test_ground_truth_cell_means_and_plane_depth(tmp_path, hex_raw):
    tex = splitlf.Sinusoid(frequency=0.7, mean=0.5, amplitude=0.3, phase=0.4)
    plane = splitlf.Plane(1000.0, 0.05, -0.02)
    splitlf.export(hex_raw, "tiff", tmp_path / "out", scene=splitlf.Scene(tex, plane))
    doc = json.loads((tmp_path / "out" / "splitlf.json").read_text())["ground_truth"]
    with np.load(tmp_path / "out" / "truth" / "truth.npz") as t:
        cells, extent, step = t["texture"], t["texture_extent"], float(t["cell_mm"])
        x0, x1, y0, y1 = extent
        ny, nx = cells.shape
        assert (x1 - x0, y1 - y0) == pytest.approx((nx * step, ny * step))
        assert step == pytest.approx(hex_raw.design.resolution_step(1000.0))
        # closed form: the mean of mean + a sin(2 pi f X + phase) over [xa, xb]
        xa = x0 + step * np.arange(nx)
        xb = xa + step
        w = 2 * np.pi * tex.frequency
        want = tex.mean + tex.amplitude * (np.cos(w * xa + tex.phase)
                                           - np.cos(w * xb + tex.phase)) / (w * step)
        np.testing.assert_allclose(cells, np.broadcast_to(want, cells.shape), atol=1e-9)
        xs = xa + step / 2
        ys = y1 - step * (np.arange(ny) + 0.5)
        np.testing.assert_allclose(t["depth"], 1000.0 + 0.05 * xs[None, :] - 0.02 * ys[:, None],
                                   rtol=1e-12)
        np.testing.assert_array_equal(t["plane"], [1000.0, 0.05, -0.02])
    np.testing.assert_allclose(tifffile.imread(tmp_path / "out" / "truth" / "texture.tiff"),
                               cells, rtol=1e-6)
    assert doc["shape"] == [ny, nx] and doc["reference_depth_mm"] == 1000.0


def test_ground_truth_of_a_depth_map_is_the_map(tmp_path, hex_raw):
    z = np.array([[900.0, 950.0], [1000.0, 1100.0]])
    scene = splitlf.Scene(0.5, splitlf.DepthMap(z, (-3.0, 3.0, -2.0, 2.0)))
    splitlf.export(hex_raw, "tiff", tmp_path / "out", scene=scene)
    with np.load(tmp_path / "out" / "truth" / "truth.npz") as t:
        np.testing.assert_array_equal(t["depth_map"], z)
        np.testing.assert_array_equal(t["depth_map_extent"], [-3.0, 3.0, -2.0, 2.0])
        assert (t["texture"] == 0.5).all()
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "out" / "truth" /
                                                  "depth_map.tiff"), z.astype(np.float32))


# -- bad input, atomic folders -------------------------------------------------------------------

def test_bad_input_is_named_before_anything_is_written(tmp_path, hex_raw):
    out = tmp_path / "out"
    with pytest.raises(InvalidParameter, match="target.*'plenopticam' or 'plenpy' or 'tiff'"):
        splitlf.export(hex_raw, "lytro", out)
    with pytest.raises(TypeError, match="target"):
        splitlf.export(hex_raw, 3, out)
    with pytest.raises(TypeError, match="raw must be a splitlf.Raw"):
        splitlf.export(hex_raw.images[0], "tiff", out)
    with pytest.raises(InvalidParameter, match="scale"):
        splitlf.export(hex_raw, "tiff", out, scale=-1.0)
    with pytest.raises(InvalidParameter, match="white_options"):
        splitlf.export(hex_raw, "tiff", out, white_options={"noise": {"photons": 10}})
    with pytest.raises(TypeError, match="RandomAlbedo"):
        splitlf.export(hex_raw, "tiff", out, scene=splitlf.Scene("random", 1000.0))
    with pytest.raises(FileNotFoundError, match="does not exist"):
        splitlf.export(hex_raw, "tiff", tmp_path / "missing" / "out")
    assert sorted(tmp_path.iterdir()) == []


def test_an_existing_folder_is_kept_unless_overwrite(tmp_path, hex_raw):
    out = tmp_path / "out"
    out.mkdir()
    splitlf.export(hex_raw, "tiff", out)  # an empty folder is fine
    before = sorted(p.name for p in out.rglob("*"))
    with pytest.raises(FileExistsError, match="overwrite=True"):
        splitlf.export(hex_raw, "plenpy", out)
    assert sorted(p.name for p in out.rglob("*")) == before
    splitlf.export(hex_raw, "plenpy", out, overwrite=True)
    assert (out / "ch1" / "Images" / "raw.png").is_file()
    assert not (out / "ch1" / "centres.csv").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no temporary folder left


def test_a_failure_leaves_no_partial_folder(tmp_path, hex_raw, monkeypatch):
    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(formats, "write_plenopticam_calibration", fail)
    with pytest.raises(OSError, match="disk full"):
        splitlf.export(hex_raw, "plenopticam", tmp_path / "out")
    assert list(tmp_path.iterdir()) == []


# -- the command line ----------------------------------------------------------------------------

def test_cli_export_writes_the_folder(tmp_path, capsys):
    raw = small_raw(tmp_path, (4, 3), "--texture", "random", "--depth", "800", capsys=capsys)
    out = tmp_path / "exp"
    code, stdout, err = run_cli(["export", str(raw), "--to", "plenopticam", str(out)], capsys)
    assert code == 0 and err == "" and "2 channel(s)" in stdout
    loaded = splitlf.Raw.load(raw)
    for i in (1, 2):
        cal = json.loads((out / f"ch{i}" / "white.json").read_text())
        got = np.array(cal["mic_list"])
        assert np.abs(got - reference_centres(loaded.design, i)).max() < TOL_PX
    code, stdout, err = run_cli(["export", str(raw), "--to", "tiff", str(out)], capsys)
    assert code == 2 and stdout == "" and err.count("\n") == 1 and "--force" in err
    code, stdout, _ = run_cli(["export", str(raw), "--to", "tiff", str(out), "--force",
                               "--json"], capsys)
    assert code == 0 and json.loads(stdout)["target"] == "tiff"
    assert (out / "ch2" / "centres.csv").is_file()


def test_cli_export_with_a_dataset_truth(tmp_path, capsys):
    d = seed_cut(4, 3)
    (tmp_path / "d.toml").write_text(d.to_toml())
    assert run_cli(["dataset", str(tmp_path / "d.toml"), "-n", "1", "--depths", "800:900",
                    "-o", str(tmp_path / "data")], capsys)[0] == 0
    code, _, err = run_cli(["export", str(tmp_path / "data" / "scene0.npz"), "--to", "tiff",
                            str(tmp_path / "exp"), "--truth",
                            str(tmp_path / "data" / "scene0_truth.npz")], capsys)
    assert code == 0, err
    with np.load(tmp_path / "data" / "scene0_truth.npz") as src, \
            np.load(tmp_path / "exp" / "truth" / "truth.npz") as t:
        np.testing.assert_array_equal(t["plane"], src["plane"])


@pytest.mark.parametrize("argv, needle", [
    (["--to", "lytro"], "invalid choice: 'lytro'"),
    (["--to", "tiff", "--scale", "-2"], "--scale"),
])
def test_cli_export_bad_options(tmp_path, capsys, argv, needle):
    raw = small_raw(tmp_path, (3, 2), "--texture", "random", "--depth", "800",
                    capsys=capsys)
    code, out, err = run_cli(["export", str(raw), str(tmp_path / "x"), *argv], capsys)
    assert code == 2 and out == "" and needle in err and err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_cli_export_of_a_file_without_design(tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    np.savez(bad, format=np.array("splitlf-raw/1"), channel1=np.zeros((3, 3)))
    code, out, err = run_cli(["export", str(bad), "--to", "tiff", str(tmp_path / "x")], capsys)
    assert code == 2 and out == "" and "no design TOML text" in err
    assert not (tmp_path / "x").exists()


def test_the_warning_of_clipping_reaches_the_cli(tmp_path, capsys):
    raw = small_raw(tmp_path, (3, 2), "--texture", "random", "--depth", "800",
                    "--noise", "50", capsys=capsys)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code, _, err = run_cli(["export", str(raw), "--to", "tiff", str(tmp_path / "x"),
                                "--scale", "200000"], capsys)
    assert code == 0 and "warning" in err and "above the white level" in err


def test_files_of_the_targets_are_what_the_docs_say():
    from splitlf.exchange.export import LAYOUT

    text = (Path(__file__).resolve().parent.parent / "docs" / "export.md").read_text()
    for target, files in LAYOUT.items():
        for name in files.values():
            assert f"chN/{name}" in text, (target, name)
