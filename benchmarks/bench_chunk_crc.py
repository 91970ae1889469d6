"""The cost of each worker chunk's CRC32C (issue 50), side by side in one run.

Run ``.venv/bin/python benchmarks/bench_chunk_crc.py [--experiments N] [--repeat R]``.
Two copies of one ``displacement`` array (N experiments x 920 inner nodes x 3, float64,
one experiment per chunk, as :func:`storage.group.create_array` lays out a worker
variable): raw chunks, as groups made before issue 50 hold them, and chunks ending in
their CRC32C, as groups made since. Reads of the whole array alternate between the two;
prints MB/s of each and the median time ratio (CRC / raw). Not a test.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import zarr
from zarr.codecs import Crc32cCodec


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--experiments", type=int, default=3000)
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    x = np.random.default_rng(0).normal(size=(args.experiments, 920, 3))
    layouts = {"raw": None, "crc32c": (Crc32cCodec(),)}
    seconds: dict[str, list[float]] = {name: [] for name in layouts}
    with tempfile.TemporaryDirectory() as tmp:
        for name, codecs in layouts.items():
            a = zarr.create_array(Path(tmp) / name, shape=x.shape, chunks=(1, 920, 3),
                                  dtype="f8", compressors=codecs)
            a[:] = x
        for _ in range(args.repeat):
            for name in layouts:
                a = zarr.open_array(Path(tmp) / name, mode="r")
                start = time.perf_counter()
                a[:]
                seconds[name].append(time.perf_counter() - start)
    mb = x.nbytes / 1e6
    for name, times in seconds.items():
        print(f"{name:7s} read {mb:.0f} MB: median {mb / statistics.median(times):.0f} MB/s "
              f"(best {mb / min(times):.0f})")
    ratio = statistics.median(seconds["crc32c"]) / statistics.median(seconds["raw"])
    print(f"read time crc32c / raw: {ratio:.2f}x")


if __name__ == "__main__":
    main()
