"""Test-wide set-up: Qt runs offscreen; matplotlib draws to files; one BLAS thread; commands start as from a
terminal."""

import os
import signal

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("MPLBACKEND", "Agg")
# The test workers fill the cores (one more worker than cores): OpenBLAS's own threads (one per core, spinning while
# they wait) would only take CPU from the other workers — a third more CPU under load for the same tests. Set before
# numpy loads OpenBLAS, and inherited by every command a test starts.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest  # noqa: E402

# A run started in the background (``cmd &`` in a script, nohup) inherits SIGINT or SIGHUP ignored, and so would every
# command a test starts: gasfilm keeps a signal it was started ignoring ignored, as the shell meant. The tests send
# stop signals to commands as a terminal would, so they start them with the dispositions a terminal gives.
for _signum, _handler in ((signal.SIGINT, signal.default_int_handler), (signal.SIGHUP, signal.SIG_DFL),
                          (signal.SIGTERM, signal.SIG_DFL)):
    if signal.getsignal(_signum) == signal.SIG_IGN:
        signal.signal(_signum, _handler)


@pytest.fixture(autouse=True, scope="session")
def every_written_spec_is_read_back():
    """Every rig spec any test writes (``RigSpec.to_toml``: the CLI's and the GUI's improved-rig.toml, sessions'
    stored specs, benchmarks' helpers) is read back by the spec reader at once, and equals what was written: what
    gasfilm writes, ``--rig`` accepts (issue 30, item 4)."""
    from gasfilm.analysis.physics.spec import RigSpec

    write = RigSpec.to_toml

    def written_and_read_back(spec: RigSpec) -> str:
        text = write(spec)
        assert RigSpec.from_toml(text, "spec written by a test") == spec, "a written spec reads back differently"
        return text

    patch = pytest.MonkeyPatch()
    patch.setattr(RigSpec, "to_toml", written_and_read_back)
    yield
    patch.undo()


@pytest.fixture(autouse=True)
def one_process_per_diagnosis_beside_another_test_worker():
    """Under test workers (``./run test``: every core has one already), a diagnosis a test runs in its own process
    computes alone instead of forking a copy to share its candidate fits (twice the processes on the same cores: the
    same results, bit for bit, for a tenth more CPU). ``test_diagnose_parallel`` asks for the copy and checks its
    results are the same."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        yield
        return
    from gasfilm.analysis.diagnosis.parallel import worker_processes

    with worker_processes(1):
        yield
