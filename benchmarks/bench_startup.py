"""Benchmark of the CLI's start-up: wall seconds of ``farm --help`` and friends.

Run ``.venv/bin/python benchmarks/bench_startup.py [--repeat N]``. Not a test: it prints
the median wall time of each command over ``N`` fresh processes, beside a bare Python
start and an ``import typer`` measured in the same run, and the ratio to issue 25's
target (``farm --help`` under 1 s on an idle machine). Fresh processes on purpose: a
user pays the imports every time.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import time

TARGET_S = 1.0


def _wall(argv: list[str], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=7, help="processes per command")
    args = parser.parse_args()
    farm = shutil.which("farm") or f"{sys.executable} -m farm"
    cases = {
        "python -c pass (baseline)": [sys.executable, "-c", "pass"],
        "python -c 'import typer'": [sys.executable, "-c", "import typer"],
        "farm --help": [*farm.split(), "--help"],
        "farm sweep --help": [*farm.split(), "sweep", "--help"],
        "farm run --help": [*farm.split(), "run", "--help"],
        "farm --version": [*farm.split(), "--version"],
    }
    print(f"median wall seconds over {args.repeat} fresh processes each")
    results = {name: _wall(argv, args.repeat) for name, argv in cases.items()}
    base = results["python -c pass (baseline)"]
    for name, seconds in results.items():
        print(f"  {name:32s} {seconds:6.3f} s   {seconds / base:5.1f}x the bare interpreter")
    help_s = results["farm --help"]
    print(f"farm --help: {help_s:.3f} s, target < {TARGET_S:g} s: "
          f"{'met' if help_s < TARGET_S else 'NOT met'} ({help_s / TARGET_S:.2f} of the target)")


if __name__ == "__main__":
    main()
