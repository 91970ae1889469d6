"""Held-out splits and folds that never split a load path (issue 45).

A rolling study keeps every state along a roll as an experiment of its own (``[loads.roll]
states``; its ``travel`` parameter says how far the road had gone). Neighbouring states of
one roll are nearly the same tyre: a model tested on one of them after training on its
neighbour is tested on what it has seen. So the states of one roll form one *group*,
and a held-out set or a CV fold takes a roll whole or not at all (grouped splits, as
scikit-learn's ``GroupKFold``). Experiments of other groups (standing, sliding, rolls
that keep their end alone) are each a group of their own, and for them every split
here is the ungrouped split of before, to the index.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from sklearn.model_selection import GroupKFold, KFold

import storage
from analysis.errors import ParameterError

#: The parameter that tells the states of one roll apart: the rest of the load case
#: is the roll's own (jobs.expand.parameters)
TRAVEL = "travel"
#: A rolling tree's parameter (issue 45): how far its branches rolled straight, on the
#: trunk, before their slips applied. Every state of a tree shares the trunk's history,
#: and a branch's first states are nearly the trunk's last, so a tree is one group:
#: its slips and ``roll_from`` tell its branches apart, as ``travel`` tells states apart.
ROLL_FROM = "roll_from"
TREE_PARAMETERS = (ROLL_FROM, "slip_ratio", "slip_angle")


def path_groups(ds: xr.Dataset, *, trees: bool = True) -> np.ndarray:
    """Group label of each experiment, (K,) int: experiments whose load cases differ in
    ``travel`` alone are states of one roll and share a label; in a store of rolling
    trees (a ``roll_from`` parameter), those that differ in travel, slips and
    ``roll_from`` alone are one tree's and share one (``trees=False``: each trunk and
    each branch a group of its own); any other experiment has a label of its own.
    Labels number the groups in order of first appearance."""
    K = ds.sizes["experiment"]
    if TRAVEL not in ds.variables or K == 0:
        return np.arange(K)
    within = ((TRAVEL, *TREE_PARAMETERS) if trees and ROLL_FROM in ds.variables
              else (TRAVEL,))
    # the store marks its parameters; an in-memory dataset: its other per-experiment
    # coordinates
    names = [n for n in storage.parameters(ds) if n not in within] or [
        str(n) for n, c in ds.coords.items() if c.dims == ("experiment",)
        and n not in (*within, "experiment")]
    cases = np.column_stack([np.round(np.asarray(ds[n].values, dtype=float), 9)
                             for n in names])
    _, first, labels = np.unique(cases, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))  # relabel by first appearance
    return order[labels.ravel()]


def path_progress(ds: xr.Dataset) -> dict[str, int] | None:
    """How far a group's load paths are (``farm sweep status``): of its ``paths`` (a
    rolling tree counts once, :func:`path_groups`), how many are ``whole`` (every state
    done), ``growing`` (some done, the rest pending), ``not_started`` (all pending) and
    ``with_failures`` (a state failed). None for a group without load paths (no
    ``travel`` parameter): each experiment is its own path there."""
    if TRAVEL not in ds.variables or ds.sizes["experiment"] == 0:
        return None
    groups = path_groups(ds)
    status = np.asarray(ds["status"].values)
    out = {"paths": 0, "whole": 0, "growing": 0, "not_started": 0, "with_failures": 0}
    for g in np.unique(groups):
        mine = status[groups == g]
        key = ("with_failures" if (mine == storage.FAILED).any() else
               "whole" if (mine == storage.DONE).all() else
               "not_started" if (mine == storage.PENDING).all() else "growing")
        out[key] += 1
        out["paths"] += 1
    return out


def grouped_split(groups: np.ndarray, test_fraction: float,
                  seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded random (train, test) positions that hold out whole groups: round(groups
    x fraction) of them (at least one, never all). With one experiment per group it is
    the experiment split of before: the same positions for the same seed.

    Parameters
    ----------
    groups : (K,) array of group labels (:func:`path_groups`).
    test_fraction : share of the groups held out, in (0, 1).
    seed : the permutation's seed.

    Returns
    -------
    train, test : sorted int arrays of positions, together 0 .. K - 1.
    """
    if not 0.0 < test_fraction < 1.0:
        raise ParameterError(f"test fraction must be in (0, 1), got {test_fraction!r}")
    groups = np.asarray(groups)
    labels = np.unique(groups)
    n = labels.size
    if n < 2:
        raise ParameterError(f"a held-out split needs at least two load paths, the "
                             f"selection has {n}: run more load cases")
    perm = np.random.default_rng(seed).permutation(n)
    n_test = min(max(1, round(n * test_fraction)), n - 1)
    held = np.isin(groups, labels[perm[:n_test]])
    return np.flatnonzero(~held), np.flatnonzero(held)


def split(ds: xr.Dataset, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded random (train, test) positions of ``ds``'s experiments that hold out whole
    load paths (:func:`grouped_split`: the states of one roll together;
    every other experiment alone, as before): round(paths x fraction) >= 1 of them."""
    return grouped_split(path_groups(ds), test_fraction, seed)


def folds(groups: np.ndarray, n_folds: int, seed: int | None) -> list[tuple[np.ndarray,
                                                                            np.ndarray]]:
    """``n_folds`` (train, test) CV folds that keep each group whole: shuffled
    ``KFold`` (the folds of before) where every group is one experiment, ``GroupKFold``
    otherwise."""
    groups = np.asarray(groups)
    dummy = np.zeros(groups.size)
    if np.unique(groups).size == groups.size:
        return list(KFold(n_folds, shuffle=seed is not None, random_state=seed).split(dummy))
    if np.unique(groups).size < n_folds:
        raise ParameterError(f"{n_folds} CV folds need at least {n_folds} load paths, the "
                             f"training part has {np.unique(groups).size}: lower --folds "
                             "or run more load cases")
    return list(GroupKFold(n_folds).split(dummy, groups=groups))


def edge_split(ds: xr.Dataset, parameters: list[str], fraction: float,
               ) -> tuple[np.ndarray, np.ndarray]:
    """(train, test) positions that hold out the design's edges (issue 46): a load path
    is at an edge when any of ``parameters`` lies within the outer ``fraction`` of that
    parameter's range (at its lowest or highest end); the model trains on the interior.
    ``travel`` never counts (a roll's states are one path). In a store of rolling trees
    the path is the roll - a trunk, or a branch - not the tree: every tree of a nested
    design has branches at the slips' edges, so holding out trees would leave no interior;
    a branch at an edge is held out whole while its trunk's states, the straight roll it
    left (interior where the trunk's own parameters are), stay in training.

    Raises :class:`ParameterError` when the edges or the interior are empty.
    """
    if not 0.0 < fraction < 0.5:
        raise ParameterError(f"the edge fraction must be in (0, 0.5), got {fraction!r}")
    groups = path_groups(ds, trees=False)
    edge = np.zeros(ds.sizes["experiment"], dtype=bool)
    for name in (p for p in parameters if p != TRAVEL):
        v = np.asarray(ds[name].values, dtype=float)
        low, high = np.nanmin(v), np.nanmax(v)
        margin = fraction * (high - low)
        edge |= (v <= low + margin) | (v >= high - margin)
    edge = np.isin(groups, groups[edge])  # a path at an edge is held out whole
    if edge.all() or not edge.any():
        raise ParameterError(
            f"holding out the outer {fraction:g} of the ranges of {', '.join(parameters)} "
            f"leaves {'no interior to train on' if edge.all() else 'no edge case'}: give "
            "another --edges fraction")
    return np.flatnonzero(~edge), np.flatnonzero(edge)
