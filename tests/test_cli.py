"""The `splitlf` command line, end to end."""

from __future__ import annotations

import errno
import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from _cli import small_raw

import splitlf
from splitlf import Camera, depth_of_field
from splitlf.cli import main


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_report_seed(capsys):
    code, out, err = run(["report"], capsys)
    assert code == 0 and err == ""
    assert "642.00" in out and "217.00" in out
    assert "seed design" in out and "split sensor" in out


def test_report_json_matches_api(capsys):
    code, out, _ = run(["report", "--json"], capsys)
    assert code == 0
    data = json.loads(out)
    cam = Camera.paper()
    assert splitlf.Design.from_dict(data["design"]) == cam
    assert data["derived"]["channels"][0]["out_of_focus_depth_mm"] == \
        cam.out_of_focus_depth(1)
    dof = depth_of_field(cam)
    assert data["depth_of_field"]["light_field"]["channel 1"] == \
        [[a, None if math.isinf(b) else b] for a, b in dof.half1]


def test_report_config(tmp_path, capsys):
    cam = Camera.paper().replace(D=10.0)
    p = tmp_path / "cam.toml"
    cam.to_toml(p)
    code, out, _ = run(["report", "--config", str(p), "--json"], capsys)
    assert code == 0 and json.loads(out)["design"]["D"] == 10.0


@pytest.mark.parametrize("content, needle", [
    (None, "error: no such file: "),
    ("[camera\n", "not valid TOML"),
    ("[camera]\nF = -1\n", "missing"),
])
def test_report_bad_config(tmp_path, capsys, content, needle):
    p = tmp_path / "bad.toml"
    if content is not None:
        p.write_text(content)
    code, out, err = run(["report", "--config", str(p)], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


def test_report_invalid_value(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_text(Camera.paper().to_toml().replace("D = 20.0", "D = -20.0"))
    code, _, err = run(["report", "--config", str(p)], capsys)
    assert code == 2 and "invalid D = -20" in err and err.count("\n") == 1


def test_console_script():
    """The installed `splitlf` entry point runs as a real process."""
    r = subprocess.run([sys.executable, "-m", "splitlf", "report", "--json"],
                       capture_output=True, text=True, check=True)
    assert json.loads(r.stdout)["derived"]["f_number"] == 4.0


def test_trace_npz(tmp_path, capsys):
    out = tmp_path / "t.npz"
    code, stdout, _ = run(["trace", "--out", str(out), "--json"], capsys)
    assert code == 0
    summary = json.loads(stdout)
    data = np.load(out)
    cam = Camera.paper()
    for h in (1, 2):
        t = splitlf.trace(cam, h)
        np.testing.assert_array_equal(data[f"channel{h}_area"], t.area)
        np.testing.assert_array_equal(data[f"channel{h}_vertices"], t.vertices)
        assert summary[f"channel{h}"]["pixels"] == cam.Kx * cam.Q
    assert summary["channel2"]["lit"] == cam.Kx * 11
    assert "[camera]" in str(data["design_toml"])  # the seed camera's own TOML


def test_trace_bad_suffix(tmp_path, capsys):
    code, _, err = run(["trace", "--out", str(tmp_path / "t.txt")], capsys)
    assert code == 2 and ".npz" in err


def test_figures_pngs(tmp_path, capsys):
    from matplotlib.image import imread

    code, stdout, _ = run(["figures", "--out", str(tmp_path), "--dpi", "100"], capsys)
    assert code == 0
    paths = stdout.split()
    from splitlf.plot import FIGURES

    assert [Path(p).stem for p in paths] == list(FIGURES)
    for p in paths:
        img = imread(p)
        _, panels, (w, h) = FIGURES[Path(p).stem]
        w *= 2 if panels == "channels" else 1  # the seed camera's two halves side by side
        assert img.shape[:2] == (round(h * 100), round(w * 100))
        assert img[..., :3].std() > 0.05  # not blank


@pytest.mark.parametrize("cmd", ["report", "figures", "trace", "sweep"])
def test_help(cmd, capsys):
    with pytest.raises(SystemExit) as e:
        main([cmd, "--help"])
    assert e.value.code == 0 and "--threads" in capsys.readouterr().out


# -- options: every one has help, named types, one-line user errors -------------------------

def _subparsers():
    import argparse

    from splitlf.cli import build_parser

    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def test_every_option_has_help_text(capsys):
    subs = _subparsers()
    assert set(subs) == {"report", "figures", "trace", "sweep", "simulate", "optimise",
                         "compare", "explore", "render", "dataset", "export", "reconstruct",
                         "depth"}
    for name, sub in subs.items():
        for action in sub._actions:
            assert action.help and action.help.strip(), (name, action.option_strings)
        with pytest.raises(SystemExit) as e:
            main([name, "--help"])
        assert e.value.code == 0
        text = capsys.readouterr().out
        for action in sub._actions:
            for opt in action.option_strings:
                assert opt in text


@pytest.mark.parametrize("args, needle", [
    (["report", "--threads", "abc"], "invalid thread count 'abc'"),
    (["report", "--threads", "0"], "invalid thread count 0: allowed an integer in [1, 1024]"),
    (["figures", "--dpi", "0"], "invalid dpi 0: allowed an integer in [10, 1000]"),
    (["figures", "--dpi", "100000"], "invalid dpi 100000"),
    (["simulate", "--n", "0", "--z-range", "300", "900"], "invalid depth count 0"),
    (["simulate", "--z-range", "500", "inf"], "invalid depth 'inf'"),
    (["simulate", "--z", "nan"], "invalid depth 'nan'"),
    (["simulate", "--seed", "-1"], "invalid seed -1"),
    (["simulate", "--photons", "1e400"], "invalid photon count"),
    (["report", "--threshold", "-1"], "invalid threshold"),
])
def test_option_values_are_checked_with_named_types(tmp_path, monkeypatch, capsys, args,
                                                    needle):
    monkeypatch.chdir(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SystemExit) as e:
            main(args)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert needle in err and "_threads" not in err and "Traceback" not in err
    assert err.count("\n") == 1 and err.startswith(f"splitlf {args[0]}: error: argument")
    assert list(tmp_path.iterdir()) == []  # e.g. figures --dpi 0 made no folder


@pytest.mark.parametrize("exc, code", [
    (ValueError("bad value"), 2),
    (TypeError("bad type"), 2),
    (FileExistsError("exists"), 2),
    (splitlf.TooLargeError("too large"), 2),
    (MemoryError("Unable to allocate 128. TiB for an array"), 2),
    (RuntimeError("a bug"), None),
    (AssertionError("a bug"), None),
    (KeyError("a bug"), None),
])
def test_only_user_errors_are_caught(monkeypatch, capsys, exc, code):
    import splitlf.cli.report as cli_report

    def fail(*args, **kwargs):
        raise exc

    monkeypatch.setattr(cli_report, "report_data", fail)
    if code is None:
        with pytest.raises(type(exc)):
            main(["report"])
    else:
        assert main(["report"]) == code
        err = capsys.readouterr().err
        assert err.startswith("splitlf report: error:") and err.count("\n") == 1


def test_binary_config_error_names_the_file(tmp_path, capsys):
    p = tmp_path / "cam.toml"
    p.write_bytes(b"\x00\xff\xfe binary")
    code, out, err = run(["report", "--config", str(p)], capsys)
    assert code == 2 and str(p) in err and err.count("\n") == 1


# -- output files: never overwritten without --force, written atomically --------------------

def test_trace_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "t.npz"
    out.write_bytes(b"previous")
    code, stdout, err = run(["trace", "--out", str(out)], capsys)
    assert code == 2 and "exists" in err and "--force" in err and stdout == ""
    assert out.read_bytes() == b"previous"
    code, stdout, _ = run(["trace", "--out", str(out), "--force"], capsys)
    assert code == 0 and stdout.strip() == str(out)
    assert "channel1_area" in np.load(out).files


def test_failed_write_keeps_the_previous_file(tmp_path, monkeypatch, capsys):
    """A writer failing part-way (e.g. a full disk) leaves the old file and no temporary."""
    out = tmp_path / "t.npz"
    out.write_bytes(b"previous good file")

    def full_disk(path, **arrays):
        with open(path, "wb") as fh:
            fh.write(b"PK truncated")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", full_disk)
    code, _, err = run(["trace", "--out", str(out), "--force"], capsys)
    assert code == 2 and "No space left" in err
    assert out.read_bytes() == b"previous good file"
    assert [p.name for p in tmp_path.iterdir()] == ["t.npz"]


def test_trace_passes_threads(tmp_path, monkeypatch, capsys):
    import splitlf.sampling.rayspace as rs

    real = rs.trace
    seen = []

    def trace(camera, half=None, axis="x", n_threads=None, *, channel=None):
        seen.append(n_threads)
        return real(camera, half, axis, channel=channel)

    monkeypatch.setattr(rs, "trace", trace)
    code, _, _ = run(["trace", "--out", str(tmp_path / "t.npz"), "--threads", "2"], capsys)
    assert code == 0 and seen == [2, 2]


def test_figures_check_every_target_before_writing(tmp_path, capsys):
    (tmp_path / "samples.png").write_bytes(b"previous")
    code, stdout, err = run(["figures", "--out", str(tmp_path)], capsys)
    assert code == 2 and "samples.png" in err and "--force" in err and stdout == ""
    assert [p.name for p in tmp_path.iterdir()] == ["samples.png"]  # nothing drawn
    file = tmp_path / "file"
    file.write_text("x")
    code, _, err = run(["figures", "--out", str(file)], capsys)
    assert code == 2 and "not a folder" in err


def test_figures_pass_threads_to_every_figure(tmp_path, monkeypatch, capsys):
    import splitlf.cli.figures as cli_figures
    import splitlf.sampling.rayspace as rs

    seen = {}

    def fake(stem):
        def draw(camera, ax=None, n_threads=None):
            seen[stem] = n_threads
        return draw

    monkeypatch.setattr(cli_figures, "figure_functions",
                        lambda design=False: {s: (fake(s), 1, (1.0, 1.0)) for s in ("a", "b")})
    real = rs.trace
    monkeypatch.setattr(rs, "trace", lambda c, h, axis="x", n_threads=None: real(c, h, axis))
    code, _, _ = run(["figures", "--out", str(tmp_path / "f"), "--threads", "3",
                      "--dpi", "10"], capsys)
    assert code == 0 and seen == {"a": 3, "b": 3}
    assert sorted(p.name for p in (tmp_path / "f").iterdir()) == ["a.png", "b.png"]


def test_written_files_get_the_usual_permissions(tmp_path, capsys):
    import os

    out = tmp_path / "t.npz"
    assert main(["trace", "--out", str(out)]) == 0
    umask = os.umask(0o022)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask  # not mkstemp's 0o600
    out.chmod(0o640)
    assert main(["trace", "--out", str(out), "--force"]) == 0
    assert out.stat().st_mode & 0o777 == 0o640  # a replaced file keeps its permissions


@pytest.mark.slow
def test_reconstruct_cli_matches_api(tmp_path, capsys):
    """render -> reconstruct on the command line gives the API's image (the .npy beside
    the .png), and refuses to overwrite without --force."""
    raw_path = small_raw(tmp_path, (16, 12), "--texture", "sinusoid:1", "--depth", "800",
                         capsys=capsys)
    png = tmp_path / "img.png"
    args = ["reconstruct", str(raw_path), "--depth", "800", "--region=-1.5,1.5,-1,1",
            "--channels", "1,2", "-o", str(png), "--npy", "--json", "--regularization", "4"]
    code, out, _ = run(args, capsys)
    assert code == 0
    summary = json.loads(out)
    image = np.load(tmp_path / "img.npy")
    rec = splitlf.reconstruct(splitlf.Raw.load(raw_path), 800.0, region=(-1.5, 1.5, -1.0, 1.0),
                              regularization=4.0)
    assert summary["regularization_rule"] == "fixed" and summary["noise_source"] == "raw"
    assert np.array_equal(image, rec.image)
    assert summary["shape"] == list(rec.image.shape) and png.stat().st_size > 0
    assert summary["tiles"] == 1
    # the picture is a figure with axes in mm (7.5 x 5 in at 110 dpi, as the depth map's),
    # not the bare image (one pixel per cell)
    from matplotlib.image import imread

    assert imread(png).shape[:2] == (550, 825)
    code, _, err = run(args, capsys)
    assert code != 0 and "--force" in err
    # --tile: the API's tiled image; a tile below 16 cells is refused by name.
    code, out, _ = run([*args, "--force", "--tile", "16"], capsys)
    tiled = splitlf.reconstruct(splitlf.Raw.load(raw_path), 800.0,
                                region=(-1.5, 1.5, -1.0, 1.0), tile=16, regularization=4.0)
    assert code == 0 and json.loads(out)["tiles"] == tiled.tiles > 1
    assert np.array_equal(np.load(tmp_path / "img.npy"), tiled.image)
    with pytest.raises(SystemExit) as e:
        main([*args, "--force", "--tile", "8"])
    assert e.value.code == 2 and "invalid tile 8" in capsys.readouterr().err
    # --lens-types: the seed has one type per half (1 is every type); 2 is refused by name,
    # and a fraction is refused, not cut.
    code, out, _ = run([*args, "--force", "--lens-types", "1"], capsys)
    assert code == 0 and np.array_equal(np.load(tmp_path / "img.npy"), rec.image)
    code, _, err = run([*args, "--force", "--lens-types", "2"], capsys)
    assert code != 0 and "lens_types" in err
    for option in ("--lens-types", "--channels"):
        code, _, err = run([*args, "--force", option, "1.5"], capsys)
        assert code != 0 and option in err and "whole numbers" in err


def test_depth_cli_matches_api(tmp_path, capsys):
    """render -> depth on the command line gives the API's map (the .npy beside the
    .png), and reconstruct's --depth reads that .npy with the printed extent."""
    raw_path = small_raw(tmp_path, (10, 8), "--texture", "random:1", "--depth", "1000",
                         "--noise", "2000", capsys=capsys)
    png = tmp_path / "depth.png"
    args = ["depth", str(raw_path), "--depths", "250:4000", "--region=-3,3,-2,2",
            "-o", str(png), "--npy", "--json"]
    code, out, _ = run(args, capsys)
    assert code == 0, out
    summary = json.loads(out)
    depth = np.load(tmp_path / "depth.npy")
    est = splitlf.estimate_depth(splitlf.Raw.load(raw_path), depths=(250.0, 4000.0),
                                 region=(-3.0, 3.0, -2.0, 2.0))
    assert np.array_equal(depth, est.depth)
    assert summary["shape"] == list(depth.shape) and png.stat().st_size > 0
    assert summary["confident"] == pytest.approx(float(est.confident.mean()))
    assert abs(summary["median_depth"] - 1000.0) < 30.0
    code, _, err = run(args, capsys)
    assert code != 0 and "--force" in err
    code, _, err = run(["depth", str(raw_path), "--depths", "50:4000", "-o",
                        str(tmp_path / "x.npy")], capsys)
    assert code != 0 and "depths" in err
    # reconstruct --depth DEPTH.npy --extent=... reads back the same surface (the map
    # build itself is tested in tests/test_depth.py: minutes on a depth map).
    from splitlf.cli._common import parse_render_depth

    ext = ",".join(repr(v) for v in summary["extent"])
    surface = parse_render_depth(str(tmp_path / "depth.npy"), ext)
    assert isinstance(surface, splitlf.DepthMap)
    assert np.array_equal(surface.depth, est.depth)
    assert np.allclose(surface.extent, est.extent, rtol=1e-15)
