"""Operating conditions with every session, rig-spec film laws, and ``gasfilm campaign`` on dask: a local cluster,
separately started ``dask scheduler``/``dask worker`` processes (same table), a damaged session as one row, the cache."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gasfilm.analysis.campaign import RUN_COLUMNS, read_table
from gasfilm.analysis.campaign.runner import WORKER_CONFIG_PATH, dask_client
from gasfilm.analysis.campaign.simulated import DEMO_RIG_PATH, record_session
from gasfilm.analysis.conditions import decode_conditions, parse_condition_flags
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.app import cli
from gasfilm.drivers.errors import SettingError

FAST_SIM = ["--device", "sim", "--pacing", "fast", "--rate", "6400", "--record-s", "0.25",
            "--hit-interval", "0.3", "0.45"]
#: The small campaign of these tests: 2 pressures at one gap, 3 hits each, short records.
POINTS = ({"supply_pressure_mpa": 0.3, "gap_um": 10.0}, {"supply_pressure_mpa": 0.6, "gap_um": 10.0})
FAST_CAMPAIGN = ["--by", "supply_pressure_mpa", "--models", "SD"]


def gasfilm(capsys, *argv) -> tuple[int, str, str]:
    status = cli.main([str(arg) for arg in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("campaign-sessions")
    spec = RigSpec.load(DEMO_RIG_PATH)
    for number, conditions in enumerate(POINTS):
        record_session(folder / f"s{number}.h5", spec, conditions, hits=3, seed=number, record_s=0.25,
                       sample_rate_hz=6400.0)
    return folder


def comparable(rows: list[dict]) -> list[dict]:
    """Rows without what depends on where and how fast they ran, keyed by file name."""
    return sorted(({key: value for key, value in row.items() if key not in RUN_COLUMNS and key != "session"}
                   | {"name": Path(row["session"]).name} for row in rows), key=lambda row: row["name"])


def test_condition_flags_parse_and_refuse():
    assert parse_condition_flags(["supply_pressure_mpa=0.4", "gap_um = 10", "bearing=B-17"]) == {
        "supply_pressure_mpa": 0.4, "gap_um": 10.0, "bearing": "B-17"}
    assert parse_condition_flags(["supply_pressure_psi=60", "run=3"]) == {"supply_pressure_psi": 60.0, "run": 3.0}
    assert decode_conditions({"conditions": {"gap": 12}}) == {"gap": 12.0}  # an older session still reads
    # a quantity recorded in another unit converts for grouping (new-user trial: kPa grouped as 'not recorded')
    from gasfilm.analysis.conditions import converted_condition

    assert converted_condition({"supply_pressure_kpa": 600.0}, "supply_pressure_mpa") == (
        pytest.approx(0.6), "supply_pressure_kpa")
    assert converted_condition({"gap_mm": 0.01}, "gap_um") == (pytest.approx(10.0), "gap_mm")
    assert converted_condition({"gap_mm": 0.01}, "supply_pressure_mpa") == (None, None)
    assert converted_condition({"flow_nl_min": 3.0}, "flow_l_min") == (None, None)
    for bad, words in ((["gap_um=ten"], "must be a number in µm"), (["Gap=1"], "condition name"),
                       (["gap_um"], "KEY=VALUE"), (["gap_um=1", "gap_um=2"], "given twice"),
                       (["gap_um=nan"], "finite"),
                       # a physical quantity typed as a bare number: the unit was forgotten (new-user trial)
                       (["supply_pressure=0.4"], "supply_pressure needs its unit at the end of the name, e.g. "
                                                 "supply_pressure_mpa"),
                       (["gap=12"], "e.g. gap_um")):
        with pytest.raises(SettingError, match=words):
            parse_condition_flags(bad)


def test_film_laws_move_the_film_and_round_trip(tmp_path):
    spec = RigSpec.load(DEMO_RIG_PATH)
    moved = spec.at_conditions({"supply_pressure_mpa": 0.6, "gap_um": 8.0, "bearing": "B-1"})
    assert moved.film_parameters["k"] == pytest.approx(37.8e6 * (0.6 / 0.4) * (8.0 / 10.0) ** -1)
    assert moved.film_parameters["eta"] == pytest.approx(3450.0 * (0.6 / 0.4) ** -0.5 * (8.0 / 10.0) ** -3)
    assert moved.film_conditions == {"supply_pressure_mpa": 0.6, "gap_um": 8.0}
    again = RigSpec.from_toml(moved.to_toml())
    assert again == moved  # re-based laws kept: the same law from the new reference
    assert again.at_conditions({"supply_pressure_mpa": 0.4, "gap_um": 10.0}).film_parameters["k"] == \
        pytest.approx(37.8e6)
    text = DEMO_RIG_PATH.read_text()
    for change, words in (((" = -3.0", " = -30.0"), "exponent must be within"),
                          (("[film.laws.eta]", "[film.laws.alpha]"), "not a coefficient of SD"),
                          (("gap_um = 10.0", "gap_mm = 0.01"), "needs its reference value")):
        with pytest.raises(SettingError, match=words):
            RigSpec.from_toml(text.replace(*change), "bad.toml")
    with pytest.raises(SettingError, match="gap_um = 0.0: the film's laws need a positive number"):
        spec.at_conditions({"gap_um": 0.0})


def test_acquire_stores_conditions_and_every_command_says_them(tmp_path, capsys):
    path = tmp_path / "run.h5"
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 3, "--rig", DEMO_RIG_PATH,
                               "--condition", "supply_pressure_mpa=0.6", "--condition", "bearing=B-17")
    assert status == 0, err
    assert "conditions: supply_pressure_mpa = 0.6 MPa, bearing = B-17, gap_um = 10 µm" in out
    assert "gap_um = 10 (not given by --condition)" in err  # the law's condition played at its reference, said so
    with Session.open(path) as session:
        assert decode_conditions(session.settings) == {"supply_pressure_mpa": 0.6, "bearing": "B-17", "gap_um": 10.0}
        played = RigSpec.from_toml(session.rig_spec_toml)
    assert played.film_parameters["k"] == pytest.approx(37.8e6 * 1.5)  # the simulator played the law
    status, out, err = gasfilm(capsys, "replay", path, "--json")
    assert json.loads(out)["conditions"]["bearing"] == "B-17"
    status, out, err = gasfilm(capsys, "export", path, "--csv", tmp_path / "frf.csv")
    assert (tmp_path / "frf.csv").read_text().startswith("# condition supply_pressure_mpa = 0.6\n")
    status, out, err = gasfilm(capsys, "report", path, "--out", tmp_path / "r.html")
    assert "Operating conditions" in (tmp_path / "r.html").read_text() and "B-17" in (tmp_path / "r.html").read_text()
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--append", "--hits", 1,
                               "--condition", "supply_pressure_mpa=0.3")
    assert status == 2 and "a session holds one operating point" in err
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", tmp_path / "x.h5", "--condition", "gap_um=a")
    assert status == 2 and "--condition 'gap_um=a': gap_um = 'a': must be a number in µm" in err


def test_campaign_local_damaged_session_is_one_row_and_cache(sessions, tmp_path, capsys):
    folder = tmp_path / "in"
    shutil.copytree(sessions, folder)
    (folder / "damaged.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + os.urandom(2000))
    results = tmp_path / "results"
    results.mkdir()
    out = tmp_path / "out"
    out.symlink_to(results)  # an output folder given as a link is written into (the one rule for links)
    status, stdout, err = gasfilm(capsys, "campaign", folder, *FAST_CAMPAIGN, "--out", out, "--workers", 1)
    assert status == 0, err
    assert "3 sessions, 3 computed on 1 dask worker(s)" in stdout and "1 failed" in stdout
    rows = read_table(out / "campaign.parquet")
    assert len(rows) == 3
    (damaged,) = [row for row in rows if row["error"]]
    assert damaged["session"].endswith("damaged.h5") and "damaged.h5" in damaged["error"]
    assert "\n" not in damaged["error"]
    good = [row for row in rows if not row["error"]]
    for row in good:  # the identified stiffness follows the rig's law
        assert row["SD.k [N/m]"] == pytest.approx(row["spec.k [N/m]"], rel=1e-3)
        assert abs(row["SD.k [N/m]"] - row["spec.k [N/m]"]) < 5 * row["SD.k sigma [N/m]"]
        assert row["diagnosis_verdict"]  # the diagnosis ran
    assert sorted(row["condition.supply_pressure_mpa"] for row in good) == [0.3, 0.6]
    assert (out / "campaign.csv").read_text().count("\n") == 4
    assert out.is_symlink() and (results / "campaign.parquet").is_file()
    report = (out / "campaign.html").read_text()
    assert "Sessions that failed (1)" in report and "K(f) and C(f)" in report
    # a re-run computes only what is not cached: the damaged session again, a new session, nothing else
    record_session(folder / "new.h5", RigSpec.load(DEMO_RIG_PATH), {"supply_pressure_mpa": 0.45, "gap_um": 10.0},
                   hits=3, seed=7, record_s=0.25, sample_rate_hz=6400.0)
    status, stdout, err = gasfilm(capsys, "campaign", folder, *FAST_CAMPAIGN, "--out", out, "--workers", 1)
    assert status == 2 and "--overwrite" in err  # the earlier table is not replaced unasked
    status, stdout, err = gasfilm(capsys, "campaign", folder, *FAST_CAMPAIGN, "--out", out, "--workers", 1,
                                  "--overwrite")
    assert "4 sessions, 2 computed" in stdout and "2 from the cache" in stdout, stdout
    def old(rows: list[dict]) -> list[dict]:
        return [row for row in comparable(rows) if row["name"] in ("s0.h5", "s1.h5")]

    assert old(read_table(out / "campaign.parquet")) == old(rows)  # the cached rows, unchanged


def _worker_settings_probe():
    """A function telling what a worker process runs with: its malloc trim threshold, OpenMP threads, and whether it
    profiles (defined locally, so that it travels by value to workers that cannot import this test module)."""

    def worker_settings() -> tuple[str | None, str | None, bool]:
        import os

        import dask

        return (os.environ.get("MALLOC_TRIM_THRESHOLD_"), os.environ.get("OMP_NUM_THREADS"),
                dask.config.get("distributed.worker.profile.enabled"))

    return worker_settings


def _start(command: list[str], log: Path, environment: dict[str, str] | None = None) -> subprocess.Popen:
    return subprocess.Popen(command, stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True,
                            env=None if environment is None else {**os.environ, **environment})


def test_campaign_through_a_separately_started_scheduler_gives_the_local_table(sessions, tmp_path, capsys):
    dask = str(Path(sys.executable).with_name("dask"))  # the `dask` command installed with distributed
    scheduler_file = tmp_path / "scheduler.json"
    processes = [_start([dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                         "--scheduler-file", str(scheduler_file)], tmp_path / "scheduler.log")]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        # the workers get the project's worker configuration the way docs/campaigns.md says
        for number in range(2):
            processes.append(_start([dask, "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                                    tmp_path / f"worker{number}.log", {"DASK_CONFIG": str(WORKER_CONFIG_PATH.parent)}))
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=60)
            assert list(client.run(_worker_settings_probe()).values()) == [(None, "1", False)] * 2
        status, remote, err = gasfilm(capsys, "campaign", sessions, *FAST_CAMPAIGN, "--out", tmp_path / "remote",
                                      "--scheduler", address, "--no-diagnosis")
        assert status == 0, err
        assert f"2 computed on 2 dask worker(s) ({address})" in remote
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
    status, local, err = gasfilm(capsys, "campaign", sessions, *FAST_CAMPAIGN, "--out", tmp_path / "local",
                                 "--workers", 2, "--no-diagnosis")
    assert status == 0, err
    remote_rows = read_table(tmp_path / "remote" / "campaign.parquet")
    local_rows = read_table(tmp_path / "local" / "campaign.parquet")
    assert comparable(remote_rows) == comparable(local_rows)
    assert all(not row["error"] for row in local_rows) and len(local_rows) == 2


def test_campaign_refuses_bad_flags(sessions, tmp_path, capsys):
    for argv, words in (([sessions, "--by", "Pressure", "--out", tmp_path], "--by Pressure: condition name"),
                        ([tmp_path / "none", "--by", "gap_um", "--out", tmp_path / "o"], "no such session file"),
                        ([sessions, "--by", "gap_um", "--out", tmp_path, "--workers", 0], "--workers: 0"),
                        ([sessions, "--by", "gap_um", "--out", tmp_path, "--models", "XY"], "XY")):
        status, out, err = gasfilm(capsys, "campaign", *argv)
        assert status == 2 and words in err, err
        assert "Traceback" not in err


def test_gui_setup_conditions_editor_records_the_conditions(qtbot, tmp_path):
    from PySide6.QtCore import Qt
    from PySide6.QtWidgets import QPushButton

    from gui_driving import arm, hit, open_window, stop

    window = open_window(qtbot, tmp_path, rig_spec_path=str(DEMO_RIG_PATH))
    try:
        tab = window.setup_tab
        table = tab.conditions_table
        names = [table.item(row, 0).text() for row in range(table.rowCount())]
        assert names[:4] == ["supply_pressure_mpa", "gap_um", "load_n", "temperature_c"]
        table.item(names.index("gap_um"), 1).setText("twelve")
        assert "gap_um = 'twelve': must be a number in µm" in tab.problem_label.text()
        table.item(names.index("gap_um"), 1).setText("12")
        table.item(names.index("supply_pressure_mpa"), 1).setText("0.6")
        (add,) = [button for button in tab.findChildren(QPushButton) if button.text() == "Add a condition"]
        qtbot.mouseClick(add, Qt.MouseButton.LeftButton)
        table.item(table.rowCount() - 1, 0).setText("bearing")
        table.item(table.rowCount() - 1, 1).setText("B-17")
        assert tab.state().conditions == {"supply_pressure_mpa": "0.6", "gap_um": "12", "bearing": "B-17"}
        assert "Setup is valid" in tab.problem_label.text()
        window.controller.new_session(tmp_path / "gui.h5")
        arm(qtbot, window)
        hit(qtbot, window)
        stop(qtbot, window)
        with Session.open(tmp_path / "gui.h5") as session:
            assert decode_conditions(session.settings) == {"supply_pressure_mpa": 0.6, "gap_um": 12.0,
                                                           "bearing": "B-17"}
            k = RigSpec.from_toml(session.rig_spec_toml).film_parameters["k"]
        assert k == pytest.approx(37.8e6 * 1.5 / 1.2)  # the simulated film followed the conditions
    finally:
        window.controller.shutdown()


def test_campaign_report_marks_a_finding_seen_at_some_conditions_only():
    from gasfilm.analysis.campaign.report import campaign_html

    def row(pressure: float, findings: str) -> dict:
        k, eta = 3.78e7 * pressure / 0.4, 3450.0
        return {"session": f"p{pressure}.h5", "error": None, "accepted_hits": 3, "condition.supply_pressure_mpa":
                pressure, "band_low_hz": 20.0, "band_high_hz": 1000.0, "best_model": "SD", "spec.film_model": "SD",
                "spec.k [N/m]": k, "spec.eta [N·s/m]": eta, "SD.k [N/m]": k * 1.001, "SD.k sigma [N/m]": 1e4,
                "SD.eta [N·s/m]": eta, "SD.eta sigma [N·s/m]": 2.0, "diagnosis_verdict": "physics found" if findings
                else "consistent", "diagnosis_findings": findings, "diagnosis_unexplained": "", "seconds": 1.0}

    rows = [row(0.3, ""), row(0.3, ""), row(0.6, "pneumatic-lag"),
            {"session": "bad.h5", "error": "bad.h5: an HDF5 file, but not a gasfilm session"}]
    page = campaign_html(rows, ["supply_pressure_mpa"])
    assert "finding: pneumatic-lag (at some conditions only)" in page and "class='news'" in page
    assert "SD ×2" in page and "Sessions that failed (1)" in page and "not a gasfilm session" in page
    assert page.count("<img") == 2  # K(f)/C(f) per condition, parameters against the condition
    assert "2.838e+07 ± 7.1e+03 (spec 2.835e+07)" in page  # two sessions' weighted mean ± σ next to the law


def test_local_workers_get_the_worker_configuration():
    """dask's default MALLOC_TRIM_THRESHOLD_ cost a session 21-24 % more CPU (every array over 128 kB mapped afresh)
    and its profiler 8 %: the local cluster's workers start without either, one BLAS/OpenMP thread each."""
    with dask_client(1, None) as client:
        settings = list(client.run(_worker_settings_probe()).values())
    assert settings == [(None, "1", False)]


def test_sessions_recorded_in_another_unit_are_grouped_by_the_converted_value():
    from gasfilm.analysis.campaign import _convert_units
    from gasfilm.analysis.campaign.table import grouped

    rows = [{"session": "a.h5", "condition.supply_pressure_kpa": 600.0},
            {"session": "b.h5", "condition.supply_pressure_mpa": 0.6},
            {"session": "c.h5", "condition.gap_um": 10.0}]
    notes: list[str] = []
    _convert_units(rows, ["supply_pressure_mpa"], notes)
    groups = grouped(rows, ["supply_pressure_mpa"])
    assert [len(group) for group in groups.values()] == [2, 1] and list(groups)[0][0] == pytest.approx(0.6)
    assert notes == ["--by supply_pressure_mpa: sessions recording supply_pressure_kpa are grouped by it converted "
                     "to supply_pressure_mpa"]
