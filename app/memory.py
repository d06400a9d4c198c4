"""How much memory the process may use: what the command line checks before it starts, and names when memory runs
out."""

from __future__ import annotations

#: Address space a command needs to start its numerical libraries (measured: 290-370 MB of virtual memory with one
#: BLAS thread); below it, OpenBLAS spins for ever retrying its buffers, or an import fails half-way.
MIN_ADDRESS_SPACE_BYTES = 400 << 20


def address_space_limit() -> int | None:
    """The memory this process may map (``ulimit -v`` / ``-d``), in bytes; None when unlimited."""
    try:
        import resource
    except ImportError:  # (Windows)
        return None
    limits = [resource.getrlimit(kind)[0] for kind in (resource.RLIMIT_AS, resource.RLIMIT_DATA)]
    limits = [limit for limit in limits if limit != resource.RLIM_INFINITY and limit >= 0]
    return min(limits) if limits else None
