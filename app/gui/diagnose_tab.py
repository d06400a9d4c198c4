"""Diagnose tab: what the rig spec leaves out, with evidence, before/after overlay and residuals; improved spec."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import (
    QMessageBox,
    QFileDialog,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QListWidget,
    QListWidgetItem,
    QProgressBar,
    QPushButton,
    QSplitter,
    QTabWidget,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

import pyqtgraph as pg

from gasfilm.analysis.diagnosis import Finding
from gasfilm.analysis.diagnosis.pipeline import replayed_mean
from gasfilm.analysis.diagnosis.plots import FILM_CURVE_LABELS, film_parts, has_film_view
from gasfilm.analysis.diagnosis.report import chi2_headline, gain_sentences
from gasfilm.analysis.diagnosis.structure import mode_row_notes
from gasfilm.analysis.quantities import band_text, uncertainty_text, unit_word
from gasfilm.app.gui.controller import SessionController
from gasfilm.app.gui.widgets import MEASURED_COLOR, PALETTE, FixedHeightLabel, make_plot, pen
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

G = STANDARD_GRAVITY_M_S2
INTRO_TEXT = "Compares the session with its rig spec under the same test conditions."
WAITING_TEXT = "The diagnosis waits until the acquisition is stopped."
READY_TEXT = "Acquisition stopped: diagnose the session's accepted hits against its rig spec."
FILM_INTRO_TEXT = ("After a diagnosis: the film's stiffness K(ω) and damping C(ω) read off the recordings, against the "
                   "spec's film (the paper's eqs. 19–20).")
FILM_STORED_TEXT = ("A stored diagnosis keeps no spectra: run Diagnose to draw the film's stiffness K(ω) and damping "
                    "C(ω).")
FILM_NOT_READ_TEXT = ("The film's K(ω) and C(ω) are read for a film on a point mover; this diagnosis is of a measured "
                      "structure or a rigid body (see its mode table and the overlay).")


def headline(verdict: str, chi2_before: float | None, chi2_after: float | None, details: str) -> str:
    """The Diagnose tab's summary: the verdict and, as the headline figure, χ² per point before → after (1 = the
    noise), worded as ``gasfilm diagnose`` prints it; RMS, BIC, hits and time as details."""
    figure = f" — <b>{chi2_headline(chi2_before, chi2_after)}</b>" if chi2_before is not None \
        and chi2_after is not None else ""
    return f"<b>Verdict: {verdict}</b>{figure}<br>{details}"


def finding_title(finding: Finding) -> str:
    """A finding's line in the list: where its own signature is, in the words its details use ("extra-mode near
    640 Hz", not the wider band its χ² gain spans)."""
    status = "modelled" if finding.status == "modelled" else "named"
    place = f", {finding.place}" if finding.place else ""
    return f"{finding.effect} — {finding.where.split(';')[0]}   ({status}{place}; {finding.hits})"


class DiagnoseTab(QWidget):
    """Run the mismatch diagnosis of the session against its rig spec and show what it found."""

    def __init__(self, controller: SessionController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.controller = controller

        self.run_button = QPushButton("Diagnose the session")
        self.run_button.setObjectName("diagnose")
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setEnabled(False)
        # A busy bar (the diagnosis cannot say how far it is) with the time it has run beside it, in room kept while
        # hidden: nothing in the row moves when it starts.
        self.progress = QProgressBar()
        self.progress.setRange(0, 0)
        self.progress.setFixedWidth(110)
        self.elapsed = QLabel()
        self.elapsed.setFixedWidth(self.elapsed.fontMetrics().horizontalAdvance("running 000 s") + 6)
        self._started_s = 0.0
        self._clock = QTimer(self)
        self._clock.setInterval(500)
        self._clock.timeout.connect(self._show_elapsed)
        for widget in (self.progress, self.elapsed):
            policy = widget.sizePolicy()
            policy.setRetainSizeWhenHidden(True)
            widget.setSizePolicy(policy)
            widget.hide()
        self.status = FixedHeightLabel(INTRO_TEXT, lines=2)  # progress text changes: the findings list stays put
        self.export_button = QPushButton("Export improved rig spec…")
        self.play_button = QPushButton("Play improved spec on the simulated rig")
        self.play_button.setObjectName("play_improved")
        for button in (self.export_button, self.play_button):
            button.setEnabled(False)
        self.reference_path = QLineEdit()
        self.reference_path.setPlaceholderText("the rig spec the session was recorded with")
        self.reference_path.setToolTip("Diagnose against another spec, e.g. the design model of the rig")
        reference_browse = QPushButton("Open…")
        reference_browse.clicked.connect(self._choose_reference)
        top = QHBoxLayout()
        top.addWidget(QLabel("Reference rig spec"))
        top.addWidget(self.reference_path, 1)
        top.addWidget(reference_browse)
        top.addWidget(self.run_button)
        top.addWidget(self.cancel_button)
        top.addWidget(self.progress)
        top.addWidget(self.elapsed)
        top.addWidget(self.export_button)
        top.addWidget(self.play_button)

        self.summary = QLabel()
        self.summary.setWordWrap(True)
        self.summary.setTextFormat(Qt.TextFormat.RichText)
        self.findings = QListWidget()
        self.findings.currentItemChanged.connect(self._show_finding)
        self.details = QTextBrowser()
        self.quality = QListWidget()
        self.quality.setWordWrap(True)
        self.findings.setWordWrap(True)
        findings_box = QGroupBox("Findings (what the spec leaves out: named, or modelled in its place)")
        findings_layout = QVBoxLayout(findings_box)
        findings_layout.addWidget(self.status)
        findings_layout.addWidget(self.summary)
        findings_layout.addWidget(self.findings, 1)
        findings_layout.addWidget(self.details, 2)
        quality_box = QGroupBox("Measurement quality (never claimed as physics)")
        QVBoxLayout(quality_box).addWidget(self.quality)
        left = QSplitter(Qt.Orientation.Vertical)
        left.addWidget(findings_box)
        left.addWidget(quality_box)
        left.setSizes([600, 200])

        self.overlay_plot = make_plot("Measured vs rig spec, before and after", ("|H|", "g/N"), log_y=True)
        self.residual_plot = make_plot("Residual |H_model − H_measured|", ("|ΔH|", "g/N"))
        self.residual_plot.setXLink(self.overlay_plot)
        # the film's restoring force r = F − m·a of every hit's free decay (model-free; diagnosis-restoring-force.png)
        self.restoring_stiffness_plot = make_plot("Film restoring force: r − c·v against x", ("r − c·v", "N"),
                                                  ("displacement x", "µm"))
        self.restoring_damping_plot = make_plot("r − k·x against v", ("r − k·x", "N"), ("velocity v", "mm/s"))
        restoring = QWidget()
        restoring_layout = QHBoxLayout(restoring)
        restoring_layout.setContentsMargins(0, 0, 0, 0)
        restoring_layout.addWidget(self.restoring_stiffness_plot)
        restoring_layout.addWidget(self.restoring_damping_plot)
        self.restoring_label = QLabel()
        self.restoring_label.setWordWrap(True)
        # a structure read off the FRF: its stabilization diagram (as diagnosis-stabilization.png); hidden otherwise
        self.stabilization_plot = make_plot("Stabilization diagram (LSCF): poles by model order, modes as lines",
                                            ("model order", ""))
        self.stabilization_plot.hide()
        before_after = QWidget()
        plots_layout = QVBoxLayout(before_after)
        plots_layout.setContentsMargins(0, 0, 0, 0)
        plots_layout.addWidget(self.overlay_plot, 3)
        plots_layout.addWidget(self.residual_plot, 2)
        plots_layout.addWidget(restoring, 2)
        plots_layout.addWidget(self.restoring_label)
        plots_layout.addWidget(self.stabilization_plot, 3)

        # the film's dynamic stiffness read off the recordings against the spec's (diagnosis-film.png)
        self.film_stiffness_plot = make_plot("Film stiffness K(ω) = Re(F/X − M·s²)", ("stiffness K", "N/m"),
                                             log_x=True)
        self.film_damping_plot = make_plot("Film damping C(ω) = Im(F/X − M·s²) / ω", ("damping C", "N·s/m"),
                                           log_x=True)
        self.film_damping_plot.setXLink(self.film_stiffness_plot)
        for plot in (self.film_stiffness_plot, self.film_damping_plot):  # one width: the linked frequencies line up
            plot.getPlotItem().getAxis("left").setWidth(72)
        self.film_label = QLabel(FILM_INTRO_TEXT)
        self.film_label.setWordWrap(True)
        film = QWidget()
        film_layout = QVBoxLayout(film)
        film_layout.setContentsMargins(0, 0, 0, 0)
        film_layout.addWidget(self.film_label)
        film_layout.addWidget(self.film_stiffness_plot, 1)
        film_layout.addWidget(self.film_damping_plot, 1)

        self.views = QTabWidget()
        self.views.setObjectName("diagnosis_views")
        self.views.addTab(before_after, "Before / after: FRF, residual, restoring force")
        self.views.addTab(film, "Film: stiffness K(ω), damping C(ω)")

        splitter = QSplitter(Qt.Orientation.Horizontal)
        splitter.addWidget(left)
        splitter.addWidget(self.views)
        splitter.setSizes([450, 800])
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(splitter, 1)

        self.run_button.clicked.connect(lambda: controller.run_diagnosis(self.reference_path.text().strip() or None,
                                                                         self.confirm_replace))
        self.cancel_button.clicked.connect(lambda: controller.cancel_job("diagnose"))
        self.export_button.clicked.connect(self._export)
        self.play_button.clicked.connect(controller.play_improved_spec)
        controller.job_running.connect(self._on_running)
        controller.acquisition_state.connect(self._on_acquisition_state)
        controller.job_progress.connect(self._on_progress)
        controller.diagnosis_changed.connect(self.show_diagnosis)
        controller.stored_diagnosis_loaded.connect(self.show_stored_diagnosis)
        controller.session_opened.connect(self._on_session_opened)

    def _on_session_opened(self, _path: str) -> None:
        """Another session: the reference spec typed for the previous one goes (the session's own spec is the
        default; a stored diagnosis made against another spec puts that one back) and the status starts again."""
        self.reference_path.clear()
        self.status.setText(INTRO_TEXT)

    def confirm_replace(self, folder: Path, names: list[str]) -> bool:
        """Ask before replacing an earlier diagnosis's files (``gasfilm diagnose`` refuses without --overwrite)."""
        answer = QMessageBox.question(
            self, "Replace the earlier diagnosis's files?",
            f"{folder} holds an earlier diagnosis's files ({', '.join(names)}); the runs themselves stay in the "
            f"session.\n\nReplace the files with this run's?",
            QMessageBox.StandardButton.Yes | QMessageBox.StandardButton.No, QMessageBox.StandardButton.No)
        return answer == QMessageBox.StandardButton.Yes

    def _choose_reference(self) -> None:
        start = self.reference_path.text() or str(self.controller.session_path.parent if self.controller.session_path
                                                      else self.controller.session_dir)
        path, _ = QFileDialog.getOpenFileName(self, "Reference rig spec", start, "Rig spec (*.toml)")
        if path:
            self.reference_path.setText(path)

    def _on_acquisition_state(self, state: str) -> None:
        """While armed the button stays, and says why it will refuse: hits are still arriving. Once stopped, the
        waiting note gives way to what can be done now."""
        reason = "Stop the acquisition first: hits are still arriving and the FRF changes with each one."
        self.run_button.setToolTip(reason if state != "idle" else "")
        if state == "starting":
            self.status.setText(WAITING_TEXT)
        elif state == "idle" and self.status.text() == WAITING_TEXT:
            self.status.setText(READY_TEXT if self.controller.accepted_count else INTRO_TEXT)

    def _on_running(self, job: str, running: bool) -> None:
        if job != "diagnose":
            return
        self.run_button.setEnabled(not running)
        self.cancel_button.setEnabled(running)
        self.progress.setVisible(running)
        self.elapsed.setVisible(running)
        if running:
            self.status.setText("Diagnosing the session's accepted hits against the rig spec…")
            self._started_s = time.monotonic()
            self._show_elapsed()
            self._clock.start()
        else:
            self._clock.stop()

    def _show_elapsed(self) -> None:
        self.elapsed.setText(f"running {time.monotonic() - self._started_s:.0f} s")

    def _on_progress(self, job: str, fraction: float, text: str) -> None:
        if job == "diagnose":
            self.status.setText(text)

    def show_diagnosis(self, diagnosis: Any) -> None:
        self.findings.clear()
        self.quality.clear()
        self.details.clear()
        self.overlay_plot.clear()
        self.residual_plot.clear()
        self.restoring_stiffness_plot.clear()
        self.restoring_damping_plot.clear()
        self.restoring_label.clear()
        self.stabilization_plot.clear()
        self.stabilization_plot.hide()
        for plot in (self.film_stiffness_plot, self.film_damping_plot):
            plot.clear()
            plot.getPlotItem().legend.clear()
        self.film_label.setText(FILM_INTRO_TEXT)
        has_spec = diagnosis is not None and diagnosis.improved_spec_path is not None
        self.export_button.setEnabled(has_spec)
        self.play_button.setEnabled(has_spec)
        if diagnosis is None:
            self.summary.clear()
            return
        better = diagnosis.improvement_e
        self.summary.setText(headline(
            diagnosis.verdict, diagnosis.chi2_per_point_before, diagnosis.chi2_per_point_after,
            f"RMS {diagnosis.rms_before / G:.3g} → {diagnosis.rms_after / G:.3g} g/N (E = {better:.1f} %), "
            f"BIC {diagnosis.bic_before:.0f} → {diagnosis.bic_after:.0f}, {diagnosis.evidence.hit_count} hits, "
            f"{self.controller.diagnosis_seconds(diagnosis):.1f} s"))
        for finding in diagnosis.findings:
            item = QListWidgetItem(finding_title(finding))
            item.setData(Qt.ItemDataRole.UserRole, finding)
            self.findings.addItem(item)
        if not diagnosis.findings:
            self._show_no_findings(diagnosis.verdict, diagnosis.recalibration)
        self._show_unexplained([item.to_dict() for item in diagnosis.unexplained])
        self._show_structure(diagnosis.to_dict().get("structure"))
        for note in diagnosis.quality:
            band = f" ({band_text(*note.band_hz)})" if note.band_hz else ""
            self.quality.addItem(f"{note.kind}{band}: {note.message}")
        if self.findings.count():
            self.findings.setCurrentRow(0)
        self._plot(diagnosis)
        self.status.setText("Diagnosis complete.")

    def show_stored_diagnosis(self, stored: dict[str, Any]) -> None:
        """What a reopened session's diagnosis said: verdict, findings and quality (the plots need a new run)."""
        self.show_diagnosis(None)
        self.summary.setText(headline(
            stored["verdict"], stored.get("chi2_per_point_before"), stored.get("chi2_per_point_after"),
            f"RMS {stored['rms_before_g_per_n']:.3g} → {stored['rms_after_g_per_n']:.3g} g/N "
            f"(E = {stored['e_percent']:.1f} %), BIC {stored['bic_before']:.0f} → {stored['bic_after']:.0f}, "
            f"{stored['hits_used']} hits (stored)"))
        self.film_label.setText(FILM_STORED_TEXT)
        for values in stored["findings"]:
            finding = Finding.from_dict(values)
            item = QListWidgetItem(finding_title(finding))
            item.setData(Qt.ItemDataRole.UserRole, finding)
            self.findings.addItem(item)
        if not stored["findings"]:
            self._show_no_findings(stored["verdict"], stored["recalibration"])
        self._show_unexplained(stored.get("unexplained", []))
        self._show_structure(stored.get("structure"))
        for note in stored["quality"]:
            band = f" ({band_text(*note['band_hz'])})" if note.get("band_hz") else ""
            self.quality.addItem(f"{note['kind']}{band}: {note['message']}")
        if self.findings.count():
            self.findings.setCurrentRow(0)
        status = "Stored diagnosis from the session file; run Diagnose to redraw the before/after plots."
        reference = (stored.get("options") or {}).get("rig")  # the spec it was made against (None: the session's)
        if reference and Path(reference).is_file():
            self.reference_path.setText(reference)
        elif reference:
            status += f" It was made against {reference}, not found from here: the session's own spec is the default."
        self.status.setText(status)

    def _show_finding(self, item: QListWidgetItem | None) -> None:
        if item is None:
            return
        finding = item.data(Qt.ItemDataRole.UserRole)
        if finding is None:
            return
        if isinstance(finding, dict):  # the measured structure's item: its mode table
            self.details.setHtml(self._modes_html(finding))
            return
        rows = "".join(
            f"<tr><td>{name}</td><td align='right'>{values['value']:.4g}</td>"
            f"<td align='right'>{uncertainty_text(values['uncertainty'])}</td><td>{unit_word(values['unit'])}</td>"
            f"<td>{'not determined by the data' if name in finding.undetermined else ''}</td></tr>"
            for name, values in finding.parameters.items()
        )
        mechanisms = ""
        if finding.mechanisms:
            first, *others = finding.mechanisms
            named = "Named" if finding.status == "named" else "Likely (modelled, not certain)"
            mechanisms = f"<p><b>{named}:</b> {first.name}</p>"
            if others:
                mechanisms += (f"<p><b>Also consistent:</b> {'; '.join(m.name for m in others)} — "
                               f"{first.tell_apart} would tell them apart</p>")
        self.details.setHtml(
            f"<h3>{finding.effect}</h3>"
            f"<p><b>Where:</b> {finding.place + ': ' if finding.place else ''}{finding.where}, {finding.hits}</p>"
            + mechanisms +
            f"<p><b>What:</b></p><table cellpadding='3'>{rows}</table>"
            f"<p><b>Why:</b> {finding.evidence}</p>"
            f"<p><b>In plain words:</b> {finding.explanation}</p>"
            f"<p><b>How much better:</b> χ² gain {finding.chi2_gain:.0f}, on held-out hits {finding.held_out_gain:.0f} "
            f"(noise units); {'; '.join(gain_sentences(finding))}</p>"
            + "".join(f"<p><b>Or:</b> {alternative.effect} — {alternative.note}</p>"
                      for alternative in finding.alternatives)
        )

    def _show_structure(self, structure: dict[str, Any] | None) -> None:
        """A measured structure: an item whose details are the mode table, and the stabilization diagram when the
        structure was read off the FRF (poles by class, modes as lines)."""
        if not structure or not structure.get("modes"):
            return
        read = structure.get("read_off_frf")
        item = QListWidgetItem(f"Measured structure: {len(structure['modes'])} modes (mode table)"
                               + (", read off the FRF (stabilization diagram)" if read else ""))
        item.setData(Qt.ItemDataRole.UserRole, structure)
        self.findings.addItem(item)
        if not self.findings.currentItem():
            self.details.setHtml(self._modes_html(structure))
        if not read or not isinstance(read.get("stabilization"), dict):
            return
        from gasfilm.analysis.diagnosis.plots import STABILITY_STYLE
        from gasfilm.analysis.diagnosis.structure import STABILITY

        diagram = read["stabilization"]
        order = np.asarray(diagram["order"], float)
        freq = np.asarray(diagram["freq_hz"], float)
        stability = np.asarray(diagram["stability"], int)
        symbols = {".": "o", "x": "x", "+": "+", "o": "o"}
        for index, (name, (marker, size, _)) in enumerate(zip(STABILITY, STABILITY_STYLE)):
            rows = stability == index
            colour = PALETTE[8] if index == 0 else PALETTE[index - 1]
            self.stabilization_plot.plot(freq[rows], order[rows], pen=None, symbol=symbols[marker],
                                         symbolSize=2 * size + 1, symbolPen=colour,
                                         symbolBrush=colour if index < len(STABILITY) - 1 else None,
                                         name=f"stable in {name}" if index else "new")
        for mode in read.get("modes_read", []):
            self.stabilization_plot.addLine(x=mode["freq_hz"], pen=pen(PALETTE[0], 0.6, Qt.PenStyle.DashLine))
        self.stabilization_plot.setXRange(*read["band_hz"], padding=0.01)
        self.stabilization_plot.show()

    @staticmethod
    def _modes_html(structure: dict[str, Any]) -> str:
        rows = "".join(
            f"<tr><td>{number}</td><td align='right'>{row['freq_hz']:.2f}</td>"
            f"<td align='right'>{row['damping_ratio']:.3g}</td><td align='right'>{row['modal_constant_per_kg']:+.4g}</td>"
            f"<td align='right'>{row['quadrature_per_kg']:+.3g}</td>"
            f"<td>{mode_row_notes(row)}</td></tr>"
            for number, row in enumerate(sorted(structure["modes"], key=lambda row: row["freq_hz"]), start=1))
        kind = "a driving point" if structure.get("driving_point") else "a transfer FRF (modal constants of both signs)"
        return (f"<h3>Measured structure: modes</h3><p>{kind}; mass line {structure.get('mass_line_kg', 0):.4g} kg, "
                f"polarity {structure.get('polarity', 1):+d}.</p><table cellpadding='3'><tr><th>#</th>"
                f"<th>frequency (Hz)</th><th>damping ratio</th><th>modal constant (1/kg)</th>"
                f"<th>quadrature (1/kg)</th><th></th></tr>{rows}</table>")

    def _show_unexplained(self, unexplained: list[dict[str, Any]]) -> None:
        """What the final spec does not explain within the noise, where and in which hits: each band holding a share
        of the excess on its own line, the rest counted in one (as the terminal report does)."""
        from gasfilm.analysis.diagnosis.report import LISTED_SHARE

        minor = [item for item in unexplained if item["chi2_share"] < LISTED_SHARE]
        for item in unexplained:
            if item["chi2_share"] < LISTED_SHARE:
                continue
            self.findings.addItem(f"NOT explained: {band_text(*item['band_hz'])}, {100 * item['chi2_share']:.0f} % of "
                                  f"the excess — {item['character']}")
        if minor:
            self.findings.addItem(f"and {len(minor)} more band(s) beyond the noise, each under "
                                  f"{100 * LISTED_SHARE:.0f} % of the excess")

    def _show_no_findings(self, verdict: str, recalibration: dict[str, dict[str, float]]) -> None:
        self.findings.addItem({
            "consistent": "Nothing left: the spec explains the recordings within the noise.",
            "parameters-only": "No missing physics: the spec's own parameters needed correcting (see details).",
        }.get(verdict, "No term of the catalog explains the mismatch (see NOT explained below)."))
        self.details.setHtml(self._recalibration_html(recalibration))

    @staticmethod
    def _recalibration_html(recalibration: dict[str, dict[str, float]]) -> str:
        if not recalibration:
            return "<p>The spec's own parameters needed no correction.</p>"
        rows = "".join(
            f"<tr><td>{name}</td><td align='right'>{v['spec']:.4g}</td><td align='right'>{v['fitted']:.4g}</td>"
            + ("<td>at its bound: not a measurement</td>" if v.get("at_bound")
               else f"<td align='right'>{uncertainty_text(v['uncertainty'])}</td>")
            + f"<td>{unit_word(v.get('unit'))}</td></tr>"
            for name, v in recalibration.items()
        )
        return (
            "<h3>Recalibrated spec parameters</h3><table cellpadding='3'>"
            f"<tr><th>parameter</th><th>spec</th><th>fitted</th><th>uncertainty</th><th>unit</th></tr>{rows}</table>"
        )

    def _plot(self, diagnosis: Any) -> None:
        # the recordings and both specs replayed with the recorded forces: the "after" curve is the written spec's
        freq = diagnosis.spectra.freq_hz
        measured = replayed_mean(diagnosis.spectra, None)
        before = replayed_mean(diagnosis.spectra, diagnosis.given)
        after = replayed_mean(diagnosis.spectra, diagnosis.improved)
        self.overlay_plot.plot(freq, np.abs(measured) / G, pen=pen(MEASURED_COLOR, 2.5), name="measured (mean of hits)")
        self.overlay_plot.plot(
            freq, np.abs(before) / G, pen=pen(PALETTE[1], 1.5, Qt.PenStyle.DashLine), name="rig spec (before)"
        )
        self.overlay_plot.plot(freq, np.abs(after) / G, pen=pen(PALETTE[0], 1.5), name="improved spec (after)")
        self.residual_plot.plot(freq, np.abs(before - measured) / G, pen=pen(PALETTE[1], 1.5), name="before")
        self.residual_plot.plot(freq, np.abs(after - measured) / G, pen=pen(PALETTE[0], 1.5), name="after")
        self._plot_restoring_force(diagnosis.restoring_force)
        self._plot_film(diagnosis)

    def _plot_film(self, diagnosis: Any) -> None:
        """The film's stiffness K(ω) and damping C(ω) read off the recordings (±2σ) against the film as given, the
        written spec's film and the written spec as a whole: the curves of diagnosis-film.png
        (:func:`~gasfilm.analysis.diagnosis.plots.film_parts`)."""
        if not has_film_view(diagnosis):
            self.film_label.setText(FILM_NOT_READ_TEXT)
            return
        freq_hz, parts, written_label = film_parts(diagnosis)
        for plot, part in zip((self.film_stiffness_plot, self.film_damping_plot), parts):
            item = plot.getPlotItem()
            upper = pg.PlotDataItem(freq_hz, part.recorded + part.two_sigma, pen=pen("#bbbbbb", 0.5))
            lower = pg.PlotDataItem(freq_hz, part.recorded - part.two_sigma, pen=pen("#bbbbbb", 0.5))
            for curve in (upper, lower):
                item.addItem(curve)
            band_brush = pg.mkBrush(160, 160, 160, 90)
            item.addItem(pg.FillBetweenItem(upper, lower, brush=band_brush))
            # (the legend shows a filled stand-in: a FillBetweenItem sample crashes pyqtgraph's legend)
            item.legend.addItem(pg.PlotDataItem(pen=pen("#bbbbbb", 0.5), fillLevel=0, fillBrush=band_brush),
                                FILM_CURVE_LABELS["band"])
            plot.plot(freq_hz, part.recorded, pen=pen(MEASURED_COLOR, 1.5), name=FILM_CURVE_LABELS["recorded"])
            plot.plot(freq_hz, part.given_film, pen=pen(PALETTE[1], 1.5, Qt.PenStyle.DashLine),
                      name=FILM_CURVE_LABELS["given_film"])
            plot.plot(freq_hz, part.written_film, pen=pen(PALETTE[0], 1.5), name=written_label)
            plot.plot(freq_hz, part.apparent, pen=pen(PALETTE[2], 1.5, Qt.PenStyle.DotLine),
                      name=FILM_CURVE_LABELS["apparent"])
            item.vb.enableAutoRange(x=True)
            item.setYRange(*part.view_range(), padding=0)
        self.film_label.setText(
            f"The film's dynamic stiffness F/X − M·s² read off the recordings (M = "
            f"{diagnosis.improved.moving_mass_kg:.4g} kg, the written spec's moving mass; grey: ±2σ) against the film "
            f"as given, the written spec's {written_label.removeprefix('written spec: ')} and the written spec as a "
            f"whole, as in diagnosis-film.png.")

    def _plot_restoring_force(self, restoring: Any) -> None:
        """The restoring force's stiffness and damping sections, one colour per hit, with the linear film's lines
        and the catalogue shape it has (as in diagnosis-restoring-force.png)."""
        if restoring is None:
            self.restoring_label.setText("Film restoring force: not measured (no quiet free decay to read it from).")
            return
        sections = restoring.sections()
        x_um, v_mm_s, hits = sections.displacement_um, sections.velocity_mm_s, sections.hit_index
        stiffness_part, damping_part = sections.stiffness_part_n, sections.damping_part_n
        k, c = restoring.stiffness_n_per_m, restoring.damping_ns_per_m
        for number in np.unique(hits):
            rows = hits == number
            colour = PALETTE[int(number) % len(PALETTE)]
            for plot, x, y in ((self.restoring_stiffness_plot, x_um, stiffness_part),
                               (self.restoring_damping_plot, v_mm_s, damping_part)):
                plot.plot(x[rows], y[rows], pen=None, symbol="o", symbolSize=2, symbolPen=None, symbolBrush=colour)
        x_line = np.linspace(x_um.min(), x_um.max(), 50)
        v_line = np.linspace(v_mm_s.min(), v_mm_s.max(), 50)
        self.restoring_stiffness_plot.plot(x_line, k * x_line * 1e-6, pen=pen(MEASURED_COLOR, 1.5, Qt.PenStyle.DashLine),
                                           name=f"linear film k = {k:.3g} N/m")
        self.restoring_damping_plot.plot(v_line, c * v_line * 1e-3, pen=pen(MEASURED_COLOR, 1.5, Qt.PenStyle.DashLine),
                                         name=f"linear film c = {c:.3g} N·s/m")
        self.restoring_label.setText(f"Film restoring force (F − m·a, colour = hit): {restoring.description()}")

    def _export(self) -> None:
        default = str(self.controller.session_dir / "improved.toml")
        if self.controller.session_path is not None:
            default = str(self.controller.session_path.with_name(f"{self.controller.session_path.stem}-improved.toml"))
        path, _ = QFileDialog.getSaveFileName(self, "Improved rig spec", default, "Rig spec (*.toml)")
        if not path:
            return
        try:
            self.controller.export_improved_spec(path)
        except GasfilmError as error:
            self.controller.message.emit(str(error), "error")
            return
        self.controller.message.emit(f"improved rig spec written to {path}", "info")
