"""``python -m cli``: the ``farm`` command."""

from cli import main

if __name__ == "__main__":  # guarded: Dask's spawned worker processes re-import this module
    main()
