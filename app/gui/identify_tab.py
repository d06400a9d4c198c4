"""Identify tab: pick models and fitter, fit in the background with progress and cancel, Table 2, Figures 18/19."""

from __future__ import annotations

import html

import numpy as np
from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QGuiApplication, QShowEvent
from PySide6.QtWidgets import (
    QAbstractItemView,
    QComboBox,
    QFileDialog,
    QFrame,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QListWidget,
    QListWidgetItem,
    QMessageBox,
    QProgressBar,
    QPushButton,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QTabWidget,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

from gasfilm.analysis.control import DEFAULT_MAX_ERROR, PlantSource, RationalModel, approximate
from gasfilm.analysis.control.export import SUFFIXES, write_model
from gasfilm.analysis.identification import DEFAULT_FIT_BAND_HZ, METHODS, best_by_bic
from gasfilm.analysis.physics.elements import PAPER_MODEL_ORDER, PAPER_MODEL_TEXT, get_model
from gasfilm.app.gui.controller import SessionController
from gasfilm.app.gui.widgets import MEASURED_COLOR, PALETTE, FixedHeightLabel, make_plot, pen, phase_deg
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

DEFAULT_MODELS = ("SD", "FOMGF")
#: the colour of a stale fit's mark (made on fewer hits than the session now accepts)
STALE_COLOR = "#a66300"
TABLE2_COLUMNS = ("#", "Model", "Parameters", "RMS (g/N)", "E", "Peak error (g/N)", "E_m", "AIC", "BIC", "At bound",
                  "Hits")
#: Table 2's headers on two lines where they are wider than their values: every column shows at the default size
TABLE2_HEADERS = tuple(name.replace(" (", "\n(").replace("At bound", "At\nbound") for name in TABLE2_COLUMNS)
#: Lines of the selected fit's description and warnings shown at once (more scroll, whole lines)
FLAGS_LINES = 4
#: Rows the parameter table shows without scrolling: the most parameters of the paper's models (FOMGF, 7), and one
#: more.
PARAMETER_ROWS = 8
WAITING_TEXT = "Fitting waits until the acquisition is stopped."
READY_TEXT = "Acquisition stopped: the FRF is final. Pick the models and fit."
METHOD_LABELS = {"default": "default (fast, multi-start least squares)", "gapso": "GA-PSO (the paper's)"}


def _percent(value: float | None) -> str:
    return "—" if value is None else f"{value:.2f} %"


class IdentifyTab(QWidget):
    """Fit gas-film models to the FRF in the chosen band and compare them like the paper."""

    def __init__(self, controller: SessionController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.controller = controller
        self._figures_stale = False

        self.model_list = QListWidget()
        for name in PAPER_MODEL_ORDER:
            item = QListWidgetItem(f"{name} — {PAPER_MODEL_TEXT[name][1]}")
            item.setData(Qt.ItemDataRole.UserRole, name)
            item.setToolTip(PAPER_MODEL_TEXT[name][0])
            item.setCheckState(Qt.CheckState.Checked if name in DEFAULT_MODELS else Qt.CheckState.Unchecked)
            self.model_list.addItem(item)
        self.custom_text = QLineEdit()
        self.custom_text.setPlaceholderText("your network, e.g. k || pot(eta, alpha)")
        add_custom = QPushButton("Add")
        add_custom.clicked.connect(self._add_custom)
        self.method_combo = QComboBox()
        for method in METHODS:
            self.method_combo.addItem(METHOD_LABELS.get(method, method), method)
        self.band_label = QLabel()
        self.run_button = QPushButton("Fit selected models")
        self.run_button.setObjectName("fit")
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setEnabled(False)
        self.refit_button = QPushButton("Refit on all hits")
        self.refit_button.setObjectName("refit")
        self.refit_button.setToolTip("fit the models in Table 2 again, with their fitter and band, on the FRF of all "
                                     "the accepted hits (gasfilm fit --refit)")
        self.refit_button.setEnabled(False)
        self.progress = QProgressBar()
        self.progress.setRange(0, 1000)
        self.status = FixedHeightLabel(lines=2)  # its text changes with every progress report: nothing may move
        self.status.setWordWrap(True)
        left_box = QGroupBox("Models and fitter")
        left = QVBoxLayout(left_box)
        left.addWidget(self.model_list)
        custom_row = QHBoxLayout()
        custom_row.addWidget(self.custom_text, 1)
        custom_row.addWidget(add_custom)
        left.addLayout(custom_row)
        left.addWidget(QLabel("Fitter"))
        left.addWidget(self.method_combo)
        left.addWidget(self.band_label)
        buttons = QHBoxLayout()
        buttons.addWidget(self.run_button)
        buttons.addWidget(self.cancel_button)
        left.addLayout(buttons)
        left.addWidget(self.refit_button)
        left.addWidget(self.progress)
        left.addWidget(self.status)

        self.table = QTableWidget(0, len(TABLE2_COLUMNS))
        self.table.setHorizontalHeaderLabels(TABLE2_HEADERS)
        self.table.verticalHeader().setVisible(False)
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.itemSelectionChanged.connect(self._show_parameters)
        self.parameters = QTableWidget(0, 4)
        self.parameters.setHorizontalHeaderLabels(("Parameter", "Value", "Std error", "Unit"))
        self.parameters.verticalHeader().setVisible(False)
        self.parameters.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        for table in (self.table, self.parameters):  # compact rows: Table 2's nine models show without scrolling
            table.verticalHeader().setDefaultSectionSize(22)
        # every parameter of the largest model shows, whatever the flags and the control model below say
        self.parameters.setFixedHeight(self.parameters.horizontalHeader().sizeHint().height() + PARAMETER_ROWS * 22
                                       + 2 * self.parameters.frameWidth() + 2)  # (the fit's warnings get the rest)
        # the fit's description, notes and warnings wrapped to the panel's width; longer ones scroll, never cut
        # (a text view, not a label in a scroll area: it wraps to its own width whether its scroll bar shows or not)
        self.flags_text = QTextBrowser()
        self.flags_text.setFrameShape(QFrame.Shape.NoFrame)
        self.flags_text.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.flags_text.viewport().setAutoFillBackground(False)
        self.flags_text.setStyleSheet("QTextBrowser { background: transparent; }")
        self.flags_text.setMinimumHeight(FLAGS_LINES * self.fontMetrics().lineSpacing() + 4)
        table_box = QWidget()
        table_layout = QVBoxLayout(table_box)
        table_layout.setContentsMargins(0, 0, 0, 0)
        heading = QLabel("<b>Table 2</b> — RMS (eq. 33) and peak error in g/N; E, E_m against SD (eq. 35); * lowest "
                         "BIC; at bound: parameters the fit left on a search bound")
        heading.setWordWrap(True)
        table_layout.addWidget(heading)
        table_layout.addWidget(self.table)
        parameters_box = QWidget()
        parameters_layout = QVBoxLayout(parameters_box)
        parameters_layout.setContentsMargins(0, 0, 0, 0)
        parameters_layout.addWidget(QLabel("<b>Parameters</b> of the selected model (± standard error)"))
        parameters_layout.addWidget(self.parameters)
        parameters_layout.addWidget(self.flags_text, 1)
        self.control_button = QPushButton("Control model")
        self.control_button.setToolTip(f"a rational state-space model of the selected fit within "
                                       f"{100 * DEFAULT_MAX_ERROR:g} % of it, stable and passive (gasfilm model)")
        self.export_control_button = QPushButton("Export for control design…")
        self.export_control_button.setToolTip("write the selected fit's state-space model as .json, .mat or .npz")
        self.control_label = FixedHeightLabel(lines=2)
        control_row = QHBoxLayout()
        control_row.addWidget(self.control_button)
        control_row.addWidget(self.export_control_button)
        control_row.addStretch(1)
        parameters_layout.addLayout(control_row)
        parameters_layout.addWidget(self.control_label)
        self._control_models: dict[str, RationalModel] = {}
        table_panel = QSplitter(Qt.Orientation.Horizontal)
        table_panel.addWidget(table_box)
        table_panel.addWidget(parameters_box)
        table_panel.setSizes([730, 370])  # Table 2's every column at the default size; the parameters beside it

        self.fig18 = {
            # The models' colours are shown in Table 2 (a swatch by each name): a legend of nine models would
            # cover the curves in a plot this size.
            "magnitude": make_plot(
                "Fig. 18a  log |H| (colours: Table 2)", ("|H|", "g/N"),
                log_y=True, legend=False,
            ),
            "real": make_plot("Fig. 18b  Real part", ("Re H", "g/N"), legend=False),
            "imag": make_plot("Fig. 18c  Imaginary part", ("Im H", "g/N"), legend=False),
            "phase": make_plot("Fig. 18d  Phase", ("Phase", "°"), legend=False),
        }
        self.fig19 = {
            "magnitude": make_plot(
                "Fig. 19a  Error of |H| (colours: Table 2)", ("| |H| − |H_d| |", "g/N"), legend=False
            ),
            "real": make_plot("Fig. 19b  Error of the real part", ("|Re H − Re H_d|", "g/N"), legend=False),
            "imag": make_plot("Fig. 19c  Error of the imaginary part", ("|Im H − Im H_d|", "g/N"), legend=False),
        }
        self.control_plot = make_plot("Rational model of the selected fit: error against the fractional one",
                                      ("|G_rational / G_fractional − 1|", "%"), log_y=True)
        self.control_plot.getPlotItem().setLogMode(x=True, y=True)
        # the empty plot's band in log10 coordinates (20–1000 read as exponents overflowed numpy at every start)
        self.control_plot.getPlotItem().vb.setRange(xRange=np.log10(DEFAULT_FIT_BAND_HZ), padding=0.02,
                                                    disableAutoRange=False)
        self.control_plot.getPlotItem().getAxis("bottom").enableAutoSIPrefix(False)
        figures = QTabWidget()
        figures.addTab(self._grid(list(self.fig18.values()), 2), "Figure 18 — fits")
        figures.addTab(self._grid(list(self.fig19.values()), 3), "Figure 19 — errors")
        figures.addTab(self.control_plot, "Control model — error")
        self.figures = figures

        right = QSplitter(Qt.Orientation.Vertical)
        right.addWidget(table_panel)
        right.addWidget(figures)
        right.setSizes([440, 490])
        splitter = QSplitter(Qt.Orientation.Horizontal)
        splitter.addWidget(left_box)
        splitter.addWidget(right)
        splitter.setSizes([370, 1100])  # the model names whole at the window's default size
        QVBoxLayout(self).addWidget(splitter)

        self.run_button.clicked.connect(self.run_fits)
        self.refit_button.clicked.connect(self.refit)
        self.control_button.clicked.connect(self._on_control_button)
        self.export_control_button.clicked.connect(lambda: self.export_control_model())
        self.cancel_button.clicked.connect(lambda: controller.cancel_job("fit"))
        controller.job_progress.connect(self._on_progress)
        controller.job_running.connect(self._on_running)
        controller.acquisition_state.connect(self._on_acquisition_state)
        controller.fits_changed.connect(self.show_fits)
        controller.frf_changed.connect(lambda _frf: (self._update_band_label(), self._show_hits()))
        self._update_band_label()

    @staticmethod
    def _grid(plots: list, columns: int) -> QWidget:
        widget = QWidget()
        grid = QGridLayout(widget)
        for number, plot in enumerate(plots):
            grid.addWidget(plot, number // columns, number % columns)
            if number:
                plot.setXLink(plots[0])
        return widget

    def selected_models(self) -> list[str]:
        return [
            self.model_list.item(i).data(Qt.ItemDataRole.UserRole)
            for i in range(self.model_list.count())
            if self.model_list.item(i).checkState() == Qt.CheckState.Checked
        ]

    def set_selected_models(self, names: list[str]) -> None:
        for i in range(self.model_list.count()):
            item = self.model_list.item(i)
            checked = item.data(Qt.ItemDataRole.UserRole) in names
            item.setCheckState(Qt.CheckState.Checked if checked else Qt.CheckState.Unchecked)

    def _add_custom(self) -> None:
        text = self.custom_text.text().strip()
        try:
            get_model(text)
        except GasfilmError as error:
            self.status.setText(f"<span style='color:#b3261e'>{error}</span>")
            return
        item = QListWidgetItem(f"custom — {text}")
        item.setData(Qt.ItemDataRole.UserRole, text)
        item.setCheckState(Qt.CheckState.Checked)
        self.model_list.addItem(item)
        self.custom_text.clear()

    def _update_band_label(self) -> None:
        low, high = self.controller.fit_band_hz
        self.band_label.setText(f"Band {low:g}–{high:g} Hz (set it on the FRF tab)")

    def run_fits(self) -> None:
        models = self.selected_models()
        if not models:
            self.status.setText("Tick at least one model.")
            return
        self._update_band_label()
        method, band_hz = self.method_combo.currentData(), self.controller.fit_band_hz
        conflicts = self.controller.stored_fit_conflicts(models, method, band_hz)
        if conflicts and not self.confirm_replace(conflicts):
            self.status.setText("The stored fits are kept: set the band and fitter they were made with, or untick "
                                "those models.")
            return
        self.progress.setValue(0)
        self.controller.run_fits(models, method, band_hz)

    def confirm_replace(self, conflicts: list[str]) -> bool:
        """Ask before replacing stored fits made with other settings (``gasfilm fit`` refuses without --overwrite)."""
        answer = QMessageBox.question(
            self, "Replace stored fits?",
            "The session holds fits made with other settings:\n\n" + "\n".join(conflicts)
            + "\n\nReplace them with the new fits?",
            QMessageBox.StandardButton.Yes | QMessageBox.StandardButton.No, QMessageBox.StandardButton.No)
        return answer == QMessageBox.StandardButton.Yes

    def _on_progress(self, job: str, fraction: float, text: str) -> None:
        if job == "fit":
            self.progress.setValue(int(1000 * fraction))
            self.status.setText(text)

    def _on_acquisition_state(self, state: str) -> None:
        """While armed the button stays, and says why it will refuse: hits are still arriving. Once stopped, the
        waiting note gives way to what can be done now."""
        reason = "Stop the acquisition first: hits are still arriving and the FRF changes with each one."
        self.run_button.setToolTip(reason if state != "idle" else "")
        if state == "starting":
            self.status.setText(WAITING_TEXT)
        elif state == "idle" and self.status.text() == WAITING_TEXT:
            self.status.setText(READY_TEXT if self.controller.frf is not None else "")

    def _on_running(self, job: str, running: bool) -> None:
        if job != "fit":
            return
        self.run_button.setEnabled(not running)
        self.cancel_button.setEnabled(running)
        self.refit_button.setEnabled(not running and bool(self.controller.stale_fits()))
        if not running:
            self.status.setText(f"{len(self.controller.fits)} model(s) fitted" if self.controller.fits else "")

    # --- results -------------------------------------------------------------------------------------------------

    def show_fits(self) -> None:
        """Table 2 of the fits now held; the model selected before stays selected and its parameters are the new
        fit's."""
        selected = self._selected_fit()
        selected_name = selected.model_name if selected is not None else None
        self._control_models.clear()
        self.control_plot.clear()
        self.control_label.clear()
        rows = self.controller.comparison
        g = STANDARD_GRAVITY_M_S2
        best = best_by_bic(rows) if len(rows) > 1 else None
        self.table.setRowCount(len(rows))
        for r, row in enumerate(rows):
            fit = self.controller.fits.get(row.model_name)
            at_bound = ", ".join(fit.at_bound) if fit is not None and fit.at_bound else "—"
            values = (
                str(row.rank),
                row.model_name,
                str(row.n_parameters),
                f"{row.rms / g:.5g}",
                _percent(row.e_percent),
                f"{row.peak_error / g:.4g}",
                _percent(row.e_m_percent),
                f"{row.aic:.1f}",
                f"{row.bic:.1f}" + (" *" if row is best else ""),
                at_bound,
                "",  # hits: _show_hits
            )
            for c, value in enumerate(values):
                item = QTableWidgetItem(value)
                if c != 1:
                    item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                else:  # the swatch of the model's curves in Figures 18 and 19 (they have no legend)
                    item.setData(Qt.ItemDataRole.DecorationRole, QColor(PALETTE[r % len(PALETTE)]))
                self.table.setItem(r, c, item)
        self._show_hits()
        if rows:
            names = [row.model_name for row in rows]
            self.table.selectRow(names.index(selected_name) if selected_name in names else 0)
            self._show_parameters()  # (the same row selected again emits no selection change)
        else:
            self.parameters.setRowCount(0)
            self.flags_text.clear()
        self._update_band_label()
        if self.isVisible():
            self._draw_figures()
        else:  # (fits that arrive while another tab is shown, e.g. the live view: drawn when this one is)
            self._figures_stale = True

    def _show_hits(self) -> None:
        """Each fit's hits in Table 2, a stale fit (made on fewer hits than the session accepts now) marked with
        how many it used, and the Refit button offered while one is."""
        stale = self.controller.stale_fits()
        column = TABLE2_COLUMNS.index("Hits")
        for r in range(self.table.rowCount()):
            name_item = self.table.item(r, 1)
            if name_item is None:
                continue
            hits = self.controller.fit_hits(name_item.text())
            text = "—" if hits is None else str(hits.count)
            item = QTableWidgetItem(f"{text} ⚠ stale" if name_item.text() in stale else text)
            item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            if name_item.text() in stale:
                item.setForeground(QColor(STALE_COLOR))
                item.setToolTip(f"stale: {stale[name_item.text()]} — Refit on all hits fits it again")
            elif hits is None:
                item.setToolTip("the fit does not say which hits it was made on (stored before that was recorded)")
            self.table.setItem(r, column, item)
        self.table.resizeColumnsToContents()
        self.refit_button.setEnabled(bool(stale) and not self.controller.job_active("fit"))
        accepted = self.controller.accepted_count
        self.refit_button.setText(f"Refit on all {accepted} hits" if stale else "Refit on all hits")

    def refit(self) -> None:
        """Fit the models of Table 2 again on all the accepted hits (their fitter and band kept)."""
        self.progress.setValue(0)
        self.controller.refit()

    def showEvent(self, event: QShowEvent) -> None:
        if self._figures_stale:
            self._draw_figures()
        super().showEvent(event)

    def _show_parameters(self) -> None:
        selected = self.table.selectionModel().selectedRows()
        if not selected:
            return
        name = self.table.item(selected[0].row(), 1).text()
        fit = self.controller.fits.get(name)
        if fit is None:
            return
        units = {p.name: p.unit for p in fit.model().parameters}
        self.parameters.setRowCount(len(fit.params))
        for r, (parameter, value) in enumerate(fit.params.items()):
            std = fit.std_errors.get(parameter, float("nan"))
            std_text = "at bound" if parameter in fit.at_bound else f"{std:.3g}"  # at a bound: not a measurement
            for c, text in enumerate((parameter, f"{value:.5g}", std_text, units.get(parameter, ""))):
                self.parameters.setItem(r, c, QTableWidgetItem(text))
        self.parameters.resizeColumnsToContents()
        flags = "; ".join(fit.flags)
        notes = "".join(f"<br>{html.escape(note)}" for note in fit.notes)
        self.flags_text.setHtml(
            f"{fit.model_name}: {fit.network} · {fit.method} fitter · {fit.evaluations} evaluations in "
            f"{fit.wall_time_s:.2f} s" + notes
            + (f"<br><span style='color:#a66300'>⚠ {html.escape(flags)}</span>" if flags else "")
        )
        if fit.model_name in self._control_models:  # the error curve shown is always the selected model's
            self.show_control_model()
        else:
            self.control_plot.clear()
            self.control_label.clear()

    # --- control design ------------------------------------------------------------------------------------------

    def _selected_fit(self) -> object | None:
        selected = self.table.selectionModel().selectedRows()
        return self.controller.fits.get(self.table.item(selected[0].row(), 1).text()) if selected else None

    def show_control_model(self) -> RationalModel | None:
        """The selected fit's rational model (lowest order within 0.5 %): its error curve and summary."""
        fit = self._selected_fit()
        if fit is None:
            self.control_label.setText("Select a fitted model in Table 2 first.")
            return None
        model = self._control_models.get(fit.model_name)
        if model is None:
            where = self.controller.session_path.name if self.controller.session_path is not None else ""
            QGuiApplication.setOverrideCursor(Qt.CursorShape.WaitCursor)
            try:
                model = approximate(PlantSource.from_fit(fit, where), max_error=DEFAULT_MAX_ERROR)
            except GasfilmError as error:
                self.control_label.setText(f"<span style='color:#b3261e'>{error}</span>")
                return None
            finally:
                QGuiApplication.restoreOverrideCursor()
            self._control_models[fit.model_name] = model
        plot = self.control_plot
        plot.clear()
        freq = model.curve_freq_hz
        plot.plot(freq, 100 * model.curve_plant_error + 1e-12, pen=pen(PALETTE[0], 1.5), name="plant (accelerance)")
        plot.plot(freq, 100 * model.curve_film_error + 1e-12, pen=pen(PALETTE[1], 1.5, Qt.PenStyle.DashLine),
                  name="film (stiffness)")
        plot.plot(list(model.band_hz), [100 * DEFAULT_MAX_ERROR] * 2, pen=pen("#b3261e", 1.0), name="target, band")
        self.control_label.setText(f"<b>{fit.model_name}</b> as a rational plant: {model.summary()}")
        return model

    def _on_control_button(self) -> None:
        if self.show_control_model() is not None:
            self.figures.setCurrentWidget(self.control_plot)

    def export_control_model(self, path: str | Path | None = None) -> Path | None:
        """Write the selected fit's rational model (.json, .mat or .npz; asks for the file when ``path`` is None)."""
        model = self.show_control_model()
        if model is None:
            return None
        if path is None:
            default = ""
            if self.controller.session_path is not None:
                session = self.controller.session_path
                default = str(session.with_name(f"{session.stem}-{model.source.origin['fit']['model_name']}.json"))
            path, _ = QFileDialog.getSaveFileName(self, "Export for control design", default,
                                                  "State-space model (*.json *.mat *.npz)")
            if not path:
                return None
        path = Path(path)
        if path.suffix.lower() not in SUFFIXES:
            path = path.with_name(path.name + ".json")
        try:
            written = write_model(model, path)
        except (GasfilmError, OSError) as error:
            self.controller.message.emit(f"{path}: cannot write the control model ({error})", "error")
            return None
        self.controller.message.emit(f"control model ({model.order} states) written to {written}", "info")
        return written

    def _draw_figures(self) -> None:
        self._figures_stale = False
        for plot in list(self.fig18.values()) + list(self.fig19.values()):
            plot.clear()
        frf = self.controller.frf
        fits = self.controller.fits
        if frf is None or not fits:
            return
        low, high = self.controller.fit_band_hz
        band = (frf.freq_hz >= low) & (frf.freq_hz <= high)
        freq = frf.freq_hz[band]
        measured = frf.h1[band] / STANDARD_GRAVITY_M_S2
        fig18 = self.fig18
        fig18["magnitude"].plot(freq, np.abs(measured), pen=pen(MEASURED_COLOR, 2.5), name="measured")
        fig18["real"].plot(freq, measured.real, pen=pen(MEASURED_COLOR, 2.5), name="measured")
        fig18["imag"].plot(freq, measured.imag, pen=pen(MEASURED_COLOR, 2.5), name="measured")
        fig18["phase"].plot(freq, phase_deg(measured), pen=pen(MEASURED_COLOR, 2.5), name="measured")
        order = [row.model_name for row in self.controller.comparison] or list(fits)  # Table 2's rows and colours
        for number, name in enumerate(order):
            fit = fits[name]
            model = fit.accelerance(freq) / STANDARD_GRAVITY_M_S2
            style = pen(PALETTE[number % len(PALETTE)], 1.5, Qt.PenStyle.DashLine)
            fig18["magnitude"].plot(freq, np.abs(model), pen=style, name=name)
            fig18["real"].plot(freq, model.real, pen=style, name=name)
            fig18["imag"].plot(freq, model.imag, pen=style, name=name)
            fig18["phase"].plot(freq, phase_deg(model), pen=style, name=name)
            solid = pen(PALETTE[number % len(PALETTE)], 1.5)
            self.fig19["magnitude"].plot(freq, np.abs(np.abs(model) - np.abs(measured)), pen=solid, name=name)
            self.fig19["real"].plot(freq, np.abs(model.real - measured.real), pen=solid, name=name)
            self.fig19["imag"].plot(freq, np.abs(model.imag - measured.imag), pen=solid, name=name)
