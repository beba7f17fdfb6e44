"""The command line's verdicts (issue 20): one validation before any output, one-line
errors in the CLI's words, missing extras, Ctrl-C, the short report, the narrow compare
table, and the structure of the cli package (option groups declared once, short functions)."""

from __future__ import annotations

import ast
import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _cli import run_cli, small_raw
from _subprocess import default_sigint

import splitlf

CLI = Path(splitlf.__file__).with_name("cli")
#: Every source file of the command line (the package: main, _common, one per command).
CLI_FILES = sorted(CLI.glob("*.py"))
ENV = {**os.environ, "PYTHONPATH": str(Path(splitlf.__file__).parent.parent)}


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
    code, out, err = run_cli([*argv, "--config", str(d40)], capsys)
    assert code == 2 and out == ""
    assert err == (f"splitlf {argv[0]}: error: {d40}: invalid D = 40: allowed an aperture "
                   f"{err.split('allowed an aperture ', 1)[1]}")
    assert err.count("\n") == 1 and "channels[1]" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d40.toml"]  # nothing written


def test_a_sweep_base_with_an_invalid_design_is_refused(tmp_path, capsys, d40):
    pytest.importorskip("xarray")
    spec = tmp_path / "sweep.toml"
    spec.write_text("[grid]\nkappa = [0.3, 0.4]\n\n" + d40.read_text())
    code, out, err = run_cli(["sweep", "--grid", str(spec), "--out", str(tmp_path / "s.nc")],
                          capsys)
    assert code == 2 and out == "" and "invalid D = 40" in err and err.count("\n") == 1
    assert not (tmp_path / "s.nc").exists()


@pytest.mark.parametrize("argv", [["report"], ["figures"], ["trace"], ["simulate"],
                                  ["explore"]])
def test_a_missing_file_is_named_in_one_line(tmp_path, capsys, argv):
    missing = tmp_path / "nope.toml"
    code, out, err = run_cli([*argv, "--config", str(missing)], capsys)
    assert (code, out, err) == (2, "", f"splitlf {argv[0]}: error: no such file: {missing}\n")


def test_a_device_is_refused_at_once(capsys):
    code, out, err = run_cli(["report", "--config", "/dev/zero"], capsys)
    assert code == 2 and out == ""
    assert err == "splitlf report: error: /dev/zero: not a regular file (a TOML file is " \
        "expected)\n"


def test_a_texture_that_is_not_an_npy_array_is_named(tmp_path, capsys):
    pytest.importorskip("scipy")
    toml = tmp_path / "some.toml"
    toml.write_text("[camera]\n")
    code, out, err = run_cli(["simulate", "--texture", f"image:{toml}:10"], capsys)
    assert (code, out) == (2, "")
    # one line naming the option, the file and what it is not (splitlf._files.read_npy)
    assert err.startswith("splitlf simulate: error: --texture ") and err.count("\n") == 1
    assert f"invalid texture file {toml}: not a NumPy .npy array" in err
    assert "pickle" not in err
    code, _, err = run_cli(["simulate", "--texture", f"image:{tmp_path / 'no.npy'}:10"], capsys)
    assert code == 2 and "no such file: " in err


def test_optimise_errors_speak_therun_cli(capsys):
    code, out, err = run_cli(["optimise", "--free", "D=8:40", "--objective", "sharpness"],
                          capsys)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("splitlf optimise: error: invalid --objective = 'sharpness': "
                          "allowed one of: sharp_fraction_channel1, ")
    assert "callable" not in err
    code, _, err = run_cli(["optimise", "--free", "D=8:40", "--objective",
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
    code, out, err = run_cli(["report"], capsys)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert len(lines) <= 30 and max(map(len, lines)) <= 120
    for needle in ("642.00", "217.00", "half 1 (light field)", "split sensor (either half)",
                   "split sensor   max gap", "--full"):
        assert needle in out, needle
    code, full, _ = run_cli(["report", "--full"], capsys)
    assert code == 0 and len(full.splitlines()) > 150 and "Coincidence planes" in full


# -- simulate ---------------------------------------------------------------------------------

def test_simulate_no_conventional(capsys):
    pytest.importorskip("scipy")
    import json

    code, out, err = run_cli(["simulate", "--z", "700", "--no-conventional", "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert list(doc["results"][0]["rmse"]) == ["channel 1", "channel 2", "union"]
    assert doc["window_cells"] == 256
    code, out, _ = run_cli(["simulate", "--z", "700", "--no-conventional"], capsys)
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


# -- what a new user hit ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def raw_file(tmp_path_factory):
    """A small raw file of the seed design (10 x 8 lenses per half), rendered by the CLI."""
    return small_raw(tmp_path_factory.mktemp("raw"), (10, 8), "--texture", "random:1",
                     "--depth", "1000", "--noise", "2000")


@pytest.mark.parametrize("command, extra_args", [
    ("depth", ["--depths", "250:4000"]),
    ("reconstruct", ["--depth", "1000", "--region=-1,1,-1,1"]),
])
def test_depth_and_reconstruct_without_scipy_name_the_extra(tmp_path, raw_file, command,
                                                           extra_args):
    """After a core-only install (no SciPy) the image commands say which extra to install,
    in one line, instead of a ModuleNotFoundError traceback; nothing is written."""
    argv = [command, str(raw_file), *extra_args, "-o", str(tmp_path / "out.npy")]
    hide = "import sys; sys.modules['scipy'] = None; from splitlf.cli import main; " \
        f"sys.exit(main({argv!r}))"
    r = subprocess.run([sys.executable, "-c", hide], capture_output=True, text=True,
                       env=ENV, timeout=120)
    assert (r.returncode, r.stdout) == (2, "")
    assert r.stderr == f'splitlf {command}: error: {command} needs scipy: pip install ' \
        '"splitlf[reconstruct]"\n'
    assert list(tmp_path.iterdir()) == []


def _extras() -> dict[str, list[str]]:
    from splitlf._files import read_toml

    root = Path(__file__).resolve().parent.parent
    return read_toml(root / "pyproject.toml")["project"]["optional-dependencies"]


def test_the_readme_names_every_extra_and_what_each_image_command_needs():
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    extras = _extras()
    assert {"plot", "simulate", "reconstruct"} <= set(extras)
    assert any(dep.startswith("scipy") for dep in extras["reconstruct"])
    table = readme.split("## Optional features (extras)", 1)[1].split("\n## ", 1)[0]
    for extra in extras:
        assert f"| `{extra}` |" in table, extra
    for command, needed in (("render", ["`plot`"]), ("reconstruct", ["`reconstruct`", "`plot`"]),
                            ("depth", ["`reconstruct`", "`plot`"]),
                            ("simulate", ["`simulate`"])):
        computes = readme.split("## What it computes", 1)[1].split("\n## ", 1)[0]
        rows = [ln for ln in computes.splitlines() if ln.startswith("|")
                and re.search(f"`splitlf {command}[ `]", ln.rsplit("|", 2)[-2])]
        assert rows, command
        for needle in needed:
            assert all(needle in row for row in rows), (command, needle)


def test_depth_npy_writes_the_confidence_beside_the_depth(tmp_path, raw_file, capsys):
    """-o DEPTH.npy writes DEPTH.confident.npy too (True where the method stands behind the
    cell); every other cell holds a confident cell's depth (the nearest one's). The region
    reaches beyond what the channels see well, so a few cells are not confident."""
    out = tmp_path / "depth.npy"
    code, stdout, err = run_cli(["depth", str(raw_file), "--depths", "250:4000",
                              "--region=-8,8,-6,6", "-o", str(out), "--json"], capsys)
    assert code == 0, err
    summary = json.loads(stdout)
    depth = np.load(out)
    conf = np.load(tmp_path / "depth.confident.npy")
    assert summary["confident_npy"] == str(tmp_path / "depth.confident.npy")
    assert conf.dtype == bool and conf.shape == depth.shape
    assert 0 < conf.sum() < conf.size
    assert summary["confident"] == conf.sum() / conf.size
    assert np.isin(depth[~conf], depth[conf]).all()
    # both are checked before any work: an existing confidence file is refused
    out.unlink()
    code, _, err = run_cli(["depth", str(raw_file), "--depths", "250:4000", "-o", str(out)],
                        capsys)
    assert code == 2 and "depth.confident.npy: exists" in err and not out.exists()


def test_the_reconstruction_picture_has_axes_in_mm_over_its_extent():
    """plot.image draws the albedo over the reconstruction's extent, row 0 at the top, with
    axes in mm and a colour bar from 0 to max(1, largest value)."""
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from splitlf.inverse.reconstruct import Reconstruction
    from splitlf.plot.image import image

    albedo = np.arange(12, dtype=np.float64).reshape(3, 4) / 8.0  # largest 1.375
    rec = Reconstruction(image=albedo, extent=(-2.0, 2.0, -1.5, 1.5), step=1.0,
                         design=splitlf.Design.preset("seed"), depth=800.0, channels=(1, 2),
                         rows=10, iterations=3, residual=1e-12, regularization=4.0,
                         noise="floor")
    ax = image(rec, Figure().add_subplot())
    shown = ax.images[0]
    assert list(shown.get_extent()) == [-2.0, 2.0, -1.5, 1.5]
    assert shown.origin == "upper" and np.array_equal(shown.get_array(), albedo)
    assert shown.get_clim() == (0.0, 1.375)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("X [mm]", "Y [mm]")
    assert "4 x 3 cells of 1 mm" in ax.get_title()


def _unwritable_folder(tmp_path):
    """A folder without write permission; as root (who may write anyway) sysfs, which
    refuses new files."""
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    for candidate in (folder, Path("/sys")):
        try:
            (candidate / ".probe").touch()
        except OSError:
            return candidate
        (candidate / ".probe").unlink()
    pytest.skip("no folder this user cannot write to")


@pytest.mark.parametrize("argv, computes", [
    (["trace", "--out", "{ro}/t.npz"], "splitlf.sampling.rayspace.trace"),
    (["render", "seed", "--texture", "random", "--depth", "1000", "-o", "{ro}/r.npz"],
     "splitlf.imaging.render.render"),
    (["reconstruct", "{tmp}/r.npz", "--depth", "800", "-o", "{ro}/i.npy"],
     "splitlf.inverse.reconstruct.reconstruct"),
    (["depth", "{tmp}/r.npz", "--depths", "250:4000", "-o", "{ro}/d.npy"],
     "splitlf.inverse.depth.estimate_depth"),
    (["simulate", "--out", "{ro}/s.json"], "splitlf.inverse.simulate.simulate"),
    (["sweep", "--grid", "{tmp}/g.toml", "--out", "{ro}/s.nc"], "splitlf.study.sweep.sweep"),
    (["optimise", "--free", "D=8:40", "--objective", "f_number", "--out", "{ro}/b.toml"],
     "splitlf.study.optimise.optimise"),
    (["compare", "--objective", "sharp_fraction_union", "--out", "{ro}/cmp"],
     "splitlf.study.compare.compare"),
    (["figures", "--out", "{ro}/figs"], "splitlf.cli.figures.figure_functions"),
])
def test_an_unwritable_output_folder_is_refused_before_any_work(tmp_path, monkeypatch,
                                                                capsys, argv, computes):
    import importlib

    pytest.importorskip("scipy")
    pytest.importorskip("xarray")
    ro = _unwritable_folder(tmp_path)
    (tmp_path / "g.toml").write_text("[grid]\nkappa = [0.3, 0.4]\n")
    module, _, name = computes.rpartition(".")

    def computed(*args, **kwargs):
        raise AssertionError("computed before checking the output folder")

    monkeypatch.setattr(importlib.import_module(module), name, computed)
    argv = [a.replace("{ro}", str(ro)).replace("{tmp}", str(tmp_path)) for a in argv]
    code, out, err = run_cli(argv, capsys)
    assert (code, out) == (2, "")
    assert err.startswith(f"splitlf {argv[0]}: error: ") and err.count("\n") == 1
    assert f"folder {ro} is not writable" in err and ".tmp" not in err


def test_reconstruct_allow_slow_reaches_the_library(tmp_path, monkeypatch, capsys):
    """--allow-slow passes allow_slow=True to reconstruct; without it the library's
    default holds (the keyword is not passed)."""
    from types import SimpleNamespace

    import splitlf.imaging.render as render_module
    import splitlf.inverse.reconstruct as rec_module

    seen = []

    def fake(raw, depth, **kwargs):
        seen.append(kwargs)
        return SimpleNamespace(image=np.zeros((2, 3)), extent=(0.0, 3.0, 0.0, 2.0), step=1.0,
                               depth=depth, channels=(1,), rows=6, iterations=1,
                               residual=0.0, regularization=4.0, noise="floor", tiles=1,
                               regularization_rule="fixed",
                               noise_model={"photons": math.inf, "read_noise": 0.0},
                               noise_source="raw")

    monkeypatch.setattr(rec_module, "reconstruct", fake)
    monkeypatch.setattr(render_module.Raw, "load", staticmethod(lambda path: path))
    argv = ["reconstruct", "r.npz", "--depth", "800", "-o", str(tmp_path / "i.npy")]
    assert run_cli([*argv, "--allow-slow"], capsys)[0] == 0
    assert run_cli([*argv, "--force"], capsys)[0] == 0
    assert seen[0]["allow_slow"] is True and "allow_slow" not in seen[1]
    code, out, _ = run_cli(["reconstruct", "--help"], capsys)
    assert "--allow-slow" in out and "refused" in out


def test_a_malformed_npy_is_one_line_not_a_memory_error(tmp_path, capsys):
    """A .npy whose header claims far more data than the file (and the machine) holds:
    NumPy's MemoryError becomes the CLI's one line naming the file, exit 2."""
    bad = tmp_path / "bad.npy"
    with open(bad, "wb") as fh:
        np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False,
                                                  "shape": (2**22, 2**22)})
        fh.write(b"\0" * 64)
    code, out, err = run_cli(["render", "seed", "--texture", str(bad), "--width", "10",
                           "--depth", "1000", "-o", str(tmp_path / "r.npz")], capsys)
    assert (code, out) == (2, "")
    assert err.startswith(f"splitlf render: error: {bad}: ") and err.count("\n") == 1
    assert not (tmp_path / "r.npz").exists()


def test_a_long_reconstruct_is_announced_and_refused_without_allow_slow(tmp_path, capsys):
    """A full seed raw reconstructed without --region (issue 46): the grid's size and the
    expected time are printed before any work, and a run expected to take more than the
    library's MAX_SECONDS is refused in one line that names --allow-slow, exit 2, before
    the map is built (the refusal comes within a few seconds)."""
    pytest.importorskip("scipy")
    raw = tmp_path / "raw.npz"
    assert run_cli(["render", "seed", "--texture", "random", "--depth", "1000", "-o",
                    str(raw)], capsys)[0] == 0
    t0 = time.perf_counter()
    code, out, err = run_cli(["reconstruct", str(raw), "--depth", "1000", "-o",
                              str(tmp_path / "img.png")], capsys)
    assert time.perf_counter() - t0 < 30
    assert (code, out) == (2, "")
    lines = err.splitlines()
    assert len(lines) == 2
    assert re.match(r"splitlf reconstruct: \d+ x \d+ cells of [\d.]+ mm", lines[0])
    assert "expected at most" in lines[0]
    assert lines[1].startswith("splitlf reconstruct: error: ") and "--allow-slow" in lines[1]
    assert "allow_slow=True" not in err
    assert not (tmp_path / "img.png").exists()
