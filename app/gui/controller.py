"""The GUI's logic, between the tabs and the workers: one session, its hits, FRF, fits and diagnosis.

Lives on the GUI thread. It starts the acquisition worker and background jobs on their own threads and hears from
them only through signals; tabs read its state and connect to its signals. Nothing here draws.
"""

from __future__ import annotations

import dataclasses
import datetime
import functools
import logging
import os
import shutil
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from PySide6.QtCore import QCoreApplication, QEvent, QObject, QStandardPaths, QThread, Signal, Slot

from gasfilm.analysis.acquisition import AcquisitionLoop
from gasfilm.analysis.capture import TriggerSettings
from gasfilm.analysis.conditions import decode_conditions, parse_condition_table
from gasfilm.analysis.diagnosis import load_recordings
from gasfilm.analysis.diagnosis.plots import OUTPUT_FILES
from gasfilm.analysis.fit_settings import FitHits, FitSettings, conflicting_fits, stale_note
from gasfilm.analysis.paths import results_folder
from gasfilm.analysis.identification import DEFAULT_FIT_BAND_HZ, best_by_bic, compare_models
from gasfilm.analysis.physics.elements import get_model
from gasfilm.analysis.physics.laws import law_keys, played_at
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_session import roving_plan
from gasfilm.analysis.spectra import usable_band_hz
from gasfilm.analysis.session import Session, SessionWriteError, to_jsonable
from gasfilm.analysis.spectra import FrfAccumulator, FrfResult, WindowSettings, session_frf, write_frf_csv
from gasfilm.analysis.uff import export_frf_uff
from gasfilm.analysis.validation import ValidationSettings, Verdict, recorded_full_scale_si, validate_hit
from gasfilm.app.gui import jobs
from gasfilm.app.gui.rigid import entries_at_point, note_hammer_run, rigid_plan, same_rig, struck_point
from gasfilm.app.gui.settings import SetupState, settings_from_dict
from gasfilm.app.gui.workers import (
    PENDING_REASON,
    AcquisitionPlan,
    AcquisitionStats,
    AcquisitionWorker,
    BackgroundJob,
    HitEntry,
    pending_verdict,
    start_on_thread,
)
from gasfilm.drivers import SIMULATED_DEVICE_NAME
from gasfilm.drivers.errors import GasfilmError, SettingError
from gasfilm.drivers.interface import ChannelKind, DaqConfig

logger = logging.getLogger(__name__)
#: How a refusal that waits for the acquisition to stop begins (the banner withdraws it once stopped).
STOP_FIRST = "stop the acquisition"


def default_session_dir() -> Path:
    base = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.AppDataLocation)
    return Path(base or Path.home() / ".gasfilm") / "sessions"


def same_file(first: Path, second: Path) -> bool:
    """Whether two paths name one file (links followed); False when either is missing."""
    try:
        return os.path.samefile(first, second)
    except OSError:
        return False


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
    #: a session file is being opened (its hits, FRF, fits and diagnosis follow): what the tabs showed of the previous
    #: session — zoomed views, a reference spec typed for it — goes
    session_opened = Signal(str)
    hit_check_changed = Signal(object)  # the hit check's HitCheckProposal (None: no tap yet)
    comparisons_changed = Signal()  # other sessions' FRFs drawn over this one's (the FRF tab)

    # Signals into the acquisition worker (queued onto its thread).
    _decide = Signal(int, bool)
    _hold = Signal(int, str)
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
        self._frf_sums: tuple[FrfAccumulator | None, list[int]] = (None, [])  # running sums and the hits in them
        self.fits: dict[str, Any] = {}
        self._fit_settings: dict[str, dict[str, Any]] = {}  # each fit's stored settings beyond its FitResult
        self._frf_hits: FitHits | None = None  # the hits the current FRF averages
        self._fitting_hits: FitHits | None = None  # those of the FRF the running fit job was given
        self.comparison: list[Any] = []
        self.fit_band_hz: tuple[float, float] = DEFAULT_FIT_BAND_HZ
        self.diagnosis: Any = None
        self._diagnosis_options: dict[str, Any] | None = None  # of the diagnosis not stored yet (None once stored)
        self._pending_diagnosis_options: dict[str, Any] | None = None  # of the diagnosis running
        self.loop: AcquisitionLoop | None = None
        self.state = "idle"
        self._worker: AcquisitionWorker | None = None
        self._worker_thread: QThread | None = None
        self._jobs: dict[str, tuple[BackgroundJob, QThread]] = {}  # the running jobs by name
        self._ending_jobs: list[tuple[BackgroundJob, QThread]] = []  # ended jobs whose threads are winding down
        self._plan: AcquisitionPlan | None = None
        self._armed_setup: SetupState = setup  # the setup of the running acquisition (Play may use another spec)
        self._stream_end_s = 0.0  # session time where the last acquisition into the open session ended
        self._created_by_arm = False  # the open session was created by the running Arm (removed if it stays empty)
        self._streamed = False  # the running acquisition's device has streamed
        self._job_started_s: dict[str, float] = {}
        self.taps: list[Any] = []  # the hit check's taps (HitRecord), stored nowhere
        self.comparisons: list[tuple[str, FrfResult]] = []  # (label, FRF) of other sessions to overlay
        self._diagnosis_wait_s = 0.0  # the shown diagnosis's time from the click to its result
        self.hit_check_proposal: Any = None
        self.hammer_point: str | None = None  # a rigid-body rig's point to strike next (None: the spec's)
        self._roving: tuple[Any, str | None] = (None, None)  # a roving test's runs and the point of its FRF

    # --- settings --------------------------------------------------------------------------------------------------

    def rig_spec(self, setup: SetupState | None = None) -> RigSpec:
        path = (setup or self.setup).rig_spec_path
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

    @property
    def hit_checking(self) -> bool:
        """The running acquisition is a hit check (trial taps, nothing recorded)."""
        return self.acquiring and self._plan is not None and self._plan.hit_check

    def start_hit_check(self) -> None:
        """Trial taps before the test: the device streams and every tap is triggered and checked as in a recording,
        but stored nowhere; each one updates :attr:`hit_check_proposal` (``hit_check_changed``)."""
        self.arm(hit_check=True)

    def arm(self, setup: SetupState | None = None, hit_check: bool = False) -> None:
        """Start streaming into the open session, or a new one when the rig, device, channels, trigger or windows
        differ from the session's (a session holds one configuration). ``setup`` replaces the Setup tab's for this
        acquisition only; ``hit_check``: trial taps, no session."""
        if self.acquiring:
            return
        setup = setup or self.setup
        previous_session = self.session
        try:
            config = setup.daq_config()
            conditions = parse_condition_table(setup.conditions)
            rig_spec = self.rig_spec(setup)
            if setup.device == SIMULATED_DEVICE_NAME:  # the simulated film follows the conditions (film laws)
                inert = [key for key in conditions if key not in law_keys(rig_spec.film_laws or {})]
                rig_spec, conditions, _missing = played_at(rig_spec, conditions)
                if inert and not hit_check:
                    self.message.emit(
                        f"conditions {', '.join(inert)}: stored with the session, but the simulated rig's spec has no "
                        f"film law for them, so its film is the same at any value (a rig spec with [film.laws] "
                        f"follows them)", "info")
            else:
                rig_spec = rig_spec.at_conditions(conditions)
            response_row = setup.response_row(config)
            rig_spec, other_responses = rigid_plan(rig_spec, self.hammer_point, config, response_row)
            plan = AcquisitionPlan(
                device_name=setup.device,
                config=config,
                response_row=response_row,
                other_responses=other_responses,
                rig_spec=rig_spec,
                conditions=conditions,
                trigger=setup.trigger_settings(),
                validation=settings_from_dict(ValidationSettings, setup.validation),
                window=settings_from_dict(WindowSettings, setup.window),
                auto_accept=setup.auto_accept,
                auto_reject=setup.auto_reject,
                sim_auto_hammer=setup.sim_auto_hammer,
                sim_tip=setup.sim_tip,
                sim_seed=setup.sim_seed,
                sim_speed=setup.sim_speed,
                ring_seconds=max(10.0, 2 * setup.live_view_s),
                hit_check=hit_check,
            )
            if not hit_check and self._target_reached(setup, plan):
                self.message.emit(
                    f"target of {setup.target_averages} averages already reached ({self.accepted_count} accepted in "
                    f"{self.session_path.name}): nothing armed; raise Target averages on the Setup tab to add hits, "
                    f"or start a new session", "warning")
                return
            if not hit_check:
                self._ensure_session(plan)
                self._store_test_record(setup)
                self._roving = (note_hammer_run(self.session, plan.rig_spec), struck_point(plan.rig_spec))
                plan = dataclasses.replace(plan, time_offset_s=self._session_time_s())
        except GasfilmError as error:
            self.message.emit(str(error), "error")
            return
        if hit_check:
            self.taps = []
            self.hit_check_proposal = None
            self.hit_check_changed.emit(None)
        self._plan = plan
        self._armed_setup = setup
        self._created_by_arm = self.session is not previous_session
        self._streamed = False
        worker = AcquisitionWorker(plan, None if hit_check else self.session)
        worker.streaming.connect(self._on_streaming)
        worker.hit_recorded.connect(self._on_hit)
        worker.verdict_changed.connect(self._on_verdict)
        worker.trigger_state.connect(self._set_state)
        worker.channel_warning.connect(lambda text: self.message.emit(text, "warning"))
        worker.device_fault.connect(self._on_device_fault)
        worker.finished.connect(self._on_worker_finished)
        self._decide.connect(worker.decide)
        self._hold.connect(worker.hold)
        self._virtual_hit.connect(worker.virtual_hit)
        self._inject_fault.connect(worker.inject_fault)
        self._stop.connect(worker.stop)
        self._worker = worker
        self._set_state("starting")
        self._worker_thread = start_on_thread(worker, worker.start, self)

    def _target_reached(self, setup: SetupState, plan: AcquisitionPlan) -> bool:
        """Whether arming would record into the open session that already holds the target number of accepted hits
        (it would stop after one more, "accepted 11 of 10")."""
        session = self.session
        return (setup.target_averages > 0 and session is not None and session.writable and session.is_open
                and not self._session_differences(plan) and self.accepted_count >= setup.target_averages)

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

    def decide(self, index: int, accepted: bool) -> bool:
        """Accept or reject hit ``index``; stored in the session at once. False when it cannot be (no such hit, or
        the session is read-only: the banner says so)."""
        entry = self._entry(index)
        if entry is None:
            return False
        if self.acquiring:
            self._decide.emit(index, accepted)
            return True
        if self.session is None or not self.session.writable:
            self.message.emit("the session is open read-only; save it under a new name to change verdicts", "warning")
            return False
        entry.verdict = Verdict(accepted, entry.automatic.reasons, overridden=accepted != entry.automatic.accepted)
        entry.pending = False
        self.session.set_verdict(index, entry.verdict)
        self.hit_changed.emit(entry)
        self.update_running_frf()
        return True

    def live_samples(self, seconds: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The newest ``seconds`` of every channel for the live view: (time_s, data (channels, samples))."""
        loop = self.loop
        if loop is None or loop.samples_read == 0:
            return None
        data = loop.ring.latest(int(seconds * loop.sample_rate_hz))
        end = loop.samples_read
        time_s = (np.arange(end - data.shape[1], end)) / loop.sample_rate_hz
        return time_s, data

    def running_trigger(self) -> TriggerSettings:
        """The trigger of the running acquisition (else the Setup tab's)."""
        return self._plan.trigger if self._plan is not None and self.acquiring else self.trigger_settings()

    def running_config(self) -> DaqConfig:
        """The channel setup being recorded (else the Setup tab's)."""
        return self._plan.config if self._plan is not None and self.acquiring else self.setup.daq_config()

    def _session_differences(self, plan: AcquisitionPlan) -> list[str]:
        """What of ``plan`` differs from the open session's configuration ([] when it may be appended to)."""
        session = self.session
        stored = session.settings
        differences = []
        if session.daq_config != plan.config:
            differences.append("channels or sample rate")
        if session.device_name != plan.device_name:
            differences.append("device")
        if not same_rig(session.rig_spec_toml, plan.rig_spec):
            differences.append("rig spec")
        for key, value in (("trigger", plan.trigger), ("window", plan.window)):
            if stored.get(key) != to_jsonable(value):
                differences.append(f"{key} settings")
        if decode_conditions(stored, str(session.path)) != plan.conditions:
            differences.append("operating conditions")
        return differences

    def _session_time_s(self) -> float:
        """Where the next acquisition's time line starts in the open session (after every stored hit)."""
        ends = [entry.record.start_time_s + entry.record.n_samples / entry.record.sample_rate_hz for entry in self.hits]
        return max([self._stream_end_s, *ends])

    def _ensure_session(self, plan: AcquisitionPlan) -> None:
        if self.session is not None and self.session.writable and self.session.is_open:
            differences = self._session_differences(plan)
            if not differences:
                return
            self.message.emit(
                f"the {', '.join(differences)} differ from {self.session_path.name}: recording into a new session "
                f"(a session holds one configuration)",
                "info",
            )
            self.close_session()
            self.session_path = None
        path = self.session_path if self.session_path is not None and not self.session_path.exists() else None
        if path is None:
            self.session_dir.mkdir(parents=True, exist_ok=True)
            path = timestamped_session_path(self.session_dir)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.session = Session.create(
            path,
            plan.config,
            plan.rig_spec.to_toml(),
            {"trigger": plan.trigger, "validation": plan.validation, "window": plan.window, "gui": self._gui_settings(),
             "conditions": plan.conditions},
            device_name=plan.device_name,
        )
        self.session_path = path
        self._reset_results()
        self.session_changed.emit(str(path))
        logger.info("recording into the new session %s", path)

    def _store_test_record(self, setup: SetupState) -> None:
        """Who tests what with which sensors (operator, test object, each sensor's model, serial, calibration date and
        TEDS), stored with the session when it is new or they changed."""
        record = to_jsonable(setup.test_record())
        stored = self.session.settings
        if any(stored.get(key) != value for key, value in record.items()):
            self.session.update_settings(record)

    def _gui_settings(self) -> dict[str, Any]:
        return {
            "response_channel": self.setup.response_channel,
            "auto_accept": self.setup.auto_accept,
            "auto_reject": self.setup.auto_reject,
        }

    def _on_streaming(self, loop: AcquisitionLoop) -> None:
        self.loop = loop
        self._streamed = True
        self.streaming.emit(loop)

    def _on_hit(self, entry: HitEntry) -> None:
        if self._plan is not None and self._plan.hit_check:
            self._on_tap(entry.record)
            return
        self.hits.append(entry)
        hold_reason = self._coherence_hold_reason(entry)
        if hold_reason:
            entry.automatic = Verdict(False, entry.automatic.reasons + (hold_reason,))
            entry.verdict = entry.automatic
            entry.pending = True
            self._hold.emit(entry.index, hold_reason)
        self.hit_added.emit(entry)
        if entry.accepted:
            self.update_running_frf()

    def _coherence_hold_reason(self, entry: HitEntry) -> str:
        """Why an automatically accepted hit should wait for the technician instead ('' when it may stay): with it,
        the mean coherence in the usable band (from the fit band's lower edge) falls below the Setup tab's minimum."""
        minimum = self._armed_setup.min_coherence
        earlier = [e.record for e in self._at_frf_point(self.hits) if e.accepted and e is not entry]
        if not entry.accepted or minimum <= 0 or not earlier:
            return ""
        try:
            frf = session_frf([*earlier, entry.record], self._plan.window if self._plan else self.window_settings())
        except GasfilmError:
            return ""
        low, high = usable_band_hz(frf.freq_hz, frf.gff, self._armed_setup.usable_drop_db)
        band = (frf.freq_hz >= max(low, self.fit_band_hz[0])) & (frf.freq_hz <= high)
        if not np.any(band):
            return ""
        coherence = float(np.mean(frf.coherence[band]))
        return f"coherence {coherence:.2f} below {minimum:g}" if coherence < minimum else ""

    def _on_tap(self, record: Any) -> None:
        """A hit-check tap: kept in memory only, the proposal made again from every tap so far."""
        from gasfilm.analysis.hit_check import propose_settings
        from gasfilm.drivers.plant import TIPS_PULSE_WIDTH_S

        self.taps.append(record)
        plan = self._plan
        full_scale = [channel.full_scale_si for channel in plan.config.channels]
        force_scale = full_scale[plan.config.channel_index(ChannelKind.FORCE)]
        tips = TIPS_PULSE_WIDTH_S if plan.device_name == SIMULATED_DEVICE_NAME else None
        self.hit_check_proposal = propose_settings(self.taps, self.fit_band_hz, force_scale, plan.trigger.pretrigger_s,
                                                   tips, full_scale)
        self.hit_check_changed.emit(self.hit_check_proposal)

    def hit_check_setup(self) -> SetupState | None:
        """The Setup tab's state with the hit check's proposal applied (trigger level, record length, windows and,
        on the simulated rig, the tip); None without a proposal."""
        proposal = self.hit_check_proposal
        if proposal is None:
            return None
        state = dataclasses.replace(
            self.setup,
            trigger={**self.setup.trigger, "level_n": proposal.trigger_level_n, "record_s": proposal.record_s},
            window={**self.setup.window, "force_window_ms": proposal.force_window_ms,
                    "exponential_end_fraction": proposal.exponential_end_fraction},
        )
        if proposal.tip is not None and state.device == SIMULATED_DEVICE_NAME:
            state.sim_tip = proposal.tip
        return state

    def _on_verdict(self, entry: HitEntry) -> None:
        for position, existing in enumerate(self.hits):
            if existing.index == entry.index:
                self.hits[position] = entry
        self.hit_changed.emit(entry)
        self.update_running_frf()

    def _on_device_fault(self, text: str) -> None:
        if not self._streamed:
            self.message.emit(f"{text} — the device did not start; nothing was recorded", "error")
            return
        kept = sum(entry.accepted for entry in self.hits)
        if not self.hits:
            self.message.emit(f"{text} — acquisition stopped before any hit; nothing was recorded", "error")
            return
        hits = "the accepted hit is" if kept == 1 else f"the {kept} accepted hits are"
        self.message.emit(f"{text} — acquisition stopped; {hits} safe in {self.session_path.name}", "error")

    def _on_worker_finished(self) -> None:
        if self.loop is not None and self._plan is not None and not self._plan.hit_check:
            self._stream_end_s = self._plan.time_offset_s + self.loop.samples_read / self.loop.sample_rate_hz
        if self._worker_thread is not None:
            self._worker_thread.wait(5_000)
            self._worker_thread.deleteLater()
        self._worker = None
        self._worker_thread = None
        self.loop = None
        self.streaming.emit(None)
        self._set_state("idle")
        self._drop_empty_created_session()

    def _drop_empty_created_session(self) -> None:
        """A session this Arm created that holds no hit (the device did not start, or stopped before a hit) is
        removed: a failed Arm leaves no empty file behind. The next Arm records into the same path."""
        session = self.session
        if not self._created_by_arm or session is None or self.hits or not session.is_open:
            return
        if session.hit_count > 0:
            return
        path = self.session_path
        session.close("aborted", "no hit recorded")
        self.session = None
        self._created_by_arm = False
        try:
            path.unlink()
        except OSError as error:
            logger.warning("could not remove the empty session %s: %s", path, error)
            return
        logger.info("removed the empty session %s (no hit was recorded)", path)
        self.session_changed.emit("")

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

    def update_running_frf(self) -> None:
        """The FRF of the accepted hits, recomputed after every hit and decision (the one place the GUI's FRF is
        made); then stops the acquisition when the target number of averages is reached."""
        accepted = [entry for entry in self._at_frf_point(self.hits) if entry.accepted]
        records = [entry.record for entry in accepted]
        self.frf = self._running_frf(accepted) if accepted else None
        self._frf_hits = FitHits(len(accepted), tuple(entry.index for entry in accepted)) if accepted else None
        self.frf_changed.emit(self.frf)
        target = self._armed_setup.target_averages
        if self.acquiring and target > 0 and len(records) >= target and self.state != "stopping":
            self.message.emit(f"target of {target} averages reached: acquisition stopped", "info")
            self._set_state("stopping")
            self.stop()

    def _at_frf_point(self, entries: list) -> list:
        """The hits the running FRF averages: in a rigid body's roving test those at the point struck (its FRF)."""
        return entries_at_point(entries, *self._roving)

    def _running_frf(self, accepted: list) -> FrfResult:
        """Running sums of the accepted hits: a newly accepted hit is added to them; a decision that removes or
        reorders hits (or another window) starts the sums again."""
        window = self.window_settings()
        indices = [entry.index for entry in accepted]
        sums, summed = self._frf_sums
        first = accepted[0].record
        if (sums is None or sums.window != window or indices[: len(summed)] != summed
                or sums.n_samples != first.data.shape[-1] or sums.sample_rate_hz != first.sample_rate_hz):
            sums, summed = FrfAccumulator(first.sample_rate_hz, first.data.shape[-1], window, len(accepted)), []
        for entry in accepted[len(summed):]:
            sums.add_hit(entry.record)
        self._frf_sums = (sums, indices)
        return sums.result()

    def accept_all_pending(self) -> int:
        """Accept every hit that waits for a decision (the technician's one click); returns how many."""
        pending = [entry.index for entry in self.hits if entry.pending]
        for index in pending:
            self.decide(index, True)
        return len(pending)

    def reject_all_pending(self) -> int:
        """Reject every hit that waits for a decision; returns how many."""
        pending = [entry.index for entry in self.hits if entry.pending]
        for index in pending:
            self.decide(index, False)
        return len(pending)

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
                stored = pending_verdict(automatic) if entry.pending else automatic  # a waiting hit still waits
                if self.session is not None and self.session.writable:
                    self.session.set_verdict(entry.index, stored)
        self.hits_reset.emit()
        self.update_running_frf()
        self.message.emit(
            f"replayed {len(self.hits)} hits: {self.accepted_count} accepted with the current validation and window "
            f"settings",
            "info",
        )

    # --- identification ----------------------------------------------------------------------------------------------

    def _new_fit_settings(self, band_hz: tuple[float, float], method: str) -> FitSettings | None:
        """The settings a fit of the current FRF over ``band_hz`` would be made with (None: no FRF lines there)."""
        if self.frf is None:
            return None
        low, high = sorted(band_hz)
        lines = self.frf.freq_hz[(self.frf.freq_hz >= low) & (self.frf.freq_hz <= high)]
        if not lines.size:
            return None
        return FitSettings((float(lines[0]), float(lines[-1])), self.rig_spec_of_session().mass_kg, False, method,
                           self.frf.decay_rate_1_s, "frf")

    def stored_fit_conflicts(self, model_names: Sequence[str], method: str, band_hz: tuple[float, float]) -> list[str]:
        """The session's stored fits that fitting ``model_names`` now would replace although they were made with other
        settings (band, mass, fitter, FRF), one line each — the GUI asks before replacing them, as ``gasfilm fit``
        refuses without ``--overwrite``."""
        if self.session is None or not self.session.is_open:
            return []
        try:
            settings = self._new_fit_settings(band_hz, method)
            if settings is None:
                return []
            conflicts = conflicting_fits(self.session, {name: settings for name in model_names})
        except GasfilmError:  # a damaged spec or session: run_fits says what is wrong
            return []
        return [f"{name}: stored {', '.join(d.stored for d in found)}; now {', '.join(d.new for d in found)}"
                for name, found in conflicts]

    def run_fits(self, model_names: Sequence[str], method: str, band_hz: tuple[float, float]) -> None:
        """Fit each model to the current FRF in the band, in the background; results arrive via ``fits_changed``.
        The mass is the session's mover mass (its rig spec; else the Setup tab's), as ``gasfilm fit`` takes it."""
        if self.acquiring:
            self.message.emit(f"{STOP_FIRST} before fitting: the FRF still changes with every hit", "warning")
            return
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
        try:
            mass_kg = self.rig_spec_of_session().mass_kg
            for name in model_names:
                get_model(name)  # an unknown name is refused here, in one line, before a process starts
        except GasfilmError as error:
            self.message.emit(f"fit: {error}", "error")
            return
        work = functools.partial(jobs.fit_models, list(model_names), method, freq_hz, h, mass_kg, frf.decay_rate_1_s)
        self.fit_band_hz = (low, high)
        self._fitting_hits = self._frf_hits
        self._start_job("fit", work, self._on_fits_done)

    def stale_fits(self) -> dict[str, str]:
        """The fits made on fewer (or other) hits than the session accepts now, each with why ("made on 4 of the 10
        accepted hits")."""
        accepted = [entry.index for entry in self.hits if entry.accepted]
        found = {}
        for name in self.fits:
            note = stale_note(FitHits.of_stored(self._fit_settings.get(name, {})), accepted)
            if note is not None:
                found[name] = note
        return found

    def fit_hits(self, name: str) -> FitHits | None:
        """The hits the fit of ``name`` was made on (None: not recorded)."""
        return FitHits.of_stored(self._fit_settings.get(name, {}))

    def refit(self) -> None:
        """Fit the models shown again, with their fitter and band, on the FRF of all the accepted hits (one click
        after more hits)."""
        if not self.fits:
            self.message.emit("no fits to refit: fit models on the Identify tab first", "warning")
            return
        method = next(iter(self.fits.values())).method
        self.run_fits(list(self.fits), method, self.fit_band_hz)

    def _on_fits_done(self, result: tuple[dict[str, Any], list[Any]]) -> None:
        self.fits, self.comparison = result
        hits = self._fitting_hits.stored_keys() if self._fitting_hits is not None else {}
        self._fit_settings = {name: {**FitSettings.of_fit(fit, "frf").stored_keys(), **hits}
                              for name, fit in self.fits.items()}
        self.fits_changed.emit()
        self._store_results()
        low, high = self.fit_band_hz
        best_row = best_by_bic(self.comparison)
        best = f"; best (lowest BIC): {best_row.model_name}" if best_row is not None else ""
        count = len(self.fits)
        self.message.emit(
            f"fit finished: {count} model{'s' if count != 1 else ''} fitted in {low:g}–{high:g} Hz in "
            f"{self._job_seconds('fit'):.1f} s{best} (Identify tab)",
            "info",
        )

    def cancel_job(self, name: str) -> None:
        job = self._jobs.get(name)
        if job is not None:
            job[0].cancel()

    # --- diagnosis -----------------------------------------------------------------------------------------------------

    def run_diagnosis(self, reference_spec_path: str | Path | None = None,
                      replace_outputs: Any = lambda folder, names: True) -> None:
        """Diagnose the session's accepted hits against ``reference_spec_path`` (default, as ``gasfilm diagnose``
        without ``--rig``: the session's own spec, else a start read off the FRF — never the Setup tab's, which may
        be another rig's); its files go into ``SESSION-diagnosis/`` as ``gasfilm diagnose`` writes them, and an
        earlier diagnosis's files there are replaced only when ``replace_outputs(folder, names)`` says so (the tab
        asks)."""
        if self.acquiring:
            self.message.emit(f"{STOP_FIRST} before running the diagnosis: hits are still arriving", "warning")
            return
        if self.session is None or self.accepted_count == 0:
            self.message.emit("nothing to diagnose: record or open a session with accepted hits", "warning")
            return
        if "diagnose" in self._jobs:
            return
        try:
            spec = RigSpec.load(reference_spec_path) if reference_spec_path else None
        except GasfilmError as error:
            self.message.emit(f"diagnose: {error}", "error")
            return
        out_dir = results_folder(self.session_path, "diagnosis")  # where `gasfilm diagnose` writes it too
        earlier = [name for name in OUTPUT_FILES if (out_dir / name).exists()]
        if earlier and not replace_outputs(out_dir, earlier):
            self.message.emit(f"diagnose: the earlier diagnosis's files in {out_dir} are kept; nothing was run",
                              "info")
            return
        try:
            recordings = load_recordings(self.session_path)  # here, not on the job's thread: one file user at a time
        except GasfilmError as error:
            self.message.emit(f"diagnose: {error}", "error")
            return

        work = functools.partial(jobs.diagnose_session, recordings, spec, out_dir)
        self._pending_diagnosis_options = {"command": "GUI", "mass_kg": None, "band_hz": None,
                                           "rig": str(reference_spec_path) if reference_spec_path else None}
        self._start_job("diagnose", work, self._on_diagnosis_done)

    def rig_spec_of_session(self) -> RigSpec:
        """The spec the session was recorded with (else the Setup tab's)."""
        text = self.session.rig_spec_toml if self.session is not None else None
        return RigSpec.from_toml(text) if text else self.rig_spec()

    def diagnosis_seconds(self, diagnosis: Any) -> float:
        """How long ``diagnosis`` took as the technician waited for it (from the click until its result arrived): the
        one figure the banner and the Diagnose tab both show; the diagnosis's own computing time when it did not
        run here."""
        return self._diagnosis_wait_s if diagnosis is self.diagnosis and self._diagnosis_wait_s else diagnosis.wall_time_s

    def _on_diagnosis_done(self, diagnosis: Any) -> None:
        self._diagnosis_wait_s = self._job_seconds("diagnose")
        self.diagnosis = diagnosis
        self._diagnosis_options = self._pending_diagnosis_options
        self.diagnosis_changed.emit(diagnosis)
        self._store_results()
        count = len(diagnosis.findings)
        found = f"{count} finding{'s' if count != 1 else ''}" if count else "no finding"
        self.message.emit(
            f"diagnosis finished in {self._diagnosis_wait_s:.1f} s: verdict {diagnosis.verdict}, {found}; "
            f"figures and improved spec in {results_folder(self.session_path, 'diagnosis').name}/ (Diagnose tab)",
            "info",
        )

    def export_improved_spec(self, path: str | Path) -> Path:
        if self.diagnosis is None:
            raise SettingError("improved rig spec: run the diagnosis first")
        path = Path(path)
        shutil.copyfile(self.diagnosis.improved_spec_path, path)
        return path

    def play_improved_spec(self) -> None:
        """Record a new simulated session from the improved spec, with the same channels, trigger and windows.
        The Setup tab (and the saved setup) keep their rig spec: the improved one is used for this recording only."""
        if self.diagnosis is None or self.acquiring:
            return
        folder = self.session_path.parent if self.session_path is not None else self.session_dir
        folder.mkdir(parents=True, exist_ok=True)
        spec_path = self.export_improved_spec(folder / f"{self.session_path.stem}-improved-rig.toml")
        self.close_session()
        self._reset_results()
        played = dataclasses.replace(
            self.setup, device=SIMULATED_DEVICE_NAME, rig_spec_path=str(spec_path), sim_auto_hammer=True
        )
        self.session_path = timestamped_session_path(folder, "improved-spec")
        self.message.emit(
            f"playing the improved spec {spec_path.name} on the simulated rig into a new session "
            f"(the Setup tab keeps its rig spec)",
            "info",
        )
        self.arm(played)

    # --- background jobs -------------------------------------------------------------------------------------------------

    def _start_job(self, name: str, work: Any, on_success: Any) -> None:
        """Run ``work`` as the background job ``name``; ``on_success(result)`` on the GUI thread. The job counts as
        ended (``job_running`` false, :meth:`job_active` false) as soon as its outcome is handled, not once its relaying
        thread has also wound down (which waits behind the live view's repaints)."""
        job = BackgroundJob(work, in_process=True)
        job.setObjectName(name)
        job.progress.connect(lambda fraction, text: self.job_progress.emit(name, fraction, text))
        job.succeeded.connect(on_success)
        job.failed.connect(lambda text: self.message.emit(f"{name}: {text}", "error"))
        job.cancelled.connect(lambda: self.message.emit(f"{name}: cancelled", "info"))
        for outcome in (job.succeeded, job.failed, job.cancelled, job.finished):  # (after the handlers above)
            outcome.connect(self._on_job_outcome)
        self._job_started_s[name] = time.monotonic()
        job.dispatch()
        thread = start_on_thread(job, job.run, self)
        thread.finished.connect(self._on_job_thread_finished)
        self._jobs[name] = (job, thread)
        self.job_running.emit(name, True)

    @Slot()
    def _on_job_outcome(self) -> None:
        """A job's outcome was handled, or its thread returned: it no longer runs; its thread is dropped once ended."""
        job = self.sender()
        name = job.objectName()
        running = self._jobs.get(name)
        if running is not None and running[0] is job:
            del self._jobs[name]
            self._ending_jobs.append(running)
            self.job_running.emit(name, False)

    @Slot()
    def _on_job_thread_finished(self) -> None:
        """An ended job's thread has returned: both are dropped."""
        thread = self.sender()
        for ending in [entry for entry in self._ending_jobs if entry[1] is thread]:
            self._ending_jobs.remove(ending)
            thread.deleteLater()

    def _job_seconds(self, name: str) -> float:
        """Wall time of the job ``name`` so far (or of its last run) in s."""
        return time.monotonic() - self._job_started_s.get(name, time.monotonic())

    def job_active(self, name: str) -> bool:
        return name in self._jobs

    # --- sessions --------------------------------------------------------------------------------------------------------

    def _reset_results(self) -> None:
        self._stream_end_s = 0.0
        self._roving = (None, None)
        self.hits = []
        self._frf_sums = (None, [])
        self.frf = None
        self.fits = {}
        self._fit_settings = {}
        self._frf_hits = None
        self.comparison = []
        self.diagnosis = None
        self._diagnosis_options = None
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
        if self.session is not None and self.session_path is not None and same_file(path, self.session_path):
            # the session open here, opened again: its writer lock is this window's own, not another process's; it is
            # closed (its results stored) and read back from the file
            self.close_session()
        read_only = None
        try:
            session = Session.open(path, "a")
        except SessionWriteError as error:  # a read-only file or folder: shown, nothing stored
            read_only = error
            try:
                session = Session.open(path, "r")
            except GasfilmError as second:
                self.message.emit(str(second), "error")
                return
        except GasfilmError as error:
            self.message.emit(str(error), "error")
            return
        self.close_session()
        self.session = session
        self.session_path = path
        self._reset_results()
        self.session_opened.emit(str(path))
        stored_spec = RigSpec.from_toml(session.rig_spec_toml) if session.rig_spec_toml else None
        self._roving = (roving_plan(session.settings), struck_point(stored_spec))
        for stored in session.hits():
            verdict = stored.verdict
            if PENDING_REASON in verdict.reasons:  # stored while waiting for a decision: it waits again
                reasons = tuple(reason for reason in verdict.reasons if reason != PENDING_REASON)
                automatic = Verdict(not reasons, reasons)
                entry = HitEntry(stored.index, stored.as_hit_record(), automatic, automatic, pending=True)
            else:
                automatic = Verdict(verdict.accepted != verdict.overridden, verdict.reasons)
                entry = HitEntry(stored.index, stored.as_hit_record(), automatic, verdict)
            self.hits.append(entry)
        self.hits_reset.emit()
        if "frf" in session.result_names("frf"):
            self.frf = session.read_frf()
            indices = session.frf_hit_indices()
            self._frf_hits = FitHits(self.frf.n_averages if indices is None else len(indices),
                                     None if indices is None else tuple(int(i) for i in indices))
            self.frf_changed.emit(self.frf)
        else:
            self.update_running_frf()
        self._load_fits(session)
        newest = session.newest_diagnosis_name()
        if newest is not None:
            self.stored_diagnosis_loaded.emit(session.read_diagnosis(newest))
        # (said in the banner: what it showed was the previous session's)
        stored = [f"{len(self.hits)} hits ({self.accepted_count} accepted)",
                  *(["its FRF"] if self.frf is not None else []),
                  *([f"{len(self.fits)} fit{'s' if len(self.fits) != 1 else ''}"] if self.fits else []),
                  *(["its latest diagnosis"] if newest is not None else [])]
        self.message.emit(f"opened {path.name}: {', '.join(stored)}", "info")
        if session.recovered:
            self.message.emit(f"{path.name}: recovered after an interrupted recording", "warning")
        self.session_changed.emit(str(path))
        if read_only is not None:
            self.message.emit(f"{path.name}: opened read-only — fits and diagnoses made now are not stored in it and "
                              f"verdicts cannot be changed (Save As keeps them in a copy) ({read_only})", "warning")

    def _load_fits(self, session: Session) -> None:
        from gasfilm.analysis.identification import FitResult

        stored = {name: session.read_fit(name) for name in session.result_names("fits")}
        self.fits = {name: FitResult.from_dict(values) for name, values in stored.items()}
        self._fit_settings = {name: {key: values[key] for key in FitSettings.STORED_KEYS + FitHits.STORED_KEYS
                                     if key in values}
                              for name, values in stored.items()}
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
            accepted = [entry.index for entry in self._at_frf_point(self.hits) if entry.accepted]
            session.write_frf(self.frf, hit_indices=np.array(accepted, dtype=np.int64))
        for name, fit in self.fits.items():
            session.write_fit(name, {**fit.to_dict(), **self._fit_settings.get(name, {})})
        if self.diagnosis is not None and self._diagnosis_options is not None:  # stored once, as a new run
            session.add_diagnosis({**self.diagnosis.to_dict(), "options": self._diagnosis_options})
            self._diagnosis_options = None

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

    def end_recording(self) -> None:
        """Close the session "complete" and open it again for writing: the file then says the recording ended, as the
        command line leaves it (a report reads its status from the file); the next Arm makes it "recording" again."""
        if self.session is None or not self.session.writable or not self.session.is_open or self.acquiring:
            return
        self._store_results()
        self.session.close("complete")
        self.session = Session.open(self.session_path, "a")

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

    # --- comparison with other sessions ----------------------------------------------------------------------------------

    def add_comparisons(self, paths: Sequence[str | Path]) -> int:
        """Overlay other sessions' FRFs (each its stored FRF, else the average of its accepted hits, as ``gasfilm
        export`` takes it), labelled with their names and operating conditions; returns how many were added."""
        from gasfilm.analysis.conditions import format_conditions
        from gasfilm.app.commands.common import load_frf_and_hits, source_conditions

        added = 0
        for path in map(Path, paths):
            try:
                frf = load_frf_and_hits([path]).frf
                conditions = source_conditions([path])
            except GasfilmError as error:
                self.message.emit(f"compare: {error}", "error")
                continue
            label = path.stem + (f" ({format_conditions(conditions)})" if conditions else "")
            self.comparisons = [entry for entry in self.comparisons if entry[0] != label] + [(label, frf)]
            added += 1
        if added:
            self.comparisons_changed.emit()
        return added

    def clear_comparisons(self) -> None:
        self.comparisons = []
        self.comparisons_changed.emit()

    # --- exports ---------------------------------------------------------------------------------------------------------

    def export_csv(self, path: str | Path) -> Path:
        """The FRF as CSV: frequency, H1 (real, imaginary, magnitude in (m/s²)/N and g/N, phase), H2, coherence."""
        conditions = decode_conditions(self.session.settings, str(self.session_path)) if self.session else {}
        return write_frf_csv(self._require_frf(), path, conditions)

    def export_uff(self, path: str | Path) -> Path:
        frf = self._require_frf()
        path = Path(path)
        conditions = decode_conditions(self.session.settings, str(self.session_path)) if self.session else {}
        export_frf_uff(frf, path, conditions=conditions, description=f"gasfilm {path.stem}",
                       hits=[entry.record for entry in self.hits if entry.accepted])
        return path

    def _require_frf(self) -> FrfResult:
        if self.frf is None:
            raise SettingError("export: no FRF yet (accept at least one hit or open a session)")
        return self.frf

    def stop_and_wait(self) -> None:
        """Stop the acquisition and return once its thread has ended (every hit it recorded is in ``hits``)."""
        self.stop()
        self.wait_for_idle()
        QCoreApplication.sendPostedEvents(self, QEvent.Type.MetaCall)  # the hits and the end it reported on its way out
        if self._worker is not None:
            self._on_worker_finished()

    def shutdown(self) -> None:
        """Stop acquisition and jobs, store results, close the session (window closing)."""
        self.stop_and_wait()
        for job, thread in list(self._jobs.values()) + self._ending_jobs:
            job.cancel()
            thread.wait(10_000)
        for name in list(self._jobs):
            del self._jobs[name]
            self.job_running.emit(name, False)
        self._ending_jobs.clear()
        self.close_session()
