"""The GUI's job process kept ready: a job runs in the process started and warmed up before it, and the next one is
started after it."""

from __future__ import annotations

import os

from PySide6.QtCore import QObject

from gasfilm.app.gui.workers import BackgroundJob, job_process_ready, start_on_thread, warm_up_job_processes


def _process_id(report, cancelled) -> int:
    """A job: the id of the process it runs in."""
    del report, cancelled
    return os.getpid()


def _run(qtbot, owner: QObject) -> int:
    job = BackgroundJob(_process_id, in_process=True)
    results: list[int] = []
    job.succeeded.connect(results.append)
    thread = start_on_thread(job, job.run, owner)
    qtbot.waitUntil(lambda: bool(results), timeout=60_000)
    thread.quit()
    thread.wait(5_000)
    return results[0]


def test_a_job_runs_in_the_process_kept_ready_and_the_next_is_started_after_it(qtbot):
    owner = QObject()
    warm_up_job_processes()
    assert job_process_ready(60)
    first = _run(qtbot, owner)
    assert first != os.getpid()
    assert job_process_ready(60)  # the next job's process, started once the first job's ended
    second = _run(qtbot, owner)
    assert second not in (first, os.getpid())
