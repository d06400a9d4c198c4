"""A session held open for writing by another process, as a recording in another gasfilm holds it."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from pathlib import Path
from typing import Iterator


@contextlib.contextmanager
def held_by_another_process(path: Path) -> Iterator[None]:
    """Within the block, a separate Python process has ``path`` open for writing (its writer lock taken); it closes
    the session when the block ends."""
    writer = subprocess.Popen(
        [sys.executable, "-c", "import sys\nfrom gasfilm.analysis.session import Session\n"
         f"session = Session.open({str(path)!r}, 'a')\nprint('open', flush=True)\nsys.stdin.read()\nsession.close()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "open"
        yield
    finally:
        writer.communicate("", timeout=60)
