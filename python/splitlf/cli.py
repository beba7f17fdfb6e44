"""The ``splitlf`` command line. Errors are one line on stderr and exit status 2."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from .camera import Camera
from .report import format_report, report_data

SEED = "seed design (docs/model.md §7, reconstructed from the paper)"


class CliError(Exception):
    """A user error with a message fit for one line."""


def _load_camera(path: str | None) -> tuple[Camera, str]:
    if path is None:
        return Camera.paper(), SEED
    return Camera.from_toml(path), path


def _dump_json(data: Any) -> None:
    json.dump(data, sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


# -- report ------------------------------------------------------------------------------

def _cmd_report(args: argparse.Namespace) -> int:
    camera, source = _load_camera(args.config)
    data = report_data(camera, args.threshold, n_threads=args.threads)
    if args.json:
        _dump_json({"source": source, **data})
    else:
        sys.stdout.write(format_report(data, f"splitlf report: {source}"))
    return 0


# -- figures -----------------------------------------------------------------------------

def figure_functions() -> dict[str, tuple[Any, int, tuple[float, float]]]:
    """File stem -> (plot function taking (camera, ax=...), stacked panels, size [in])."""
    from . import plot

    return {stem: (getattr(plot, fn), panels, size)
            for stem, (fn, panels, size) in plot.FIGURES.items()}


def _cmd_figures(args: argparse.Namespace) -> int:
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise CliError('figures need matplotlib: pip install "splitlf[plot]"') from None
    camera, _ = _load_camera(args.config)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for stem, (fn, panels, size) in figure_functions().items():
        # A bare Figure needs no pyplot backend: nothing global is changed.
        fig = Figure(figsize=size, layout="constrained")
        if panels == 1:
            fn(camera, ax=fig.add_subplot())
        else:
            fn(camera, ax=fig.subplots(panels, 1, sharex=True))
        path = out / f"{stem}.{args.format}"
        fig.savefig(path, dpi=args.dpi)
        print(path)
    return 0


# -- trace -------------------------------------------------------------------------------

TRACE_FIELDS = ("vertices", "n_vertices", "area", "centroid", "lens", "pixel", "chief", "lit")


def _cmd_trace(args: argparse.Namespace) -> int:
    from .rayspace import trace

    camera, source = _load_camera(args.config)
    out = Path(args.out)
    if out.suffix != ".npz":
        raise CliError(f"--out {out}: the ray-space arrays are written as .npz")
    arrays: dict[str, Any] = {"camera_toml": np.array(camera.to_toml())}
    summary: dict[str, Any] = {"path": str(out), "source": source, "axis": args.axis}
    for h in (1, 2):
        t = trace(camera, h, axis=args.axis)
        for name in TRACE_FIELDS:
            arrays[f"half{h}_{name}"] = getattr(t, name)
        summary[f"half{h}"] = {
            "pixels": int(t.area.size),
            "lit": int(np.count_nonzero(t.lit)),
            "polygons_by_vertex_count": {
                str(k): int(np.count_nonzero(t.n_vertices == k)) for k in range(7)
                if np.any(t.n_vertices == k)
            },
            "total_area_mm2": float(t.area.sum()),
        }
    np.savez_compressed(out, **arrays)
    if args.json:
        _dump_json(summary)
    else:
        print(out)
    return 0


# -- sweep -------------------------------------------------------------------------------

def _linspace(name: str, spec: Any) -> list[Any]:
    if isinstance(spec, list):
        return spec
    if isinstance(spec, dict):
        unknown = set(spec) - {"start", "stop", "num", "log"}
        if unknown or not {"start", "stop", "num"} <= set(spec):
            raise CliError(f"grid.{name}: a range needs start, stop, num (and optional log)")
        make = np.geomspace if spec.get("log", False) else np.linspace
        return make(spec["start"], spec["stop"], int(spec["num"])).tolist()
    raise CliError(f"grid.{name}: expected a list of values or {{start, stop, num}}")


def load_sweep(path: str) -> dict[str, Any]:
    """Read a sweep TOML: [grid] (required), [depths] min/max/num (log-spaced),
    [options] threshold_px/tol, optional [camera] base design."""
    with open(path, "rb") as fh:
        try:
            doc = tomllib.load(fh)
        except tomllib.TOMLDecodeError as e:
            raise CliError(f"{path}: not valid TOML: {e}") from None
    unknown = set(doc) - {"grid", "depths", "options", "camera"}
    if unknown:
        raise CliError(f"{path}: unknown table(s) {sorted(unknown)}; "
                       "allowed: grid, depths, options, camera")
    if not isinstance(doc.get("grid"), dict) or not doc["grid"]:
        raise CliError(f"{path}: needs a non-empty [grid] table of camera fields")
    grid = {k: _linspace(k, v) for k, v in doc["grid"].items()}
    dep = doc.get("depths", {})
    bad = set(dep) - {"min", "max", "num"}
    if bad:
        raise CliError(f"{path}: unknown [depths] key(s) {sorted(bad)}; allowed: min, max, num")
    lo, hi, num = dep.get("min", 150.0), dep.get("max", 10_000.0), dep.get("num", 200)
    if not (isinstance(num, int) and num >= 2):
        raise CliError(f"{path}: depths.num must be an integer >= 2, got {num!r}")
    if not (isinstance(lo, int | float) and isinstance(hi, int | float) and 0 < lo < hi):
        raise CliError(f"{path}: depths needs 0 < min < max (mm), got min={lo!r}, max={hi!r}")
    opts = doc.get("options", {})
    bad = set(opts) - {"threshold_px", "tol"}
    if bad:
        raise CliError(f"{path}: unknown [options] key(s) {sorted(bad)}; "
                       "allowed: threshold_px, tol")
    camera = Camera.from_dict(doc["camera"], source=f"{path} [camera]") if "camera" in doc \
        else None
    return {"grid": grid, "depths": np.geomspace(lo, hi, num), "options": opts,
            "camera": camera}


def _cmd_sweep(args: argparse.Namespace) -> int:
    from .sweep import METRICS, sweep

    spec = load_sweep(args.grid)
    camera = spec["camera"] or _load_camera(args.config)[0]
    executor = None
    client = None
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise CliError('--scheduler needs Dask: pip install "splitlf[dask]"') from None
        client = Client(args.scheduler)
        executor = client.get_executor()
    try:
        ds = sweep(camera, spec["grid"], spec["depths"], executor=executor,
                   n_threads=args.threads, **spec["options"])
    finally:
        if client is not None:
            client.close()
    if args.out:
        out = Path(args.out)
        if out.suffix == ".nc":
            ds.to_netcdf(out)
        elif out.suffix == ".parquet":
            ds.to_dataframe().reset_index().to_parquet(out)
        else:
            raise CliError(f"--out {out}: allowed suffixes .nc (NetCDF) or .parquet")
        print(out)
        return 0
    df = ds.to_dataframe().reset_index()
    if args.json:
        records = json.loads(df.to_json(orient="records"))
        _dump_json({"attrs": {k: v for k, v in ds.attrs.items() if k != "base_camera"},
                    "designs": records})
        return 0
    cols = list(spec["grid"]) + ["sharp_fraction_split", "max_gap_worst_union", "reason"]
    cols = [c for c in cols if c in df.columns]
    sys.stdout.write(df[cols].to_string(index=False) + "\n")
    sys.stdout.write(f"\n{len(df)} designs; metrics: {', '.join(METRICS)}\n")
    return 0


# -- simulate ----------------------------------------------------------------------------

def parse_texture(spec: str) -> Any:
    """random | sinusoid:F | bars:F (F in cycles/mm) | image:FILE.npy:WIDTH_MM."""
    from .simulation import BarChart, Image, RandomAlbedo, Sinusoid

    kind, _, rest = spec.partition(":")
    try:
        if kind == "random" and not rest:
            return RandomAlbedo()
        if kind in ("sinusoid", "bars"):
            f = float(rest)
            return Sinusoid(f) if kind == "sinusoid" else BarChart(f)
        if kind == "image":
            path, _, width = rest.rpartition(":")
            return Image(np.load(path, allow_pickle=False), float(width))
    except ValueError as e:
        raise CliError(f"--texture {spec}: {e}") from None
    raise CliError(f"--texture {spec}: allowed random, sinusoid:F, bars:F (cycles/mm) "
                   "or image:FILE.npy:WIDTH_MM")


def _cmd_simulate(args: argparse.Namespace) -> int:
    from .simulation import CONFIGS, simulate

    camera, source = _load_camera(args.config)
    texture = parse_texture(args.texture)
    noise = None if args.photons is None else {"photons": args.photons,
                                              "read_noise": args.read_noise}
    if args.z_range is not None:
        lo, hi = args.z_range
        if not 0 < lo < hi:
            raise CliError(f"--z-range {lo} {hi}: needs 0 < A < B (mm)")
        depths = np.geomspace(lo, hi, args.n)
    else:
        depths = [args.z]
    rows = [simulate(camera, float(z), texture=texture, noise=noise, seed=args.seed,
                     n_threads=args.threads).summary() for z in depths]
    if args.json:
        _dump_json({"source": source, "texture": args.texture, "results": rows})
        return 0
    head = f"{'z [mm]':>9}  {'config':<13}{'RMSE':>9}{'PSNR [dB]':>11}{'MTF50 [c/mm]':>14}"
    print(f"splitlf simulate: {source}; texture {args.texture}; "
          f"{'noise-free' if noise is None else f'{args.photons:g} photons'}")
    print(head)
    for r in rows:
        for c in CONFIGS:
            print(f"{r['z_mm']:>9.1f}  {c:<13}{r['rmse'][c]:>9.4f}{r['psnr_db'][c]:>11.2f}"
                  f"{r['mtf50_cycles_per_mm'][c]:>14.3f}")
    return 0


# -- parser ------------------------------------------------------------------------------

def _threads(value: str) -> int:
    n = int(value)
    if not 1 <= n <= 1024:
        raise argparse.ArgumentTypeError(f"invalid thread count {value}: allowed 1..1024")
    return n


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="splitlf",
        description="Design and analysis of split-sensor light field cameras.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def common(p: argparse.ArgumentParser, config: bool = True) -> None:
        if config:
            p.add_argument("--config", metavar="CAM.toml",
                           help="camera TOML file (default: the seed design)")
        p.add_argument("--threads", type=_threads, default=None, metavar="N",
                       help="threads for the core (default: all cores)")

    rep = sub.add_parser(
        "report",
        help="the camera, its derived values, out-of-focus planes and depth of field",
        description="Print the camera (the seed design unless --config), its derived values, "
        "the out-of-focus planes and the depth-of-field intervals of each half, of the split "
        "sensor and of the conventional cameras.",
    )
    common(rep)
    rep.add_argument("--json", action="store_true", help="print one JSON document")
    rep.add_argument("--threshold", type=float, default=0.5, metavar="PX",
                     help="sharpness threshold on the blur radius in pixels (default 0.5)")
    rep.set_defaults(func=_cmd_report)

    fig = sub.add_parser("figures", help="write every figure of a design",
                         description="Write the paper's figures (1, 4, 5) and the samples "
                         "figure for a design.")
    common(fig)
    fig.add_argument("--out", default="figures", metavar="DIR", help="output folder")
    fig.add_argument("--format", choices=("png", "svg"), default="png")
    fig.add_argument("--dpi", type=int, default=150)
    fig.set_defaults(func=_cmd_figures)

    tr = sub.add_parser("trace", help="write every pixel's ray-space polygon to .npz",
                        description="Trace every pixel of both halves along one axis "
                        "(docs/model.md §3-4) and write the arrays of splitlf.trace, prefixed "
                        "half1_/half2_, with the camera as TOML, to an .npz file.")
    common(tr)
    tr.add_argument("--axis", choices=("x", "y"), default="x")
    tr.add_argument("--out", default="trace.npz", metavar="FILE.npz")
    tr.add_argument("--json", action="store_true", help="print a JSON summary of the arrays")
    tr.set_defaults(func=_cmd_trace)

    sw = sub.add_parser("sweep", help="figures of merit over a grid of designs",
                        description="Full-factorial design sweep from a TOML file with "
                        "[grid], [depths] (min, max, num; log-spaced), [options] and an "
                        "optional [camera] base design.")
    common(sw)
    sw.add_argument("--grid", required=True, metavar="SWEEP.toml")
    sw.add_argument("--scheduler", metavar="ADDRESS",
                    help="Dask scheduler address, e.g. tcp://host:8786")
    sw.add_argument("--out", metavar="FILE", help="write .nc (NetCDF) or .parquet")
    sw.add_argument("--json", action="store_true", help="print the designs as JSON records")
    sw.set_defaults(func=_cmd_sweep)

    si = sub.add_parser("simulate", help="super-resolution simulation at one or more depths",
                        description="Image a textured plane with half 1, half 2, the split "
                        "sensor and the conventional camera, reconstruct it with known depth "
                        "and print RMSE, PSNR and MTF50 (docs/simulate.md).")
    common(si)
    where = si.add_mutually_exclusive_group()
    where.add_argument("--z", type=float, default=1000.0, metavar="MM",
                       help="depth of the plane (default 1000)")
    where.add_argument("--z-range", type=float, nargs=2, metavar=("A", "B"),
                       help="log-spaced depths from A to B (see --n)")
    si.add_argument("--n", type=int, default=8, help="depths of --z-range (default 8)")
    si.add_argument("--texture", default="random",
                    help="random | sinusoid:F | bars:F (cycles/mm) | image:FILE.npy:WIDTH_MM")
    si.add_argument("--photons", type=float, default=None,
                    help="add noise: photo-electrons of a full-aperture pixel, white texture")
    si.add_argument("--read-noise", type=float, default=0.0, metavar="E",
                    help="read noise in electrons rms (with --photons)")
    si.add_argument("--seed", type=int, default=0)
    si.add_argument("--json", action="store_true", help="print one JSON document")
    si.set_defaults(func=_cmd_simulate)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:
        # The reader went away (e.g. `splitlf report | head`): not an error of ours.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (CliError, ValueError, TypeError, OSError, ImportError, KeyError) as e:
        msg = " ".join(str(e).split()) or type(e).__name__
        print(f"splitlf {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
