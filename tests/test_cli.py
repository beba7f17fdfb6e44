"""The `splitlf` command line, end to end."""

from __future__ import annotations

import json
import math
import subprocess
import sys

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
