"""The command line's verdicts (issue 20): one validation before any output, one-line
errors in the CLI's words, missing extras, Ctrl-C, the short report, the narrow compare
table, and the structure of the cli package (option groups declared once, short functions)."""

from __future__ import annotations

import ast
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _subprocess import default_sigint

import splitlf
from splitlf.cli import main

CLI = Path(splitlf.__file__).with_name("cli")
#: Every source file of the command line (the package: main, _common, one per command).
CLI_FILES = sorted(CLI.glob("*.py"))
ENV = {**os.environ, "PYTHONPATH": str(Path(splitlf.__file__).parent.parent)}


def _cli(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def d40(tmp_path):
    """The README's own example, cam.replace(D=40.0), as a [camera] file: refused (its
    microlens images overlap)."""
    text = splitlf.Camera.paper().to_toml().replace("D = 20.0", "D = 40.0")
    path = tmp_path / "d40.toml"
    path.write_text(text)
    return path


# -- structure --------------------------------------------------------------------------------

def _cli_source() -> str:
    return "\n".join(p.read_text() for p in CLI_FILES)


def test_the_cli_is_a_package_of_one_module_per_command():
    from splitlf.cli import COMMANDS

    assert {p.stem for p in CLI_FILES} == {"__init__", "_common", *(
        m.__name__.rpartition(".")[2] for m in COMMANDS)}
    for module in COMMANDS:
        assert callable(module.add_parser) and callable(module.run)


def test_no_function_in_cli_is_longer_than_60_lines():
    long = [(p.name, n.name, n.end_lineno - n.lineno + 1) for p in CLI_FILES
            for n in ast.walk(ast.parse(p.read_text()))
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
            and n.end_lineno - n.lineno + 1 > 60]
    assert long == []


def test_cli_never_branches_on_camera():
    src = _cli_source()
    assert "isinstance(" not in src.replace("isinstance(data", "").replace(
        "isinstance(value", "").replace("isinstance(spec", "").replace(
        "isinstance(log", "").replace("isinstance(dep", "").replace(
        "isinstance(doc", "").replace("isinstance(opts", "")
    assert "sweep import METRICS" not in src and "design_metrics" not in src


def test_option_groups_are_declared_once():
    src = _cli_source()
    for option in ('"--config"', '"--preset", choices=PRESETS', '"--threads"', '"--force"',
                   '"--json"', '"--out"', '"--scheduler"', '"--threshold"'):
        assert src.count(f"add_argument({option}") == 1, option


# -- one validation, one verdict --------------------------------------------------------------

@pytest.mark.parametrize("argv", [
    ["report"], ["report", "--json"], ["trace", "--out", "{tmp}/t.npz"],
    ["figures", "--out", "{tmp}/figs"], ["simulate", "--out", "{tmp}/s.json"],
    ["optimise", "--free", "D=8:40", "--objective", "sharp_fraction_union",
     "--out", "{tmp}/best.toml"],
    ["explore", "--port", "0"],
])
def test_an_invalid_design_gets_one_verdict_before_any_output(tmp_path, capsys, d40, argv):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    code, out, err = _cli([*argv, "--config", str(d40)], capsys)
    assert code == 2 and out == ""
    assert err == (f"splitlf {argv[0]}: error: {d40}: invalid D = 40: allowed an aperture "
                   f"{err.split('allowed an aperture ', 1)[1]}")
    assert err.count("\n") == 1 and "channels[1]" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d40.toml"]  # nothing written


def test_a_sweep_base_with_an_invalid_design_is_refused(tmp_path, capsys, d40):
    pytest.importorskip("xarray")
    spec = tmp_path / "sweep.toml"
    spec.write_text("[grid]\nkappa = [0.3, 0.4]\n\n" + d40.read_text())
    code, out, err = _cli(["sweep", "--grid", str(spec), "--out", str(tmp_path / "s.nc")],
                          capsys)
    assert code == 2 and out == "" and "invalid D = 40" in err and err.count("\n") == 1
    assert not (tmp_path / "s.nc").exists()


@pytest.mark.parametrize("argv", [["report"], ["figures"], ["trace"], ["simulate"],
                                  ["explore"]])
def test_a_missing_file_is_named_in_one_line(tmp_path, capsys, argv):
    missing = tmp_path / "nope.toml"
    code, out, err = _cli([*argv, "--config", str(missing)], capsys)
    assert (code, out, err) == (2, "", f"splitlf {argv[0]}: error: no such file: {missing}\n")


def test_a_device_is_refused_at_once(capsys):
    code, out, err = _cli(["report", "--config", "/dev/zero"], capsys)
    assert code == 2 and out == ""
    assert err == "splitlf report: error: /dev/zero: not a regular file (a TOML file is " \
        "expected)\n"


def test_a_texture_that_is_not_an_npy_array_is_named(tmp_path, capsys):
    pytest.importorskip("scipy")
    toml = tmp_path / "some.toml"
    toml.write_text("[camera]\n")
    code, out, err = _cli(["simulate", "--texture", f"image:{toml}:10"], capsys)
    assert (code, out) == (2, "")
    assert err == f"splitlf simulate: error: {toml}: not a NumPy .npy array file\n"
    assert "pickle" not in err
    code, _, err = _cli(["simulate", "--texture", f"image:{tmp_path / 'no.npy'}:10"], capsys)
    assert code == 2 and "no such file: " in err


def test_optimise_errors_speak_the_cli(capsys):
    code, out, err = _cli(["optimise", "--free", "D=8:40", "--objective", "sharpness"],
                          capsys)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("splitlf optimise: error: invalid --objective = 'sharpness': "
                          "allowed one of: sharp_fraction_channel1, ")
    assert "callable" not in err
    code, _, err = _cli(["optimise", "--free", "D=8:40", "--objective",
                         "sharp_fraction_union", "--constraint", "nope<=3"], capsys)
    assert code == 2 and "invalid --constraint = 'nope'" in err and "callable" not in err


# -- missing extras ---------------------------------------------------------------------------

@pytest.mark.parametrize("argv, extra", [
    (["simulate"], "simulate"),
    (["optimise", "--free", "D=8:40", "--objective", "f_number"], "sweep"),
])
def test_a_missing_extra_is_one_line(argv, extra):
    hide = "import sys; sys.modules['scipy'] = None; from splitlf.cli import main; " \
        f"sys.exit(main({argv!r}))"
    r = subprocess.run([sys.executable, "-c", hide], capture_output=True, text=True,
                       env=ENV, timeout=120)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == f'splitlf {argv[0]}: error: {argv[0]} needs scipy: pip install ' \
        f'"splitlf[{extra}]"\n'


# -- Ctrl-C -----------------------------------------------------------------------------------

def test_ctrl_c_is_one_line_and_status_130(tmp_path):
    pytest.importorskip("xarray")
    spec = tmp_path / "big.toml"
    spec.write_text("[grid]\nkappa = {start = 0.1, stop = 0.6, num = 400}\n"
                    "D = {start = 5.0, stop = 20.0, num = 50}\n"
                    "[depths]\nnum = 2000\n")
    p = subprocess.Popen([sys.executable, "-m", "splitlf", "sweep", "--grid", str(spec),
                          "--threads", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=ENV, preexec_fn=default_sigint)
    try:
        time.sleep(4.0)
        assert p.poll() is None, p.communicate()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
    finally:
        p.kill()  # never left running when the test fails
        p.wait()
    assert p.returncode == 130
    assert err.splitlines()[-1] == "splitlf sweep: interrupted"
    assert "Traceback" not in err


# -- explore ----------------------------------------------------------------------------------

def test_explore_on_a_port_in_use_prints_no_url():
    pytest.importorskip("bokeh")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = subprocess.run([sys.executable, "-m", "splitlf", "explore", "--port", str(port)],
                           capture_output=True, text=True, env=ENV, timeout=120)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == f"splitlf explore: error: --port {port}: cannot listen on 127.0.0.1: " \
        "Address already in use\n"


def test_the_threaded_explorer_stops_at_interpreter_exit():
    pytest.importorskip("bokeh")
    code = ("import splitlf.explorer as e; r = e.serve(threaded=True, port=0); "
            "print(r.thread.is_alive())")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=ENV, timeout=120)
    assert r.returncode == 0 and r.stdout.splitlines()[-1] == "True"
    assert "Traceback" not in r.stderr and "Exception" not in r.stderr


# -- report -----------------------------------------------------------------------------------

def test_report_is_short_by_default_and_full_on_request(capsys):
    code, out, err = _cli(["report"], capsys)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert len(lines) <= 30 and max(map(len, lines)) <= 120
    for needle in ("642.00", "217.00", "half 1 (light field)", "split sensor (either half)",
                   "split sensor   max gap", "--full"):
        assert needle in out, needle
    code, full, _ = _cli(["report", "--full"], capsys)
    assert code == 0 and len(full.splitlines()) > 150 and "Coincidence planes" in full


# -- simulate ---------------------------------------------------------------------------------

def test_simulate_no_conventional(capsys):
    pytest.importorskip("scipy")
    import json

    code, out, err = _cli(["simulate", "--z", "700", "--no-conventional", "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert list(doc["results"][0]["rmse"]) == ["channel 1", "channel 2", "union"]
    assert doc["window_cells"] == 256
    code, out, _ = _cli(["simulate", "--z", "700", "--no-conventional"], capsys)
    assert code == 0 and "conventional" not in out and "window [mm]" in out


# -- compare ----------------------------------------------------------------------------------

def _comparison_table():
    pd = pytest.importorskip("pandas")
    cols = ["channels", "pixels", "shares", "sharp_fraction", "covering_radius_worst",
            "covering_radius_median", "distinct_2d_median", "field_at_1m_mm",
            "light_per_pixel", "light_from_rect_twin", "light_relative", "out_of_focus_mm",
            "mtf50_500mm", "mtf50_2000mm"]
    rows = {}
    for n in ("plain", "split", "split3", "multifocus", "conventional"):
        rows[n] = [1, 8_640_000, "1/3, 1/3, 1/3", 1.0, 3.14159, 1.2345, 1234.5, 123.456,
                   0.00012345, False, 0.33333, "642.0, 300.3, 217.0", 12.345, 6.789]
    tab = pd.DataFrame.from_dict(rows, orient="index", columns=cols)
    tab.index.name = "architecture"
    tab.loc["conventional", "sharp_fraction"] = 0.1
    tab.insert(0, "feasible", pd.Series({n: True for n in rows} |
                                        {"conventional": pd.NA}, dtype="boolean"))
    tab.insert(1, "objective", pd.Series({n: 1.0 for n in rows} |
                                         {"conventional": np.nan}, dtype=float))
    return tab


def test_compare_table_fits_100_columns_unless_wide():
    from types import SimpleNamespace

    from splitlf.cli.compare import compare_text

    res = SimpleNamespace(table=_comparison_table(), preset="seed",
                          timing={"optimise_s": 1.0, "evaluate_s": 2.0})
    args = SimpleNamespace(objective="sharp_fraction_union", sense=None, wide=False)
    text = compare_text(res, args, {}, [])
    assert max(map(len, text.splitlines())) <= 100
    conv = next(ln for ln in text.splitlines() if ln.startswith("conventional"))
    assert conv.split()[1] == "-" and "<NA>" not in text and "None" not in text
    assert ("note: sharp (the union's sharp fraction) is 1 for every light field row: the "
            "objective maximised it") in text
    args.wide = True
    wide = compare_text(res, args, {}, [])
    assert max(map(len, wide.splitlines())) > 100 and "covering_radius_median" in wide
    assert wide.splitlines()[-1].startswith("optimised in")
