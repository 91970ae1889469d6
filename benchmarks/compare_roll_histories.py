"""Two stores of the same rolling design, side by side: what a change of load history
(or of anything else that changes ids) does to the states both hold (issue 45's rule:
forces within 0.5 % of |F|, the camera field within 1 % of its RMS).

    .venv/bin/python benchmarks/compare_roll_histories.py STORE_A STORE_B [--group-a G]
        [--group-b G]

Each store's one group is read (or the one named); states are matched by friction, slip
ratio, slip angle, camber (tilt) and travel. Printed: per travel, the largest force
component's difference in % of |F| and the displacement field's RMS difference in % of
its RMS (median, max, share within the rule), over the states done in both; and per
store, its rolls whole, lost, and lost keeping nothing. Measured with it (docs/rolling.md,
"A frictionless rise"): examples/rolling_design_coarse.toml against
examples/rolling_design_coarse_rise.toml. Nothing is asserted.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import answer_rule
import numpy as np
import xarray as xr

from analysis.data import open_group, resolve_group

KEYS = ("friction", "slip_ratio", "slip_angle", "tilt", "travel")
DONE, FAILED = 1, 2


def _group(path: str, name: str | None) -> xr.Dataset:
    """The store's one group (or ``name``), through the analyses' reader."""
    return open_group(path, resolve_group(path, name))


def _index(g: xr.Dataset) -> dict[tuple[float, ...], int]:
    """(friction, slip ratio, slip angle, tilt, travel) -> row."""
    keys = np.round(np.stack([g[k].values for k in KEYS], axis=1), 6)
    return {tuple(map(float, k)): i for i, k in enumerate(keys)}


def differences(a: xr.Dataset, b: xr.Dataset) -> dict[float, list[tuple[float, float]]]:
    """Per travel, (force %, field %) of each state done in both."""
    sa, sb = a["status"].values, b["status"].values
    ib = _index(b)
    out: dict[float, list[tuple[float, float]]] = defaultdict(list)
    for key, i in _index(a).items():
        j = ib.get(key)
        if j is None or sa[i] != DONE or sb[j] != DONE:
            continue
        fa, fb = (g["road_reaction"][k].values for g, k in ((a, i), (b, j)))
        da, db = (g["displacement"][k].values for g, k in ((a, i), (b, j)))
        out[key[-1]].append(answer_rule.differences(fa, fb, da, db))
    return out


def rolls(g: xr.Dataset) -> tuple[int, int, int, int]:
    """(rolls, whole, lost, lost keeping nothing) of a store's group."""
    status = g["status"].values
    per: dict[tuple[float, ...], list[int]] = defaultdict(list)
    for key, i in _index(g).items():
        per[key[:-1]].append(int(status[i]))
    whole = sum(all(s == DONE for s in v) for v in per.values())
    lost = sum(any(s == FAILED for s in v) for v in per.values())
    nothing = sum(all(s == FAILED for s in v) for v in per.values())
    return len(per), whole, lost, nothing


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("store_a")
    p.add_argument("store_b")
    p.add_argument("--group-a")
    p.add_argument("--group-b")
    a = p.parse_args()
    ga, gb = _group(a.store_a, a.group_a), _group(a.store_b, a.group_b)
    diffs = differences(ga, gb)
    print(f"{sum(map(len, diffs.values()))} states done in both")
    for travel in sorted(diffs):
        f, d = np.array(diffs[travel]).T
        print(f"travel {travel:6.1f} mm: {len(f):3d} states; force median {np.median(f):.2f} %"
              f" max {f.max():.2f} %, within 0.5 %: {np.mean(f <= 0.5):.0%}; field median "
              f"{np.median(d):.2f} % max {d.max():.2f} %, within 1 %: {np.mean(d <= 1):.0%}")
    for name, g in (("A", ga), ("B", gb)):
        n, whole, lost, nothing = rolls(g)
        print(f"{name}: {n} rolls, {whole} whole, {lost} lost ({nothing} keeping nothing)")


if __name__ == "__main__":
    main()
