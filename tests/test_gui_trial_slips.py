"""The GUI's side of the second new-user trial's slips: stored fits made with other settings are replaced only when
the technician says so, as `gasfilm fit` refuses without --overwrite."""

import pytest

from gasfilm.analysis.session import Session
from PySide6.QtCore import Qt

from gui_driving import arm, configure, fits_finish, hit, open_window, stop
from test_cli_acquire_replay import FAST_SIM, gasfilm


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    yield main
    main.controller.shutdown()


def test_identify_asks_before_replacing_a_stored_fit_made_with_other_settings(qtbot, window, tmp_path, capsys):
    path = tmp_path / "run.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 3, "--seed", 2)[0] == 0
    assert gasfilm(capsys, "fit", path, "--models", "SD", "--out", tmp_path)[0] == 0
    with Session.open(path) as session:
        stored = session.read_fit("SD")
    controller, tab = window.controller, window.identify_tab
    controller.open_session(path)
    asked = []
    tab.set_selected_models(["SD"])

    # the stored band: nothing to ask, the fit runs
    tab.confirm_replace = lambda conflicts: asked.append(conflicts) or False
    tab.run_fits()
    qtbot.waitUntil(lambda: not controller.job_active("fit"), timeout=60_000)
    assert not asked

    controller.fit_band_hz = (50.0, 800.0)
    tab.run_fits()  # answered No: no fit, the stored one kept
    assert len(asked) == 1 and "SD: stored over 20–1000 Hz" in asked[0][0] and "; now over 5" in asked[0][0], asked
    assert not controller.job_active("fit") and "kept" in tab.status.text()
    with Session.open(path) as session:
        assert list(session.read_fit("SD")["band_hz"]) == list(stored["band_hz"])

    tab.confirm_replace = lambda conflicts: asked.append(conflicts) or True
    tab.run_fits()  # answered Yes: replaced, with the settings it was made with
    qtbot.waitUntil(lambda: not controller.job_active("fit"), timeout=60_000)
    controller.save_session()
    with Session.open(path, "r") as session:
        replaced = session.read_fit("SD")
    assert replaced["band_hz"][0] >= 50.0 and replaced["frf_name"] == "frf"
    assert replaced["mass_given_kg"] == stored["mass_kg"]  # the session's mover mass, as `gasfilm fit` takes it


def test_a_gui_diagnosis_is_kept_beside_the_earlier_ones_and_stored_once(qtbot, window, tmp_path, capsys):
    path = tmp_path / "run.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 3, "--seed", 2)[0] == 0
    assert gasfilm(capsys, "diagnose", path, "--mass", "25", "--out", tmp_path / "d", "--no-figures")[0] == 0
    controller = window.controller
    controller.open_session(path)
    controller.run_diagnosis()
    qtbot.waitUntil(lambda: not controller.job_active("diagnose"), timeout=120_000)
    assert controller.diagnosis is not None, window.banner.history
    controller.save_session()
    controller.save_session()  # saving again stores nothing new
    controller.close_session()
    with Session.open(path) as session:
        runs = sorted(name for name in session.result_names("diagnoses") if name != "latest")
        assert runs == ["run-001", "run-002"]
        assert session.read_diagnosis("run-001")["options"]["mass_kg"] == 25.0  # the command line's, kept
        assert session.read_diagnosis("latest")["options"]["command"] == "GUI"


def _children(pid: int) -> list[tuple[int, str]]:
    """(pid, command line) of the processes whose parent is ``pid``."""
    from pathlib import Path

    found = []
    for status in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = status.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == pid:
                command = (status.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                found.append((int(status.parent.name), command))
        except (OSError, IndexError, ValueError):
            continue
    return found


def _gui_process(tmp_path, session):
    import os
    import subprocess
    import sys

    environment = {**os.environ, "QT_QPA_PLATFORM": "offscreen", "HOME": str(tmp_path),
                   "XDG_CONFIG_HOME": str(tmp_path / "config")}
    # its own process group, as in a terminal: Ctrl-C there reaches every process of the group
    return subprocess.Popen([sys.executable, "-m", "gasfilm.app.cli", "gui", "--session", str(session)],
                            env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _ended(process) -> str:
    import subprocess

    try:
        _, err = process.communicate(timeout=90)
    except subprocess.TimeoutExpired:  # (the window ignored the signal: no orphan is left behind)
        process.kill()
        process.communicate()
        raise
    return err


@pytest.mark.parametrize("moment", ["while the job process starts", "once the window stands"])
def test_ctrl_c_in_the_terminal_closes_the_gui_cleanly_whenever_it_comes(tmp_path, moment):
    """New-user trial: Ctrl-C printed KeyboardInterrupt tracebacks (or nothing) and the window kept running; and a
    quit in the first seconds, while the job process and its fork server started, printed a multiprocessing
    traceback (issue 32 item 14). Ctrl-C (SIGINT to the whole process group) now ends the start as "interrupted",
    or closes the window like Quit: no traceback, the fork server born deaf to it, the session intact."""
    import os
    import signal
    import time

    session = tmp_path / "viewed.h5"
    from gasfilm.app.cli import main

    assert main(["acquire", *FAST_SIM, "--out", str(session), "--hits", "2", "--seed", "3"]) == 0
    process = _gui_process(tmp_path, session)
    deadline = time.monotonic() + 120
    server = None
    while server is None and time.monotonic() < deadline and process.poll() is None:
        server = next((pid for pid, command in _children(process.pid) if "forkserver" in command), None)
        time.sleep(0.02)
    assert server is not None, _ended(process)
    with open(f"/proc/{server}/status") as status:  # the fork server ignores Ctrl-C from its birth
        ignored = int(next(line for line in status if line.startswith("SigIgn:")).split()[1], 16)
    assert ignored & (1 << (signal.SIGINT - 1))
    if moment == "once the window stands":  # the first job process, forked from the server, waits for work (a fork
        while time.monotonic() < deadline and not _children(server):  # keeps the server's command line)
            time.sleep(0.05)
        time.sleep(1.0)
    os.killpg(process.pid, signal.SIGINT)
    err = _ended(process)
    assert process.returncode in (0, 130) and "Traceback" not in err and "Error" not in err, err
    assert process.returncode == 0 or err.strip().endswith("gasfilm gui: interrupted"), err
    with Session.open(session) as reopened:
        assert reopened.status == "complete" and not reopened.recovered


def test_gui_refuses_a_session_that_is_not_one_before_opening(tmp_path, capsys):
    status, out, err = gasfilm(capsys, "gui", "--session", tmp_path / "nosuch.h5")
    assert status == 2 and err.strip() == f"gasfilm gui: error: {tmp_path / 'nosuch.h5'}: no such session file"


def _fit_after_hits(qtbot, window, hits: int, models: list[str]) -> None:
    tab = window.identify_tab
    arm(qtbot, window)
    for _ in range(hits):
        hit(qtbot, window)
    stop(qtbot, window)
    window.tabs.setCurrentWidget(tab)
    tab.set_selected_models(models)
    qtbot.mouseClick(tab.run_button, Qt.MouseButton.LeftButton)
    fits_finish(qtbot, window, len(models))


def test_the_parameters_panel_shows_the_refit_of_the_selected_model_at_once(qtbot, window):
    """Trial 2026-11-29 item 1: after "Refit on all N hits" the panel kept the previous fit until re-selected."""
    controller, tab = window.controller, window.identify_tab
    _fit_after_hits(qtbot, window, 3, ["SD", "Zener"])
    row = next(r for r in range(tab.table.rowCount()) if tab.table.item(r, 1).text() == "Zener")
    tab.table.selectRow(row)
    before = controller.fits["Zener"]
    arm(qtbot, window)
    hit(qtbot, window)
    stop(qtbot, window)
    qtbot.mouseClick(tab.refit_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not controller.job_active("fit") and controller.fits["Zener"] is not before,
                    timeout=90_000)
    refit = controller.fits["Zener"]
    selected = tab.table.selectionModel().selectedRows()
    assert [tab.table.item(index.row(), 1).text() for index in selected] == ["Zener"]
    shown = {tab.parameters.item(r, 0).text(): tab.parameters.item(r, 1).text()
             for r in range(tab.parameters.rowCount())}
    assert shown == {name: f"{value:.5g}" for name, value in refit.params.items()}
    assert f"{refit.evaluations} evaluations" in tab.flags_text.toPlainText()


def test_the_banner_says_what_the_latest_decision_key_did(qtbot, window):
    """Trial 2026-11-29 item 3: after Ctrl+Z then A the banner still said the hit was taken out; R and A said
    nothing."""
    from PySide6.QtGui import QKeySequence

    from gasfilm.app.gui.measure_tab import SHORTCUTS

    def key(name: str) -> None:
        combination = QKeySequence(SHORTCUTS[name])[0]
        qtbot.keyClick(window.tabs.currentWidget(), combination.key(), combination.keyboardModifiers())

    window.activateWindow()
    arm(qtbot, window)
    for _ in range(2):
        hit(qtbot, window)
    stop(qtbot, window)
    newest = window.controller.hits[-1]
    key("undo")
    assert not newest.accepted and f"hit {newest.index + 1} taken out of the average" in window.banner.text
    key("accept")
    assert newest.accepted and window.banner.text == f"hit {newest.index + 1} accepted: in the average"
    key("reject")
    assert not newest.accepted and window.banner.text == f"hit {newest.index + 1} rejected by hand: out of the average"


def test_the_exponential_window_cursor_is_drawn_only_while_the_window_is_on(qtbot, window):
    """Trial 2026-11-29 item 8: the Selected-hit plot drew an "exp. window" cursor with the window off."""
    arm(qtbot, window)
    hit(qtbot, window)
    stop(qtbot, window)
    tab = window.measure_tab
    tab.select_hit(window.controller.hits[0].index)
    assert window.controller.window_settings().exponential_end_fraction is None
    drawn = tab.hit_plot.getPlotItem().items
    assert tab.force_window_line in drawn and tab.exp_window_line not in drawn
    configure(window, window={**window.setup_tab.state().window, "exponential_end_fraction": 0.01})
    assert tab.exp_window_line in tab.hit_plot.getPlotItem().items and "ends at 0.01" in tab.exp_window_line.label.format
    configure(window)  # off again
    assert tab.exp_window_line not in tab.hit_plot.getPlotItem().items


def test_a_report_written_from_the_gui_after_stop_says_the_session_is_complete(qtbot, window, tmp_path):
    """Trial 2026-11-29 item 9: the GUI's report said "session status recording"; the command line's "complete"."""
    arm(qtbot, window)
    hit(qtbot, window)
    stop(qtbot, window)
    written = window.write_report(tmp_path / "after-stop-report.html")
    text = written.read_text()
    assert "session status complete." in text and "session status recording" not in text
    with Session.open(window.controller.session_path, "r") as session:
        assert session.status == "complete"
    arm(qtbot, window)  # the session takes hits again after the report
    hit(qtbot, window)
    stop(qtbot, window)
    assert len(window.controller.hits) == 2


def test_the_setup_tabs_editors_are_not_squashed_at_the_default_size(qtbot, window):
    """Trial 2026-11-29 item 6: with the operating conditions beside the device, the accept rules' spin boxes were
    12 px high and their values cut."""
    from PySide6.QtWidgets import QAbstractSpinBox, QComboBox

    from gasfilm.app.gui.main_window import DEFAULT_WINDOW_SIZE

    assert (window.width(), window.height()) == DEFAULT_WINDOW_SIZE
    window.tabs.setCurrentWidget(window.setup_tab)
    qtbot.wait(50)
    editors = window.setup_tab.findChildren(QAbstractSpinBox) + window.setup_tab.findChildren(QComboBox)
    squashed = [(editor.objectName(), editor.height()) for editor in editors
                if editor.isVisible() and editor.height() < editor.minimumSizeHint().height()]
    assert not squashed and window.setup_tab.min_coherence.isVisible()
    conditions = window.setup_tab.conditions_table
    assert conditions.viewport().height() >= sum(conditions.rowHeight(r) for r in range(conditions.rowCount()))


def test_table2_and_the_fit_warnings_are_whole_at_the_default_size(qtbot, window):
    """Trial 2026-11-29 item 2: Table 2's 'At bound' and 'Hits' columns were off the right edge (scrolling to them hid
    the model names) and the correlation warning under the parameters was cut mid-line."""
    from gasfilm.app.gui.main_window import DEFAULT_WINDOW_SIZE

    controller, tab = window.controller, window.identify_tab
    _fit_after_hits(qtbot, window, 3, ["SD", "Zener", "FOMGF"])
    arm(qtbot, window)  # one more hit: every fit is stale, its Hits cell at its widest
    hit(qtbot, window)
    stop(qtbot, window)
    qtbot.wait(50)
    assert (window.width(), window.height()) == DEFAULT_WINDOW_SIZE
    table = tab.table
    assert "⚠ stale" in table.item(0, table.columnCount() - 1).text()
    widths = sum(table.columnWidth(c) for c in range(table.columnCount()))
    assert widths <= table.viewport().width() and not table.horizontalScrollBar().isVisible()
    assert sum(table.rowHeight(r) for r in range(table.rowCount())) <= table.viewport().height()
    assert any(controller.fits[name].flags for name in controller.fits)  # (a warning to show)
    text = tab.flags_text
    for row in range(table.rowCount()):
        table.selectRow(row)
        qtbot.wait(20)
        # the whole warning wrapped to the panel's width, whether its scroll bar shows or not: nothing off the edge
        cells = [table.item(row, column).text().rstrip(" *") for column in range(table.columnCount())]
        assert any(text.toPlainText().startswith(f"{cell}: ") for cell in cells)  # the selected model's
        assert text.document().textWidth() <= text.viewport().width()
        assert not text.horizontalScrollBar().isVisible()


def test_arming_with_the_target_reached_records_nothing_and_says_why(qtbot, tmp_path):
    """Trial 2026-11-29 item 5: F5 after the target of 10 was reached recorded one more hit ("accepted 11 of 10")."""
    window = open_window(qtbot, tmp_path, target_averages=2)
    try:
        controller = window.controller
        arm(qtbot, window)
        hit(qtbot, window)
        hit(qtbot, window)
        qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)  # the target stops it
        window.measure_tab.arm_button.click()
        qtbot.wait(200)
        assert controller.state == "idle" and controller.accepted_count == 2
        assert window.banner.text.startswith("target of 2 averages already reached (2 accepted in ")
        configure(window, target_averages=3)  # raised: arming adds hits again
        arm(qtbot, window)
        hit(qtbot, window)
        qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
        assert controller.accepted_count == 3
    finally:
        window.controller.shutdown()


def test_the_measure_tabs_hit_views_show_their_labels_whole_at_the_default_size(qtbot, window):
    """Trial 2026-11-29 item 7: the four views needed scroll arrows and read "cted hit", "Hit ch"."""
    window.tabs.setCurrentWidget(window.measure_tab)
    arm(qtbot, window)
    hit(qtbot, window)
    stop(qtbot, window)
    qtbot.wait(50)
    bar = window.measure_tab.hit_views.tabBar()
    assert sum(bar.tabSizeHint(i).width() for i in range(bar.count())) <= bar.width()
    assert all(bar.tabRect(i).width() >= bar.tabSizeHint(i).width() for i in range(bar.count()))


def test_a_session_without_a_spec_is_diagnosed_from_its_frf_as_the_command_does_not_against_the_setup(
        qtbot, window, tmp_path, capsys):
    """A session replayed from a UFF holds no rig spec: with the reference field empty the GUI read a start off the
    FRF as `gasfilm diagnose` does — it diagnosed against the Setup tab's spec (another rig's) and said nothing."""
    recorded, exported, replayed = tmp_path / "run.h5", tmp_path / "run.uff", tmp_path / "from-uff.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", recorded, "--hits", 3, "--seed", 2)[0] == 0
    assert gasfilm(capsys, "export", recorded, "--uff", exported)[0] == 0
    assert gasfilm(capsys, "replay", exported, "--out", replayed)[0] == 0
    controller = window.controller
    controller.open_session(replayed)
    controller.run_diagnosis()
    qtbot.waitUntil(lambda: not controller.job_active("diagnose"), timeout=120_000)
    assert controller.diagnosis is not None, window.banner.history
    assert controller.diagnosis.notes[0].startswith("no rig spec given: a start read off the FRF")


def test_opening_a_session_replaces_what_the_banner_said_of_the_previous_one(qtbot, window, tmp_path, capsys):
    """A new user opened a second session and the banner still announced the first one's diagnosis ("diagnosis
    finished … verdict not explained"), also while the second was being diagnosed."""
    first, second = tmp_path / "first.h5", tmp_path / "second.h5"
    for path, seed in ((first, 2), (second, 3)):
        assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 3, "--seed", seed)[0] == 0
    controller = window.controller
    controller.open_session(first)
    controller.message.emit("diagnosis finished in 3.0 s: verdict not explained (first-diagnosis/)", "info")
    controller.open_session(second)
    assert window.banner.text.startswith("opened second.h5: 3 hits (3 accepted)"), window.banner.history
