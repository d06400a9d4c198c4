"""FRF tab: magnitude (log) with its uncertainty band, phase, real and imaginary parts, coherence; fit band."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtGui import QShowEvent
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QFileDialog, QGridLayout, QHBoxLayout, QLabel,
                               QPushButton, QSizePolicy, QWidget)

from gasfilm.analysis.spectra import peak_line, usable_band_hz
from gasfilm.analysis.spectra import FrfResult
from gasfilm.app.gui.controller import SessionController
from gasfilm.app.gui.widgets import (
    MEASURED_COLOR,
    PALETTE,
    make_plot,
    pen,
    phase_deg,
    set_region_hz,
    show_legend_only_with_data,
)
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

#: Accelerance units offered, the first the default: g/N as the Identify and Diagnose tabs and the command line show it
UNITS = {"g/N": 1.0 / STANDARD_GRAVITY_M_S2, "(m/s²)/N": 1.0}
UNCERTAINTY = {"from coherence (Bendat & Piersol)": "h1_std_coherence", "hit-to-hit scatter": "h1_std_scatter"}
#: How |H| is drawn: on a logarithmic axis, a linear one, or in dB re 1 unit (20·log10 |H|).
MAGNITUDE_SCALES = ("log", "linear", "dB")


class FrfTab(QWidget):
    """The averaged FRF of the accepted hits, the way a modal engineer reads it."""

    def __init__(self, controller: SessionController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.controller = controller
        self.frf: FrfResult | None = None
        self._stale = False
        self._view_set = False

        self.unit_combo = QComboBox()
        self.unit_combo.addItems(list(UNITS))
        self.scale_combo = QComboBox()
        self.scale_combo.setObjectName("magnitude_scale")
        self.scale_combo.addItems(list(MAGNITUDE_SCALES))
        self.scale_combo.setToolTip("|H| on a logarithmic axis, a linear axis, or in dB re 1 (g/N or (m/s²)/N)")
        self.uncertainty_combo = QComboBox()
        self.uncertainty_combo.addItems(list(UNCERTAINTY))
        self.band_low = QDoubleSpinBox()
        self.band_high = QDoubleSpinBox()
        for spin in (self.band_low, self.band_high):
            spin.setRange(0.0, 30_000.0)
            spin.setDecimals(1)
            spin.setSuffix(" Hz")
            spin.setKeyboardTracking(False)
        self.band_low.setValue(controller.fit_band_hz[0])
        self.band_high.setValue(controller.fit_band_hz[1])
        self.summary = QLabel("No FRF yet: accept hits on the Measure tab or open a session.")
        self.log_frequency = QCheckBox("Log frequency")
        self.log_frequency.setObjectName("log_frequency")
        controls = QHBoxLayout()
        controls.addWidget(QLabel("Units"))
        controls.addWidget(self.unit_combo)
        controls.addWidget(QLabel("|H|"))
        controls.addWidget(self.scale_combo)
        controls.addWidget(QLabel("Uncertainty band (±1σ)"))
        controls.addWidget(self.uncertainty_combo)
        controls.addWidget(QLabel("Fit band"))
        controls.addWidget(self.band_low)
        controls.addWidget(QLabel("to"))
        controls.addWidget(self.band_high)
        controls.addWidget(self.log_frequency)
        self.compare_button = QPushButton("Compare sessions…")
        self.compare_button.setObjectName("compare_sessions")
        self.compare_button.setToolTip("Draw other sessions' FRFs over this one (named with their conditions)")
        self.compare_button.clicked.connect(self._choose_comparisons)
        self.clear_compare_button = QPushButton("Clear comparison")
        self.clear_compare_button.clicked.connect(controller.clear_comparisons)
        self.clear_compare_button.setEnabled(False)
        controls.addStretch(1)
        controls.addWidget(self.compare_button)
        controls.addWidget(self.clear_compare_button)
        # the summary on a line of its own, elided if need be: the controls row keeps the window's default width
        self.summary.setMinimumWidth(0)
        self.summary.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Preferred)

        self.magnitude_plot = make_plot("Accelerance magnitude |H|", ("|H|", "g/N"), log_y=True)
        self.phase_plot = make_plot("Phase", ("Phase", "°"))
        self.real_plot = make_plot("Real part", ("Re H", "g/N"))
        self.imag_plot = make_plot("Imaginary part", ("Im H", "g/N"))
        self.coherence_plot = make_plot("Coherence", ("γ²", ""))
        self.coherence_plot.setYRange(0, 1.05)
        self.phase_plot.setYRange(-90, 270)
        plots = (self.magnitude_plot, self.phase_plot, self.real_plot, self.imag_plot, self.coherence_plot)
        for plot in plots[1:]:
            plot.setXLink(self.magnitude_plot)

        self.h1_curve = self.magnitude_plot.plot(pen=pen(MEASURED_COLOR), name="H1")
        self.h1_outside_curve = self.magnitude_plot.plot(pen=pen("#bbbbbb", 1.0), name="H1, force too low")
        self.h2_curve = self.magnitude_plot.plot(pen=pen(PALETTE[4], 1.0, Qt.PenStyle.DashLine), name="H2")
        self.hv_curve = self.magnitude_plot.plot(pen=pen(PALETTE[6], 1.0, Qt.PenStyle.DotLine), name="Hv")
        self.upper_curve = pg.PlotDataItem(pen=pen(PALETTE[5], 0.5))
        self.lower_curve = pg.PlotDataItem(pen=pen(PALETTE[5], 0.5))
        band_brush = pg.mkBrush(86, 180, 233, 80)
        self.band_fill = pg.FillBetweenItem(self.upper_curve, self.lower_curve, brush=band_brush)
        for item in (self.upper_curve, self.lower_curve, self.band_fill):
            self.magnitude_plot.addItem(item)
        # The legend shows a filled sample of a stand-in curve (a FillBetweenItem sample crashes pyqtgraph's legend).
        self._band_legend_sample = pg.PlotDataItem(pen=pen(PALETTE[5], 0.5), fillLevel=0, fillBrush=band_brush)
        self.magnitude_plot.getPlotItem().legend.addItem(self._band_legend_sample, "±1σ uncertainty")
        self.phase_curve = self.phase_plot.plot(pen=pen(MEASURED_COLOR), name="H1")
        self.real_curve = self.real_plot.plot(pen=pen(PALETTE[0]), name="Re H1")
        self.imag_curve = self.imag_plot.plot(pen=pen(PALETTE[1]), name="Im H1")
        self.coherence_curve = self.coherence_plot.plot(pen=pen(PALETTE[2]), name="γ²")
        self.region = pg.LinearRegionItem(values=controller.fit_band_hz, brush=pg.mkBrush(0, 114, 178, 30))
        self.region.setZValue(-10)
        self.magnitude_plot.addItem(self.region)
        self.coherence_region = pg.LinearRegionItem(
            values=controller.fit_band_hz, brush=pg.mkBrush(0, 114, 178, 30), movable=False
        )
        self.coherence_plot.addItem(self.coherence_region)

        grid = QGridLayout(self)
        grid.addLayout(controls, 0, 0, 1, 2)
        grid.addWidget(self.summary, 1, 0, 1, 2)
        grid.addWidget(self.magnitude_plot, 2, 0, 2, 1)
        grid.addWidget(self.phase_plot, 2, 1)
        grid.addWidget(self.coherence_plot, 3, 1)
        grid.addWidget(self.real_plot, 4, 0)
        grid.addWidget(self.imag_plot, 4, 1)
        grid.setRowStretch(2, 1)
        grid.setRowStretch(3, 1)
        grid.setRowStretch(4, 1)

        self.region.sigRegionChangeFinished.connect(self._region_moved)
        self.band_low.valueChanged.connect(self._band_typed)
        self.band_high.valueChanged.connect(self._band_typed)
        self.unit_combo.currentIndexChanged.connect(self.redraw)
        self.scale_combo.currentIndexChanged.connect(self._set_magnitude_scale)
        self.uncertainty_combo.currentIndexChanged.connect(self.redraw)
        self.log_frequency.toggled.connect(self._set_log_frequency)
        controller.frf_changed.connect(self.set_frf)
        controller.comparisons_changed.connect(self._comparisons_changed)
        self._comparison_curves: list[pg.PlotDataItem] = []

    @property
    def unit(self) -> str:
        return self.unit_combo.currentText()

    @property
    def magnitude_scale(self) -> str:
        return self.scale_combo.currentText()

    def _shown_magnitude(self, magnitude: np.ndarray) -> np.ndarray:
        """|H| as the magnitude plot draws it: as it is (log or linear axis) or in dB re 1 unit."""
        if self.magnitude_scale != "dB":
            return magnitude
        with np.errstate(divide="ignore"):
            return 20.0 * np.log10(magnitude)

    def _set_magnitude_scale(self) -> None:
        self.magnitude_plot.getPlotItem().setLogMode(y=self.magnitude_scale == "log")
        self.redraw()
        self.magnitude_plot.getPlotItem().vb.enableAutoRange(y=True)

    def set_frf(self, frf: FrfResult | None) -> None:
        """Keep the FRF; draw it now if the tab is visible, else when it is shown (hits arrive while measuring)."""
        self.frf = frf
        self._stale = True
        if frf is None:  # (another session, or no accepted hit left): the next FRF opens on its default view
            self._view_set = False
        if self.isVisible():
            self.redraw()

    def showEvent(self, event: QShowEvent) -> None:
        if self._stale:
            self.redraw()
        super().showEvent(event)

    def redraw(self) -> None:
        self._stale = False
        frf = self.frf
        curves = (self.h1_curve, self.h1_outside_curve, self.h2_curve, self.hv_curve, self.upper_curve, self.lower_curve, self.phase_curve,
                  self.real_curve, self.imag_curve, self.coherence_curve)
        self._draw_comparisons(UNITS[self.unit])
        if frf is None:
            for curve in curves:
                curve.setData([], [])
            self.summary.setText("No FRF yet: accept hits on the Measure tab or open a session.")
            self._view_set = False
            self._update_legends()
            return
        scale = UNITS[self.unit]
        for plot, label in ((self.magnitude_plot, "|H|"), (self.real_plot, "Re H"), (self.imag_plot, "Im H")):
            plot.getPlotItem().setLabel("left", label, units=self.unit)
        if self.magnitude_scale == "dB":
            self.magnitude_plot.getPlotItem().setLabel("left", "|H|", units=f"dB re 1 {self.unit}")
        keep = frf.freq_hz > 0
        freq = frf.freq_hz[keep]
        h1 = frf.h1[keep] * scale
        magnitude = np.abs(h1)
        sigma = np.nan_to_num(getattr(frf, UNCERTAINTY[self.uncertainty_combo.currentText()])[keep] * scale)
        floor = np.min(magnitude[magnitude > 0]) * 0.1 if np.any(magnitude > 0) else 1e-12
        _, usable_high = usable_band_hz(frf.freq_hz, frf.gff, self.controller.setup.usable_drop_db)
        inside = freq <= usable_high
        shown = self._shown_magnitude
        self.h1_curve.setData(freq[inside], shown(magnitude[inside]))
        self.h1_outside_curve.setData(freq[~inside], shown(magnitude[~inside]))
        self.h2_curve.setData(freq, shown(np.abs(frf.h2[keep] * scale)))
        self.hv_curve.setData(freq, shown(np.abs(frf.hv[keep] * scale)))
        self.upper_curve.setData(freq, shown(magnitude + sigma))
        self.lower_curve.setData(freq, shown(np.maximum(magnitude - sigma, floor)))
        self.phase_curve.setData(freq, phase_deg(h1))
        self.real_curve.setData(freq, h1.real)
        self.imag_curve.setData(freq, h1.imag)
        self.coherence_curve.setData(freq, frf.coherence[keep])
        low, high = self.controller.fit_band_hz
        if not self._view_set:  # open on the whole usable band (and the fit band); zoom out for the rest up to Nyquist
            self._show_default_range(freq, max(high, usable_high))
            self._view_set = True
        band = (freq >= low) & (freq <= high)
        mean_coherence = float(np.mean(frf.coherence[keep][band])) if np.any(band) else float("nan")
        peak = peak_line(frf, self.controller.setup.usable_drop_db)  # as `gasfilm replay` reports it
        self.summary.setText(
            f"{frf.n_averages} averages · {frf.sample_rate_hz:g} S/s · Δf {freq[0]:.3g} Hz · "
            f"peak {frf.freq_hz[peak]:.1f} Hz · mean γ² in band {mean_coherence:.3f} · usable to {usable_high:.0f} Hz"
        )
        self._update_legends()

    def _choose_comparisons(self) -> None:
        folder = self.controller.session_path.parent if self.controller.session_path else self.controller.session_dir
        paths, _ = QFileDialog.getOpenFileNames(self, "Sessions to compare", str(folder), "gasfilm session (*.h5)")
        if paths:
            self.controller.add_comparisons(paths)

    def _comparisons_changed(self) -> None:
        self.clear_compare_button.setEnabled(bool(self.controller.comparisons))
        self._stale = True
        if self.isVisible():
            self.redraw()

    def _draw_comparisons(self, scale: float) -> None:
        """Each compared session's H1 (magnitude and phase) in its own colour, named in the legends."""
        for curve in self._comparison_curves:
            for plot in (self.magnitude_plot, self.phase_plot):
                if curve in plot.getPlotItem().listDataItems():
                    plot.removeItem(curve)
        self._comparison_curves = []
        for number, (label, frf) in enumerate(self.controller.comparisons):
            keep = frf.freq_hz > 0
            color = PALETTE[(number + 1) % len(PALETTE)]
            h = frf.h1[keep] * scale
            self._comparison_curves += [
                self.magnitude_plot.plot(frf.freq_hz[keep], self._shown_magnitude(np.abs(h)), pen=pen(color, 1.2),
                                         name=label),
                self.phase_plot.plot(frf.freq_hz[keep], phase_deg(h), pen=pen(color, 1.0), name=label),
            ]

    def _update_legends(self) -> None:
        for plot in (self.magnitude_plot, self.phase_plot, self.real_plot, self.imag_plot, self.coherence_plot):
            show_legend_only_with_data(plot)

    def _show_default_range(self, freq, high_hz: float) -> None:
        """Frequencies up to ``high_hz`` (the usable band's top, or the fit band's when higher) and a little beyond."""
        top = min(float(freq[-1]), 1.1 * high_hz)
        if self.log_frequency.isChecked():
            self.magnitude_plot.setXRange(np.log10(freq[0]), np.log10(top), padding=0.02)
        else:
            self.magnitude_plot.setXRange(0.0, top, padding=0.02)

    def _set_log_frequency(self, log_x: bool) -> None:
        for plot in (self.magnitude_plot, self.phase_plot, self.real_plot, self.imag_plot, self.coherence_plot):
            plot.getPlotItem().setLogMode(x=log_x)
        low, high = self.controller.fit_band_hz
        self._set_band(low, high, move_region=True)
        if self.frf is not None:
            keep = self.frf.freq_hz > 0
            _, usable_high = usable_band_hz(self.frf.freq_hz, self.frf.gff, self.controller.setup.usable_drop_db)
            self._show_default_range(self.frf.freq_hz[keep], max(high, usable_high))

    def _region_moved(self) -> None:
        low, high = self.region.getRegion()
        if self.log_frequency.isChecked():
            low, high = 10.0**low, 10.0**high
        self._set_band(low, high, move_region=False)

    def _band_typed(self) -> None:
        self._set_band(self.band_low.value(), self.band_high.value(), move_region=True)

    def _set_band(self, low: float, high: float, move_region: bool) -> None:
        low, high = sorted((max(0.0, low), max(0.0, high)))
        self.controller.fit_band_hz = (low, high)
        for spin, value in ((self.band_low, low), (self.band_high, high)):
            spin.blockSignals(True)
            spin.setValue(value)
            spin.blockSignals(False)
        if move_region:
            self.region.blockSignals(True)
            set_region_hz(self.region, low, high, self.log_frequency.isChecked())
            self.region.blockSignals(False)
        set_region_hz(self.coherence_region, low, high, self.log_frequency.isChecked())
        if self.isVisible():
            self.redraw()
        else:  # (a band chosen elsewhere: drawn when the tab is shown)
            self._stale = True

    def show_band(self, band_hz: tuple[float, float]) -> None:
        """Follow a band chosen elsewhere (a session's stored fits)."""
        self._set_band(band_hz[0], band_hz[1], move_region=True)
