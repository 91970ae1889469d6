"""One metadata writer at a time: the client lock of a store, and the workers' claims.

Why a lock: ``create_group``, ``reserve`` and ``write_solves`` read metadata, decide
(which slots are free, whether the group is there) and then write. Two clients doing
that at once both take the same free slots and overwrite each other's ids and
parameters; measured before this module, 4 racing ``reserve`` calls lost 348 of 600 ids
and mislabelled 12 in 10 trials while every call returned normally
(``tests/storage/test_store_concurrency.py``). :func:`client_lock` makes those calls
take turns, per store (``docs/store.md``, "Concurrent clients"):

- local and shared file systems: an advisory ``flock`` on ``<store>/.farm.lock``. The
  kernel (or the NFSv4 server) drops it when its process dies, so a killed client never
  leaves the store locked;
- object stores (``s3://``): a lock object ``<store>/.farm.lock`` made by a conditional
  write (``If-None-Match: *``): exactly one client can create it. It has no lease: a
  client killed inside the lock (a window of a second) leaves it, and the next client
  waits, then says which object to delete. A backend that ignores the condition, or
  cannot create exclusively at all, gives no exclusion; ``reserve`` re-reads what it
  wrote and raises if another client's race changed it, so a lost race is never silent;
- any other zarr store object (in memory): a lock of this process.

The lock is re-entrant within a thread. Why a claim (:func:`claim`): two clusters on
one store (two embedded clusters) share no Dask keys, so both would solve every path;
a worker holds the path's claim while it solves, and the other waits, then finds the
experiments done. Claims are files, so object stores have none (both solve the path
and write the same bytes: wasted time, no corruption).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import socket
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

from zarr.abc.store import Store
from zarr.storage import FsspecStore, LocalStore

from storage._zarr import run
from storage.errors import SchemaError, StoreBusyError, StoreError
from storage.paths import (
    CLAIMS_DIR,
    LOCK_NAME,
    StoreLike,
    check_group_name,
    check_local_dir,
    describe,
    open_store,
)
from storage.schema import GROUP_NAME

#: How long a client waits for another one's create_group/reserve (seconds): those
#: take well under a second for a study, seconds for 10^5 experiments.
LOCK_TIMEOUT_S = 120.0
_HELD = threading.local()  # lock key -> depth, per thread (re-entrance)
_IN_PROCESS: dict[int, threading.Lock] = {}  # locks of stores that live in this process
_IN_PROCESS_GUARD = threading.Lock()


@contextlib.contextmanager
def client_lock(store: Store, *, create: bool = False,
                timeout: float = LOCK_TIMEOUT_S) -> Iterator[None]:
    """Hold the store's client lock: one metadata writer at a time.

    Parameters
    ----------
    store : zarr store
        From :func:`storage.open_store`.
    create : bool
        A local store's directory may be made (for ``create_group``); otherwise a
        missing store raises :class:`NotAStoreError` and nothing is created.
    timeout : float
        Seconds to wait for another client before :class:`StoreBusyError`.
    """
    key = _key(store)
    held = _HELD.__dict__.setdefault("depth", {})
    if key in held:  # create_group -> ... -> reserve in one thread: already ours
        held[key] += 1
        try:
            yield
        finally:
            held[key] -= 1
        return
    if isinstance(store, LocalStore):
        lock = _file_lock(store, create, timeout)
    elif isinstance(store, FsspecStore):
        lock = _object_lock(store, timeout)
    else:
        lock = _process_lock(store, timeout)
    with lock:
        held[key] = 1
        try:
            yield
        finally:
            del held[key]


def _key(store: Store) -> tuple[object, ...]:
    if isinstance(store, LocalStore):
        return ("local", str(Path(store.root).resolve()))
    if isinstance(store, FsspecStore):
        return ("fsspec", describe(store))
    return ("object", id(store))


def _owner() -> str:
    return f"pid {os.getpid()} on {socket.gethostname()} since {time.strftime('%H:%M:%S')}"


def _wait(attempt: Callable[[], bool], timeout: float, busy: Callable[[], str],
          longest: float = 0.05) -> None:
    """Call ``attempt`` until it returns True, backing off; StoreBusyError after ``timeout``."""
    deadline, delay = time.monotonic() + timeout, 0.001
    while not attempt():
        if time.monotonic() >= deadline:
            raise StoreBusyError(busy())
        time.sleep(delay)
        delay = min(2 * delay, longest)


# ---------------------------------------------------------------- files: flock


def _try_flock(fd: int, path: Path) -> bool:
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False
    except OSError as e:  # ENOLCK, EOPNOTSUPP: a file system without locks
        code = e.errno if e.errno is None else errno.errorcode.get(e.errno, e.errno)
        raise StoreError(
            f"cannot lock {path}: its file system does not support file locks "
            f"({code}: {e.strerror}); put the store on a local "
            "disk or an NFSv4 share, or use an s3:// store"
        ) from e


def _open(path: Path) -> int:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
    except OSError as e:
        raise StoreError(
            f"cannot open the lock file {path} ({e.strerror}): a client needs write access "
            "to the store's directory"
        ) from e


def _holder(path: Path) -> str:
    try:
        return path.read_text(errors="replace").strip() or "unknown"
    except OSError:
        return "unknown"


@contextlib.contextmanager
def _file_lock(store: LocalStore, create: bool, timeout: float) -> Iterator[None]:
    check_local_dir(store, create)  # nothing made in a directory that is not ours
    path = Path(store.root) / LOCK_NAME
    fd = _open(path)
    try:
        _wait(lambda: _try_flock(fd, path), timeout, lambda: (
            f"the store at {store.root} is busy: another client has held its lock for over "
            f"{timeout:.0f} s ({path}: {_holder(path)}); wait for it to finish creating "
            "groups or reserving experiments, or stop it"))
        with contextlib.suppress(OSError):  # who holds it, for the message above only
            os.ftruncate(fd, 0)
            os.pwrite(fd, _owner().encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the flock


# ---------------------------------------------------------------- objects: conditional write


@contextlib.contextmanager
def _object_lock(store: FsspecStore, timeout: float) -> Iterator[None]:
    fs, path = store.fs, f"{store.path.rstrip('/')}/{LOCK_NAME}"
    token = f"{_owner()}, token {uuid.uuid4().hex}".encode()
    unsupported = []

    def attempt() -> bool:
        try:
            run(fs._pipe_file(path, token, mode="create"))  # If-None-Match: * on S3
            return True
        except FileExistsError:
            return False
        except (TypeError, NotImplementedError):
            # A backend without exclusive creation: no lock; the rule is one client at a
            # time, and reserve's read-back detects a lost race (docs/store.md).
            unsupported.append(True)
            return True
        except OSError as e:
            raise StoreError(f"cannot create the lock object {describe(store)}/{LOCK_NAME} "
                             f"({type(e).__name__}: {e}): check the store's URL and "
                             "write permission") from e

    def busy() -> str:
        try:
            holder = run(fs._cat_file(path)).decode(errors="replace")
        except (OSError, ValueError):
            holder = "unknown"
        return (f"the store at {describe(store)} is busy: its lock object {LOCK_NAME} has "
                f"been there for over {timeout:.0f} s ({holder}); if no farm client runs on "
                f"this store (one was killed while it held the lock), delete "
                f"{describe(store)}/{LOCK_NAME}")

    _wait(attempt, timeout, busy, longest=0.5)
    try:
        yield
    finally:
        with contextlib.suppress(OSError, ValueError):  # never delete another client's lock
            if not unsupported and run(fs._cat_file(path)) == token:
                run(fs._rm_file(path))


@contextlib.contextmanager
def _process_lock(store: Store, timeout: float) -> Iterator[None]:
    with _IN_PROCESS_GUARD:
        lock = _IN_PROCESS.setdefault(id(store), threading.Lock())
    if not lock.acquire(timeout=timeout):
        raise StoreBusyError(f"the store {describe(store)} is busy: another thread of this "
                             f"process has held its lock for over {timeout:.0f} s")
    try:
        yield
    finally:
        lock.release()


# ---------------------------------------------------------------- claims


@contextlib.contextmanager
def claim(store: StoreLike, group: str, key: str, *,
          should_stop: Callable[[], bool] | None = None, poll_s: float = 0.2) -> Iterator[bool]:
    """Hold the claim on one unit of work of ``group`` (a load path) while it is done.

    Waits while another process holds it, then yields True: the caller re-reads what is
    done and does the rest. Yields False without the claim when ``should_stop`` turns
    True while waiting (a cancelled task). Object stores and stores in memory have no
    claims: yields True at once.

    Parameters
    ----------
    store, group : the store and the group the work writes into.
    key : str
        The unit's name (a Dask key such as ``path-<hash>``): letters, digits, ``_.-``.
    should_stop : callable, optional
        Polled while waiting.
    poll_s : float
        Seconds between attempts while waiting.
    """
    zs = open_store(store)
    check_group_name(group)
    if not (isinstance(key, str) and GROUP_NAME.fullmatch(key)):
        raise SchemaError(f"a claim key is 1-128 letters, digits, '_', '.' or '-', got {key!r}")
    if not isinstance(zs, LocalStore):
        yield True
        return
    check_local_dir(zs, create=False)
    path = Path(zs.root) / CLAIMS_DIR / group / key
    fd = _take(path, should_stop, poll_s)
    if fd is None:
        yield False
        return
    try:
        yield True
    finally:
        # Unlink while still holding it: a waiter that then locks the unlinked file sees
        # that the path names another file (or none) and starts again (_same_file).
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
        os.close(fd)


def _same_file(fd: int, path: Path) -> bool:
    try:
        mine, now = os.fstat(fd), path.stat()
    except FileNotFoundError:
        return False
    return (mine.st_dev, mine.st_ino) == (now.st_dev, now.st_ino)


def _take(path: Path, should_stop: Callable[[], bool] | None, poll_s: float) -> int | None:
    while True:
        fd = _open(path)
        if _try_flock(fd, path):
            if _same_file(fd, path):
                return fd
            os.close(fd)  # its holder finished and removed it: try the new file at once
            continue
        os.close(fd)
        if should_stop is not None and should_stop():
            return None
        time.sleep(poll_s)
