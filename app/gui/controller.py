"""The GUI's logic, between the tabs and the workers: one session, its hits, FRF, fits and diagnosis.

Lives on the GUI thread. It starts the acquisition worker and background jobs on their own threads and hears from
them only through signals; tabs read its state and connect to its signals. Nothing here draws.
"""

from __future__ import annotations

import dataclasses
import datetime
import shutil
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from PySide6.QtCore import QObject, QStandardPaths, QThread, Signal

from gasfilm.analysis.acquisition import AcquisitionLoop
from gasfilm.analysis.capture import TriggerSettings
from gasfilm.analysis.diagnose import diagnose, load_recordings
from gasfilm.analysis.identify import compare_models, fit_model
from gasfilm.analysis.physics.elements import get_model
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import FrfResult, WindowSettings, frf_from_hits, write_frf_csv
from gasfilm.analysis.uff import export_frf_uff
from gasfilm.analysis.validation import ValidationSettings, Verdict, recorded_full_scale_si, validate_hit
from gasfilm.app.gui.settings import SetupState, settings_from_dict
from gasfilm.app.gui.workers import (
    AcquisitionPlan,
    AcquisitionStats,
    AcquisitionWorker,
    BackgroundJob,
    HitEntry,
    start_on_thread,
)
from gasfilm.drivers import SIMULATED_DEVICE_NAME
from gasfilm.drivers.errors import GasfilmError, SettingError
from gasfilm.drivers.interface import DaqConfig

DEFAULT_FIT_BAND_HZ = (20.0, 800.0)


def default_session_dir() -> Path:
    base = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.AppDataLocation)
    return Path(base or Path.home() / ".gasfilm") / "sessions"


def timestamped_session_path(folder: Path, stem: str = "session") -> Path:
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = folder / f"{stem}-{stamp}.h5"
    number = 1
    while path.exists():
        number += 1
        path = folder / f"{stem}-{stamp}-{number}.h5"
    return path


class SessionController(QObject):
    """State of the open session and the jobs working on it."""

    acquisition_state = Signal(str)  # "idle" | "starting" | "armed" | "triggered"
    streaming = Signal(object)  # AcquisitionLoop (its ring buffer feeds the live view) or None when stopped
    hits_reset = Signal()
    hit_added = Signal(object)  # HitEntry
    hit_changed = Signal(object)  # HitEntry
    frf_changed = Signal(object)  # FrfResult or None
    fits_changed = Signal()
    diagnosis_changed = Signal(object)
    stored_diagnosis_loaded = Signal(object)  # the diagnosis dict a reopened session holds (no live model behind it)
    job_progress = Signal(str, float, str)  # job name, fraction done, text
    job_running = Signal(str, bool)  # job name ("fit" | "diagnose"), running
    message = Signal(str, str)  # text, severity ("error" | "warning" | "info")
    session_changed = Signal(str)  # path of the open session ('' for none)
    setup_replaced = Signal(object)  # SetupState the controller chose (e.g. "play improved spec")

    # Signals into the acquisition worker (queued onto its thread).
    _decide = Signal(int, bool)
    _virtual_hit = Signal(str)
    _inject_fault = Signal(str)
    _stop = Signal()

    def __init__(self, setup: SetupState, session_dir: Path | None = None, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.setup = setup
        self.session_dir = Path(session_dir) if session_dir else default_session_dir()
        self.session: Session | None = None
        self.session_path: Path | None = None
        self.hits: list[HitEntry] = []
        self.frf: FrfResult | None = None
        self.fits: dict[str, Any] = {}
        self.comparison: list[Any] = []
        self.fit_band_hz: tuple[float, float] = DEFAULT_FIT_BAND_HZ
        self.diagnosis: Any = None
        self.loop: AcquisitionLoop | None = None
        self.state = "idle"
        self._worker: AcquisitionWorker | None = None
        self._worker_thread: QThread | None = None
        self._jobs: dict[str, tuple[BackgroundJob, QThread]] = {}
        self._plan: AcquisitionPlan | None = None

    # --- settings --------------------------------------------------------------------------------------------------

    def rig_spec(self) -> RigSpec:
        path = self.setup.rig_spec_path
        return RigSpec.load(path) if path else RigSpec.nominal("FOMGF")

    def trigger_settings(self) -> TriggerSettings:
        return settings_from_dict(TriggerSettings, self.setup.trigger)

    def window_settings(self) -> WindowSettings:
        return settings_from_dict(WindowSettings, self.setup.window)

    def validation_settings(self) -> ValidationSettings:
        return settings_from_dict(ValidationSettings, self.setup.validation)

    @property
    def is_simulated(self) -> bool:
        device = self._plan.device_name if self._plan is not None and self.acquiring else self.setup.device
        return device == SIMULATED_DEVICE_NAME

    @property
    def acquiring(self) -> bool:
        return self._worker is not None

    @property
    def acquisition_stats(self) -> AcquisitionStats | None:
        """Counters of the running acquisition (chunks, samples, dropped chunks, hits); ``None`` when idle."""
        return self._worker.stats if self._worker is not None else None

    # --- acquisition -----------------------------------------------------------------------------------------------

    def arm(self) -> None:
        """Start streaming with the current setup into the open session (a new one if the setup changed)."""
        if self.acquiring:
            return
        try:
            config = self.setup.daq_config()
            plan = AcquisitionPlan(
                device_name=self.setup.device,
                config=config,
                response_row=self.setup.response_row(config),
                rig_spec=self.rig_spec(),
                trigger=self.trigger_settings(),
                validation=self.validation_settings(),
                window=self.window_settings(),
                auto_accept=self.setup.auto_accept,
                auto_reject=self.setup.auto_reject,
                sim_auto_hammer=self.setup.sim_auto_hammer,
                sim_tip=self.setup.sim_tip,
                sim_seed=self.setup.sim_seed,
                ring_seconds=max(10.0, 2 * self.setup.live_view_s),
            )
            self._ensure_session(plan)
        except GasfilmError as error:
            self.message.emit(str(error), "error")
            return
        self._plan = plan
        worker = AcquisitionWorker(plan, self.session)
        worker.streaming.connect(self._on_streaming)
        worker.hit_recorded.connect(self._on_hit)
        worker.verdict_changed.connect(self._on_verdict)
        worker.frf_updated.connect(self._on_frf)
        worker.trigger_state.connect(self._set_state)
        worker.channel_warning.connect(lambda text: self.message.emit(text, "warning"))
        worker.device_fault.connect(self._on_device_fault)
        worker.finished.connect(self._on_worker_finished)
        self._decide.connect(worker.decide)
        self._virtual_hit.connect(worker.virtual_hit)
        self._inject_fault.connect(worker.inject_fault)
        self._stop.connect(worker.stop)
        self._worker = worker
        self._set_state("starting")
        self._worker_thread = start_on_thread(worker, worker.start, self)

    def stop(self) -> None:
        if self._worker is not None:
            self._stop.emit()

    def virtual_hit(self, tip: str) -> None:
        """The simulated rig's hammer (the GUI knows the device only by name)."""
        if self.acquiring and self.is_simulated:
            self._virtual_hit.emit(tip)

    def inject_fault(self, kind: str) -> None:
        """Simulated rig only: make the device fail the way real hardware does."""
        if self.acquiring and self.is_simulated:
            self._inject_fault.emit(kind)

    def decide(self, index: int, accepted: bool) -> None:
        """Accept or reject hit ``index``; stored in the session at once."""
        entry = self._entry(index)
        if entry is None:
            return
        if self.acquiring:
            self._decide.emit(index, accepted)
            return
        if self.session is None or not self.session.writable:
            self.message.emit("the session is open read-only; save it under a new name to change verdicts", "warning")
            return
        entry.verdict = Verdict(accepted, entry.automatic.reasons, overridden=accepted != entry.automatic.accepted)
        entry.pending = False
        self.session.set_verdict(index, entry.verdict)
        self.hit_changed.emit(entry)
        self._recompute_frf()

    def live_samples(self, seconds: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The newest ``seconds`` of every channel for the live view: (time_s, data (channels, samples))."""
        loop = self.loop
        if loop is None or loop.samples_read == 0:
            return None
        data = loop.ring.latest(int(seconds * loop.sample_rate_hz))
        end = loop.samples_read
        time_s = (np.arange(end - data.shape[1], end)) / loop.sample_rate_hz
        return time_s, data

    def running_config(self) -> DaqConfig:
        """The channel setup being recorded (else the Setup tab's)."""
        return self._plan.config if self._plan is not None and self.acquiring else self.setup.daq_config()

    def _ensure_session(self, plan: AcquisitionPlan) -> None:
        if self.session is not None and self.session.writable and self.session.is_open:
            if self.session.daq_config == plan.config:
                return
            self.message.emit(
                f"the channel setup differs from {self.session_path.name}; recording into a new session", "info"
            )
            self.close_session()
        path = self.session_path if self.session_path is not None and not self.session_path.exists() else None
        if path is None:
            self.session_dir.mkdir(parents=True, exist_ok=True)
            path = timestamped_session_path(self.session_dir)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.session = Session.create(
            path,
            plan.config,
            plan.rig_spec.to_toml(),
            {"trigger": plan.trigger, "validation": plan.validation, "window": plan.window, "gui": self._gui_settings()},
            device_name=plan.device_name,
        )
        self.session_path = path
        self._reset_results()
        self.session_changed.emit(str(path))

    def _gui_settings(self) -> dict[str, Any]:
        return {
            "response_channel": self.setup.response_channel,
            "auto_accept": self.setup.auto_accept,
            "auto_reject": self.setup.auto_reject,
        }

    def _on_streaming(self, loop: AcquisitionLoop) -> None:
        self.loop = loop
        self.streaming.emit(loop)

    def _on_hit(self, entry: HitEntry) -> None:
        self.hits.append(entry)
        self.hit_added.emit(entry)

    def _on_verdict(self, entry: HitEntry) -> None:
        for position, existing in enumerate(self.hits):
            if existing.index == entry.index:
                self.hits[position] = entry
        self.hit_changed.emit(entry)

    def _on_frf(self, frf: FrfResult) -> None:
        self.frf = frf
        self.frf_changed.emit(frf)

    def _on_device_fault(self, text: str) -> None:
        kept = sum(entry.accepted for entry in self.hits)
        self.message.emit(f"{text} — acquisition stopped; the {kept} accepted hits are safe in the session", "error")

    def _on_worker_finished(self) -> None:
        if self._worker_thread is not None:
            self._worker_thread.wait(5_000)
            self._worker_thread.deleteLater()
        self._worker = None
        self._worker_thread = None
        self.loop = None
        self.streaming.emit(None)
        self._set_state("idle")

    def _set_state(self, state: str) -> None:
        self.state = state
        self.acquisition_state.emit(state)

    def wait_for_idle(self, timeout_ms: int = 10_000) -> None:
        """Block until the acquisition thread has ended (for closing the window)."""
        thread = self._worker_thread
        if thread is not None:
            thread.wait(timeout_ms)

    # --- hits and FRF ----------------------------------------------------------------------------------------------

    def _entry(self, index: int) -> HitEntry | None:
        return next((entry for entry in self.hits if entry.index == index), None)

    @property
    def accepted_count(self) -> int:
        return sum(entry.accepted for entry in self.hits)

    @property
    def rejected_count(self) -> int:
        return sum(not entry.verdict.accepted and not entry.pending for entry in self.hits)

    @property
    def pending_count(self) -> int:
        return sum(entry.pending for entry in self.hits)

    def _recompute_frf(self) -> None:
        records = [entry.record for entry in self.hits if entry.accepted]
        self.frf = frf_from_hits(records, self.window_settings()) if records else None
        self.frf_changed.emit(self.frf)

    def replay(self) -> None:
        """Re-validate every stored hit and recompute the FRF with the Setup tab's current settings."""
        if self.acquiring or not self.hits:
            return
        validation = self.validation_settings()
        window = self.window_settings()
        config = self.session.daq_config if self.session is not None else None
        full_scale = recorded_full_scale_si(config, self.session.settings) if config is not None else None
        for entry in self.hits:
            automatic = validate_hit(entry.record, validation, full_scale, window=window)
            entry.automatic = automatic
            if not entry.verdict.overridden:
                entry.verdict = automatic
                if self.session is not None and self.session.writable:
                    self.session.set_verdict(entry.index, automatic)
        self.hits_reset.emit()
        self._recompute_frf()
        self.message.emit(
            f"replayed {len(self.hits)} hits: {self.accepted_count} accepted with the current validation and window "
            f"settings",
            "info",
        )

    # --- identification ----------------------------------------------------------------------------------------------

    def run_fits(self, model_names: Sequence[str], method: str, band_hz: tuple[float, float]) -> None:
        """Fit each model to the current FRF in the band, in the background; results arrive via ``fits_changed``."""
        if self.frf is None:
            self.message.emit("no FRF yet: accept at least one hit or open a session", "warning")
            return
        if "fit" in self._jobs:
            return
        frf = self.frf
        low, high = sorted(band_hz)
        band = (frf.freq_hz >= low) & (frf.freq_hz <= high)
        if np.count_nonzero(band) < 8:
            self.message.emit(f"fit band {low:g}–{high:g} Hz holds fewer than 8 FRF lines; widen it", "error")
            return
        freq_hz, h = frf.freq_hz[band], frf.h1[band]
        mass_kg = self.rig_spec().mass_kg
        models = [get_model(name) for name in model_names]
        names = list(model_names)

        def work(report, cancelled):
            fits = {}
            for number, (name, model) in enumerate(zip(names, models)):
                report(number / len(models), f"fitting {name} ({number + 1} of {len(models)})")
                fits[name] = fit_model(
                    model,
                    freq_hz,
                    h,
                    mass_kg,
                    method=method,
                    decay_rate_1_s=frf.decay_rate_1_s,
                    progress=lambda done, n=number, m=name: report(
                        (n + done) / len(models), f"fitting {m} ({n + 1} of {len(models)})"
                    ),
                    cancel=cancelled,
                )
            report(1.0, "comparing the models")
            return fits, compare_models(list(fits.values()), freq_hz, h)

        self.fit_band_hz = (low, high)
        self._start_job("fit", work, self._on_fits_done)

    def _on_fits_done(self, result: tuple[dict[str, Any], list[Any]]) -> None:
        self.fits, self.comparison = result
        self.fits_changed.emit()
        self._store_results()

    def cancel_job(self, name: str) -> None:
        job = self._jobs.get(name)
        if job is not None:
            job[0].cancel()

    # --- diagnosis -----------------------------------------------------------------------------------------------------

    def run_diagnosis(self, reference_spec_path: str | Path | None = None) -> None:
        """Diagnose the session's accepted hits against ``reference_spec_path`` (default: the session's own spec)."""
        if self.session is None or self.accepted_count == 0:
            self.message.emit("nothing to diagnose: record or open a session with accepted hits", "warning")
            return
        if self.acquiring:
            self.message.emit("stop the acquisition before running the diagnosis", "warning")
            return
        if "diagnose" in self._jobs:
            return
        try:
            spec = RigSpec.load(reference_spec_path) if reference_spec_path else self.rig_spec_of_session()
        except GasfilmError as error:
            self.message.emit(f"diagnose: {error}", "error")
            return
        out_dir = self.session_path.with_name(f"{self.session_path.stem}-diagnosis")
        try:
            recordings = load_recordings(self.session_path)  # here, not on the job's thread: one file user at a time
        except GasfilmError as error:
            self.message.emit(f"diagnose: {error}", "error")
            return

        def work(report, _cancelled):  # the diagnosis has no cancel hook: Cancel acts at its next progress report
            return diagnose(recordings, spec, out_dir=out_dir, progress=lambda text: report(0.0, text))

        self._start_job("diagnose", work, self._on_diagnosis_done)

    def rig_spec_of_session(self) -> RigSpec:
        """The spec the session was recorded with (else the Setup tab's)."""
        text = self.session.rig_spec_toml if self.session is not None else None
        return RigSpec.from_toml(text) if text else self.rig_spec()

    def _on_diagnosis_done(self, diagnosis: Any) -> None:
        self.diagnosis = diagnosis
        self.diagnosis_changed.emit(diagnosis)
        self._store_results()

    def export_improved_spec(self, path: str | Path) -> Path:
        if self.diagnosis is None:
            raise SettingError("improved rig spec: run the diagnosis first")
        path = Path(path)
        shutil.copyfile(self.diagnosis.improved_spec, path)
        return path

    def play_improved_spec(self) -> None:
        """Record a new simulated session from the improved spec, with the same channels, trigger and windows."""
        if self.diagnosis is None or self.acquiring:
            return
        folder = self.session_path.parent if self.session_path is not None else self.session_dir
        folder.mkdir(parents=True, exist_ok=True)
        spec_path = self.export_improved_spec(folder / f"{self.session_path.stem}-improved-rig.toml")
        self.close_session()
        self.setup = dataclasses.replace(
            self.setup, device=SIMULATED_DEVICE_NAME, rig_spec_path=str(spec_path), sim_auto_hammer=True
        )
        self.setup_replaced.emit(self.setup)
        self.session_path = timestamped_session_path(folder, "improved-spec")
        self.message.emit(f"playing the improved spec {spec_path.name} on the simulated rig", "info")
        self.arm()

    # --- background jobs -------------------------------------------------------------------------------------------------

    def _start_job(self, name: str, work: Any, on_success: Any) -> None:
        job = BackgroundJob(work)
        job.progress.connect(lambda fraction, text: self.job_progress.emit(name, fraction, text))
        job.succeeded.connect(on_success)
        job.failed.connect(lambda text: self.message.emit(f"{name}: {text}", "error"))
        job.cancelled.connect(lambda: self.message.emit(f"{name}: cancelled", "info"))
        job.finished.connect(lambda: self._job_finished(name))
        thread = start_on_thread(job, job.run, self)
        self._jobs[name] = (job, thread)
        self.job_running.emit(name, True)

    def _job_finished(self, name: str) -> None:
        job = self._jobs.pop(name, None)
        if job is not None:
            job[1].wait(5_000)
            job[1].deleteLater()
        self.job_running.emit(name, False)

    def job_active(self, name: str) -> bool:
        return name in self._jobs

    # --- sessions --------------------------------------------------------------------------------------------------------

    def _reset_results(self) -> None:
        self.hits = []
        self.frf = None
        self.fits = {}
        self.comparison = []
        self.diagnosis = None
        self.hits_reset.emit()
        self.frf_changed.emit(None)
        self.fits_changed.emit()
        self.diagnosis_changed.emit(None)

    def new_session(self, path: str | Path | None = None) -> None:
        """Forget the open session; the next Arm records into ``path`` (or a time-stamped file)."""
        if self.acquiring:
            self.message.emit("stop the acquisition before starting a new session", "warning")
            return
        self.close_session()
        self.session_path = Path(path) if path else None
        self._reset_results()
        self.session_changed.emit("")

    def close_session(self) -> None:
        if self.session is not None and self.session.is_open:
            self._store_results()
            self.session.close("complete")
        self.session = None

    def open_session(self, path: str | Path) -> None:
        """Open a session file: its hits, FRF, fits and diagnosis come back as they were saved."""
        if self.acquiring:
            self.message.emit("stop the acquisition before opening a session", "warning")
            return
        path = Path(path)
        try:
            session = Session.open(path, "a")
        except GasfilmError as error:
            self.message.emit(str(error), "error")
            return
        self.close_session()
        self.session = session
        self.session_path = path
        self._reset_results()
        for stored in session.hits():
            verdict = stored.verdict
            automatic = Verdict(verdict.accepted != verdict.overridden, verdict.reasons)
            entry = HitEntry(stored.index, stored.as_hit_record(), automatic, verdict)
            self.hits.append(entry)
        self.hits_reset.emit()
        if "frf" in session.result_names("frf"):
            self.frf = session.read_frf()
            self.frf_changed.emit(self.frf)
        else:
            self._recompute_frf()
        self._load_fits(session)
        for name in ("diagnosis", "latest"):  # the GUI's name, then the command line's
            if name in session.result_names("diagnoses"):
                self.stored_diagnosis_loaded.emit(session.read_diagnosis(name))
                break
        if session.recovered:
            self.message.emit(f"{path.name}: recovered after an interrupted recording", "warning")
        self.session_changed.emit(str(path))

    def _load_fits(self, session: Session) -> None:
        from gasfilm.analysis.identify import FitResult

        names = session.result_names("fits")
        self.fits = {name: FitResult.from_dict(session.read_fit(name)) for name in names}
        if self.fits and self.frf is not None:
            first = next(iter(self.fits.values()))
            self.fit_band_hz = first.band_hz
            band = (self.frf.freq_hz >= first.band_hz[0]) & (self.frf.freq_hz <= first.band_hz[1])
            self.comparison = compare_models(list(self.fits.values()), self.frf.freq_hz[band], self.frf.h1[band])
        self.fits_changed.emit()

    def _store_results(self) -> None:
        """Write FRF, fits and diagnosis into the session (not while the acquisition writes hits)."""
        session = self.session
        if session is None or not session.writable or not session.is_open or self.acquiring:
            return
        if self.frf is not None:
            accepted = [entry.index for entry in self.hits if entry.accepted]
            session.write_frf(self.frf, hit_indices=np.array(accepted, dtype=np.int64))
        for name, fit in self.fits.items():
            session.write_fit(name, fit.to_dict())
        if self.diagnosis is not None:
            session.write_diagnosis("diagnosis", self.diagnosis.to_dict())

    def save_session(self) -> Path | None:
        if self.session is None:
            self.message.emit("no session to save: arm and record, or open a session", "warning")
            return None
        if self.acquiring:
            self.message.emit("hits are already on disk; stop the acquisition to save the FRF and results", "info")
            return self.session_path
        self._store_results()
        self.message.emit(f"saved {self.session_path}", "info")
        return self.session_path

    def save_session_as(self, path: str | Path) -> Path | None:
        """Copy the session (with results) to ``path`` and continue in the copy."""
        if self.session is None or self.acquiring:
            return None
        path = Path(path)
        self._store_results()
        self.session.close("complete")
        shutil.copyfile(self.session_path, path)
        self.session = Session.open(path, "a")
        self.session_path = path
        self.session_changed.emit(str(path))
        self.message.emit(f"saved as {path}", "info")
        return path

    # --- exports ---------------------------------------------------------------------------------------------------------

    def export_csv(self, path: str | Path) -> Path:
        """The FRF as CSV: frequency, H1 (real, imaginary, magnitude in (m/s²)/N and g/N, phase), H2, coherence."""
        return write_frf_csv(self._require_frf(), path)

    def export_uff(self, path: str | Path) -> Path:
        frf = self._require_frf()
        path = Path(path)
        export_frf_uff(frf, path)
        return path

    def _require_frf(self) -> FrfResult:
        if self.frf is None:
            raise SettingError("export: no FRF yet (accept at least one hit or open a session)")
        return self.frf

    def shutdown(self) -> None:
        """Stop acquisition and jobs, store results, close the session (window closing)."""
        self.stop()
        self.wait_for_idle()
        if self._worker is not None:
            self._on_worker_finished()
        for name, (job, thread) in list(self._jobs.items()):
            job.cancel()
            thread.wait(10_000)
            self._job_finished(name)
        self.close_session()
