"""The design report: every number computed by the core, formatted for people or JSON.

One builder (:func:`report_data`) for every design (a :class:`~splitlf.Camera` is one)
and one formatter (:func:`format_report`): a short answer by default (where is the
design sharp, how densely does it sample) and every section with ``full=True``.
"""

from __future__ import annotations

from typing import Any

from .. import _validate
from ..model.design import Design
from ..model.optics import depth_of_field
from ..sampling.samples import coincidence_planes, worst_resolution

__all__ = ["format_report", "report_data"]

#: Coincidence planes listed in the report: N <= 3 (T <= Q).
REPORT_MAX_N = 3
#: Depth range of the worst-resolution figure [mm].
REPORT_Z_RANGE = (150.0, 10_000.0)


def _channel_data(design: Design, i: int, res: dict[str, Any]) -> dict[str, Any]:
    ch = design.channels[i - 1]
    radius = design.image_radius(i)
    return {
        "name": f"channel {i}",
        "array_plane_mm": ch.L,
        "out_of_focus_depth_mm": design.out_of_focus_depth(i),
        "microlens_image_radius_mm": radius,
        "microlens_image_radius_px": radius / ch.mu,
        "ng_setting": res["ng"],
        "lens_types": [{"focal_length_mm": f, "focus_depth_mm": z}
                       for f, z in zip(res["f"], design.focus_depths(i), strict=True)],
        "pixels": [res["Mx"], res["My"]] if ch.layout == "sensor"
        else [res["Q"] * ch.Kx, res["Q"] * ch.Ky],
    }


def _samples_data(design: Design, n_threads: int | None) -> dict[str, Any]:
    """Coincidence planes per channel (None where docs/model.md §6 does not hold) and the
    worst resolution (None with a hex channel: the max gap is 1-D, on rect grids)."""
    planes = {
        f"channel {i}": coincidence_planes(design, channel=i, max_n=REPORT_MAX_N,
                                           n_threads=n_threads).rows()
        if ch.grid == "rect" and ch.layout == "ideal" and design.aperture == "square"
        else None
        for i, ch in enumerate(design.channels, 1)
    }
    rect = all(ch.grid == "rect" for ch in design.channels)
    resolution = worst_resolution(design, REPORT_Z_RANGE, max_n=REPORT_MAX_N,
                                  n_threads=n_threads) if rect else None
    return {"coincidence_planes": planes, "resolution": resolution}


def report_data(design: Design, threshold_px: float = 0.5, *, n_threads: int | None = None,
                samples: bool = True) -> dict[str, Any]:
    """A design's report as a JSON-ready dict (the seed camera's too: a Camera is a Design).

    - ``design``: its fields in the general form (:meth:`Design.as_dict` of
      ``design.design``)
    - ``derived``: the f-number and, per channel, its array plane, out-of-focus plane,
      microlens image radius, pixels and each lens type's focal length and focus depth
    - ``depth_of_field``: :meth:`DepthOfField.as_dict` at ``threshold_px`` (finite > 0,
      pixels): per channel (and lens type), the union, the conventional cameras
    - with ``samples`` (default): ``coincidence_planes`` {"channel i": rows with N <=
      :data:`REPORT_MAX_N`, or None where docs/model.md §6 does not hold} and
      ``resolution`` (:func:`~splitlf.samples.worst_resolution` over
      :data:`REPORT_Z_RANGE`, None with a hex channel), on ``n_threads`` threads of the
      core (None: all cores)

    Raises ``TypeError`` for a non-Design and the errors of the functions it calls."""
    subject = _validate.design(design)
    n_threads = _validate.n_threads(n_threads)
    general = subject.design
    out: dict[str, Any] = {
        "design": general.as_dict(),
        "derived": {"f_number": general.f_number,
                    "channels": [_channel_data(general, i, res)
                                 for i, res in enumerate(general.resolved(), 1)]},
        "depth_of_field": depth_of_field(general, threshold_px).as_dict(),
    }
    if samples:
        out.update(_samples_data(general, n_threads))
    return out


# -- text --------------------------------------------------------------------------------

def _row_word(n_channels: int, row: str) -> str:
    """A row name in the split sensor's words for a two-channel design (half 1, half 2,
    split sensor), else as given (channel c, union)."""
    if n_channels != 2:
        return row
    if row == "union":
        return "split sensor"
    return row.replace("channel", "half", 1)


def _interval_text(iv: list[Any]) -> str:
    if not iv:
        return "none"
    return ", ".join(f"{near:.1f} - {'inf' if far is None else f'{far:.1f}'}"
                     for near, far in iv)


def _gap_text(g: float | None) -> str:
    return "inf (field not covered)" if g is None else f"{g:.2f}"


def _summary_text(data: dict[str, Any]) -> list[str]:
    """The design in a few lines: main lens, then one line per channel."""
    des, der = data["design"], data["derived"]
    n = len(des["channels"])
    out = [f"Design: F = {des['F']:.6g} mm, D = {des['D']:.6g} mm ({des['aperture']} "
           f"aperture), f-number {der['f_number']:.3g}, {n} channel{'s' * (n > 1)}"]
    for ch, cd in zip(des["channels"], der["channels"], strict=True):
        name = _row_word(n, cd["name"])
        px = cd["pixels"]
        out.append(f"  {name}: array plane L = {ch['L']:.4f} mm, {ch['grid']} grid of "
                   f"{ch['Kx']} x {ch['Ky']} lenses, {px[0]} x {px[1]} px, out-of-focus "
                   f"plane {cd['out_of_focus_depth_mm']:.2f} mm")
    return out


def _dof_text(data: dict[str, Any]) -> list[str]:
    dof = data["depth_of_field"]
    n = len(data["design"]["channels"])
    out = [f"Depth of field (sharp: blur < {dof['threshold_px']:g} px), depths in mm"]
    for name, iv in dof["light_field"].items():
        label = _row_word(n, name)
        label += " (any channel)" if name == "union" and n != 2 else \
            " (either half)" if name == "union" else " (light field)"
        out.append(f"  {label:<34} {_interval_text(iv)}")
    for name, iv in dof["conventional"].items():
        label = f"conventional, sensor on {_row_word(n, name)}"
        out.append(f"  {label:<34} {_interval_text(iv)}")
    return out


def _resolution_text(data: dict[str, Any]) -> list[str]:
    res, n = data.get("resolution"), len(data["design"]["channels"])
    lo, hi = REPORT_Z_RANGE
    if res is None:
        return [f"Worst resolution over {lo:g} - {hi:g} mm: not defined for a hex channel "
                "(the max gap is 1-D, on rect grids; splitlf.coverage gives the 2-D "
                "covering radius)"]
    lo, hi = res["z_range_mm"]
    out = [f"Worst resolution over {lo:g} - {hi:g} mm (largest max gap in the central "
           "field, in delta(z) = mu_1 z / L_1)"]
    for key, r in res.items():
        if isinstance(r, dict):
            out.append(f"  {_row_word(n, key):<14} max gap {_gap_text(r['max_gap']):>8} at "
                       f"z = {r['z_mm']:.1f} mm   (fewest distinct samples along x: "
                       f"{r['min_distinct']})")
    return out


def _channel_text(ch: dict[str, Any], der: dict[str, Any], name: str) -> list[str]:
    """One channel's block of the full report: its fields and derived values."""
    layout = (f"ideal layout, Q = {ch['Q']}" if ch["layout"] == "ideal"
              else f"sensor layout, {der['pixels'][0]} x {der['pixels'][1]} pixels")
    out = [
        f"{name.capitalize()}: share {ch['share']:.6g}, {ch['grid']} grid of "
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


def _planes_text(data: dict[str, Any]) -> list[str]:
    """The coincidence planes of each channel (the full report)."""
    n = len(data["design"]["channels"])
    out = [f"Coincidence planes (N <= {REPORT_MAX_N}, T <= Q), sorted by depth; "
           "Eq. 8/9 with Q_lit vs brute-force count"]
    for name, rows in data["coincidence_planes"].items():
        if rows is None:
            out.append(f"  {_row_word(n, name)}: none defined (docs/model.md §6 needs a rect "
                       "grid, the ideal layout and a square aperture)")
            continue
        agree = sum(r["counted"] == r["new_samples"] for r in rows)
        out.append(f"  {_row_word(n, name)}: {len(rows)} planes, counted == Eq. 8/9 on "
                   f"{agree}")
        out.append(f"    {'N':>2} {'T':>3} {'side':<5} {'z [mm]':>10} {'rep':>7} "
                   f"{'Eq. 8/9':>12} {'counted':>12}")
        out += [f"    {r['N']:>2} {r['T']:>3} {r['side']:<5} {r['z']:>10.2f} "
                f"{r['repetitions']:>7.3f} {r['new_samples']:>12} {r['counted']:>12}"
                for r in rows]
    return out


def format_report(data: dict[str, Any], title: str, *, full: bool = False) -> str:
    """The report as text for people: ``data`` from :func:`report_data`, under ``title``.
    By default the short answer (the design in a few lines, the depth of field of each
    channel and the union, the worst resolution); ``full`` adds every field of every
    channel, its lens types and the coincidence planes. Returns the text, ending in a
    newline."""
    des, der = data["design"], data["derived"]
    n = len(des["channels"])
    if full:
        out = [title, "", "Main lens (lengths in mm)",
               f"  {'F':<6} = {des['F']:<12.6g} main lens focal length",
               f"  {'D':<6} = {des['D']:<12.6g} aperture width ({des['aperture']})",
               f"  f-number {der['f_number']:.3g}"]
        for ch, cd in zip(des["channels"], der["channels"], strict=True):
            out += ["", *_channel_text(ch, cd, _row_word(n, cd["name"]))]
    else:
        out = [title, "", *_summary_text(data)]
    out += ["", *_dof_text(data)]
    if full and "coincidence_planes" in data:
        out += ["", *_planes_text(data)]
    if "resolution" in data:
        out += ["", *_resolution_text(data)]
    if not full:
        out += ["", "(--full: every field, the lens types and the coincidence planes)"]
    return "\n".join(out) + "\n"
