"""One BLAS thread for the analysis's many small linear-algebra calls.

The diagnosis and the fitters make thousands of BLAS/LAPACK calls on arrays of a few thousand numbers (vector norms
inside iterative solvers, least squares of a few columns). A multi-threaded OpenBLAS wakes and synchronises its
threads for each: on the 2-core machine with another process busy (the GUI's live view, a second job) a 32 768-point
norm took 2.2 ms instead of 31 µs and a diagnosis twice the CPU time. :func:`one_blas_thread` limits the BLAS and
OpenMP pools of the loaded libraries for the duration of a call (threadpoolctl, restored afterwards).
"""

from __future__ import annotations

import functools
from typing import Callable, TypeVar

from threadpoolctl import threadpool_limits

Function = TypeVar("Function", bound=Callable)


def one_blas_thread(function: Function) -> Function:
    """Decorator: ``function`` runs with one BLAS/OpenMP thread (the previous limits restored after it)."""

    @functools.wraps(function)
    def limited(*args, **kwargs):
        with threadpool_limits(limits=1):
            return function(*args, **kwargs)

    return limited  # type: ignore[return-value]
