"""The page of ``isj app`` and its Bokeh server (docs/app.md).

:func:`make_document` lays out one browser tab: the controls on the left, the numbers, marks
and plots on the right, every output recomputed by :mod:`isj.app.state` when a control
changes. Each tab is its own Bokeh session with its own :class:`Session`; the slow work (FE
verify, the surrogate's build) runs in a child process (:mod:`isj.app.jobs`) that is cancelled
when the tab's session ends. :func:`serve` runs the server until interrupted.
"""

from __future__ import annotations

import logging
import math
import threading

import numpy as np
from bokeh.layouts import column, row
from bokeh.models import (
    BoxAnnotation,
    Button,
    ColorBar,
    ColumnDataSource,
    CustomJS,
    Div,
    LinearColorMapper,
    RadioButtonGroup,
    Select,
    Slider,
    TabPanel,
    Tabs,
    TextInput,
)
from bokeh.palettes import Viridis256
from bokeh.plotting import figure

from isj.cases import THESIS_CASES
from isj.errors import InvalidParameter, IsjError

from . import jobs, state

log = logging.getLogger("isj.app")

#: Digits the page shows for α and β (µrad) and for β/α.
DIGITS = 4

_ROMS: dict = {}  # (order, resolution) -> (rom or None, why)
_ROM_LOCK = threading.Lock()


def _calibration_mesh() -> tuple[int, float]:
    """Order and resolution of the shipped calibration's FE mesh (its surrogate's mesh)."""
    fe = state.Design().model().calibration.fe_settings
    return int(fe.get("order", 2)), float(fe.get("resolution", 1.0))


def cached_rom(refresh: bool = False):
    """``(rom, why)``: the surrogate of the calibration's mesh if its build is cached (looked up once)."""
    from isj._cli._region import cached_surrogate

    key = _calibration_mesh()
    with _ROM_LOCK:
        if refresh or key not in _ROMS:
            _ROMS[key] = cached_surrogate(*key)
        return _ROMS[key]


def _one_line(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return text if isinstance(exc, IsjError) else f"{type(exc).__name__}: {text}"


def _short(text) -> str:
    """A typed value for a message: its repr, cut to 40 characters so the message stays one line."""
    return repr(str(text)[:40])


def _urad(x: float) -> str:
    return f"{x * 1e6:.{DIGITS}g}"


class Session:
    """One browser tab: its design, its widgets and its background job."""

    def __init__(self, doc):
        self.doc = doc
        self.design = state.Design()
        self.job: jobs.Job | None = None
        self.job_kind = ""
        self._poll = None
        self._quiet = False  # set while the page itself writes a widget
        self.specs = state.field_specs()
        self.fe_last: dict | None = None
        self._build()
        doc.on_session_destroyed(self._destroyed)
        self.update_all()

    # ---- layout -------------------------------------------------------------------------------

    def _field(self, name: str):
        spec = self.specs[name]
        v = self._value(name)
        if spec.log:
            lo, hi = (math.log10(x) for x in spec.slider)
            s = Slider(
                start=lo, end=hi, value=math.log10(v), step=0.01, title=f"log10 {spec.label} (Pa)", width=230
            )
        elif spec.unit == "m":
            lo, hi = (x * 1e6 for x in spec.slider)
            s = Slider(
                start=lo, end=hi, value=v * 1e6, step=(hi - lo) / 100, title=f"{spec.label} (µm)", width=230
            )
        else:
            s = Slider(
                start=spec.slider[0],
                end=spec.slider[1],
                value=v,
                step=0.5,
                title=f"{spec.label} (Pa)",
                width=230,
            )
        t = TextInput(value=f"{v:.6g}", width=110, css_classes=[f"isj-text-{name}"])
        s.css_classes = [f"isj-slider-{name}"]
        s.on_change("value", lambda attr, old, new, name=name: self.on_slider(name, new))
        t.on_change("value", lambda attr, old, new, name=name: self.on_text(name, new))
        self.sliders[name], self.texts[name] = s, t
        return row(s, t)

    def _build(self) -> None:
        """The page: its controls and status lines, the four tabs' plots, the export, the layout."""
        self._build_status()
        self._build_chain_plots()
        self._build_ear_plots()
        self._build_map()
        self._build_uncertainty()
        self._build_export()
        self._layout()

    def _build_status(self) -> None:
        """The fields' holders, the message and number lines, the surrogate and FE controls, the
        joint buttons and the reset."""
        self.sliders: dict[str, Slider] = {}
        self.texts: dict[str, TextInput] = {}
        self.message = Div(text='<span id="message"></span>', width=700, height=22)
        self.numbers = Div(width=700, height=96)  # fixed sizes: a new text re-renders no other part
        self.surrogate = Div(width=520, height=40)
        self.rom_button = Button(label="Build the surrogate", width=170, visible=False)
        self.rom_button.on_click(self.on_build_rom)
        self.fe_res = TextInput(
            title="FE mesh resolution",
            value=f"{_calibration_mesh()[1]:g}",
            width=130,
            css_classes=["isj-fe-res"],
        )
        self.fe_button = Button(
            label="Verify with FE", button_type="primary", width=150, css_classes=["isj-verify"]
        )
        self.stamp = Div(
            text="<span id='stamp'>update 0</span>", width=200, height=20, styles={"color": "#bbb"}
        )
        self.updates = 0
        self._stale: set[str] = set()
        self._plots_pending = False
        self.fe_button.on_click(self.on_verify)
        self.fe_res.on_change("value", lambda a, o, n: self.guarded(self.on_fe_res, n))
        self.fe_div = Div(text='<span id="fe"></span>', width=640, height=40)
        self.joint = RadioButtonGroup(labels=list(state.JOINTS), active=0)
        self.joint.on_change("active", lambda a, o, n: self.on_joint(n))
        self.reset_select = Select(
            title="reset to",
            value="defaults",
            options=["defaults", *(c.name for c in THESIS_CASES)],
            width=150,
        )
        self.reset_button = Button(label="Reset", width=80)
        self.reset_button.on_click(self.on_reset)

    def _build_chain_plots(self) -> None:
        """The isolated chain's α and β over frequency (lumped): magnitude and phase."""
        self.bode_src = ColumnDataSource(dict(f=[], a=[], b=[], pa=[], pb=[]))
        self.bode = figure(
            title="isolated chain (lumped)",
            x_axis_type="log",
            y_axis_type="log",
            width=640,
            height=260,
            x_axis_label="frequency (Hz)",
            y_axis_label="|angle| (rad)",
        )
        self.bode.line("f", "a", source=self.bode_src, legend_label="alpha", color="#1f77b4", line_width=2)
        self.bode.line("f", "b", source=self.bode_src, legend_label="beta", color="#d62728", line_width=2)
        self.bode.legend.location = "bottom_left"
        self.bode_phase = figure(
            x_axis_type="log",
            width=640,
            height=180,
            x_range=self.bode.x_range,
            x_axis_label="frequency (Hz)",
            y_axis_label="phase (deg)",
        )
        self.bode_phase.line("f", "pa", source=self.bode_src, color="#1f77b4", line_width=2)
        self.bode_phase.line("f", "pb", source=self.bode_src, color="#d62728", line_width=2)

    def _build_ear_plots(self) -> None:
        """The whole ear's H_V and ΔH_V over frequency, with the band the model holds."""
        self.ear_src = ColumnDataSource(dict(f=[], hv=[], ddb=[], ddeg=[]))
        self.ear = figure(
            x_axis_type="log",
            y_axis_type="log",
            width=640,
            height=240,
            x_range=(100, 20000),
            x_axis_label="frequency (Hz)",
            y_axis_label="|H_V| (m/s/Pa)",
        )
        self.ear.line("f", "hv", source=self.ear_src, line_width=2, color="#2ca02c")
        self.ear_band = BoxAnnotation(fill_alpha=0.08, fill_color="green")
        self.ear.add_layout(self.ear_band)
        self.ear_delta = figure(
            x_axis_type="log",
            width=640,
            height=200,
            x_range=self.ear.x_range,
            x_axis_label="frequency (Hz)",
            y_axis_label="ΔH_V (dB)",
        )
        self.ear_delta.line("f", "ddb", source=self.ear_src, line_width=2, color="#9467bd")
        self.ear_delta_band = BoxAnnotation(fill_alpha=0.08, fill_color="green")
        self.ear_delta.add_layout(self.ear_delta_band)
        self.ear_note = Div(width=640, height=60)

    def _build_map(self) -> None:
        """The map of log10 β/α over two moduli, with the design marked."""
        self.map_x = Select(title="map x", value="pedicle_e_pa", options=list(state.MODULI), width=150)
        self.map_y = Select(title="map y", value="gap_e_pa", options=list(state.MODULI), width=150)
        self.map_x.css_classes, self.map_y.css_classes = ["isj-map-x"], ["isj-map-y"]
        for w in (self.map_x, self.map_y):
            w.on_change("value", lambda a, o, n: self.guarded(self._redo, "update_map", True))
        self.map_src = ColumnDataSource(dict(image=[], x=[], y=[], dw=[], dh=[]))
        self.map_dot = ColumnDataSource(dict(x=[], y=[]))
        self.map_mapper = LinearColorMapper(palette=Viridis256)
        self.map = figure(width=560, height=420, title="log10 beta/alpha (lumped)", match_aspect=False)
        self.map.image(
            "image", x="x", y="y", dw="dw", dh="dh", source=self.map_src, color_mapper=self.map_mapper
        )
        self.map.scatter("x", "y", source=self.map_dot, size=12, marker="x", line_width=3, color="red")
        self.map.add_layout(ColorBar(color_mapper=self.map_mapper, width=12), "right")
        self.map_info = Div(width=560, height=40, text='<span id="map"></span>')

    def _build_uncertainty(self) -> None:
        """The moduli's distributions and the histogram of log10 β/α."""
        self.uq_kinds = {
            k: Select(
                title=k,
                value="loguniform",
                options=list(state.UQ_KINDS),
                width=120,
                css_classes=[f"isj-uq-{k}"],
            )
            for k in state.MODULI
        }
        self.uq_factor = TextInput(title="lognormal factor", value="2", width=110)
        self.uq_samples = TextInput(title="samples", value="20000", width=110)
        for w in (*self.uq_kinds.values(), self.uq_factor, self.uq_samples):
            w.on_change("value", lambda a, o, n: self.guarded(self._redo, "update_uq", True))
        self.uq_src = ColumnDataSource(dict(left=[], right=[], top=[]))
        self.uq = figure(width=560, height=300, x_axis_label="log10 beta/alpha", y_axis_label="draws")
        self.uq.quad(left="left", right="right", top="top", bottom=0, source=self.uq_src, fill_alpha=0.6)
        self.uq.add_layout(BoxAnnotation(right=0.0, fill_alpha=0.1, fill_color="red"))
        self.uq_info = Div(width=560, height=40, text='<span id="uq"></span>')

    def _build_export(self) -> None:
        """The case-file download and the plots' format."""
        self.case_src = ColumnDataSource(dict(text=[""]))
        self.export_button = Button(label="Download case file (TOML)", width=210)
        self.export_button.js_on_click(
            CustomJS(
                args=dict(src=self.case_src),
                code="""
                const blob = new Blob([src.data.text[0]], {type: 'application/toml'});
                const a = document.createElement('a');
                a.href = URL.createObjectURL(blob); a.download = 'isj-case.toml';
                document.body.appendChild(a); a.click(); a.remove();
                """,
            )
        )
        self.case_div = Div(width=640)
        self.plot_format = Select(title="plots save as", value="png", options=["png", "svg"], width=120)
        self.plot_format.on_change("value", lambda a, o, n: self.on_format(n))

    def _layout(self) -> None:
        """The controls column beside the outputs and the tabs, added to the document."""
        moduli = column(
            Div(text="<b>Moduli</b> (log sliders over the calibrated domain)"),
            *(self._field(k) for k in state.MODULI),
        )
        geom = column(
            Div(text="<b>Geometry</b> (the geometry calibration's range)"),
            *(self._field(k) for k in state.GEOMETRY_FIELDS),
        )
        load = column(
            Div(text="<b>Joint and load</b>"),
            self.joint,
            self._field("pressure_pa"),
            row(self.reset_select, self.reset_button),
        )
        controls = column(moduli, load, geom, width=370)
        self.tabs = tabs = Tabs(
            tabs=[
                TabPanel(title="Chain", child=column(self.bode, self.bode_phase)),
                TabPanel(title="Ear H_V", child=column(self.ear_note, self.ear, self.ear_delta)),
                TabPanel(title="Map", child=column(row(self.map_x, self.map_y), self.map_info, self.map)),
                TabPanel(
                    title="Uncertainty",
                    child=column(
                        row(*self.uq_kinds.values()),
                        row(self.uq_factor, self.uq_samples),
                        self.uq_info,
                        self.uq,
                    ),
                ),
                TabPanel(
                    title="Export", child=column(row(self.export_button, self.plot_format), self.case_div)
                ),
            ]
        )
        outputs = column(
            Div(text="<h2 style='margin:0'>isj app: the incus–stapes coupling</h2>"),
            self.message,
            self.numbers,
            row(self.surrogate, self.rom_button),
            row(self.fe_res, self.fe_button),
            self.fe_div,
            tabs,
            self.stamp,
        )
        self.tabs.on_change("active", lambda a, o, n: self.guarded(self.update_plots))
        self.doc.title = "isj app"
        self.doc.add_root(row(controls, outputs))

    # ---- values -------------------------------------------------------------------------------

    def _value(self, name: str) -> float:
        if name in state.MODULI:
            return self.design.moduli[name]
        if name in state.GEOMETRY_FIELDS:
            return self.design.dims[name]
        return self.design.pressure_pa

    def _show_value(self, name: str) -> None:
        """Write the design's value of ``name`` into its slider (clamped) and its text field."""
        v, spec, s = self._value(name), self.specs[name], self.sliders[name]
        pos = math.log10(v) if spec.log else (v * 1e6 if spec.unit == "m" else v)
        self._quiet = True
        try:
            s.value = min(max(pos, s.start), s.end)
            self.texts[name].value = f"{v:.6g}"
        finally:
            self._quiet = False

    def say(self, text: str = "", error: bool = True) -> None:
        style = "color:#b00020;font-weight:bold" if error else "color:#333"
        from html import escape

        self.message.text = f'<span id="message" style="{style}">{escape(text)}</span>'

    def guarded(self, fn, *args) -> None:
        """Run ``fn``; an error is one line in the page (the server log keeps the traceback)."""
        try:
            fn(*args)
        except Exception as exc:  # noqa: BLE001 - nothing may reach the page as a traceback
            if not isinstance(exc, IsjError):
                log.exception("isj app: callback failed")
            self.say(_one_line(exc))

    # ---- events -------------------------------------------------------------------------------

    def on_slider(self, name: str, pos: float) -> None:
        if self._quiet:
            return
        spec = self.specs[name]

        def go():
            # the page's sliders stay in their range; a value sent otherwise is checked as if typed
            try:
                text = f"{float(10**pos if spec.log else (pos * 1e-6 if spec.unit == 'm' else pos)):.6g}"
            except OverflowError:
                text = "inf"
            except TypeError:  # not a number at all
                text = str(pos)
            self._set(name, state.parse_value(name, text), True)

        self.guarded(go)

    def on_text(self, name: str, text: str) -> None:
        if self._quiet:
            return
        self.guarded(self._set, name, None, False, text)

    def _set(self, name: str, v, from_slider: bool, text: str | None = None) -> None:
        if v is None:
            v = state.parse_value(name, text)
        try:
            self.design = self.design.replace(name, v)  # an invalid geometry raises here, the design stays
        except InvalidParameter as exc:
            if name in str(exc):
                raise
            # another dimension's limit moved (plate_thickness_m bounds capsule_reach_m): name this one
            raise InvalidParameter(f"{name} = {v:.6g}: {exc}") from None
        self.say("", error=False)
        if from_slider:
            self._quiet = True
            try:
                self.texts[name].value = f"{v:.6g}"
            finally:
                self._quiet = False
        else:
            self._show_value(name)
        self.update_all()

    def on_joint(self, active) -> None:
        if self._quiet:
            return

        def go():
            if not (isinstance(active, int) and 0 <= active < len(state.JOINTS)):
                raise IsjError(
                    f"joint = {str(active)[:40]}: must be 0 ({state.JOINTS[0]}) or 1 ({state.JOINTS[1]})"
                )
            self._set_joint(state.JOINTS[active])

        self.guarded(go)

    def _set_joint(self, joint: str) -> None:
        self.design = self.design.replace("joint", joint)
        self.say("", error=False)
        self.update_all()

    def on_reset(self) -> None:
        def go():
            self.design = state.Design.case(self.reset_select.value)
            for name in self.sliders:
                self._show_value(name)
            self._quiet = True
            self.joint.active = 0
            self._quiet = False
            self.say("", error=False)
            self.update_all()

        self.guarded(go)

    def on_format(self, fmt: str) -> None:
        self.guarded(self._set_format, fmt)

    def _set_format(self, fmt: str) -> None:
        if fmt not in ("png", "svg"):
            raise IsjError(f"plots save as = {_short(fmt)}: must be png or svg")
        self.say("", error=False)
        for p in (self.bode, self.bode_phase, self.ear, self.ear_delta, self.map, self.uq):
            p.output_backend = "svg" if fmt == "svg" else "canvas"

    # ---- outputs ------------------------------------------------------------------------------

    #: What each tab shows, by tab index.
    TAB_PLOTS = ("update_bode", "update_ear", "update_map", "update_uq", "update_export")

    def update_all(self) -> None:
        """The numbers and marks now; the plots on the next tick, so the numbers reach the page first.

        Only the visible tab's plot is recomputed; the others are when their tab is chosen.
        """
        self.update_numbers()
        self._stale = set(self.TAB_PLOTS)
        if not self._plots_pending:
            self._plots_pending = True
            self.doc.add_next_tick_callback(lambda: self.guarded(self.update_plots))

    def update_plots(self) -> None:
        """The visible tab's plot, if stale; then the update counter (the page's last write)."""
        self._plots_pending = False
        name = self.TAB_PLOTS[self.tabs.active]
        if name in self._stale:
            self._stale.discard(name)
            getattr(self, name)()
        self.updates += 1  # written last: the page has every output of this change once it shows
        self.stamp.text = f"<span id='stamp'>update {self.updates}</span>"

    def _redo(self, name: str, clear: bool = False) -> None:
        getattr(self, name)()
        self._stale.discard(name)
        if clear:  # the control that changed is valid now: its earlier message goes
            self.say("", error=False)

    def update_numbers(self) -> None:
        d = self.design
        rom, why = (None, "the surrogate covers the default geometry only")
        if d.is_default_geometry() and d.joint == "bonded":
            rom, why = cached_rom()
        out = state.static_outputs(d, rom)
        numbers = (
            "<div style='font-size:1.25em'>lumped model: "
            f"α = <b><span id='alpha'>{_urad(out['alpha_rad'])}</span></b> µrad, "
            f"β = <b><span id='beta'>{_urad(out['beta_rad'])}</span></b> µrad, "
            f"β/α = <b><span id='ratio'>{out['beta_over_alpha']:.{DIGITS}g}</span></b></div>"
            f"<div>at {d.pressure_pa:g} Pa, {d.joint} joint</div>"
        )
        marks = []
        for k, (v, lo, hi) in out["outside_domain"].items():
            marks.append(
                f"{k} = {v:.4g} Pa outside the calibrated domain [{lo:.3g}, {hi:.3g}] Pa: extrapolating"
            )
        for k, (v, lo, hi) in out["outside_geometry"].items():
            marks.append(
                f"{k} = {v:.4g} m outside the geometry calibration [{lo:.3g}, {hi:.3g}] m: extrapolating"
            )
        reg = out["region"]
        if reg is not None and not reg["inside"]:
            marks.append(
                f"outside the region where the lumped model holds {100 * reg['tolerance']:g} % of FE"
            )
        if marks:
            marks_html = "<div id='marks' style='color:#b35900'>⚠ " + "<br>⚠ ".join(marks) + "</div>"
        else:
            inside = (
                ""
                if reg is None
                else f", inside the region where it holds {100 * reg['tolerance']:g} % of FE"
            )
            marks_html = f"<div id='marks' style='color:#2e7d32'>✓ inside the calibrated domain{inside}</div>"
        self.numbers.text = numbers + marks_html  # one write: one patch, one re-render
        s = out["surrogate"]
        building = self.job is not None and self.job_kind == "rom" and not self.job.done
        if s is not None:
            self.surrogate.text = (
                f"<span id='surrogate'>surrogate (FE within its bound): α = {_urad(s['alpha_rad'])} ± "
                f"{_urad(s['alpha_bound_rad'])} µrad, β = {_urad(s['beta_rad'])} ± "
                f"{_urad(s['beta_bound_rad'])} µrad</span>"
            )
            self.rom_button.visible = False
        elif not building:
            note = "outside the surrogate's domain" if rom is not None else why
            self.surrogate.text = f"<span id='surrogate' style='color:#666'>surrogate: {note}</span>"
            self.rom_button.visible = rom is None and d.is_default_geometry() and d.joint == "bonded"
        self._static = out

    def update_bode(self) -> None:
        b = state.chain_bode(self.design)
        self.bode_src.data = dict(
            f=b["freq_hz"],
            a=b["alpha_rad_abs"],
            b=b["beta_rad_abs"],
            pa=b["alpha_rad_phase_deg"],
            pb=b["beta_rad_phase_deg"],
        )

    def update_ear(self) -> None:
        e = state.ear_velocity(self.design)
        self.ear_src.data = dict(f=e["freq_hz"], hv=e["h_v_abs"], ddb=e["delta_db"], ddeg=e["delta_deg"])
        lo, hi = e["band_hz"]
        for band in (self.ear_band, self.ear_delta_band):
            band.left, band.right = lo, hi
        if e["source"] == "lumped ear":
            self.ear_note.text = (
                f"<span id='ear'>{e['source']}, valid {lo:g}–{hi:g} Hz (shaded; docs/ear.md §5.10). "
                "Its ΔH_V misses the joint's axial, bending and torsional compliances "
                "(docs/transmission.md §12.5): read it as a lower bound of the joint's cost.</span>"
            )
        else:
            self.ear_note.text = f"<span id='ear'>{e['source']}, {lo:g}–{hi:g} Hz</span>"

    def update_map(self) -> None:
        x, y = self.map_x.value, self.map_y.value
        if x == y:
            raise IsjError(f"map axes: x and y are both {x}; choose two different moduli")
        m = state.ratio_map(self.design, x, y)
        lx, ly = np.log10(m["x"]), np.log10(m["y"])
        z = np.log10(m["ratio"])
        self.map_src.data = dict(image=[z], x=[lx[0]], y=[ly[0]], dw=[lx[-1] - lx[0]], dh=[ly[-1] - ly[0]])
        cx, cy = m["current"]
        self.map_dot.data = dict(x=[math.log10(cx)], y=[math.log10(cy)])
        self.map_mapper.low, self.map_mapper.high = float(z.min()), float(z.max())
        self.map.xaxis.axis_label, self.map.yaxis.axis_label = f"log10 {x} (Pa)", f"log10 {y} (Pa)"
        self.map_info.text = (
            f"<span id='map'>β/α from {10 ** z.min():.3g} to {10 ** z.max():.3g} over {x} × {y}; "
            f"× marks the design (β/α = {self._static['beta_over_alpha']:.{DIGITS}g})</span>"
        )

    def update_uq(self) -> None:
        try:
            samples = int(self.uq_samples.value)
        except ValueError:
            raise IsjError(
                f"samples = {_short(self.uq_samples.value)}: not an integer in [1000, {state.MAX_UQ_SAMPLES}]"
            ) from None
        try:
            factor = float(self.uq_factor.value)
        except ValueError:
            raise IsjError(
                f"lognormal factor = {_short(self.uq_factor.value)}: not a number in (1, {math.exp(3):.4g}]"
            ) from None
        kinds = {k: w.value for k, w in self.uq_kinds.items()}
        if all(v == "fixed" for v in kinds.values()):
            self.uq_src.data = dict(left=[], right=[], top=[])
            self.uq_info.text = "<span id='uq'>every modulus fixed: no uncertainty</span>"
            return
        u = state.uncertainty(self.design, kinds, factor, samples)
        e = u["log10_edges"]
        self.uq_src.data = dict(left=e[:-1], right=e[1:], top=u["counts"])
        lo, hi = u["p_interval"]
        self.uq_info.text = (
            f"<span id='uq'>P(β/α > 1) = <b>{u['p_gt_1']:.4f}</b> (95 % interval {lo:.4f}–{hi:.4f}, "
            f"{u['samples']} draws, lumped model)</span>"
        )

    def update_export(self) -> None:
        try:
            r = self.fe_resolution()
        except IsjError:  # shown when typed; the case file keeps the calibration's
            r = _calibration_mesh()[1]
        text = state.case_toml(self.design, r)
        self.case_src.data = dict(text=[text])
        from html import escape

        self.case_div.text = (
            f"<pre id='case' style='background:#f6f6f6;padding:6px'>{escape(text)}</pre>"
            f"<div>then: <code>{escape(state.report_command())}</code></div>"
            "<div>Plots: the save tool of each plot's toolbar writes PNG, or SVG with "
            "'plots save as: svg'.</div>"
        )

    # ---- background jobs ----------------------------------------------------------------------

    def fe_resolution(self) -> float:
        """The FE mesh resolution typed in; one line (:class:`IsjError`) outside ``jobs.RESOLUTION_RANGE``."""
        lo, hi = jobs.RESOLUTION_RANGE
        text = self.fe_res.value
        try:
            res = float(str(text).strip())
        except ValueError:
            raise IsjError(f"FE mesh resolution = {_short(text)}: not a number in [{lo:g}, {hi:g}]") from None
        if not (math.isfinite(res) and lo <= res <= hi):
            raise IsjError(f"FE mesh resolution = {str(text)[:40]}: must be in [{lo:g}, {hi:g}]")
        return res

    def on_fe_res(self, text: str) -> None:
        self._stale.add("update_export")
        self.fe_resolution()  # a bad value is one line now, not only when Verify is pressed
        self.say("", error=False)

    def on_verify(self) -> None:
        def go():
            if self.job is not None and not self.job.done:
                raise IsjError("a background job is running; wait for it to finish")
            res = self.fe_resolution()
            d = self.design
            order = _calibration_mesh()[0]
            payload = dict(
                moduli=dict(d.moduli),
                geometry=dict(d.dims),
                joint=d.joint,
                pressure_pa=d.pressure_pa,
                order=order,
                resolution=res,
            )
            self.fe_design = d
            self.say("", error=False)
            self._start(jobs.fe_job(payload), "fe")

        self.guarded(go)

    def on_build_rom(self) -> None:
        def go():
            if self.job is not None and not self.job.done:
                raise IsjError("a background job is running; wait for it to finish")
            self._start(jobs.rom_build_job(*_calibration_mesh()), "rom")

        self.guarded(go)

    def _start(self, job: jobs.Job, kind: str) -> None:
        self.job, self.job_kind = job, kind
        self.fe_button.disabled = self.rom_button.disabled = True
        self._progress()
        self._poll = self.doc.add_periodic_callback(self._progress, 250)

    def _progress(self) -> None:
        job = self.job
        if job is None:
            return
        from html import escape

        target = self.fe_div if self.job_kind == "fe" else self.surrogate
        sid = "fe" if self.job_kind == "fe" else "surrogate"
        if not job.done:
            what = "FE solve" if self.job_kind == "fe" else "building the surrogate (minutes, once)"
            line = escape(job.last_line[-160:])
            target.text = f"<span id='{sid}-progress'>{what}: {job.elapsed_s:.0f} s … {line}</span>"
            return
        if self._poll is not None:
            self.doc.remove_periodic_callback(self._poll)
            self._poll = None
        self.fe_button.disabled = self.rom_button.disabled = False
        if self.job_kind == "fe":
            r = job.result
            if r is None:
                self.fe_div.text = (
                    f"<span id='fe' style='color:#b00020'>FE failed: {escape(job.last_line)}</span>"
                )
            else:
                lum = state.static_outputs(self.fe_design)
                err_a = lum["alpha_rad"] / r["alpha_rad"] - 1
                err_b = lum["beta_rad"] / r["beta_rad"] - 1
                self.fe_div.text = (
                    f"<span id='fe'>FE (P{_calibration_mesh()[0]}, resolution {self.fe_res.value}, "
                    f"{r['n_dofs']} dofs, {r['seconds']:.1f} s): α = <b><span id='fe-alpha'>"
                    f"{_urad(r['alpha_rad'])}</span></b> µrad, β = <b><span id='fe-beta'>"
                    f"{_urad(r['beta_rad'])}</span></b> µrad; "
                    f"lumped − FE: α {100 * err_a:+.2f} %, β {100 * err_b:+.2f} %"
                    + ("" if self.fe_design == self.design else " (for the design when Verify was pressed)")
                    + "</span>"
                )
        else:
            cached_rom(refresh=True)
            if job.returncode != 0:
                self.surrogate.text = (
                    f"<span id='surrogate'>surrogate build failed: {escape(job.last_line)}</span>"
                )
            self.update_numbers()

    def _destroyed(self, session_context) -> None:
        if self.job is not None:
            self.job.cancel()


def warm_up() -> None:
    """Look the surrogate up (it meshes once) and run every output once (imports, caches), at start."""
    try:
        cached_rom()
        d = state.Design()
        state.chain_bode(d)
        state.ear_velocity(d)
        state.uncertainty(d, {k: "loguniform" for k in state.MODULI}, 2.0, 1000)
    except Exception:  # noqa: BLE001 - a failure here shows again, as one line, in the page
        log.exception("isj app: warm-up failed")


def make_document(doc) -> None:
    """Bokeh's entry: lay out one session's page in ``doc``."""
    Session(doc)


def serve(host: str = "127.0.0.1", port: int = 5006, open_browser: bool = True, on_ready=None) -> None:
    """Run the app on ``host:port`` until Ctrl-C or SIGTERM; every job is cancelled on the way out.

    ``on_ready(url)`` is called once the server listens.
    """
    import signal

    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server

    origins = [f"{host}:{port}", f"127.0.0.1:{port}", f"localhost:{port}"]
    server = Server(
        {"/": Application(FunctionHandler(make_document))},
        address=host,
        port=port,
        allow_websocket_origin=origins,
        num_procs=1,
        check_unused_sessions_milliseconds=500,
        unused_session_lifetime_milliseconds=2000,
    )
    server.start()
    loop = server.io_loop
    url = f"http://{host}:{port}/"

    def stop(*_):
        loop.add_callback_from_signal(loop.stop)

    signal.signal(signal.SIGTERM, stop)
    threading.Thread(target=warm_up, daemon=True).start()
    if on_ready is not None:
        on_ready(url)
    if open_browser:
        loop.add_callback(server.show, "/")
    try:
        loop.start()
    except KeyboardInterrupt:
        pass
    finally:
        jobs.cancel_all()
        server.stop()
