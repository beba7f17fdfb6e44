"""Inverse design: the design that optimises a figure of merit, subject to constraints.

:func:`optimise` searches the free fields of a base :class:`~splitlf.Design` (a
:class:`~splitlf.Camera` is one) with SciPy's
``differential_evolution`` (global, deterministic for a seed), then polishes the best
feasible design locally (Nelder-Mead on the same penalised objective, integer fields held).
Every candidate is first built by the base's own ``replace`` (its constructor validates it)
and checked against the physical constraints (``min_microlens_f_number``, depths beyond
F); only a valid design reaches :func:`splitlf.evaluate`, which gives its merits over the
depths. Candidates are evaluated one generation at
a time through ``differential_evolution``'s ``workers=`` hook: in-process on the core's
thread pool, or in batches of plain field dicts on any ``concurrent.futures.Executor``
(e.g. a Dask cluster's ``client.get_executor()``), exactly as :func:`splitlf.sweep.sweep`.

See docs/optimise.md for the API, the penalty and the decisions behind it.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import inspect
import math
import numbers
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _validate
from .._progress import Progress, progress_bar, progress_flag
from ..errors import InvalidParameter
from ..model.design import Design
from ._options import options_2d, real_option, threshold_option, tol_option
from .merit import (
    DEFAULT_THRESHOLD_PX,
    DEFAULT_TOL,
    DEFAULT_WINDOW,
    IMAGE_PHOTONS,
    IMAGE_STATS,
    evaluate,
    image_merit_names,
    image_option,
    merit_names,
)
from .sweep import check_field, evaluate_batch, with_changes

__all__ = ["OptimiseResult", "merit_names", "natural_sense", "optimise"]


def natural_sense(merit: str) -> str | None:
    """The direction in which a merit is better, used when ``sense`` is not given: "max"
    for sharp fractions, lit fractions, light per pixel and distinct 2-D samples, "min"
    for max gaps and covering radii, None for the closed-form values (f-number,
    out-of-focus planes, image fill, microlens f-numbers) and the simulated MTF50; "max"
    for the image merits (PSNR, MTF50 / Nyquist)."""
    if merit.startswith(("sharp_fraction_", "lit_fraction_", "light_per_pixel_",
                         "distinct_2d_")) or merit.rpartition("_")[0] in IMAGE_STATS:
        return "max"
    if merit.startswith(("max_gap_", "covering_radius_")):
        return "min"
    return None


#: Energy offsets of the penalty: a valid design that violates a constraint scores
#: PENALTY + its relative violation, an invalid design 2 PENALTY, so every feasible design
#: beats every infeasible one. Objective values must stay below OBJECTIVE_LIMIT in size.
PENALTY = 1e12
OBJECTIVE_LIMIT = 1e11
#: Differential-evolution keywords a caller may pass through ``de_options``.
DE_OPTIONS = ("strategy", "mutation", "recombination", "init", "tol", "atol")
#: Step of the probes around the optimum that find the active constraints, as a fraction
#: of each continuous field's bound range (integer fields step by 1).
PROBE_STEP = 1e-6


class _Abort(Exception):
    """Stops differential_evolution when a user callable fails (SciPy turns a TypeError or
    ValueError raised by the map into a RuntimeError; this one passes through)."""


@dataclasses.dataclass(frozen=True)
class Free:
    """One free field: its name, bounds and whether it is searched as an integer."""

    name: str
    lo: float
    hi: float
    integer: bool

    def value(self, x: float) -> float | int:
        return int(round(x)) if self.integer else float(x)


@dataclasses.dataclass(frozen=True)
class OptimiseResult:
    """What :func:`optimise` found.

    - ``design``: the best design, of the base's class (a :class:`~splitlf.Camera` for a
      Camera base; feasible when ``feasible``)
    - ``merits``: its merits {name of :func:`merit_names` (the 2-D ones when they were
      computed): value}, as :func:`splitlf.evaluate` gives them
    - ``objective``: the objective's value there (as defined, not negated)
    - ``free``: the free fields' values {name: value}
    - ``feasible``: the design satisfies every constraint (else it is the valid design of
      least violation and no feasible design was found)
    - ``active``: what bounds the optimum, e.g. ``"bound: D <= 40.0"``,
      ``"constraint: image_fill_channel1 <= 1.0"``, ``"physical: invalid v1 = 79.9 ..."``: the
      bounds the design lies on and the constraints a probe step of :data:`PROBE_STEP`
      (of the bound range; 1 for an integer field) from it violates
    - ``slack``: per constraint, how far the design is inside it (>= 0 when satisfied)
    - ``history``: a ``pandas.DataFrame``, one row per evaluated candidate in evaluation
      order: ``stage`` (init, de, polish, probe), ``generation``, the free fields,
      ``valid``, ``feasible``, ``objective``, every merit (NaN when invalid: an invalid
      design never reaches the core), ``violated`` (the broken rules: a constructor
      parameter such as ``v1``, ``F``, ``min_microlens_f_number``, constrained merits,
      ``objective``) and ``reason`` (why invalid or infeasible)
    - ``nfev`` candidates evaluated, ``generations`` run, ``message`` (SciPy's)
    - ``timing``: {"total_s", "core_s" (in-process core calls; 0 with an executor),
      "evaluations" (designs that reached the core)}
    """

    design: Design
    merits: dict[str, float]
    objective: float
    free: dict[str, float | int]
    feasible: bool
    active: tuple[str, ...]
    slack: dict[str, float]
    history: Any
    nfev: int
    generations: int
    message: str
    timing: dict[str, float]


# -- argument checks ---------------------------------------------------------------------

def _base(base: Any) -> Design:
    return _validate.design(base, "base")


def _real(value: Any, where: str) -> float:
    """A real number (an integer beyond the float range is +-inf), else ``TypeError``."""
    return real_option(value, where, "a real number", lambda x: True)


def _free(free: Any, design: Design) -> list[Free]:
    """The free fields: names of :func:`splitlf.sweep.design_fields` of the base (a
    Camera's paper fields, a Design's ``F``, ``D`` and channel paths)."""
    if not isinstance(free, Mapping) or not free:
        raise TypeError("free must be a non-empty mapping {field: (low, high)}")
    out = []
    for name, bounds in free.items():
        is_count = check_field(design, name, "free")[1]
        if isinstance(bounds, str | bytes) or not isinstance(bounds, Sequence) \
                or len(bounds) != 2:
            raise TypeError(f"free[{name!r}] must be a pair (low, high), got {bounds!r}")
        lo, hi = (_real(b, f"free[{name!r}] bound") for b in bounds)
        integer = is_count
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InvalidParameter.of(f"free[{name!r}]", (lo, hi),
                                      "finite bounds with low < high")
        if integer and not (lo.is_integer() and hi.is_integer()):
            raise InvalidParameter.of(f"free[{name!r}]", (lo, hi),
                                      "integer bounds (a count is searched as an integer)")
        out.append(Free(name, lo, hi, integer))
    return out


def _objective(objective: Any, sense: Any, merits: Sequence[str]
               ) -> tuple[Callable[[dict[str, float]], Any], str, str]:
    """(function of the merit dict, its name, "max" | "min")."""
    if isinstance(objective, str):
        if objective not in merits:
            raise InvalidParameter.of("objective", objective,
                                      f"a merit name ({', '.join(merits)}) or a callable")
        name = objective

        def fn(m: dict[str, float]) -> float:
            return m[name]
    elif callable(objective):
        fn, name = objective, getattr(objective, "__name__", "objective")
    else:
        raise TypeError("objective must be a merit name or a callable on the merit dict, "
                        f"got {type(objective).__name__}")
    if sense is None:
        natural = natural_sense(objective) if isinstance(objective, str) else None
        if natural is not None:
            return fn, name, natural
        raise InvalidParameter.of("sense", None, "'max' or 'min' (needed: the objective "
                                  "has no natural direction)")
    if sense not in ("max", "min"):
        raise InvalidParameter.of("sense", sense, "'max' or 'min'")
    return fn, name, sense


def _constraints(constraints: Any, merits: Sequence[str]) -> list[tuple[str, str, float]]:
    if constraints is None:
        return []
    if not isinstance(constraints, Mapping):
        raise TypeError("constraints must be a mapping {merit: ('<=' | '>=', value)}")
    out = []
    for merit, spec in constraints.items():
        if merit not in merits:
            raise InvalidParameter.of("constraints", merit, f"merit names: {', '.join(merits)}")
        if isinstance(spec, str | bytes) or not isinstance(spec, Sequence) or len(spec) != 2:
            raise TypeError(f"constraints[{merit!r}] must be a pair (op, value), "
                            f"got {spec!r}")
        op, limit = spec
        if op not in ("<=", ">="):
            raise InvalidParameter.of(f"constraints[{merit!r}]", op, "'<=' or '>='")
        x = _real(limit, f"constraints[{merit!r}] value")
        if not math.isfinite(x):
            raise InvalidParameter.of(f"constraints[{merit!r}]", x, "a finite value")
        out.append((merit, op, x))
    return out


def _depths(depths: Any) -> np.ndarray:
    if depths is None:
        return np.geomspace(150.0, 10_000.0, 200)
    return _validate.depth_range(depths)


def _count(value: Any, name: str, lo: int = 1) -> int:
    n = _validate.integer(value, name, f"an integer >= {lo}")
    if n < lo:
        raise InvalidParameter.of(name, n, f"an integer >= {lo}")
    return n


def _de_options(options: Any) -> dict[str, Any]:
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise TypeError("de_options must be a mapping of differential_evolution keywords")
    bad = [k for k in options if k not in DE_OPTIONS]
    if bad:
        raise InvalidParameter.of("de_options", bad, f"keywords {', '.join(DE_OPTIONS)} "
                                  "(seed, workers, bounds, integrality, polish, maxiter, "
                                  "popsize, callback are set by optimise)")
    return dict(options)


# -- the problem: candidates -> validated designs -> merits -> penalised energies ----------

class _Problem:
    """Candidates -> designs (the base's own ``replace``, its constructor validating them)
    -> merits (:func:`splitlf.evaluate`, in-process or in batches on an executor) ->
    penalised energies, one history row per candidate."""

    def __init__(self, base: Design, free: list[Free], z: np.ndarray, objective: Callable,
                 sense: str, constraints: list[tuple[str, str, float]],
                 min_f_number: float | None, core_args: tuple[float, float],
                 executor: cf.Executor | None, n_threads: int | None, threads_per_task: int,
                 batch_size: int | None, window: float | None = None,
                 image: tuple[tuple[str, ...], float] = ((), IMAGE_PHOTONS)) -> None:
        self.base = base
        #: the window of the 2-D merits, None when they are not computed
        self.window = window
        #: the image merits computed and their photons
        self.image = image
        self.merit_names = merit_names(base, window is not None, image=image[0])
        self.free = free
        self.z = z
        self.objective = objective
        self.sign = -1.0 if sense == "max" else 1.0
        self.constraints = constraints
        self.min_f_number = min_f_number
        self.threshold_px, self.tol = core_args
        self.executor = executor
        self.n_threads = n_threads
        self.threads_per_task = threads_per_task
        self.batch_size = batch_size
        self.rows: list[dict[str, Any]] = []
        self.stage = "init"
        self.generation = 0
        self.map_calls = 0
        self.core_s = 0.0
        self.evaluations = 0
        self.error: BaseException | None = None

    # candidates
    def build(self, changes: dict[str, Any]) -> Design:
        """The design of a candidate (the base's class), validated by its constructor."""
        return with_changes(self.base, changes)

    def changes(self, x: Sequence[float]) -> dict[str, float | int]:
        return {f.name: f.value(v) for f, v in zip(self.free, x, strict=True)}

    def check(self, changes: dict[str, Any]) -> tuple[Design | None, str, str]:
        """(the design, "", "") if valid, else (None, why, the rule's name): its
        constructor accepts it (ranges, shares, lens-type rules, overlapping images:
        docs/model.md §9), every depth lies beyond F, every lens type's f_t / d reaches the
        floor."""
        try:
            design = self.build(changes)
        except InvalidParameter as e:
            return None, str(e), e.name
        except (ValueError, TypeError) as e:
            return None, str(e), "design"
        if not self.z.min() > design.F:
            return None, (f"invalid F = {design.F!r}: allowed F < the nearest depth "
                          f"{float(self.z.min())!r} mm"), "F"
        if self.min_f_number is not None:
            for i, ch in enumerate(design.resolved(), 1):
                for t, f in enumerate(ch["f"]):
                    n = f / ch["d"]
                    if not n >= self.min_f_number:
                        return None, (f"invalid microlens f-number of channel {i} type {t} "
                                      f"f/d = {n!r}: allowed >= min_microlens_f_number = "
                                      f"{self.min_f_number!r}"), "min_microlens_f_number"
        return design, "", ""

    def merits(self, designs: list[Design], changes: list[dict[str, Any]]
               ) -> list[list[float]]:
        """The merits of valid designs (:func:`splitlf.evaluate`), in order; with an
        executor, batches of the plain ``changes`` beside the base (the worker rebuilds
        the same designs)."""
        if not designs:
            return []
        if self.executor is None:
            out = []
            for d in designs:
                t = time.perf_counter()
                m = evaluate(d, self.z, threshold_px=self.threshold_px, tol=self.tol,
                             merits_2d=self.window is not None,
                             window=DEFAULT_WINDOW if self.window is None else self.window,
                             image=self.image[0], photons=self.image[1],
                             n_threads=self.n_threads)
                self.core_s += time.perf_counter() - t
                out.append(list(m.values()))
            return out
        size = self.batch_size or max(1, math.ceil(len(designs) / 16))
        futures = [self.executor.submit(evaluate_batch, self.base, changes[i:i + size],
                                        self.z, self.threshold_px, self.tol, self.window,
                                        self.threads_per_task, self.image)
                   for i in range(0, len(changes), size)]
        out = []
        for fut in futures:
            for values, reason in fut.result():
                if values is None:  # a valid design refused by the core: a bug, not input
                    raise RuntimeError(f"optimise: the core refused a checked design: {reason}")
                out.append(values)
        return out

    # energies
    def score(self, merits: dict[str, float]) -> tuple[float, float, str, str]:
        """(objective value, relative violation of the constraints, reason, the names of
        the violated constraints)."""
        try:
            value = self.objective(dict(merits))
        except Exception as e:  # a user callable: re-raised after the search stops
            self.error = e
            raise _Abort from e
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            self.error = TypeError(f"the objective must return a real number, got "
                                   f"{type(value).__name__} {value!r}")
            raise _Abort
        value = float(value)
        violation, why, names = 0.0, [], []
        for merit, op, limit in self.constraints:
            v = merits[merit]
            over = (v - limit) if op == "<=" else (limit - v)
            if not over <= 0.0:  # NaN counts as violated
                violation += (over if math.isfinite(over) else OBJECTIVE_LIMIT) \
                    / max(1.0, abs(limit))
                why.append(f"{merit} = {v!r} violates {op} {limit!r}")
                names.append(merit)
        if not (math.isfinite(value) and abs(value) < OBJECTIVE_LIMIT):
            violation += 1.0
            why.append(f"objective = {value!r} is not finite or beyond {OBJECTIVE_LIMIT:g}")
            names.append("objective")
        return value, violation, "; ".join(why), ",".join(names)

    def evaluate(self, xs: Sequence[Sequence[float]]) -> list[float]:
        """Penalised energies of candidates (one history row each)."""
        cands = [self.changes(x) for x in xs]
        checked = [self.check(c) for c in cands]
        ok = [(d, c) for (d, _, _), c in zip(checked, cands, strict=True) if d is not None]
        values = iter(self.merits([d for d, _ in ok], [c for _, c in ok]))
        self.evaluations += len(ok)
        energies = []
        for changes, (design, reason, rule) in zip(cands, checked, strict=True):
            row: dict[str, Any] = {"stage": self.stage, "generation": self.generation,
                                   **changes}
            if design is None:
                row.update(valid=False, feasible=False, objective=math.nan,
                           **{m: math.nan for m in self.merit_names}, violated=rule,
                           reason=reason)
                energies.append(2.0 * PENALTY)
            else:
                merits = dict(zip(self.merit_names, next(values), strict=True))
                value, violation, why, names = self.score(merits)
                row.update(valid=True, feasible=violation == 0.0, objective=value, **merits,
                           violated=names, reason=why)
                energies.append(self.sign * value if violation == 0.0
                                else PENALTY + min(violation, PENALTY / 2))
            self.rows.append(row)
        return energies

    def map(self, func: Any, xs: Any) -> list[float]:
        """The ``workers=`` hook of differential_evolution: one call per generation (the
        first is the initial population)."""
        self.stage = "init" if self.map_calls == 0 else "de"
        self.generation = self.map_calls
        self.map_calls += 1
        return self.evaluate([list(np.asarray(x, dtype=float)) for x in xs])

    def one(self, x: Sequence[float]) -> float:
        return self.evaluate([x])[0]


# -- the search --------------------------------------------------------------------------

def _progress_bar(total: int, progress: bool | None) -> Progress | None:
    """The report over generations (splitlf._progress)."""
    return progress_bar(progress_flag(progress), "splitlf optimise", "gen", total)[0]


def _de_seed_keyword(de: Callable) -> str:
    """SciPy >= 1.15 names the seed ``rng``; older releases ``seed``."""
    return "rng" if "rng" in inspect.signature(de).parameters else "seed"


def _polish(problem: _Problem, x0: np.ndarray, maxfev: int) -> None:
    """Nelder-Mead on the continuous free fields (scaled to [0, 1]) from ``x0``, integer
    fields held; every point is evaluated (and recorded) through ``problem``."""
    from scipy.optimize import minimize

    cont = [i for i, f in enumerate(problem.free) if not f.integer]
    if not cont:
        return
    lo = np.array([problem.free[i].lo for i in cont])
    span = np.array([problem.free[i].hi for i in cont]) - lo

    def energy(u: np.ndarray) -> float:
        x = x0.copy()
        x[cont] = lo + np.clip(u, 0.0, 1.0) * span
        return problem.one(x)

    u0 = (x0[cont] - lo) / span
    step = 1e-2
    simplex = np.array([u0] + [u0 + step * (1 if u0[k] <= 0.5 else -1) * np.eye(len(cont))[k]
                               for k in range(len(cont))])
    problem.stage = "polish"
    minimize(energy, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(cont),
             options={"initial_simplex": simplex, "xatol": 1e-10, "fatol": 1e-12,
                      "maxfev": maxfev})


def _best(rows: list[dict[str, Any]], sign: float) -> dict[str, Any] | None:
    """The best row: feasible by objective, else valid by least violation (first wins)."""
    feasible = [r for r in rows if r["feasible"]]
    if feasible:
        return min(feasible, key=lambda r: sign * r["objective"])
    return None


def _active(problem: _Problem, best: dict[str, Any]) -> tuple[str, ...]:
    """The bounds the optimum lies on, and the constraints (user or physical, each once, a
    physical one with the message of its first violating probe) that one probe step from it
    along a free field violates."""
    out: list[str] = []
    x = np.array([float(best[f.name]) for f in problem.free])
    for i, f in enumerate(problem.free):
        step = 1.0 if f.integer else PROBE_STEP * (f.hi - f.lo)
        if x[i] - f.lo < step * (1 - 1e-9) or (f.integer and x[i] == f.lo):
            out.append(f"bound: {f.name} >= {_num(f.lo, f.integer)}")
        if f.hi - x[i] < step * (1 - 1e-9) or (f.integer and x[i] == f.hi):
            out.append(f"bound: {f.name} <= {_num(f.hi, f.integer)}")
    problem.stage = "probe"
    probes = []
    for i, f in enumerate(problem.free):
        step = 1.0 if f.integer else PROBE_STEP * (f.hi - f.lo)
        for s in (-step, step):
            if f.lo <= x[i] + s <= f.hi:
                y = x.copy()
                y[i] += s
                probes.append(y)
    start = len(problem.rows)
    problem.evaluate(probes)
    cons = {merit: f"constraint: {merit} {op} {limit!r}"
            for merit, op, limit in problem.constraints}
    seen = set()
    for row in problem.rows[start:]:
        for name in filter(None, row["violated"].split(",")):
            if name in seen:
                continue
            seen.add(name)
            out.append(cons.get(name) or f"physical: {row['reason']}")
    return tuple(out)


def _num(x: float, integer: bool) -> str:
    return str(int(x)) if integer else repr(float(x))


def optimise(base: Design, free: Mapping[str, tuple[float, float]],
             objective: str | Callable, sense: str | None = None,
             constraints: Mapping[str, tuple[str, float]] | None = None,
             depths: Any = None, seed: int = 0, executor: cf.Executor | None = None,
             progress: bool | None = None, *, maxiter: int = 100, popsize: int = 15,
             polish: bool = True, polish_maxfev: int | None = None,
             min_microlens_f_number: float | None = None,
             threshold_px: float = DEFAULT_THRESHOLD_PX, tol: float = DEFAULT_TOL,
             merits_2d: bool | None = None, window: float = DEFAULT_WINDOW,
             image: Sequence[str] | None = None, photons: float = IMAGE_PHOTONS,
             n_threads: int | None = None, threads_per_task: int = 1,
             batch_size: int | None = None, de_options: Mapping[str, Any] | None = None
             ) -> OptimiseResult:
    """The design around ``base`` that optimises ``objective`` subject to ``constraints``.

    - ``base``: a :class:`~splitlf.Design` (a :class:`~splitlf.Camera` is one); every field
      not free keeps its value (focal lengths left to Ng's setting keep tracking the
      geometry); candidates are built by the base's own ``replace``
    - ``free``: {field: (low, high)}, names of :func:`splitlf.sweep.design_fields`: a
      Camera's paper fields (``"D"``, ``"kappa"``, ...), a Design's ``"F"``, ``"D"``,
      ``"channels[2].L"``, ``"channels[1].f[0]"`` (channels from 1, lens types from 0);
      the counts are searched as integers (integer bounds); the others are continuous
    - ``objective``: a merit name (:func:`merit_names`, those of :func:`splitlf.evaluate`)
      or a callable on the merit dict returning a real number; ``sense``: "max" or "min"
      (default: the merit's :func:`natural_sense` — max for sharp and lit fractions and
      distinct 2-D samples, min for max gaps and covering radii — and required
      otherwise)
    - ``constraints``: {merit: ("<=" | ">=", value)}
    - ``depths``: scene depths [mm] of the core's merits (default 200 log-spaced over
      150-10 000 mm); a design with F >= the nearest depth is invalid
    - ``seed``: the search is deterministic for a seed, in-process or on any executor
    - ``executor``: a ``concurrent.futures.Executor`` (Dask: ``client.get_executor()``);
      each generation is sent as batches of plain field dicts (``batch_size`` designs per
      task, default at most 16 tasks), each task on ``threads_per_task`` core threads;
      None evaluates in-process on ``n_threads`` (None: all cores)
    - ``progress``: a tqdm bar over generations (None: a bar when stderr is a terminal,
      else sparse lines on stderr once the search has run 10 s; False: nothing)
    - ``maxiter``, ``popsize``: generations and population (popsize x free fields) of
      differential evolution; ``de_options``: other keywords of
      ``scipy.optimize.differential_evolution`` (:data:`DE_OPTIONS`)
    - ``polish``: refine the best feasible design with Nelder-Mead over the continuous
      fields (``polish_maxfev`` evaluations, default 100 + 100 per field)
    - ``min_microlens_f_number``: a manufacturable floor on f_t / d of every lens type of
      every channel; a design below it is invalid (never evaluated)
    - ``threshold_px``, ``tol``: sharpness threshold [px] and merge tolerance [delta(z)] of
      the core's merits, as in :func:`splitlf.sweep.sweep`
    - ``merits_2d``: whether to compute the 2-D merits (``merit_names(base, True)``
      beyond ``merit_names(base)``), which cost a 2-D analysis per depth:
      None (default) computes them iff the objective or a constraint names one; True
      always (a callable objective that reads them needs it); False never (naming one is
      then an error). Not computed, they are absent from ``merits`` and the history
    - ``window``: width of their central field in lens pitches of channel 1, finite > 0
      (default 16, as :func:`splitlf.coverage`)
    - ``image``: the image merits to compute (names of
      :func:`splitlf.merits.image_merit_names`, e.g. ``psnr_worst_union``; None: those the
      objective and constraints name), at ``photons`` photo-electrons for white, as
      :func:`splitlf.evaluate` computes them (seconds per candidate)

    Returns an :class:`OptimiseResult`. Every argument is checked before any work:
    ``TypeError`` for wrong types, :class:`~splitlf.errors.InvalidParameter` for values out
    of range (unknown fields or merits, bounds, sense, depths), ``ImportError`` without
    SciPy or pandas. If no candidate was a valid design, :class:`InvalidParameter` names the
    free bounds; if none was feasible the result has ``feasible=False``. An exception raised
    by a callable objective propagates.
    """
    cam = _base(base)
    names = merit_names(cam, True) + image_merit_names(cam)
    fields = _free(free, cam)
    fn, _, sense_ = _objective(objective, sense, names)
    cons = _constraints(constraints, names)
    on_2d = _merits_2d_wanted(merits_2d, objective, cons,
                              frozenset(merit_names(cam, True)) - frozenset(merit_names(cam)))
    named = [objective] if isinstance(objective, str) else []
    named += [c[0] for c in cons]
    image_names = image_option(cam, [n for n in named if n in image_merit_names(cam)]
                               if image is None else image)
    n_photons = _validate.positive(photons, "photons")
    z = _depths(depths)
    seed_ = _validate.integer(seed, "seed", "an integer >= 0")
    if seed_ < 0:
        raise InvalidParameter.of("seed", seed_, "an integer >= 0")
    maxiter_, popsize_ = _count(maxiter, "maxiter"), _count(popsize, "popsize")
    if polish_maxfev is None:
        polish_maxfev = 100 + 100 * len(fields)
    polish_maxfev = _count(polish_maxfev, "polish_maxfev")
    min_f = _min_f_number(min_microlens_f_number)
    core_args = (threshold_option(threshold_px), tol_option(tol))
    window_2d = options_2d(on_2d, window, core_args[1])
    n_threads = _validate.n_threads(n_threads)
    tpt = _validate.n_threads(threads_per_task)
    if batch_size is not None:
        batch_size = _count(batch_size, "batch_size")
    if executor is not None and not isinstance(executor, cf.Executor):
        raise TypeError("executor must be a concurrent.futures.Executor or None, got "
                        f"{type(executor).__name__}")
    opts = _de_options(de_options)
    try:
        import pandas as pd
        from scipy.optimize import differential_evolution
    except ImportError as e:
        raise ImportError('splitlf.optimise needs SciPy and pandas: '
                          'pip install "splitlf[sweep]"') from e

    problem = _Problem(cam, fields, z, fn, sense_, cons, min_f, core_args, executor, n_threads,
                   tpt or 1, batch_size, window=window_2d, image=(image_names, n_photons))
    bar = _progress_bar(maxiter_, progress)

    def callback(xk: Any, convergence: float = 0.0) -> None:
        if bar is not None:
            bar.update(1)

    t0 = time.perf_counter()
    opts.setdefault("tol", 0.01)
    try:
        res = differential_evolution(
            problem.one, [(f.lo, f.hi) for f in fields], maxiter=maxiter_, popsize=popsize_,
            polish=False, workers=problem.map, updating="deferred", callback=callback,
            integrality=[f.integer for f in fields],
            **{_de_seed_keyword(differential_evolution): seed_}, **opts)
        best = _best(problem.rows, problem.sign)
        if polish and best is not None:
            _polish(problem, np.array([float(best[f.name]) for f in fields]), polish_maxfev)
    except _Abort:
        raise problem.error from None  # type: ignore[misc]
    finally:
        if bar is not None:
            bar.close()
    return _result(problem, fields, cons, str(res.message), time.perf_counter() - t0, pd)


def _merits_2d_wanted(merits_2d: Any, objective: Any, cons: list[tuple[str, str, float]],
                      names_2d: frozenset[str]) -> bool:
    """Whether the 2-D merits are computed: ``merits_2d`` (None, True or False), None
    meaning iff the objective or a constraint names one (False with one named is an
    error)."""
    named = sorted({m for m, _, _ in cons if m in names_2d}
                   | ({objective} if isinstance(objective, str) and objective in names_2d
                      else set()))
    if merits_2d is not None and not isinstance(merits_2d, bool):
        raise TypeError(f"merits_2d must be None, True or False, got "
                        f"{type(merits_2d).__name__} {merits_2d!r}")
    if merits_2d is False and named:
        raise InvalidParameter.of("merits_2d", False, "None or True: the objective or a "
                                  f"constraint names the 2-D merit {named[0]}")
    return bool(named) if merits_2d is None else merits_2d


def _min_f_number(value: Any) -> float | None:
    if value is None:
        return None
    min_f = _real(value, "min_microlens_f_number")
    if not (math.isfinite(min_f) and min_f > 0):
        raise InvalidParameter.of("min_microlens_f_number", min_f, "a finite number > 0")
    return min_f


def _result(problem: _Problem, fields: list[Free], cons: list[tuple[str, str, float]],
            message: str, total_s: float, pd: Any) -> OptimiseResult:
    """The search's result from its evaluations (``InvalidParameter`` naming ``free``
    when no candidate was a valid design)."""
    best = _best(problem.rows, problem.sign)
    feasible = best is not None
    if best is None:
        valid = [r for r in problem.rows if r["valid"]]
        if not valid:
            reasons = sorted({r["reason"] for r in problem.rows})
            raise InvalidParameter.of("free", {f.name: (f.lo, f.hi) for f in fields},
                                      "bounds holding at least one valid design; every "
                                      f"candidate was invalid, e.g.: {reasons[0]}")
        best = min(valid, key=lambda r: _violation(r, cons))
    generations = max(problem.map_calls - 1, 0)
    active = _active(problem, best) if feasible else ()
    design = problem.build({f.name: best[f.name] for f in fields})
    merits = {m: float(best[m]) for m in problem.merit_names}
    slack = {f"{m} {op} {limit!r}": (limit - merits[m]) if op == "<=" else (merits[m] - limit)
             for m, op, limit in cons}
    history = pd.DataFrame(problem.rows)
    for f in fields:
        if f.integer:
            history[f.name] = history[f.name].astype("int64")
    return OptimiseResult(
        design=design, merits=merits, objective=float(best["objective"]),
        free={f.name: best[f.name] for f in fields}, feasible=feasible, active=active,
        slack=slack, history=history, nfev=len(problem.rows), generations=generations,
        message=message,
        timing={"total_s": total_s, "core_s": problem.core_s,
                "evaluations": float(problem.evaluations)})


def _violation(row: dict[str, Any], cons: list[tuple[str, str, float]]) -> float:
    total = 0.0
    for merit, op, limit in cons:
        over = (row[merit] - limit) if op == "<=" else (limit - row[merit])
        if not over <= 0.0:
            total += (over if math.isfinite(over) else OBJECTIVE_LIMIT) / max(1.0, abs(limit))
    return total
