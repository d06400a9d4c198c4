"""The GUI's long jobs — fitting models, diagnosing a session — as plain functions of picklable arguments, without
Qt: :class:`gasfilm.app.gui.workers.BackgroundJob` runs them in a child process, whose own interpreter lock keeps
the live view and the acquisition from slowing them down (``benchmarks/bench_gui_jobs.py``).

Each takes ``report(fraction, text)`` (progress; raises once Cancel was pressed) and ``cancelled()`` last.
:func:`serve_one_job` is what a job process runs: started before its job and warmed up, it waits for the work and
runs it (:func:`run_job_in_child`). Nothing here imports Qt: a job's process starts light.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from gasfilm.analysis.diagnosis import diagnose
from gasfilm.analysis.diagnosis.pipeline import is_trace
from gasfilm.analysis.diagnosis.plots import remove_stale_outputs, write_outputs
from gasfilm.analysis.identification import compare_models, fit_model
from gasfilm.analysis.physics.elements import get_model
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import GasfilmError

Report = Callable[[float, str], None]
#: Progress reaches the GUI at most this often, in s (never flooding its event loop).
PROGRESS_INTERVAL_S = 0.1
#: How often a job process waiting for its work checks that the GUI (its fork server) is still there, in s.
PARENT_CHECK_S = 1.0


class JobCancelled(GasfilmError):
    """Raised inside a background job when the technician pressed Cancel."""




def fit_models(
    names: Sequence[str],
    method: str,
    freq_hz: np.ndarray,
    h: np.ndarray,
    mass_kg: float,
    decay_rate_1_s: float,
    report: Report,
    cancelled: Callable[[], bool],
) -> tuple[dict[str, Any], list[Any]]:
    """Fit each model (a paper name or a network) to ``h`` (accelerance in (m/s²)/N) at ``freq_hz`` in Hz; returns
    the fits by name and their Table 2 comparison."""
    fits = {}
    for number, name in enumerate(names):
        report(number / len(names), f"fitting {name} ({number + 1} of {len(names)})")
        fits[name] = fit_model(
            get_model(name),
            freq_hz,
            h,
            mass_kg,
            method=method,
            decay_rate_1_s=decay_rate_1_s,
            progress=lambda done, n=number, m=name: report(
                (n + done) / len(names), f"fitting {m} ({n + 1} of {len(names)})"
            ),
            cancel=cancelled,
        )
    report(1.0, "comparing the models")
    return fits, compare_models(list(fits.values()), freq_hz, h)


def diagnose_session(
    recordings: Any, spec: RigSpec | None, out_dir: Path, report: Report, _cancelled: Callable[[], bool]
) -> Any:
    """Diagnose ``recordings`` against ``spec`` (None: their own, else one read off the FRF) and write the figures
    and the improved spec into ``out_dir`` (removing an earlier run's figure this one does not draw); the diagnosis
    has no cancel hook: Cancel acts at its next progress report."""
    step = ""

    def progress(text: str) -> None:  # the step and what it has so far; the search's trace is a cancel point only
        nonlocal step
        if not is_trace(text):
            step = text
        report(0.0, step)

    diagnosis = diagnose(recordings, spec, progress=progress)
    write_outputs(diagnosis, out_dir)
    remove_stale_outputs(diagnosis, out_dir)  # the folder is the GUI's own: an earlier run's figure goes
    return diagnosis


def serve_one_job(works: Any, messages: Any, cancel: Any, warm: Any) -> None:
    """A job process started before its job: warm up (:func:`warm_up`, cut short when the work arrives; then the event
    ``warm`` is set), wait for the work on the pipe ``works`` and run it (:func:`run_job_in_child`). Ends without work
    when the pipe closes or its parent (the fork server, which ends with the GUI) has gone."""
    try:
        warm_up(lambda: works.poll(0))
    except GasfilmError:  # the work arrived meanwhile: it goes first
        pass
    warm.set()
    parent = os.getppid()
    while not works.poll(PARENT_CHECK_S):
        if os.getppid() != parent:
            return
    try:
        work = works.recv()
    except EOFError:  # the GUI closed without a job for this process
        return
    run_job_in_child(work, messages, cancel)


def warm_up(interrupted: Callable[[], bool]) -> None:
    """A small fit of two models: in a freshly forked process the first fit ran ~0.1 s slower than the next (pages
    of code and data copied from the fork server, the BLAS libraries looked up), which the technician's first click
    then waited for. Stops (raising the fitter's cancellation) as soon as ``interrupted()``."""
    freq_hz = np.linspace(20.0, 1000.0, 64)
    s = 2j * np.pi * freq_hz
    h = s**2 / (25.0 * s**2 + 2e3 * s + 4e7)  # a 25 kg mover on a spring-damper film
    fit_models(("SD", "FOMGF"), "default", freq_hz, h, 25.0, 0.0, lambda fraction, text: None, interrupted)


def run_job_in_child(work: Callable[..., Any], messages: Any, cancel: Any) -> None:
    """Child process: run ``work(report, cancelled)``, sending progress (at most 10 a second) and the outcome."""
    last_emit_s = [0.0]
    checked = [0.0, False]  # when the cancel event was last read, and what it said

    def cancelled() -> bool:
        """The cancel event, read at most every 50 ms (a read takes a lock between processes; fitters ask often)."""
        now = time.monotonic()
        if now - checked[0] >= 0.05:
            checked[:] = [now, cancel.is_set()]
        return checked[1]

    def report(fraction: float, text: str) -> None:
        if cancelled():
            raise JobCancelled("cancelled")
        now = time.monotonic()
        if now - last_emit_s[0] >= PROGRESS_INTERVAL_S or fraction >= 1.0:
            last_emit_s[0] = now
            messages.put(("progress", float(fraction), text))

    try:
        result = work(report, cancelled)
    except JobCancelled:
        messages.put(("cancelled",))
    except GasfilmError as error:
        messages.put(("cancelled",) if cancel.is_set() else ("failed", str(error)))
    except Exception as error:  # a bug in a job must reach the banner, not vanish with the process
        messages.put(("failed", f"internal error: {type(error).__name__}: {error}"))
    else:
        messages.put(("cancelled",) if cancel.is_set() else ("done", result))
