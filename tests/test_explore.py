"""The design explorer (docs/explore.md): the view data against the public API, parsing
that never evaluates page text, the server's host/origin allow-list, and the app in a real
headless browser (Debian's chromium and chromedriver through Selenium, never a downloaded
browser).

Browser tests skip, with the reason, only when /usr/bin/chromium or /usr/bin/chromedriver
is absent (.ci/run installs both). Screenshots go to $SPLITLF_SCREENSHOT_DIR, else to the
run's temporary folder (the path is printed).
"""

from __future__ import annotations

import http.client
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import splitlf
from splitlf.model.design import PRESETS

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


# -- without a browser ---------------------------------------------------------------------

def test_import_splitlf_does_not_import_the_explorer():
    code = ("import sys, splitlf; bad = [m for m in ('panel', 'bokeh', 'splitlf.explorer') "
            "if m in sys.modules]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_controls_round_trip_every_preset():
    from splitlf.explorer import model

    for name in PRESETS:
        d = splitlf.Design.preset(name)
        assert model.design_from_texts(model.design_texts(d), len(d.channels)) == d


def test_page_text_is_never_evaluated(tmp_path):
    from splitlf.explorer import model

    marker = tmp_path / "pwned"
    texts = model.design_texts(splitlf.Design.preset("seed"))
    for key in ("F", "channels[1].Kx", "channels[1].f", "channels[2].Q"):
        bad = dict(texts, **{key: f"__import__('pathlib').Path({str(marker)!r}).touch()"})
        with pytest.raises(model.FieldError) as e:
            model.design_from_texts(bad, 2)
        assert e.value.key == key
    assert not marker.exists()
    # Nor does the package hold a way to: no eval, exec or compile of anything.
    for path in (ROOT / "python" / "splitlf" / "explorer").glob("*.py"):
        assert not re.search(r"\b(eval|exec|compile)\s*\(", path.read_text()), path


def test_invalid_values_name_their_control():
    from splitlf.explorer import model

    texts = model.design_texts(splitlf.Design.preset("seed"))
    cases = {"D": "25", "F": "-1", "channels[2].L": "50", "channels[1].Q": "0"}
    for key, text in cases.items():
        with pytest.raises(model.FieldError) as e:
            model.design_from_texts(dict(texts, **{key: text}), 2)
        assert e.value.key == key, (key, e.value.message)
    # Shares summing above 1 concern no one control: the page's banner shows it.
    with pytest.raises(model.FieldError, match="sum to at most 1") as e:
        model.design_from_texts(dict(texts, **{"channels[1].share": "0.9"}), 2)
    assert e.value.key is None


def test_views_are_the_api():
    from splitlf.explorer import model

    d = splitlf.Design.preset("split3")
    v = model.blur_view(d, 0.5)
    c = splitlf.curves(d, v["z"])
    np.testing.assert_array_equal(v["blur_px"], c.blur_px)
    np.testing.assert_array_equal(v["repetitions"], c.repetitions)
    dof = splitlf.depth_of_field(d, 0.5)
    assert [(r, a, b) for r, iv in zip(dof.rows, dof.intervals, strict=True)
            for a, b in iv] == v["dof"]
    s = model.samples_view(splitlf.Design.preset("seed"), 4, 2.0)
    cov = splitlf.coverage(splitlf.Design.preset("seed"), s["z"], window=2.0)
    np.testing.assert_array_equal(s["distinct"], cov.distinct)
    np.testing.assert_array_equal(s["covering_radius"], cov.covering_radius)
    assert 642.0 in np.round(s["z"], 6)  # the out-of-focus planes are sampled


def test_gap_view_is_new_samples_at_the_sweep_depths():
    from splitlf.explorer import model

    seed = splitlf.Design.preset("seed")
    v = model.gap_view(seed, 50)
    # The depths: 50 log-spaced over the samples view's range, plus the out-of-focus
    # planes and the coincidence planes (N <= 3) of every channel inside it.
    lo, hi = 1.875 * seed.F, 125.0 * seed.F
    planes = [seed.out_of_focus_depth(1), seed.out_of_focus_depth(2)]
    for c in (1, 2):
        planes += list(splitlf.coincidence_planes(seed, channel=c, max_n=3).z)
    want = np.concatenate([np.geomspace(lo, hi, 50), planes])
    np.testing.assert_array_equal(v["z"], np.unique(want[(want >= lo) & (want <= hi)]))
    r = splitlf.new_samples(seed, v["z"])
    assert v["rows"] == ("channel 1", "channel 2", "union") and v["note"] == ""
    np.testing.assert_array_equal(v["distinct"], r.distinct)
    finite = np.isfinite(r.max_gap)
    np.testing.assert_array_equal(v["max_gap"][finite], r.max_gap[finite])
    assert np.isnan(v["max_gap"][~finite]).all()
    # Where a channel falls to one sample per lens its gap peaks: the out-of-focus plane
    # of channel 1 is the depth of its largest gap.
    assert v["z"][np.nanargmax(v["max_gap"][0])] == pytest.approx(planes[0], rel=1e-12)
    # A hex channel: the 1-D engine refuses it, the view says why and stays empty.
    hexd = splitlf.Design.preset("raytrix-r12")
    h = model.gap_view(hexd, 20)
    assert h["z"].size == 0 and "grid" in h["note"]
    with pytest.raises(splitlf.InvalidParameter) as e:
        splitlf.new_samples(hexd, [1000.0])
    assert str(e.value) in h["note"]


def test_ray_space_view_is_the_trace_of_the_central_lenses():
    from splitlf.explorer import model

    for name in ("seed", "split3"):
        d = splitlf.Design.preset(name)
        for c in range(1, len(d.channels) + 1):
            v = model.ray_space_view(d, c, 3)
            tr = splitlf.trace(d, channel=c, axis="x")
            K = d.channels[c - 1].Kx
            mid = [(K - 3) // 2 + i for i in range(3)]
            assert sorted(set(v["lens"].tolist())) == mid
            # every lit-or-vignetted pixel of those lenses that collects light, in order
            idx = [i for i in range(len(tr.lens)) if tr.lens[i] in mid and tr.n_vertices[i] > 0]
            assert len(v["us"]) == len(idx) == len(v["ws"])
            for k, i in enumerate(idx):
                n = tr.n_vertices[i]
                np.testing.assert_array_equal(v["us"][k], tr.vertices[i, :n, 0])
                np.testing.assert_array_equal(v["ws"][k], tr.vertices[i, :n, 1])
            # the polygons lie within the aperture, |w| <= D/2
            assert v["half_aperture"] == d.D / 2
            assert max(np.abs(w).max() for w in v["ws"]) <= d.D / 2 * (1 + 1e-12)
            np.testing.assert_array_equal(v["type"], tr.type[idx])
    v = model.ray_space_view(splitlf.Design.preset("raytrix-r12"), 1)
    assert v["us"] == [] and "grid" in v["note"]


def test_blur_axis_end_snaps_to_nice_steps():
    pytest.importorskip("bokeh")
    from splitlf.explorer.app import _nice_ceiling

    cases = {9.0: 10.0, 7.5: 10.0, 0.75: 1.0, 2.1: 2.5, 1.9: 2.0, 10.0: 10.0, 0.3: 0.5,
             46.0: 50.0, 1e-3: 1e-3}
    for x, want in cases.items():
        assert _nice_ceiling(x) == pytest.approx(want, rel=1e-12), x
        assert _nice_ceiling(x) >= x * (1 - 1e-12)


def test_w8_skips_cleanly_without_a_browser(monkeypatch, capsys):
    """benches/run.py --only W8 prints why and records nothing when chromium is absent."""
    monkeypatch.syspath_prepend(str(ROOT / "benches"))
    import run
    import w8_explore

    monkeypatch.setattr(w8_explore, "CHROMIUM", "/nonexistent/chromium")
    assert run.run_w8(quick=True) is None
    assert "W8 skipped: needs Debian's chromium" in capsys.readouterr().out


def test_load_toml_bytes_reads_design_and_camera_files(tmp_path):
    from splitlf.explorer import model

    d = splitlf.Design.preset("raytrix-r12")
    assert model.load_toml_bytes(d.to_toml().encode()) == d
    cam = splitlf.Camera.paper().replace(D=18.0)
    assert model.load_toml_bytes(cam.to_toml().encode()) == cam.design
    with pytest.raises(ValueError, match="not valid TOML"):
        model.load_toml_bytes(b"F = = 3")


# -- the server ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def server():
    pytest.importorskip("bokeh")
    from splitlf.explorer import serve

    srv = serve(splitlf.Design.preset("seed"), threaded=True)
    port = int(srv.url.rsplit(":", 1)[1].strip("/"))
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            time.sleep(0.1)
    yield srv, port
    srv.stop()


def _get(port: int, host: str, path: str = "/", headers: dict | None = None) -> int:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.request("GET", path, headers={"Host": host, **(headers or {})})
    status = conn.getresponse().status
    conn.close()
    return status


def _non_loopback_ips() -> list[str]:
    try:
        out = subprocess.run(["hostname", "-I"], capture_output=True, text=True).stdout
    except OSError:
        return []
    return [ip for ip in out.split() if "." in ip and not ip.startswith("127.")]


def test_server_binds_loopback_and_refuses_other_hosts(server):
    srv, port = server
    assert _get(port, f"127.0.0.1:{port}") == 200
    assert _get(port, f"localhost:{port}") == 200
    # A page or websocket addressed to another host name is refused (DNS rebinding).
    assert _get(port, f"evil.example:{port}") == 403
    ws = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
          "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==", "Origin": "http://evil.example"}
    assert _get(port, f"127.0.0.1:{port}", "/ws", ws) == 403
    # Bound to 127.0.0.1 only: the machine's other addresses do not answer.
    for ip in _non_loopback_ips():
        with pytest.raises(OSError):
            socket.create_connection((ip, port), timeout=2).close()


def test_cli_explore_is_registered_and_checks_its_input(capsys):
    from splitlf.cli import main

    with pytest.raises(SystemExit):
        main(["explore", "--port", "70000"])
    assert "invalid port" in capsys.readouterr().err
    assert main(["explore", "--preset", "seed", "--config", "x.toml"]) == 2


# -- in a real browser -----------------------------------------------------------------------

needs_browser = pytest.mark.skipif(
    not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
    reason=f"needs Debian's chromium and chromium-driver ({CHROMIUM}, {CHROMEDRIVER}); "
    "apt-get install chromium chromium-driver (.ci/run does)")

#: JavaScript: every element matching a selector, through open shadow roots (Bokeh's
#: components live in shadow DOM).
DEEP = """
function deep(root, sel) {
  let out = [...root.querySelectorAll(sel)];
  for (const el of root.querySelectorAll('*'))
    if (el.shadowRoot) out = out.concat(deep(el.shadowRoot, sel));
  return out;
}
"""


class Page:
    """The explorer's page in headless chromium, with helpers that read what is plotted."""

    def __init__(self, driver, url: str, downloads: Path, shots: Path) -> None:
        self.d, self.url, self.downloads, self.shots = driver, url, downloads, shots

    def open(self) -> None:
        self.d.get(self.url)
        self.wait(lambda: self.status()[0] >= 1 and self.status()[1] >= 1, 60)

    def js(self, script: str, *args):
        return self.d.execute_script(DEEP + script, *args)

    def find(self, selector: str):
        found = self.js("return deep(document, arguments[0]);", selector)
        assert found, selector
        return found[0]

    def wait(self, cond, timeout: float = 30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            value = cond()
            if value:
                return value
            time.sleep(0.05)
        raise AssertionError("timed out waiting for the page")

    def status(self) -> tuple[int, int]:
        """(design shown by the closed-form views, design shown by the samples view)."""
        got = self.d.execute_script(
            "const d = window.Bokeh && Bokeh.documents[0];"
            "const s = d && d.get_model_by_name('status');"
            "return s ? [s.data.blur[0], s.data.samples[0]] : [0, 0];")
        return int(got[0]), int(got[1])

    def source(self, name: str) -> dict:
        return self.d.execute_script(
            "const s = Bokeh.documents[0].get_model_by_name(arguments[0]);"
            "const o = {}; for (const k of Object.keys(s.data))"
            "  o[k] = Array.from(s.data[k], v => (v && v.length !== undefined"
            "    && typeof v !== 'string') ? Array.from(v) : v);"
            "return o;", name)

    def type(self, key: str, text: str) -> None:
        from selenium.webdriver.common.keys import Keys

        el = self.find(f'input[placeholder="{key}"]')
        el.send_keys(Keys.END + Keys.BACKSPACE * 40 + text + Keys.ENTER)

    def after_change(self, before: tuple[int, int]) -> None:
        """Wait until every view shows a design newer than ``before``: the closed-form
        views, the 1-D samples and the 2-D coverage."""
        def done() -> bool:
            s = self.status()
            gap = self.d.execute_script(
                "return Bokeh.documents[0].get_model_by_name('status').data.gap[0];")
            return s[0] > before[0] and s[1] == s[0] and int(gap) == s[0]

        self.wait(done, 60)

    def field_error(self, key: str) -> str:
        got = self.js("const e = deep(document, `.field-error[data-key=\"${arguments[0]}\"]`)"
                      "[0]; return e ? e.textContent : '';", key)
        return str(got)

    def report(self) -> dict[str, str]:
        src = self.source("report")
        return dict(zip(src["label"], src["value"], strict=True))

    def screenshot(self, name: str) -> Path:
        path = self.shots / name
        self.d.save_screenshot(str(path))
        print(f"screenshot: {path}")
        return path


def _plotted_blur(page: Page) -> np.ndarray:
    return np.array(page.source("blur")["ys"], dtype=float)


def _api_blur(design: splitlf.Design, z) -> np.ndarray:
    return splitlf.curves(design, np.asarray(z)).blur_px


def _plotted_lines(page: Page, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(depths, values (rows, m)) of a multi_line source (NaN for gaps)."""
    src = page.source(name)
    return (np.asarray(src["xs"][0], dtype=float),
            np.array([[np.nan if v is None else v for v in row] for row in src["ys"]],
                     dtype=float))


def _plotted_points(page: Page, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(depths, values (rows, m)) of a scatter source of every row's points."""
    src = page.source(name)
    rows = np.asarray(src["row"], dtype=int)
    n = int(rows.max()) + 1
    x = np.asarray(src["x"], dtype=float).reshape(n, -1)
    y = np.array([np.nan if v is None else v for v in src["y"]], dtype=float).reshape(n, -1)
    assert (rows.reshape(n, -1) == np.arange(n)[:, None]).all()
    return x[0], y


def _check_samples_figures(page: Page, design: splitlf.Design, prefix: str = "") -> None:
    """The samples figures of the page hold the API's numbers for ``design``: the 1-D
    lines (new_samples at the depths shown) and the 2-D dots (coverage)."""
    z, gap = _plotted_lines(page, prefix + "max_gap")
    r = splitlf.new_samples(design, z)
    np.testing.assert_allclose(gap, np.where(np.isfinite(r.max_gap), r.max_gap, np.nan),
                               rtol=1e-12)
    _, distinct = _plotted_lines(page, prefix + "distinct_1d")
    np.testing.assert_array_equal(distinct, r.distinct)
    z2, cover = _plotted_points(page, prefix + "covering_radius")
    api = splitlf.coverage(design, z2, window=2.0)
    np.testing.assert_allclose(cover, api.covering_radius, rtol=1e-12)
    _, distinct2 = _plotted_points(page, prefix + "distinct")
    np.testing.assert_array_equal(distinct2, api.distinct)


@pytest.fixture(scope="module")
def page(server, tmp_path_factory):
    if not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
        pytest.skip(needs_browser.kwargs["reason"])
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    os.environ.setdefault("SE_OFFLINE", "true")  # never let Selenium Manager fetch anything
    downloads = tmp_path_factory.mktemp("downloads")
    shots = Path(os.environ.get("SPLITLF_SCREENSHOT_DIR")
                 or tmp_path_factory.mktemp("screenshots"))
    shots.mkdir(parents=True, exist_ok=True)
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--window-size=1600,1300", "--disable-gpu"):
        opts.add_argument(arg)
    opts.add_experimental_option("prefs", {"download.default_directory": str(downloads),
                                           "download.prompt_for_download": False})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    driver.execute_cdp_cmd("Browser.setDownloadBehavior",
                           {"behavior": "allow", "downloadPath": str(downloads)})
    srv, _ = server
    p = Page(driver, srv.url, downloads, shots)
    yield p
    driver.quit()


@needs_browser
def test_app_starts_and_figures_render(page):
    page.open()
    seed = splitlf.Design.preset("seed")
    blur = page.source("blur")
    assert blur["label"] == ["channel 1", "channel 2"]
    np.testing.assert_allclose(_plotted_blur(page), _api_blur(seed, blur["xs"][0]),
                               rtol=1e-12)
    assert page.source("max_gap")["label"] == ["channel 1", "channel 2", "union"]
    _check_samples_figures(page, seed)
    assert len(page.source("dof")["row"]) == sum(
        len(iv) for iv in splitlf.depth_of_field(seed).intervals)
    # Every figure drew on its canvas (Bokeh renders each plot into canvas elements).
    assert page.js("return deep(document, '.bk-Canvas, canvas').length;") >= 5
    assert page.report()["channel 1: out-of-focus plane [mm]"] == "642.00"
    page.screenshot("explore_seed.png")


@needs_browser
def test_control_change_plots_what_the_api_returns(page):
    page.open()
    before = page.status()
    page.type("D", "16")
    page.after_change(before)
    design = splitlf.Design.preset("seed").replace(D=16.0)
    z = page.source("blur")["xs"][0]
    np.testing.assert_allclose(_plotted_blur(page), _api_blur(design, z), rtol=1e-12)
    reps = np.array(page.source("repetitions")["ys"], dtype=float)
    np.testing.assert_allclose(reps, splitlf.curves(design, np.asarray(z)).repetitions,
                               rtol=1e-12)
    _check_samples_figures(page, design)
    from splitlf.explorer.model import report_rows

    assert page.report() == dict(report_rows(design))
    page.screenshot("explore_D16.png")


@needs_browser
def test_invalid_value_shows_the_error_and_keeps_the_figures(page):
    page.open()
    shown = _plotted_blur(page)
    before = page.status()
    page.type("D", "25")  # the aperture's image behind a lens would overlap its neighbours
    message = page.wait(lambda: page.field_error("D"))
    with pytest.raises(splitlf.InvalidParameter) as e:
        splitlf.Design.preset("seed").replace(D=25.0)
    assert " ".join(str(e.value).split()) in " ".join(message.split())
    assert "overlap" in message
    time.sleep(0.5)
    assert page.status() == before
    np.testing.assert_array_equal(_plotted_blur(page), shown)
    page.screenshot("explore_invalid.png")
    page.type("channels[1].Kx", "abc")  # not a number: the parser says so, nothing runs
    assert "is not an integer" in page.wait(lambda: page.field_error("channels[1].Kx"))
    assert page.status() == before


@needs_browser
def test_save_then_load_reproduces_the_design(page, tmp_path):
    from selenium.webdriver.support.ui import Select

    page.open()
    before = page.status()
    page.type("channels[1].L", "95.5")
    page.after_change(before)
    design = splitlf.Design.preset("seed")
    design = design.replace(channels=(design.channels[0].replace(L=95.5),
                                      design.channels[1]))
    for f in page.downloads.glob("*"):
        f.unlink()
    page.js("deep(document, 'button').find(b => b.textContent.includes('save TOML'))"
            ".click();")
    saved = page.wait(lambda: [f for f in page.downloads.glob("*.toml")], 30)[0]
    time.sleep(0.3)
    assert splitlf.Design.from_toml(saved) == design
    out = subprocess.run([shutil.which("splitlf") or "splitlf", "report", "--config",
                          str(saved), "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    # Another design, then load the file: the controls and figures are the saved design.
    before = page.status()
    Select(page.find("select")).select_by_value("split3")
    page.after_change(before)
    assert len(page.source("blur")["label"]) == 3
    before = page.status()
    page.find('input[type="file"]').send_keys(str(saved))
    page.after_change(before)
    z = page.source("blur")["xs"][0]
    np.testing.assert_allclose(_plotted_blur(page), _api_blur(design, z), rtol=1e-12)
    assert page.find('input[placeholder="channels[1].L"]').get_attribute("value") == "95.5"


@needs_browser
def test_reference_design_on_the_same_axes(page):
    page.open()
    assert page.source("reference_blur")["label"] == []
    before = page.status()
    page.js("deep(document, 'button').find(b => b.textContent.includes('pin as reference'))"
            ".click();")
    page.after_change(before)
    seed = splitlf.Design.preset("seed")
    before = page.status()
    page.type("D", "16")
    page.after_change(before)
    ref = page.source("reference_blur")
    assert ref["label"] == ["reference channel 1", "reference channel 2"]
    np.testing.assert_allclose(np.array(ref["ys"], dtype=float),
                               _api_blur(seed, ref["xs"][0]), rtol=1e-12)
    np.testing.assert_allclose(_plotted_blur(page),
                               _api_blur(seed.replace(D=16.0), ref["xs"][0]), rtol=1e-12)
    _check_samples_figures(page, seed, "reference_")
    _check_samples_figures(page, seed.replace(D=16.0))
    assert "reference" in page.source("dof")["row"]
    page.screenshot("explore_reference.png")


@needs_browser
def test_sample_map_and_microlens_images_at_a_picked_depth(page):
    from selenium.webdriver.common.action_chains import ActionChains

    page.open()
    seed = splitlf.Design.preset("seed")
    page.wait(lambda: len(page.source("sample_map")["x"]) > 0)
    image = page.source("microlens_image")
    assert len(image["image"]) == 1
    page.type("map_z", "300")

    def shown():
        got = page.source("sample_map")
        r = splitlf.samples_2d(seed, 300.0, window=2.0)
        delta = seed.resolution_step(300.0)
        want = np.concatenate([r.samples[k] for k in range(2)]) / delta
        if len(got["x"]) != len(want):
            return False
        np.testing.assert_allclose(np.c_[got["x"], got["y"]], want, rtol=1e-12)
        return True

    page.wait(shown)
    # A click on the blur figure picks the depth under the pointer.
    canvas = page.js("return deep(document, '.bk-Canvas, canvas').filter("
                     "e => e.getBoundingClientRect().width > 600)[0];")
    before = page.find('input[placeholder="map_z"]').get_attribute("value")
    ActionChains(page.d).move_to_element(canvas).click().perform()
    picked = page.wait(lambda: (v := page.find('input[placeholder="map_z"]')
                                .get_attribute("value")) != before and v)
    assert 1.25 * seed.F <= float(picked) <= 125 * seed.F


@needs_browser
def test_ray_space_of_the_open_channel(page):
    from splitlf.explorer.model import ray_space_view

    page.open()
    seed = splitlf.Design.preset("seed")

    def shows(channel: int) -> bool:
        got = page.source("ray_space")
        want = ray_space_view(seed, channel)
        if len(got["us"]) != len(want["us"]) or got["lens"] != want["lens"].tolist():
            return False
        for gu, gw, wu, ww in zip(got["us"], got["ws"], want["us"], want["ws"], strict=True):
            np.testing.assert_allclose(gu, wu, rtol=1e-12)
            np.testing.assert_allclose(gw, ww, rtol=1e-12)
        return True

    page.wait(lambda: shows(1))
    # Open channel 2's tab: the ray space (and microlens images) follow it.
    page.js("deep(document, '.bk-tab').find(t => t.textContent.trim() === 'channel 2')"
            ".click();")
    page.wait(lambda: shows(2))
    page.js("deep(document, '.bk-tab').find(t => t.textContent.trim() === 'channel 1')"
            ".click();")
    page.wait(lambda: shows(1))


def test_running_server_shows_inline_in_jupyter(monkeypatch):
    """In a Jupyter kernel ``splitlf.explore`` returns at once with the server running in
    the background, and the notebook shows it through ``_repr_html_`` (an IFrame of the
    page): checked with a stand-in for IPython's kernel, without a notebook server."""
    pytest.importorskip("bokeh")
    import types

    class Shell:
        kernel = object()

    fake = types.ModuleType("IPython")
    fake.get_ipython = lambda: Shell()  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "IPython", fake)
    running = splitlf.explore(splitlf.Design.preset("split3"))
    try:
        html = running._repr_html_()
        assert re.fullmatch(r'<iframe src="http://127\.0\.0\.1:\d+/" width="100%" '
                            r'height="900" style="border:0" title="splitlf explorer"></iframe>',
                            html), html
        port = int(running.url.rsplit(":", 1)[1].strip("/"))
        assert _get(port, f"127.0.0.1:{port}") == 200
    finally:
        running.stop()
    # Outside a kernel (IPython imported but no kernel): no background server; serve()
    # would block, so only the decision is checked.
    fake.get_ipython = lambda: None  # type: ignore[attr-defined]
    assert splitlf._in_jupyter_kernel() is False
    monkeypatch.delitem(sys.modules, "IPython")
    assert splitlf._in_jupyter_kernel() is False


def test_explorer_builds_without_a_session():
    """An :class:`Explorer` built outside a server (``doc=None``, as for
    ``bokeh.io.show`` in a notebook) fills its views at once, from the API."""
    pytest.importorskip("bokeh")
    from bokeh.models import LayoutDOM

    from splitlf.explorer.app import Explorer

    ex = Explorer(splitlf.Design.preset("seed"))
    assert isinstance(ex.layout, LayoutDOM)
    np.testing.assert_array_equal(np.array(ex.blur_src.data["ys"]),
                                  splitlf.curves(ex.design, ex.blur_src.data["xs"][0]).blur_px)
    gap = splitlf.new_samples(ex.design, ex.gap_src.data["xs"][0]).max_gap
    np.testing.assert_array_equal(np.array(ex.gap_src.data["ys"]),
                                  np.where(np.isfinite(gap), gap, np.nan))


def test_serve_checks_its_arguments():
    pytest.importorskip("bokeh")
    from splitlf.explorer import serve

    with pytest.raises(TypeError, match="design must be"):
        serve("seed", threaded=True)
    with pytest.raises(TypeError, match="reference must be"):
        serve(None, reference=3, threaded=True)
    with pytest.raises(ValueError):
        serve(None, address="not an address", threaded=True)


def _half_cut() -> splitlf.Design:
    """The seed's half 1 alone, cut to 12 x 8 lenses: image merits in about a second a
    depth."""
    seed = splitlf.Design.preset("seed")
    return seed.replace(channels=(seed.channels[0].replace(Kx=12, Ky=8),))


def _wait_idle(e, timeout: float = 300.0) -> None:
    deadline = time.monotonic() + timeout
    while e._worker_busy:
        assert time.monotonic() < deadline, "the explorer's worker did not finish"
        time.sleep(0.05)


def test_image_photons_are_checked_before_any_work():
    """A bad photon count is shown beside its control and starts nothing; a new design
    empties the image figures and says how to fill them again."""
    from splitlf.explorer.app import IMAGE_IDLE, IMAGE_PHOTONS, Explorer

    e = Explorer(_half_cut())
    _wait_idle(e)
    e._widgets["D"].value = "abc"  # a design error, which the photon count's must not clear
    design_error = e._errors["D"].text
    assert design_error and e.banner.visible
    for text in ("-3", "abc", "inf", "nan"):
        e.image_photons.value = text
        e.request_image()
        assert e._errors[IMAGE_PHOTONS].visible, text
        assert IMAGE_PHOTONS in e._errors[IMAGE_PHOTONS].text, text
        assert "image" not in e._pending and not e._worker_busy
        assert e._errors["D"].text == design_error and e.banner.visible
    assert e.image_status.text == IMAGE_IDLE
    assert e.psnr_src.data["label"] == [] and e.mtf_src.data["label"] == []


def test_image_view_is_the_api_and_the_button_plots_it():
    """The image view is splitlf.image_merits at its depths (5 log-spaced over 3.75 F to
    25 F and the out-of-focus plane) bit for bit; the button computes it on the worker and
    plots it (lines and points) for the design shown; a new design empties it again."""
    from splitlf.explorer import model
    from splitlf.explorer.app import IMAGE_IDLE, Explorer

    d = _half_cut()
    z = model.image_depths(d)
    np.testing.assert_allclose(z, np.sort([*np.geomspace(300.0, 2000.0, 5),
                                           d.out_of_focus_depth(1)]), rtol=1e-12)
    want = splitlf.image_merits(d, z, 1500.0, n_threads=model.THREADS)
    e = Explorer(d)
    _wait_idle(e)
    e.image_photons.value = "1500"
    e.request_image()
    assert "Computing" in e.image_status.text
    _wait_idle(e)
    assert e.psnr_src.data["label"] == ["channel 1", "union"]
    for k, row in enumerate(["channel 1", "union"]):
        np.testing.assert_array_equal(e.psnr_src.data["xs"][k], z)
        np.testing.assert_array_equal(e.psnr_src.data["ys"][k], want.rows[row]["psnr"])
        got = np.asarray(e.mtf_src.data["ys"][k], dtype=float)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want.rows[row]["mtf50"]))
        np.testing.assert_array_equal(got[~np.isnan(got)],
                                      want.rows[row]["mtf50"][~np.isnan(got)])
    assert "1500 photons" in e.image_status.text
    np.testing.assert_array_equal(e.psnr_pts_src.data["y"], np.ravel(
        [want.rows[r]["psnr"] for r in ("channel 1", "union")]))
    e.set_design(d.replace(D=d.D * 0.9))
    _wait_idle(e)
    assert e.psnr_src.data["label"] == [] and e.image_status.text == IMAGE_IDLE


@needs_browser
def test_image_quality_button_in_the_page(page, tmp_path):
    """In chromium: load a design, set the photons, press "predict image quality"; the
    page's PSNR and MTF50 lines are splitlf.image_merits' for that design."""
    from splitlf.explorer import model

    page.open()
    d = _half_cut()
    path = tmp_path / "half.toml"
    d.to_toml(path)
    before = page.status()
    page.find('input[type="file"]').send_keys(str(path))
    page.after_change(before)
    page.type("image_photons", "1500")
    page.js("deep(document, 'button').find(b => b.textContent.includes('predict image'))"
            ".click();")
    page.wait(lambda: page.source("image_psnr")["label"], 300)
    z, psnr = _plotted_lines(page, "image_psnr")
    _, mtf = _plotted_lines(page, "image_mtf50")
    want = splitlf.image_merits(d, model.image_depths(d), 1500.0, n_threads=model.THREADS)
    np.testing.assert_allclose(z, model.image_depths(d), rtol=1e-12)
    rows = ["channel 1", "union"]
    assert page.source("image_psnr")["label"] == rows
    np.testing.assert_allclose(psnr, [want.rows[r]["psnr"] for r in rows], rtol=1e-12)
    np.testing.assert_allclose(mtf, [want.rows[r]["mtf50"] for r in rows], rtol=1e-12)
    page.js("deep(document, 'button').find(b => b.textContent.includes('predict image'))"
            ".scrollIntoView();")
    time.sleep(0.5)
    page.screenshot("explore_image_quality.png")
