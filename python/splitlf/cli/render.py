"""``splitlf render``: the raw sensor images of a textured scene (docs/model.md §10,
docs/render.md).

Render what each channel's sensor records for a textured surface (docs/model.md §10) and
write the raws to an .npz file that splitlf.Raw.load reads (and, with --png, a picture
of them with a zoom on a few micro-images). With --scheduler the rows of each channel
are rendered as tasks on a Dask cluster (the same raw bit for bit). With --cfa the sensor
has a Bayer colour filter array (docs/model.md §12): one render per colour, mosaiced; an
image texture then keeps its colours (a colour PNG, or a .npy of shape (rows, cols, 3)).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from .._files import atomic_output
from . import _common


def add_parser(subparsers: Any) -> None:
    p = subparsers.add_parser("render", description=_common.described(__doc__),
                              help="the raw sensor images of a textured scene")
    _common.design_argument(p)
    p.add_argument("--texture", required=True, metavar="SPEC",
                   help="random | sinusoid:F | bars:F (cycles/mm) | edge[:ANGLE] (degrees "
                   "from vertical, default 5) | star[:SPOKES] (default 36) | an image file "
                   "(.png or .npy of albedos) with --width")
    p.add_argument("--width", type=_common.real_type("width", 0.0, "a finite width > 0 (mm)"),
                   default=None, metavar="MM", help="an image texture's width on the object")
    p.add_argument("--depth", required=True, metavar="SPEC",
                   help="a depth in mm (a fronto-parallel plane) | plane:Z0,GX,GY "
                   "(Z = Z0 + GX X + GY Y) | a .npy depth map with --extent")
    p.add_argument("--extent", default=None, metavar="X0,X1,Y0,Y1",
                   help="a depth map's extent on the object [mm] (with a negative X0: "
                   "--extent=X0,X1,Y0,Y1)")
    p.add_argument("--noise", type=_common.noise_type, default=None, metavar="N[,READ]",
                   help="add noise: N photo-electrons for value 1 (Poisson), READ electrons "
                   "rms of read noise (default 0)")
    acc = p.add_mutually_exclusive_group()
    acc.add_argument("--tol", type=_common.real_type("tol", 0.0, "a value in [1e-10, 0.1]"),
                     default=None, help="error target of a pixel relative to a fully lit "
                     "pixel under the scene's largest albedo (default 1e-3; docs/render.md)")
    acc.add_argument("--noise-tol",
                     type=_common.real_type("noise tol", 0.0, "a fraction in (0, 1]"),
                     default=None, metavar="K", help="instead: each pixel's error target is "
                     "K (e.g. 0.1) times the standard deviation of --noise at its value")
    p.add_argument("--cfa", choices=("RGGB", "GRBG", "GBRG", "BGGR"), default=None,
                   help="a Bayer colour filter array on the sensor, by its top-left 2 x 2 "
                   "block (docs/model.md §12; default: a grey sensor)")
    p.add_argument("--qe", default=None, metavar="R,G,B",
                   help="with --cfa: each colour's quantum efficiency in (0, 1] (default "
                   "1,1,1)")
    p.add_argument("--seed", type=_common.seed_type, default=0,
                   help="seed of the random texture and the noise, an integer >= 0 "
                   "(default 0)")
    p.add_argument("--falloff", choices=("microlens", "main", "both"), default=None,
                   help="radiometric falloff: weight each ray by the cos^4 law on its "
                   "microlens-to-sensor segment, its main-lens-to-array segment, or both "
                   "(default: off, the paper's paraxial model; docs/model.md §10)")
    _common.threads_option(p, "threads of the core (with --scheduler: of each task)")
    _common.scheduler_option(p, ": render there, each channel's rows cut into bands, one task "
                             "each, the same raw bit for bit (docs/render.md, 'Scale-out and "
                             "datasets')")
    g = _common.output_group(p, "the raw file to write (.npz)", "RAW.npz", required=True,
                             json_help="print a JSON summary of the raws instead of the path")
    g.add_argument("--png", default=None, metavar="FILE.png",
                   help="also write a picture of the raws (splitlf.plot.raw)")
    p.set_defaults(func=run)


def parse_render_texture(spec: str, width: float | None, colour: bool = False) -> Any:
    """The texture of ``render --texture``: random[:CELL] (CELL in mm; default delta(z))
    | sinusoid:F | bars:F (F in cycles/mm on the object) | edge[:ANGLE] (degrees) |
    star[:SPOKES] | an image file (.png or .npy; needs ``width`` [mm]; a colour PNG kept
    in colour when ``colour``, else its luma). Raises :class:`CliError` for anything
    else."""
    from ..imaging.texture import BarChart, RandomAlbedo, SiemensStar, Sinusoid, SlantedEdge

    kind, colon, rest = spec.partition(":")
    known = {"random", "sinusoid", "bars", "edge", "star"}
    if kind not in known:
        return _image_texture(spec, width, colour)
    if width is not None:
        raise _common.CliError("--width: only with an image file as --texture")
    try:
        if kind == "random":
            return RandomAlbedo(float(rest)) if colon else RandomAlbedo()
        if kind in ("sinusoid", "bars"):
            return (Sinusoid if kind == "sinusoid" else BarChart)(float(rest))
        if kind == "edge":
            return SlantedEdge(float(rest)) if colon else SlantedEdge()
        return SiemensStar(int(rest)) if colon else SiemensStar()
    except ValueError as e:
        raise _common.CliError(f"--texture {spec}: {e}") from None


TEXTURE_FORMS = ("random[:CELL] (mm), sinusoid:F, bars:F (cycles/mm), edge[:ANGLE], "
                 "star[:SPOKES] or an image file (.png, .npy) with --width")


def _image_texture(path: str, width: float | None, colour: bool = False) -> Any:
    """An :class:`~splitlf.Image` from a .npy array of albedos or a PNG (read by
    matplotlib: values in [0, 1], a colour image as its R, G, B when ``colour`` (a render
    through a CFA), else as the Rec. 709 luma of R, G, B)."""
    from ..imaging.texture import Image

    suffix = Path(path).suffix.lower()
    if suffix not in (".png", ".npy"):
        raise _common.CliError(f"--texture {path}: allowed {TEXTURE_FORMS}")
    if width is None:
        raise _common.CliError(f"--texture {path}: an image needs --width MM (its width on the "
                               "object)")
    if suffix == ".npy":
        array = _common.load_npy(path, "texture")
    else:
        _common.need("matplotlib", "render with a PNG texture", "plot")
        import matplotlib.image

        if not Path(path).is_file():
            raise _common.CliError(f"no such file: {path}")
        try:
            array = np.asarray(matplotlib.image.imread(path), dtype=np.float64)
        except (OSError, ValueError, SyntaxError) as e:
            raise _common.CliError(f"{path}: not a PNG image ({e})") from None
        if array.ndim == 3 and colour and array.shape[2] >= 3:
            array = array[..., :3]
        elif array.ndim == 3:
            array = array[..., :3] @ np.array([0.2126, 0.7152, 0.0722])[:array.shape[2]]
    try:
        return Image(array, width)
    except (TypeError, ValueError) as e:
        raise _common.CliError(f"--texture {path}: {e}") from None


def _render_targets(args: argparse.Namespace) -> tuple[Path, Path | None]:
    out = Path(args.out)
    _common.check_suffix("--out", out, (".npz",))
    _common.check_output(out, args.force)
    png = None if args.png is None else Path(args.png)
    if png is not None:
        _common.check_suffix("--png", png, (".png",))
        _common.need("matplotlib", "render --png", "plot")
        _common.check_output(png, args.force)
        if png.resolve() == out.resolve():
            raise _common.CliError("--png and --out: give two different files")
    return out, png


def _render_summary(raw: Any, out: Path, png: Path | None, args: argparse.Namespace
                    ) -> dict[str, Any]:
    channels = [{"channel": i, "shape": list(a.shape), "min": float(a.min()),
                 "max": float(a.max()), "mean": float(a.mean())}
                for i, a in enumerate(raw.images, 1)]
    return {"path": str(out), "png": None if png is None else str(png),
            "design": args.design, "texture": args.texture, "depth": args.depth,
            "noise": args.noise, "falloff": args.falloff, "seed": args.seed,
            "channels": channels,
            "cfa": raw.cfa and {"pattern": raw.cfa["pattern"], "qe": list(raw.cfa["qe"])}}


def _write_render(raw: Any, out: Path, png: Path | None, force: bool) -> None:
    """The raw file, and its picture (both atomic; the picture is put in place only once
    the raw file is)."""
    import contextlib

    with contextlib.ExitStack() as stack:
        if png is not None:
            from ..plot import raw as plot_raw
            from ..plot._mpl import pyplot

            tmp = stack.enter_context(atomic_output(png, force=force, hint=_common.FORCE_HINT))
            fig = plot_raw(raw)
            try:
                fig.savefig(tmp, dpi=150)
            finally:
                pyplot().close(fig)
        raw.save(out, force=force)


def run(args: argparse.Namespace) -> int:
    from ..imaging.render import Scene, render

    out, png = _render_targets(args)
    design = _common.named_design(args.design)
    texture = parse_render_texture(args.texture, args.width, colour=args.cfa is not None)
    if args.qe is not None and args.cfa is None:
        raise _common.CliError("--qe: the quantum efficiencies of a --cfa's colours, needs "
                               "--cfa")
    qe = None if args.qe is None else _common.numbers("--qe", args.qe, 3)
    depth = _common.parse_render_depth(args.depth, args.extent)
    scene = Scene(texture, depth)
    if args.noise_tol is not None and args.noise is None:
        raise _common.CliError("--noise-tol: a fraction of the noise, needs --noise N[,READ]")
    with _common.scheduler_executor(args) as executor:
        raw = render(design, scene, noise=args.noise, seed=args.seed, tol=args.tol,
                     noise_tol=args.noise_tol, n_threads=args.threads, executor=executor,
                     cfa=args.cfa, qe=qe, falloff=args.falloff)
    _write_render(raw, out, png, args.force)
    sys.stdout.write(_common.json_text(_render_summary(raw, out, png, args)) if args.json
                     else f"{out}\n")
    return 0
