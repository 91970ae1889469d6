"""The queue: study specs, their expansion into experiments, and sweeps on Dask.

Wires :mod:`farm` (the physics) to :mod:`storage` (the Zarr store): the client expands a
study, reserves room in the store and submits one task per load path; workers solve
and write their own experiments; finished experiments are skipped on resubmission.
"""
