"""Screenshots of a rigid-body test in the GUI: ``python -m gasfilm.app.gui.rigid_screenshots [--out DIR]``.

Runs the real GUI offscreen on the simulated rig ``fixtures/rigs/three-pads.toml`` with pad 1 stiffer (its elastic
centre 14 mm off the centre of mass): the hammer and three accelerometers on ai0…ai3, a run of hits at each of the
four hammer points (the roving test: stop, pick the next point, arm), then the Rigid body tab's analysis. Writes
``setup-rigid.png``, ``measure-rigid.png``, ``rigid.png`` (layout, each direction's FRF with its fit, the
stiffness and damping with the couplings) and ``rigid-channels.png`` (each accelerometer at one point) to
``docs/screenshots/``.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6.QtCore import QSettings  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from gasfilm.analysis.physics.spec import RigSpec  # noqa: E402
from gasfilm.app.gui.main_window import DEFAULT_WINDOW_SIZE, MainWindow  # noqa: E402
from gasfilm.app.gui.screenshots import DEFAULT_OUT, _save, _settle, _wait_until  # noqa: E402
from gasfilm.app.gui.settings import ChannelSetup  # noqa: E402

RIG = Path(__file__).resolve().parents[2] / "fixtures" / "rigs" / "three-pads.toml"
HITS_PER_POINT = 4


def take_rigid_screenshots(out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    scratch = Path(tempfile.mkdtemp(prefix="gasfilm-rigid-screenshots-"))
    window = MainWindow(QSettings(str(scratch / "settings.ini"), QSettings.Format.IniFormat), scratch)
    window.resize(*DEFAULT_WINDOW_SIZE)
    window.show()
    controller = window.controller
    spec = RigSpec.load(RIG)
    spec = spec.with_values(film_parameters={**spec.film_parameters, "k_pad1": 1.4e7, "eta_pad1": 2000.0})
    rig = scratch / "three-pads-offset.toml"
    spec.save(rig)
    state = window.setup_tab.state()
    state.device = "sim"
    state.rig_spec_path = str(rig)
    state.sample_rate_hz = 51200.0 / 4
    state.trigger = {**state.trigger, "record_s": 1.0, "pretrigger_s": 0.01, "level_n": 20.0}
    state.channels = [ChannelSetup("ai0", "force", True, "hammer", "PCB 086C02", 11.2, "mV/N")] + [
        ChannelSetup(f"ai{k}", "acceleration", True, sensor.name, f"PCB 352B s/n {sensor.serial}",
                     sensor.sensitivity_mv_per_m_s2, "mV/(m/s^2)")  # the library's calibrated entries
        for k, sensor in enumerate(spec.rigid_body.accelerometers, start=1)]
    state.response_channel = "ai1"
    state.live_view_s = 3.0
    window.setup_tab.set_state(state)
    written = [_save(window, window.setup_tab, out_dir / "setup-rigid.png", app)]
    controller.new_session(scratch / "rigid-session.h5")
    for number, point in enumerate(spec.rigid_body.point_names):
        window.rigid_tab.point_combo.setCurrentText(point)
        controller.arm()
        _wait_until(app, lambda: controller.state == "armed", 20, "the simulated device to stream")
        _settle(app, 0.3)
        for _ in range(HITS_PER_POINT):
            count = len(controller.hits)
            controller.virtual_hit("medium")
            _wait_until(app, lambda c=count: len(controller.hits) == c + 1, 20, "a hit")
            _settle(app, 0.3)
        if number == 1:
            written.append(_save(window, window.measure_tab, out_dir / "measure-rigid.png", app))
        controller.stop()
        _wait_until(app, lambda: controller.state == "idle", 20, "the acquisition to stop")
    window.tabs.setCurrentWidget(window.rigid_tab)
    window.rigid_tab.analyse()
    written.append(_save(window, window.rigid_tab, out_dir / "rigid.png", app))
    window.rigid_tab.view_combo.setCurrentIndex(2)
    written.append(_save(window, window.rigid_tab, out_dir / "rigid-channels.png", app))
    failures = [text for severity, text in window.banner.history if severity == "error"]
    controller.shutdown()
    window.close()
    if failures:
        raise RuntimeError("rigid screenshots: the session reported errors: " + " | ".join(failures))
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"folder for the PNGs (default {DEFAULT_OUT})")
    take_rigid_screenshots(parser.parse_args(argv).out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
