"""Independent parts of a diagnosis computed by two processes at once.

The candidate fits of one forward-selection step do not depend on each other and take tens to hundreds of
milliseconds each; nor do the hits of a nonlinear replay, nor the figures. :func:`shared_map` computes them in this process and in a forked copy of it, both taking the next
item from one queue (a pipe), so the diagnosis uses both cores of a 2-core machine. Each item's result is what the
serial loop gives, bit for bit: the copy starts from the same memory and every item is computed the same way; only the
results travel back (pickled). Where there is no ``fork`` (Windows), with one CPU, inside
:func:`worker_processes` ``(1)`` (a campaign's dask workers are already one per core), or when the copy fails, the
items are computed here one after the other. A map inside an item of another (a nonlinear replay inside a fit that
is an item) is computed by the process that took the item: both are busy already.
"""

from __future__ import annotations

import contextlib
import contextvars
import logging
import os
import pickle
import signal
from typing import Any, Callable, Iterator, Sequence, TypeVar

from gasfilm.analysis.interrupts import die_with_parent

logger = logging.getLogger(__name__)

#: Processes that share the work, at most (this one and a forked copy).
MAX_WORKERS = 2
#: The queue holds item numbers as single bytes.
MAX_ITEMS = 255

Item = TypeVar("Item")

_workers: contextvars.ContextVar[int | None] = contextvars.ContextVar("gasfilm_diagnosis_workers", default=None)
_inside_item: contextvars.ContextVar[bool] = contextvars.ContextVar("gasfilm_diagnosis_inside_item", default=False)


@contextlib.contextmanager
def worker_processes(count: int) -> Iterator[None]:
    """Within the block, diagnoses share their work among at most ``count`` processes (1: no copy is forked)."""
    token = _workers.set(count)
    try:
        yield
    finally:
        _workers.reset(token)


def worker_count() -> int:
    """Processes a diagnosis may use here: the CPUs this process may run on, at most :data:`MAX_WORKERS`."""
    if not hasattr(os, "fork") or _inside_item.get():
        return 1
    chosen = _workers.get()
    if chosen is not None:
        return max(1, min(chosen, MAX_WORKERS))
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, MAX_WORKERS))


def shared_map(function: Callable[[Item], Any], items: Sequence[Item], longest_first: bool = False) -> list[Any]:
    """``[function(item) for item in items]``, where an item whose call raised an :class:`Exception` gives that
    exception as its result; computed by this process and a forked copy of it (see the module's description).
    ``longest_first``: the items are listed from the quickest to the slowest, so the two processes take them from the
    end (then neither is left alone with a long item at the finish)."""
    items = list(items)
    if len(items) < 2 or len(items) > MAX_ITEMS or worker_count() < 2:
        return [_called(function, item) for item in items]
    order = range(len(items) - 1, -1, -1) if longest_first else range(len(items))
    queue_read, queue_write = os.pipe()
    os.write(queue_write, bytes(order))
    os.close(queue_write)
    result_read, result_write = os.pipe()
    parent = os.getpid()
    try:
        child = os.fork()
    except OSError as error:
        logger.info("diagnosis: no second process (%s); computing alone", error)
        for descriptor in (result_read, result_write):
            os.close(descriptor)
        results = {index: _called(function, items[index]) for index in _taken(queue_read)}
        os.close(queue_read)
        return [results[index] for index in range(len(items))]
    if child == 0:  # the copy: compute what it takes from the queue, send the results, never return
        status = 1
        try:
            die_with_parent(parent)  # (a killed diagnosis leaves no process computing on)
            os.close(result_read)
            done = {index: _called(function, items[index]) for index in _taken(queue_read)}
            payload = pickle.dumps(done, protocol=pickle.HIGHEST_PROTOCOL)
            with os.fdopen(result_write, "wb") as stream:
                stream.write(payload)
            status = 0
        finally:
            os._exit(status)
    os.close(result_write)
    try:
        results = {index: _called(function, items[index]) for index in _taken(queue_read)}
        os.close(queue_read)
        with os.fdopen(result_read, "rb") as stream:
            payload = stream.read()
    except BaseException:  # (stopped by a signal: the copy is stopped with it)
        with contextlib.suppress(OSError):
            os.kill(child, signal.SIGKILL)
            os.waitpid(child, 0)
        raise
    _, status = os.waitpid(child, 0)
    if payload and status == 0:
        results.update(pickle.loads(payload))
    missing = [index for index in range(len(items)) if index not in results]
    if missing:  # the copy failed (its results could not be pickled, or it was killed): do its share here
        logger.info("diagnosis: the second process returned no results for %d item(s); computing them here",
                    len(missing))
        results.update({index: _called(function, items[index]) for index in missing})
    return [results[index] for index in range(len(items))]


def _taken(queue_read: int) -> Iterator[int]:
    """Item numbers taken one at a time from the shared queue until it is empty (a one-byte read from a pipe is
    atomic: each number goes to exactly one process)."""
    while True:
        taken = os.read(queue_read, 1)
        if not taken:
            return
        yield taken[0]


def _called(function: Callable[[Item], Any], item: Item) -> Any:
    token = _inside_item.set(True)
    try:
        return function(item)
    except Exception as error:  # returned, and raised or handled by the caller as in a serial loop
        return error
    finally:
        _inside_item.reset(token)
