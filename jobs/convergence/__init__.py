"""The mesh-convergence study of the full model (issue 24, docs/mesh-convergence.md).

:mod:`~jobs.convergence.levels` names the refinement levels and load cases,
:mod:`~jobs.convergence.run` solves every (level, case) on a Dask cluster and measures
it, :mod:`~jobs.convergence.table` compares the levels (Richardson extrapolation) and
writes the tables.
"""
