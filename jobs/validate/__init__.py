"""Validation of user input, one rule per kind of value, shared by every study kind.

Sweeps (:mod:`jobs.study`), inverse studies (:mod:`jobs.inverse.study`), model-space
designs (:mod:`jobs.design`) and the command line (:mod:`tyre_farm_cli`) check their
input with these modules, so a range, a model table or a solver table means the same
wherever it is written. Import the module you need; this package re-exports nothing.

- :mod:`~jobs.validate.messages`: the one error line, ``<key path>: <what is wrong>``.
- :mod:`~jobs.validate.limits`: practical limits (``MAX_*``, :class:`Limit`), docs/limits.md.
- :mod:`~jobs.validate.reading`: study files and tables read safely (regular, 1 MiB, UTF-8).
- :mod:`~jobs.validate.scalars`: tables and their keys, numbers, integers, switches, names.
- :mod:`~jobs.validate.lists`: a number, a list or a ``{start, stop, step}`` range.
- :mod:`~jobs.validate.spec_tables`: ``[model]`` (merged by :mod:`farm.overrides`) and
  ``[solver]``.
- :mod:`~jobs.validate.locations`: store and cache paths and URLs, fsspec options.
- :mod:`~jobs.validate.addresses`: Dask scheduler addresses.

Checks of what only the command line takes (output files and folders, ``--workers``) are
:mod:`tyre_farm_cli.checks`'; its ``10:40:5`` ranges are :mod:`tyre_farm_cli.params`'.

Why not pydantic. Pydantic v2 (``extra="forbid"``, a JSON Schema for editors) was
considered and not adopted, because it would add code rather than delete it. It would
replace the primitive checks of :mod:`~jobs.validate.scalars` (about 65 lines) with
about 14 model classes for the two study kinds (about 90 lines with their field
constraints) plus a formatter (about 20 lines) that turns its multi-line
``ValidationError`` into the one-line, key-naming message the CLI prints. Nothing else
goes: the three forms of a value list and the range rule need a custom validator; the
preset-plus-overrides merge onto ``ModelSpec`` (a frozen dataclass of ``farm``, which
must not depend on pydantic) stays; so do the cross-field rules (sampled and listed
loads, an inflated model needs a pressure, least squares needs ``per_solve``, distinct
condition names, deflections the tyre can take, paths relative to the study). That is
about 45 more lines and a new hard dependency of every worker; the editor schema, the
one real gain, can be written by hand for the two tables if it is ever wanted.
"""
