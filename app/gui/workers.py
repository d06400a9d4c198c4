"""Work that must not run on the GUI thread: acquisition (device → trigger → validation → session) and long jobs.

Each worker is a QObject moved to its own QThread (PyMoDAQ's pattern). It talks to the GUI only through signals and
never touches a widget; the GUI talks to it through queued signals. The acquisition worker polls its mailbox from
a timer on its own thread, so queued requests (accept, reject, virtual hit, stop) are handled between chunks and a
fast device can never flood the GUI's event loop: the GUI receives one signal per hit, not one per chunk.
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import multiprocessing
import multiprocessing.forkserver
import multiprocessing.resource_tracker
import multiprocessing.util  # (its exit function is registered before ours, so ours runs first: see _JobProcesses)
import queue
import signal
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from PySide6.QtCore import QCoreApplication, QObject, Qt, QThread, QTimer, Signal, Slot

from gasfilm.analysis.acquisition import AcquisitionLoop
from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.analysis.hit_check import TapRecorder
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.recording import HitEvent, HitRecorder
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.validation import ValidationSettings, Verdict
from gasfilm.app.gui.jobs import PROGRESS_INTERVAL_S, JobCancelled, serve_one_job
from gasfilm.drivers import SIMULATED_DEVICE_NAME, open_device
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import ChannelKind, DaqConfig, DaqDevice

logger = logging.getLogger(__name__)

POLL_INTERVAL_MS = 50
SIM_HIT_INTERVAL_S = (1.5, 3.0)
#: Stored with a hit that waits for the technician's decision: until then the session counts it as not accepted.
PENDING_REASON = "awaiting decision"


def pending_verdict(automatic: Verdict, hold_reason: str = "") -> Verdict:
    """How a hit waiting for a decision is stored: not accepted, its check results and why it waits."""
    reasons = automatic.reasons + ((hold_reason,) if hold_reason else ()) + (PENDING_REASON,)
    return Verdict(False, reasons)


@dataclass(frozen=True)
class AcquisitionPlan:
    """Everything the acquisition worker needs, decided on the GUI thread before arming."""

    device_name: str
    config: DaqConfig
    response_row: int
    rig_spec: RigSpec
    trigger: TriggerSettings
    validation: ValidationSettings
    window: WindowSettings
    auto_accept: bool = True
    auto_reject: bool = True
    sim_auto_hammer: bool = False
    sim_tip: str = "medium"
    sim_seed: int = 1
    sim_pacing: str = "realtime"
    sim_speed: float = 1.0  # realtime pacing at this many times real time
    ring_seconds: float = 10.0
    time_offset_s: float = 0.0  # session time of the stream's first sample (hit times continue across re-arms)
    conditions: dict = field(default_factory=dict)  # the session's operating conditions (analysis/conditions.py)
    hit_check: bool = False  # trial taps before the test: triggered and checked, stored nowhere
    other_responses: tuple[int, ...] = ()  # a rigid body's further accelerometers, checked as the response is


@dataclass
class HitEntry:
    """A hit as the GUI shows it: the record, the automatic verdict and the decision in force."""

    index: int
    record: HitRecord
    automatic: Verdict
    verdict: Verdict
    pending: bool = False

    @property
    def accepted(self) -> bool:
        return self.verdict.accepted and not self.pending


@dataclass
class AcquisitionStats:
    """Counters for the status bar and the benchmark."""

    chunks_read: int = 0
    samples_read: int = 0
    dropped_chunks: int = 0
    hits: int = 0


class AcquisitionWorker(QObject):
    """Runs device, trigger, validation and session writing; lives on its own thread."""

    streaming = Signal(object)  # the AcquisitionLoop, once the device streams (its ring feeds the live view)
    hit_recorded = Signal(object)  # HitEntry
    verdict_changed = Signal(object)  # HitEntry after a decision
    trigger_state = Signal(str)  # "armed" | "triggered"
    channel_warning = Signal(str)  # overload / open sensor flags, one line
    device_fault = Signal(str)  # a DeviceError's message; acquisition has ended
    finished = Signal()

    def __init__(self, plan: AcquisitionPlan, session: Session | None, first_index: int = 0) -> None:
        super().__init__()
        self.plan = plan
        self.session = session
        self.first_index = first_index
        self.device: DaqDevice | None = None
        self.loop: AcquisitionLoop | None = None
        self.recorder: HitRecorder | TapRecorder | None = None
        self.stats = AcquisitionStats()
        self._mailbox = None
        self._timer: QTimer | None = None
        self._entries: dict[int, HitEntry] = {}
        self._last_trigger_state = ""
        self._last_flags = ""
        self._stopping = False
        self._capture: ImpactCapture | None = None
        self._record_samples = 0
        self._force_row = 0
        self._recording_until = 0

    # --- life cycle (worker thread) ----------------------------------------------------------------------------------

    @Slot()
    def start(self) -> None:
        plan = self.plan
        try:
            options: dict[str, Any] = {}
            if plan.device_name == SIMULATED_DEVICE_NAME:
                options = dict(
                    plant=RigPlant(plan.rig_spec),
                    seed=plan.sim_seed,
                    pacing=plan.sim_pacing,
                    speed=plan.sim_speed,
                    hit_interval_s=SIM_HIT_INTERVAL_S if plan.sim_auto_hammer else None,
                    tip=plan.sim_tip,
                )
            device = open_device(plan.device_name, **options)
            self.device = ReaderThreadHooks(device) if plan.device_name == SIMULATED_DEVICE_NAME else device
            self.device.configure(plan.config)
            force_row = plan.config.channel_index(ChannelKind.FORCE)
            capture = ContinuingCapture(
                plan.trigger, self.device.sample_rate_hz, len(plan.config.channels), force_row, plan.response_row
            )
            capture.time_offset_s = plan.time_offset_s
            full_scale = tuple(channel.full_scale_si for channel in plan.config.channels)
            self._capture = capture
            if plan.hit_check:
                self.recorder = TapRecorder(capture, plan.validation, full_scale_si=full_scale, window=plan.window)
            else:
                self.recorder = HitRecorder(
                    self.session, capture, plan.validation, full_scale_si=full_scale, window=plan.window,
                    other_responses=plan.other_responses,
                )
            self._record_samples = capture.record_samples
            self._force_row = force_row
            self.loop = AcquisitionLoop(self.device, ring_seconds=plan.ring_seconds)
            self._mailbox = self.loop.subscribe("gui")
            self.loop.start()
        except GasfilmError as error:
            self._close_device()
            self.device_fault.emit(str(error))
            self._finish()
            return
        self.stats = AcquisitionStats()
        self._timer = QTimer(self)
        self._timer.timeout.connect(self._poll)
        self._timer.start(POLL_INTERVAL_MS)
        self.streaming.emit(self.loop)
        self._set_trigger_state("armed")

    @Slot()
    def stop(self) -> None:
        """Stop streaming, keep every hit already recorded, and end."""
        if self._stopping:
            return
        self._stopping = True
        if self._timer is not None:
            self._timer.stop()
        if self.loop is not None:
            self.loop.stop()
            self._drain()
        self._close_device()
        self._finish()

    def _finish(self) -> None:
        hand_back(self)
        self.finished.emit()

    def _close_device(self) -> None:
        if self.device is not None:
            try:
                self.device.close()
            except GasfilmError:
                pass  # a removed device cannot be closed cleanly; the fault was already reported
            self.device = None

    # --- the poll: chunks → hits -------------------------------------------------------------------------------------

    def _poll(self) -> None:
        try:
            ended = self._drain()
            error = self.loop.error if ended and self.loop is not None else None
        except GasfilmError as stopped:  # the recorder stopped: a write failed, or too many hits in a row were rejected
            ended, error = True, stopped
            if self.loop is not None:
                self.loop.stop()
        if ended:
            if self._timer is not None:
                self._timer.stop()
            self._stopping = True
            if error is not None:
                self.device_fault.emit(str(error))
            self._close_device()
            self._finish()

    def _drain(self) -> bool:
        """Feed every waiting chunk to the recorder; True when the stream has ended."""
        if self._mailbox is None or self.recorder is None:
            return True
        while True:
            try:
                chunk = self._mailbox.get(timeout_s=0)
            except queue.Empty:
                return False
            if chunk is None:
                return True
            self.stats.chunks_read += 1
            self.stats.samples_read += chunk.data.shape[1]
            self.stats.dropped_chunks = self._mailbox.dropped_chunks
            self._report_flags(chunk.status)
            self._watch_trigger(chunk.data[self._force_row], chunk.first_sample + chunk.data.shape[1])
            events = self.recorder.feed(chunk.data, chunk.status.overload)
            for event in events:
                self._on_hit(event)
            if events and self._capture.samples_seen >= self._recording_until:
                self._set_trigger_state("armed")

    def _watch_trigger(self, force_n: np.ndarray, end_sample: int) -> None:
        """Show "triggered" from a chunk that crosses the trigger level until its record is complete."""
        trigger = self.plan.trigger
        crossed = np.max(force_n) >= trigger.level_n if trigger.slope == "rising" else np.min(force_n) <= trigger.level_n
        if crossed:
            self._recording_until = end_sample + self._record_samples
            self._set_trigger_state("triggered")
        elif end_sample >= self._recording_until:
            self._set_trigger_state("armed")

    def _on_hit(self, event: HitEvent) -> None:
        self.stats.hits += 1
        automatic = event.verdict
        decided = (self.plan.hit_check or (automatic.accepted and self.plan.auto_accept)
                   or (not automatic.accepted and self.plan.auto_reject))
        entry = HitEntry(event.index, event.record, automatic, automatic, pending=not decided)
        if entry.pending and self.session is not None:  # never on disk as accepted before the technician says so
            self.session.set_verdict(entry.index, pending_verdict(automatic))
        self._entries[entry.index] = entry
        self.hit_recorded.emit(entry)

    def _report_flags(self, status: Any) -> None:
        names = [channel.physical_channel for channel in self.plan.config.channels]
        parts = []
        if status.overload is not None and np.any(status.overload):
            parts.append("overload on " + ", ".join(n for n, f in zip(names, status.overload) if f))
        if status.open_sensor is not None and np.any(status.open_sensor):
            parts.append("open sensor (unplugged or broken cable) on " + ", ".join(
                n for n, f in zip(names, status.open_sensor) if f
            ))
        text = "; ".join(parts)
        if text != self._last_flags:
            self._last_flags = text
            if text:
                self.channel_warning.emit(f"{self.plan.device_name}: {text}")

    def _set_trigger_state(self, state: str) -> None:
        if state != self._last_trigger_state:
            self._last_trigger_state = state
            self.trigger_state.emit(state)

    # --- requests from the GUI (queued onto this thread) -------------------------------------------------------------

    @Slot(int, bool)
    def decide(self, index: int, accepted: bool) -> None:
        """The technician's Accept/Reject: stored in the session at once, the FRF follows."""
        entry = self._entries.get(index)
        if entry is None:
            return
        overridden = accepted != entry.automatic.accepted
        entry.verdict = Verdict(accepted, entry.automatic.reasons, overridden=overridden)
        entry.pending = False
        self.session.set_verdict(index, entry.verdict)
        self.verdict_changed.emit(entry)

    @Slot(int, str)
    def hold(self, index: int, reason: str) -> None:
        """Take back an automatic acceptance (e.g. the hit lowers the coherence): the hit waits for the technician."""
        entry = self._entries.get(index)
        if entry is None or entry.verdict.overridden:
            return
        entry.automatic = Verdict(False, entry.automatic.reasons + (reason,))
        entry.verdict = entry.automatic
        entry.pending = True
        self.session.set_verdict(index, pending_verdict(entry.automatic))
        self.verdict_changed.emit(entry)

    @Slot(str)
    def virtual_hit(self, tip: str) -> None:
        if isinstance(self.device, ReaderThreadHooks):
            self.device.request(lambda device: device.sim_hit(tip=tip))

    @Slot(str)
    def inject_fault(self, kind: str) -> None:
        if isinstance(self.device, ReaderThreadHooks):
            self.device.request(lambda device: device.sim_inject_fault(kind))


class ContinuingCapture(ImpactCapture):
    """The software trigger with hit times counted from the session's start, not the stream's: a session re-armed
    after a stop continues its time line instead of starting again at 0."""

    time_offset_s = 0.0

    def feed(self, chunk: np.ndarray, overload: np.ndarray | None = None) -> list[HitRecord]:
        records = super().feed(chunk, overload)
        for record in records:
            record.start_time_s += self.time_offset_s
        return records


class ReaderThreadHooks:
    """The simulated device with its ``sim_`` hooks run on the reader thread, just before the next read.

    The simulator is not thread-safe: a hit synthesised while another thread is inside ``read`` can be dropped.
    Requests are queued here and applied by the reader thread itself, so hooks and reads never overlap; a virtual
    hit lands at the start of the next chunk (at most one chunk, about 0.1 s, later)."""

    def __init__(self, device: DaqDevice) -> None:
        self._device = device
        self._requests: "queue.SimpleQueue[Callable[[Any], Any]]" = queue.SimpleQueue()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._device, name)

    def request(self, action: Callable[[Any], Any]) -> None:
        """Thread-safe: ``action(device)`` runs on the reader thread before its next read."""
        self._requests.put(action)

    def read(self, out: np.ndarray, timeout_s: float = 10.0) -> int:
        while True:
            try:
                action = self._requests.get_nowait()
            except queue.Empty:
                break
            action(self._device)
        return self._device.read(out, timeout_s)


Report = Callable[[float, str], None]


#: Modules the job processes' fork server imports once, so that each job starts in milliseconds.
JOB_MODULES = ("gasfilm.app.gui.jobs",)
#: How long a cancelled job's process may take to reach its next progress report before it is terminated, in s.
CANCEL_GRACE_S = 10.0


def warm_up_job_processes() -> None:
    """Start the fork server now (it imports the analysis in its own process, seconds on a busy machine) and a first
    job process, so the first fit or diagnosis starts at once. Returns at once: the server is spawned here, from the
    main thread, with Ctrl-C ignored, which it and the job processes forked from it inherit — a Ctrl-C in the terminal
    reaches the whole process group, and the GUI, not the terminal, ends its job processes (before, a Ctrl-C while
    the server imported the analysis printed its KeyboardInterrupt traceback). The first job process is started on a
    thread (it waits for the server's imports)."""
    context = _job_context()
    if context.get_start_method() == "forkserver" and threading.current_thread() is threading.main_thread():
        multiprocessing.resource_tracker.ensure_running()  # (it ignores Ctrl-C itself)
        with _ctrl_c_ignored():
            multiprocessing.forkserver.ensure_running()
    threading.Thread(target=_JOB_PROCESSES.prepare, name="gasfilm-job-warm-up", daemon=True).start()


@contextlib.contextmanager
def _ctrl_c_ignored():
    """SIGINT ignored while the block runs (main thread only, for a spawn): a process spawned meanwhile is born
    ignoring it (an ignored signal stays ignored across exec; a blocked one does not, the spawn resets the mask).
    It is also blocked meanwhile, so that one arriving now is not lost: Linux keeps a blocked signal pending even
    while it is ignored, and delivers it to the handler restored before it is unblocked."""
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def job_process_ready(timeout_s: float) -> bool:
    """Wait until a warmed-up job process waits for work (at most ``timeout_s``); whether one does."""
    return _JOB_PROCESSES.ready(timeout_s)


def _job_context() -> Any:
    """Processes forked from a fork server (started once, without Qt or threads) that has imported the analysis;
    where there is none (Windows), freshly started ones."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(JOB_MODULES))
    return context


@dataclass
class _JobProcess:
    """A job's process (:func:`gasfilm.app.gui.jobs.serve_one_job`), its work pipe, message queue, cancel event and
    the event it sets once warmed up."""

    process: Any
    works: Any
    messages: Any
    cancel: Any
    warm: Any

    @classmethod
    def start(cls) -> "_JobProcess":
        context = _job_context()
        receiving, sending = context.Pipe(duplex=False)
        messages, cancel, warm = context.Queue(), context.Event(), context.Event()
        process = context.Process(target=serve_one_job, args=(receiving, messages, cancel, warm), daemon=True)
        process.start()
        receiving.close()
        return cls(process, sending, messages, cancel, warm)


class _JobProcesses:
    """One job process kept ready: started and warmed up while the GUI is idle (after the previous job), so that a
    click does not wait for a process to start (some 30 ms) nor for its first fit's slower pace (some 100 ms). A
    second job at the same time starts a process of its own."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._spare: _JobProcess | None = None
        self._prepared = threading.Event()
        self._closed = False

    def prepare(self) -> None:
        """Start the spare process if there is none (in the calling thread)."""
        with self._lock:
            if self._closed or (self._spare is not None and self._spare.process.is_alive()):
                return
            self._prepared.clear()
            try:
                self._spare = _JobProcess.start()
            except Exception as error:  # the next job starts its own process, and says so if it cannot
                logger.info("no job process started ahead: %s", error)
                self._spare = None
            self._prepared.set()

    def close(self, timeout_s: float = 30.0) -> None:
        """No more spare processes (the application ends); the waiting one ends now. A spare being started (the warm-up
        thread waits for the fork server's imports) is waited for first: quitting in the first seconds used to end the
        interpreter under it — multiprocessing removed the fork server's socket folder while the thread still
        connected, and the thread printed a FileNotFoundError traceback. This runs before multiprocessing's own exit
        function (registered earlier, so called later)."""
        self._closed = True  # a prepare() that has not taken the lock yet starts nothing
        if not self._lock.acquire(timeout=timeout_s):
            logger.warning("a job process was still starting after %.0f s; leaving it", timeout_s)
            return
        try:
            spare, self._spare = self._spare, None
        finally:
            self._lock.release()
        if spare is not None:
            spare.works.close()  # it ends at once (EOF), without work
            spare.process.join(1.0)

    def take(self) -> _JobProcess:
        """The spare process (a new one when there is none)."""
        with self._lock:
            spare, self._spare = self._spare, None
        if spare is None or not spare.process.is_alive():
            spare = _JobProcess.start()
        return spare

    def ready(self, timeout_s: float) -> bool:
        if not self._prepared.wait(timeout_s):
            return False
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                spare = self._spare
            if spare is not None and spare.process.is_alive() and spare.warm.wait(0.05):
                return True
        return False


_JOB_PROCESSES = _JobProcesses()
atexit.register(_JOB_PROCESSES.close)


def _end_child(child: _JobProcess) -> None:
    """Wait for a job's process to end (terminate it after a grace second), close its queue, and start the next
    job's process."""
    child.process.join(1.0)
    if child.process.is_alive():
        child.process.terminate()
        child.process.join(1.0)
    child.messages.close()
    child.works.close()
    _JOB_PROCESSES.prepare()


class BackgroundJob(QObject):
    """Run ``work(report, cancelled)`` away from the GUI thread; ``report(fraction, text)`` drives a progress bar and
    raises :class:`JobCancelled` once Cancel was pressed; ``cancelled()`` can be polled by long computations.

    With ``in_process`` (the fits and the diagnosis) ``work`` must be picklable (a module-level function, or a
    ``functools.partial`` of one, see :mod:`gasfilm.app.gui.jobs`) and runs in a child process: it has its own
    interpreter lock, so the live view, the acquisition and the simulated device never slow it down. The thread
    that owns the job only relays the child's progress and result."""

    progress = Signal(float, str)
    succeeded = Signal(object)
    failed = Signal(str)
    cancelled = Signal()
    finished = Signal()

    def __init__(self, work: Callable[[Report, Callable[[], bool]], Any], in_process: bool = False) -> None:
        super().__init__()
        self._work = work
        self._in_process = in_process
        self._cancel = threading.Event()
        self._child: _JobProcess | None = None  # the job process once dispatched, and whether the work reached it
        self._sent = False

    def dispatch(self) -> None:
        """In-process jobs: hand the work to a job process now, from the caller's (the GUI's) thread, so that it starts
        at the click and not once the thread that relays its messages gets the interpreter lock (some 10 ms later when
        the GUI is busy, as when Arm is pressed just after). A failure here is left to :meth:`run`, which reports it."""
        if not self._in_process or self._child is not None:
            return
        try:
            child = _JOB_PROCESSES.take()
        except Exception as error:  # (the process could not start: run() tries again and says why)
            logger.info("job not dispatched from the GUI thread: %s", error)
            return
        self._child = child
        try:
            child.works.send(self._work)
        except Exception as error:  # (the work cannot be pickled: run() fails with the reason, and ends the child)
            logger.info("job not dispatched from the GUI thread: %s", error)
        else:
            self._sent = True

    def cancel(self) -> None:
        """Thread-safe: the job stops at its next check."""
        self._cancel.set()

    def _run_in_process(self, report: Report) -> Any:
        """Start the child, relay its progress, return its result (or raise its failure or cancellation)."""
        child, sent = self._child or _JOB_PROCESSES.take(), self._sent
        messages, cancel = child.messages, child.cancel
        cancel_sent_s: float | None = None
        try:
            if not sent:
                child.works.send(self._work)
            while True:
                if self._cancel.is_set() and cancel_sent_s is None:
                    cancel.set()
                    cancel_sent_s = time.monotonic()
                if cancel_sent_s is not None and time.monotonic() - cancel_sent_s > CANCEL_GRACE_S:
                    raise JobCancelled("cancelled")
                try:
                    message = messages.get(timeout=0.05)
                except queue.Empty:
                    if not child.process.is_alive() and messages.empty():
                        raise GasfilmError(
                            f"the job's process ended unexpectedly (exit code {child.process.exitcode})"
                        ) from None
                    continue
                kind = message[0]
                if kind == "progress":
                    if not self._cancel.is_set():
                        self.progress.emit(message[1], message[2])
                elif kind == "done":
                    return message[1]
                elif kind == "cancelled":
                    raise JobCancelled("cancelled")
                else:
                    raise GasfilmError(message[1])
        finally:
            # The result is delivered at once; the child's own exit (flushing its queue, freeing its memory: tenths
            # of a second on a busy machine) is awaited on a helper thread, not before the GUI gets the result.
            threading.Thread(target=_end_child, args=(child,), name="gasfilm-job-exit", daemon=True).start()

    @Slot()
    def run(self) -> None:
        last_emit_s = [0.0]

        def report(fraction: float, text: str) -> None:
            if self._cancel.is_set():
                raise JobCancelled("cancelled")
            now = time.monotonic()
            if now - last_emit_s[0] >= PROGRESS_INTERVAL_S or fraction >= 1.0:  # never flood the GUI's event loop
                last_emit_s[0] = now
                self.progress.emit(float(fraction), text)

        try:
            result = self._run_in_process(report) if self._in_process else self._work(report, self._cancel.is_set)
        except GasfilmError as error:
            if self._cancel.is_set():
                self.cancelled.emit()
            else:
                self.failed.emit(str(error))
        except Exception as error:  # a bug in a job must reach the banner, not vanish with the thread
            self.failed.emit(f"internal error: {type(error).__name__}: {error}")
        else:
            if self._cancel.is_set():
                self.cancelled.emit()
            else:
                self.succeeded.emit(result)
        hand_back(self)
        self.finished.emit()


def start_on_thread(worker: QObject, entry: Callable[[], None], parent: QObject) -> QThread:
    """Move ``worker`` to a new thread and call ``entry`` there. The worker must call :func:`hand_back` just before
    it emits ``finished``; the owner then waits for the thread and drops both (see the controller)."""
    thread = QThread(parent)
    worker.moveToThread(thread)
    thread.started.connect(entry)
    # Direct: QThread.quit is thread-safe, and the GUI thread may be blocked in thread.wait() (closing the window).
    worker.finished.connect(thread.quit, Qt.ConnectionType.DirectConnection)
    thread.start()
    return thread


def hand_back(worker: QObject) -> None:
    """Called on the worker's thread at its end: move it to the GUI thread, where its owner deletes it safely."""
    application = QCoreApplication.instance()
    if application is not None:
        worker.moveToThread(application.thread())
