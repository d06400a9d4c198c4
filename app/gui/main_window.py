"""The main window: the error banner, the five tabs, the Session and Simulator menus, the status bar."""

from __future__ import annotations

import logging
import signal
import sys
from pathlib import Path

from PySide6.QtCore import QSettings, QTimer
from PySide6.QtGui import QAction, QCloseEvent, QKeySequence
from PySide6.QtWidgets import (
    QApplication,
    QFileDialog,
    QGridLayout,
    QLabel,
    QMainWindow,
    QMessageBox,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from gasfilm.app.gui.controller import STOP_FIRST, SessionController
from gasfilm.app.gui.diagnose_tab import DiagnoseTab
from gasfilm.app.gui.frf_tab import FrfTab
from gasfilm.app.gui.identify_tab import IdentifyTab
from gasfilm.app.gui.measure_tab import MeasureTab
from gasfilm.app.gui.rigid_tab import RigidTab
from gasfilm.app.gui.settings import (
    SETTINGS_APPLICATION,
    SETTINGS_ORGANIZATION,
    SetupState,
    load_setup,
    save_setup,
)
from gasfilm.app.gui.setup_tab import SetupTab
from gasfilm.app.gui.widgets import Banner, HomeViews, configure_pyqtgraph
from gasfilm.app.gui.workers import warm_up_job_processes
from gasfilm.drivers import SIMULATED_DEVICE_NAME
from gasfilm.drivers.errors import GasfilmError

SIM_FAULTS = {
    "overflow": "Buffer overflow",
    "device_removed": "Device removed (unplugged)",
    "open_sensor": "Open sensor (cable pulled)",
    "overload": "Overload on the next hit",
}
logger = logging.getLogger(__name__)
STATUS_INTERVAL_MS = 500
#: The window's size at start: every tab is laid out (and its screenshot taken) at this size.
DEFAULT_WINDOW_SIZE = (1500, 950)


class MainWindow(QMainWindow):
    """Setup → Measure → FRF → Identify → Diagnose, and the Rigid body tab of a mover with several accelerometers."""

    def __init__(self, settings: QSettings | None = None, session_dir: Path | None = None) -> None:
        super().__init__()
        configure_pyqtgraph()
        self.setWindowTitle("gasfilm — impact testing of gas films")
        self.settings = settings or QSettings(SETTINGS_ORGANIZATION, SETTINGS_APPLICATION)
        setup, settings_problem = load_setup(self.settings)
        self.controller = SessionController(setup, session_dir, self)
        self.banner = Banner()
        self.pending_dialog: QMessageBox | None = None
        self.running_dialog: QMessageBox | None = None
        self._closed = False
        self._closing_on_signal = False
        try:
            self.setup_tab = SetupTab(setup)
        except (GasfilmError, ValueError, TypeError, KeyError, OverflowError) as error:  # stored values Qt refuses
            settings_problem = (
                f"stored GUI settings in {self.settings.fileName()} are damaged ({error}); using the defaults"
            )
            self.setup_tab = SetupTab(SetupState())
        if settings_problem:
            self.banner.show_message(settings_problem, "warning")
        self.controller.setup = self.setup_tab.state()
        self.measure_tab = MeasureTab(self.controller)
        self.frf_tab = FrfTab(self.controller)
        self.identify_tab = IdentifyTab(self.controller)
        self.diagnose_tab = DiagnoseTab(self.controller)
        self.rigid_tab = RigidTab(self.controller)
        self.tabs = QTabWidget()
        for tab, title in (
            (self.setup_tab, "1  Setup"),
            (self.measure_tab, "2  Measure"),
            (self.frf_tab, "3  FRF"),
            (self.identify_tab, "4  Identify"),
            (self.diagnose_tab, "5  Diagnose"),
            (self.rigid_tab, "6  Rigid body"),
        ):
            self.tabs.addTab(tab, title)
        central = QWidget()
        layout = QVBoxLayout(central)
        layout.setContentsMargins(6, 6, 6, 6)
        # The banner's row is kept while no message shows (nothing shifts when one arrives); a quiet hint fills it.
        banner_row = QGridLayout()
        hint = QLabel("Device faults, refused settings and finished jobs are reported here.")
        hint.setStyleSheet("QLabel { color: #888888; padding-left: 10px; }")
        banner_row.addWidget(hint, 0, 0)
        banner_row.addWidget(self.banner, 0, 0)
        layout.addLayout(banner_row)
        layout.addWidget(self.tabs, 1)
        self.setCentralWidget(central)

        self.session_label = QLabel()
        self.stream_label = QLabel()
        self.statusBar().addWidget(self.session_label, 1)
        self.statusBar().addPermanentWidget(self.stream_label)
        self._build_menus()

        self.setup_tab.changed.connect(self._setup_changed)
        self.measure_tab.apply_hit_check.connect(self.apply_hit_check)
        self.measure_tab.window_dragged.connect(self.setup_tab.set_window)
        self.setup_tab.teds_said.connect(lambda text: self.banner.show_message(text, "info"))
        self.setup_tab.changed.connect(lambda: self.rigid_tab.refresh() if self.controller.session is None else None)
        self.controller.message.connect(self.banner.show_message)
        self.controller.session_changed.connect(self._session_changed)
        self.controller.acquisition_state.connect(self._acquisition_state)
        self.controller.acquisition_state.connect(self._session_changed)
        self.controller.fits_changed.connect(lambda: self.frf_tab.show_band(self.controller.fit_band_hz))
        self.status_timer = QTimer(self)
        self.status_timer.setInterval(STATUS_INTERVAL_MS)
        self.status_timer.timeout.connect(self._update_stream_status)
        self.status_timer.start()
        self._session_changed("")
        self.home_views = HomeViews(self.tabs)  # (every plot as first laid out: an opened session starts from it)
        self.controller.session_opened.connect(self.home_views.restore)
        self.resize(*DEFAULT_WINDOW_SIZE)

    # --- menus ----------------------------------------------------------------------------------------------------

    def _build_menus(self) -> None:
        session = self.menuBar().addMenu("&Session")
        self._add_action(session, "&New session…", self.new_session, QKeySequence.StandardKey.New)
        self._add_action(session, "&Open session…", self.open_session, QKeySequence.StandardKey.Open)
        self._add_action(session, "&Save", self.controller.save_session, QKeySequence.StandardKey.Save)
        self._add_action(session, "Save &as…", self.save_session_as, QKeySequence.StandardKey.SaveAs)
        session.addSeparator()
        self._add_action(session, "&Replay with the current Setup settings", self.controller.replay)
        session.addSeparator()
        self._add_action(session, "Export FRF as &UFF 58…",
                         lambda: self._export("UFF 58 (*.uff)", self.controller.export_uff, ".uff"))
        self._add_action(session, "Export FRF as &CSV…",
                         lambda: self._export("CSV (*.csv)", self.controller.export_csv, ".csv"))
        self._add_action(session, "Export this tab as &PNG…",
                         lambda: self._export("PNG image (*.png)", self.export_png, f"-{self._tab_name()}.png"))
        self._add_action(
            session, "Write a &report (HTML or PDF)…",
            lambda: self._export("HTML report (*.html);;PDF report (*.pdf)", self.write_report, "-report.html"),
        )
        session.addSeparator()
        self._add_action(session, "&Quit", self.close, QKeySequence.StandardKey.Quit)
        measure = self.menuBar().addMenu("&Measure")
        for name, action in self.measure_tab.actions_by_name.items():
            if name in ("accept", "undo"):
                measure.addSeparator()
            measure.addAction(action)
        self.measure_menu = measure
        simulator = self.menuBar().addMenu("Si&mulator")
        faults = simulator.addMenu("Inject a device &fault")
        for kind, label in SIM_FAULTS.items():
            self._add_action(faults, label, lambda _=False, k=kind: self.controller.inject_fault(k))
        self.simulator_menu = simulator

    def _add_action(self, menu, text: str, slot, shortcut=None) -> QAction:
        action = QAction(text, self)
        if shortcut is not None:
            action.setShortcut(shortcut)
        action.triggered.connect(lambda _=False: slot())
        menu.addAction(action)
        return action

    # --- sessions and exports ----------------------------------------------------------------------------------------

    def new_session(self) -> None:
        path, _ = QFileDialog.getSaveFileName(
            self, "New session file", str(self.dialog_folder()), "gasfilm session (*.h5)"
        )
        if path:
            self.controller.new_session(path)

    def open_session(self) -> None:
        path, _ = QFileDialog.getOpenFileName(
            self, "Open session", str(self.dialog_folder()), "gasfilm session (*.h5)"
        )
        if path:
            self.controller.open_session(path)

    def save_session_as(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Save session as", str(self.proposed_path("-copy.h5")),
                                              "gasfilm session (*.h5)")
        if path:
            self.controller.save_session_as(path)

    def export_png(self, path: str | Path) -> Path:
        """The visible tab as a PNG image."""
        path = Path(path)
        if not self.tabs.currentWidget().grab().save(str(path)):
            raise GasfilmError(f"{path}: the image could not be written")
        return path

    def write_report(self, path: str | Path) -> Path:
        """The open session's report (:mod:`gasfilm.analysis.report`), after storing the FRF, fits and diagnosis;
        the file dialog has already asked before replacing an existing file."""
        from gasfilm.analysis.report import write_report

        if self.controller.session_path is None or self.controller.session is None:
            raise GasfilmError("report: no session open: record or open one first")
        if self.controller.acquiring:
            raise GasfilmError("report: stop the acquisition first (hits are still arriving)")
        self.controller.save_session()
        self.controller.end_recording()  # the report says "complete", as after `gasfilm acquire`, not "recording"
        path = Path(path)
        if not path.suffix:
            path = path.with_suffix(".html")
        return write_report(self.controller.session_path, path, overwrite=True)

    def _tab_name(self) -> str:
        return self.tabs.tabText(self.tabs.currentIndex()).split()[-1].lower()

    def dialog_folder(self) -> Path:
        """Where a file dialog opens: the open session's folder, else the folder sessions are made in (never the
        process's working directory)."""
        if self.controller.session_path is not None:
            return self.controller.session_path.parent
        return self.controller.session_dir

    def proposed_path(self, ending: str) -> Path:
        """The file a dialog proposes: the session's name with ``ending`` ("-report.html", ".uff", …) in its folder."""
        stem = self.controller.session_path.stem if self.controller.session_path is not None else "gasfilm"
        return self.dialog_folder() / f"{stem}{ending}"

    def _export(self, file_filter: str, export, ending: str) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Export", str(self.proposed_path(ending)), file_filter)
        if not path:
            return
        try:
            written = export(path)
        except GasfilmError as error:
            self.banner.show_message(str(error), "error")
            return
        self.banner.show_message(f"exported {written}", "info")

    def apply_hit_check(self) -> None:
        """Stop the hit check and set the Setup tab as its taps propose (one click)."""
        state = self.controller.hit_check_setup()
        if state is None:
            return
        self.controller.stop_and_wait()
        self.setup_tab.set_state(state)
        proposal = self.controller.hit_check_proposal
        window = f"exponential window to {proposal.exponential_end_fraction:g}" \
            if proposal.exponential_end_fraction is not None else "no exponential window"
        tip = f", {proposal.tip} tip on the simulated hammer" if proposal.tip and state.sim_tip == proposal.tip else ""
        self.banner.show_message(
            f"hit check applied: trigger {proposal.trigger_level_n:g} N, record {proposal.record_s:g} s, force window "
            f"{proposal.force_window_ms:g} ms, {window}{tip}" + (f" (change the hammer's tip: {proposal.tip})"
                                                                if proposal.tip and not tip else ""), "info")

    # --- state ------------------------------------------------------------------------------------------------------

    def _setup_changed(self) -> None:
        state = self.setup_tab.state()
        windows_changed = state.window != self.controller.setup.window
        self.controller.setup = state
        if windows_changed and not self.controller.acquiring:  # other windows: the FRF follows at once
            self.controller.update_running_frf()
            self.measure_tab.draw_windows()
        save_setup(self.settings, state)
        self.simulator_menu.setEnabled(state.device == SIMULATED_DEVICE_NAME)
        if not self.controller.acquiring:
            self.measure_tab.hammer_box.setVisible(state.device == SIMULATED_DEVICE_NAME)

    def _session_changed(self, *_: object) -> None:
        """The status bar names the session the hits go into: open, about to be created by the next Arm, or none;
        during a hit check, that nothing is recorded."""
        controller = self.controller
        if controller.hit_checking:
            text = "Hit check: nothing is recorded (Stop, then Arm to record)"
        elif controller.session is not None and controller.session_path is not None:
            text = f"Session: {controller.session_path}"
        elif controller.session_path is not None:
            text = f"Session: {controller.session_path} (new: the next Arm records into it)"
        else:
            text = f"Session: none (the next Arm creates one in {controller.session_dir})"
        self.session_label.setText(text)

    def _acquisition_state(self, state: str) -> None:
        self.setup_tab.setEnabled(state == "idle")
        if state == "idle":
            self.banner.withdraw(STOP_FIRST)
        if state == "starting":
            self.tabs.setCurrentWidget(self.measure_tab)

    def _update_stream_status(self) -> None:
        loop = self.controller.loop
        if loop is None:
            self.stream_label.setText("not streaming")
            return
        seconds = loop.samples_read / loop.sample_rate_hz
        stats = self.controller.acquisition_stats
        dropped = f" · {stats.dropped_chunks} chunks dropped" if stats is not None and stats.dropped_chunks else ""
        self.stream_label.setText(
            f"{loop.channel_count} ch · {loop.sample_rate_hz:g} S/s · "
            f"{seconds:.1f} s streamed · view {self.measure_tab.redraw_rate_hz():.0f} fps{dropped}"
        )

    def ask_about_running_acquisition(self) -> bool:
        """Quitting while armed: stop the acquisition and quit (every hit is already stored), or stay. False: stay."""
        if not self.controller.acquiring:
            return True
        what = "A hit check runs" if self.controller.hit_checking else (
            f"The acquisition runs ({len(self.controller.hits)} hits recorded, each already in the session)")
        box = QMessageBox(self)
        box.setIcon(QMessageBox.Icon.Question)
        box.setWindowTitle("Stop the acquisition?")
        box.setText(f"{what}. Stop it and quit?")
        quit_button = box.addButton("Stop and quit", QMessageBox.ButtonRole.AcceptRole)
        cancel = box.addButton(QMessageBox.StandardButton.Cancel)
        box.setDefaultButton(cancel)
        self.running_dialog = box  # tests answer it
        box.exec()
        self.running_dialog = None
        return box.clickedButton() is quit_button

    def ask_about_pending_hits(self) -> bool:
        """Before quitting with hits that wait for a decision: accept them, reject them, or keep them waiting
        (stored as not accepted; they wait again when the session is reopened). False: do not quit."""
        pending = self.controller.pending_count
        if pending == 0:
            return True
        box = QMessageBox(self)
        box.setIcon(QMessageBox.Icon.Question)
        box.setWindowTitle("Hits wait for your decision")
        box.setText(f"{pending} hit{'s' if pending > 1 else ''} wait{'' if pending > 1 else 's'} for your decision.")
        box.setInformativeText(
            "Accept or reject them now? Kept undecided, they are stored as not accepted and wait for you when the "
            "session is opened again."
        )
        accept = box.addButton("Accept all", QMessageBox.ButtonRole.AcceptRole)
        reject = box.addButton("Reject all", QMessageBox.ButtonRole.DestructiveRole)
        keep = box.addButton("Keep undecided", QMessageBox.ButtonRole.NoRole)
        cancel = box.addButton(QMessageBox.StandardButton.Cancel)
        box.setDefaultButton(cancel)
        self.pending_dialog = box  # tests answer it
        box.exec()
        self.pending_dialog = None
        clicked = box.clickedButton()
        if clicked is accept:
            self.controller.stop_and_wait()
            self.controller.accept_all_pending()
        elif clicked is reject:
            self.controller.stop_and_wait()
            self.controller.reject_all_pending()
        return clicked in (accept, reject, keep)

    def close_on_signal(self, signal_number: int) -> None:
        """SIGTERM, SIGHUP or SIGINT (``kill``, a closed terminal, a logout, Ctrl-C): quit like *Quit*, without asking — hits that
        wait for a decision stay undecided (stored as not accepted) — and close the session cleanly."""
        logger.warning("signal %d: closing the window and the session", signal_number)
        self._closing_on_signal = True
        self.close()

    def closeEvent(self, event: QCloseEvent) -> None:
        if self._closed:
            super().closeEvent(event)
            return
        if not self._closing_on_signal and not (self.ask_about_running_acquisition() and self.ask_about_pending_hits()):
            event.ignore()
            return
        save_setup(self.settings, self.setup_tab.state())
        self.controller.shutdown()
        self._closed = True
        super().closeEvent(event)


def run_gui(device: str | None = None, session: str | Path | None = None, received: list[int] | None = None) -> int:
    """Start the GUI (``gasfilm gui``); ``device`` overrides the remembered device, ``session`` opens a file;
    ``received`` holds stop signals that arrived while it loaded (kept, and more added, until the window stands)."""
    # SIGTERM, SIGHUP and SIGINT (Ctrl-C) while the window is being built are kept, not raised inside Qt's calls
    # (where an exception is lost): once the window stands, it quits as on a later signal.
    received = [] if received is None else received
    stop_signals = (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)
    for number in stop_signals:
        signal.signal(number, lambda number_received, _frame: received.append(number_received))
    app = QApplication.instance() or QApplication(sys.argv[:1])
    warm_up_job_processes()  # fits and diagnoses run in child processes: have their fork server ready
    if received:  # (before a window exists: the start is interrupted)
        raise KeyboardInterrupt(signal.Signals(received[0]).name)
    app.setOrganizationName(SETTINGS_ORGANIZATION)
    app.setApplicationName(SETTINGS_APPLICATION)
    window = MainWindow()
    if device:
        state = window.setup_tab.state()
        state.device = device
        window.setup_tab.set_state(state)
    if session:
        window.controller.open_session(session)
    for number in stop_signals:  # Ctrl-C in the terminal quits the same way
        signal.signal(number, lambda number_received, _frame: QTimer.singleShot(
            0, lambda: window.close_on_signal(number_received)))
    heartbeat = QTimer(window)  # Python runs signal handlers only between bytecodes: wake it while Qt waits
    heartbeat.timeout.connect(lambda: None)
    heartbeat.start(250)
    window.show()
    if received:
        QTimer.singleShot(0, lambda: window.close_on_signal(received[0]))
    return app.exec()
