"""The design explorer as a Bokeh server app: one :class:`Explorer` per browser session.
Every number comes from :mod:`splitlf.explorer.model` (the public API); this module only
lays out controls and moves numbers into Bokeh figures.

Plain Bokeh models (no Panel). Per change only data sources (and, when they change,
ranges and titles) are sent; figures are never replaced. In the page,
:data:`SKIP_SAME_CSS_JS` keeps BokehJS from rewriting unchanged styles at every paint
(each rewrite forced a recalculation of the page's styles; docs/explore.md).

Threads: a change is answered in three ticks of the server's event loop, each patch sent
before the next tick starts: the closed-form views (blur, repetitions, depth of field,
report; a few ms), then the 1-D samples (:func:`splitlf.new_samples` at a couple of
hundred depths, 6-18 ms; the page draws the first patch meanwhile), then the heavy views
are queued: the 2-D coverage (tens of ms a depth), the sample map, the microlens images
and the ray space run on one worker thread per session, coalescing: while it computes,
further changes only replace what it computes next, so a burst of changes costs one
extra computation, never a queue. Results reach the page through the document's next
tick (the only place Bokeh models are changed).
"""

from __future__ import annotations

import base64
import html
import threading
from functools import partial
from typing import Any

import numpy as np
from bokeh.core.property.descriptors import UnsetValueError
from bokeh.document import Document
from bokeh.events import Tap
from bokeh.layouts import column, row
from bokeh.models import ColumnDataSource, CustomJS, FactorRange, Range1d, TabPanel, Tabs

# the defining subpackages: mypy cannot follow bokeh.models' computed __all__ to these
from bokeh.models.annotations import LegendItem, Span, Title
from bokeh.models.widgets import (
    Button,
    DataTable,
    Div,
    FileInput,
    Select,
    Slider,
    TableColumn,
    TextInput,
)
from bokeh.palettes import Category10_10
from bokeh.plotting import figure

from .. import _validate
from ..errors import InvalidParameter, SplitlfError
from ..model.design import PRESETS, Design
from . import model
from .model import CHANNEL_CONTROLS, DESIGN_CONTROLS, Field, FieldError

__all__ = ["Explorer"]

ERROR_STYLE = "color:#b00020;font-size:12px;"
REFERENCE_COLOR = "#888888"
#: The threshold control's key (a field of the views, not of the design).
THRESHOLD = "threshold_px"
DISTINCT_TITLE = "Distinct samples: along x (lines), 2-D in the central field (dots)"
GAP_TITLE = "Max gap along x (lines) and 2-D covering radius (dots) [δ(z)]"
#: The sample map's depth control's key.
MAP_Z = "map_z"
#: The image view's photon count control's key.
IMAGE_PHOTONS = "image_photons"
IMAGE_IDLE = ("Predicted image quality of the design shown: press the button (seconds to "
              "minutes a depth; docs/merits.md)")
#: Controls per row in the control panel.
PER_ROW = 4
CONTROL_WIDTH = 125

#: Saves the TOML text the server puts in the "toml" source (on "save TOML") as a file.
SAVE_JS = """
const text = source.data.text[0];
if (!text) return;
const url = URL.createObjectURL(new Blob([text], {type: "application/toml"}));
const a = document.createElement("a");
a.href = url; a.download = "design.toml";
document.body.appendChild(a); a.click(); a.remove();
setTimeout(() => URL.revokeObjectURL(url), 1000);
"""


#: Run once in the page: BokehJS (3.9) rewrites the <style> of every renderer of a figure
#: at every paint (its position), even when the text is the same, and then reads the
#: renderer's visual properties through getComputedStyle, so each renderer of each
#: repainted figure forces the browser to recalculate the page's styles (about 13 a
#: figure). Skipping the rewrite of an unchanged text keeps the styles clean. Nothing
#: else changes (the same text is in place); without the module it does nothing.
SKIP_SAME_CSS_JS = """
const dom = Bokeh.require("core/dom");
const proto = dom && dom.InlineStyleSheet && dom.InlineStyleSheet.prototype;
if (proto && proto._update && !proto._splitlf_skips_same) {
  const update = proto._update;
  proto._update = function (css) {
    if (this.el.textContent !== css)
      update.call(this, css);
  };
  proto._splitlf_skips_same = true;
}
"""


def _esc(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _lines(z: np.ndarray, rows: tuple[str, ...], values: np.ndarray,
           grey: bool = False) -> dict[str, list]:
    """The columns of a multi_line source: one line per row (non-finite values as NaN)."""
    ys = [np.where(np.isfinite(v), v, np.nan) for v in np.asarray(values, dtype=float)]
    return {"xs": [z] * len(rows), "ys": ys, "label": list(rows),
            "color": [REFERENCE_COLOR if grey else Category10_10[i % 10]
                      for i in range(len(rows))]}


def model_color(lens_type: int) -> str:
    """The colour of lens type ``lens_type`` (from 0), as in the microlens images."""
    r, g, b = model.TYPE_RGBA[int(lens_type) % len(model.TYPE_RGBA)]
    return f"#{r:02x}{g:02x}{b:02x}"


def _points(z: np.ndarray, rows: tuple[str, ...], values: np.ndarray,
            grey: bool = False) -> dict[str, Any]:
    """The columns of a scatter source: every (depth, value) of every row, row-major
    (``row`` its index; non-finite values as NaN)."""
    n = len(z)
    v = np.asarray(values, dtype=float).reshape(len(rows), n)
    return {"x": np.tile(np.asarray(z, dtype=float), len(rows)),
            "y": np.where(np.isfinite(v), v, np.nan).ravel(),
            "row": np.repeat(np.arange(len(rows)), n),
            "color": [REFERENCE_COLOR if grey else Category10_10[i % 10]
                      for i in range(len(rows)) for _ in range(n)]}


def _nice_ceiling(x: float) -> float:
    """The least of 1, 2, 2.5, 5, 10 times a power of ten that is >= x (x > 0): the blur
    axis changes its end, and so its ticks and layout, only when the curves outgrow it."""
    p = 10.0 ** np.floor(np.log10(x))
    return float(next(m * p for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * p >= x * (1 - 1e-12)))


def _title(fig: figure) -> Title:
    """A figure's title model (Bokeh makes one of the title string it is given)."""
    title = fig.title
    if not isinstance(title, Title):
        raise TypeError(f"the figure's title is {title!r}, not a bokeh Title")
    return title


def _last_legend_item(fig: figure) -> LegendItem:
    """The item the last ``legend_label=`` glyph added to ``fig``'s legend."""
    item = fig.legend.items[-1]
    if not isinstance(item, LegendItem):
        raise TypeError(f"the legend's last item is {item!r}, not a bokeh LegendItem")
    return item


def _grid(items: list[Any], per_row: int = PER_ROW) -> Any:
    return column(*[row(*items[i:i + per_row]) for i in range(0, len(items), per_row)])


class Explorer:
    """One session of the explorer for ``design`` (a :class:`~splitlf.Design`).

    ``self.design`` is the last valid design: the figures always show it. ``layout`` is
    the Bokeh layout served; ``doc`` the session's document (None: models are changed at
    once, e.g. in tests)."""

    def __init__(self, design: Design, reference: Design | None = None,
                 doc: Document | None = None) -> None:
        self.design = design
        #: A second design drawn on the same axes (grey), e.g. the seed beside an
        #: optimised one: given, or pinned from the page.
        self.reference = reference
        self._ref_samples: dict[tuple[Design, int, float], dict[str, Any]] = {}
        self._ref_gap: tuple[Design, dict[str, Any]] | None = None
        self.generation = 0  # counts valid designs shown
        self._suspend = False
        self._doc = doc
        self._lock = threading.Lock()
        self._pending: dict[str, tuple] = {}
        self._worker_busy = False
        self._widgets: dict[str, Any] = {}
        self._errors: dict[str, Div] = {}
        self._shown = {"blur": 0, "gap": 0, "samples": 0}
        self._n_channels = len(design.channels)
        self._build_figures()
        self._build_controls()
        self._refresh(design)

    # -- layout --------------------------------------------------------------------------
    def _build_controls(self) -> None:
        self.banner = Div(text="", visible=False, width=540)
        presets: list[str | tuple[Any, str]] = ["custom", *PRESETS]
        self.preset = Select(title="preset", options=presets,
                             value=self._preset_of(self.design), width=150)
        self.preset.on_change("value", self._on_preset)
        self.load = FileInput(title="load TOML", accept=".toml", multiple=False, width=230)
        self.load.on_change("value", self._on_load)
        self.toml_src = ColumnDataSource({"text": [""], "n": [0]}, name="toml")
        self.toml_src.js_on_change("data", CustomJS(args={"source": self.toml_src},
                                                    code=SAVE_JS))
        self.save = Button(label="save TOML", button_type="primary", width=110,
                           margin=(24, 5, 5, 5))
        self.save.on_click(lambda: self._save_toml())
        self.save.tags = [self.toml_src]  # a model must reference the source to send it
        self.threshold = self._text_widget(
            Field(THRESHOLD, "real", "threshold [px]", "sharpness threshold on the blur "
                  "radius [px], > 0"), THRESHOLD, "0.5")
        self.n_depths = Slider(title="samples: 2-D depths", start=3, end=40, step=1,
                               value=model.SAMPLES_DEPTHS, width=250)
        self.window = Slider(title="samples: field [lens pitches]", start=1, end=16, step=1,
                             value=model.SAMPLES_WINDOW, width=250)
        for w in (self.n_depths, self.window):
            w.on_change("value_throttled", lambda attr, old, new: self._request_samples(
                self.design))
        self.pin = Button(label="pin as reference", width=140)
        self.pin.on_click(lambda: self.set_reference(self.design))
        self.unpin = Button(label="clear reference", width=130)
        self.unpin.on_click(lambda: self.set_reference(None))
        self.map_z = TextInput(title="sample map depth z [mm] (or click a plot)",
                               value=f"{model.default_map_depth(self.design):.6g}",
                               placeholder=MAP_Z, width=260)
        self.map_z.on_change("value", lambda attr, old, new: self._request_map())
        self._errors[MAP_Z] = Div(text="", width=260, visible=False)
        self.design_box = row()
        self.channel_tabs = Tabs(tabs=[], width=540)
        self.channel_tabs.on_change("active", lambda attr, old, new: self._request_channel(
            self.design))
        self._populate(self.design)
        heading = "<h2 style='margin:4px 0'>splitlf design explorer</h2>"
        controls = column(
            Div(text=heading), row(self.preset, self.load, self.save),
            row(self.pin, self.unpin), self.banner,
            Div(text="<h3 style='margin:4px 0'>Main lens and views</h3>"), self.design_box,
            Div(text="<h3 style='margin:4px 0'>Channels</h3>"), self.channel_tabs,
            row(self.n_depths, self.window), self.map_z, self._errors[MAP_Z],
            self.map_fig, self.sensor_fig, self.rays_fig, width=560)
        views = column(self.blur_fig, self.dof_fig, self.reps_fig,
                       row(self.distinct_fig, self.cover_fig, sizing_mode="stretch_width"),
                       Div(text="<h3 style='margin:4px 0'>Image quality (on request)</h3>"),
                       row(self.image_photons, self.image_button),
                       self._errors[IMAGE_PHOTONS], self.image_status,
                       row(self.psnr_fig, self.mtf_fig, sizing_mode="stretch_width"),
                       Div(text="<h3 style='margin:4px 0'>Report</h3>"), self.report,
                       sizing_mode="stretch_width")
        self.layout = row(controls, views, sizing_mode="stretch_width")

    def _text_widget(self, field: Field, key: str, value: str) -> Any:
        w: Select | TextInput
        if field.kind == "choice":
            choices: list[str | tuple[Any, str]] = list(field.choices)
            w = Select(title=field.label, options=choices, value=value,
                       description=field.help, width=CONTROL_WIDTH - 5)
        else:
            # The placeholder (the key) names the input for people and for the tests.
            w = TextInput(title=field.label, value=value, placeholder=key,
                          description=field.help, width=CONTROL_WIDTH - 5)
        w.on_change("value", partial(self._on_field, key))
        # Hidden until it has a message (a hidden element costs the page nothing).
        err = Div(text="", width=CONTROL_WIDTH - 5, visible=False, margin=(0, 5, 0, 5))
        self._widgets[key] = w
        self._errors[key] = err
        return column(w, err, width=CONTROL_WIDTH)

    def _populate(self, design: Design) -> None:
        """(Re)build the controls of ``design``'s fields."""
        texts = model.design_texts(design)
        self._widgets = {k: v for k, v in self._widgets.items() if k == THRESHOLD}
        self._errors = {k: v for k, v in self._errors.items()
                        if k in (THRESHOLD, MAP_Z, IMAGE_PHOTONS)}
        boxes = [self._text_widget(f, f.name, texts[f.name]) for f in DESIGN_CONTROLS]
        self.design_box.children = [*boxes, self.threshold]
        tabs = []
        for i in range(1, len(design.channels) + 1):
            items = [self._text_widget(f, f"channels[{i}].{f.name}",
                                       texts[f"channels[{i}].{f.name}"])
                     for f in CHANNEL_CONTROLS]
            tabs.append(TabPanel(title=f"channel {i}", child=_grid(items)))
        self.channel_tabs.active = 0
        self.channel_tabs.tabs = tabs
        self._n_channels = len(design.channels)

    def _build_figures(self) -> None:
        """Every figure and data source of the page (the views fill the sources)."""
        tools = "pan,wheel_zoom,box_zoom,reset,save"
        empty = _lines(np.zeros(1), (), np.zeros((0, 1)))
        nothing = _points(np.zeros(0), (), np.zeros((0, 0)))
        self._build_depth_figures(tools, empty, nothing)
        self._build_image_figures(tools, empty)
        self._build_report()
        self._build_picked_figures()
        for fig in (self.blur_fig, self.dof_fig, self.reps_fig, self.distinct_fig,
                    self.cover_fig):  # a click on a depth axis picks the sample map's depth
            fig.on_event(Tap, self._on_tap)
        self._build_reference(empty, nothing)

    def _build_depth_figures(self, tools: str, empty: dict[str, Any],
                             nothing: dict[str, Any]) -> None:
        """The figures against depth: blur, depth of field, repetitions, the samples."""
        self.blur_src = ColumnDataSource(dict(empty), name="blur")
        self.conv_src = ColumnDataSource(dict(empty), name="conventional")
        self.reps_src = ColumnDataSource(dict(empty), name="repetitions")
        self.dof_src = ColumnDataSource({"row": [], "left": [], "right": [], "color": []},
                                        name="dof")
        # The 1-D samples (new_samples, hundreds of depths: lines) and the 2-D coverage
        # (a few depths: dots) on the same two figures.
        self.gap_distinct_src = ColumnDataSource(dict(empty), name="distinct_1d")
        self.gap_src = ColumnDataSource(dict(empty), name="max_gap")
        self.distinct_src = ColumnDataSource(dict(nothing), name="distinct")
        self.cover_src = ColumnDataSource(dict(nothing), name="covering_radius")
        # Fixed left borders: the figures keep their layout when their tick labels change.
        self.blur_y_range = Range1d(start=0, end=10)
        f = figure(title="Blur against depth (Fig. 1); dashed: conventional cameras",
                   x_axis_type="log", height=300, sizing_mode="stretch_width", tools=tools,
                   x_axis_label="depth z [mm]", y_axis_label="blur radius [px]",
                   y_range=self.blur_y_range, min_border_left=70)
        f.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.blur_src)
        f.multi_line("xs", "ys", color="color", line_dash="dashed", source=self.conv_src)
        self.threshold_span = Span(location=0.5, dimension="width", line_color="gray",
                                   line_dash="dotted")
        f.add_layout(self.threshold_span)
        f.legend.location = "top_right"
        self.blur_fig = f
        self.dof_y_range = FactorRange()
        d = figure(title="Depth of field: sharp intervals (blur < threshold)",
                   x_axis_type="log", height=170, sizing_mode="stretch_width",
                   x_range=f.x_range, y_range=self.dof_y_range, tools="xpan,xwheel_zoom,reset",
                   x_axis_label="depth z [mm]", min_border_left=70)
        d.hbar(y="row", left="left", right="right", height=0.6, color="color",
               source=self.dof_src)
        self.dof_fig = d
        r = figure(title="Repetitions 2H/d (Fig. 5)", x_axis_type="log", height=230,
                   sizing_mode="stretch_width", tools=tools, x_range=f.x_range,
                   x_axis_label="depth z [mm]", y_axis_label="repetitions",
                   min_border_left=70)
        r.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.reps_src)
        self.reps_fig = r
        s = figure(title=DISTINCT_TITLE, x_axis_type="log", y_axis_type="log", height=270,
                   sizing_mode="stretch_width", tools=tools, x_axis_label="depth z [mm]",
                   y_axis_label="distinct samples", min_border_left=70)
        s.multi_line("xs", "ys", color="color", legend_field="label", line_width=1.5,
                     source=self.gap_distinct_src)
        s.scatter("x", "y", color="color", size=6, source=self.distinct_src)
        _title(s).text_font_size = "11px"
        self.distinct_fig = s
        c = figure(title=GAP_TITLE, x_axis_type="log", height=270,
                   sizing_mode="stretch_width", tools=tools, x_range=s.x_range,
                   x_axis_label="depth z [mm]", y_axis_label="[δ(z)]", min_border_left=50)
        c.multi_line("xs", "ys", color="color", legend_field="label", line_width=1.5,
                     source=self.gap_src)
        c.scatter("x", "y", color="color", size=6, source=self.cover_src)
        _title(c).text_font_size = "11px"
        self.cover_fig = c

    def _build_image_figures(self, tools: str, empty: dict[str, Any]) -> None:
        """The predicted image quality against depth (splitlf.image_merits, on request):
        PSNR and MTF50 per row, with the button and the photon count that start it."""
        self.psnr_src = ColumnDataSource(dict(empty), name="image_psnr")
        self.mtf_src = ColumnDataSource(dict(empty), name="image_mtf50")
        nothing = _points(np.zeros(0), (), np.zeros((0, 0)))
        self.psnr_pts_src = ColumnDataSource(dict(nothing), name="image_psnr_points")
        self.mtf_pts_src = ColumnDataSource(dict(nothing), name="image_mtf50_points")
        p = figure(title="Predicted PSNR of a reconstruction [dB]", x_axis_type="log",
                   height=250, sizing_mode="stretch_width", tools=tools,
                   x_axis_label="depth z [mm]", y_axis_label="PSNR [dB]", min_border_left=70)
        p.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.psnr_src)
        m = figure(title="Predicted MTF50 [share of the sensor's Nyquist]", x_axis_type="log",
                   height=250, sizing_mode="stretch_width", tools=tools, x_range=p.x_range,
                   x_axis_label="depth z [mm]", y_axis_label="MTF50 / Nyquist",
                   min_border_left=50)
        m.multi_line("xs", "ys", color="color", legend_field="label", line_width=2,
                     source=self.mtf_src)
        p.scatter("x", "y", color="color", size=6, source=self.psnr_pts_src)
        m.scatter("x", "y", color="color", size=6, source=self.mtf_pts_src)
        for fig in (p, m):
            fig.legend.location = "top_right"
            fig.legend.label_text_font_size = "10px"
            fig.legend.background_fill_alpha = 0.6
        self.psnr_fig, self.mtf_fig = p, m
        self.image_button = Button(label="predict image quality", width=170,
                                   margin=(24, 5, 5, 5))
        self.image_button.on_click(lambda: self.request_image())
        self.image_photons = TextInput(title="photons for white", value=f"{model.IMAGE_PHOTONS:g}",
                                       placeholder=IMAGE_PHOTONS, width=150,
                                       description="photo-electrons of a white pixel (photon "
                                       "noise), > 0")
        self._errors[IMAGE_PHOTONS] = Div(text="", width=260, visible=False)
        self.image_status = Div(text=IMAGE_IDLE, width=540)
        self._image_gen = 0  # the design (generation) the image figures show; 0: none

    def _build_report(self) -> None:
        # The report as a table of a data source, and the status (which design each view
        # shows) as a data source: changing either sends data, never re-lays the page out.
        self.report_src = ColumnDataSource({"label": [], "value": []}, name="report")
        self.report = DataTable(source=self.report_src, index_position=None, height=420,
                                sizing_mode="stretch_width", columns=[
                                    TableColumn(field="label", title="quantity", width=320),
                                    TableColumn(field="value", title="value", width=280)])
        self.status_src = ColumnDataSource({"blur": [0], "gap": [0], "samples": [0]},
                                           name="status")
        self.report.tags = [self.status_src]  # a model must reference it to reach the page

    def _build_picked_figures(self) -> None:
        # The 2-D sample map at a picked depth and the microlens images on the sensor.
        self.map_src = ColumnDataSource({"x": [], "y": [], "color": [], "label": []},
                                        name="sample_map")
        m = figure(title="2-D samples", width=540, height=420, match_aspect=True,
                   tools="pan,wheel_zoom,box_zoom,reset,save", x_axis_label="X / δ(z)",
                   y_axis_label="Y / δ(z)")
        m.scatter("x", "y", color="color", legend_field="label", size=4, alpha=0.7,
                  source=self.map_src)
        self.map_fig = m
        self.sensor_src = ColumnDataSource({"image": [], "x": [], "y": [], "dw": [], "dh": []},
                                           name="microlens_image")
        g = figure(title="Microlens images", width=540, height=420, match_aspect=True,
                   tools="pan,wheel_zoom,box_zoom,reset,save", x_axis_label="sensor column",
                   y_axis_label="sensor row")
        g.image_rgba(image="image", x="x", y="y", dw="dw", dh="dh", source=self.sensor_src)
        self.sensor_fig = g
        # The ray space of the open channel: each pixel's integration polygon in (u, w).
        self.rays_src = ColumnDataSource({"us": [], "ws": [], "lens": [], "type": [],
                                          "color": []}, name="ray_space")
        a = figure(title="Ray space (Fig. 4)", width=540, height=360,
                   tools="pan,wheel_zoom,box_zoom,reset,save,hover",
                   tooltips=[("lens", "@lens"), ("type", "@type")],
                   x_axis_label="u: height on channel 1's array plane [mm]",
                   y_axis_label="w: height on the main lens [mm]")
        a.patches("us", "ws", fill_color="color", line_color="#333333", line_width=0.5,
                  fill_alpha=0.55, source=self.rays_src)
        self.aperture_spans = [Span(location=v, dimension="width", line_color="black",
                                    line_dash="dashed") for v in (-1.0, 1.0)]
        for sp in self.aperture_spans:
            a.add_layout(sp)
        self.rays_fig = a

    def _build_reference(self, empty: dict[str, Any], nothing: dict[str, Any]) -> None:
        """The reference design, grey and dashed on the same axes."""
        f, s, c = self.blur_fig, self.distinct_fig, self.cover_fig
        self.ref_blur_src = ColumnDataSource(dict(empty), name="reference_blur")
        self.ref_gap_distinct_src = ColumnDataSource(dict(empty), name="reference_distinct_1d")
        self.ref_gap_src = ColumnDataSource(dict(empty), name="reference_max_gap")
        self.ref_distinct_src = ColumnDataSource(dict(nothing), name="reference_distinct")
        self.ref_cover_src = ColumnDataSource(dict(nothing), name="reference_covering_radius")
        self._ref_items: list[LegendItem] = []
        for fig, src in ((f, self.ref_blur_src), (s, self.ref_gap_distinct_src),
                         (c, self.ref_gap_src)):
            fig.multi_line("xs", "ys", color=REFERENCE_COLOR, line_dash="dashed",
                           line_width=1.5, legend_label="reference", source=src)
            self._ref_items.append(_last_legend_item(fig))
            self._ref_items[-1].visible = self.reference is not None
        for fig, src in ((s, self.ref_distinct_src), (c, self.ref_cover_src)):
            fig.scatter("x", "y", color=REFERENCE_COLOR, size=6, marker="diamond",
                        source=src)
        for fig in (s, c):  # small legends, in the corner the curves leave freest
            fig.legend.location = "bottom_right" if fig is s else "top_right"
            fig.legend.label_text_font_size = "10px"
            fig.legend.background_fill_alpha = 0.6
            # bokeh's stub types Legend.padding as its Property, not the property's value
            fig.legend.padding = 4  # type: ignore[assignment]
            fig.legend.spacing = 0
            fig.legend.click_policy = "hide"

    # -- events --------------------------------------------------------------------------
    @staticmethod
    def _preset_of(design: Design) -> str:
        for name in PRESETS:
            if Design.preset(name) == design:
                return name
        return "custom"

    def _on_preset(self, attr: str, old: Any, new: Any) -> None:
        if self._suspend or new == "custom":
            return
        self.set_design(Design.preset(new))

    def _on_load(self, attr: str, old: Any, new: Any) -> None:
        if not new:
            return
        try:
            data = base64.b64decode(new, validate=True)
            design = model.load_toml_bytes(data, self._load_name())
        except (SplitlfError, ValueError, TypeError, OSError) as e:
            self._show_errors(None, f"load TOML: {e}")
            return
        self.set_design(design)

    def _load_name(self) -> str:
        """The loaded file's name (the page may send it after the content: unset then)."""
        try:
            return str(self.load.filename) or "uploaded.toml"
        except UnsetValueError:
            return "uploaded.toml"

    def _save_toml(self) -> None:
        """Send the current design's TOML to the page, which saves it as design.toml."""
        n = self.toml_src.data.get("n", [0])[0] + 1  # a new value even for the same text
        self.toml_src.data = {"text": [self.design.to_toml()], "n": [n]}

    def _on_tap(self, event: Any) -> None:
        if event.x is not None and np.isfinite(event.x) and event.x > 0:
            self.map_z.value = f"{event.x:.6g}"

    def set_reference(self, design: Design | None) -> None:
        """Draw ``design`` (None: nothing) beside the current one on the same axes."""
        self.reference = design
        self._refresh(self.design)

    def _on_field(self, key: str, attr: str, old: Any, new: Any) -> None:
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
        for k, div in self._errors.items():
            text = (f'<span class="field-error" data-key="{_esc(k)}" '
                    f'style="{ERROR_STYLE}">{_esc(message)}</span>') if k == key else ""
            self._set_div(div, text)
        text = (f'<div class="explorer-error" style="{ERROR_STYLE}">Invalid: {_esc(message)} '
                "(the figures show the last valid design)</div>") if message else ""
        self._set_div(self.banner, text)

    @staticmethod
    def _set_div(div: Div, text: str) -> None:
        """Show ``text`` in ``div``, hidden when empty; untouched when unchanged."""
        if div.text != text:
            div.text = text
        if div.visible != bool(text):
            div.visible = bool(text)

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
        # Three ticks, each sent before the next starts (the session's lock): the
        # closed-form views, then the 1-D samples (the page draws the first while the
        # server computes these), then the heavy views start on the worker.
        self._push(partial(self._apply_blur, blur, ref, report, gen))
        self._push(self._clear_image)
        self._push(partial(self._gap, design, gen))
        self._push(partial(self._request_samples, design))

    def _gap(self, design: Design, gen: int) -> None:
        """Compute and show the 1-D samples of ``design`` (and of the reference)."""
        if gen != self.generation:
            return  # a newer design is on its way
        try:
            gap = model.gap_view(design)
            ref_gap = None
            if self.reference is not None:
                if self._ref_gap is None or self._ref_gap[0] != self.reference:
                    self._ref_gap = (self.reference, model.gap_view(self.reference))
                ref_gap = self._ref_gap[1]
        except (SplitlfError, ValueError, MemoryError) as e:
            self._show_errors(None, f"1-D samples: {e}")
            return
        self._apply_gap(gap, ref_gap, gen)

    def _push(self, fn: Any) -> None:
        """Run ``fn`` where Bokeh models may change: the session's next tick (or now,
        before the app is attached to a session)."""
        if self._doc is not None and self._doc.session_context is not None:
            self._doc.add_next_tick_callback(fn)
        else:
            fn()

    def _apply_gap(self, gap: dict[str, Any], ref_gap: dict[str, Any] | None,
                   gen: int) -> None:
        self.gap_distinct_src.data = _lines(gap["z"], gap["rows"], gap["distinct"])
        title = gap["note"] or DISTINCT_TITLE  # why the 1-D lines are absent, if they are
        if _title(self.distinct_fig).text != title:
            _title(self.distinct_fig).text = title
        self.gap_src.data = _lines(gap["z"], gap["rows"], gap["max_gap"])
        if ref_gap is None:
            if self.ref_gap_src.data["label"]:
                empty = _lines(np.zeros(1), (), np.zeros((0, 1)))
                self.ref_gap_distinct_src.data = dict(empty)
                self.ref_gap_src.data = dict(empty)
        else:
            labels = tuple(f"reference {r}" for r in ref_gap["rows"])
            self.ref_gap_distinct_src.data = _lines(ref_gap["z"], labels,
                                                    ref_gap["distinct"], grey=True)
            self.ref_gap_src.data = _lines(ref_gap["z"], labels, ref_gap["max_gap"],
                                           grey=True)
        self._status(gap=gen)

    def _apply_blur(self, blur: dict[str, Any], ref: dict[str, Any] | None,
                    report: list[tuple[str, str]], gen: int) -> None:
        z = blur["z"]
        for item in self._ref_items:
            if item.visible != (ref is not None):
                item.visible = ref is not None
        if ref is None:
            if self.ref_blur_src.data["label"]:
                self.ref_blur_src.data = _lines(np.zeros(1), (), np.zeros((0, 1)))
        else:
            self.ref_blur_src.data = _lines(ref["z"], tuple(f"reference {r}" for r in
                                                            ref["rows"]), ref["blur_px"],
                                            grey=True)
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
        end = _nice_ceiling(max(1.2 * top, 1.5 * blur["threshold_px"]))
        if self.blur_y_range.end != end:
            self.blur_y_range.end = end
        self.threshold_span.location = blur["threshold_px"]
        rows = list(blur["dof_rows"])
        zmax = float(z[-1])
        colors = {r: Category10_10[i % 10] for i, r in enumerate(rows)}
        colors["reference"] = REFERENCE_COLOR
        self.dof_y_range.factors = rows[::-1]
        self.dof_src.data = {
            "row": [r for r, _, _ in blur["dof"]],
            "left": [max(a, float(z[0])) for _, a, _ in blur["dof"]],
            "right": [min(b, zmax) for _, _, b in blur["dof"]],
            "color": [colors[r] for r, _, _ in blur["dof"]],
        }
        self.report_src.data = {"label": [k for k, _ in report], "value": [v for _, v in report]}
        self._status(blur=gen)

    def _status(self, **shown: int) -> None:
        """Record which design (generation) the closed-form views (``blur``), the 1-D
        samples (``gap``) and the 2-D coverage (``samples``) show, in the page's "status"
        source. (Not shown in a title: a title that changes makes Bokeh lay the figure
        out again.)"""
        self._shown.update(shown)
        self.status_src.data = {k: [v] for k, v in self._shown.items()}

    def _request_samples(self, design: Design) -> None:
        """Queue the heavy views of ``design``: samples over depth, then the sample map
        at the picked depth and the microlens images."""
        self._request("samples", (self.generation, design, self.reference,
                                  int(self.n_depths.value), float(self.window.value)))
        self._request_map()
        self._request_channel(design)

    def _request_channel(self, design: Design) -> None:
        """Queue the views of the channel whose tab is open: microlens images, ray space."""
        self._request("sensor", (design, self._sensor_channel()))
        self._request("rays", (design, self._sensor_channel()))

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
        # Not a daemon (said explicitly: a thread started from the server's daemon thread
        # would inherit daemon=True): at interpreter exit Python waits for the job in hand.
        # A daemon thread inside the core at exit is ended by CPython with a forced unwind
        # through the extension's frames, which crashed the wheel (segfault at exit).
        threading.Thread(target=self._worker, name="splitlf-explorer-worker",
                         daemon=False).start()

    def _worker(self) -> None:
        while True:
            with self._lock:
                kind = next((k for k in ("samples", "map", "sensor", "rays", "image")
                             if k in self._pending), None)
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
        _title(self.map_fig).text = (f"2-D samples at z = {m['z']:.5g} mm "
                                   f"(δ = {m['delta_mm'] * 1e3:.3g} µm){union}")

    def request_image(self) -> None:
        """Queue the image-quality view of the design shown (the button), at the photon
        count of its control (checked first: a bad value is shown beside the control)."""
        try:
            photons = _validate.positive(model.parse(
                Field(IMAGE_PHOTONS, "real", "", ""), str(self.image_photons.value),
                IMAGE_PHOTONS), IMAGE_PHOTONS)
        except (FieldError, InvalidParameter) as e:  # beside this control only
            self._photons_error(str(e))
            return
        self._photons_error("")
        n = len(model.image_depths(self.design))
        self._set_div(self.image_status, f"Computing the image merits of the design shown at "
                      f"{photons:g} photons, {n} depths (seconds to minutes a depth)...")
        self._request("image", (self.generation, self.design, photons))

    def _photons_error(self, message: str) -> None:
        """``message`` (empty: none) beside the photon count, the other controls' messages and
        the banner (about the design) left as they are."""
        text = (f'<span class="field-error" data-key="{IMAGE_PHOTONS}" '
                f'style="{ERROR_STYLE}">{_esc(message)}</span>') if message else ""
        self._set_div(self._errors[IMAGE_PHOTONS], text)

    def _compute_image(self, gen: int, design: Design, photons: float) -> Any:
        return partial(self._apply_image, model.image_view(design, photons), gen)

    def _apply_image(self, data: dict[str, Any], gen: int) -> None:
        if gen != self.generation:
            self._set_div(self.image_status, "The design changed while its image merits were "
                          "computed: press the button again for the design shown.")
            return
        rows = tuple(data["rows"])
        self.psnr_src.data = _lines(data["z"], rows, data["psnr"])
        self.mtf_src.data = _lines(data["z"], rows, data["mtf50"])
        self.psnr_pts_src.data = _points(data["z"], rows, data["psnr"])
        self.mtf_pts_src.data = _points(data["z"], rows, data["mtf50"])
        self._image_gen = gen
        self._set_div(self.image_status, f"Image merits of the design shown at "
                      f"{data['photons']:g} photons for white, {len(data['z'])} depths: "
                      f"{data['seconds']:.1f} s (splitlf.image_merits, docs/merits.md).")

    def _clear_image(self) -> None:
        """A new design: the image figures no longer show it, so they are emptied."""
        if self._image_gen and self._image_gen != self.generation:
            empty = _lines(np.zeros(1), (), np.zeros((0, 1)))
            nothing = _points(np.zeros(0), (), np.zeros((0, 0)))
            self.psnr_src.data = dict(empty)
            self.mtf_src.data = dict(empty)
            self.psnr_pts_src.data = dict(nothing)
            self.mtf_pts_src.data = dict(nothing)
            self._image_gen = 0
            self._set_div(self.image_status, IMAGE_IDLE)

    def _compute_rays(self, design: Design, channel: int) -> Any:
        return partial(self._apply_rays, channel, model.ray_space_view(design, channel))

    def _apply_rays(self, channel: int, r: dict[str, Any]) -> None:
        self.rays_src.data = {
            "us": r["us"], "ws": r["ws"], "lens": r["lens"], "type": r["type"],
            "color": [model_color(t) for t in r["type"]]}
        h = r["half_aperture"]
        self.aperture_spans[0].location, self.aperture_spans[1].location = -h, h
        _title(self.rays_fig).text = r["note"] or (
            f"Ray space of channel {channel} (Fig. 4): pixels under the {model.RAY_LENSES} "
            "central microlenses")

    def _apply_sensor(self, channel: int, im: dict[str, Any]) -> None:
        rgba = im["rgba"]
        ny, nx = rgba.shape
        self.sensor_src.data = {"image": [rgba], "x": [im["x0"] - 0.5], "y": [im["y0"] - 0.5],
                                "dw": [nx], "dh": [ny]}
        _title(self.sensor_fig).text = (f"Microlens images, channel {channel}: {im['lit']} of "
                                      f"{im['pixels']} pixels shown are lit")

    def _apply_samples(self, data: dict[str, Any], ref: dict[str, Any] | None,
                       gen: int) -> None:
        if gen < self._shown["samples"]:
            return
        if ref is None:
            if len(self.ref_distinct_src.data["x"]):
                nothing = _points(np.zeros(0), (), np.zeros((0, 0)))
                self.ref_distinct_src.data = dict(nothing)
                self.ref_cover_src.data = dict(nothing)
        else:
            self.ref_distinct_src.data = _points(ref["z"], ref["rows"], ref["distinct"], True)
            self.ref_cover_src.data = _points(ref["z"], ref["rows"], ref["covering_radius"],
                                              True)
        self.distinct_src.data = _points(data["z"], data["rows"], data["distinct"])
        self.cover_src.data = _points(data["z"], data["rows"], data["covering_radius"])
        self._status(samples=gen)
