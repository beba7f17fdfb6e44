"""The design explorer as a Panel (Bokeh server) app: one :class:`Explorer` per browser
session. Every number comes from :mod:`splitlf.explorer.model` (the public API); this
module only lays out controls and moves numbers into Bokeh figures.

Threads: the closed-form views (blur, repetitions, depth of field, report; about a
millisecond) are computed in the control's callback; the samples view (2-D coverage, tens
of ms a depth) runs on one worker thread per session, coalescing: while it computes,
further changes only replace the design it will compute next, so a burst of changes costs
one extra computation, never a queue. Results reach the page through the document's next
tick (the only place Bokeh models are changed).
"""

from __future__ import annotations

import html
import io
import threading
from functools import partial
from typing import Any

import numpy as np
import panel as pn
from bokeh.events import Tap
from bokeh.models import ColumnDataSource, DataTable, FactorRange, Range1d, Span, TableColumn
from bokeh.palettes import Category10_10
from bokeh.plotting import figure

from ..design import PRESETS, Design
from ..errors import SplitlfError
from . import model
from .model import CHANNEL_CONTROLS, DESIGN_CONTROLS, Field, FieldError

__all__ = ["Explorer"]

ERROR_STYLE = "color:#b00020;font-size:12px;"
#: The threshold control's key (a field of the views, not of the design).
THRESHOLD = "threshold_px"
DISTINCT_TITLE = "Distinct 2-D samples in the central field"
#: The sample map's depth control's key.
MAP_Z = "map_z"


def _esc(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _lines(z: np.ndarray, rows: tuple[str, ...], values: np.ndarray,
           offset: int = 0) -> dict[str, list]:
    """The columns of a multi_line source: one line per row (non-finite values as NaN)."""
    ys = [np.where(np.isfinite(v), v, np.nan) for v in np.asarray(values, dtype=float)]
    return {"xs": [z] * len(rows), "ys": ys, "label": list(rows),
            "color": [Category10_10[(i + offset) % 10] for i in range(len(rows))]}


class Explorer:
    """One session of the explorer for ``design`` (a :class:`~splitlf.Design`).

    ``self.design`` is the last valid design: the figures always show it. ``layout`` is
    the Panel object served (or displayed)."""

    def __init__(self, design: Design, reference: Design | None = None) -> None:
        self.design = design
        #: A second design drawn on the same axes (grey), e.g. the seed beside an
        #: optimised one: given, or pinned from the page.
        self.reference = reference
        self._ref_samples: dict[tuple[Design, int, float], dict[str, Any]] = {}
        self.generation = 0  # counts valid designs shown
        self._suspend = False
        self._doc = pn.state.curdoc
        self._lock = threading.Lock()
        self._pending: dict[str, tuple] = {}
        self._worker_busy = False
        self._widgets: dict[str, Any] = {}
        self._errors: dict[str, pn.pane.HTML] = {}
        self._n_channels = len(design.channels)
        self._build_figures()
        self._build_controls()
        self._refresh(design)

    # -- layout --------------------------------------------------------------------------
    def _build_controls(self) -> None:
        self.banner = pn.pane.HTML("", sizing_mode="stretch_width")
        options = ["custom", *PRESETS]
        self.preset = pn.widgets.Select(label="preset", options=options, value=self._preset_of(
            self.design), width=150)
        self.preset.param.watch(self._on_preset, "value")
        self.load = pn.widgets.FileInput(accept=".toml", multiple=False, width=220)
        self.load.param.watch(self._on_load, "value")
        self.save = pn.widgets.FileDownload(callback=self._toml_file, filename="design.toml",
                                            label="save TOML", color="primary",
                                            embed=False, width=120)
        self.threshold = self._text_widget(
            Field(THRESHOLD, "real", "threshold [px]", "sharpness threshold on the blur "
                  "radius [px], > 0"), THRESHOLD, "0.5")
        self.n_depths = pn.widgets.IntSlider(label="samples: depths", start=3, end=40,
                                             value=model.SAMPLES_DEPTHS, width=180)
        self.window = pn.widgets.FloatSlider(label="samples: field [lens pitches]", start=1,
                                             end=16, step=1, value=model.SAMPLES_WINDOW,
                                             width=180)
        for w in (self.n_depths, self.window):
            w.param.watch(lambda e: self._request_samples(self.design), "value_throttled")
        self.pin = pn.widgets.Button(label="pin as reference", width=140)
        self.pin.on_click(lambda e: self.set_reference(self.design))
        self.unpin = pn.widgets.Button(label="clear reference", width=130)
        self.unpin.on_click(lambda e: self.set_reference(None))
        self.map_z = pn.widgets.TextInput(label="sample map depth z [mm] (or click a plot)",
                                          value=f"{model.default_map_depth(self.design):.6g}",
                                          placeholder=MAP_Z, width=260)
        self.map_z.param.watch(lambda e: self._request_map(), "value")
        self._errors[MAP_Z] = pn.pane.HTML("", width=260)
        self.design_box = pn.FlexBox(sizing_mode="stretch_width")
        self.channel_tabs = pn.Tabs(sizing_mode="stretch_width")
        self.channel_tabs.param.watch(
            lambda e: self._request("sensor", (self.design, self._sensor_channel())), "active")
        self._populate(self.design)
        top = pn.Row(self.preset, pn.Column(pn.pane.HTML("<b>load TOML</b>"), self.load),
                     pn.Column(pn.Spacer(height=18), self.save), sizing_mode="stretch_width")
        controls = pn.Column(
            "## splitlf design explorer", top, pn.Row(self.pin, self.unpin), self.banner,
            "### Main lens and views",
            self.design_box, "### Channels", self.channel_tabs,
            pn.Row(self.n_depths, self.window),
            pn.Column(self.map_z, self._errors[MAP_Z]),
            pn.pane.Bokeh(self.map_fig), pn.pane.Bokeh(self.sensor_fig),
            width=560)
        views = pn.Column(
            pn.pane.Bokeh(self.blur_fig, sizing_mode="stretch_width"),
            pn.pane.Bokeh(self.dof_fig, sizing_mode="stretch_width"),
            pn.Row(pn.pane.Bokeh(self.reps_fig, sizing_mode="stretch_width"),
                   sizing_mode="stretch_width"),
            pn.Row(pn.pane.Bokeh(self.distinct_fig, sizing_mode="stretch_width"),
                   pn.pane.Bokeh(self.cover_fig, sizing_mode="stretch_width"),
                   sizing_mode="stretch_width"),
            "### Report", pn.pane.Bokeh(self.report, sizing_mode="stretch_width"),
            sizing_mode="stretch_width")
        self.layout = pn.Row(controls, views, sizing_mode="stretch_width")

    def _text_widget(self, field: Field, key: str, value: str) -> pn.Column:
        if field.kind == "choice":
            w = pn.widgets.Select(label=field.label, options=list(field.choices), value=value,
                                  description=field.help, width=120)
        else:
            # The placeholder (the key) names the input for people and for the tests.
            w = pn.widgets.TextInput(label=field.label, value=value, placeholder=key,
                                     description=field.help, width=120)
        w.param.watch(partial(self._on_field, key), "value")
        err = pn.pane.HTML("", width=120, margin=(0, 5))
        self._widgets[key] = w
        self._errors[key] = err
        return pn.Column(w, err, width=130)

    def _populate(self, design: Design) -> None:
        """(Re)build the controls of ``design``'s fields."""
        texts = model.design_texts(design)
        self._widgets = {k: v for k, v in self._widgets.items() if k == THRESHOLD}
        self._errors = {k: v for k, v in self._errors.items() if k in (THRESHOLD, MAP_Z)}
        boxes = [self._text_widget(f, f.name, texts[f.name]) for f in DESIGN_CONTROLS]
        self.design_box.objects = [*boxes, self.threshold]
        tabs = []
        for i in range(1, len(design.channels) + 1):
            items = [self._text_widget(f, f"channels[{i}].{f.name}",
                                       texts[f"channels[{i}].{f.name}"])
                     for f in CHANNEL_CONTROLS]
            tabs.append((f"channel {i}", pn.FlexBox(*items, sizing_mode="stretch_width")))
        self.channel_tabs.objects = [pn.Column(t, name=n) for n, t in tabs]
        self._n_channels = len(design.channels)

    def _build_figures(self) -> None:
        tools = "pan,wheel_zoom,box_zoom,reset,save,hover"
        self.blur_src = ColumnDataSource(_lines(np.zeros(1), (), np.zeros((0, 1))), name="blur")
        self.conv_src = ColumnDataSource(_lines(np.zeros(1), (), np.zeros((0, 1))),
                                         name="conventional")
        self.reps_src = ColumnDataSource(_lines(np.zeros(1), (), np.zeros((0, 1))),
                                         name="repetitions")
        self.dof_src = ColumnDataSource({"row": [], "left": [], "right": [], "color": []},
                                        name="dof")
        self.distinct_src = ColumnDataSource(_lines(np.zeros(1), (), np.zeros((0, 1))),
                                             name="distinct")
        self.cover_src = ColumnDataSource(_lines(np.zeros(1), (), np.zeros((0, 1))),
                                          name="covering_radius")
        f = figure(title="Blur against depth (Fig. 1); dashed: conventional cameras",
                   x_axis_type="log", height=300, sizing_mode="stretch_width", tools=tools,
                   x_axis_label="depth z [mm]", y_axis_label="blur radius [px]",
                   y_range=Range1d(0, 10))
        f.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.blur_src)
        f.multi_line("xs", "ys", color="color", line_dash="dashed", source=self.conv_src)
        self.threshold_span = Span(location=0.5, dimension="width", line_color="gray",
                                   line_dash="dotted")
        f.add_layout(self.threshold_span)
        f.legend.location = "top_right"
        self.blur_fig = f
        d = figure(title="Depth of field: sharp intervals (blur < threshold)",
                   x_axis_type="log", height=170, sizing_mode="stretch_width",
                   x_range=f.x_range, y_range=FactorRange(), tools="xpan,xwheel_zoom,reset",
                   x_axis_label="depth z [mm]")
        d.hbar(y="row", left="left", right="right", height=0.6, color="color",
               source=self.dof_src)
        self.dof_fig = d
        r = figure(title="Repetitions 2H/d (Fig. 5)", x_axis_type="log", height=230,
                   sizing_mode="stretch_width", tools=tools, x_range=f.x_range,
                   x_axis_label="depth z [mm]", y_axis_label="repetitions")
        r.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.reps_src)
        self.reps_fig = r
        s = figure(title=DISTINCT_TITLE, x_axis_type="log",
                   y_axis_type="log", height=250, sizing_mode="stretch_width", tools=tools,
                   x_axis_label="depth z [mm]", y_axis_label="distinct samples")
        s.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.distinct_src)
        s.legend.location = "bottom_right"
        self.distinct_fig = s
        c = figure(title="Covering radius [δ(z)]", x_axis_type="log", height=250,
                   sizing_mode="stretch_width", tools=tools, x_range=s.x_range,
                   x_axis_label="depth z [mm]", y_axis_label="covering radius [δ]")
        c.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.cover_src)
        self.cover_fig = c
        # The report as a table of a data source, and the status (which design each view
        # shows) as a data source: changing either sends data, never re-lays the page out
        # (an HTML pane whose text changes makes Bokeh measure every element again).
        self.report_src = ColumnDataSource({"label": [], "value": []}, name="report")
        self.report = DataTable(source=self.report_src, index_position=None, height=420,
                                sizing_mode="stretch_width", columns=[
                                    TableColumn(field="label", title="quantity", width=320),
                                    TableColumn(field="value", title="value", width=280)])
        self.status_src = ColumnDataSource({"blur": [0], "samples": [0]}, name="status")
        self.report.tags = [self.status_src]  # a model must reference it to reach the page
        # The 2-D sample map at a picked depth and the microlens images on the sensor.
        self.map_src = ColumnDataSource({"x": [], "y": [], "color": [], "label": []},
                                        name="sample_map")
        m = figure(title="2-D samples", width=520, height=420, match_aspect=True,
                   tools="pan,wheel_zoom,box_zoom,reset,save", x_axis_label="X / δ(z)",
                   y_axis_label="Y / δ(z)")
        m.scatter("x", "y", color="color", legend_field="label", size=4, alpha=0.7,
                  source=self.map_src)
        self.map_fig = m
        self.sensor_src = ColumnDataSource({"image": [], "x": [], "y": [], "dw": [], "dh": []},
                                           name="microlens_image")
        g = figure(title="Microlens images", width=520, height=420, match_aspect=True,
                   tools="pan,wheel_zoom,box_zoom,reset,save", x_axis_label="sensor column",
                   y_axis_label="sensor row")
        g.image_rgba(image="image", x="x", y="y", dw="dw", dh="dh", source=self.sensor_src)
        self.sensor_fig = g
        for fig in (f, d, r, s, c):  # a click on a depth axis picks the sample map's depth
            fig.on_event(Tap, self._on_tap)
        # The reference design, grey and dashed on the same axes.
        empty = _lines(np.zeros(1), (), np.zeros((0, 1)))
        self.ref_blur_src = ColumnDataSource(dict(empty), name="reference_blur")
        self.ref_distinct_src = ColumnDataSource(dict(empty), name="reference_distinct")
        self.ref_cover_src = ColumnDataSource(dict(empty), name="reference_covering_radius")
        self._ref_items = []
        for fig, src in ((f, self.ref_blur_src), (s, self.ref_distinct_src),
                         (c, self.ref_cover_src)):
            fig.multi_line("xs", "ys", color="#888888", line_dash="dashed", line_width=1.5,
                           legend_label="reference", source=src)
            self._ref_items.append(fig.legend.items[-1])
            self._ref_items[-1].visible = self.reference is not None

    # -- events --------------------------------------------------------------------------
    @staticmethod
    def _preset_of(design: Design) -> str:
        for name in PRESETS:
            if Design.preset(name) == design:
                return name
        return "custom"

    def _on_preset(self, event: Any) -> None:
        if self._suspend or event.new == "custom":
            return
        self.set_design(Design.preset(event.new))

    def _on_load(self, event: Any) -> None:
        if not event.new:
            return
        try:
            design = model.load_toml_bytes(event.new, self.load.filename or "uploaded.toml")
        except (SplitlfError, ValueError, TypeError, OSError) as e:
            self._show_errors(None, f"load TOML: {e}")
            return
        self.set_design(design)

    def _toml_file(self) -> io.StringIO:
        return io.StringIO(self.design.to_toml())

    def _on_tap(self, event: Any) -> None:
        if event.x is not None and np.isfinite(event.x) and event.x > 0:
            self.map_z.value = f"{event.x:.6g}"

    def set_reference(self, design: Design | None) -> None:
        """Draw ``design`` (None: nothing) beside the current one on the same axes."""
        self.reference = design
        self._refresh(self.design)

    def _on_field(self, key: str, event: Any) -> None:
        if not self._suspend:
            self.apply_controls()

    def set_design(self, design: Design) -> None:
        """Show ``design``: its values in the controls, its figures."""
        self._suspend = True
        try:
            if len(design.channels) != self._n_channels:
                self._populate(design)
            else:
                for key, text in model.design_texts(design).items():
                    self._widgets[key].value = text
            self.preset.value = self._preset_of(design)
            self.map_z.value = f"{model.default_map_depth(design):.6g}"
        finally:
            self._suspend = False
        self._refresh(design)

    def texts(self) -> dict[str, str]:
        """The text of every control."""
        return {k: str(w.value) for k, w in self._widgets.items()}

    def apply_controls(self) -> None:
        """Validate what the controls say with the API; show its figures, or the API's
        message next to the control it names (the figures keep the last valid design)."""
        texts = self.texts()
        try:
            design = model.design_from_texts(texts, self._n_channels)
            threshold = model.parse(Field(THRESHOLD, "real", "", ""), texts[THRESHOLD],
                                    THRESHOLD)
        except FieldError as e:
            self._show_errors(e.key, e.message)
            return
        self._refresh(design, threshold)

    def _show_errors(self, key: str | None, message: str) -> None:
        """The message beside control ``key`` (and in the banner), every other cleared;
        only panes whose text changes are touched (each change is a message to the page)."""
        for k, pane in self._errors.items():
            text = (f'<span class="field-error" data-key="{_esc(k)}" '
                    f'style="{ERROR_STYLE}">{_esc(message)}</span>') if k == key else ""
            if pane.object != text:
                pane.object = text
        text = (f'<div class="explorer-error" style="{ERROR_STYLE}">Invalid: {_esc(message)} '
                "(the figures show the last valid design)</div>") if message else ""
        if self.banner.object != text:
            self.banner.object = text

    # -- views ---------------------------------------------------------------------------
    def _refresh(self, design: Design, threshold: float | None = None) -> None:
        if threshold is None:
            w = self._widgets.get(THRESHOLD)
            try:
                threshold = 0.5 if w is None else model.parse(
                    Field(THRESHOLD, "real", "", ""), str(w.value), THRESHOLD)
            except FieldError as e:
                self._show_errors(e.key, e.message)
                return
        try:
            blur = model.blur_view(design, threshold)
            report = model.report_rows(design, threshold)
            ref = None if self.reference is None else model.blur_view(self.reference,
                                                                      threshold)
        except (SplitlfError, ValueError, TypeError) as e:
            self._show_errors(model.control_key(getattr(e, "name", None)), str(e))
            return
        self.design = design
        self.generation += 1
        gen = self.generation
        self._show_errors(None, "")
        self._push(partial(self._apply_blur, blur, ref, report, gen))
        self._request_samples(design)

    def _push(self, fn: Any) -> None:
        """Run ``fn`` where Bokeh models may change: the session's next tick (or now,
        before the app is attached to a session)."""
        if self._doc is not None and self._doc.session_context is not None:
            self._doc.add_next_tick_callback(fn)
        else:
            fn()

    def _apply_blur(self, blur: dict[str, Any], ref: dict[str, Any] | None,
                    report: list[tuple[str, str]], gen: int) -> None:
        z = blur["z"]
        for item in self._ref_items:
            item.visible = ref is not None
        if ref is None:
            self.ref_blur_src.data = _lines(np.zeros(1), (), np.zeros((0, 1)))
        else:
            self.ref_blur_src.data = _lines(ref["z"], tuple(f"reference {r}" for r in
                                                            ref["rows"]), ref["blur_px"])
            union = ref["dof_rows"][-1]
            blur = dict(blur, dof_rows=(*blur["dof_rows"], "reference"),
                        dof=[*blur["dof"], *(("reference", a, b) for r, a, b in ref["dof"]
                                             if r == union)])
        self.blur_src.data = _lines(z, blur["rows"], blur["blur_px"])
        self.conv_src.data = _lines(z, tuple(f"{c} conventional" for c in blur["channels"]),
                                    blur["conventional_px"])
        self.reps_src.data = _lines(z, blur["channels"], blur["repetitions"])
        bp = np.asarray(blur["blur_px"], dtype=float)
        top = float(np.nanmax(np.where(np.isfinite(bp), bp, np.nan))) if bp.size else 1.0
        self.blur_fig.y_range.start = 0.0
        self.blur_fig.y_range.end = max(1.3 * top, 1.5 * blur["threshold_px"])
        self.threshold_span.location = blur["threshold_px"]
        rows = list(blur["dof_rows"])
        zmax = float(z[-1])
        colors = {r: Category10_10[i % 10] for i, r in enumerate(rows)}
        colors["reference"] = "#888888"
        self.dof_fig.y_range.factors = rows[::-1]
        self.dof_src.data = {
            "row": [r for r, _, _ in blur["dof"]],
            "left": [max(a, float(z[0])) for _, a, _ in blur["dof"]],
            "right": [min(b, zmax) for _, _, b in blur["dof"]],
            "color": [colors[r] for r, _, _ in blur["dof"]],
        }
        self.report_src.data = {"label": [k for k, _ in report], "value": [v for _, v in report]}
        self._status(blur=gen)

    def _status(self, blur: int | None = None, samples: int | None = None) -> None:
        if blur is not None:
            self._shown_blur = blur
        if samples is not None:
            self._shown_samples = samples
        b = getattr(self, "_shown_blur", 0)
        s = getattr(self, "_shown_samples", 0)
        # (Not shown in a title: a title that changes makes Bokeh lay the figure out again.)
        self.status_src.data = {"blur": [b], "samples": [s]}

    def _request_samples(self, design: Design) -> None:
        """Queue the heavy views of ``design``: samples over depth, then the sample map
        at the picked depth and the microlens images."""
        self._request("samples", (self.generation, design, self.reference,
                                  int(self.n_depths.value), float(self.window.value)))
        self._request_map()
        self._request("sensor", (design, self._sensor_channel()))

    def _request_map(self) -> None:
        try:
            z = model.parse(Field(MAP_Z, "real", "", ""), str(self.map_z.value), MAP_Z)
        except FieldError as e:
            self._show_errors(e.key, e.message)
            return
        self._request("map", (self.design, z, float(self.window.value)))

    def _sensor_channel(self) -> int:
        return min(int(self.channel_tabs.active) + 1, len(self.design.channels))

    def _request(self, kind: str, job: tuple) -> None:
        """Give the worker thread a job of ``kind``, replacing one of that kind not yet
        started (coalescing), and start the worker if it is idle."""
        with self._lock:
            self._pending[kind] = job
            if self._worker_busy:
                return
            self._worker_busy = True
        threading.Thread(target=self._worker, daemon=True).start()

    def _worker(self) -> None:
        while True:
            with self._lock:
                kind = next((k for k in ("samples", "map", "sensor") if k in self._pending),
                            None)
                if kind is None:
                    self._worker_busy = False
                    return
                job = self._pending.pop(kind)
            try:
                apply = getattr(self, f"_compute_{kind}")(*job)
            except (SplitlfError, ValueError, MemoryError) as e:
                key = MAP_Z if kind == "map" and getattr(e, "name", "") == "z" else None
                self._push(partial(self._show_errors, key, f"{kind} view: {e}"))
                continue
            self._push(apply)

    def _compute_samples(self, gen: int, design: Design, reference: Design | None, n: int,
                         window: float) -> Any:
        data = model.samples_view(design, n, window)
        ref = None
        if reference is not None:
            key = (reference, n, window)
            if key not in self._ref_samples:  # computed once per pinned design
                self._ref_samples = {key: model.samples_view(reference, n, window)}
            ref = self._ref_samples[key]
        return partial(self._apply_samples, data, ref, gen)

    def _compute_map(self, design: Design, z: float, window: float) -> Any:
        return partial(self._apply_map, model.sample_map(design, z, window))

    def _compute_sensor(self, design: Design, channel: int) -> Any:
        return partial(self._apply_sensor, channel, model.microlens_image(design, channel))

    def _apply_map(self, m: dict[str, Any]) -> None:
        xs, ys, color, label = [], [], [], []
        for k, (x, y) in enumerate(zip(m["x"], m["y"], strict=True)):
            xs.append(x)
            ys.append(y)
            color += [Category10_10[k % 10]] * len(x)
            label += [f"{m['rows'][k]}: {m['distinct'][k]} distinct, "
                      f"ρ = {m['covering_radius'][k]:.3g} δ"] * len(x)
        self.map_src.data = {"x": np.concatenate(xs) if xs else [],
                             "y": np.concatenate(ys) if ys else [],
                             "color": color, "label": label}
        union = (f"; {m['rows'][-1]}: {m['distinct'][-1]} distinct, "
                 f"ρ = {m['covering_radius'][-1]:.3g} δ" if len(m["rows"]) > 2 else "")
        self.map_fig.title.text = (f"2-D samples at z = {m['z']:.5g} mm "
                                   f"(δ = {m['delta_mm'] * 1e3:.3g} µm){union}")

    def _apply_sensor(self, channel: int, im: dict[str, Any]) -> None:
        rgba = im["rgba"]
        ny, nx = rgba.shape
        self.sensor_src.data = {"image": [rgba], "x": [im["x0"] - 0.5], "y": [im["y0"] - 0.5],
                                "dw": [nx], "dh": [ny]}
        self.sensor_fig.title.text = (f"Microlens images, channel {channel}: {im['lit']} of "
                                      f"{im['pixels']} pixels shown are lit")

    def _apply_samples(self, data: dict[str, Any], ref: dict[str, Any] | None,
                       gen: int) -> None:
        if gen < getattr(self, "_shown_samples", 0):
            return
        if ref is None:
            self.ref_distinct_src.data = _lines(np.zeros(1), (), np.zeros((0, 1)))
            self.ref_cover_src.data = _lines(np.zeros(1), (), np.zeros((0, 1)))
        else:
            labels = tuple(f"reference {r}" for r in ref["rows"])
            self.ref_distinct_src.data = _lines(ref["z"], labels, ref["distinct"])
            self.ref_cover_src.data = _lines(ref["z"], labels, ref["covering_radius"])
        self.distinct_src.data = _lines(data["z"], data["rows"], data["distinct"])
        self.cover_src.data = _lines(data["z"], data["rows"], data["covering_radius"])
        self._status(samples=gen)
