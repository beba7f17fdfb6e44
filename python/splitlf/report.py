"""The design report: every number computed by the core, formatted for people or JSON."""

from __future__ import annotations

from typing import Any

from . import _validate
from .design import Design
from .optics import depth_of_field
from .samples import coincidence_planes, worst_resolution

__all__ = ["REPORT_MAX_N", "REPORT_Z_RANGE", "format_report", "report_data"]

#: Coincidence planes listed in the report: N <= 3 (T <= Q).
REPORT_MAX_N = 3
#: Depth range of the worst-resolution figure [mm].
REPORT_Z_RANGE = (150.0, 10_000.0)


def report_data(design: Design, threshold_px: float = 0.5, *,
                n_threads: int | None = None, samples: bool = True) -> dict[str, Any]:
    """A design's report as a JSON-ready dict (a :class:`~splitlf.Camera` is a design):
    ``design`` (the general design's fields, :meth:`Design.as_dict` of ``design.design``),
    ``parameters`` (the fields as the design was given: a Camera's own), ``derived``
    (f-number, and per channel its array plane, its out-of-focus plane, its microlens
    image radius and each lens type's focal length and the depth it is focused on) and
    ``depth_of_field`` (:meth:`DepthOfField.as_dict`: per lens type, per channel, the
    union, the conventional cameras; [near, far] in mm, far None when infinite) at ``threshold_px``
    (finite > 0, pixels).

    With ``samples`` (the default; the explorer's quick form leaves them out), also the
    sample sections: ``coincidence_planes`` {"channel i": the rows of
    :func:`~splitlf.coincidence_planes` with N <= :data:`REPORT_MAX_N`, or None where
    docs/model.md §6 does not hold (a hex grid, a sensor layout, a circular aperture)} and
    ``resolution`` (:func:`~splitlf.samples.worst_resolution` over :data:`REPORT_Z_RANGE`,
    per channel and union; None when a channel has a hex grid: the 1-D max gap needs rect
    grids, :func:`splitlf.coverage` is the 2-D measure), on ``n_threads`` threads of the
    core (None: all cores). Raises the errors of :func:`~splitlf.depth_of_field` and of
    those functions."""
    design = _validate.design(design)
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
        "design": design.design.as_dict(),
        "parameters": design.as_dict(),
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


def _interval_text(iv: list) -> str:
    if not iv:
        return "none"
    parts = []
    for near, far in iv:
        far_s = "inf" if far is None else f"{far:.1f}"
        parts.append(f"{near:.1f} - {far_s}")
    return ", ".join(parts)


def _gap_text(g: float | None) -> str:
    return "inf (field not covered)" if g is None else f"{g:.2f}"


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


def _channel_line(ch: dict[str, Any], der: dict[str, Any]) -> str:
    """One channel in one line (the short report)."""
    lenses = f"{ch['Kx']} x {ch['Ky']} {ch['grid']}"
    types = len(der["lens_types"])
    kinds = f", {types} lens types" if types > 1 else ""
    z = der["out_of_focus_depth_mm"]
    return (f"  {der['name']:<10} L {ch['L']:>9.4f} mm  z {z:>8.1f} mm"
            f"  R {der['microlens_image_radius_px']:>6.2f} px  {lenses}{kinds}, "
            f"share {ch['share']:.3g}")


def format_report(data: dict[str, Any], title: str, full: bool = False) -> str:
    """A design's report as text for people: ``data`` from :func:`report_data`, under
    ``title``. Short by default — the main lens, one line per channel, where the design
    is sharp (depth of field) and how densely it samples (worst resolution) — and with
    ``full`` every channel's fields and lens types and the coincidence planes. Returns the
    text, ending in a newline."""
    des, der, dof = data["design"], data["derived"], data["depth_of_field"]
    out = [title, "", "Main lens (lengths in mm)",
           f"  {'F':<6} = {des['F']:<12.6g} main lens focal length",
           f"  {'D':<6} = {des['D']:<12.6g} aperture width ({des['aperture']})",
           f"  f-number {der['f_number']:.3g}"]
    if not full:
        out += ["", "Channels (L: array plane, z: out-of-focus plane, R: microlens image "
                "radius)"]
    for ch, cd in zip(des["channels"], der["channels"], strict=True):
        out += ["", *_channel_text(ch, cd)] if full else [_channel_line(ch, cd)]
    out += ["", f"Depth of field (sharp: blur < {dof['threshold_px']:g} px), depths in mm"]
    for name, iv in dof["light_field"].items():
        label = "union (any channel)" if name == "union" else f"{name} (light field)"
        out.append(f"  {label:<34} {_interval_text(iv)}")
    for name, iv in dof["conventional"].items():
        out.append(f"  {'conventional, sensor on ' + name:<34} {_interval_text(iv)}")
    if "coincidence_planes" in data:
        out += _samples_text(data, full)
    return "\n".join(out) + "\n"


def _samples_text(data: dict[str, Any], full: bool) -> list[str]:
    """The sample sections of a report (:func:`report_data` with ``samples``): with
    ``full`` the coincidence planes per channel; the worst resolution per channel and
    union."""
    out: list[str] = []
    if full:
        out += ["", f"Coincidence planes (N <= {REPORT_MAX_N}, T <= Q), sorted by depth; "
                "Eq. 8/9 with Q_lit vs brute-force count"]
    for name, rows in data["coincidence_planes"].items() if full else ():
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
