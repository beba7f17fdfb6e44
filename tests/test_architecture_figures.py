"""The figures of a general design (splitlf.plot.microlens_images, sample_map; blur and
repetitions of a Design) and `splitlf figures --preset`: every drawn value is the API's."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest
from matplotlib.figure import Figure

import splitlf
from splitlf import Camera, Channel, Design, plot
from splitlf.cli import main
from splitlf.plot.architecture import BOUNDARY, TYPE_COLORS, UNLIT

matplotlib.use("Agg")


def small_hex() -> Design:
    """A hexagonal, three-type channel on a sensor grid, behind a circular aperture."""
    ch = Channel(L=60.0, d=0.05, v=0.25, mu=0.005, Kx=30, Ky=26, grid="hex",
                 f=(0.3, 0.31, 0.32), layout="sensor")
    return Design(F=50.0, D=10.0, channels=(ch,), aperture="circle")


def axes() -> object:
    return Figure().add_subplot()


# -- chief samples of a window of rows ---------------------------------------------------


@pytest.mark.parametrize("name", ["seed", "raytrix-r12"])
def test_row_window_equals_the_whole_grid(name):
    d = Design.preset(name) if name != "seed" else Camera.paper().design
    full = splitlf.chief_samples(d, 1, 700.0)
    rows = full.lit.shape[0]
    for start, stop in [(0, 1), (rows // 3, rows // 3 + 17), (rows - 5, rows)]:
        w = splitlf.chief_samples(d, 1, 700.0, rows=(start, stop), n_threads=1)
        assert w.first_row == start and w.lit.shape == (stop - start, full.lit.shape[1])
        for field in ("X", "Y", "lit", "lens", "type"):
            np.testing.assert_array_equal(getattr(w, field), getattr(full, field)[start:stop])


def test_a_sensor_too_large_for_memory_is_refused_but_its_rows_are_not():
    ch = Channel(L=60.0, d=0.05, v=0.25, mu=0.001, Kx=3000, Ky=3000, grid="hex",
                 layout="sensor")
    d = Design(F=50.0, D=10.0, channels=(ch,), aperture="circle")
    mx, my = d.resolved()[0]["Mx"], d.resolved()[0]["My"]
    assert mx * my > 1.5e10  # 41 bytes per pixel: far beyond this machine's memory
    with pytest.raises(splitlf.TooLargeError, match="chief_samples needs"):
        splitlf.chief_samples(d, 1, 500.0)
    s = splitlf.chief_samples(d, 1, 500.0, rows=(my // 2, my // 2 + 2))
    assert s.lit.shape == (2, mx) and s.lit.any()


def test_row_window_errors():
    d = small_hex()
    rows = d.resolved()[0]["My"]
    for bad in [(-1, 2), (3, 3), (4, 2), (0, rows + 1), (2**62, 2**62 + 1)]:
        with pytest.raises(ValueError, match=r"rows"):
            splitlf.chief_samples(d, 1, 500.0, rows=bad)
    with pytest.raises(TypeError, match=r"rows\[0\]"):
        splitlf.chief_samples(d, 1, 500.0, rows=(True, 3))
    with pytest.raises(TypeError, match="pair"):
        splitlf.chief_samples(d, 1, 500.0, rows=5)


# -- microlens images ---------------------------------------------------------------------


@pytest.mark.parametrize("make", [small_hex, lambda: Design.preset("split3")])
def test_microlens_images_show_lens_types_and_lit_pixels(make):
    from matplotlib.colors import to_rgb

    d = make()
    axs = [axes() for _ in d.channels]
    out = plot.microlens_images(d, ax=axs, lenses=3)
    assert out == axs
    for c, ax in enumerate(axs, start=1):
        img = ax.get_images()[0]
        rgb = np.asarray(img.get_array())
        x0, x1, y0, y1 = img.get_extent()
        r0, c0 = round(y0 + 0.5), round(x0 + 0.5)
        s = splitlf.chief_samples(d, c, 3 * d.F)  # lens, type and lit do not depend on z
        lit = s.lit[r0:r0 + rgb.shape[0], c0:c0 + rgb.shape[1]]
        kind = s.type[r0:r0 + rgb.shape[0], c0:c0 + rgb.shape[1]]
        lens = s.lens[r0:r0 + rgb.shape[0], c0:c0 + rgb.shape[1]]
        palette = np.array([to_rgb(TYPE_COLORS[t]) for t in range(3)])
        want = np.where(lit[..., None], palette[kind], np.array(UNLIT))
        np.testing.assert_array_equal(rgb, want)
        # the crop is centred on the grid's centre pixel
        assert abs((r0 + r0 + rgb.shape[0] - 1) / 2 - (s.lit.shape[0] // 2)) <= 0.5
        # one unit segment per pair of neighbouring pixels of different lenses
        edges = [col for col in ax.collections if np.allclose(col.get_colors()[0][:3],
                                                             BOUNDARY)]
        n_edges = np.count_nonzero(np.any(lens[:, 1:] != lens[:, :-1], axis=-1)) + \
            np.count_nonzero(np.any(lens[1:] != lens[:-1], axis=-1))
        assert len(edges[0].get_segments()) == n_edges
        assert f"channel {c}" in ax.get_title()
        assert f"{np.count_nonzero(lit)} of {lit.size} pixels" in ax.get_title()


def test_hex_types_are_all_drawn_and_unlit_pixels_appear():
    ax = plot.microlens_images(small_hex(), channel=1, lenses=5, ax=axes())
    s = splitlf.chief_samples(small_hex(), 1, 200.0)
    assert set(np.unique(s.type)) == {0, 1, 2}
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[:3] == ["type 1: f = 0.3 mm", "type 2: f = 0.31 mm", "type 3: f = 0.32 mm"]
    assert labels[3] == "unlit"


def test_microlens_images_errors():
    d = small_hex()
    with pytest.raises(ValueError, match=r"invalid channel = 2: allowed an integer in \[1, 1\]"):
        plot.microlens_images(d, channel=2)
    with pytest.raises(ValueError, match="lenses"):
        plot.microlens_images(d, lenses=0)
    with pytest.raises(TypeError, match="lenses"):
        plot.microlens_images(d, lenses=2.5)
    with pytest.raises(ValueError, match="one per channel"):
        plot.microlens_images(Design.preset("split3"), ax=[axes(), axes()])
    with pytest.raises(TypeError, match="must be a splitlf.Design"):
        plot.microlens_images("seed")


# -- sample map ----------------------------------------------------------------------------


@pytest.mark.parametrize("name,z", [("split3", None), ("raytrix-r12", 900.0)])
def test_sample_map_draws_the_distinct_samples(name, z):
    d = Design.preset(name)
    ax = plot.sample_map(d, z, ax=axes(), zoom=1.5)
    zz = d.out_of_focus_depth(1) * (1.0 if len(d.channels) > 1 else 2.0) if z is None else z
    r = splitlf.samples_2d(d, zz)
    delta = d.resolution_step(zz)
    half = 1.5 / 2 * d.channels[0].d * zz / d.channels[0].L / delta
    scatters = ax.collections
    assert len(scatters) == len(d.channels)
    for row, sc in enumerate(scatters):
        pts = r.samples[row] / delta
        pts = pts[np.all(np.abs(pts) <= 1.02 * half, axis=1)]
        np.testing.assert_array_equal(sc.get_offsets(), pts)
        assert len(pts) > 0
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    shown = r.rows if len(d.channels) > 1 else r.rows[:1]  # one channel: union = channel
    assert len(labels) == len(shown)
    for row, name_ in enumerate(shown):
        assert f"{name_}: {r.distinct[row]} distinct, rho = {r.covering_radius[row]:.3g}" \
            in labels[row]
    assert ax.get_xlim() == pytest.approx((-1.04 * half, 1.04 * half))


def test_sample_map_errors():
    d = small_hex()
    with pytest.raises(ValueError, match=r"invalid zoom = 20.0: allowed a finite number in"):
        plot.sample_map(d, 500.0, zoom=20.0)
    with pytest.raises(ValueError, match="zoom"):
        plot.sample_map(d, 500.0, zoom=float("nan"))
    with pytest.raises(TypeError, match="zoom"):
        plot.sample_map(d, 500.0, zoom="2")
    with pytest.raises(ValueError, match="z"):
        plot.sample_map(d, 40.0)


# -- blur and repetitions of a design -----------------------------------------------------


def test_design_blur_draws_every_lens_type_and_channel():
    d = Design.preset("raytrix-r12")
    ax = plot.blur(d, (150.0, 5000.0), n=300, ax=axes())
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    c = None
    for t in range(3):
        z, y = lines[f"light field, array 1 type {t + 1}"].get_data()
        c = splitlf.curves(d, z)
        np.testing.assert_array_equal(y, c.blur_px[t])
    z, y = lines["conventional, sensor on plane 1"].get_data()
    np.testing.assert_array_equal(y, splitlf.curves(d, z).conventional_px[0])
    assert d.out_of_focus_depth(1) in z  # the peak is drawn


def test_design_repetitions_one_curve_per_channel():
    d = Design.preset("split3")
    ax = plot.repetitions(d, ax=axes())
    for ch in (1, 2, 3):
        ln = [ln for ln in ax.get_lines() if ln.get_label() == f"array {ch}"][0]
        z, y = ln.get_data()
        np.testing.assert_array_equal(y, splitlf.curves(d, z).repetitions[ch - 1])


def test_design_samples_figure_draws_new_samples_rows():
    d = Design.preset("split3")
    a_count, a_gap = plot.samples(d, (200.0, 2000.0), ax=(axes(), axes()), n=80)
    lines = {ln.get_label(): ln for ln in a_count.get_lines()}
    gaps = {ln.get_label(): ln for ln in a_gap.get_lines()}
    z = lines["union (10374 pixels)"].get_data()[0]
    r = splitlf.new_samples(d, z)
    for row, name in enumerate(r.rows):
        np.testing.assert_array_equal(lines[f"{name} ({r.sampled[row]} pixels)"].get_data()[1],
                                      r.distinct[row])
        np.testing.assert_array_equal(gaps[name].get_data()[1], r.max_gap[row])
    # coincidence-plane ticks of every channel (all three have the ideal layout)
    for c in (1, 2, 3):
        ticks = lines[f"coincidence planes, channel {c} (N <= 2)"].get_data()[0]
        planes = splitlf.coincidence_planes(d, channel=c, max_n=2).z
        np.testing.assert_array_equal(ticks, planes[(planes >= z[0]) & (planes <= z[-1])])


def test_design_ray_space_draws_every_channel():
    d = Design.preset("split3")
    ax = plot.ray_space(d, n_lenses=2, ax=axes())
    polys = ax.collections
    assert len(polys) == 3
    for c, pc in enumerate(polys, start=1):
        tr = splitlf.trace(d, channel=c)
        K = int(tr.lens.max()) + 1
        first = (K - 2) // 2
        keep = (tr.lens >= first) & (tr.lens < first + 2) & (tr.n_vertices > 0)
        got = pc.get_paths()
        assert len(got) == keep.sum()
        np.testing.assert_array_equal(got[0].vertices[:tr.n_vertices[keep][0]],
                                      tr.vertices[keep][0, :tr.n_vertices[keep][0]])
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "scene plane z = 217 mm (out-of-focus plane of channel 3)" in labels
    with pytest.raises(ValueError, match="grid"):
        plot.ray_space(small_hex())


# -- the CLI -------------------------------------------------------------------------------


def test_cli_figures_of_a_preset(tmp_path, capsys):
    from matplotlib.image import imread

    out = tmp_path / "fig"
    assert main(["figures", "--preset", "split3", "--out", str(out), "--dpi", "40",
                 "--z", "900"]) == 0
    paths = capsys.readouterr().out.split()
    assert [Path(p).stem for p in paths] == list(plot.DESIGN_FIGURES)
    for p in paths:
        _, panels, (w, h) = plot.DESIGN_FIGURES[Path(p).stem]
        w *= 3 if panels == "channels" else 1
        img = imread(p)
        assert img.shape[:2] == (round(h * 40), round(w * 40))
        assert img[..., :3].std() > 0.05


def test_cli_figures_of_a_design_file(tmp_path, capsys):
    cfg = tmp_path / "d.toml"
    small_hex().to_toml(cfg)
    assert main(["figures", "--config", str(cfg), "--out", str(tmp_path / "f"),
                 "--dpi", "30"]) == 0
    # a hex channel has no analysis along x: no ray space, no samples figure
    assert sorted(p.name for p in (tmp_path / "f").iterdir()) == \
        sorted(f"{s}.png" for s in plot.DESIGN_FIGURES if s not in plot.RECT_ONLY)


@pytest.mark.parametrize("args,msg", [
    (["--preset", "split3", "--z", "40"], "invalid --z 40: allowed a depth > F = 80 mm"),
    (["--z", "-3"], "invalid depth '-3'"),
    (["--preset", "split3", "--config", "x.toml"], "--preset and --config"),
    (["--preset", "nope"], "invalid choice"),
])
def test_cli_figures_bad_options_write_nothing(tmp_path, capsys, args, msg):
    out = tmp_path / "f"
    try:
        code = main(["figures", "--out", str(out), *args])
    except SystemExit as e:  # argparse's own errors
        code = e.code
    assert code == 2 and msg in capsys.readouterr().err
    assert not out.exists()


def test_cli_trace_of_a_design(tmp_path, capsys):
    import json

    import tomllib

    out = tmp_path / "t.npz"
    assert main(["trace", "--preset", "split3", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    d = Design.preset("split3")
    with np.load(out) as f:
        assert Design.from_dict(tomllib.loads(str(f["design_toml"]))["design"]) == d
        for c in (1, 2, 3):
            t = splitlf.trace(d, channel=c)
            for name in ("vertices", "n_vertices", "area", "lit"):
                np.testing.assert_array_equal(f[f"channel{c}_{name}"], getattr(t, name))
            assert summary[f"channel{c}"]["lit"] == int(np.count_nonzero(t.lit))
        assert not any(k.startswith("half") for k in f.files)


def test_cli_trace_refuses_a_hex_design(tmp_path, capsys):
    out = tmp_path / "t.npz"
    assert main(["trace", "--preset", "raytrix-r12", "--out", str(out)]) == 2
    assert "channel 1 has a hex grid" in capsys.readouterr().err and not out.exists()
