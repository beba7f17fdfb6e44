"""The `splitlf` command line, end to end."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

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
    assert Camera.from_dict(data["camera"]) == cam
    assert data["derived"]["half1"]["out_of_focus_depth_mm"] == cam.out_of_focus_depth(1)
    assert data["derived"]["half2"]["lit_pixels"] == 11
    dof = depth_of_field(cam)
    assert data["depth_of_field"]["half1"] == [[a, None if math.isinf(b) else b]
                                               for a, b in dof.half1]


def test_report_config(tmp_path, capsys):
    cam = Camera.paper().replace(D=10.0)
    p = tmp_path / "cam.toml"
    cam.to_toml(p)
    code, out, _ = run(["report", "--config", str(p), "--json"], capsys)
    assert code == 0 and json.loads(out)["camera"]["D"] == 10.0


@pytest.mark.parametrize("content, needle", [
    (None, "No such file"),
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
    import numpy as np

    import splitlf

    out = tmp_path / "t.npz"
    code, stdout, _ = run(["trace", "--out", str(out), "--json"], capsys)
    assert code == 0
    summary = json.loads(stdout)
    data = np.load(out)
    cam = Camera.paper()
    for h in (1, 2):
        t = splitlf.trace(cam, h)
        np.testing.assert_array_equal(data[f"half{h}_area"], t.area)
        np.testing.assert_array_equal(data[f"half{h}_vertices"], t.vertices)
        assert summary[f"half{h}"]["pixels"] == cam.Kx * cam.Q
    assert summary["half2"]["lit"] == cam.Kx * 11
    assert "[camera]" in str(data["camera_toml"])


def test_trace_bad_suffix(tmp_path, capsys):
    code, _, err = run(["trace", "--out", str(tmp_path / "t.txt")], capsys)
    assert code == 2 and ".npz" in err


def test_figures_pngs(tmp_path, capsys):
    from matplotlib.image import imread

    code, stdout, _ = run(["figures", "--out", str(tmp_path), "--dpi", "100"], capsys)
    assert code == 0
    paths = stdout.split()
    assert len(paths) == 4
    from splitlf.plot import FIGURES

    for p in paths:
        img = imread(p)
        w, h = FIGURES[Path(p).stem][2]
        assert img.shape[:2] == (round(h * 100), round(w * 100))
        assert img[..., :3].std() > 0.05  # not blank


@pytest.mark.parametrize("cmd", ["report", "figures", "trace", "sweep"])
def test_help(cmd, capsys):
    with pytest.raises(SystemExit) as e:
        main([cmd, "--help"])
    assert e.value.code == 0 and "--threads" in capsys.readouterr().out
