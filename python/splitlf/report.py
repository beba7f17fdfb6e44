"""The design report: every number computed by the core, formatted for people or JSON."""

from __future__ import annotations

import math
from typing import Any

from . import _validate
from .camera import _DESCRIPTIONS, COUNT_FIELDS, FIELDS, Camera
from .design import Design
from .optics import depth_of_field
from .samples import coincidence_planes, worst_resolution

__all__ = ["report_data", "format_report", "design_report_data", "format_design_report"]

#: Coincidence planes listed in the report: N <= 3 (T <= Q).
REPORT_MAX_N = 3
#: Depth range of the worst-resolution figure [mm].
REPORT_Z_RANGE = (150.0, 10_000.0)


def report_data(camera: Camera | Design, threshold_px: float = 0.5,
                n_threads: int | None = None) -> dict[str, Any]:
    """Camera, derived values, out-of-focus planes and depth of field as a JSON-ready dict.

    - ``camera``: the :class:`~splitlf.Camera`, or a :class:`~splitlf.Design` (then the
      result is :func:`design_report_data`'s with ``samples=True``, per channel and lens
      type, and :func:`format_report` formats it as :func:`format_design_report` does)
    - ``threshold_px``: sharpness threshold on the blur radius [pixels], finite > 0
    - ``n_threads``: threads of the core for the coincidence planes and the worst
      resolution (None: all cores)

    Keys: ``camera`` (fields, mm), ``derived`` (f-number, rho and per-half values),
    ``depth_of_field`` (intervals [near, far] mm, far None when infinite),
    ``coincidence_planes`` (N <= :data:`REPORT_MAX_N`) and ``resolution`` (worst max gap
    over :data:`REPORT_Z_RANGE`). Raises ``TypeError`` and ``ValueError`` (from the
    functions it calls) for bad arguments.
    """
    if isinstance(camera, Design):
        return design_report_data(camera, threshold_px, n_threads=n_threads, samples=True)
    _validate.camera_or_design(camera)
    halves = {}
    for h in (1, 2):
        halves[f"half{h}"] = {
            "array_plane_mm": camera.L(h),
            "microlens_focal_mm": camera.f1 if h == 1 else camera.f2,
            "ng_setting": camera.is_ng(h) or math.isclose(
                camera.f1 if h == 1 else camera.f2, camera.ng_focal_length(h), rel_tol=1e-12
            ),
            "out_of_focus_depth_mm": camera.out_of_focus_depth(h),
            "microlens_image_radius_mm": camera.image_radius(h),
            "microlens_image_radius_px": camera.image_radius(h) / camera.mu,
            "lit_pixels": camera.lit_pixels(h),
            "pixels_per_microlens": camera.Q,
        }
    dof = depth_of_field(camera, threshold_px)
    return {
        "camera": camera.as_dict(),
        "derived": {"f_number": camera.f_number, "rho_mm": camera.rho, **halves},
        "depth_of_field": dof.as_dict(),
        "coincidence_planes": {
            f"half{h}": coincidence_planes(camera, h, max_n=REPORT_MAX_N,
                                           n_threads=n_threads).rows()
            for h in (1, 2)
        },
        "resolution": worst_resolution(camera, REPORT_Z_RANGE, max_n=REPORT_MAX_N,
                                       n_threads=n_threads),
    }


def _interval_text(iv: list) -> str:
    if not iv:
        return "none"
    parts = []
    for near, far in iv:
        far_s = "inf" if far is None else f"{far:.1f}"
        parts.append(f"{near:.1f} - {far_s}")
    return ", ".join(parts)


def format_report(data: dict[str, Any], title: str) -> str:
    """The report as text for people: ``data`` from :func:`report_data` (a Camera's, or a
    Design's: then :func:`format_design_report`), under ``title``. Returns the text,
    ending in a newline."""
    if "design" in data:
        return format_design_report(data, title)
    cam, der, dof = data["camera"], data["derived"], data["depth_of_field"]
    h1, h2 = der["half1"], der["half2"]
    out = [title, "", "Camera (lengths in mm)"]
    for name in FIELDS:
        value = cam[name]
        text = f"{value}" if name in COUNT_FIELDS else f"{value:.6g}"
        out.append(f"  {name:<6} = {text:<12} {_DESCRIPTIONS[name]}")
    out += [
        "",
        "Derived",
        f"  f-number                           {der['f_number']:.3g}",
        f"  rho = kappa v1 (prism side)        {der['rho_mm']:.4g} mm",
        f"  {'':<34} {'half 1':>10} {'half 2':>10}",
    ]

    def row(label: str, key: str, fmt: str) -> str:
        """One line: label, then the value of ``key`` for half 1 and half 2."""
        return f"  {label:<34} {format(h1[key], fmt):>10} {format(h2[key], fmt):>10}"

    out += [
        row("array plane L_i [mm]", "array_plane_mm", ".4f"),
        row("microlens focal length f_i [mm]", "microlens_focal_mm", ".5f"),
        f"  {'  (Ng setting)':<34} {str(h1['ng_setting']):>10} {str(h2['ng_setting']):>10}",
        row("out-of-focus plane z_i [mm]", "out_of_focus_depth_mm", ".2f"),
        row("microlens image radius R_i [px]", "microlens_image_radius_px", ".3f"),
        f"  {'lit pixels per microlens':<34} {h1['lit_pixels']:>5} / {cam['Q']:<2} "
        f"{h2['lit_pixels']:>5} / {cam['Q']:<2}",
        "",
        f"Depth of field (sharp: blur < {dof['threshold_px']:g} px), depths in mm",
        f"  half 1 (light field)               {_interval_text(dof['half1'])}",
        f"  half 2 (light field)               {_interval_text(dof['half2'])}",
        f"  split sensor (either half)         {_interval_text(dof['split'])}",
        f"  conventional, sensor on plane 1    {_interval_text(dof['conventional1'])}",
        f"  conventional, sensor on plane 2    {_interval_text(dof['conventional2'])}",
    ]
    out += _samples_text(data)
    return "\n".join(out) + "\n"


def _gap_text(g: float | None) -> str:
    return "inf (field not covered)" if g is None else f"{g:.2f}"


def _samples_text(data: dict[str, Any]) -> list[str]:
    out = ["", f"Coincidence planes (N <= {REPORT_MAX_N}, T <= Q), sorted by depth; "
           "Eq. 8/9 with Q_lit vs brute-force count"]
    for h in (1, 2):
        rows = data["coincidence_planes"][f"half{h}"]
        agree = sum(r["counted"] == r["new_samples"] for r in rows)
        out.append(f"  half {h}: {len(rows)} planes, counted == Eq. {7 + h} on {agree}")
        out.append(f"    {'N':>2} {'T':>3} {'side':<5} {'z [mm]':>10} {'rep':>7} "
                   f"{'Eq. ' + str(7 + h):>12} {'counted':>12}")
        for r in rows:
            out.append(f"    {r['N']:>2} {r['T']:>3} {r['side']:<5} {r['z']:>10.2f} "
                       f"{r['repetitions']:>7.3f} {r['new_samples']:>12} {r['counted']:>12}")
    res = data["resolution"]
    lo, hi = res["z_range_mm"]
    out += ["", f"Worst resolution over {lo:g} - {hi:g} mm (largest max gap in the central "
            "field, in delta(z) = d z / (Q v'))",
            f"  depths: {res['depths']} ({res['sampling']})"]
    for key, label in (("half1", "half 1"), ("half2", "half 2"), ("split", "split sensor")):
        r = res[key]
        out.append(f"  {label:<14} max gap {_gap_text(r['max_gap']):>8} at z = {r['z_mm']:.1f} mm"
                   f"   (fewest distinct samples along x: {r['min_distinct']})")
    return out


# -- general designs (docs/architectures.md) ------------------------------------------------

def design_report_data(design: Design, threshold_px: float = 0.5, *,
                       n_threads: int | None = None, samples: bool = False) -> dict[str, Any]:
    """A :class:`~splitlf.Design`'s report as a JSON-ready dict: ``design`` (its fields,
    :meth:`Design.as_dict`), ``derived`` (f-number, and per channel its array plane, its
    out-of-focus plane, its microlens image radius and each lens type's focal length and
    the depth it is focused on) and ``depth_of_field`` (:meth:`DesignDepthOfField.as_dict`:
    per lens type, per channel, the union, the conventional cameras; [near, far] in mm,
    far None when infinite) at ``threshold_px`` (finite > 0, pixels).

    With ``samples`` (what ``splitlf report`` and :func:`report_data` give), also the
    camera report's sample sections: ``coincidence_planes`` {"channel i": the rows of
    :func:`~splitlf.coincidence_planes` with N <= :data:`REPORT_MAX_N`, or None where
    docs/model.md §6 does not hold (a hex grid, a sensor layout, a circular aperture)} and
    ``resolution`` (:func:`~splitlf.samples.worst_resolution` over :data:`REPORT_Z_RANGE`,
    per channel and union; None when a channel has a hex grid: the 1-D max gap needs rect
    grids, :func:`splitlf.coverage` is the 2-D measure), on ``n_threads`` threads of the
    core (None: all cores). Raises the errors of :func:`~splitlf.depth_of_field` and of
    those functions."""
    if not isinstance(design, Design):
        raise TypeError(f"design must be a splitlf.Design, got {type(design).__name__}")
    n_threads = _validate.n_threads(n_threads)
    channels = []
    for i, (ch, res) in enumerate(zip(design.channels, design.resolved(), strict=True), 1):
        radius = design.image_radius(i)
        types = [{"focal_length_mm": f, "focus_depth_mm": z}
                 for f, z in zip(res["f"], design.focus_depths(i), strict=True)]
        channels.append({
            "name": f"channel {i}",
            "array_plane_mm": ch.L,
            "out_of_focus_depth_mm": design.out_of_focus_depth(i),
            "microlens_image_radius_mm": radius,
            "microlens_image_radius_px": radius / ch.mu,
            "ng_setting": res["ng"],
            "lens_types": types,
            "pixels": [res["Mx"], res["My"]] if ch.layout == "sensor"
            else [res["Q"] * ch.Kx, res["Q"] * ch.Ky],
        })
    dof = depth_of_field(design, threshold_px)
    out = {
        "design": design.as_dict(),
        "derived": {"f_number": design.f_number, "channels": channels},
        "depth_of_field": dof.as_dict(),
    }
    if samples:
        out["coincidence_planes"] = {
            f"channel {i}": coincidence_planes(design, channel=i, max_n=REPORT_MAX_N,
                                               n_threads=n_threads).rows()
            if ch.grid == "rect" and ch.layout == "ideal" and design.aperture == "square"
            else None
            for i, ch in enumerate(design.channels, 1)
        }
        rect = all(ch.grid == "rect" for ch in design.channels)
        out["resolution"] = worst_resolution(design, REPORT_Z_RANGE, max_n=REPORT_MAX_N,
                                             n_threads=n_threads) if rect else None
    return out


def _channel_text(ch: dict[str, Any], der: dict[str, Any]) -> list[str]:
    """One channel's block: its fields and derived values."""
    layout = (f"ideal layout, Q = {ch['Q']}" if ch["layout"] == "ideal"
              else f"sensor layout, {der['pixels'][0]} x {der['pixels'][1]} pixels")
    out = [
        f"{der['name'].capitalize()}: share {ch['share']:.6g}, {ch['grid']} grid of "
        f"{ch['Kx']} x {ch['Ky']} lenses, {layout}",
        f"  {'array plane L':<34} {ch['L']:>12.6g} mm",
        f"  {'pitch d':<34} {ch['d']:>12.6g} mm",
        f"  {'array -> sensor v':<34} {ch['v']:>12.6g} mm",
        f"  {'pixel pitch mu':<34} {ch['mu']:>12.6g} mm",
        f"  {'out-of-focus plane z':<34} {der['out_of_focus_depth_mm']:>12.2f} mm",
        f"  {'microlens image radius R':<34} {der['microlens_image_radius_px']:>12.3f} px",
    ]
    for t, lt in enumerate(der["lens_types"], 1):
        label = "lens type" if len(der["lens_types"]) == 1 else f"lens type {t}"
        ng = " (Ng's setting)" if der["ng_setting"] else ""
        z = lt["focus_depth_mm"]
        focus = "focused on the main lens" if z is None else f"focused at z = {z:.2f} mm"
        out.append(f"  {label + ': f':<34} {lt['focal_length_mm']:>12.6g} mm{ng}, {focus}")
    return out


def format_design_report(data: dict[str, Any], title: str) -> str:
    """A design's report as text for people: ``data`` from :func:`design_report_data`,
    under ``title``. Returns the text, ending in a newline."""
    des, der, dof = data["design"], data["derived"], data["depth_of_field"]
    out = [title, "", "Main lens (lengths in mm)",
           f"  {'F':<6} = {des['F']:<12.6g} main lens focal length",
           f"  {'D':<6} = {des['D']:<12.6g} aperture width ({des['aperture']})",
           f"  f-number {der['f_number']:.3g}"]
    for ch, cd in zip(des["channels"], der["channels"], strict=True):
        out += ["", *_channel_text(ch, cd)]
    out += ["", f"Depth of field (sharp: blur < {dof['threshold_px']:g} px), depths in mm"]
    for name, iv in dof["light_field"].items():
        label = "union (any channel)" if name == "union" else f"{name} (light field)"
        out.append(f"  {label:<34} {_interval_text(iv)}")
    for name, iv in dof["conventional"].items():
        out.append(f"  {'conventional, sensor on ' + name:<34} {_interval_text(iv)}")
    if "coincidence_planes" in data:
        out += _design_samples_text(data)
    return "\n".join(out) + "\n"


def _design_samples_text(data: dict[str, Any]) -> list[str]:
    """The sample sections of a design's report (:func:`design_report_data` with
    ``samples``): coincidence planes per channel, worst resolution per channel and union."""
    out = ["", f"Coincidence planes (N <= {REPORT_MAX_N}, T <= Q), sorted by depth; "
           "Eq. 8/9 with Q_lit vs brute-force count"]
    for name, rows in data["coincidence_planes"].items():
        if rows is None:
            out.append(f"  {name}: none defined (docs/model.md §6 needs a rect grid, the "
                       "ideal layout and a square aperture)")
            continue
        agree = sum(r["counted"] == r["new_samples"] for r in rows)
        out.append(f"  {name}: {len(rows)} planes, counted == Eq. 8/9 on {agree}")
        out.append(f"    {'N':>2} {'T':>3} {'side':<5} {'z [mm]':>10} {'rep':>7} "
                   f"{'Eq. 8/9':>12} {'counted':>12}")
        for r in rows:
            out.append(f"    {r['N']:>2} {r['T']:>3} {r['side']:<5} {r['z']:>10.2f} "
                       f"{r['repetitions']:>7.3f} {r['new_samples']:>12} {r['counted']:>12}")
    res = data["resolution"]
    lo, hi = REPORT_Z_RANGE
    if res is None:
        out += ["", f"Worst resolution over {lo:g} - {hi:g} mm: not defined for a hex channel "
                "(the max gap is 1-D, on rect grids; splitlf.coverage gives the 2-D "
                "covering radius)"]
        return out
    lo, hi = res["z_range_mm"]
    out += ["", f"Worst resolution over {lo:g} - {hi:g} mm (largest max gap in the central "
            "field, in delta(z) = mu_1 z / L_1)",
            f"  depths: {res['depths']} ({res['sampling']})"]
    for key, r in res.items():
        if not isinstance(r, dict):
            continue
        label = "union" if key == "union" else key
        out.append(f"  {label:<14} max gap {_gap_text(r['max_gap']):>8} at z = "
                   f"{r['z_mm']:.1f} mm   (fewest distinct samples along x: "
                   f"{r['min_distinct']})")
    return out
