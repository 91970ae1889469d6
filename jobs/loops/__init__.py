"""Optimisation loops on the farm: the machinery the inverse and calibration loops share.

Loop drivers run on the client (one thread per loop); every solver evaluation is one
Dask task keyed by the content hash of what it solves, so identical evaluations, in one
loop or across loops, are solved once, and tasks never wait on tasks: however many loops
share however few workers, nothing deadlocks (docs/architecture.md, "Jobs on Dask").

- :mod:`jobs.loops.cache` keeps every finished evaluation on disk, keyed by its hash;
  a loop resumed after the client died replays its evaluations from there without ccx.
- :mod:`jobs.loops.evaluator` deduplicates, submits and counts evaluations.
- :mod:`jobs.loops.optimizers`: Nelder-Mead, and least squares with a finite-difference
  Jacobian whose columns are solved side by side on the workers.
- :mod:`jobs.loops.secant`: least squares that reuses Jacobians (Broyden updates
  between full ones); :mod:`jobs.loops.jacobians`: full Jacobians shared by loops.
- the worker side (retry policy, typed results) is :mod:`jobs.guard`, shared with sweeps.
"""
