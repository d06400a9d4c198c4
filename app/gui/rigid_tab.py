"""Rigid body tab: the mover's layout (outline, pads, centre of mass, accelerometers, hammer points and the next one
to strike in a roving test), the FRFs per accelerometer and per direction, and the fits per direction with the
couplings — what ``gasfilm rigid`` computes, from the hits on screen."""

from __future__ import annotations

from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QComboBox,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QWidget,
)

from gasfilm.analysis.identification.rigid import RigidIdentification, direction_unit, identify_rigid
from gasfilm.analysis.physics import rigid_body
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_frf import RigidFrf, rigid_frf
from gasfilm.analysis.rigid_session import accelerometer_rows, hits_by_point, next_point, roving_plan
from gasfilm.app.gui.controller import SessionController
from gasfilm.app.gui.widgets import MEASURED_COLOR, PALETTE, make_plot, pen
from gasfilm.drivers.errors import GasfilmError

DIRECTION_VIEW = "Heave, roll, pitch (the other directions held still)"
RESULT_COLUMNS = ("Term", "K ± σ", "C ± σ", "Layout K", "Layout C", "Coupling")


class RigidTab(QWidget):
    """A rigid-body hammer test: where to hit, what each accelerometer and each direction shows, the films."""

    def __init__(self, controller: SessionController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.controller = controller
        self.spec: RigSpec | None = None
        self.rigid: RigidFrf | None = None
        self.identification: RigidIdentification | None = None

        self.point_combo = QComboBox()
        self.point_combo.setToolTip("The hammer point the next armed acquisition strikes (a roving test: record a "
                                    "run of hits at each point)")
        self.next_label = QLabel()
        self.analyse_button = QPushButton("Analyse (SD per direction)")
        self.analyse_button.setToolTip("Rigid-body FRFs of the accepted hits and a spring-damper fit per direction, "
                                       "with the couplings (gasfilm rigid)")
        self.view_combo = QComboBox()
        self.summary = QLabel("Open or record a session with a [rigid_body] rig spec (docs/rig-spec.md).")
        self.summary.setWordWrap(True)
        controls = QHBoxLayout()
        controls.addWidget(QLabel("Hammer point"))
        controls.addWidget(self.point_combo)
        controls.addWidget(self.next_label)
        controls.addStretch(1)
        controls.addWidget(QLabel("Show"))
        controls.addWidget(self.view_combo)
        controls.addWidget(self.analyse_button)

        self.layout_plot = make_plot("Layout (seen from the hammer)", ("y", "m"), ("x", "m"), legend=True)
        self.layout_plot.setAspectLocked(True)
        self.frf_plot = make_plot("FRF magnitude", ("|H|", ""), log_y=True)
        self.table = QTableWidget(0, len(RESULT_COLUMNS))
        self.table.setHorizontalHeaderLabels(RESULT_COLUMNS)
        self.table.verticalHeader().setVisible(False)
        self.table.horizontalHeader().setStretchLastSection(True)

        grid = QGridLayout(self)
        grid.addLayout(controls, 0, 0, 1, 2)
        grid.addWidget(self.layout_plot, 1, 0)
        grid.addWidget(self.frf_plot, 1, 1)
        grid.addWidget(self.table, 2, 0, 1, 2)
        grid.addWidget(self.summary, 3, 0, 1, 2)
        grid.setColumnStretch(0, 2)
        grid.setColumnStretch(1, 3)
        grid.setRowStretch(1, 3)
        grid.setRowStretch(2, 2)

        self.point_combo.currentTextChanged.connect(self._point_chosen)
        self.view_combo.currentIndexChanged.connect(self._draw_frfs)
        self.analyse_button.clicked.connect(self.analyse)
        controller.session_changed.connect(lambda _path: self.refresh())
        controller.hits_reset.connect(self.refresh)
        controller.acquisition_state.connect(lambda state: self._show_layout() if state == "idle" else None)
        self.refresh()

    # --- state -----------------------------------------------------------------------------------------------------

    def _current_spec(self) -> RigSpec | None:
        try:
            spec = (self.controller.rig_spec_of_session() if self.controller.session is not None
                    else self.controller.rig_spec())
        except GasfilmError:
            return None
        return spec if spec.rigid_body is not None else None

    def _struck(self) -> dict[str, int]:
        """Accepted hits per hammer point so far."""
        session = self.controller.session
        if self.spec is None or session is None or not session.is_open:
            return {}
        plan = roving_plan(session.settings)
        counts: dict[str, int] = {}
        for entry in self.controller.hits:
            if entry.accepted:
                point = plan.point_of_hit(entry.index, self.spec.rigid_body.hammer_point)
                counts[point] = counts.get(point, 0) + 1
        return counts

    def refresh(self) -> None:
        """A new session or setup: its rigid body, stored identification, and what the roving test has struck."""
        self.spec = self._current_spec()
        self.rigid, self.identification = None, None
        self.point_combo.blockSignals(True)
        self.point_combo.clear()
        if self.spec is not None:
            self.point_combo.addItems(list(self.spec.rigid_body.point_names))
            chosen = self.controller.hammer_point or self.spec.rigid_body.hammer_point
            self.point_combo.setCurrentText(chosen)
        self.point_combo.blockSignals(False)
        self.analyse_button.setEnabled(self.spec is not None)
        self.table.setRowCount(0)
        self.frf_plot.clear()
        if self.spec is None:
            self.summary.setText("The rig spec has no [rigid_body]: this tab shows a mover with several "
                                 "accelerometers (docs/rig-spec.md).")
        else:
            self.summary.setText(f"{self.spec.name}: {len(self.spec.rigid_body.accelerometers)} accelerometers, "
                                 f"{len(self.spec.rigid_body.hammer_points)} hammer points. Record a run at each "
                                 f"point, stop, then Analyse.")
        self._show_layout()

    def _point_chosen(self, point: str) -> None:
        if not point:
            return
        self.controller.hammer_point = point
        if self.controller.acquiring:
            self.controller.message.emit(f"the hammer moves to {point} at the next Arm (stop this run first)",
                                         "info")
        self._show_layout()

    # --- analysis --------------------------------------------------------------------------------------------------

    def analyse(self) -> None:
        """Rigid-body FRFs and SD fits per direction of the accepted hits (the acquisition stopped)."""
        controller = self.controller
        if self.spec is None or controller.session is None:
            return
        if controller.acquiring:
            controller.message.emit("stop the acquisition to analyse the rigid body", "warning")
            return
        accepted = [entry for entry in controller.hits if entry.accepted]
        try:
            session = controller.session
            grouped = hits_by_point(self.spec, session.settings, accepted)  # (by the entries' session indices)
            records = {point: np.stack([entry.record.data for entry in entries]) for point, entries in grouped.items()}
            if not records:
                raise GasfilmError("no accepted hits yet")
            self.rigid = rigid_frf(self.spec, records, accepted[0].record.sample_rate_hz,
                                   controller.window_settings(), accepted[0].record.force_channel,
                                   accelerometer_rows(self.spec, session.daq_config))
            self.identification = identify_rigid(self.rigid, ("SD",))
        except GasfilmError as error:
            controller.message.emit(f"rigid body: {error}", "error")
            return
        self._fill_views()
        self._fill_table()
        self._show_layout()
        found = self.identification.coupling_found()
        self.summary.setText(" ".join(self.rigid.summary_lines()[1:2]) + " — coupling: "
                             + ("found" if found else "none beyond the noise" if found is False else "not measured"))

    def _fill_views(self) -> None:
        self.view_combo.blockSignals(True)
        self.view_combo.clear()
        self.view_combo.addItem(DIRECTION_VIEW)
        for point in self.rigid.point_names:
            self.view_combo.addItem(f"Each accelerometer, hammer at {point}")
        self.view_combo.blockSignals(False)
        self._draw_frfs()

    def _draw_frfs(self) -> None:
        plot = self.frf_plot
        plot.clear()
        if self.rigid is None or self.view_combo.currentIndex() < 0:
            return
        rigid = self.rigid
        index = self.view_combo.currentIndex()
        low, high = self.identification.band_hz
        lines = rigid.readable() & (rigid.freq_hz >= low) & (rigid.freq_hz <= high)
        if index == 0:
            plot.setTitle("Each direction's accelerance, the others held still (measured; dashed: SD fit)")
            for colour, direction in zip(PALETTE, self.identification.directions):
                h = rigid.direction_accelerance(direction)[lines]
                scale = 1.0 / np.max(np.abs(h))
                plot.plot(rigid.freq_hz[lines], np.abs(h) * scale, pen=pen(colour),
                          name=f"{direction} (÷ {1 / scale:.3g} {rigid_body.ACCELERATION_UNITS[direction]} per "
                               f"{rigid_body.LOAD_UNITS[direction]})")
                fit = self.identification.directions[direction].fit("SD")
                plot.plot(rigid.freq_hz[lines], np.abs(fit.accelerance(rigid.freq_hz[lines])) * scale,
                          pen=pen(colour, 1.0, Qt.PenStyle.DashLine))
            plot.getPlotItem().setLabel("left", "|H| / peak")
        else:
            point = rigid.point_names[index - 1]
            plot.setTitle(f"H1 of each accelerometer, hammer at {point}")
            for colour, name, frf in zip(PALETTE, rigid.sensor_names, rigid.channel_frfs[index - 1]):
                shown = frf.freq_hz > 0
                plot.plot(frf.freq_hz[shown], np.abs(frf.h1[shown]), pen=pen(colour), name=name)
            plot.getPlotItem().setLabel("left", "|H1|", units=None)
            plot.getPlotItem().setLabel("left", "|H1| ((m/s²)/N)")
        plot.setXRange(low, high)

    def _fill_table(self) -> None:
        result = self.identification
        implied = rigid_body.layout_direction_films(self.spec) if self.spec.rigid_body.has_pads else {}
        couplings = rigid_body.layout_coupling_sd(self.spec) or {}
        rows: list[tuple[str, ...]] = []
        for direction, fits in result.directions.items():
            fit = fits.fit("SD")
            layout = implied.get(direction)
            rows.append((direction, _value(fit.params["k"], fit.std_errors.get("k"),
                                           direction_unit("N/m", direction)),
                         _value(fit.params["eta"], fit.std_errors.get("eta"), direction_unit("N·s/m", direction)),
                         "—" if layout is None or "k" not in layout[1] else f"{layout[1]['k']:.6g}",
                         "—" if layout is None or "eta" not in layout[1] else f"{layout[1]['eta']:.5g}", ""))
        for term in result.couplings():
            k_unit, c_unit = term.units
            layout = couplings.get(term.directions)
            rows.append((f"{term.directions[0]}–{term.directions[1]}",
                         _value(term.stiffness, term.stiffness_std, k_unit),
                         _value(term.damping, term.damping_std, c_unit),
                         "—" if layout is None else f"{layout[0]:.6g}", "—" if layout is None else f"{layout[1]:.5g}",
                         "coupled" if term.found else "none beyond the noise"))
        if result.elastic_centre_offset_m is not None:
            dx, sx, dy, sy = result.elastic_centre_offset_m
            rows.append(("elastic centre − centre of mass", f"Δx {1e3 * dx:+.2f} ± {1e3 * sx:.2f} mm",
                         f"Δy {1e3 * dy:+.2f} ± {1e3 * sy:.2f} mm", "", "", ""))
        self.table.setRowCount(len(rows))
        for row, cells in enumerate(rows):
            for column, text in enumerate(cells):
                self.table.setItem(row, column, QTableWidgetItem(text))
        self.table.resizeColumnsToContents()

    # --- layout ----------------------------------------------------------------------------------------------------

    def _show_layout(self) -> None:
        plot = self.layout_plot
        plot.clear()
        if self.spec is None:
            return
        body = self.spec.rigid_body
        positions = [sensor.position_m for sensor in body.accelerometers] + [p.position_m for p in body.hammer_points]
        positions += [pad.position_m for pad in body.pads] + [body.centre_of_mass_m]
        xy = np.array(positions)
        margin = 0.15 * max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1]), 0.05)
        (x0, y0), (x1, y1) = xy.min(axis=0) - margin, xy.max(axis=0) + margin
        plot.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], pen=pen("#555555", 2.0), name="mover outline")
        if body.pads:
            pads = np.array([pad.position_m for pad in body.pads])
            plot.plot(pads[:, 0], pads[:, 1], pen=None, symbol="s", symbolSize=22, symbolBrush=pg.mkBrush(200, 200, 200),
                      symbolPen=pen("#777777"), name="pads")
        centre = body.centre_of_mass_m
        plot.plot([centre[0]], [centre[1]], pen=None, symbol="+", symbolSize=18, symbolPen=pen(MEASURED_COLOR, 2.5),
                  name="centre of mass")
        if self.identification is not None and self.identification.elastic_centre_offset_m is not None:
            dx, _, dy, _ = self.identification.elastic_centre_offset_m
            plot.plot([centre[0] + dx], [centre[1] + dy], pen=None, symbol="x", symbolSize=16,
                      symbolPen=pen(PALETTE[1], 2.5), name="elastic centre (measured)")
        sensors = np.array([sensor.position_m for sensor in body.accelerometers])
        plot.plot(sensors[:, 0], sensors[:, 1], pen=None, symbol="t", symbolSize=14,
                  symbolBrush=pg.mkBrush(PALETTE[0]), name="accelerometers")
        struck = self._struck()
        chosen = self.point_combo.currentText()
        points = np.array([point.position_m for point in body.hammer_points])
        brushes = [pg.mkBrush(PALETTE[2]) if point.name in struck else pg.mkBrush(255, 255, 255)
                   for point in body.hammer_points]
        plot.plot(points[:, 0], points[:, 1], pen=None, symbol="o", symbolSize=12, symbolBrush=brushes,
                  symbolPen=pen(PALETTE[2]), name="hammer points (filled: struck)")
        if chosen in body.point_names:
            x, y = body.point(chosen).position_m
            plot.plot([x], [y], pen=None, symbol="o", symbolSize=26, symbolBrush=None,
                      symbolPen=pen("#d62728", 3.0), name="strike next")
        for sensor in body.accelerometers:
            self._label(f"{sensor.name}{' (−z)' if sensor.direction < 0 else ''}", sensor.position_m, PALETTE[0])
        for point in body.hammer_points:
            count = struck.get(point.name)
            self._label(point.name + (f" ({count})" if count else ""), point.position_m, PALETTE[2])
        plan = roving_plan(self.controller.session.settings) if self.controller.session is not None and \
            self.controller.session.is_open else roving_plan({})
        coming = next_point(self.spec, plan)
        self.next_label.setText(f"next to strike: {coming}" if coming else "every point struck")

    def _label(self, text: str, position: tuple[float, float], colour: str) -> None:
        item = pg.TextItem(text, color=colour, anchor=(0, 1))
        item.setPos(position[0], position[1])
        self.layout_plot.addItem(item)


def _value(value: float, sigma: Any, unit: str) -> str:
    return f"{value:.6g} ± {sigma:.2g} {unit}" if sigma is not None else f"{value:.6g} {unit} (at bound)"
