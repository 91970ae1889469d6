"""``python -m farm``: the ``farm`` command, for machines where the console script is not
on ``PATH`` (a bare ``pip install --user``, a cluster node's module environment).

The command lives in :mod:`tyre_farm_cli` (named so it cannot collide with another
distribution's top-level ``cli``); this entry point is the one arrow from ``farm`` up to
it, and it is taken only when run as a program (tests/test_layering.py exempts it).
"""

if __name__ == "__main__":  # guarded: Dask's spawned worker processes re-import this module
    from tyre_farm_cli import main

    main()
