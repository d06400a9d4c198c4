"""Measure tab: arm/stop, live view, each hit with its verdict and Accept/Reject, running H1 and coherence."""

from __future__ import annotations

import time

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QAbstractItemView,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from gasfilm.app.gui.controller import SessionController
from gasfilm.app.gui.settings import SIM_TIPS
from gasfilm.app.gui.widgets import (
    ACCEPTED_COLOR,
    MEASURED_COLOR,
    PALETTE,
    PENDING_COLOR,
    REJECTED_COLOR,
    make_plot,
    pen,
)
from gasfilm.app.gui.workers import HitEntry
from gasfilm.drivers.interface import ChannelKind

REDRAW_INTERVAL_MS = 40  # 25 frames per second
_STATE_STYLE = {
    "idle": ("STOPPED", "#666666"),
    "starting": ("STARTING…", "#0b5394"),
    "armed": ("ARMED — waiting for a hit", "#1b7f3b"),
    "triggered": ("TRIGGERED — recording", "#b3261e"),
}
_HIT_COLUMNS = ("Hit", "Time (s)", "Peak force (N)", "Verdict", "Reasons")


def verdict_text(entry: HitEntry) -> tuple[str, str]:
    if entry.pending:
        return "pending", PENDING_COLOR
    if entry.verdict.accepted:
        return ("accepted (by you)" if entry.verdict.overridden else "accepted"), ACCEPTED_COLOR
    return ("rejected (by you)" if entry.verdict.overridden else "rejected"), REJECTED_COLOR


class MeasureTab(QWidget):
    """The technician's main screen while hitting the structure."""

    def __init__(self, controller: SessionController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.controller = controller
        self.redraw_count = 0
        self.redraw_seconds = 0.0
        self._first_redraw_s: float | None = None

        self.arm_button = QPushButton("Arm")
        self.arm_button.setObjectName("arm")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setObjectName("stop")
        self.arm_button.clicked.connect(controller.arm)
        self.stop_button.clicked.connect(controller.stop)
        self.state_label = QLabel()
        self.state_label.setMinimumWidth(260)
        self.counter_label = QLabel()
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
        top.addWidget(self.arm_button)
        top.addWidget(self.stop_button)
        top.addWidget(self.state_label)
        top.addWidget(self.counter_label, 1)
        top.addWidget(hammer_box)

        # Time runs to 0 = now on a fixed axis, and the live plots have no grid: their axes are then not redrawn
        # with every frame, which keeps the view at 25 fps with 4 channels at 51.2 kS/s.
        self.force_plot = make_plot("Live: force", ("Force", "N"), ("Time before now", "s"), grid=False)
        self.response_plot = make_plot(
            "Live: response", ("Acceleration", "m/s²"), ("Time before now", "s"), grid=False
        )
        self.response_plot.setXLink(self.force_plot)
        self.force_plot.getPlotItem().enableAutoRange(x=False)
        self.response_plot.getPlotItem().enableAutoRange(x=False)
        for plot in (self.force_plot, self.response_plot):
            plot.getPlotItem().legend.setOffset((70, 10))  # top left, clear of the newest samples
        self._live_curves: list[pg.PlotDataItem] = []
        live = QWidget()
        live_layout = QVBoxLayout(live)
        live_layout.setContentsMargins(0, 0, 0, 0)
        live_layout.addWidget(self.force_plot)
        live_layout.addWidget(self.response_plot)

        self.hit_table = QTableWidget(0, len(_HIT_COLUMNS))
        self.hit_table.setHorizontalHeaderLabels(_HIT_COLUMNS)
        self.hit_table.verticalHeader().setVisible(False)
        self.hit_table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.hit_table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.hit_table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.hit_table.horizontalHeader().setStretchLastSection(True)
        self.hit_table.verticalHeader().setDefaultSectionSize(22)
        self.hit_table.itemSelectionChanged.connect(self._show_selected_hit)
        self.verdict_label = QLabel("No hit yet")
        self.verdict_label.setWordWrap(True)
        self.accept_button = QPushButton("Accept hit")
        self.accept_button.setObjectName("accept")
        self.reject_button = QPushButton("Reject hit")
        self.reject_button.setObjectName("reject")
        self.accept_button.clicked.connect(lambda: self._decide(True))
        self.reject_button.clicked.connect(lambda: self._decide(False))
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
        hits = QWidget()
        hits_layout = QVBoxLayout(hits)
        hits_layout.setContentsMargins(0, 0, 0, 0)
        hits_layout.addWidget(self.hit_table, 2)
        hits_layout.addWidget(self.verdict_label)
        buttons = QHBoxLayout()
        buttons.addWidget(self.accept_button)
        buttons.addWidget(self.reject_button)
        hits_layout.addLayout(buttons)
        hits_layout.addWidget(self.hit_plot, 3)

        self.h1_plot = make_plot("Running H1", ("|H1|", "(m/s²)/N"), log_y=True)
        self.coherence_plot = make_plot("Coherence", ("γ²", ""))
        self.coherence_plot.setXLink(self.h1_plot)
        self.coherence_plot.setYRange(0, 1.05)
        self.h1_curve = self.h1_plot.plot(pen=pen(MEASURED_COLOR), name="H1")
        self.coherence_curve = self.coherence_plot.plot(pen=pen(PALETTE[2]), name="γ²")
        frf = QWidget()
        frf_layout = QVBoxLayout(frf)
        frf_layout.setContentsMargins(0, 0, 0, 0)
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

        self.redraw_timer = QTimer(self)
        self.redraw_timer.setInterval(REDRAW_INTERVAL_MS)
        self.redraw_timer.timeout.connect(self.redraw_live)

        controller.acquisition_state.connect(self._on_state)
        controller.streaming.connect(self._on_streaming)
        controller.hits_reset.connect(self._rebuild_hits)
        controller.hit_added.connect(self._on_hit_added)
        controller.hit_changed.connect(self._on_hit_changed)
        controller.frf_changed.connect(self._on_frf)
        self._on_state("idle")
        self._update_counter()

    # --- live view ---------------------------------------------------------------------------------------------------

    def _on_streaming(self, loop: object) -> None:
        if loop is None:
            self.redraw_timer.stop()
            return
        config = self.controller.running_config()
        self.force_plot.clear()
        self.response_plot.clear()
        self._live_curves = []
        response_number = 0
        for channel in config.channels:
            if channel.kind is ChannelKind.FORCE:
                curve = self.force_plot.plot(pen=pen(PALETTE[0], 1.0), name=channel.label)
            else:
                curve = self.response_plot.plot(pen=pen(PALETTE[1 + response_number], 1.0), name=channel.label)
                response_number += 1
            curve.setDownsampling(auto=True, method="peak")
            curve.setClipToView(True)
            curve.setSkipFiniteCheck(True)
            self._live_curves.append(curve)
        self.force_plot.setXRange(-self.controller.setup.live_view_s, 0.0, padding=0.0)
        self.redraw_count = 0
        self.redraw_seconds = 0.0
        self._first_redraw_s = None
        self.redraw_timer.start()

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
        self.state_label.setText(text)
        self.state_label.setStyleSheet(
            f"QLabel {{ color: white; background: {color}; border-radius: 4px; padding: 4px 10px; font-weight: 700; }}"
        )
        running = state != "idle"
        self.arm_button.setEnabled(not running)
        self.stop_button.setEnabled(running)
        self.hammer_box.setVisible(self.controller.is_simulated)
        self.hammer_box.setEnabled(running and state != "starting")

    def _update_counter(self) -> None:
        c = self.controller
        self.counter_label.setText(
            f"  Hits: {len(c.hits)}   ·   accepted {c.accepted_count}   ·   rejected {c.rejected_count}"
            + (f"   ·   waiting for you {c.pending_count}" if c.pending_count else "")
        )

    # --- hit list ---------------------------------------------------------------------------------------------------

    def _rebuild_hits(self) -> None:
        self.hit_table.setRowCount(0)
        for entry in self.controller.hits:
            self._append_row(entry)
        self._update_counter()
        if self.controller.hits:
            self.hit_table.selectRow(self.hit_table.rowCount() - 1)
        else:
            self.verdict_label.setText("No hit yet")
            self.hit_force_curve.setData([], [])
            self.hit_response_curve.setData([], [])

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

    def _on_hit_changed(self, entry: HitEntry) -> None:
        row = self._row_of(entry.index)
        if row >= 0:
            self._fill_row(row, entry)
        self._update_counter()
        if self.selected_index() == entry.index:
            self._show_selected_hit()

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
        self.accept_button.setEnabled(not entry.accepted)
        self.reject_button.setEnabled(entry.accepted or entry.pending)

    def _decide(self, accepted: bool) -> None:
        index = self.selected_index()
        if index is not None:
            self.controller.decide(index, accepted)

    # --- running FRF ------------------------------------------------------------------------------------------------

    def _on_frf(self, frf: object) -> None:
        if frf is None:
            self.h1_curve.setData([], [])
            self.coherence_curve.setData([], [])
            self.h1_plot.setTitle("Running H1")
            return
        keep = frf.freq_hz > 0
        self.h1_curve.setData(frf.freq_hz[keep], np.abs(frf.h1[keep]))
        self.coherence_curve.setData(frf.freq_hz[keep], frf.coherence[keep])
        self.h1_plot.setTitle(f"Running H1 — {frf.n_averages} averages")
