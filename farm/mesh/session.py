"""gmsh behind a context manager.

gmsh keeps one global state per process, so a session is exclusive (a lock serialises
threads, e.g. a Dask worker with several threads) and always finalised. It is started
non-interruptible: gmsh's default installs a SIGINT handler, which only works in the main
thread and would steal Ctrl-C from the CLI.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType

import gmsh

from farm.errors import FarmError, MeshError

_LOCK = threading.Lock()


@contextmanager
def gmsh_session(name: str, verbosity: int = 1) -> Iterator[ModuleType]:
    """Yield the initialised ``gmsh`` module with an empty model called ``name``.

    Any gmsh failure inside the block is re-raised as :class:`MeshError`.
    """
    with _LOCK:
        if gmsh.isInitialized():
            raise MeshError("gmsh is already initialised in this process; sessions cannot nest")
        gmsh.initialize(argv=["tyre-farm"], readConfigFiles=False, run=False, interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 1 if verbosity > 1 else 0)
            gmsh.option.setNumber("General.Verbosity", verbosity)
            gmsh.model.add(name)
            yield gmsh
        except FarmError:
            raise
        except Exception as e:  # gmsh raises bare Exception with its last error
            raise MeshError(f"gmsh failed while meshing {name!r}: {e}") from e
        finally:
            gmsh.finalize()
