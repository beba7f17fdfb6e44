"""What the design explorer shows, without any web framework: the controls' fields, the
parsing of their text (numbers only: nothing typed in the page is ever evaluated as code),
and the data of every view, each computed by the public API (the core is the only physics).

The browser app (:mod:`splitlf.explorer.app`) only moves these numbers into figures.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tempfile
from typing import Any

import numpy as np

from ..errors import InvalidParameter, TooLargeError
from ..model.camera import Camera, read_toml
from ..model.design import CHANNEL_DESCRIPTIONS, DESIGN_DESCRIPTIONS, Channel, Design
from ..model.optics import curves, depth_of_field
from ..sampling.rayspace import trace
from ..sampling.samples import new_samples, sweep_depths
from ..sampling.samples2d import coverage
from ..study.report import report_data

__all__ = [
    "CHANNEL_CONTROLS",
    "DESIGN_CONTROLS",
    "Field",
    "FieldError",
    "blur_view",
    "control_key",
    "design_from_texts",
    "design_texts",
    "gap_view",
    "load_toml_bytes",
    "parse",
    "ray_space_view",
    "image_depths",
    "image_view",
    "report_rows",
    "samples_depths",
    "samples_view",
]

#: Depths of the closed-form views: from 1.25 F to 125 F, log-spaced (seed: 100 mm - 10 m).
BLUR_DEPTHS = 600
#: Default depths of the samples view (2-D coverage: about 10-60 ms a depth for the seed).
SAMPLES_DEPTHS = 8
#: Default width of the samples view's central field, in lens pitches of channel 1.
SAMPLES_WINDOW = 2.0
#: Log-spaced depths of the 1-D samples view, to which the out-of-focus and coincidence
#: planes are added (seed: 191 depths, new_samples 6-10 ms).
GAP_DEPTHS = 60
#: Microlenses drawn in the ray-space view.
RAY_LENSES = 3
#: Depths of the image-quality view (:func:`splitlf.image_merits`, seconds to minutes a
#: depth: computed on request only), log-spaced over [3.75 F, 25 F] (seed: 300 mm - 2 m,
#: the depth range of docs/compare.md's study) plus the channels' out-of-focus planes
#: there, and its default photon count.
IMAGE_DEPTHS = 5
IMAGE_RANGE_F = (3.75, 25.0)
IMAGE_PHOTONS = 2000.0
#: Threads of the core for the explorer's heavy views (2-D coverage, ray space), which run
#: beside the page: all cores but one, which stays free for the browser drawing the
#: previous results and the server answering the next change. A pool of its own (the
#: core keeps one per thread count): the closed-form and 1-D views, computed while the
#: page waits, use all cores and never queue behind a heavy view.
THREADS = max(1, (os.cpu_count() or 1) - 1)


@dataclasses.dataclass(frozen=True)
class Field:
    """One control: ``name`` as the API names it, ``kind`` the text it accepts
    (``real``, ``count``, ``optional count``, ``focal lengths``, or ``choice``),
    ``label`` with its unit, ``help`` (the API's description), ``choices``."""

    name: str
    kind: str
    label: str
    help: str
    choices: tuple[str, ...] = ()


DESIGN_CONTROLS = (
    Field("F", "real", "F [mm]", DESIGN_DESCRIPTIONS["F"]),
    Field("D", "real", "D [mm]", DESIGN_DESCRIPTIONS["D"]),
    Field("aperture", "choice", "aperture", DESIGN_DESCRIPTIONS["aperture"],
          ("square", "circle")),
)

CHANNEL_CONTROLS = (
    Field("L", "real", "L [mm]", CHANNEL_DESCRIPTIONS["L"]),
    Field("d", "real", "d [mm]", CHANNEL_DESCRIPTIONS["d"]),
    Field("v", "real", "v [mm]", CHANNEL_DESCRIPTIONS["v"]),
    Field("mu", "real", "μ [mm]", CHANNEL_DESCRIPTIONS["mu"]),
    Field("Kx", "count", "Kx [lenses]", CHANNEL_DESCRIPTIONS["Kx"]),
    Field("Ky", "count", "Ky [lenses]", CHANNEL_DESCRIPTIONS["Ky"]),
    Field("f", "focal lengths", "f [mm] (blank: Ng)", CHANNEL_DESCRIPTIONS["f"]),
    Field("grid", "choice", "grid", CHANNEL_DESCRIPTIONS["grid"], ("rect", "hex")),
    Field("layout", "choice", "layout", CHANNEL_DESCRIPTIONS["layout"],
          ("ideal", "sensor")),
    Field("Q", "optional count", "Q [px/lens]", CHANNEL_DESCRIPTIONS["Q"]),
    Field("Mx", "optional count", "Mx [px]", CHANNEL_DESCRIPTIONS["Mx"]),
    Field("My", "optional count", "My [px]", CHANNEL_DESCRIPTIONS["My"]),
    Field("share", "real", "share", CHANNEL_DESCRIPTIONS["share"]),
)


def control_key(name: str | None) -> str | None:
    """The control an error of the API names: ``F``, ``channels[2].L``; a main-lens field
    named within a channel (``channels[1].D``: the aperture's image overlaps in channel 1)
    is the main-lens control ``D``; ``None`` when no control matches."""
    if name is None:
        return None
    if name in {f.name for f in DESIGN_CONTROLS}:
        return name
    head, _, field = name.rpartition(".")
    if head.startswith("channels[") and field in {f.name for f in CHANNEL_CONTROLS}:
        return name
    if field in {f.name for f in DESIGN_CONTROLS}:
        return field
    return None


class FieldError(ValueError):
    """Text of a control that is not a value of its kind (or a design the API refuses):
    ``key`` names the control (``F``, ``channels[2].L``; ``None``: the design as a whole),
    ``message`` is what the page shows."""

    def __init__(self, key: str | None, message: str) -> None:
        super().__init__(message)
        self.key = control_key(key)
        self.message = message


def _text(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, tuple | list):
        return ", ".join(repr(float(x)) for x in value)
    if isinstance(value, float):
        return repr(value)
    return str(value)


def parse(field: Field, text: str, key: str) -> Any:
    """The value of a control's text: ``float()`` / ``int()`` of the stripped text only
    (never ``eval``), a choice from its list, ``None`` for a blank optional field. Raises
    :class:`FieldError` naming ``key``."""
    t = text.strip()
    if field.kind == "choice":
        if t not in field.choices:
            raise FieldError(key, f"{key}: {t!r} is not one of {', '.join(field.choices)}")
        return t
    if field.kind == "optional count" and t == "":
        return None
    if field.kind == "focal lengths":
        if t == "" or t.lower() == "ng":
            return None
        return tuple(_real(key, part) for part in t.split(","))
    if field.kind == "real":
        return _real(key, t)
    try:
        return int(t)
    except ValueError:
        raise FieldError(key, f"{key}: {t!r} is not an integer") from None


def _real(key: str, text: str) -> float:
    try:
        return float(text.strip())
    except ValueError:
        raise FieldError(key, f"{key}: {text.strip()!r} is not a number") from None


def design_texts(design: Design) -> dict[str, str]:
    """The text of every control for ``design``: ``F``, ``D``, ``aperture`` and
    ``channels[i].NAME`` (i from 1)."""
    out = {f.name: _text(getattr(design, f.name)) for f in DESIGN_CONTROLS}
    for i, ch in enumerate(design.channels, 1):
        for f in CHANNEL_CONTROLS:
            out[f"channels[{i}].{f.name}"] = _text(getattr(ch, f.name))
    return out


def design_from_texts(texts: dict[str, str], n_channels: int) -> Design:
    """The design the controls describe, validated by the API. Raises :class:`FieldError`
    whose ``key`` is the control the API (or the parser) names, or ``None``."""
    main = {f.name: parse(f, texts[f.name], f.name) for f in DESIGN_CONTROLS}
    channels = []
    for i in range(1, n_channels + 1):
        fields = {f.name: parse(f, texts[f"channels[{i}].{f.name}"], f"channels[{i}].{f.name}")
                  for f in CHANNEL_CONTROLS}
        try:
            channels.append(Channel(**fields))
        except (TypeError, InvalidParameter) as e:
            name = getattr(e, "name", None)
            raise FieldError(None if name is None else f"channels[{i}].{name}", str(e)) from None
    try:
        return Design(channels=tuple(channels), **main)
    except (TypeError, InvalidParameter) as e:
        raise FieldError(getattr(e, "name", None), str(e)) from None


def load_toml_bytes(data: bytes, name: str = "uploaded.toml") -> Design:
    """A design from the bytes of a TOML file: a ``[design]`` file (what "save TOML"
    writes and ``splitlf report --config`` reads) or a ``[camera]`` file (its design).
    Raises the errors of :meth:`Design.from_toml` / :meth:`Camera.from_toml`."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, os.path.basename(name) or "uploaded.toml")
        with open(path, "wb") as fh:
            fh.write(data)
        if "design" in read_toml(path):
            return Design.from_toml(path)
        return Camera.from_toml(path).design


def blur_depths(design: Design, n: int = BLUR_DEPTHS) -> np.ndarray:
    """Depths of the closed-form views: n log-spaced from 1.25 F to 125 F [mm]."""
    return np.geomspace(1.25 * design.F, 125.0 * design.F, n)


def samples_depths(design: Design, n: int = SAMPLES_DEPTHS) -> np.ndarray:
    """Depths of the samples view: n log-spaced from 1.875 F to 125 F [mm] (seed: 150 mm
    to 10 m, the report's range), with every channel's out-of-focus plane in that range
    added (where a channel falls to one sample per lens), sorted."""
    lo, hi = 1.875 * design.F, 125.0 * design.F
    planes = [design.out_of_focus_depth(i) for i in range(1, len(design.channels) + 1)]
    z = np.concatenate([np.geomspace(lo, hi, n), [p for p in planes if lo < p < hi]])
    return np.unique(z)


def image_depths(design: Design, n: int = IMAGE_DEPTHS) -> np.ndarray:
    """Depths of the image-quality view: n log-spaced over [3.75 F, 25 F] [mm], with every
    channel's out-of-focus plane inside that range added (where its band is), sorted."""
    lo, hi = IMAGE_RANGE_F[0] * design.F, IMAGE_RANGE_F[1] * design.F
    planes = [design.out_of_focus_depth(i) for i in range(1, len(design.channels) + 1)]
    return np.unique(np.concatenate([np.geomspace(lo, hi, n),
                                     [p for p in planes if lo < p < hi]]))


def image_view(design: Design, photons: float = IMAGE_PHOTONS,
               n: int = IMAGE_DEPTHS) -> dict[str, Any]:
    """The predicted image quality against depth, from :func:`splitlf.image_merits` at
    :func:`image_depths` (n depths) and ``photons`` photo-electrons for white, every row
    (each channel, each lens type when there are several, the union) with its defaults
    (the natural ensemble, the prior's weight chosen by GCV; docs/merits.md): ``z``,
    ``rows``, ``psnr`` and ``psnr_error`` [dB], ``mtf50`` [share of the sensor's Nyquist
    frequency], each (rows, n); ``photons``; ``seconds`` (the call's wall time).

    The heaviest view (seconds to minutes a depth and row): the app computes it off the
    UI thread and only when asked."""
    import time

    from ..inverse.merits import image_merits

    z = image_depths(design, n)
    t0 = time.perf_counter()
    r = image_merits(design, z, photons, n_threads=THREADS)
    rows = tuple(r.rows)
    return {"z": z, "rows": rows, "photons": float(r.photons),
            "psnr": np.array([r.rows[k]["psnr"] for k in rows]),
            "psnr_error": np.array([r.rows[k]["psnr_error"] for k in rows]),
            "mtf50": np.array([r.rows[k]["mtf50"] for k in rows]),
            "seconds": time.perf_counter() - t0}


def _finite(x: float) -> float:
    return x if math.isfinite(x) else float("nan")


def blur_view(design: Design, threshold_px: float = 0.5) -> dict[str, Any]:
    """Blur against depth (Fig. 1), repetitions (Fig. 5) and the depth of field, from
    :func:`splitlf.curves` and :func:`splitlf.depth_of_field`:

    - ``z`` (n,) [mm]; ``rows`` and ``blur_px`` (R, n): light field blur per (channel,
      lens type); ``channels``, ``conventional_px`` and ``repetitions`` (C, n) per channel
    - ``dof``: (row, near, far) for every sharp interval of every row of
      :func:`~splitlf.depth_of_field` (``far`` may be ``inf``); ``threshold_px``
    """
    z = blur_depths(design)
    c = curves(design, z)
    dof = depth_of_field(design, threshold_px)
    bands = [(row, float(a), float(b)) for row, iv in zip(dof.rows, dof.intervals, strict=True)
             for a, b in iv]
    return {"z": z, "rows": c.rows, "blur_px": c.blur_px, "channels": c.channels,
            "conventional_px": c.conventional_px, "repetitions": c.repetitions,
            "dof_rows": dof.rows, "dof": bands, "threshold_px": threshold_px}


def samples_view(design: Design, n: int = SAMPLES_DEPTHS,
                 window: float = SAMPLES_WINDOW) -> dict[str, Any]:
    """Distinct 2-D samples and covering radius against depth, from
    :func:`splitlf.coverage` at :func:`samples_depths` (n depths) over a central field
    ``window`` lens pitches wide: ``z``, ``rows`` (channels, then the union),
    ``distinct`` and ``covering_radius`` (in delta(z)), (rows, n).

    This is the heavy view (tens of ms a depth): the app computes it off the UI thread.
    Its 1-D counterpart, at many more depths for the price of a few of these, is
    :func:`gap_view`."""
    z = samples_depths(design, n)
    cov = coverage(design, z, window=window, n_threads=THREADS)
    return {"z": z, "rows": cov.rows, "distinct": cov.distinct,
            "covering_radius": cov.covering_radius, "window": window}


def gap_view(design: Design, n: int = GAP_DEPTHS) -> dict[str, Any]:
    """Distinct samples along x and the largest gap between them (in delta(z)) against
    depth, from :func:`splitlf.new_samples` at :func:`splitlf.sweep_depths` over the
    samples view's range (n log-spaced depths plus the out-of-focus and coincidence
    planes, where the counts dip and the gaps peak): ``z``, ``rows`` (channels, then the
    union), ``distinct`` and ``max_gap`` (rows, m; an infinite gap, samples not covering
    the field, is NaN), ``note`` (empty, or why the view is empty, the API's message: the
    1-D engine takes rect channels only, and refuses sensors too large for it)."""
    lo, hi = 1.875 * design.F, 125.0 * design.F
    rows = (*(f"channel {i}" for i in range(1, len(design.channels) + 1)), "union")
    try:
        z = sweep_depths(design, (lo, hi), n=n)
        r = new_samples(design, z)
    except (InvalidParameter, TooLargeError) as e:
        if isinstance(e, InvalidParameter) and not str(getattr(e, "name", "")).endswith(".grid"):
            raise
        empty = np.zeros((len(rows), 0))
        return {"z": np.zeros(0), "rows": rows, "distinct": empty, "max_gap": empty,
                "note": f"1-D samples: {e}"}
    gap = np.where(np.isfinite(r.max_gap), r.max_gap, np.nan)
    return {"z": z, "rows": r.rows, "distinct": r.distinct, "max_gap": gap, "note": ""}


def ray_space_view(design: Design, channel: int, lenses: int = RAY_LENSES) -> dict[str, Any]:
    """The ray space of one channel along x (Fig. 4): the integration polygon in (u, w)
    [mm] of every pixel under the ``lenses`` central microlenses of channel ``channel``
    that collects light, from :func:`splitlf.trace` (u on channel 1's array plane, w on
    the main lens): ``us``, ``ws`` (lists of vertex arrays), ``lens`` and ``type`` of
    each polygon, ``half_aperture`` (D/2), ``note`` (empty, or why the view is empty: the
    1-D engine takes rect channels only)."""
    try:
        tr = trace(design, channel=channel, axis="x", n_threads=THREADS)
    except (InvalidParameter, TooLargeError) as e:
        if isinstance(e, InvalidParameter) and not str(getattr(e, "name", "")).endswith(".grid"):
            raise
        return {"us": [], "ws": [], "lens": np.zeros(0, dtype=np.int64),
                "type": np.zeros(0, dtype=np.int64), "half_aperture": design.D / 2.0,
                "note": f"ray space: {e}"}
    K = int(tr.lens.max()) + 1
    first = max(0, (K - lenses) // 2)
    keep = np.flatnonzero((tr.lens >= first) & (tr.lens < first + lenses) & (tr.n_vertices > 0))
    us = [tr.vertices[i, : tr.n_vertices[i], 0] for i in keep]
    ws = [tr.vertices[i, : tr.n_vertices[i], 1] for i in keep]
    kind = tr.type[keep] if tr.type is not None else np.zeros(len(keep), dtype=np.int64)
    return {"us": us, "ws": ws, "lens": tr.lens[keep], "type": kind,
            "half_aperture": design.D / 2.0, "note": ""}


def report_rows(design: Design, threshold_px: float = 0.5) -> list[tuple[str, str]]:
    """The report's numbers (:func:`splitlf.report.report_data`) as (label, value)
    rows for the table of the page."""
    data = report_data(design, threshold_px, samples=False)
    der = data["derived"]
    out = [("f-number", f"{der['f_number']:.4g}")]
    for ch in der["channels"]:
        n = ch["name"]
        out.append((f"{n}: array plane L [mm]", f"{ch['array_plane_mm']:.4f}"))
        out.append((f"{n}: out-of-focus plane [mm]", f"{ch['out_of_focus_depth_mm']:.2f}"))
        out.append((f"{n}: microlens image radius [px]",
                    f"{ch['microlens_image_radius_px']:.3f}"))
        out.append((f"{n}: pixels", f"{ch['pixels'][0]} x {ch['pixels'][1]}"))
        for t, lt in enumerate(ch["lens_types"], 1):
            z = lt["focus_depth_mm"]
            focus = "main lens" if z is None else f"{z:.2f} mm"
            out.append((f"{n}: type {t} f [mm], focused on",
                        f"{lt['focal_length_mm']:.6g}, {focus}"))
    dof = data["depth_of_field"]
    for name, iv in dof["light_field"].items():
        out.append((f"sharp ({name}) [mm]", _intervals(iv)))
    for name, iv in dof["conventional"].items():
        out.append((f"sharp (conventional, {name}) [mm]", _intervals(iv)))
    return out


def _intervals(iv: list) -> str:
    if not iv:
        return "none"
    return ", ".join(f"{a:.1f} – {'inf' if b is None else f'{b:.1f}'}" for a, b in iv)


def default_map_depth(design: Design) -> float:
    """The sample map's first depth: channel 1's out-of-focus plane with several channels
    (where channel 1 alone resolves least), twice it with one (as ``splitlf figures``)."""
    return design.out_of_focus_depth(1) * (1.0 if len(design.channels) > 1 else 2.0)


def sample_map(design: Design, z: float, window: float = SAMPLES_WINDOW) -> dict[str, Any]:
    """The 2-D chief samples at depth ``z`` (:func:`splitlf.samples_2d` over a central
    field ``window`` lens pitches wide), per channel, in units of delta(z): ``x``, ``y``
    (lists of arrays), ``rows`` (channels, then the union), ``distinct`` and
    ``covering_radius`` of every row, ``delta_mm``."""
    from ..sampling.samples2d import samples_2d

    r = samples_2d(design, z, window=window)
    delta = design.resolution_step(r.z)
    n = len(design.channels)
    return {"z": r.z, "rows": r.rows, "delta_mm": delta,
            "x": [r.samples[k][:, 0] / delta for k in range(n)],
            "y": [r.samples[k][:, 1] / delta for k in range(n)],
            "distinct": r.distinct, "covering_radius": r.covering_radius}


#: Colours (RGBA, uint8) of lens types 1, 2, 3, ... of the microlens images, and unlit.
TYPE_RGBA = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189))
UNLIT_RGBA = (220, 220, 220)


def microlens_image(design: Design, channel: int, lenses: int = 4) -> dict[str, Any]:
    """The centre of channel ``channel``'s sensor, ``lenses`` image pitches wide: each lit
    pixel coloured by its lens's type, unlit pixels grey (from :func:`splitlf.chief_samples`
    over the crop's rows only; which pixels are lit does not depend on the depth).
    ``rgba`` (rows, cols) uint32 for Bokeh's ``image_rgba``, ``x0``, ``y0`` (the crop's
    first column and row), ``lit`` and ``pixels`` (counts in the crop)."""
    from ..sampling.samples2d import chief_samples

    ch = design.channels[channel - 1]
    info = design.resolved()[channel - 1]
    rows, cols = ((info["My"], info["Mx"]) if info["layout"] == "sensor"
                  else (ch.Ky * info["Q"], ch.Kx * info["Q"]))
    half = int(np.ceil(lenses * ch.d * (1.0 + ch.v / ch.L) / ch.mu / 2.0))
    r0, r1 = max(rows // 2 - half, 0), min(rows // 2 + half + 1, rows)
    c0, c1 = max(cols // 2 - half, 0), min(cols // 2 + half + 1, cols)
    s = chief_samples(design, channel, 100.0 * design.F, rows=(r0, r1))
    lit, kind = s.lit[:, c0:c1], s.type[:, c0:c1]
    palette = np.array([TYPE_RGBA[t % len(TYPE_RGBA)] for t in range(len(info["f"]))],
                       dtype=np.uint32)
    rgb = np.where(lit[..., None], palette[kind], np.array(UNLIT_RGBA, dtype=np.uint32))
    rgba = (rgb[..., 0] | (rgb[..., 1] << 8) | (rgb[..., 2] << 16) | (255 << 24))
    return {"rgba": rgba.astype(np.uint32), "x0": c0, "y0": r0,
            "lit": int(np.count_nonzero(lit)), "pixels": int(lit.size)}
