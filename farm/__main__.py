"""``python -m farm``: the ``farm`` command."""

from farm.cli import main

if __name__ == "__main__":  # guarded: Dask's spawned worker processes re-import this module
    main()
