"""Measure tab: arm/stop, live view with the trigger level, each hit with its verdict and Accept/Reject, its force
spectrum with the usable band, an overlay of the accepted hits, and the running H1 (grey outside the usable band) and
coherence."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtGui import QAction, QColor, QKeySequence
from PySide6.QtWidgets import (
    QAbstractItemView,
    QPlainTextEdit,
    QCheckBox,
    QGroupBox,
    QHeaderView,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSizePolicy,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from gasfilm.analysis.spectra import CAUTION_DROP_DB, force_level_db, usable_band_hz
from gasfilm.analysis.spectra import session_frf
from gasfilm.app.gui.controller import SessionController
from gasfilm.app.gui.settings import SIM_TIPS
from gasfilm.app.gui.widgets import (
    ACCEPTED_COLOR,
    MEASURED_COLOR,
    PALETTE,
    PENDING_COLOR,
    REJECTED_COLOR,
    FixedHeightLabel,
    make_plot,
    pen,
    set_region_hz,
    show_legend_only_with_data,
)
from gasfilm.app.gui.workers import HitEntry
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2, ChannelKind

REDRAW_INTERVAL_MS = 40  # 25 frames per second
#: Where the force window's cursor sits on the selected hit while the window is off (dragging it switches it on).
DRAG_START_FORCE_WINDOW_MS = 5.0
#: While a fit or diagnosis runs, the live view draws 5 frames per second: the drawing shares the Python interpreter
#: with the job, which then runs nearly as fast as on the command line (benchmarks/bench_gui_jobs.py).
BUSY_REDRAW_INTERVAL_MS = 200
_STATE_STYLE = {
    "idle": ("STOPPED", "#666666"),
    "starting": ("STARTING…", "#0b5394"),
    "armed": ("ARMED — waiting for a hit", "#1b7f3b"),
    "triggered": ("TRIGGERED — recording", "#b3261e"),
    "stopping": ("STOPPING…", "#666666"),
}
OUTSIDE_BAND_COLOR = "#bbbbbb"
BAND_BRUSH = (0, 114, 178, 25)
OVERLAY_PULSE_MS = (-2.0, 10.0)
LIVE_FORCE_TITLE = "Live: force"
LIVE_RESPONSE_TITLE = "Live: response"
#: The live force view reaches this far past the trigger level, so the dashed line and its label stay inside.
TRIGGER_HEADROOM = 1.25  # force pulses are overlaid from 2 ms before to 10 ms after the trigger
_HIT_COLUMNS = ("Hit", "Time (s)", "Peak force (N)", "Verdict", "Reasons")
#: The technician's keys at the rig (a foot switch is set up to send one of them). Shown in the Measure menu and in
#: the buttons' tooltips; they work wherever the focus is in the window, except while typing in a text field.
SHORTCUTS = {
    "hit_check": "F4",
    "arm": "F5",
    "stop": "F6",
    "accept": "A",
    "reject": "R",
    "undo": "Ctrl+Z",
    "accept_pending": "Shift+A",
}


def stacked(*widgets: QWidget) -> QWidget:
    """The widgets one above the other, without margins."""
    box = QWidget()
    layout = QVBoxLayout(box)
    layout.setContentsMargins(0, 0, 0, 0)
    for widget in widgets:
        layout.addWidget(widget, 0 if isinstance(widget, QLabel) else 1)
    return box


def verdict_text(entry: HitEntry) -> tuple[str, str]:
    """The verdict in the words every view uses (the report and ``replay`` say "by hand" too)."""
    if entry.pending:
        return "pending", PENDING_COLOR
    if entry.verdict.accepted:
        return ("accepted (by hand)" if entry.verdict.overridden else "accepted"), ACCEPTED_COLOR
    return ("rejected (by hand)" if entry.verdict.overridden else "rejected"), REJECTED_COLOR


class MeasureTab(QWidget):
    """The technician's main screen while hitting the structure."""

    apply_hit_check = Signal()  # the technician accepts the hit check's proposal (the window applies it to Setup)
    window_dragged = Signal(dict)  # window settings changed by dragging a window's cursor on the selected hit

    def __init__(self, controller: SessionController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.controller = controller
        self.redraw_count = 0
        self.redraw_seconds = 0.0
        self._first_redraw_s: float | None = None

        self.hit_check_button = QPushButton("Hit check")
        self.hit_check_button.setObjectName("hit_check")
        self.arm_button = QPushButton("Arm")
        self.arm_button.setObjectName("arm")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setObjectName("stop")
        self.state_label = QLabel()
        self.state_label.setMinimumWidth(260)
        self.counter_label = QLabel()
        self.accept_pending_button = QPushButton("Accept all pending")
        self.accept_pending_button.setObjectName("accept_pending")
        self.hammer_buttons: dict[str, QPushButton] = {}
        hammer_box = QGroupBox("Virtual hammer (simulated rig)")
        hammer_layout = QHBoxLayout(hammer_box)
        hammer_layout.setContentsMargins(6, 2, 6, 2)
        for tip in SIM_TIPS:
            button = QPushButton(f"Hit: {tip} tip")
            button.setObjectName(f"hit_{tip}")
            button.clicked.connect(lambda _=False, t=tip: controller.virtual_hit(t))
            hammer_layout.addWidget(button)
            self.hammer_buttons[tip] = button
        self.hammer_box = hammer_box
        top = QHBoxLayout()
        top.addWidget(self.hit_check_button)
        top.addWidget(self.arm_button)
        top.addWidget(self.stop_button)
        top.addWidget(self.state_label)
        top.addWidget(self.counter_label, 1)
        top.addWidget(self.accept_pending_button)
        top.addWidget(hammer_box)

        # Time runs to 0 = now on a fixed axis, and the live plots have no grid: their axes are then not redrawn
        # with every frame, which keeps the view at 25 fps with 4 channels at 51.2 kS/s.
        # The channels are named in the titles, in their colours: a legend box would hide the newest hits.
        self.force_plot = make_plot(
            LIVE_FORCE_TITLE, ("Force", "N"), ("Time before now", "s"), grid=False, legend=False
        )
        self.response_plot = make_plot(
            LIVE_RESPONSE_TITLE, ("Acceleration", "m/s²"), ("Time before now", "s"), grid=False, legend=False
        )
        self.response_plot.setXLink(self.force_plot)
        self.force_plot.getPlotItem().enableAutoRange(x=False)
        self.response_plot.getPlotItem().enableAutoRange(x=False)
        self.trigger_line = pg.InfiniteLine(
            angle=0, pen=pen(REJECTED_COLOR, 1.0, Qt.PenStyle.DashLine), label="trigger {value:g} N",
            labelOpts={"position": 0.08, "color": REJECTED_COLOR, "anchors": [(0, 1), (0, 1)]},
        )
        self.trigger_line.setVisible(False)
        self.force_plot.addItem(self.trigger_line, ignoreBounds=True)
        # Invisible, but in the force view's autorange: the trigger level stays on the scale between hits, when the
        # force is only noise in mN.
        self.trigger_span = pg.PlotDataItem(pen=pg.mkPen((0, 0, 0, 0)))  # transparent: drawn, so autoranged
        self.force_plot.addItem(self.trigger_span)
        self._live_curves: list[pg.PlotDataItem] = []
        live = stacked(self.force_plot, self.response_plot)

        self.hit_table = QTableWidget(0, len(_HIT_COLUMNS))
        self.hit_table.setHorizontalHeaderLabels(_HIT_COLUMNS)
        self.hit_table.verticalHeader().setVisible(False)
        self.hit_table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.hit_table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.hit_table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        header = self.hit_table.horizontalHeader()
        for column in range(len(_HIT_COLUMNS) - 1):
            header.setSectionResizeMode(column, QHeaderView.ResizeMode.ResizeToContents)
        header.setStretchLastSection(True)
        self.hit_table.setWordWrap(True)  # long reasons wrap inside their row instead of being cut off
        self.hit_table.verticalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.hit_table.itemSelectionChanged.connect(self._show_selected_hit)
        self.verdict_label = FixedHeightLabel("No hit yet", lines=2)  # a long reason list moves nothing
        self.verdict_label.setWordWrap(True)
        self.accept_button = QPushButton("Accept hit")
        self.accept_button.setObjectName("accept")
        self.reject_button = QPushButton("Reject hit")
        self.reject_button.setObjectName("reject")
        for button in (self.accept_button, self.reject_button):
            button.setEnabled(False)  # until a hit is selected
        self.hit_plot = make_plot(
            "Selected hit: <span style='color:#0072B2'>force</span> · "
            "<span style='color:#D55E00'>response</span>",
            ("Force", "N"),
            ("Time in record", "s"),
            legend=False,
        )
        self.hit_force_curve = self.hit_plot.plot(pen=pen(PALETTE[0]), name="force")
        self.hit_response_view = pg.ViewBox()
        hit_item = self.hit_plot.getPlotItem()
        hit_item.showAxis("right")
        hit_item.scene().addItem(self.hit_response_view)
        hit_item.getAxis("right").linkToView(self.hit_response_view)
        hit_item.getAxis("right").setLabel("Acceleration", units="m/s²")
        hit_item.getAxis("right").enableAutoSIPrefix(False)
        self.hit_response_view.setXLink(hit_item)
        self.hit_response_curve = pg.PlotDataItem(pen=pen(PALETTE[1]))
        self.hit_response_curve.setDownsampling(auto=True, method="peak")
        self.hit_response_curve.setClipToView(True)
        self.hit_response_view.addItem(self.hit_response_curve)
        hit_item.vb.sigResized.connect(lambda: self.hit_response_view.setGeometry(hit_item.vb.sceneBoundingRect()))
        # The windows on the trace: the force window's end and the exponential window's time constant are cursors;
        # dragging one sets the window (Setup ▸ Windows) and the FRF follows at once.
        self.force_window_curve = pg.PlotDataItem(pen=pen(PALETTE[0], 1.0, Qt.PenStyle.DotLine))
        self.hit_plot.addItem(self.force_window_curve, ignoreBounds=True)
        self.exp_window_curve = pg.PlotDataItem(pen=pen(PALETTE[1], 1.0, Qt.PenStyle.DotLine))
        self.hit_response_view.addItem(self.exp_window_curve, ignoreBounds=True)
        self.force_window_line = pg.InfiniteLine(
            angle=90, movable=True, pen=pen(PALETTE[0], 2.0, Qt.PenStyle.DashLine), hoverPen=pen(PALETTE[0], 3.0),
            label="", labelOpts={"position": 0.92, "color": PALETTE[0], "anchors": [(0, 1), (0, 1)]})
        self.exp_window_line = pg.InfiniteLine(
            angle=90, movable=True, pen=pen(PALETTE[1], 2.0, Qt.PenStyle.DashLine), hoverPen=pen(PALETTE[1], 3.0),
            label="", labelOpts={"position": 0.8, "color": PALETTE[1], "anchors": [(1, 1), (1, 1)]})  # (text left of
        # the line: the time constant is late in the record, and a label right of it ran off the plot)
        self.force_window_line.setToolTip("Force window: drag its end (the force after it is set to 0)")
        self.exp_window_line.setToolTip("Exponential window: drag its time constant τ (the window is 1/e there)")
        # (the cursors join the plot with the first hit shown: hidden lines with labels would relayout the tab on
        # every show)
        self.force_window_line.sigPositionChanged.connect(self._force_window_dragged)
        self.exp_window_line.sigPositionChanged.connect(self._exp_window_dragged)
        self._dragged_window: dict = {}
        self._window_timer = QTimer(self)
        self._window_timer.setSingleShot(True)
        self._window_timer.setInterval(80)  # a drag redraws the FRF at most about 12 times a second
        self._window_timer.timeout.connect(self._apply_dragged_window)
        hits = QWidget()
        hits_layout = QVBoxLayout(hits)
        hits_layout.setContentsMargins(0, 0, 0, 0)
        hits_layout.addWidget(self.hit_table, 2)
        hits_layout.addWidget(self.verdict_label)
        buttons = QHBoxLayout()
        buttons.addWidget(self.accept_button)
        buttons.addWidget(self.reject_button)
        hits_layout.addLayout(buttons)
        self.spectrum_plot = make_plot(
            "Force spectrum: selected hit · average of accepted", ("Force level", "dB re low f"), legend=True
        )
        self.spectrum_plot.getPlotItem().getAxis("left").enableAutoSIPrefix(False)
        self.hit_spectrum_curve = self.spectrum_plot.plot(pen=pen(PALETTE[0]), name="selected hit")
        self.mean_spectrum_curve = self.spectrum_plot.plot(
            pen=pen(MEASURED_COLOR, 1.0, Qt.PenStyle.DashLine), name="accepted hits"
        )
        self.drop_lines = {}
        for drop_db, style in ((CAUTION_DROP_DB, Qt.PenStyle.DotLine), (controller.setup.usable_drop_db, Qt.PenStyle.DashLine)):
            line = pg.InfiniteLine(
                pos=-drop_db, angle=0, pen=pen(REJECTED_COLOR, 1.0, style), label=f"−{drop_db:g} dB",
                labelOpts={"position": 0.95, "color": REJECTED_COLOR},
            )
            self.spectrum_plot.addItem(line, ignoreBounds=True)
            self.drop_lines[drop_db] = line
        self.spectrum_band = pg.LinearRegionItem(brush=pg.mkBrush(*BAND_BRUSH), movable=False)
        self.spectrum_band.setZValue(-10)
        self.spectrum_plot.addItem(self.spectrum_band, ignoreBounds=True)
        self.spectrum_plot.setYRange(-45, 5)
        # Room for three lines, whatever the text: the page never asks for more height than the other views.
        self.spectrum_label = FixedHeightLabel(lines=3)
        spectrum_page = stacked(self.spectrum_plot, self.spectrum_label)

        self.overlay_force_plot = make_plot(
            "Accepted hits: force pulses", ("Force", "N"), ("Time from trigger", "s"), legend=False
        )
        self.overlay_response_plot = make_plot(
            "Accepted hits: responses", ("Acceleration", "m/s²"), ("Time from trigger", "s"), legend=False
        )
        self._overlay_curves: list[pg.PlotDataItem] = []
        self._mixed_tips_said = False
        self.mixed_tips_warning = ""
        overlay_page = stacked(self.overlay_force_plot, self.overlay_response_plot)

        self.hit_views = QTabWidget()
        self.hit_views.addTab(self.hit_plot, "Selected hit")
        self.hit_views.addTab(spectrum_page, "Force spectrum")
        overlay_tab = self.hit_views.addTab(overlay_page, "Accepted hits")  # (short: the four labels fit whole)
        self.hit_views.setTabToolTip(overlay_tab, "The accepted hits' force pulses and responses overlaid")
        self.hit_check_page = self._make_hit_check_page()
        self.hit_views.addTab(self.hit_check_page, "Hit check")
        # The hit list and the views share the column 2 : 3 whatever the views' pages ask for: switching to the
        # force spectrum moves nothing.
        for widget in (self.hit_table, self.hit_views):
            policy = widget.sizePolicy()
            policy.setVerticalPolicy(QSizePolicy.Policy.Ignored)
            widget.setSizePolicy(policy)
        hits_layout.addWidget(self.hit_views, 3)

        self.h1_plot = make_plot("Running H1", ("|H1|", "g/N"), log_y=True)  # as every other tab and the CLI
        self.coherence_plot = make_plot("Coherence", ("γ²", ""), legend=False)
        self.coherence_plot.setXLink(self.h1_plot)
        self.coherence_plot.setYRange(0, 1.05)
        self.h1_curve = self.h1_plot.plot(pen=pen(MEASURED_COLOR), name="H1 in the usable band")
        self.h1_outside_curve = self.h1_plot.plot(pen=pen(OUTSIDE_BAND_COLOR, 1.0), name="outside (force too low)")
        self.coherence_curve = self.coherence_plot.plot(pen=pen(PALETTE[2]), name="γ²")
        self.h1_band = pg.LinearRegionItem(brush=pg.mkBrush(*BAND_BRUSH), movable=False)
        self.h1_band.setZValue(-10)
        self.h1_plot.addItem(self.h1_band, ignoreBounds=True)
        self.log_frequency = QCheckBox("Logarithmic frequency axes")
        self.log_frequency.setObjectName("log_frequency")
        self.log_frequency.toggled.connect(self._set_log_frequency)
        self.usable_label = QLabel()
        frf = QWidget()
        frf_layout = QVBoxLayout(frf)
        frf_layout.setContentsMargins(0, 0, 0, 0)
        frf_row = QHBoxLayout()
        frf_row.addWidget(self.log_frequency)
        frf_row.addStretch(1)
        frf_row.addWidget(self.usable_label)
        frf_layout.addLayout(frf_row)
        frf_layout.addWidget(self.h1_plot)
        frf_layout.addWidget(self.coherence_plot)

        splitter = QSplitter(Qt.Orientation.Horizontal)
        splitter.addWidget(live)
        splitter.addWidget(hits)
        splitter.addWidget(frf)
        splitter.setSizes([500, 420, 420])
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(splitter, 1)

        self.actions_by_name = self._make_actions()

        self.redraw_timer = QTimer(self)
        self.redraw_timer.setInterval(REDRAW_INTERVAL_MS)
        self.redraw_timer.timeout.connect(self.redraw_live)

        controller.acquisition_state.connect(self._on_state)
        controller.streaming.connect(self._on_streaming)
        controller.hits_reset.connect(self._rebuild_hits)
        controller.hit_added.connect(self._on_hit_added)
        controller.hit_changed.connect(self._on_hit_changed)
        controller.frf_changed.connect(self._on_frf)
        controller.session_changed.connect(self._clear_live)
        controller.job_running.connect(self._pace_live_view)
        controller.hit_check_changed.connect(self._on_hit_check)
        self._on_state("idle")
        self._update_counter()
        self._on_frf(None)

    def _make_actions(self) -> dict[str, QAction]:
        """The Measure menu's actions with their keys (:data:`SHORTCUTS`), and the buttons that trigger them, each
        button's tooltip naming its key."""
        c = self.controller
        spec = {
            "hit_check": ("&Hit check", "Hit check: tap a few times (nothing is recorded) for the trigger level, force "
                          "range, tip, windows and record length", c.start_hit_check, self.hit_check_button),
            "arm": ("&Arm", "Arm: record every hit into the session", c.arm, self.arm_button),
            "stop": ("&Stop", "Stop the acquisition (every hit is already stored)", c.stop, self.stop_button),
            "accept": ("A&ccept hit", "Accept the hit that waits for you (else the selected hit)",
                       lambda: self.decide_by_key(True), self.accept_button),
            "reject": ("&Reject hit", "Reject the hit that waits for you (else the selected hit)",
                       lambda: self.decide_by_key(False), self.reject_button),
            "undo": ("&Undo last hit", "Take the newest accepted hit out of the average (rejected by hand)",
                     self.undo_last_hit, None),
            "accept_pending": ("Accept all &pending", "Accept every hit that waits for your decision",
                               c.accept_all_pending, self.accept_pending_button),
        }
        actions = {}
        for name, (text, tip, slot, button) in spec.items():
            action = QAction(text, self)
            action.setObjectName(f"{name}_action")
            action.setShortcut(QKeySequence(SHORTCUTS[name]))
            action.setShortcutContext(Qt.ShortcutContext.WindowShortcut)
            key = action.shortcut().toString(QKeySequence.SequenceFormat.NativeText)
            action.setToolTip(f"{tip} ({key})")
            action.triggered.connect(lambda _=False, run=slot: run())
            self.addAction(action)  # the key works whichever tab is shown
            if button is not None:
                button.setToolTip(f"{tip} ({key})")
                button.clicked.connect(action.trigger)
            actions[name] = action
        return actions

    # --- live view ---------------------------------------------------------------------------------------------------

    def _on_streaming(self, loop: object) -> None:
        if loop is None:
            self.redraw_timer.stop()
            return
        config = self.controller.running_config()
        self._clear_live()
        self._live_curves = []
        names: dict[str, list[str]] = {"force": [], "response": []}
        response_number = 0
        for channel in config.channels:
            if channel.kind is ChannelKind.FORCE:
                color, plot, group = PALETTE[0], self.force_plot, "force"
            else:
                color, plot, group = PALETTE[1 + response_number], self.response_plot, "response"
                response_number += 1
            curve = plot.plot(pen=pen(color, 1.0))
            names[group].append(f"<span style='color:{color}'>{channel.label}</span>")
            curve.setDownsampling(auto=True, method="peak")
            curve.setClipToView(True)
            curve.setSkipFiniteCheck(True)
            self._live_curves.append(curve)
        self.force_plot.setTitle(f"{LIVE_FORCE_TITLE}: {', '.join(names['force'])}")
        self.response_plot.setTitle(f"{LIVE_RESPONSE_TITLE}: {', '.join(names['response'])}")
        level_n = self.controller.running_trigger().level_n
        live_s = self.controller.setup.live_view_s
        self.trigger_line.setVisible(True)  # first: a hidden line's label does not follow its value
        self.trigger_line.setValue(level_n)
        self.trigger_span.setData([-live_s, -live_s], [0.0, TRIGGER_HEADROOM * level_n])
        self.force_plot.setXRange(-live_s, 0.0, padding=0.0)
        self.redraw_count = 0
        self.redraw_seconds = 0.0
        self._first_redraw_s = None
        self._pace_live_view()
        self.redraw_timer.start()

    def _pace_live_view(self, *_: object) -> None:
        """25 frames per second, or 5 while a background job runs (it needs the interpreter more than the eye)."""
        busy = any(self.controller.job_active(name) for name in ("fit", "diagnose"))
        self.redraw_timer.setInterval(BUSY_REDRAW_INTERVAL_MS if busy else REDRAW_INTERVAL_MS)

    def _clear_live(self, *_: object) -> None:
        """Empty the live plots (a new stream, or another session opened)."""
        for curve in self._live_curves:
            for plot in (self.force_plot, self.response_plot):
                if curve in plot.getPlotItem().listDataItems():
                    plot.removeItem(curve)
        self.force_plot.setTitle(LIVE_FORCE_TITLE)
        self.response_plot.setTitle(LIVE_RESPONSE_TITLE)
        self._live_curves = []
        self.trigger_line.setVisible(False)
        self.trigger_span.setData([], [])

    def redraw_live(self) -> None:
        """Timer slot: draw the newest samples from the ring buffer (peak-downsampled, clipped to view)."""
        started = time.perf_counter()
        snapshot = self.controller.live_samples(self.controller.setup.live_view_s)
        if snapshot is None:
            return
        time_s, data = snapshot
        before_now_s = time_s - time_s[-1]
        for curve, row in zip(self._live_curves, data):
            curve.setData(before_now_s, row)
        self.redraw_count += 1
        now = time.perf_counter()
        self.redraw_seconds += now - started
        if self._first_redraw_s is None:
            self._first_redraw_s = now

    def redraw_rate_hz(self) -> float:
        if self._first_redraw_s is None or self.redraw_count < 2:
            return 0.0
        return (self.redraw_count - 1) / max(1e-9, time.perf_counter() - self._first_redraw_s)

    # --- state and counters -------------------------------------------------------------------------------------------

    def _on_state(self, state: str) -> None:
        text, color = _STATE_STYLE.get(state, (state.upper(), "#666666"))
        if self.controller.hit_checking and state in ("armed", "triggered"):
            text, color = "HIT CHECK — tap; nothing is recorded", "#6a3d9a"
        if self.controller.hit_checking and state == "starting":
            self.hit_views.setCurrentWidget(self.hit_check_page)
        elif state == "starting" and self.hit_views.currentWidget() is self.hit_check_page:
            self.hit_views.setCurrentWidget(self.hit_plot)  # the test proper: its hits, not the check's taps
        # the proposal applies to the Setup tab: not while a recording runs (it would stop it)
        self.apply_proposal_button.setEnabled(self.controller.hit_check_proposal is not None
                                              and (state == "idle" or self.controller.hit_checking))
        # during a hit check the (empty) hit list gives its room to the taps and the proposal
        checking = self.controller.hit_checking
        for widget in (self.hit_table, self.verdict_label, self.accept_button, self.reject_button):
            widget.setVisible(not checking)
        self.state_label.setText(text)
        self.state_label.setStyleSheet(
            f"QLabel {{ color: white; background: {color}; border-radius: 4px; padding: 4px 10px; font-weight: 700; }}"
        )
        running = state != "idle"
        self.arm_button.setEnabled(not running)
        self.hit_check_button.setEnabled(not running)
        self.stop_button.setEnabled(running)
        self.actions_by_name["hit_check"].setEnabled(not running)
        self.actions_by_name["arm"].setEnabled(not running)
        self.actions_by_name["stop"].setEnabled(running)
        self.hammer_box.setVisible(self.controller.is_simulated)
        self.hammer_box.setEnabled(running and state != "starting")

    def _update_counter(self) -> None:
        c = self.controller
        target = c.setup.target_averages
        self.counter_label.setText(
            f"  Hits: {len(c.hits)}   ·   accepted {c.accepted_count}" + (f" of {target}" if target else "")
            + f"   ·   rejected {c.rejected_count}"
            + (f"   ·   waiting for you {c.pending_count}" if c.pending_count else "")
        )
        self.accept_pending_button.setEnabled(c.pending_count > 0)

    # --- hit list ---------------------------------------------------------------------------------------------------

    def _rebuild_hits(self) -> None:
        self._mixed_tips_said = False
        self.hit_table.setRowCount(0)
        for entry in self.controller.hits:
            self._append_row(entry)
        self._update_counter()
        if self.controller.hits:
            self.hit_table.selectRow(self.hit_table.rowCount() - 1)
        else:
            self.verdict_label.setText("No hit yet")
            self.accept_button.setEnabled(False)  # nothing to decide on
            self.reject_button.setEnabled(False)
            self.hit_force_curve.setData([], [])
            self.hit_response_curve.setData([], [])
            self.hit_spectrum_curve.setData([], [])
            show_legend_only_with_data(self.spectrum_plot)
        self._draw_overlay()

    def _append_row(self, entry: HitEntry) -> None:
        row = self.hit_table.rowCount()
        self.hit_table.insertRow(row)
        self._fill_row(row, entry)

    def _fill_row(self, row: int, entry: HitEntry) -> None:
        record = entry.record
        verdict, color = verdict_text(entry)
        values = (
            str(entry.index + 1),
            f"{record.trigger_time_s:.2f}",
            f"{np.max(np.abs(record.force_n)):.0f}",
            verdict,
            ", ".join(entry.automatic.reasons) or "—",
        )
        for column, value in enumerate(values):
            item = QTableWidgetItem(value)
            item.setToolTip(value)
            if column == 0:
                item.setData(Qt.ItemDataRole.UserRole, entry.index)
            if column == 3:
                item.setForeground(QColor(color))
            self.hit_table.setItem(row, column, item)

    def _row_of(self, index: int) -> int:
        for row in range(self.hit_table.rowCount()):
            if self.hit_table.item(row, 0).data(Qt.ItemDataRole.UserRole) == index:
                return row
        return -1

    def _on_hit_added(self, entry: HitEntry) -> None:
        self._append_row(entry)
        self.hit_table.selectRow(self.hit_table.rowCount() - 1)
        self.hit_table.scrollToBottom()
        self._update_counter()
        self._draw_overlay()

    def _on_hit_changed(self, entry: HitEntry) -> None:
        row = self._row_of(entry.index)
        if row >= 0:
            self._fill_row(row, entry)
        self._update_counter()
        if self.selected_index() == entry.index:
            self._show_selected_hit()
        self._draw_overlay()

    def _draw_overlay(self) -> None:
        """Every accepted hit's force pulse and response on one time axis from its trigger: the odd one stands out."""
        self.overlay_force_plot.clear()
        self.overlay_response_plot.clear()
        self._overlay_curves = []
        accepted = [entry for entry in self.controller.hits if entry.accepted]
        for number, entry in enumerate(accepted):
            record = entry.record
            t_s = (np.arange(record.n_samples) - record.trigger_index) / record.sample_rate_hz
            pulse = (t_s >= OVERLAY_PULSE_MS[0] / 1e3) & (t_s <= OVERLAY_PULSE_MS[1] / 1e3)
            color = PALETTE[number % len(PALETTE)]
            force = self.overlay_force_plot.plot(t_s[pulse], record.force_n[pulse], pen=pen(color, 1.0))
            response = self.overlay_response_plot.plot(t_s, record.response, pen=pen(color, 1.0))
            for curve in (force, response):
                curve.setToolTip(f"hit {entry.index + 1}")
            self._overlay_curves += [force, response]
        from gasfilm.analysis.hit_check import mixed_tips

        titles = f"{len(accepted)} accepted hits"
        warning = mixed_tips([entry.record for entry in accepted])
        self.overlay_force_plot.setTitle(f"Force pulses of the {titles}" + (
            f" — <span style='color:{REJECTED_COLOR}'>{warning.split(':')[0]}</span>" if warning else ""))
        self.overlay_response_plot.setTitle(f"Responses of the {titles}")
        if warning and not self._mixed_tips_said:  # said once per session, where the technician looks
            self._mixed_tips_said = True
            self.controller.message.emit(warning, "warning")
        self.mixed_tips_warning = warning

    def selected_index(self) -> int | None:
        rows = self.hit_table.selectionModel().selectedRows()
        if not rows:
            return None
        return self.hit_table.item(rows[0].row(), 0).data(Qt.ItemDataRole.UserRole)

    def select_hit(self, index: int) -> None:
        row = self._row_of(index)
        if row >= 0:
            self.hit_table.selectRow(row)

    def _show_selected_hit(self) -> None:
        index = self.selected_index()
        entry = next((e for e in self.controller.hits if e.index == index), None)
        if entry is None:
            return
        verdict, color = verdict_text(entry)
        reasons = ", ".join(entry.automatic.reasons)
        checks = f"failed checks: {reasons}" if reasons else "every check passed"
        self.verdict_label.setText(f"<b style='color:{color}'>Hit {entry.index + 1}: {verdict}</b> — {checks}")
        record = entry.record
        t = np.arange(record.n_samples) / record.sample_rate_hz
        self.hit_force_curve.setData(t, record.force_n)
        self.hit_response_curve.setData(t, record.response)
        self.hit_response_view.enableAutoRange()
        self.draw_windows(entry)
        self._show_hit_spectrum(entry)
        self.accept_button.setEnabled(not entry.accepted)
        self.reject_button.setEnabled(entry.accepted or entry.pending)

    # --- the windows as cursors on the selected hit ----------------------------------------------------------------

    def _selected_entry(self) -> HitEntry | None:
        return next((e for e in self.controller.hits if e.index == self.selected_index()), None)

    def draw_windows(self, entry: HitEntry | None = None) -> None:
        """The force and exponential windows of the Setup tab over the selected hit: their shapes dotted (the force
        window scaled to the peak force, the exponential one to the largest response) and their cursors."""
        from gasfilm.analysis.spectra import exponential_window, force_window

        entry = entry or self._selected_entry()
        if entry is None:
            for line in (self.force_window_line, self.exp_window_line):
                if line.scene() is not None:
                    self.hit_plot.removeItem(line)
            self.force_window_curve.setData([], [])
            self.exp_window_curve.setData([], [])
            return
        record = entry.record
        rate, n = record.sample_rate_hz, record.n_samples
        t = np.arange(n) / rate
        window = self.controller.window_settings()
        peak_s = int(np.argmax(np.abs(record.force_n))) / rate
        force_ms = window.force_window_ms
        force_on = force_ms is not None
        shown = window if force_on else dataclasses.replace(window, force_window_ms=DRAG_START_FORCE_WINDOW_MS)
        shape = force_window(record.force_n, rate, shown)[0]
        self.force_window_curve.setData(t, shape * float(np.max(np.abs(record.force_n))) if force_on else [])
        end = window.exponential_end_fraction
        tau_s = (n - 1) / rate / -np.log(end) if end is not None and end < 1 else None
        if tau_s is not None:
            self.exp_window_curve.setData(t, exponential_window(n, end) * float(np.max(np.abs(record.response))))
        else:
            self.exp_window_curve.setData([], [])
        # the exponential window's cursor only while it is on (Setup ▸ Windows): drawn off, it read as applied
        shown_lines = [self.force_window_line] + ([self.exp_window_line] if tau_s is not None else [])
        for line in (self.force_window_line, self.exp_window_line):
            if line in shown_lines and line.scene() is None:
                self.hit_plot.addItem(line, ignoreBounds=True)
            elif line not in shown_lines and line.scene() is not None:
                self.hit_plot.removeItem(line)
        moving = not self.controller.acquiring  # a running acquisition keeps the windows it was armed with
        cursors = [(self.force_window_line, peak_s + 1e-3 * (force_ms if force_on else DRAG_START_FORCE_WINDOW_MS),
                    f"force window {force_ms:.3g} ms" if force_on else "force window off (drag to set)")]
        if tau_s is not None:
            cursors.append((self.exp_window_line, tau_s, f"exp. window τ {tau_s:.3g} s, ends at {end:.3g}"))
        for line, value, text in cursors:
            line.blockSignals(True)
            line.setVisible(True)
            line.setValue(value)
            line.setMovable(moving)
            line.label.setFormat(text)
            line.blockSignals(False)

    def _force_window_dragged(self) -> None:
        entry = self._selected_entry()
        if entry is None:
            return
        rate = entry.record.sample_rate_hz
        peak_s = int(np.argmax(np.abs(entry.record.force_n))) / rate
        width_ms = max(1e3 / rate, 1e3 * (self.force_window_line.value() - peak_s))
        self._dragged_window["force_window_ms"] = float(f"{width_ms:.3g}")
        self.force_window_line.label.setFormat(f"force window {width_ms:.3g} ms")
        self._window_timer.start()

    def _exp_window_dragged(self) -> None:
        entry = self._selected_entry()
        if entry is None:
            return
        record = entry.record
        length_s = (record.n_samples - 1) / record.sample_rate_hz
        tau_s = max(1.0 / record.sample_rate_hz, self.exp_window_line.value())
        end = float(f"{min(1.0, max(1e-6, np.exp(-length_s / tau_s))):.3g}")
        self._dragged_window["exponential_end_fraction"] = end
        self.exp_window_line.label.setFormat(f"exp. window τ {tau_s:.3g} s, ends at {end:.3g}")
        self._window_timer.start()

    def _apply_dragged_window(self) -> None:
        values, self._dragged_window = self._dragged_window, {}
        if values:
            self.window_dragged.emit(values)

    def decide_by_key(self, accepted: bool) -> None:
        """Accept or reject from the rig (a key or a foot switch): the selected hit when it waits for a decision,
        else the oldest waiting hit, else the selected hit."""
        hits = self.controller.hits
        selected = next((e for e in hits if e.index == self.selected_index()), None)
        waiting = [entry for entry in hits if entry.pending]
        target = selected if selected is not None and selected.pending else (waiting[0] if waiting else selected)
        if target is None:
            self.controller.message.emit("no hit to decide on yet", "info")
            return
        self.select_hit(target.index)
        if self.controller.decide(target.index, accepted):  # the banner says what the latest key did
            said = "accepted: in the average" if accepted else "rejected by hand: out of the average"
            self.controller.message.emit(f"hit {target.index + 1} {said}", "info")

    def undo_last_hit(self) -> None:
        """Take the newest accepted hit out of the average (it stays in the session, rejected by hand)."""
        accepted = [entry for entry in self.controller.hits if entry.accepted]
        if not accepted:
            self.controller.message.emit("undo: no accepted hit to take out of the average", "info")
            return
        last = accepted[-1]
        self.select_hit(last.index)
        if self.controller.decide(last.index, False):
            self.controller.message.emit(f"undo: hit {last.index + 1} taken out of the average (rejected by hand)",
                                         "info")

    def _show_hit_spectrum(self, entry: HitEntry) -> None:
        """The selected hit's force spectrum (dB re its low-frequency level) with the usable band shaded."""
        drop_db = self.controller.setup.usable_drop_db
        try:
            single = session_frf([entry.record], self.controller.window_settings())
        except GasfilmError:
            return
        keep = single.freq_hz > 0
        self.hit_spectrum_curve.setData(single.freq_hz[keep], force_level_db(single.freq_hz, single.gff)[keep])
        low, high = usable_band_hz(single.freq_hz, single.gff, drop_db)
        set_region_hz(self.spectrum_band, low, high, self.log_frequency.isChecked())
        self.spectrum_label.setText(
            f"Hit {entry.index + 1}: force within {drop_db:g} dB of its low-frequency level up to {high:.0f} Hz; "
            f"above that the hammer put too little energy in (spectral nulls) and the FRF is not trusted."
        )
        show_legend_only_with_data(self.spectrum_plot)

    # --- hit check ----------------------------------------------------------------------------------------------------

    def _make_hit_check_page(self) -> QWidget:
        self.tap_pulse_plot = make_plot("Taps: force pulses", ("Force", "N"), ("Time from trigger", "s"), legend=False)
        self.tap_spectrum_plot = make_plot("Taps: force spectra", ("Force level", "dB re low f"), legend=False)
        self.tap_spectrum_plot.getPlotItem().getAxis("left").enableAutoSIPrefix(False)
        self.tap_spectrum_plot.setYRange(-45, 5)
        self.tap_band = pg.LinearRegionItem(brush=pg.mkBrush(*BAND_BRUSH), movable=False)
        self.tap_band.setZValue(-10)
        self.tap_spectrum_plot.addItem(self.tap_band, ignoreBounds=True)
        self.tap_drop_line = pg.InfiniteLine(pos=-self.controller.setup.usable_drop_db, angle=0,
                                             pen=pen(REJECTED_COLOR, 1.0, Qt.PenStyle.DashLine))
        self.tap_spectrum_plot.addItem(self.tap_drop_line, ignoreBounds=True)
        # the proposal in a read-only text box: every line readable (it scrolls), nothing cut at the view's edge
        self.proposal_label = QPlainTextEdit(
            "Hit check: press Hit check (F4) and tap the structure a few times. Nothing is recorded; the taps "
            "propose the trigger level, tip, windows and record length.")
        self.proposal_label.setReadOnly(True)
        self.proposal_label.setObjectName("hit_check_proposal")
        self.proposal_label.setFixedHeight(9 * self.fontMetrics().lineSpacing() + 12)
        self.apply_proposal_button = QPushButton("Apply the proposal to Setup")
        self.apply_proposal_button.setObjectName("apply_hit_check")
        self.apply_proposal_button.setToolTip("Stop the hit check and set the trigger level, record length, windows "
                                              "(and on the simulated rig the tip) as proposed")
        self.apply_proposal_button.setEnabled(False)
        self.apply_proposal_button.clicked.connect(self.apply_hit_check)
        page = QWidget()
        layout = QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        plots = QHBoxLayout()
        plots.addWidget(self.tap_pulse_plot)
        plots.addWidget(self.tap_spectrum_plot)
        layout.addLayout(plots, 1)
        layout.addWidget(self.proposal_label)
        layout.addWidget(self.apply_proposal_button)
        return page

    def _on_hit_check(self, proposal: object) -> None:
        """Every tap's force pulse and spectrum, the band they cover, and the proposal in words."""
        from gasfilm.analysis.hit_check import force_spectrum_db

        for plot in (self.tap_pulse_plot, self.tap_spectrum_plot):
            for item in plot.getPlotItem().listDataItems():
                plot.removeItem(item)
        taps = self.controller.taps
        for number, record in enumerate(taps):
            color = PALETTE[number % len(PALETTE)]
            t_s = (np.arange(record.n_samples) - record.trigger_index) / record.sample_rate_hz
            pulse = (t_s >= OVERLAY_PULSE_MS[0] / 1e3) & (t_s <= OVERLAY_PULSE_MS[1] / 1e3)
            self.tap_pulse_plot.plot(t_s[pulse], record.force_n[pulse], pen=pen(color, 1.0))
            freq, level = force_spectrum_db(record)
            self.tap_spectrum_plot.plot(freq, level, pen=pen(color, 1.0))
        low, high = self.controller.fit_band_hz
        set_region_hz(self.tap_band, low, high, False)
        self.tap_drop_line.setValue(-self.controller.setup.usable_drop_db)
        if proposal is None:
            self.proposal_label.setPlainText("Hit check running: tap the structure a few times (nothing is "
                                             "recorded).")
            self.apply_proposal_button.setEnabled(False)
            return
        self.proposal_label.setPlainText(proposal.text())
        self.apply_proposal_button.setEnabled(True)
        self.tap_pulse_plot.setTitle(f"{len(taps)} tap{'s' if len(taps) != 1 else ''}: force pulses")

    # --- running FRF ------------------------------------------------------------------------------------------------

    def _on_frf(self, frf: object) -> None:
        if frf is None:
            for curve in (self.h1_curve, self.h1_outside_curve, self.coherence_curve, self.mean_spectrum_curve):
                curve.setData([], [])
            self.h1_plot.setTitle("Running H1")
            self.usable_label.setText("")
            self.h1_band.setVisible(False)
        else:
            keep = frf.freq_hz > 0
            freq = frf.freq_hz[keep]
            low, high = usable_band_hz(frf.freq_hz, frf.gff, self.controller.setup.usable_drop_db)
            magnitude = np.abs(frf.h1[keep]) / STANDARD_GRAVITY_M_S2
            inside = freq <= high
            self.h1_curve.setData(freq[inside], magnitude[inside])
            self.h1_outside_curve.setData(freq[~inside], magnitude[~inside])
            self.coherence_curve.setData(freq, frf.coherence[keep])
            self.mean_spectrum_curve.setData(freq, force_level_db(frf.freq_hz, frf.gff)[keep])
            self.h1_band.setVisible(True)
            set_region_hz(self.h1_band, low, high, self.log_frequency.isChecked())
            self.h1_plot.setTitle(f"Running H1 — {frf.n_averages} averages")
            self.usable_label.setText(f"usable band {low:.3g}–{high:.0f} Hz")
        for plot in (self.h1_plot, self.spectrum_plot):
            show_legend_only_with_data(plot)

    def _set_log_frequency(self, log_x: bool) -> None:
        for plot in (self.h1_plot, self.coherence_plot, self.spectrum_plot):
            plot.getPlotItem().setLogMode(x=log_x)
            plot.getPlotItem().vb.autoRange()  # the old range in the new coordinates would be 10^6400 Hz wide
        self._on_frf(self.controller.frf)
        entry = next((e for e in self.controller.hits if e.index == self.selected_index()), None)
        if entry is not None:
            self._show_hit_spectrum(entry)
