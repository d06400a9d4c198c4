"""One BLAS thread for the analysis's many small linear-algebra calls.

The diagnosis and the fitters make thousands of BLAS/LAPACK calls on arrays of a few thousand numbers (vector norms
inside iterative solvers, least squares of a few columns). A multi-threaded OpenBLAS wakes and synchronises its
threads for each: on the 2-core machine with another process busy (the GUI's live view, a second job) a 32 768-point
norm took 2.2 ms instead of 31 µs and a diagnosis twice the CPU time. :func:`one_blas_thread` limits the BLAS and
OpenMP pools of the loaded libraries for the duration of a call (threadpoolctl, restored afterwards). Finding those
libraries takes threadpoolctl ~2 ms (a walk over every loaded shared object), a tenth of a small fit, so the list is
kept and found again only after more modules were imported (a new extension may bring its own BLAS).
"""

from __future__ import annotations

import functools
import sys
from typing import Callable, TypeVar

from threadpoolctl import ThreadpoolController

Function = TypeVar("Function", bound=Callable)

#: the threadpool libraries found, and how many modules were imported then
_controller: tuple[ThreadpoolController, int] | None = None


def _loaded_threadpools() -> ThreadpoolController:
    """The BLAS/OpenMP libraries loaded in this process, found again when modules were imported since."""
    global _controller
    if _controller is None or _controller[1] != len(sys.modules):
        _controller = (ThreadpoolController(), len(sys.modules))
    return _controller[0]


def one_blas_thread(function: Function) -> Function:
    """Decorator: ``function`` runs with one BLAS/OpenMP thread (the previous limits restored after it)."""

    @functools.wraps(function)
    def limited(*args, **kwargs):
        with _loaded_threadpools().limit(limits=1):
            return function(*args, **kwargs)

    return limited  # type: ignore[return-value]
