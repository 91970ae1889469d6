"""Meshing that leaves the process's signal dispositions as it found them.

gmsh's initialisation resets process-wide signal dispositions behind Python's back
(gmsh 4.x: SIGPIPE from ignored to default, SIGINT from Python's handler to default).
With SIGPIPE at its default, the first write to a socket whose peer has gone kills the
whole process instead of raising ``BrokenPipeError``: a Dask client, a worker, or the
test session (CI died so, exit 141, in the TLS tests after an earlier test had meshed
in-process); with SIGINT at its default, Ctrl-C no longer cancels a run cleanly.
:func:`farm.mesh.build.build_mesh` meshes inside :func:`signal_dispositions_kept`.
"""

from __future__ import annotations

import ctypes
import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager

_SIGNALS = tuple(s for s in range(1, signal.NSIG) if s not in (signal.SIGKILL, signal.SIGSTOP))


@contextmanager
def signal_dispositions_kept() -> Iterator[None]:
    """Put back every signal disposition the block changed (process-wide, any thread).

    The C ``struct sigaction`` is saved and restored as opaque bytes, so Python's own
    handlers (SIGINT -> KeyboardInterrupt) come back too; signals the C library keeps
    for itself are refused by ``sigaction`` and left alone.
    """
    if not sys.platform.startswith(("linux", "darwin")):
        yield
        return
    libc = ctypes.CDLL(None, use_errno=True)
    saved = {}
    for number in _SIGNALS:
        action = ctypes.create_string_buffer(512)  # larger than any struct sigaction
        if libc.sigaction(number, None, action) == 0:
            saved[number] = action
    try:
        yield
    finally:
        for number, action in saved.items():
            libc.sigaction(number, action, None)
