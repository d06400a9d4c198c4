"""The GUI's rigid-body test (issue 34): a roving hammer over three points with the hammer and three accelerometers,
the runs kept in the session, each point's running FRF its own, and the Rigid body tab's layout, FRFs and fits.
Driven on the simulated rig with Qt offscreen (pytest-qt), like tests/test_gui.py."""

from pathlib import Path

import pytest

from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_session import roving_plan
from gasfilm.app.gui.settings import ChannelSetup
from gui_driving import arm, hit, open_window, stop

RIG = Path(__file__).resolve().parents[1] / "fixtures" / "rigs" / "three-pads.toml"


@pytest.fixture
def window(qtbot, tmp_path):
    spec = RigSpec.load(RIG)
    spec = spec.with_values(film_parameters={**spec.film_parameters, "k_pad1": 1.4e7, "eta_pad1": 2000.0})
    spec.save(tmp_path / "rig.toml")
    channels = [ChannelSetup("ai0", "force", True, "hammer", "PCB 086C02", 11.2, "mV/N")] + [
        ChannelSetup(f"ai{k}", "acceleration", True, sensor.name, f"PCB 352B s/n {sensor.serial}",
                     sensor.sensitivity_mv_per_m_s2, "mV/(m/s^2)")  # the sensor library's calibrated entries
        for k, sensor in enumerate(spec.rigid_body.accelerometers, start=1)]
    main = open_window(qtbot, tmp_path, rig_spec_path=str(tmp_path / "rig.toml"), channels=channels,
                       response_channel="ai1")
    yield main
    main.controller.shutdown()


def test_a_roving_test_in_the_gui_identifies_the_rigid_body(qtbot, window, tmp_path):
    controller, tab = window.controller, window.rigid_tab
    assert tab.spec is not None and tab.point_combo.count() == 4
    # the sensor library's serial-numbered entries are offered and picked
    assert window.setup_tab.channel_cell(2, "Sensor").currentText() == "PCB 352B s/n LW210002"
    controller.new_session(tmp_path / "rigid.h5")
    for point in ("centre", "east", "north"):
        tab.point_combo.setCurrentText(point)
        arm(qtbot, window)
        hit(qtbot, window)
        hit(qtbot, window)
        stop(qtbot, window)
        assert controller.frf.n_averages == 2  # the running FRF is this point's hits
    runs = roving_plan(controller.session.settings).to_setting()
    assert runs == [{"point": "centre", "first_hit": 0}, {"point": "east", "first_hit": 2},
                    {"point": "north", "first_hit": 4}]
    assert all(entry.accepted for entry in controller.hits)
    assert "next to strike: north-east" in tab.next_label.text()
    tab.analyse()
    terms = [tab.table.item(row, 0).text() for row in range(tab.table.rowCount())]
    assert terms[:3] == ["heave", "roll", "pitch"] and "heave–pitch" in terms
    heave_pitch = terms.index("heave–pitch")
    assert tab.table.item(heave_pitch, 5).text() == "coupled"
    assert tab.identification.directions["heave"].fit("SD").params["k"] == pytest.approx(3.4e7, rel=0.02)
    assert tab.view_combo.count() == 4  # the directions, and each point's accelerometers
