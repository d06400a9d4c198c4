"""What a hammer-test engineer expects at the rig (issue 32): keys for every step of a hit, a hit check before the
test, windows drawn on the trace, cursor read-outs, dB or linear magnitude, Hv and the overlay of other sessions'
FRFs — driven like a technician would (pytest-qt, offscreen, the simulated rig)."""

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QKeySequence

from gasfilm.app.gui.measure_tab import SHORTCUTS
from gasfilm.app.gui.settings import SetupState
from gui_driving import arm, hit, open_window, stop


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    main.activateWindow()
    yield main
    main.controller.shutdown()


def _key(qtbot, window, name: str) -> None:
    """Press the key of the Measure menu's action ``name`` on the window, as a technician (or a foot switch) does."""
    sequence = QKeySequence(SHORTCUTS[name])
    combination = sequence[0]
    qtbot.keyClick(window.tabs.currentWidget(), combination.key(), combination.keyboardModifiers())


def test_every_step_of_a_hit_has_a_key_shown_in_the_menu_and_the_buttons_tooltip(window):
    assert SetupState().auto_accept  # a hit that passes every check is accepted without a key: on by default
    menu = window.measure_menu
    shown = {action.objectName(): action.shortcut().toString() for action in menu.actions() if action.objectName()}
    assert shown == {f"{name}_action": QKeySequence(key).toString() for name, key in SHORTCUTS.items()
                     if name != "hit_check"}
    tab = window.measure_tab
    for button, name in ((tab.arm_button, "arm"), (tab.stop_button, "stop"), (tab.accept_button, "accept"),
                         (tab.reject_button, "reject"), (tab.accept_pending_button, "accept_pending")):
        assert f"({QKeySequence(SHORTCUTS[name]).toString()})" in button.toolTip()


def test_a_technician_arms_accepts_rejects_undoes_and_stops_with_keys_alone(qtbot, window):
    window.setup_tab.auto_accept.setChecked(False)  # every hit waits for a key
    controller = window.controller
    window.tabs.setCurrentWidget(window.setup_tab)
    _key(qtbot, window, "arm")
    qtbot.waitUntil(lambda: controller.state == "armed", timeout=10_000)
    assert window.tabs.currentWidget() is window.measure_tab
    for _ in range(3):
        hit(qtbot, window)
    assert controller.pending_count == 3
    window.measure_tab.select_hit(controller.hits[2].index)  # the technician looks at the newest hit ...
    _key(qtbot, window, "accept")  # ... accepts it: the selected hit waits, so it is the one decided
    qtbot.waitUntil(lambda: controller.hits[2].accepted, timeout=5_000)
    _key(qtbot, window, "accept")  # then the oldest waiting hit
    qtbot.waitUntil(lambda: controller.hits[0].accepted, timeout=5_000)
    _key(qtbot, window, "reject")
    qtbot.waitUntil(lambda: not controller.hits[1].pending, timeout=5_000)
    assert not controller.hits[1].accepted and controller.pending_count == 0
    _key(qtbot, window, "undo")  # the newest accepted hit leaves the average
    qtbot.waitUntil(lambda: not controller.hits[2].accepted, timeout=5_000)
    qtbot.waitUntil(lambda: controller.frf is not None and controller.frf.n_averages == 1, timeout=5_000)
    _key(qtbot, window, "stop")
    qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
    verdicts = [entry.verdict.accepted for entry in controller.hits]
    assert verdicts == [True, False, False]
