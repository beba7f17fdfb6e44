"""Inverse design (splitlf.optimise): closed-form optima, determinism, executors, the
history's validity, named errors, and the CLI."""

from __future__ import annotations

import concurrent.futures as cf
import json
import math

import numpy as np
import pytest

import splitlf
from splitlf import Camera, Design, _native
from splitlf.cli import main
from splitlf.errors import InvalidParameter
from splitlf.study.merit import merit_names
from splitlf.study.optimise import optimise

pytest.importorskip("scipy")
pd = pytest.importorskip("pandas")

Z = np.geomspace(150.0, 10_000.0, 20)
FAST = {"depths": Z, "maxiter": 15, "popsize": 8}
SEED = Camera.paper()
#: Relative accuracy the optimiser reaches on the smooth closed-form problems below (the
#: polish converges to ~1e-13; the tests allow 1e-9).
RTOL = 1e-9


# -- closed-form optima --------------------------------------------------------------------

def test_kappa_that_puts_half2_out_of_focus_plane_at_a_stated_depth():
    # z_2 = F L_2 / (L_2 - F) = 300 mm  <=>  L_2 = 300 F / (300 - F), kappa = L_2 / v' - 1.
    target = 300.0
    kappa = SEED.F * target / (target - SEED.F) / SEED.v1 - 1.0
    res = optimise(SEED, {"kappa": (0.05, 0.8)},
                   lambda m: abs(m["out_of_focus_depth_channel2"] - target), sense="min", **FAST)
    assert res.feasible
    assert res.free["kappa"] == pytest.approx(kappa, rel=RTOL)
    assert res.design.out_of_focus_depth(2) == pytest.approx(target, rel=RTOL)
    assert res.active == ()  # an interior optimum


def test_fastest_aperture_that_keeps_half1_f_number_matched():
    # image_fill_channel1 = D v / (v' Q mu) <= 1: the largest D is Q mu v' / v (f-number
    # matched); with v = 0.5 mm it lies below the overlap limit d (v' + v) / v.
    base = SEED.replace(v=0.5)
    d_star = base.Q * base.mu * base.v1 / base.v
    assert d_star < base.d * (base.v1 + base.v) / base.v
    res = optimise(base, {"D": (8.0, 40.0)}, "f_number", sense="min",
                   constraints={"image_fill_channel1": ("<=", 1.0)}, **FAST)
    assert res.feasible
    assert res.free["D"] == pytest.approx(d_star, rel=RTOL)
    assert res.active == ("constraint: image_fill_channel1 <= 1.0",)
    assert 0.0 <= res.slack["image_fill_channel1 <= 1.0"] < RTOL


def test_overlapping_microlens_images_bound_the_aperture():
    # Without a constraint the largest D is where half 1's images would overlap (§9):
    # D v / v' = d (1 + v / v'), i.e. D = d (v' + v) / v. The optimum says so.
    base = SEED.replace(v=0.5)
    d_star = base.d * (base.v1 + base.v) / base.v
    res = optimise(base, {"D": (8.0, 40.0)}, "f_number", sense="min", **FAST)
    assert res.free["D"] == pytest.approx(d_star, rel=RTOL)
    assert len(res.active) == 1 and res.active[0].startswith("physical: invalid D")
    assert "overlap" in res.active[0]
    assert res.history.loc[~res.history["valid"], "violated"].eq("D").all()


def test_microlens_f_number_floor_binds():
    # Ng's setting: f_1 = 1 / (1/v' + 1/v); f_1 / d = 4 gives v = 1 / (1/(4 d) - 1/v').
    v_star = 1.0 / (1.0 / (4.0 * SEED.d) - 1.0 / SEED.v1)
    res = optimise(SEED, {"v": (0.3, 1.0)}, "microlens_f_number_channel1", sense="min",
                   min_microlens_f_number=4.0, **FAST)
    assert res.free["v"] == pytest.approx(v_star, rel=RTOL)
    assert res.merits["microlens_f_number_channel1"] >= 4.0
    assert len(res.active) == 1 and "min_microlens_f_number" in res.active[0]


def test_integer_field_is_searched_as_an_integer():
    # The seed's half-1 image is 15 pixels wide (v = d v'/D, d = 15 mu): Q = 15 fills it.
    res = optimise(SEED, {"Q": (9, 21)}, lambda m: abs(m["image_fill_channel1"] - 1.0),
                   sense="min", **FAST)
    assert res.free["Q"] == 15 and isinstance(res.design.Q, int)
    assert res.history["Q"].dtype == np.int64
    assert res.merits["image_fill_channel1"] == pytest.approx(1.0, rel=1e-12)


def test_bound_is_reported_active():
    res = optimise(SEED, {"kappa": (0.05, 0.3)}, lambda m: m["out_of_focus_depth_channel2"],
                   sense="max", **FAST)
    assert res.free["kappa"] == pytest.approx(0.05, rel=1e-6)
    assert res.active == ("bound: kappa >= 0.05",)


# -- determinism and executors --------------------------------------------------------------

PROBLEM = dict(free={"kappa": (0.05, 0.8), "D": (8.0, 40.0), "Q": (11, 17)},
               objective="sharp_fraction_union",
               constraints={"max_gap_worst_union": ("<=", 3.0)}, depths=Z, maxiter=6,
               popsize=5, polish_maxfev=30)


@pytest.fixture(scope="module")
def in_process():
    return optimise(SEED, **PROBLEM)


def _same(a, b):
    assert a.design == b.design and a.merits == b.merits and a.active == b.active
    pd.testing.assert_frame_equal(a.history, b.history)


def test_deterministic_for_a_seed(in_process):
    _same(in_process, optimise(SEED, **PROBLEM))
    other = optimise(SEED, **{**PROBLEM, "seed": 1})
    assert not other.history[["kappa", "D"]].equals(in_process.history[["kappa", "D"]])


def test_thread_pool_gives_the_in_process_result(in_process):
    with cf.ThreadPoolExecutor(2) as ex:
        _same(in_process, optimise(SEED, executor=ex, batch_size=3, **PROBLEM))


def test_dask_local_cluster_gives_the_in_process_result(in_process):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        _same(in_process, optimise(SEED, executor=client.get_executor(), **PROBLEM))


# -- the history: every design valid, invalid ones never reach the core ----------------------

def test_invalid_designs_never_reach_the_core(monkeypatch):
    reached = []
    real = _native.design_figures_of_merit

    def spy(core, z, *args):
        reached.append(Design._from_core(core))
        return real(core, z, *args)

    monkeypatch.setattr(_native, "design_figures_of_merit", spy)
    # v' below F, apertures whose microlens images overlap, microlens f-numbers below 4:
    # all inside these bounds.
    res = optimise(SEED, {"v1": (75.0, 100.0), "D": (10.0, 30.0), "v": (0.4, 0.8)},
                   "sharp_fraction_union", min_microlens_f_number=4.0, depths=Z, maxiter=5,
                   popsize=6, polish_maxfev=20)
    h = res.history
    assert len(h) == res.nfev and set(h["stage"]) == {"init", "de", "polish", "probe"}
    assert (~h["valid"]).sum() > 20 and h["valid"].sum() == len(reached)
    assert set(h.loc[~h["valid"], "violated"]) == {"v1", "D",
                                                   "min_microlens_f_number"}
    for d in reached:  # what reached the core is a valid design
        assert min(f / ch["d"] for ch in d.resolved() for f in ch["f"]) >= 4.0
    for row in h[h["valid"]].itertuples():
        Camera.paper().replace(v1=row.v1, D=row.D, v=row.v).design  # noqa: B018
    names = list(merit_names(SEED))
    assert h.loc[~h["valid"], names].isna().all().all()
    assert h.loc[h["valid"], names].notna().all().all()
    assert (h["feasible"] == h["valid"]).all()  # no user constraints


def test_infeasible_and_impossible_problems():
    res = optimise(SEED, {"kappa": (0.05, 0.8)}, "sharp_fraction_union",
                   constraints={"max_gap_worst_union": ("<=", 0.5)}, depths=Z, maxiter=3,
                   popsize=4)
    assert not res.feasible and res.active == ()
    assert res.slack["max_gap_worst_union <= 0.5"] < 0
    with pytest.raises(splitlf.InvalidParameter, match="v1") as e:
        optimise(SEED, {"v1": (60.0, 79.0)}, "sharp_fraction_union", depths=Z, maxiter=2,
                 popsize=3)
    assert e.value.name == "free"


# -- named errors -----------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, exc, match", [
    ({"free": {}}, TypeError, "free"),
    ({"free": {"focal": (1.0, 2.0)}}, splitlf.InvalidParameter, "focal"),
    ({"free": {"D": (40.0, 8.0)}}, splitlf.InvalidParameter, "low < high"),
    ({"free": {"D": (8.0, math.inf)}}, splitlf.InvalidParameter, "finite"),
    ({"free": {"D": 8.0}}, TypeError, "pair"),
    ({"free": {"Q": (9.5, 21)}}, splitlf.InvalidParameter, "integer bounds"),
    ({"objective": "sharpness"}, splitlf.InvalidParameter, "merit name"),
    ({"objective": 3}, TypeError, "objective"),
    ({"objective": "f_number"}, splitlf.InvalidParameter, "sense"),
    ({"sense": "maximise"}, splitlf.InvalidParameter, "sense"),
    ({"constraints": {"gap": ("<=", 1.0)}}, splitlf.InvalidParameter, "gap"),
    ({"constraints": {"f_number": ("<", 1.0)}}, splitlf.InvalidParameter, "'<='"),
    ({"constraints": {"f_number": ("<=", math.nan)}}, splitlf.InvalidParameter, "finite"),
    ({"constraints": {"f_number": 4.0}}, TypeError, "pair"),
    ({"constraints": [("f_number", "<=", 4.0)]}, TypeError, "mapping"),
    ({"depths": [500.0]}, splitlf.InvalidParameter, "depths"),
    ({"min_microlens_f_number": -1.0}, splitlf.InvalidParameter, "min_microlens"),
    ({"de_options": {"workers": 2}}, splitlf.InvalidParameter, "de_options"),
    ({"maxiter": 0}, splitlf.InvalidParameter, "maxiter"),
    ({"seed": -1}, splitlf.InvalidParameter, "seed"),
    ({"executor": 2}, TypeError, "executor"),
])
def test_bad_arguments_are_named(kwargs, exc, match):
    args = {"free": {"D": (8.0, 40.0)}, "objective": "sharp_fraction_union", **kwargs}
    with pytest.raises(exc, match=match):
        optimise(SEED, depths=kwargs.get("depths", Z),
                 **{k: v for k, v in args.items() if k != "depths"})


def test_camera_and_design_bases_name_the_same_merits():
    # a Camera is a Design: one set of merit names (per channel and union) for both; the
    # camera-only names of the two-engine code are gone
    for base in (SEED, splitlf.Design.preset("seed")):
        with pytest.raises(InvalidParameter, match="sharp_fraction_union"):
            optimise(base, {"D": (8.0, 40.0)}, "sharp_fraction_split")
    with pytest.raises(TypeError, match="Design"):
        optimise({"D": 20.0}, {"D": (8.0, 40.0)}, "sharp_fraction_union")


def test_objective_callable_errors_propagate():
    class Boom(Exception):
        pass

    def boom(m):
        raise Boom("no")

    with pytest.raises(Boom):
        optimise(SEED, {"D": (8.0, 40.0)}, boom, sense="max", depths=Z, maxiter=2)
    with pytest.raises(TypeError, match="real number"):
        optimise(SEED, {"D": (8.0, 40.0)}, lambda m: "best", sense="max", depths=Z,
                 maxiter=2)


def test_progress_bar_over_generations(capsys):
    pytest.importorskip("tqdm")
    optimise(SEED, {"kappa": (0.05, 0.8)}, "sharp_fraction_union", depths=Z, maxiter=3,
             popsize=3, polish=False, progress=True)
    assert "splitlf optimise" in capsys.readouterr().err


# -- CLI ----------------------------------------------------------------------------------------

def test_cli_writes_a_toml_that_report_reads(tmp_path, capsys):
    out, hist = tmp_path / "best.toml", tmp_path / "history.csv"
    argv = ["optimise", "--free", "kappa=0.05:0.8", "--free", "Q=11:17",
            "--objective", "sharp_fraction_union", "--constraint", "max_gap_worst_union<=3",
            "--depths", "150:10000:20", "--maxiter", "4", "--popsize", "4",
            "--out", str(out), "--history", str(hist), "--json"]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    res = optimise(SEED, {"kappa": (0.05, 0.8), "Q": (11, 17)}, "sharp_fraction_union",
                   constraints={"max_gap_worst_union": ("<=", 3.0)}, depths=Z, maxiter=4,
                   popsize=4)
    assert Camera.from_toml(out) == res.design
    assert doc["free"] == res.free and doc["path"] == str(out)
    assert len(pd.read_csv(hist)) == res.nfev
    assert main(["report", "--config", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert splitlf.Design.from_dict(doc["design"]) == res.design
    assert main(argv) == 2  # no overwrite without --force
    assert "exists" in capsys.readouterr().err


@pytest.mark.parametrize("extra, needle", [
    (["--free", "kappa:0.8"], "NAME=LOW:HIGH"),
    (["--free", "kappa=0.05:0.8", "--constraint", "gap<3"], "MERIT<=VALUE"),
    (["--free", "kappa=0.05:0.8", "--depths", "150:10"], "MIN:MAX:NUM"),
    (["--free", "lens=1:2"], "lens"),
    (["--free", "kappa=0.05:0.8", "--out", "best.json"], ".toml"),
])
def test_cli_bad_options(capsys, extra, needle):
    assert main(["optimise", "--objective", "sharp_fraction_union", *extra]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
