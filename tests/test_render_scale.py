"""A render split over an executor (bands of raw rows as tasks) is the in-process render
bit for bit, and ``splitlf dataset`` writes raws with their ground truth
(docs/render.md, "Scale-out and datasets")."""

from __future__ import annotations

import concurrent.futures as cf
import json
from pathlib import Path

import numpy as np
import pytest

import splitlf
from splitlf import Design, Image, Plane, Raw, Scene, render
from splitlf.errors import InvalidParameter
from splitlf.imaging import bands as bands_module
from splitlf.imaging.bands import bands


def seed_cut() -> Design:
    """The seed on 6 x 4 lenses per channel: the exact route (rect, square, ideal)."""
    d = Design.preset("seed")
    return d.replace(channels=tuple(c.replace(Kx=6, Ky=4) for c in d.channels))


def r12_cut() -> Design:
    """raytrix-r12 on 3 x 3 lenses: the general route (hex, circle, sensor layout)."""
    d = Design.preset("raytrix-r12")
    return d.replace(channels=tuple(c.replace(Kx=3, Ky=3, Mx=None, My=None)
                                    for c in d.channels))


def same(a: Raw, b: Raw) -> bool:
    """Bit for bit: every channel's values (as bytes) and the recorded noise."""
    return (len(a.images) == len(b.images) and a.noise == b.noise
            and all(x.shape == y.shape and x.tobytes() == y.tobytes()
                    for x, y in zip(a.images, b.images, strict=True)))


def test_bands_cut_each_channel_into_consecutive_rows():
    """Hand-listed: 7-row bands over raws of 20 and 9 rows; the default cuts the total rows
    into at most 64 tasks (plus one per channel for the remainders)."""
    assert bands([(20, 5), (9, 3)], 7) == [(0, 0, 7), (0, 7, 14), (0, 14, 20),
                                          (1, 0, 7), (1, 7, 9)]
    assert bands([(20, 5), (9, 3)], None) == [(c, r, r + 1) for c, n in ((0, 20), (1, 9))
                                              for r in range(n)]
    big = bands([(1320, 3990), (1320, 3990)], None)  # the seed's raws: 42 rows a task
    assert {r1 - r0 for _, r0, r1 in big} == {42, 1320 - 31 * 42}
    assert len(big) == 64


@pytest.mark.parametrize("kind", ["thread", "process"])
@pytest.mark.parametrize("name", ["seed", "r12"])
def test_executor_render_is_the_in_process_render(name, kind):
    """The seed cut (exact route) and raytrix-r12 cut (general route, tol 1e-2), a random
    texture drawn from the seed and photon noise: the raw on a 2-worker thread or process
    pool equals the in-process raw bit for bit, with the default bands and with 5-row
    bands that end inside a lens's rows."""
    design, tol = (seed_cut(), None) if name == "seed" else (r12_cut(), 1e-2)
    scene = Scene("random", 900.0)
    kw = {"noise": {"photons": 500.0, "read_noise": 2.0}, "seed": 7, "tol": tol}
    here = render(design, scene, **kw)
    pool = cf.ThreadPoolExecutor if kind == "thread" else cf.ProcessPoolExecutor
    with pool(2) as ex:
        for rows in (None, 5):
            raw = render(design, scene, executor=ex, rows_per_task=rows, **kw)
            assert same(raw, here), (rows, [np.abs(a - b).max() for a, b
                                            in zip(raw.images, here.images, strict=True)])
    assert here.images[0].std() > 0  # a textured, noisy raw, not zeros


def test_dask_local_cluster_render_is_the_in_process_render(monkeypatch):
    """On a 2-worker LocalCluster (in-process workers), the same raw bit for bit; the
    scene is scattered once to every worker, not sent with each task."""
    distributed = pytest.importorskip("distributed")
    design, scene = seed_cut(), Scene("random", 700.0)
    here = render(design, scene, noise={"photons": 300.0}, seed=3)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        scattered = []
        real = client.scatter

        def scatter(data, **kw):
            scattered.append((type(data[0][2]).__name__, kw))
            return real(data, **kw)

        monkeypatch.setattr(client, "scatter", scatter)
        raw = render(design, scene, noise={"photons": 300.0}, seed=3,
                     executor=client.get_executor(), rows_per_task=9)
    assert same(raw, here)
    assert scattered == [("ndarray", {"broadcast": True})]


@pytest.mark.parametrize(("kw", "error", "name"), [
    ({"executor": object()}, TypeError, "executor"),
    ({"executor": cf.ThreadPoolExecutor}, TypeError, "executor"),
    ({"executor": "tcp://localhost:8786"}, TypeError, "executor"),
    ({"rows_per_task": 4}, InvalidParameter, "rows_per_task"),
    ({"executor": "pool", "rows_per_task": 0}, InvalidParameter, "rows_per_task"),
    ({"executor": "pool", "rows_per_task": -3}, InvalidParameter, "rows_per_task"),
    ({"executor": "pool", "rows_per_task": 2.5}, TypeError, "rows_per_task"),
    ({"executor": "pool", "rows_per_task": True}, TypeError, "rows_per_task"),
])
def test_bad_executor_or_rows_per_task_is_refused_by_name(kw, error, name):
    with cf.ThreadPoolExecutor(1) as pool:
        kw = {k: pool if v == "pool" else v for k, v in kw.items()}
        with pytest.raises(error, match=name):
            render(seed_cut(), Scene(0.5, 900.0), **kw)
    if error is InvalidParameter:
        with pytest.raises(InvalidParameter) as e:
            render(seed_cut(), Scene(0.5, 900.0), **kw)
        assert e.value.name == name


class _Stalled(cf.Executor):
    """An executor whose first task raises ``KeyboardInterrupt`` (Ctrl-C while the caller
    waits) and whose other tasks never start: what a Ctrl-C leaves pending."""

    def __init__(self) -> None:
        self.futures: list[cf.Future] = []

    def submit(self, fn, /, *args, **kwargs):
        fut: cf.Future = cf.Future()
        if not self.futures:
            fut.set_exception(KeyboardInterrupt())
        self.futures.append(fut)
        return fut


def test_ctrl_c_cancels_the_pending_tasks():
    ex = _Stalled()
    with pytest.raises(KeyboardInterrupt):
        render(seed_cut(), Scene(0.5, 900.0), executor=ex, rows_per_task=10)
    shapes = [(ch["Ky"] * ch["Q"], ch["Kx"] * ch["Q"]) for ch in seed_cut().resolved()]
    assert len(ex.futures) == len(bands(shapes, 10)) > 1
    assert all(f.cancelled() for f in ex.futures[1:])


def test_band_task_is_one_band_of_the_raw():
    """The worker task alone: rows 5..17 of channel 2 (from 0: 1) of a seeded scene."""
    design = seed_cut()
    scene = Scene("random", 900.0)
    whole = render(design, scene, seed=4)
    from splitlf.imaging.render import scene_parts

    parts = scene_parts(scene, design, np.random.default_rng([4, 0]))
    band = bands_module.band_task(design, parts, (1, 5, 17), 1e-3, 1)
    assert band.tobytes() == whole.images[1][5:17].tobytes()


# -- the command line ---------------------------------------------------------------------


def _toml(folder: Path, design: Design) -> str:
    path = folder / "d.toml"
    path.write_text(design.to_toml())
    return str(path)


def test_render_cli_on_a_scheduler_writes_the_same_raw(tmp_path):
    distributed = pytest.importorskip("distributed")
    from splitlf.cli import main

    toml = _toml(tmp_path, seed_cut())
    args = ["render", toml, "--texture", "random", "--depth", "800", "--noise", "400",
            "--seed", "2"]
    assert main([*args, "-o", str(tmp_path / "a.npz")]) == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        assert main([*args, "-o", str(tmp_path / "b.npz"), "--threads", "1",
                     "--scheduler", cluster.scheduler_address]) == 0
    assert same(Raw.load(tmp_path / "a.npz"), Raw.load(tmp_path / "b.npz"))


def _expected_scene(seed: int, depths: tuple[float, float], tilt: float
                    ) -> tuple[float, float, float, np.random.Generator]:
    """The documented draw, written out again: Z0 log-uniform, then GX, GY (tilt > 0),
    then the cells, from default_rng([seed, 2])."""
    rng = np.random.default_rng([seed, 2])
    z0 = depths[0] * (depths[1] / depths[0]) ** rng.uniform()
    gx, gy = rng.uniform(-tilt, tilt, 2) if tilt > 0 else (0.0, 0.0)
    return z0, gx, gy, rng


@pytest.mark.parametrize("case", ["fronto", "tilted"])
def test_dataset_writes_raws_that_are_the_render_of_their_truth(tmp_path, capsys, case):
    """Three scenes of the seed cut (fronto-parallel planes, noise) or two of it cut to
    2 x 2 lenses on tilted planes with 2 mm cells: every raw reloaded is splitlf.render of
    the scene its truth file records, bit for bit; the draws follow the documented
    distribution; the texture covers what the pixels see at Z0; the index lists them."""
    from splitlf.cli import main

    if case == "fronto":
        design, n, extra, tilt, cell = seed_cut(), 3, [], 0.0, None
    else:
        d = Design.preset("seed")
        design = d.replace(channels=tuple(c.replace(Kx=2, Ky=2) for c in d.channels))
        n, tilt, cell = 2, 0.05, 2.0
        extra = ["--tilt", "0.05", "--cell", "2"]
    out = tmp_path / "ds"
    argv = ["dataset", _toml(tmp_path, design), "-n", str(n), "-o", str(out), "--seed",
            "11", "--depths", "300:3000", "--noise", "800,1.5", *extra]
    assert main(argv) == 0
    assert capsys.readouterr().out == f"{out / 'index.json'}\n"
    index = json.loads((out / "index.json").read_text())
    assert index["format"] == "splitlf-dataset/1" and len(index["scenes"]) == n
    names = {p.name for p in out.iterdir()}
    assert names == {"index.json"} | {f"scene{k}{s}.npz" for k in range(n)
                                      for s in ("", "_truth")}
    for k, rec in enumerate(index["scenes"]):
        assert (rec["raw"], rec["truth"], rec["seed"]) == (f"scene{k}.npz",
                                                           f"scene{k}_truth.npz", 11 + k)
        truth = np.load(out / rec["truth"])
        assert str(truth["format"]) == "splitlf-truth/1"
        z0, gx, gy, rng = _expected_scene(11 + k, (300.0, 3000.0), tilt)
        assert truth["plane"].tolist() == [z0, gx, gy] == rec["plane"]
        texture, ext = truth["texture"], truth["texture_extent"]
        assert texture.tobytes() == rng.uniform(0.0, 1.0, texture.shape).tobytes()
        step = design.resolution_step(z0) if cell is None else cell
        assert ext.tolist() == pytest.approx([-texture.shape[1] * step / 2,
                                              texture.shape[1] * step / 2,
                                              -texture.shape[0] * step / 2,
                                              texture.shape[0] * step / 2], rel=1e-12)
        x0, x1, y0, y1 = splitlf._native.render_extent(design.core, z0)
        assert ext[0] <= x0 and ext[1] >= x1 and ext[2] <= y0 and ext[3] >= y1
        scene = Scene(Image(texture, ext[1] - ext[0]), Plane(*truth["plane"]))
        assert float(truth["background"]) == scene.background
        again = render(design, scene, noise={"photons": 800.0, "read_noise": 1.5},
                       seed=11 + k)
        assert same(Raw.load(out / rec["raw"]), again)
    if case == "fronto":  # log-uniform over [300, 3000]: the three drawn depths differ
        assert len({r["plane"][0] for r in index["scenes"]}) == 3


def test_dataset_on_a_scheduler_is_the_same_dataset(tmp_path):
    distributed = pytest.importorskip("distributed")
    from splitlf.cli import main

    toml = _toml(tmp_path, seed_cut())
    base = ["dataset", toml, "-n", "2", "--seed", "5", "--noise", "300"]
    assert main([*base, "-o", str(tmp_path / "a")]) == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        assert main([*base, "-o", str(tmp_path / "b"), "--threads", "1",
                     "--scheduler", cluster.scheduler_address]) == 0
    for name in ("scene0.npz", "scene1.npz", "scene0_truth.npz", "scene1_truth.npz",
                 "index.json"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_dataset_interrupted_leaves_complete_files_only(tmp_path, monkeypatch, capsys):
    """Ctrl-C during the second scene's render: scene 0's two files complete, nothing of
    scene 1, no index, no temporary file; a rerun refuses the existing files without
    --force, naming one, and writes nothing."""
    import splitlf.imaging.render as render_module
    from splitlf.cli import main

    calls = []
    real = render_module.render

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(render_module, "render", interrupted)
    out = tmp_path / "ds"
    argv = ["dataset", _toml(tmp_path, seed_cut()), "-n", "3", "-o", str(out)]
    assert main(argv) == 130
    assert sorted(p.name for p in out.iterdir()) == ["scene0.npz", "scene0_truth.npz"]
    Raw.load(out / "scene0.npz")
    monkeypatch.setattr(render_module, "render", real)
    capsys.readouterr()
    assert main(argv) == 2
    assert "scene0.npz: exists" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["scene0.npz", "scene0_truth.npz"]


@pytest.mark.parametrize(("args", "message"), [
    (["--depths", "50:900"], "--depths 50:900: allowed F = 80 < ZMIN <= ZMAX"),
    (["--depths", "900"], "--depths 900: expected ZMIN:ZMAX"),
    (["--seed", str(2**63 - 1)], "must stay below 2**63"),
])
def test_dataset_refuses_bad_options_before_any_file(tmp_path, capsys, args, message):
    from splitlf.cli import main

    out = tmp_path / "ds"
    assert main(["dataset", "seed", "-n", "2", "-o", str(out), *args]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_dataset_help_documents_the_distribution(capsys):
    from splitlf.cli import main

    with pytest.raises(SystemExit):
        main(["dataset", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for words in ("log-uniform", "default_rng([S + k, 2])", "sceneK_truth.npz",
                  "index.json", "--scheduler"):
        assert words in text, words
