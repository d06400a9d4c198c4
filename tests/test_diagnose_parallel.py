"""The diagnosis's work shared with a forked copy of the process: the same results as computed alone, bit for bit."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

from gasfilm.analysis.diagnosis import diagnose
from gasfilm.analysis.diagnosis.parallel import shared_map, worker_count, worker_processes
from gasfilm.analysis.diagnosis.plots import OUTPUT_FILES, write_outputs
from gasfilm.analysis.physics.effects import CubicStiffness
from gasfilm.drivers.errors import GasfilmError

from tests.test_diagnose import NOMINAL, record

needs_fork = pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")


def _square_or_fail(value: int) -> int:
    if value == 3:
        raise GasfilmError("three is refused")
    return value * value


@needs_fork
def test_items_are_shared_between_two_processes_and_come_back_in_order():
    with worker_processes(2):
        assert worker_count() == 2 or len(os.sched_getaffinity(0)) == 1
        results = shared_map(lambda value: (value * value, os.getpid()), list(range(40)))
    assert [value for value, _ in results] == [value * value for value in range(40)]
    if worker_count() == 2:
        assert len({pid for _, pid in results}) in (1, 2)  # the copy may or may not have taken an item


def test_an_exception_is_the_item_result_as_in_a_serial_loop():
    for workers in (1, 2):
        with worker_processes(workers):
            results = shared_map(_square_or_fail, [1, 2, 3, 4])
        assert results[:2] == [1, 4] and results[3] == 16
        assert isinstance(results[2], GasfilmError) and "three" in str(results[2])


@needs_fork
def test_results_the_copy_cannot_send_back_are_computed_here():
    lock_type = type(threading.Lock())
    with worker_processes(2):
        results = shared_map(lambda value: (value, threading.Lock()), list(range(6)))  # a lock cannot be pickled
    assert [value for value, _ in results] == list(range(6))
    assert all(isinstance(lock, lock_type) for _, lock in results)


def test_worker_processes_1_computes_alone():
    with worker_processes(1):
        assert worker_count() == 1
        assert {pid for pid in shared_map(lambda _: os.getpid(), range(5))} == {os.getpid()}


@needs_fork
def test_a_diagnosis_shared_with_a_copy_equals_one_computed_alone(tmp_path):
    """A hardening film: the cubic candidate's exact nonlinear replays play their hits in both processes; the figures
    drawn by both are the same files."""
    path = record(NOMINAL.with_effects(CubicStiffness(k3_n_per_m3=6e15)), tmp_path / "cubic.h5", hits=8, seed=4)
    with worker_processes(1):
        alone = diagnose(path, NOMINAL)
        write_outputs(alone, tmp_path / "alone")
    with worker_processes(2):
        shared = diagnose(path, NOMINAL)
        write_outputs(shared, tmp_path / "shared")
    for name in OUTPUT_FILES:
        if not (tmp_path / "alone" / name).exists():  # a figure this diagnosis has none of (a stabilization diagram)
            assert not (tmp_path / "shared" / name).exists(), name
            continue
        assert (tmp_path / "alone" / name).read_bytes() == (tmp_path / "shared" / name).read_bytes(), name
    assert shared.verdict == alone.verdict
    assert [f.to_dict() for f in shared.findings] == [f.to_dict() for f in alone.findings]
    assert shared.improved.to_toml() == alone.improved.to_toml()
    assert shared.chi2_per_point_after == alone.chi2_per_point_after
    assert np.array_equal(shared.evidence.spectra.h, alone.evidence.spectra.h)


@needs_fork
def test_longest_first_changes_only_the_order_of_work_not_of_results():
    with worker_processes(2):
        assert shared_map(lambda value: value + 1, list(range(12)), longest_first=True) == list(range(1, 13))


@needs_fork
def test_a_map_inside_an_item_is_computed_by_the_process_that_took_the_item():
    with worker_processes(2):
        results = shared_map(lambda _: (os.getpid(), shared_map(lambda _: os.getpid(), range(4))), range(6))
    for outer, inner in results:
        assert inner == [outer] * 4
