"""A worker process for the concurrency and crash tests: writes experiments as a farm
worker does (``write_experiment`` with synthetic results).

    python store_writer.py STORE GROUP N_INNER N_TREAD ID [ID ...]
        [--loop] [--ready FILE] [--kill-before-status ID] [--variant V]

``--loop`` re-writes the ids until killed; ``--ready`` touches FILE after the first
write; ``--kill-before-status`` kills this process (SIGKILL, no clean-up) at the moment
it would mark ID done, i.e. after every data chunk of ID was written; ``--variant``
writes other values (those of ``make_result(f"{id}/{V}")``), as a changed re-run would.
"""

from __future__ import annotations

import argparse
import itertools
import os
import signal
from pathlib import Path

from store_helpers import make_info, make_result
from zarr.storage import LocalStore

import storage


class KillBeforeStatus(LocalStore):
    """A local store that dies on the write that would mark one slot done."""

    def __init__(self, root: str, status_key: str) -> None:
        super().__init__(root)
        self.status_key = status_key

    async def set(self, key, value, *args, **kwargs):
        # the status chunk: one byte, then its CRC32C in groups made since issue 50
        if key == self.status_key and value.to_bytes()[:1] == bytes([storage.DONE]):
            os.kill(os.getpid(), signal.SIGKILL)
        return await super().set(key, value, *args, **kwargs)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("store")
    p.add_argument("group")
    p.add_argument("n_inner", type=int)
    p.add_argument("n_tread", type=int)
    p.add_argument("ids", nargs="+")
    p.add_argument("--loop", action="store_true")
    p.add_argument("--ready", type=Path)
    p.add_argument("--kill-before-status")
    p.add_argument("--variant")
    args = p.parse_args()
    store = args.store
    if args.kill_before_status:
        index = storage.statuses(store, args.group)  # ids in index order
        i = list(index).index(args.kill_before_status)
        store = KillBeforeStatus(args.store, f"{args.group}/status/c/{i}")
    passes = itertools.count() if args.loop else range(1)
    for _ in passes:
        for e in args.ids:
            key = f"{e}/{args.variant}" if args.variant else e
            result = make_result(key, args.n_inner, args.n_tread)
            storage.write_experiment(store, args.group, e, result, make_info(key))
            if args.ready and not args.ready.exists():
                args.ready.touch()
    print("wrote", len(args.ids), flush=True)


if __name__ == "__main__":
    main()
